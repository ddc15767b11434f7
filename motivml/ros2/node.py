"""The `motivml` ROS 2 node: a running robot's features as parameters, its health on the graph.

`motivml run ROBOT --variant V --ros2 [--ros-namespace NS]` starts, beside the loop, a node
`NS/motivml` that is a second front door of the same binder as `motivml ctl`:

* a boolean parameter `features.<id>.active` per selected feature, equal to its membership of
  the active set; read-only for Static Early features (compiled in, always active);
* one `set_parameters` or `set_parameters_atomically` call on them is one reconfiguration
  (`true` loads, `false` unloads), checked on the one encoding like any other request. A
  refusal answers `successful: false` with `validate`'s words in `reason`, and changes
  nothing. An acceptance is committed between two ticks before the call returns, and the
  parameters of every feature that moved with it (a subtree unloaded, mandatory
  sub-features loaded) are updated in the same parameter event. (ROS's own
  `set_parameters` sets each parameter on its own; here a call is one change of features,
  so every result of the call is the same.) A call that changes `features.*` changes nothing
  else;
* the active set on `~/active_features` (`std_msgs/String`, JSON, transient-local: a late
  subscriber gets the current set) at start and after every commit, whoever asked for it
  (`ctl`, a fault's unload, this node);
* every accepted and refused change in the node's log (rosout);
* the loop's health on `/diagnostics` once a second: rate, missed deadlines (WARN when more
  than 1% of the last second's were missed), faults, and one status per selected feature.

Everything that changes the node's parameters runs in one mutually exclusive callback group
(the parameter services and the binder's news), so the parameters always follow the active
set, one change after the other. `ros2 param set`, rqt's parameter editor and any rclpy
client speak these same standard services.
"""

from __future__ import annotations

import json
import queue
from typing import Any

from ..errors import describe_exception
from ..plugins.ros2 import Graph, import_rclpy, open_graph, release_graph
from ..runtime.binder import Outcome
from ..runtime.launch import Robot
from ..runtime.requests import Request

DIAGNOSTICS_PERIOD = 1.0  # s
MISSED_WARNING = 0.01  # the loop's status is WARN when more than this share of its deadlines were missed
PREFIX = "features."
SUFFIX = ".active"


def parameter_name(feature: str) -> str:
    return f"{PREFIX}{feature}{SUFFIX}"


class FrontDoor:
    """The robot's `motivml` node, on the graph of its namespace."""

    def __init__(self, robot: Robot, ns: str, timeout: float = 5.0) -> None:
        import_rclpy()
        from diagnostic_msgs.msg import DiagnosticArray
        from rcl_interfaces.msg import ParameterDescriptor, ParameterType
        from rclpy.node import Node
        from rclpy.parameter_service import ParameterService
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import String

        self.robot = robot
        self.binder = robot.binder
        self.runtime = robot.runtime
        self.timeout = timeout
        model = robot.variant.model
        # every selected feature but the root (always there, nothing to switch)
        self.selected = [d for d in robot.variant.decisions if d.selected and d.feature.parent is not None]
        self.features = {parameter_name(d.feature.id): d.feature.id for d in self.selected}
        self.compiled_in = {d.feature.id for d in self.selected if d.binding.static and d.binding.early}
        self.order = model.index
        self.graph: Graph = open_graph(ns)
        self._news: queue.SimpleQueue[Outcome] = queue.SimpleQueue()
        self._internal = False  # parameters being brought in line with the active set
        self._published: frozenset[str] | None = None
        self._ticks = (0, 0.0)
        self._missed = 0
        self._closed = False
        try:
            door = self

            class FeatureParameters(ParameterService):  # type: ignore[misc]
                """The standard parameter services, with one call = one reconfiguration."""

                def _set_parameters_callback(self, request: Any, response: Any) -> Any:
                    results = door.set_call(request.parameters)
                    if results is None:
                        return super()._set_parameters_callback(request, response)
                    response.results = [results] * len(request.parameters)
                    return response

                def _set_parameters_atomically_callback(self, request: Any, response: Any) -> Any:
                    result = door.set_call(request.parameters)
                    if result is None:
                        return super()._set_parameters_atomically_callback(request, response)
                    response.result = result
                    return response

            self.node = Node(
                "motivml",
                namespace=ns,
                context=self.graph.context,
                start_parameter_services=False,
            )
            self.log = self.node.get_logger()
            active = self.binder.active
            for d in self.selected:
                read_only = d.feature.id in self.compiled_in
                self.node.declare_parameter(
                    parameter_name(d.feature.id),
                    d.feature.id in active,
                    ParameterDescriptor(
                        type=ParameterType.PARAMETER_BOOL,
                        description=f"{d.feature.id} is active ({d.binding.words})"
                        + (": compiled in, always" if read_only else ""),
                        read_only=read_only,
                    ),
                )
            self.node.add_on_set_parameters_callback(self._on_set)
            self.services = FeatureParameters(self.node)
            latched = QoSProfile(
                depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
            )
            self._active_topic = self.node.create_publisher(String, "~/active_features", latched)
            self._diagnostics = self.node.create_publisher(DiagnosticArray, "/diagnostics", 10)
            self._string = String
            self._guard = self.node.create_guard_condition(self._catch_up)
            self._timer = self.node.create_timer(DIAGNOSTICS_PERIOD, self._publish_diagnostics)
            self.binder.watchers.append(self._heard)
            self.graph.spin(self.node)
            self._publish_active("start")
        except BaseException:
            release_graph(self.graph)
            raise

    # ------------------------------------------------------------ parameters
    def _on_set(self, parameters: list[Any]) -> Any:
        """Direct sets of features.* (not through the services) are refused: they would skip the check."""
        from rcl_interfaces.msg import SetParametersResult

        if self._internal or not any(p.name in self.features for p in parameters):
            return SetParametersResult(successful=True)
        return SetParametersResult(
            successful=False, reason="features.* change through the set_parameters services, one call a change"
        )

    def set_call(self, messages: list[Any]) -> Any | None:
        """One set_parameters(_atomically) call: its result, or None when it names no feature.

        Whatever goes wrong inside answers the call (successful: false), never the executor."""
        from rcl_interfaces.msg import SetParametersResult

        try:
            return self._set_call(messages)
        except Exception as exc:
            reason = f"motivml could not handle the call: {describe_exception(exc)}"
            self.log.error(reason)
            return SetParametersResult(successful=False, reason=reason)

    def _set_call(self, messages: list[Any]) -> Any | None:
        from rcl_interfaces.msg import ParameterType, SetParametersResult

        names = [m.name for m in messages]
        if not any(n in self.features or n.startswith(PREFIX) for n in names):
            return None

        def refuse(reason: str) -> Any:
            self.log.warning(f"refused {', '.join(names)}: {reason}")
            return SetParametersResult(successful=False, reason=reason)

        others = [n for n in names if n not in self.features]
        if others:
            unknown = [n for n in others if n.startswith(PREFIX)]
            if unknown:
                return refuse(
                    f"{unknown[0]}: no such parameter: the variant {self.robot.variant.name} selects no feature "
                    f"{unknown[0][len(PREFIX) :].removesuffix(SUFFIX)!r} (features.<id>.active exist for its selected features)"
                )
            return refuse(f"a call that changes features.* changes nothing else ({', '.join(others)})")
        active = self.binder.active
        for message in messages:
            if message.value.type != ParameterType.PARAMETER_BOOL:
                return refuse(f"{message.name} takes true or false")
        wanted = {self.features[m.name]: bool(m.value.bool_value) for m in messages}
        loads = [f for f, on in wanted.items() if on and f not in active]
        unloads = [f for f, on in wanted.items() if not on and f in active]
        request = Request.set(loads, unloads)
        if not loads and not unloads:
            return SetParametersResult(successful=True)  # every value as it is: nothing to change
        outcome = self.binder.request(request, timeout=self.timeout)
        if not outcome.accepted:
            return SetParametersResult(successful=False, reason=outcome.reason)
        self._align_parameters()  # before the answer; the log and the topic follow it (_catch_up)
        return SetParametersResult(successful=True)

    # ---------------------------------------------------------- the binder's news
    def _heard(self, outcome: Outcome) -> None:
        """On the requesting thread, with the binder held: queue it, wake the node."""
        if not self._closed:
            self._news.put(outcome)
            self._guard.trigger()

    def _catch_up(self) -> None:
        """In the node's group: log what happened, bring the parameters and the topic in line."""
        while not self._news.empty():
            outcome = self._news.get()
            if outcome.accepted:
                plan = outcome.plan
                moved = ""
                if plan is not None:
                    moved = "; ".join(
                        part
                        for part in (
                            f"loaded {', '.join(plan.loads)}" if plan.loads else "",
                            f"unloaded {', '.join(plan.unloads)}" if plan.unloads else "",
                        )
                        if part
                    )
                self.log.info(f"accepted {outcome.request}: {moved}")
            else:
                self.log.warning(f"refused {outcome.request}: {outcome.reason}")
        self._align_parameters()
        if self.binder.active != self._published:
            self._publish_active("change")

    def _align_parameters(self) -> None:
        """Every features.<id>.active equal to the active set, in one parameter event."""
        from rclpy.parameter import Parameter

        active = self.binder.active
        stale = [
            Parameter(name, Parameter.Type.BOOL, feature in active)
            for name, feature in self.features.items()
            if feature not in self.compiled_in and self.node.get_parameter(name).value != (feature in active)
        ]
        if stale:
            self._internal = True
            try:
                self.node.set_parameters_atomically(stale)
            finally:
                self._internal = False

    def _publish_active(self, why: str) -> None:
        active = self.binder.active
        self._published = active
        change = self.runtime.changes[-1] if self.runtime.changes and why == "change" else None
        message = {
            "active": sorted(active, key=self.order.__getitem__),
            "tick": change.tick if change else self.runtime.ticks,
            "request": change.request if change else None,
        }
        self._active_topic.publish(self._string(data=json.dumps(message)))

    # ------------------------------------------------------------ diagnostics
    def _publish_diagnostics(self) -> None:
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

        runtime = self.runtime
        now = self.node.get_clock().now()
        ticks, seconds = runtime.ticks, now.nanoseconds * 1e-9
        before, then = self._ticks
        achieved = (ticks - before) / (seconds - then) if then and seconds > then else 0.0
        self._ticks = (ticks, seconds)
        missed_now = runtime.missed - self._missed
        self._missed = runtime.missed
        robot = self.robot.folder.name
        level, message = DiagnosticStatus.OK, "running"
        if runtime.failure is not None:
            level, message = DiagnosticStatus.ERROR, f"stopped by the fault of {runtime.failure.feature}"
        elif missed_now > MISSED_WARNING * runtime.rate * DIAGNOSTICS_PERIOD:
            level, message = DiagnosticStatus.WARN, f"{missed_now} deadlines missed in the last second"
        elif missed_now:
            message = f"running ({missed_now} deadlines missed in the last second)"
        loop = DiagnosticStatus(
            level=level,
            name=f"motivml: {robot} loop",
            message=message,
            hardware_id=self.node.get_fully_qualified_name(),
            values=[
                KeyValue(key="rate", value=f"{runtime.rate:g}"),
                KeyValue(key="achieved rate", value=f"{achieved:.1f}"),
                KeyValue(key="ticks", value=str(ticks)),
                KeyValue(key="missed deadlines", value=str(runtime.missed)),
                KeyValue(key="faults", value=str(len(runtime.faults))),
                KeyValue(key="active features", value=str(len(self.binder.active))),
            ],
        )
        statuses = [loop]
        faulted = {f.feature: f.error for f in runtime.faults}
        plugins = dict(runtime.plugins)
        active = self.binder.active
        for d in self.selected:
            feature = d.feature.id
            running = plugins.get(feature)
            level, state = DiagnosticStatus.OK, "active" if feature in active else "inactive"
            if running is not None and running.faulted:
                level, state = DiagnosticStatus.ERROR, f"faulted: {faulted.get(feature, '')}"
            elif feature in faulted and feature not in active:
                level, state = DiagnosticStatus.WARN, f"unloaded after a fault: {faulted[feature]}"
            values = [KeyValue(key="binding", value=d.binding.words)]
            if running is not None:
                try:
                    values.append(KeyValue(key="status", value=str(running.instance.status())[:200]))
                except BaseException as exc:  # plugin code: a report never fails because of it
                    values.append(KeyValue(key="status", value=f"status() raised {type(exc).__name__}"))
            statuses.append(
                DiagnosticStatus(
                    level=level,
                    name=f"motivml: {robot} feature {feature}",
                    message=state,
                    hardware_id=self.node.get_fully_qualified_name(),
                    values=values,
                )
            )
        array = DiagnosticArray(status=statuses)
        array.header.stamp = now.to_msg()
        self._diagnostics.publish(array)

    # --------------------------------------------------------------- closing
    def close(self) -> None:
        """Leave the graph (before the robot's plugins stop)."""
        if self._closed:
            return
        self._closed = True
        if self._heard in self.binder.watchers:
            self.binder.watchers.remove(self._heard)
        self.graph.forget(self.node)
        release_graph(self.graph)


def start(robot: Robot, ns: str) -> FrontDoor:
    """The robot's `motivml` node, spinning on a thread of its own."""
    return FrontDoor(robot, ns)


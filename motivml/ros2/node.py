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
  (`ctl`, a fault's unload, this node), with the robot's and the variant's names and the
  variant's digest (what `motivml fleet list` shows of each robot, and how `fleet plan`
  tells a robot that runs its variant without its fleet's layers);
* every accepted and refused change in the node's log (rosout);
* the loop's health on `/diagnostics` once a second: rate, missed deadlines (WARN when more
  than 1% of the last second's were missed), faults, and one status per selected feature.

The node lives in the run's ROS 2 bridge process (`motivml.plugins.bridge`), which holds
rclpy; the run's side of it is `motivml.ros2.door`. A call on the parameter services goes
over the bridge's link to the binder; the binder's news (every outcome, from any front
door) and the loop's health come back the same way. Everything that changes the node's
parameters runs in one mutually exclusive callback group (the parameter services and the
binder's news), so the parameters always follow the active set, one change after the
other; the news goes into the log and onto the topic there too, after the answer to the call
in hand. `ros2 param set`, rqt's parameter editor and any rclpy client speak these same
standard services.
"""

from __future__ import annotations

import json
from collections import deque
from typing import Any

from ..errors import describe_exception
from ..plugins.bridge import Link, LinkBroken
from .graph import Graph

PREFIX = "features."
SUFFIX = ".active"
# diagnostic_msgs/DiagnosticStatus levels, as the message's `byte` field holds them: given a
# plain int, these wheels published garbage (OK arrived as b'a', WARN as b'\xca')
LEVELS = {"OK": b"\x00", "WARN": b"\x01", "ERROR": b"\x02"}


def parameter_name(feature: str) -> str:
    return f"{PREFIX}{feature}{SUFFIX}"


class FrontDoor:
    """The robot's `motivml` node, in the bridge, on the graph of its namespace.

    `robot` describes what the node shows (the run's door sends it): the robot's and the
    variant's names, the selected features but the root (`id`, `words` for their binding,
    `read_only` for the compiled-in ones) in the model's order, the active set, the tick.
    """

    def __init__(self, graph: Graph, link: Link, robot: dict[str, Any]) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from rcl_interfaces.msg import ParameterDescriptor, ParameterType
        from rclpy.node import Node
        from rclpy.parameter_service import ParameterService
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import String

        self.graph = graph
        self.link = link
        self.robot = str(robot["robot"])
        self.variant = str(robot["variant"])
        self.configuration = str(robot.get("configuration", ""))  # the variant's digest
        self.timeout = float(robot["timeout"])
        self.features = {parameter_name(f["id"]): str(f["id"]) for f in robot["features"]}
        self.compiled_in = {str(f["id"]) for f in robot["features"] if f["read_only"]}
        self.active = frozenset(robot["active"])
        self._internal = False  # parameters being brought in line with the active set
        self._news: deque[dict[str, Any]] = deque()  # the binder's outcomes, for `_catch_up`
        self._shown = 0  # the number of the outcome the parameters show (`told`, see the run's door)
        self._closed = False
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

        self.node = Node("motivml", namespace=graph.namespace, context=graph.context, start_parameter_services=False)
        try:
            self.log = self.node.get_logger()
            for feature in robot["features"]:
                read_only = bool(feature["read_only"])
                self.node.declare_parameter(
                    parameter_name(feature["id"]),
                    feature["id"] in self.active,
                    ParameterDescriptor(
                        type=ParameterType.PARAMETER_BOOL,
                        description=f"{feature['id']} is active ({feature['words']})"
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
            graph.spin(self.node)
            self._publish_active(robot["active"], int(robot["tick"]), None)
        except BaseException:
            self.node.destroy_node()
            raise
        self.name = self.node.get_fully_qualified_name()

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
                    f"{unknown[0]}: no such parameter: the variant {self.variant} selects no feature "
                    f"{unknown[0][len(PREFIX) :].removesuffix(SUFFIX)!r} (features.<id>.active exist for its selected features)"
                )
            return refuse(f"a call that changes features.* changes nothing else ({', '.join(others)})")
        wanted: dict[str, bool] = {}
        for message in messages:
            if message.value.type != ParameterType.PARAMETER_BOOL:
                return refuse(f"{message.name} takes true or false")
            feature, value = self.features[message.name], bool(message.value.bool_value)
            if wanted.get(feature, value) != value:  # (the last one won: both entries answered success)
                return refuse(f"{message.name} is set to true and to false in one call: nothing changed")
            wanted[feature] = value
        try:
            # The run waits up to the timeout for the commit; the margin is the link's.
            answer = self.link.call("set", self.timeout + 5.0, wanted=wanted)
        except LinkBroken:
            return SetParametersResult(successful=False, reason="the robot's run has ended: nothing changed")
        if "error" in answer:  # the run's side met something it did not expect
            self.log.error(answer["error"])
            return SetParametersResult(successful=False, reason=answer["error"])
        if not answer["accepted"]:
            return SetParametersResult(successful=False, reason=answer["reason"])
        self._show(int(answer["told"]), answer["active"])
        self._align_parameters()  # before the answer; the log and the topic follow it (`_catch_up`)
        return SetParametersResult(successful=True)

    # ---------------------------------------------------------- the binder's news
    def heard(self, outcome: dict[str, Any]) -> None:
        """On the link's thread: an outcome of the binder (any front door's), queued for the
        node's thread (`_catch_up`). There it comes after the answer to the call in hand: the
        outcome of that call arrives just before its answer, and its log line and message,
        written here at once, delayed the answer by 0.5-1 ms on a busy 2-core machine."""
        if self._closed:
            return
        self._news.append(outcome)
        self._guard.trigger()

    def _catch_up(self) -> None:
        """In the node's group, between two calls: the binder's news in the log and on the
        topic, in the order it came, then the parameters in line with the active set (a
        change that came through this node's services is in line already)."""
        self._write_news(show=True)
        self._align_parameters()

    def _write_news(self, show: bool) -> None:
        """The queued outcomes in the log and on the topic; with `show`, the active set of the
        newest accepted one, unless a set call's answer has shown a later state already (its
        outcome may still be queued behind an older one, news that came on another thread)."""
        while self._news:
            outcome = self._news.popleft()
            if not outcome["accepted"]:
                self.log.warning(f"refused {outcome['request']}: {outcome['reason']}")
                continue
            if show:
                self._show(int(outcome["told"]), outcome["active"])
            moved = "; ".join(
                part
                for part in (
                    f"loaded {', '.join(outcome['loads'])}" if outcome["loads"] else "",
                    f"unloaded {', '.join(outcome['unloads'])}" if outcome["unloads"] else "",
                )
                if part
            )
            self.log.info(f"accepted {outcome['request']}: {moved}")
            self._publish_active(outcome["active"], outcome["tick"], outcome["change"])

    def _show(self, told: int, active: list[str]) -> None:
        """The active set after the binder's outcome number `told`, unless a later one is shown."""
        if told >= self._shown:
            self._shown = told
            self.active = frozenset(active)

    def _align_parameters(self) -> None:
        """Every features.<id>.active equal to the active set, in one parameter event."""
        from rclpy.parameter import Parameter

        active = self.active
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

    def _publish_active(self, active: list[str], tick: int, request: str | None) -> None:
        message = {
            "robot": self.robot,
            "variant": self.variant,
            "configuration": self.configuration,
            "active": active,
            "tick": tick,
            "request": request,
        }
        self._active_topic.publish(self._string(data=json.dumps(message)))

    # ------------------------------------------------------------ diagnostics
    def publish_health(self, health: dict[str, Any]) -> None:
        """On the link's thread, once a second: the loop's health as the run measured it."""
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

        me = self.name
        statuses = [
            DiagnosticStatus(
                level=LEVELS[status["level"]],
                name=f"motivml: {self.robot} {status['name']}",
                message=status["message"],
                hardware_id=me,
                values=[KeyValue(key=k, value=v) for k, v in status["values"]],
            )
            for status in health["statuses"]
        ]
        array = DiagnosticArray(status=statuses)
        array.header.stamp = self.node.get_clock().now().to_msg()
        self._diagnostics.publish(array)

    # --------------------------------------------------------------- closing
    def close(self) -> None:
        """Leave the graph, once the news still queued is in the log and on the topic."""
        if not self._closed:
            self.graph.stop(self.node)
            self._closed = True
            self._write_news(show=False)
            self.graph.forget(self.node)

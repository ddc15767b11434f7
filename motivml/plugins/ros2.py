"""Plugins of kind `ros2_lifecycle`: a feature is a ROS 2 lifecycle node in another process.

The manifest names the node, `{"feature": "uv_lamp_control", "kind": "ros2_lifecycle",
"entry": {"node": "lamp"}}`; a relative name is resolved against the run's ROS namespace
(`run --ros-namespace /uv` makes it `/uv/lamp`). The node may run anywhere DDS reaches.
Its feature's life is the node's lifecycle, driven through the node's standard services
(`lifecycle_msgs/srv/ChangeState`, `GetState`):

* **prepare**, off the control loop (`start`): wait for the node's services and ask it to
  configure (unconfigured -> inactive). A node that is not there within the entry's
  `timeout` (default 5 s) refuses the request;
* **switch**, when the request is about to commit (`activate`, `deactivate`): the binder
  first deactivates the nodes of the features that leave (while the arriving ones
  configure), then activates those that arrive, once configured. If one fails (a node that
  refuses to configure or activate, say), the nodes already moved are moved back and the
  request is refused, naming the node and its state; nothing is committed;
* **release**, after the commit (`stop`): the nodes that left are cleaned up (inactive ->
  unconfigured), as at the end of the run. The clean-up is sent, not waited for: the
  feature has left already, so the request returns without that round trip; the next use
  of the node, and the end of the run, wait for it.

The nodes are driven by the run's ROS 2 bridge, a process of its own that holds rclpy
(`motivml.plugins.bridge`, `motivml.ros2.lifecycle`): this module holds none of it, only a
stand-in per plugin instance whose moves are calls to the bridge. While its feature is
active a node is watched by the bridge (its state asked every 0.2 s); a node that leaves the
graph, stops answering within 0.8 s or leaves the active state on its own is *lost*, and
so is every node when the bridge itself ends. A lost instance's next `step` raises, which
makes it a fault of the feature like any plugin's: a Dynamic feature is unloaded with its
subtree, a Static one stops the run. So a dead node is noticed within about a second.
"""

from __future__ import annotations

import itertools
import re
import threading
from importlib.util import find_spec
from typing import Any

from ..documents.robot_folder import Plugin
from ..errors import Diagnostic, EnvironmentProblem, Location, error
from . import bridge as bridges
from .api import FeatureUnavailable, PluginContext
from .bridge import Bridge, LinkBroken

DEFAULT_TIMEOUT = 5.0  # s: waiting for a node's services, and for each transition
MARGIN = 5.0  # s the run waits for the bridge beyond a node's own timeout (a reload: several)
NAMESPACE = re.compile(r"^/([A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*)?$")

INSTALL_HINT = (
    "install ROS 2's Python packages: make ros2, then use .venv-ros/bin/motivml "
    "(or pip install 'motivml[ros2]')"
)


def namespace(text: str | None) -> str:
    """A ROS namespace, absolute: '' and None are '/', 'uv' is '/uv'; ValueError if not a name."""
    value = "/" + (text or "").strip("/")
    if not NAMESPACE.match(value):
        raise ValueError(
            f"{text!r} is not a ROS namespace: names of letters, digits and '_' (not first), joined by '/'"
        )
    return value


def resolve_node(name: str, ns: str) -> str:
    """The fully qualified name of a node named in a manifest."""
    if name.startswith("/"):
        return name
    return f"{ns.rstrip('/')}/{name}"


def ros2_missing() -> EnvironmentProblem | None:
    """Why this Python cannot speak ROS 2 (rclpy is not installed), or None; rclpy is looked
    for, not imported: only the bridge process imports it."""
    if find_spec("rclpy") is not None:
        return None
    return EnvironmentProblem(
        error(Location("ros2"), f"ROS 2 is not available in this Python (No module named 'rclpy'): {INSTALL_HINT}",
              "ros2.missing")
    )


class LifecyclePlugins:
    """The ros2_lifecycle plugins of one launched robot: stand-ins, and the bridge they call."""

    def __init__(self, robot: str, plugins: dict[str, Plugin], ros_namespace: str = "/") -> None:
        self.plugins = plugins
        self.namespace = ros_namespace
        self.bridge: Bridge | None = None
        self.instances: dict[int, LifecycleFeature] = {}
        self.contexts: dict[str, PluginContext] = {}  # feature -> its latest instance's context
        self._ids = itertools.count(1)
        self._lock = threading.Lock()

    def problems(self) -> list[Diagnostic]:
        """Without ROS 2 no node can be driven: say so before anything starts."""
        missing = ros2_missing()
        if missing is None:
            try:
                self._bridge()
            except EnvironmentProblem as failed:
                missing = failed
        if missing is None:
            return []
        first = min(self.plugins.values(), key=lambda p: str(p.manifest))
        return [
            error(
                Location(str(first.manifest)),
                f"{', '.join(sorted(self.plugins))}: plugins of kind ros2_lifecycle need ROS 2: "
                f"{missing.diagnostics[0].message}",
                "ros2.missing",
                first.feature,
            )
        ]

    def _bridge(self) -> Bridge:
        with self._lock:
            if self.bridge is None:
                self.bridge = bridges.open_bridge(self.namespace, bridges.BRIDGE_CPUS)
                self.bridge.on("lost", self._lost)
                self.bridge.on("log", self._log)
                self.bridge.ended.append(self._bridge_ended)
                # The bridge makes its clients of every node now: discovering a node takes
                # a moment, better spent while the run starts than in its first request.
                nodes = sorted({resolve_node(str(p.entry["node"]), self.namespace) for p in self.plugins.values()})
                self.bridge.link.send({"op": "lifecycle", "do": "know", "nodes": nodes})
            return self.bridge

    def absent(self, features: list[str]) -> dict[str, str]:
        """The features whose nodes are not on the graph, waited for together: a run of four
        missing nodes waited for each in turn, 22 s, and named the first only."""
        if not features:
            return {}
        nodes = {f: resolve_node(str(self.plugins[f].entry["node"]), self.namespace) for f in features}
        timeout = max(float(self.plugins[f].entry.get("timeout", DEFAULT_TIMEOUT)) for f in features)
        try:
            answer = self._bridge().call(
                "lifecycle", timeout + MARGIN, do="absent", nodes=sorted(set(nodes.values())), timeout=timeout
            )
        except (LinkBroken, TimeoutError):  # (each start then says what it finds)
            return {}
        gone = set(answer.get("absent", []))
        return {
            f: f"node {node} is not on the ROS graph: no {node}/change_state within {timeout:g} s"
            for f, node in nodes.items()
            if node in gone
        }

    def call(self, instance: LifecycleFeature, do: str, wait: float, **fields: Any) -> dict[str, Any]:
        """One move of `instance`'s node, made by the bridge; FeatureUnavailable if it failed."""
        try:
            answer = self._bridge().call("lifecycle", wait, do=do, instance=instance.ident, **fields)
        except (LinkBroken, TimeoutError) as exc:
            raise FeatureUnavailable(f"node {instance.node}: {exc}") from None
        if "state" in answer:
            instance.state = str(answer["state"])
            instance.epoch = int(answer["epoch"])
        if "error" in answer:
            raise FeatureUnavailable(str(answer["error"]))
        return answer

    def tell(self, instance: LifecycleFeature, do: str) -> None:
        """A move of `instance`'s node that nobody waits for (the bridge makes them in order)."""
        try:
            self._bridge().link.send(
                {"op": "lifecycle", "do": do, "instance": instance.ident, "feature": instance.feature}
            )
        except LinkBroken:
            pass  # (the bridge has gone: it cleaned up what it had activated)

    def _lost(self, message: dict[str, Any]) -> None:
        instance = self.instances.get(int(message["instance"]))
        if instance is not None and int(message["epoch"]) >= instance.epoch:
            instance.lost = str(message["why"])

    def _log(self, message: dict[str, Any]) -> None:
        context = self.contexts.get(str(message["feature"]))
        if context is not None:
            context.log(str(message["text"]))

    def _bridge_ended(self, why: str) -> None:
        for instance in list(self.instances.values()):
            if instance.active and instance.lost is None:
                instance.lost = f"node {instance.node}: {why}"

    def create(self, plugin: Plugin, context: PluginContext, fresh: bool = False) -> LifecycleFeature:
        instance = LifecycleFeature(self, next(self._ids), plugin, context, fresh)
        self.instances[instance.ident] = instance
        self.contexts[plugin.feature] = context  # its log, even once the instance has stopped
        return instance

    def discard(self, instance: Any) -> None:
        instance.stop()

    def activation(self, instance: Any) -> LifecycleFeature:
        """The node's own: configured at start(), active only from the commit on."""
        assert isinstance(instance, LifecycleFeature)
        return instance

    def close(self) -> None:
        with self._lock:
            bridge, self.bridge = self.bridge, None
        if bridge is None:
            return
        if bridge.gone is None:
            try:  # every node that left is unconfigured before the run ends
                bridge.call("lifecycle", DEFAULT_TIMEOUT + MARGIN, do="settle")
            except (LinkBroken, TimeoutError):
                pass
        bridge.ended.remove(self._bridge_ended)
        bridges.release_bridge(bridge)


class LifecycleFeature:
    """One feature's lifecycle node, as the binder and the loop see it: a stand-in."""

    def __init__(
        self, nodes: LifecyclePlugins, ident: int, plugin: Plugin, context: PluginContext, restart: bool
    ) -> None:
        self.nodes = nodes
        self.ident = ident
        self.feature = plugin.feature
        self.node = resolve_node(str(plugin.entry["node"]), nodes.namespace)
        self.timeout = float(plugin.entry.get("timeout", DEFAULT_TIMEOUT))
        self.restart = restart  # a reload: the node is cleaned up and configured anew at activation
        self.context = context
        self.state = "unknown"  # the node's state as last told by the bridge
        self.epoch = 0  # the bridge's count of this node's activations
        self.active = False
        self.lost: str | None = None  # why the node is no longer what its feature needs

    def _wait(self, moves: int = 1) -> float:
        """How long the run waits for the bridge: the node's timeout per round trip, and a margin."""
        return moves * self.timeout + MARGIN

    def start(self) -> None:
        """Prepare, off the loop: the node is there, and asked to configure."""
        self.nodes.call(
            self, "start", 3 * self._wait(), feature=self.feature, node=self.node, timeout=self.timeout,
            restart=self.restart,
        )

    def activate(self) -> None:
        """At the commit: inactive -> active (a reload cleans up and configures first)."""
        self.nodes.call(self, "activate", self._wait(5))
        self.lost = None
        self.active = True

    def deactivate(self) -> None:
        """Leaving (or moved back): active -> inactive. A lost node is left as it is."""
        self.active = False
        if not self._gone():
            self.nodes.call(self, "deactivate", self._wait(3))

    def stop(self) -> None:
        """Release: back to unconfigured (unless the node is lost, or another instance owns it).

        A node left inactive (by the switch) only has its clean-up sent, which nobody waits
        for: then neither does this, and a failure goes into the run's log."""
        self.active = False
        try:
            if self._gone():
                return
            if self.state == "inactive" and self.lost is None:
                self.nodes.tell(self, "stop")
            else:
                self.nodes.call(self, "stop", self._wait(4))
        finally:
            self.nodes.instances.pop(self.ident, None)

    def _gone(self) -> bool:
        """Lost with the bridge: nobody is left to move the node (the bridge, when it ended,
        moved the nodes it had activated back to unconfigured, if it could)."""
        bridge = self.nodes.bridge
        return self.lost is not None and bridge is not None and bridge.gone is not None

    # --------------------------------------------------------------- the loop
    def step(self, time: float) -> None:
        if self.lost is not None:
            raise FeatureUnavailable(self.lost)

    def status(self) -> str:
        return f"{self.node}: {'lost' if self.lost else self.state}"

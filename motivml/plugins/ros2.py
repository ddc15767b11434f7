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

While its feature is active a node is watched from the ROS executor's thread: its state is
asked every 0.2 s, and a node that leaves the graph, stops answering within 0.8 s or leaves
the active state on its own is *lost*. Its instance's next `step` raises, which makes it a
fault of the feature like any plugin's: a Dynamic feature is unloaded with its subtree, a
Static one stops the run. So a dead node is noticed within about a second.

rclpy is imported only when a robot has such a plugin (it is the optional extra
`motivml[ros2]`, kept in `.venv-ros` by `make ros2`). Every robot launched in one process
with one namespace shares one `Graph`: an rclpy context of its own (no signal handlers of
rclpy's: the run session has Ctrl-C) and a node `motivml_binder` spinning on a thread of its
own. The ROS 2 front door (`motivml.ros2`) spins its `motivml` node in the same context.
"""

from __future__ import annotations

import re
import threading
import time
from typing import Any

from ..documents.robot_folder import Plugin
from ..errors import Diagnostic, EnvironmentProblem, Location, describe_exception, error
from .api import FeatureUnavailable, PluginContext

DEFAULT_TIMEOUT = 5.0  # s: waiting for a node's services, and for each transition
WATCH_PERIOD = 0.2  # s between two questions to a watched node
WATCH_DEADLINE = 0.8  # s: a node that has not answered by then is lost
HANDSHAKE = 0.5  # s: a first question to a node on new clients, asked again until its timeout
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


def import_rclpy() -> Any:
    """rclpy, or EnvironmentProblem (exit 3) saying how to install it."""
    try:
        import rclpy
    except ImportError as exc:
        raise EnvironmentProblem(
            error(Location("ros2"), f"ROS 2 is not available in this Python ({exc}): {INSTALL_HINT}", "ros2.missing")
        ) from None
    return rclpy


class Graph:
    """rclpy for the robots of one namespace in this process: a context, and a way to spin nodes.

    Each node spins on an executor of its own, on a thread of its own (`spin`): the binder's
    lifecycle clients never wait behind a service callback of the front door (which itself
    waits for lifecycle transitions), and a single-threaded executor answers a client
    sooner than a pool of threads handing work to each other under the GIL.
    """

    def __init__(self, ns: str) -> None:
        rclpy = import_rclpy()

        self.namespace = ns
        self.users = 0
        self.context = rclpy.Context()
        self._spinning: list[tuple[Any, Any, threading.Thread]] = []  # (node, executor, thread)
        try:
            rclpy.init(context=self.context)  # ROS_DOMAIN_ID and the rest from the environment
            self.node = rclpy.create_node(
                "motivml_binder",
                namespace=ns,
                context=self.context,
                start_parameter_services=False,
            )
            self.spin(self.node)
        except Exception as exc:  # rclpy's RCLError: a bad ROS_DOMAIN_ID, say
            self.context.try_shutdown()
            first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise EnvironmentProblem(
                error(Location("ros2"), f"ROS 2 could not start: {first}", "ros2.start")
            ) from None

    def spin(self, node: Any) -> None:
        """Spin `node` on an executor and a daemon thread of its own until `forget` or `close`."""
        from rclpy.executors import SingleThreadedExecutor

        executor = SingleThreadedExecutor(context=self.context)
        executor.add_node(node)

        def spin() -> None:
            # A callback that raises ends rclpy's spin: log it and spin on, so that one bad
            # message never silences the node. The context shutting down ends it for good.
            while self.context.ok():
                try:
                    executor.spin()
                    return
                except Exception as exc:
                    if not self.context.ok():
                        return
                    node.get_logger().error(f"a callback raised {describe_exception(exc)}; spinning on")
                except BaseException:  # (rclpy's shutdown exceptions, a KeyboardInterrupt)
                    return

        thread = threading.Thread(target=spin, daemon=True, name=f"motivml-ros2-{node.get_name()}")
        thread.start()
        self._spinning.append((node, executor, thread))

    def forget(self, node: Any) -> None:
        """Stop spinning `node` and destroy it."""
        for entry in list(self._spinning):
            if entry[0] is node:
                self._spinning.remove(entry)
                _, executor, thread = entry
                executor.shutdown(timeout_sec=2.0)
                thread.join(timeout=2.0)
        node.destroy_node()

    def call(self, client: Any, request: Any, timeout: float) -> Any:
        """A service call from any thread but the executor's; None when no answer came in time."""
        return self.answer(client, self.send(client, request), timeout)

    def send(self, client: Any, request: Any) -> tuple[Any, threading.Event]:
        """Send a request; `answer` waits for it."""
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        return future, done

    def answer(self, client: Any, sent: tuple[Any, threading.Event], timeout: float) -> Any:
        future, done = sent
        if not done.wait(timeout):
            client.remove_pending_request(future)
            return None
        return future.result()

    def close(self) -> None:
        for node, _, _ in list(self._spinning):
            self.forget(node)
        self.context.try_shutdown()


# Where each transition ends when it succeeds (lifecycle_msgs' primary state ids and labels).
GOALS = {
    1: (2, "inactive"),  # configure
    2: (1, "unconfigured"),  # cleanup
    3: (3, "active"),  # activate
    4: (2, "inactive"),  # deactivate
}

_graphs: dict[str, Graph] = {}
_graphs_lock = threading.Lock()


def open_graph(ns: str) -> Graph:
    """The namespace's graph in this process, made at first use; `release_graph` when done."""
    with _graphs_lock:
        graph = _graphs.get(ns)
        if graph is None:
            graph = _graphs[ns] = Graph(ns)
        graph.users += 1
        return graph


def release_graph(graph: Graph) -> None:
    with _graphs_lock:
        graph.users -= 1
        if graph.users == 0:
            del _graphs[graph.namespace]
            graph.close()


class LifecycleNodes:
    """The ros2_lifecycle plugins of one launched robot, and the watch over their nodes."""

    def __init__(self, robot: str, plugins: dict[str, Plugin], ros_namespace: str = "/") -> None:
        self.plugins = plugins
        self.namespace = ros_namespace
        self.graph: Graph | None = None
        self.owners: dict[str, LifecycleFeature] = {}  # node -> the instance that activated it
        self._timer: Any = None
        self._clients: dict[str, tuple[Any, Any]] = {}  # node -> (change_state, get_state)
        self._cleanups: dict[str, tuple[threading.Event, float]] = {}  # node -> its clean-up's answer
        self.proven: set[str] = set()  # nodes that answered on their present clients
        self._lock = threading.Lock()

    def problems(self) -> list[Diagnostic]:
        """Without rclpy no node can be driven: say so before anything starts."""
        try:
            import_rclpy()
        except EnvironmentProblem as missing:
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
        return []

    def _graph(self) -> Graph:
        with self._lock:
            if self.graph is None:
                self.graph = open_graph(self.namespace)
                self._timer = self.graph.node.create_timer(WATCH_PERIOD, self._watch)
            return self.graph

    def clients(self, node: str) -> tuple[Any, Any]:
        """The node's change_state and get_state clients, made once: a new client must be
        discovered by the node before its first answer, which costs tens of milliseconds."""
        from lifecycle_msgs.srv import ChangeState, GetState

        graph = self._graph()
        with self._lock:
            made = self._clients.get(node)
            if made is None:
                made = self._clients[node] = (
                    graph.node.create_client(ChangeState, f"{node}/change_state"),
                    graph.node.create_client(GetState, f"{node}/get_state"),
                )
            return made

    def renew(self, node: str) -> None:
        """Forget the node's clients after it failed to answer: if it comes back (a new
        process of the same name), fresh clients find it, where old ones may wait for the
        dead one's answers."""
        with self._lock:
            made = self._clients.pop(node, None)
            self.proven.discard(node)
        graph = self.graph
        if made is not None and graph is not None:
            for client in made:
                graph.node.destroy_client(client)

    def clean_up(self, instance: LifecycleFeature) -> None:
        """Send `instance`'s node back to unconfigured without waiting for its answer: the
        feature has already left, nothing waits on it. The next use of the node waits for it
        (`settle`), and a failure goes into the run's log."""
        from lifecycle_msgs.msg import Transition
        from lifecycle_msgs.srv import ChangeState

        change, _ = self.clients(instance.node)
        request = ChangeState.Request(transition=Transition(id=Transition.TRANSITION_CLEANUP))
        future, answered = self._graph().send(change, request)

        def heard(_: Any) -> None:
            answer = future.result() if not future.cancelled() else None
            if answer is not None and answer.success:
                instance.state_id, instance.state = GOALS[Transition.TRANSITION_CLEANUP]
            else:
                instance.context.log(f"node {instance.node} did not clean up (it stays inactive)")

        future.add_done_callback(heard)  # the node has answered once `answered` is set
        with self._lock:
            self._cleanups[instance.node] = (answered, instance.timeout)

    def settle(self, node: str | None = None) -> None:
        """Wait for the clean-up of `node` (None: of every node) sent by `clean_up`."""
        with self._lock:
            pending = [(n, c) for n, c in self._cleanups.items() if node is None or n == node]
        for name, (done, timeout) in pending:
            done.wait(timeout)
            with self._lock:
                if self._cleanups.get(name, (None,))[0] is done:
                    del self._cleanups[name]

    def create(self, plugin: Plugin, context: PluginContext, fresh: bool = False) -> LifecycleFeature:
        return LifecycleFeature(self, plugin, context, fresh)

    def discard(self, instance: Any) -> None:
        instance.stop()

    def close(self) -> None:
        self.settle()  # every node that left is unconfigured before the run ends
        with self._lock:
            graph, self.graph = self.graph, None
        if graph is not None:
            if self._timer is not None:
                graph.node.destroy_timer(self._timer)
            for clients in self._clients.values():
                for client in clients:
                    graph.node.destroy_client(client)
            self._clients.clear()
            release_graph(graph)

    def _watch(self) -> None:
        """Every WATCH_PERIOD, on the executor: ask each active node its state."""
        graph = self.graph
        if graph is None:
            return
        present = None
        for instance in list(self.owners.values()):
            if not instance.watched or instance.lost is not None:
                continue
            if present is None:
                present = {
                    f"{ns.rstrip('/')}/{name}" for name, ns in graph.node.get_node_names_and_namespaces()
                }
            instance.check(present)


class LifecycleFeature:
    """One feature's lifecycle node, as the binder and the loop see it."""

    def __init__(self, nodes: LifecycleNodes, plugin: Plugin, context: PluginContext, restart: bool) -> None:
        self.nodes = nodes
        self.feature = plugin.feature
        self.node = resolve_node(str(plugin.entry["node"]), nodes.namespace)
        self.timeout = float(plugin.entry.get("timeout", DEFAULT_TIMEOUT))
        self.restart = restart  # a reload: the node is cleaned up and configured anew at activation
        self.context = context
        self.graph = nodes._graph()
        self._change, self._get = nodes.clients(self.node)
        self.state = "unknown"  # the node's state as last seen (its label)
        self.state_id = 0  # lifecycle_msgs/State id (0: unknown)
        self.watched = False  # expected active, and not being moved by us
        self.lost: str | None = None  # why the node is no longer what its feature needs
        self._probe: tuple[Any, float] | None = None
        self._seen = False  # listed on the graph since it was activated
        self._released = False
        self._configuring: tuple[Any, threading.Event] | None = None  # start's configure, in flight

    # ------------------------------------------------------------ transitions
    def _get_state(self) -> int:
        from lifecycle_msgs.srv import GetState

        answer = self.graph.call(self._get, GetState.Request(), self.timeout)
        if answer is None:
            self.nodes.renew(self.node)
            raise FeatureUnavailable(f"node {self.node} did not answer get_state within {self.timeout:g} s")
        self.state_id, self.state = answer.current_state.id, answer.current_state.label
        return int(self.state_id)

    def _transition(self, transition: int, verb: str) -> None:
        """One transition; on success the node is in its goal state (asked only on failure)."""
        from lifecycle_msgs.msg import Transition
        from lifecycle_msgs.srv import ChangeState

        request = ChangeState.Request(transition=Transition(id=transition))
        answer = self.graph.call(self._change, request, self.timeout)
        if answer is None:
            self.nodes.renew(self.node)
            raise FeatureUnavailable(f"node {self.node} did not {verb} within {self.timeout:g} s")
        if not answer.success:
            try:
                self._get_state()
                state = f"it is {self.state}"
            except FeatureUnavailable:
                state = "its state is unknown"
            raise FeatureUnavailable(f"node {self.node} failed to {verb}: {state}")
        self.state_id, self.state = GOALS[transition]

    def start(self) -> None:
        """Prepare, off the loop: the node is there, and asked to configure."""
        from lifecycle_msgs.msg import Transition
        from lifecycle_msgs.srv import ChangeState

        if not self._change.wait_for_service(timeout_sec=self.timeout) or not self._get.wait_for_service(
            timeout_sec=self.timeout
        ):
            raise FeatureUnavailable(
                f"node {self.node} is not on the ROS graph: no {self.node}/change_state within {self.timeout:g} s"
            )
        if self.node not in self.nodes.proven:
            self._handshake()
        self.nodes.settle(self.node)  # a clean-up of this node still under way
        if self.restart:  # active: its instance deactivates it at the switch, this one reconfigures it
            self._get_state()
            return
        # Nodes wait unconfigured: configure at once, and ask the state only if that fails. The
        # answer is waited for at the switch, so that it comes while the nodes that leave are
        # being deactivated (one round trip less on a swap's way).
        request = ChangeState.Request(transition=Transition(id=Transition.TRANSITION_CONFIGURE))
        self._configuring = self.graph.send(self._change, request)

    def _handshake(self) -> None:
        """New clients: ask the state until a node answers. `wait_for_service` also counts a
        node that died a moment ago and is still listed (until its DDS lease ends), and a live
        node may not have matched a brand-new client yet: a first request could be lost."""
        from lifecycle_msgs.srv import GetState

        deadline = time.monotonic() + self.timeout
        while True:
            left = deadline - time.monotonic()
            answer = self.graph.call(self._get, GetState.Request(), min(HANDSHAKE, max(left, 0.0)))
            if answer is not None:
                self.state_id, self.state = answer.current_state.id, answer.current_state.label
                self.nodes.proven.add(self.node)
                return
            if time.monotonic() >= deadline:
                self.nodes.renew(self.node)
                raise FeatureUnavailable(f"node {self.node} did not answer get_state within {self.timeout:g} s")

    def _configured(self) -> None:
        """Wait for the configure that `start` sent; RuntimeError if the node is not configured."""
        from lifecycle_msgs.msg import State, Transition

        if self._configuring is None:
            return
        sent, self._configuring = self._configuring, None
        answer = self.graph.answer(self._change, sent, self.timeout)
        if answer is None:
            self.nodes.renew(self.node)
            raise FeatureUnavailable(f"node {self.node} did not configure within {self.timeout:g} s")
        if answer.success:
            self.state_id, self.state = GOALS[Transition.TRANSITION_CONFIGURE]
            return
        try:
            self._get_state()
        except FeatureUnavailable:
            raise FeatureUnavailable(f"node {self.node} failed to configure: its state is unknown") from None
        if self.state_id not in (State.PRIMARY_STATE_INACTIVE, State.PRIMARY_STATE_ACTIVE):
            raise FeatureUnavailable(f"node {self.node} failed to configure: it is {self.state}")

    def activate(self) -> None:
        """At the commit: inactive -> active (a reload cleans up and configures first)."""
        from lifecycle_msgs.msg import State, Transition

        self._configured()
        if self.restart:
            state = self._get_state()  # the instance it replaces has just deactivated it
            if state == State.PRIMARY_STATE_INACTIVE:
                self._transition(Transition.TRANSITION_CLEANUP, "clean up")
                self._transition(Transition.TRANSITION_CONFIGURE, "configure")
        if self.state_id != State.PRIMARY_STATE_ACTIVE:
            self._transition(Transition.TRANSITION_ACTIVATE, "activate")
        previous = self.nodes.owners.get(self.node)
        if previous is not None and previous is not self:
            previous.watched = False
        self.nodes.owners[self.node] = self
        self.lost = None
        self._probe = None
        self._seen = False
        self.watched = True

    def deactivate(self) -> None:
        """Leaving (or moved back): active -> inactive. A lost node is left as it is."""
        from lifecycle_msgs.msg import State, Transition

        self.watched = False
        self._settle_configure()
        if self.lost is None and self.state_id == State.PRIMARY_STATE_ACTIVE:
            self._transition(Transition.TRANSITION_DEACTIVATE, "deactivate")

    def stop(self) -> None:
        """Release: back to unconfigured (unless the node is lost, or another instance owns it)."""
        from lifecycle_msgs.msg import State, Transition

        if self._released:
            return
        self._released = True
        self.watched = False
        self._settle_configure()
        owner = self.nodes.owners.get(self.node)
        try:
            if owner is not None and owner is not self:
                return  # reloaded: the new instance has the node now
            self.nodes.owners.pop(self.node, None)
            if self.lost is not None:
                return
            if self.state_id == State.PRIMARY_STATE_ACTIVE:
                self._transition(Transition.TRANSITION_DEACTIVATE, "deactivate")
            if self.state_id == State.PRIMARY_STATE_INACTIVE:
                self.nodes.clean_up(self)
        finally:
            self._probe = None

    def _settle_configure(self) -> None:
        """A configure still under way has ended (the state is then known, or left unknown)."""
        try:
            self._configured()
        except FeatureUnavailable:
            pass

    # --------------------------------------------------------------- the loop
    def step(self, time: float) -> None:
        if self.lost is not None:
            raise FeatureUnavailable(self.lost)

    def status(self) -> str:
        return f"{self.node}: {'lost' if self.lost else self.state}"

    # -------------------------------------------------------------- the watch
    def check(self, present: set[str]) -> None:
        """On the executor thread, every WATCH_PERIOD while active."""
        from lifecycle_msgs.msg import State
        from lifecycle_msgs.srv import GetState

        if self.node in present:
            self._seen = True
        elif self._seen:  # (discovery may list a node a little after its services)
            self.lost = f"node {self.node} left the ROS graph"
            self.nodes.renew(self.node)
            return
        now = time.monotonic()
        if self._probe is None:
            self._probe = (self._get.call_async(GetState.Request()), now)
            return
        future, asked = self._probe
        if future.done():
            self._probe = None
            answer = future.result()
            if answer is not None and self.watched and answer.current_state.id != State.PRIMARY_STATE_ACTIVE:
                self.state_id, self.state = answer.current_state.id, answer.current_state.label
                self.lost = f"node {self.node} left the active state: it is {self.state}"
        elif now - asked > WATCH_DEADLINE:
            self._get.remove_pending_request(future)
            self._probe = None
            self.lost = f"node {self.node} stopped answering (no state within {WATCH_DEADLINE:g} s): it died or hung"
            self.nodes.renew(self.node)

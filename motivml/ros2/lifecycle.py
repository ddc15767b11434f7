"""The bridge's side of `ros2_lifecycle` plugins: driving the features' lifecycle nodes.

The run's process holds a stand-in per plugin instance (`motivml.plugins.ros2`); each of
its moves is a call to the bridge, answered here, on the bridge's worker thread, one at a
time and in order. The steps (see `motivml.plugins.ros2` for their place in a request):

* `start`: wait for the node's services, and ask it to configure (not waited for: the
  answer is waited for at `activate`, so that it comes while the nodes that leave are being
  deactivated);
* `activate`, `deactivate`: inactive <-> active, at the commit;
* `stop`: back to unconfigured; the clean-up is sent, not waited for (the next use of the
  node, and the end of the run, wait for it: `settle`).

While its feature is active a node is watched from the executor of the node
`motivml_binder`: its state is asked every 0.2 s, and a node that leaves the graph, stops
answering within 0.8 s or leaves the active state on its own is *lost*: the run is told at
once (`{"event": "lost"}`), and the stand-in's next step raises.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from ..plugins.api import FeatureUnavailable
from .graph import Graph

WATCH_PERIOD = 0.2  # s between two questions to a watched node
WATCH_DEADLINE = 0.8  # s: a node that has not answered by then is lost
HANDSHAKE = 0.2  # s: a first question to a node on new clients, asked again until its timeout (an answer
# to a new client is lost until the node has discovered it: a few tenths of a second)

# Where each transition ends when it succeeds (lifecycle_msgs' primary state ids and labels).
GOALS = {
    1: (2, "inactive"),  # configure
    2: (1, "unconfigured"),  # cleanup
    3: (3, "active"),  # activate
    4: (2, "inactive"),  # deactivate
}


class LifecycleNodes:
    """Every lifecycle node the run drives, and the watch over the active ones."""

    def __init__(self, graph: Graph, tell: Callable[[dict[str, Any]], None]) -> None:
        self.graph = graph
        self.tell = tell  # a one-way message to the run
        self.instances: dict[int, NodeFeature] = {}
        self.owners: dict[str, NodeFeature] = {}  # node -> the instance that activated it
        self._clients: dict[str, tuple[Any, Any]] = {}  # node -> (change_state, get_state)
        self._cleanups: dict[str, tuple[threading.Event, float]] = {}  # node -> its clean-up's answer
        self.proven: set[str] = set()  # nodes that answered on their present clients
        self._lock = threading.Lock()
        self._timer = graph.node.create_timer(WATCH_PERIOD, self._watch)

    # ------------------------------------------------------------- the run's calls
    def handle(self, message: dict[str, Any]) -> dict[str, Any]:
        """One call of the run (`{"op": "lifecycle", "do": ..., "instance": k, ...}`): its answer."""
        do = message["do"]
        if do == "settle":
            self.settle(message.get("node"))
            return {}
        if do == "know":  # the run's nodes, to be discovered while it starts
            for node in message["nodes"]:
                self.clients(str(node))
            return {}
        if do == "absent":  # which of these nodes are not there within one deadline for all
            deadline = time.monotonic() + float(message["timeout"])
            absent = []
            for node in message["nodes"]:
                change, _ = self.clients(str(node))
                if not change.wait_for_service(timeout_sec=max(deadline - time.monotonic(), 0.0)):
                    absent.append(node)
            return {"absent": absent}
        ident = int(message["instance"])
        instance = self.instances.get(ident)
        if do == "start":
            instance = self.instances[ident] = NodeFeature(
                self, ident, str(message["feature"]), str(message["node"]), float(message["timeout"]),
                bool(message.get("restart")),
            )
        if instance is None:
            return {}  # (a stop of an instance whose start never reached the bridge: nothing to do)
        try:
            getattr(instance, do)()
        except FeatureUnavailable as exc:
            return {"error": str(exc), **instance.state_fields()}
        finally:
            if do == "stop":
                self.instances.pop(ident, None)
        return instance.state_fields()

    def clients(self, node: str) -> tuple[Any, Any]:
        """The node's change_state and get_state clients, made once: a new client must be
        discovered by the node before its first answer, which costs tens of milliseconds."""
        from lifecycle_msgs.srv import ChangeState, GetState

        with self._lock:
            made = self._clients.get(node)
            if made is None:
                made = self._clients[node] = (
                    self.graph.node.create_client(ChangeState, f"{node}/change_state"),
                    self.graph.node.create_client(GetState, f"{node}/get_state"),
                )
            return made

    def renew(self, node: str) -> None:
        """Forget the node's clients after it failed to answer: if it comes back (a new
        process of the same name), fresh clients find it, where old ones may wait for the
        dead one's answers."""
        with self._lock:
            made = self._clients.pop(node, None)
            self.proven.discard(node)
        if made is not None:
            for client in made:
                self.graph.node.destroy_client(client)

    def clean_up(self, instance: NodeFeature) -> None:
        """Send `instance`'s node back to unconfigured without waiting for its answer: the
        feature has already left, nothing waits on it. The next use of the node waits for it
        (`settle`), and a failure goes into the run's log."""
        from lifecycle_msgs.msg import Transition
        from lifecycle_msgs.srv import ChangeState

        change, _ = self.clients(instance.node)
        request = ChangeState.Request(transition=Transition(id=Transition.TRANSITION_CLEANUP))
        future, answered = self.graph.send(change, request)

        def heard(_: Any) -> None:
            answer = future.result() if not future.cancelled() else None
            if answer is not None and answer.success:
                instance.state_id, instance.state = GOALS[Transition.TRANSITION_CLEANUP]
            else:
                instance.log(f"node {instance.node} did not clean up (it stays inactive)")

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

    def release_all(self) -> None:
        """The run has gone without stopping its features (killed, say): every node it had
        moved out of unconfigured goes back there, so that nothing it switched on stays on:
        the active ones, and those configured for a load it never committed (a run killed
        between a request's preparation and its commit). Each node by one instance: the one
        that activated it, if any (a reload's other instance would move it again, from a
        state it no longer has)."""
        owned = dict(self.owners)
        left = {id(i): i for i in [*owned.values(), *self.instances.values()]}
        for instance in left.values():
            if owned.get(instance.node, instance) is not instance:
                continue
            instance.watched = False
            try:
                instance.stop()
            except FeatureUnavailable as exc:
                instance.log(str(exc))
        self.settle()

    def close(self) -> None:
        self.settle()  # every node that left is unconfigured before the bridge ends
        self.graph.node.destroy_timer(self._timer)
        for clients in self._clients.values():
            for client in clients:
                self.graph.node.destroy_client(client)
        self._clients.clear()

    def _watch(self) -> None:
        """Every WATCH_PERIOD, on the executor: ask each active node its state."""
        present = None
        for instance in list(self.owners.values()):
            if not instance.watched or instance.lost is not None:
                continue
            if present is None:
                present = {
                    f"{ns.rstrip('/')}/{name}" for name, ns in self.graph.node.get_node_names_and_namespaces()
                }
            instance.check(present)


class NodeFeature:
    """One plugin instance's lifecycle node, driven for the run."""

    def __init__(
        self, nodes: LifecycleNodes, ident: int, feature: str, node: str, timeout: float, restart: bool
    ) -> None:
        self.nodes = nodes
        self.ident = ident
        self.feature = feature
        self.node = node
        self.timeout = timeout
        self.restart = restart  # a reload: the node is cleaned up and configured anew at activation
        self.graph = nodes.graph
        self._change, self._get = nodes.clients(self.node)
        self.state = "unknown"  # the node's state as last seen (its label)
        self.state_id = 0  # lifecycle_msgs/State id (0: unknown)
        self.watched = False  # expected active, and not being moved by us
        self.lost: str | None = None  # why the node is no longer what its feature needs
        self.epoch = 0  # activations so far: a loss is of one of them
        self._probe: tuple[Any, float] | None = None
        self._seen = False  # listed on the graph since it was activated
        self._released = False
        self._configuring: tuple[Any, threading.Event] | None = None  # start's configure, in flight

    def state_fields(self) -> dict[str, Any]:
        return {"state": self.state, "state_id": self.state_id, "epoch": self.epoch}

    def log(self, text: str) -> None:
        self.nodes.tell({"event": "log", "feature": self.feature, "text": text})

    def _lose(self, why: str) -> None:
        self.lost = why
        self.nodes.tell({"event": "lost", "instance": self.ident, "epoch": self.epoch, "why": why})

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
        # Nodes wait unconfigured: configure at once, and ask the state only if that fails.
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
        """Wait for the configure that `start` sent; FeatureUnavailable if the node is not configured."""
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
        self.epoch += 1
        self.lost = None
        self._probe = None
        self._seen = False
        self.watched = True

    def deactivate(self) -> None:
        """Leaving (or moved back): active -> inactive. A lost node is left as it is."""
        from lifecycle_msgs.msg import State, Transition

        self.watched = False  # (its own deactivation is not a loss)
        self._settle_configure()
        if self.lost is None and self.state_id == State.PRIMARY_STATE_ACTIVE:
            try:
                self._transition(Transition.TRANSITION_DEACTIVATE, "deactivate")
            except FeatureUnavailable:
                # The node would not go: the request is refused and its feature stays, so
                # the node is watched again (it was not, and a node killed later raised no
                # fault while status still said active).
                self.watched = True
                raise

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

    # -------------------------------------------------------------- the watch
    def check(self, present: set[str]) -> None:
        """On the executor thread, every WATCH_PERIOD while active."""
        from lifecycle_msgs.msg import State
        from lifecycle_msgs.srv import GetState

        if self.node in present:
            self._seen = True
        elif self._seen:  # (discovery may list a node a little after its services)
            self.nodes.renew(self.node)
            self._lose(f"node {self.node} left the ROS graph")
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
                self._lose(f"node {self.node} left the active state: it is {self.state}")
        elif now - asked > WATCH_DEADLINE:
            self._get.remove_pending_request(future)
            self._probe = None
            self.nodes.renew(self.node)
            self._lose(f"node {self.node} stopped answering (no state within {WATCH_DEADLINE:g} s): it died or hung")

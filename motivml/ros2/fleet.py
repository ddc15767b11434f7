"""The running fleet as `motivml fleet` sees it: an rclpy client of the graph (reference.md
section 9).

Every robot of `motivml run --ros2` has a node `NS/motivml` (see node.py). `Watch` finds
those nodes under a namespace prefix, keeps what each one says of itself (its latched
`~/active_features`: robot, variant, active set, tick, last change; and its statuses on
`/diagnostics`, which name it as their `hardware_id`), and makes the one call a change is on
a robot: `set_parameters_atomically` on its `features.<id>.active` parameters. It reports
plain data (the node's own JSON and statuses); what the data means for a rollout is
motivml.fleet's business, which knows no rclpy.

The client's node logs through rosout, so each step of a rollout is on the graph's log too.
"""

from __future__ import annotations

import json
import os
import re
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from ..errors import EnvironmentProblem, Location, error
from .graph import import_rclpy
from .node import LEVELS, parameter_name

NODE_NAME = "motivml"
LEVEL_WORDS = {value: word for word, value in LEVELS.items()}
POLL = 0.02  # s between two looks at the graph while waiting for discovery


def natural(namespace: str) -> list[Any]:
    """A sort key that puts /uv2 before /uv10."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", namespace)]


@dataclass
class Seen:
    """What one robot's node has said: its active set message, its last /diagnostics."""

    namespace: str
    state: dict[str, Any] | None = None  # the latest ~/active_features message
    state_at: float = 0.0  # monotonic time it came
    statuses: list[dict[str, Any]] = field(default_factory=list)  # the latest /diagnostics statuses of the node
    statuses_at: float = 0.0
    reports: int = 0  # /diagnostics messages heard from the node


class Watch:
    """An rclpy client of the graph: the `motivml` nodes under `prefix`, what they say, and
    one parameter call per change. Its own context and node spin on a thread of its own."""

    def __init__(self, prefix: str = "/") -> None:
        rclpy = import_rclpy()
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.executors import SingleThreadedExecutor

        self.prefix = "/" + prefix.strip("/")
        self.context = rclpy.Context()
        self._lock = threading.Lock()
        self._seen: dict[str, Seen] = {}
        self._clients: dict[str, Any] = {}
        try:
            # its log goes to rosout only: the command prints its own lines
            rclpy.init(context=self.context, args=["--ros-args", "--disable-stdout-logs"])
            self.node = rclpy.create_node(
                f"motivml_fleet_{os.getpid()}", context=self.context, start_parameter_services=False
            )
        except Exception as exc:  # a bad ROS_DOMAIN_ID, say
            self.context.try_shutdown()
            first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise EnvironmentProblem(error(Location("ros2"), f"ROS 2 could not start: {first}", "ros2.start")) from None
        self.log = self.node.get_logger()
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._diagnostics, 50)
        self._executor = SingleThreadedExecutor(context=self.context)
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True, name="motivml-fleet")
        self._thread.start()

    def _spin(self) -> None:
        try:
            self._executor.spin()
        except BaseException:  # (the context shutting down)
            pass

    # -------------------------------------------------------------- discovery
    def namespaces(self) -> list[str]:
        """The namespaces of the `motivml` nodes on the graph under the prefix, now."""
        found = set()
        for name, namespace in self.node.get_node_names_and_namespaces():
            if name == NODE_NAME and self._under(namespace):
                found.add(namespace)
        return sorted(found, key=natural)

    def _under(self, namespace: str) -> bool:
        return self.prefix == "/" or namespace == self.prefix or namespace.startswith(self.prefix + "/")

    def follow(self, namespaces: list[str]) -> None:
        """Subscribe to the active sets of these robots' nodes (those not followed yet)."""
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import String

        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        for namespace in namespaces:
            with self._lock:
                if namespace in self._seen:
                    continue
                self._seen[namespace] = Seen(namespace)
            topic = f"{namespace.rstrip('/')}/{NODE_NAME}/active_features"
            self.node.create_subscription(
                String, topic, lambda message, ns=namespace: self._state(ns, message.data), latched
            )

    def discover(self, wait: float, expected: list[str] | None = None, quiet: float = 1.5) -> list[str]:
        """Follow the robots' nodes as they appear, for at most `wait` seconds, and return
        the namespaces of those that have said their active set. Without `expected`, the
        search ends `quiet` seconds after the last new node (DDS discovery on loopback
        comes in bursts); with it, as soon as every expected robot has been heard."""
        deadline = time.monotonic() + wait
        last_new = time.monotonic()
        while True:
            found = self.namespaces()
            with self._lock:
                new = [ns for ns in found if ns not in self._seen]
            if new:
                self.follow(new)
                last_new = time.monotonic()
            heard = self.heard()
            now = time.monotonic()
            if expected is not None and set(expected) <= set(heard):
                return heard
            if expected is None and found and set(found) <= set(heard) and now - last_new >= quiet:
                return heard
            if now >= deadline:
                return heard
            time.sleep(POLL)

    def heard(self) -> list[str]:
        """The robots whose active set has come."""
        with self._lock:
            return sorted(ns for ns, seen in self._seen.items() if seen.state is not None)

    def wait_reports(self, namespaces: list[str], wait: float) -> None:
        """Wait, at most `wait` seconds, until each of these robots has sent a /diagnostics message."""
        deadline = time.monotonic() + wait
        while time.monotonic() < deadline:
            with self._lock:
                if all(self._seen.get(ns, Seen(ns)).reports for ns in namespaces):
                    return
            time.sleep(POLL)

    # ----------------------------------------------------------------- news
    def _state(self, namespace: str, data: str) -> None:
        try:
            state = json.loads(data)
        except ValueError:
            return
        if not isinstance(state, dict):
            return
        with self._lock:
            seen = self._seen.setdefault(namespace, Seen(namespace))
            seen.state, seen.state_at = state, time.monotonic()

    def _diagnostics(self, message: Any) -> None:
        mine: dict[str, list[dict[str, Any]]] = {}
        for status in message.status:
            node = status.hardware_id
            if not node.endswith("/" + NODE_NAME):
                continue
            namespace = node[: -len(NODE_NAME) - 1] or "/"
            level = status.level if isinstance(status.level, bytes) else bytes([status.level])
            mine.setdefault(namespace, []).append(
                {
                    "name": status.name,
                    "level": LEVEL_WORDS.get(level, "STALE"),
                    "message": status.message,
                    "values": {v.key: v.value for v in status.values},
                }
            )
        now = time.monotonic()
        with self._lock:
            for namespace, statuses in mine.items():
                if namespace in self._seen:
                    seen = self._seen[namespace]
                    seen.statuses, seen.statuses_at = statuses, now
                    seen.reports += 1

    def snapshot(self, namespace: str) -> Seen | None:
        """A copy of what the robot in `namespace` has said (None: nothing yet)."""
        with self._lock:
            seen = self._seen.get(namespace)
            if seen is None:
                return None
            return Seen(seen.namespace, seen.state, seen.state_at, list(seen.statuses), seen.statuses_at, seen.reports)

    def alive(self, namespace: str) -> bool:
        """Whether the robot's node is on the graph now."""
        return namespace in self.namespaces()

    # ----------------------------------------------------------------- calls
    def set(self, namespace: str, wanted: dict[str, bool], timeout: float) -> tuple[bool | None, str]:
        """One atomic parameter call: features on and off. (True: accepted; False: refused,
        or the node is not there; None: no answer within `timeout`, the node may have taken
        it), and the node's reason.

        A new client's first request may be lost while discovery has not matched it with
        the node's service: it is sent again each second until answered. That is safe, as
        the call says what each feature must be: a second one moves nothing."""
        from rcl_interfaces.srv import SetParametersAtomically
        from rclpy.parameter import Parameter

        service = f"{namespace.rstrip('/')}/{NODE_NAME}/set_parameters_atomically"
        client = self._clients.get(service)
        fresh = client is None
        if client is None:
            client = self._clients[service] = self.node.create_client(SetParametersAtomically, service)
        if not client.wait_for_service(timeout_sec=timeout):
            return False, f"{service} is not on the graph"
        request = SetParametersAtomically.Request(
            parameters=[Parameter(parameter_name(f), value=on).to_parameter_msg() for f, on in wanted.items()]
        )
        deadline = time.monotonic() + timeout
        while True:
            done = threading.Event()
            future = client.call_async(request)
            future.add_done_callback(lambda _, done=done: done.set())
            left = deadline - time.monotonic()
            if done.wait(max(0.0, min(1.0, left) if fresh else left)):
                result = future.result().result
                return bool(result.successful), str(result.reason)
            client.remove_pending_request(future)
            if time.monotonic() >= deadline:
                return None, f"{service} did not answer within {timeout:g} s"

    def close(self) -> None:
        """Leave the graph: the spinning thread ended before the node and the context go."""
        self._executor.shutdown(timeout_sec=2.0)
        self._thread.join(timeout=2.0)
        self.node.destroy_node()
        self.context.try_shutdown()

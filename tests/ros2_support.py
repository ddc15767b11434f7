"""What the ROS 2 tests share: the marker, a graph of their own on loopback, node processes.

Every ROS 2 test module starts with `pytestmark = ROS2`. In the default `.venv` (no rclpy)
they are skipped, saying so; `make test` runs them again in `.venv-ros` with
MOTIVML_REQUIRE_ROS2=1, where a missing rclpy fails them instead of skipping them.

Traffic stays on this machine: discovery is limited to localhost, and each test takes a
ROS_DOMAIN_ID of its own (`domain()`, locked against every other test process), so that two
tests, or two test runs at once, never see each other's nodes.
"""

from __future__ import annotations

import fcntl
import importlib.util
import os
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

import pytest
from paths import ROOT

AVAILABLE = importlib.util.find_spec("rclpy") is not None
REQUIRED = os.environ.get("MOTIVML_REQUIRE_ROS2") == "1"

ROS2 = [
    pytest.mark.ros2,
    pytest.mark.skipif(
        not AVAILABLE and not REQUIRED, reason="needs ROS 2 (rclpy): make ros2, then .venv-ros/bin/pytest -m ros2"
    ),
]

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"  # never beyond this machine
os.environ.pop("ROS_STATIC_PEERS", None)

# Domain ids 1..101 are safe on Linux. A domain is taken with an exclusive lock on a file of
# its own, held until this process ends, so that two test runs at once (a developer's and
# CI's, or two of pytest's) never share one; none is reused within a run.
_held: list[IO[str]] = []
_START = os.getpid() % 101


def domain() -> int:
    """A ROS_DOMAIN_ID no other process of ours holds, and not used before in this run."""
    taken = {int(h.name.rsplit("-", 1)[1].split(".")[0]) for h in _held}
    for step in range(101):
        value = 1 + (_START + step) % 101
        if value in taken:
            continue
        handle = open(Path(tempfile.gettempdir()) / f"motivml-ros-domain-{value}.lock", "w")  # noqa: SIM115
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        _held.append(handle)
        os.environ["ROS_DOMAIN_ID"] = str(value)
        return value
    raise RuntimeError("no free ROS domain id left for this test run")


def environment(domain_id: int) -> dict[str, str]:
    """The environment of a process on the test's own graph."""
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["PYTHONUNBUFFERED"] = "1"
    return env


@contextmanager
def processes() -> Iterator[list[subprocess.Popen[str]]]:
    """Processes started in the block (append them) are ended when it ends, whatever happens."""
    started: list[subprocess.Popen[str]] = []
    try:
        yield started
    finally:
        for process in started:
            if process.poll() is None:
                process.terminate()
        for process in started:
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


def python_process(args: list[str], domain_id: int, **options: object) -> subprocess.Popen[str]:
    """`python ARGS` with this interpreter, on the test's graph, output captured."""
    return subprocess.Popen(  # noqa: S603 (our own interpreter and scripts)
        [sys.executable, *args],
        env=environment(domain_id),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        cwd=ROOT,
        **options,  # type: ignore[call-overload]
    )


class Client:
    """An rclpy client of the robot's graph, with its own context and executor thread."""

    def __init__(self, domain_id: int, ns: str = "/") -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        self.ns = ns.rstrip("/")
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = rclpy.create_node("test_client", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()
        self.clients: dict[str, Any] = {}

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except BaseException:
            pass

    def call(self, kind: Any, service: str, request: Any, timeout: float = 20.0) -> Any:
        """One call. A new client's first request may be lost while the server has not yet
        matched the client (DDS discovery): that one is sent again each second until answered."""
        client = self.clients.get(service)
        fresh = client is None
        if client is None:
            client = self.clients[service] = self.node.create_client(kind, service)
            assert client.wait_for_service(timeout_sec=timeout), f"no service {service}"
        deadline = time.monotonic() + timeout
        while True:
            done = threading.Event()
            future = client.call_async(request)
            future.add_done_callback(lambda _, done=done: done.set())
            if done.wait(min(1.0, timeout) if fresh else timeout):
                return future.result()
            client.remove_pending_request(future)
            assert fresh and time.monotonic() < deadline, f"{service} did not answer"

    def set(self, atomically: bool = True, pairs: tuple[tuple[str, bool], ...] = (), **values: Any) -> list[Any]:
        """Set features.<id>.active; the results (one for atomically). `pairs` come first,
        as given (a feature may be named twice)."""
        from rcl_interfaces.srv import SetParameters, SetParametersAtomically
        from rclpy.parameter import Parameter

        given = [*pairs, *values.items()]
        messages = [Parameter(f"features.{k}.active", value=v).to_parameter_msg() for k, v in given]
        kind = SetParametersAtomically if atomically else SetParameters
        name = "set_parameters_atomically" if atomically else "set_parameters"
        answer = self.call(kind, f"{self.ns}/motivml/{name}", kind.Request(parameters=messages))
        return [answer.result] if atomically else list(answer.results)

    def parameters(self, *features: str) -> dict[str, bool]:
        from rcl_interfaces.srv import GetParameters

        names = [f"features.{f}.active" for f in features]
        answer = self.call(GetParameters, f"{self.ns}/motivml/get_parameters", GetParameters.Request(names=names))
        return {f: v.bool_value for f, v in zip(features, answer.values, strict=True)}

    def state(self, node: str) -> str:
        from lifecycle_msgs.srv import GetState

        answer = self.call(GetState, f"{self.ns}/{node}/get_state", GetState.Request())
        return str(answer.current_state.label)

    def subscribe(self, kind: Any, topic: str, latched: bool = False) -> list[Any]:
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

        got: list[Any] = []
        qos: Any = 10
        if latched:
            qos = QoSProfile(
                depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
            )
        self.node.create_subscription(kind, topic, got.append, qos)
        return got

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2)
        self.node.destroy_node()
        self.context.try_shutdown()

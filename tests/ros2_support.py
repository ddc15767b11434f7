"""What the ROS 2 tests share: the marker, a graph of their own on loopback, node processes.

Every ROS 2 test module starts with `pytestmark = ROS2`. In the default `.venv` (no rclpy)
they are skipped, saying so; `make test` runs them again in `.venv-ros` with
MOTIVML_REQUIRE_ROS2=1, where a missing rclpy fails them instead of skipping them.

Traffic stays on this machine: discovery is limited to localhost, and each test takes a
ROS_DOMAIN_ID of its own (`domain()`), so that two tests, or a test and a developer's own
ROS graph, never see each other's nodes.
"""

from __future__ import annotations

import importlib.util
import itertools
import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
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

# Domain ids 0..101 are safe on Linux; start from the process id so that two test runs at
# once (a developer's and CI's) are unlikely to share one, and never reuse one in a run.
_domains = itertools.count()
_FIRST = 1 + os.getpid() % 50


def domain() -> int:
    """A ROS_DOMAIN_ID not used before in this test run."""
    value = _FIRST + next(_domains)
    if value > 101:
        raise RuntimeError("more ROS 2 tests than domain ids in one run")
    os.environ["ROS_DOMAIN_ID"] = str(value)
    return value


def environment(domain_id: int) -> dict[str, str]:
    """The environment of a process on the test's own graph."""
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["PYTHONUNBUFFERED"] = "1"
    return env


@contextmanager
def processes(domain_id: int) -> Iterator[list[subprocess.Popen[str]]]:
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

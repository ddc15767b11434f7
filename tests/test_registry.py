"""Plugin kinds behind one registry: a new kind is one loader and one registration."""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest
from paths import SIMPLEBOT

from motivml.documents.robot_folder import Plugin
from motivml.errors import Diagnostic
from motivml.plugins import registry
from motivml.plugins.api import PluginContext
from motivml.plugins.manifests import discover
from motivml.runtime import launch as launching
from motivml.runtime.requests import Swap


class Echo:
    """A plugin instance of the fake kind: records its life."""

    def __init__(self, feature: str, log: list[str], fail_start: bool) -> None:
        self.feature, self.log, self.fail_start = feature, log, fail_start

    def start(self) -> None:
        self.log.append(f"start {self.feature}")
        if self.fail_start:
            raise RuntimeError("no hardware")

    def step(self, time: float) -> None:
        pass

    def stop(self) -> None:
        self.log.append(f"stop {self.feature}")

    def status(self) -> str:
        return "echoing"


class FakeLoader:
    log: list[str] = []
    failing: set[str] = set()

    def __init__(self, robot: str, plugins: dict[str, Plugin]) -> None:
        self.plugins = plugins
        FakeLoader.log.append(f"loader for {sorted(plugins)}")

    def problems(self) -> list[Diagnostic]:
        return []

    def absent(self, features: list[str]) -> dict[str, str]:
        return {}

    def create(self, plugin: Plugin, context: PluginContext, fresh: bool) -> Any:
        assert plugin.feature in self.plugins and context.feature == plugin.feature
        return Echo(plugin.feature, FakeLoader.log, plugin.feature in FakeLoader.failing)

    def discard(self, instance: Any) -> None:
        FakeLoader.log.append(f"discard {instance.feature}")

    def activation(self, instance: Any) -> None:
        return None  # (an echo runs from its start() on)

    def close(self) -> None:
        FakeLoader.log.append("close")


@pytest.fixture
def fake_kind(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Register kind "echo" and make every SLAM plugin of SimpleBot one of it."""
    FakeLoader.log, FakeLoader.failing = [], set()
    kind = registry.Kind("echo", "module", path_is_file=False, loader=f"{__name__}:FakeLoader")
    monkeypatch.setitem(registry.KINDS, "echo", kind)

    def discover_as_echo(*args: Any) -> tuple[dict[str, Plugin], list[Diagnostic]]:
        plugins, problems = discover(*args)
        slam = {"hectorslam", "kartoslam", "orbslam"}
        return {
            f: dataclasses.replace(p, kind="echo") if f in slam else p for f, p in plugins.items()
        }, problems

    monkeypatch.setattr(launching, "discover", discover_as_echo)
    return FakeLoader.log


def test_a_registered_kind_loads_starts_swaps_and_closes_its_plugins(fake_kind: list[str]) -> None:
    robot = launching.launch(SIMPLEBOT, "field")
    try:
        assert fake_kind == ["loader for ['hectorslam', 'kartoslam', 'orbslam']", "start hectorslam"]
        assert robot.runtime.plugins["hectorslam"].instance.status() == "echoing"
        outcome = robot.binder.request_between_ticks(Swap("hectorslam", "kartoslam"))
        assert outcome.accepted
        assert fake_kind[-2:] == ["start kartoslam", "stop hectorslam"]
    finally:
        robot.close()
    assert fake_kind[-2:] == ["stop kartoslam", "close"]


def test_a_failed_start_is_discarded_by_its_loader_and_refused(fake_kind: list[str]) -> None:
    FakeLoader.failing = {"kartoslam"}
    robot = launching.launch(SIMPLEBOT, "field")
    try:
        outcome = robot.binder.request_between_ticks(Swap("hectorslam", "kartoslam"))
        assert not outcome.accepted and "start() of plugin kartoslam failed" in outcome.reason
        assert fake_kind[-2:] == ["start kartoslam", "discard kartoslam"]
        assert set(robot.runtime.plugins) == {"hectorslam"}
    finally:
        robot.close()


def test_only_the_kinds_in_use_get_a_loader() -> None:
    made = registry.loaders("robot", {})
    assert made == {}
    kinds = {k.name: (k.path_key, k.path_is_file) for k in registry.KINDS.values()}
    assert kinds == {"python": ("module", False), "cpp": ("library", True), "ros2_lifecycle": ("node", False)}


def test_entry_checks_come_from_the_kind() -> None:
    cpp, python = registry.KINDS["cpp"], registry.KINDS["python"]
    assert cpp.check_entry({"class": "A"}) == ((), "a cpp plugin's entry needs 'library'")
    assert cpp.check_entry({"library": "../x.so", "class": "A"}) == (
        ("library",),
        "library '../x.so' leaves the plugin folder",
    )
    assert python.check_entry({"module": "a.b", "class": "A"}) is None
    assert python.check_entry({"library": "x.so", "class": "A"}) == (
        (),
        "a python plugin's entry needs 'module'",
    )


@pytest.mark.parametrize(
    ("parameters", "problem"),
    [
        ({"gains": [1.0, 2.5], "names": ["a"], "on": [True], "n": -(2**63), "s": "x"}, None),
        (
            {"gains": [1, 2.5]},
            (
                ("parameters", "gains", 1),
                "parameter 'gains': a ROS 2 array holds one type, but item 1 is a double after an integer "
                "(write 1.0 for a double)",
            ),
        ),
        (
            {"flags": [True, 1]},
            (
                ("parameters", "flags", 1),
                "parameter 'flags': a ROS 2 array holds one type, but item 1 is an integer after a boolean",
            ),
        ),
        (
            {"names": []},
            (
                ("parameters", "names"),
                "parameter 'names': an empty array has no ROS 2 type (leave the parameter out)",
            ),
        ),
        (
            {"ticks": 2**63},
            (("parameters", "ticks"), f"parameter 'ticks': {2**63} does not fit a ROS 2 integer (64 bits)"),
        ),
        (
            {"motivml.feature": "x"},
            (
                ("parameters", "motivml.feature"),
                "parameter 'motivml.feature': names starting 'motivml.' are written by configure",
            ),
        ),
    ],
)
def test_ros2_parameters_are_what_ros_2_can_take(parameters: dict[str, object], problem: object) -> None:
    """ROS 2 parameters have one type each: arrays are homogeneous (booleans are not integers,
    integers not doubles) and not empty; integers have 64 bits."""
    lifecycle = registry.KINDS["ros2_lifecycle"]
    assert lifecycle.check_entry({"node": "lamp", "parameters": parameters}) == problem

"""ROS 2 options without ROS: names and namespaces, and what a run says when rclpy is missing.

These run in the default .venv, which has no rclpy (the ROS 2 wheels live in .venv-ros);
test_ros2.py drives a real ROS graph.
"""

from __future__ import annotations

import importlib.util
import json
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from click.testing import CliRunner

from motivml.cli import main
from motivml.plugins.ros2 import namespace, resolve_node

ROS = importlib.util.find_spec("rclpy") is not None


@pytest.mark.parametrize(
    ("given", "expected"),
    [("/", "/"), ("", "/"), ("uv", "/uv"), ("/uv/", "/uv"), ("/fleet/uv_2", "/fleet/uv_2")],
)
def test_a_namespace_is_made_absolute(given: str, expected: str) -> None:
    assert namespace(given) == expected


@pytest.mark.parametrize("given", ["/2uv", "/uv//x", "/u-v", "/uv x"])
def test_a_namespace_that_ros_refuses_is_refused(given: str) -> None:
    with pytest.raises(ValueError, match="is not a ROS namespace"):
        namespace(given)


def test_relative_node_names_resolve_in_the_namespace() -> None:
    assert resolve_node("lamp", "/uv") == "/uv/lamp"
    assert resolve_node("lamp", "/") == "/lamp"
    assert resolve_node("/other/lamp", "/uv") == "/other/lamp"


def _robot(folder: Path) -> Path:
    any_ = {
        "featuresIncluded": [],
        "featuresExcluded": [],
        "bindingTimeAllowed": "Any",
        "bindingModeAllowed": "Any",
    }
    model = {
        "id": "bot",
        "name": "Bot",
        "isMandatory": True,
        "isSelected": True,
        "sub": [{"id": "lamp", "name": "Lamp", "isMandatory": False, "constraints": any_}],
    }
    (folder / "variants").mkdir(parents=True)
    (folder / "model.json").write_text(json.dumps(model))
    (folder / "variants" / "v.json").write_text(
        json.dumps(
            {"properties": [{"id": "lamp", "selected": True, "props": {"time": "Early", "mode": "Dynamic"}}]}
        )
    )
    (folder / "robot.json").write_text(json.dumps({"pluginDirectories": ["plugins"]}))
    (folder / "plugins" / "lamp").mkdir(parents=True)
    (folder / "plugins" / "lamp" / "plugin.json").write_text(
        json.dumps({"feature": "lamp", "kind": "ros2_lifecycle", "entry": {"node": "lamp"}})
    )
    return folder


def test_a_bad_namespace_is_a_usage_error(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        main, ["run", str(_robot(tmp_path)), "--variant", "v", "--ros-namespace", "/2uv"]
    )
    assert result.exit_code == 2
    assert "'/2uv' is not a ROS namespace" in result.output


@pytest.mark.skipif(ROS, reason="this Python has rclpy")
def test_without_rclpy_a_lifecycle_plugin_says_how_to_install_it(tmp_path: Path) -> None:
    robot = _robot(tmp_path)
    result = CliRunner().invoke(
        main, ["run", str(robot), "--variant", "v", "--duration", "1", "--no-control"]
    )
    assert result.exit_code == 3, result.output
    manifest = robot / "plugins" / "lamp" / "plugin.json"
    assert f"{manifest}: $: error: lamp: plugins of kind ros2_lifecycle need ROS 2" in result.output
    assert "make ros2" in result.output and "Traceback" not in result.output


@pytest.mark.skipif(ROS, reason="this Python has rclpy")
def test_without_rclpy_run_ros2_says_how_to_install_it(tmp_path: Path) -> None:
    robot = tmp_path / "robot"
    _robot(robot)
    (robot / "robot.json").unlink()
    (robot / "architecture.json").write_text(json.dumps({"spaces": [], "modules": [], "components": []}))
    result = CliRunner().invoke(
        main, ["run", str(robot), "--variant", "v", "--duration", "1", "--no-control", "--ros2"]
    )
    assert result.exit_code == 3, result.output
    assert "ROS 2 is not available in this Python" in result.output and "make ros2" in result.output


def test_a_variant_without_ros_features_runs_without_rclpy(tmp_path: Path) -> None:
    """Only the plugins of the variant's selected features are loaded: a lifecycle node's
    manifest in the robot folder asks nothing of a variant that does not select its feature."""
    robot = _robot(tmp_path)
    (robot / "variants" / "v.json").write_text(
        json.dumps({"properties": [{"id": "lamp", "selected": False}]})
    )
    (robot / "architecture.json").write_text(json.dumps({"spaces": [], "modules": [], "components": []}))
    result = CliRunner().invoke(
        main,
        ["run", str(robot), "--variant", "v", "--duration", "0.01", "--clock", "simulated", "--no-control"],
    )
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize(
    ("given", "message"),
    [
        ("x", "'x' is not a list of CPUs such as 0, 2-3 or 0,2"),
        ("1-", "'1-' is not a list of CPUs"),
        ("4096", "CPUs 4096 are not among"),
        # issue 31: a range of millions took 23 s, 2.4 GB and a 190 MB message
        ("0-20000000", "CPU 20000000 is beyond the 8192 CPUs a process can be kept to"),
        ("\u00b2", "is not a list of CPUs"),  # (a digit to str.isdigit, not to int)
        ("1" * 80, "'" + "1" * 57 + "...' is not a list of CPUs"),
    ],
)
def test_cpus_that_cannot_be_had_are_a_usage_error(tmp_path: Path, given: str, message: str) -> None:
    result = CliRunner().invoke(main, ["run", str(_robot(tmp_path)), "--variant", "v", "--cpus", given])
    assert result.exit_code == 2 and message in result.output, result.output


def test_cpus_keep_the_run_to_them(tmp_path: Path) -> None:
    import os

    from motivml.plugins import bridge

    robot = _robot(tmp_path)
    (robot / "variants" / "v.json").write_text(
        json.dumps({"properties": [{"id": "lamp", "selected": False}]})
    )
    (robot / "architecture.json").write_text(json.dumps({"spaces": [], "modules": [], "components": []}))
    before = os.sched_getaffinity(0)
    first = min(before)
    try:
        result = CliRunner().invoke(
            main,
            [
                "run",
                str(robot),
                "--variant",
                "v",
                "--duration",
                "0.01",
                "--clock",
                "simulated",
                "--no-control",
            ]
            + ["--cpus", str(first)],
        )
        assert result.exit_code == 0, result.output
        assert os.sched_getaffinity(0) == {first}  # (CliRunner runs it in this process)
        # a ROS 2 bridge started from now on keeps to the other CPUs (none left: the run's)
        assert bridge.BRIDGE_CPUS == (frozenset(before - {first}) or None)
    finally:
        os.sched_setaffinity(0, before)
        bridge.BRIDGE_CPUS = None


def test_a_bridge_whose_run_is_gone_releases_every_node_the_run_moved_once() -> None:
    """The active nodes and those only configured (a load prepared, never committed: the run
    was killed between the two) go back to unconfigured, each by one instance: a node reloaded
    by a second instance by the one that activated it, never by both."""
    from motivml.ros2.lifecycle import LifecycleNodes

    stopped: list[str] = []

    class Instance:
        def __init__(self, name: str, node: str) -> None:
            self.name, self.node, self.watched = name, node, True

        def stop(self) -> None:
            assert not self.watched
            stopped.append(self.name)

    class Graph:
        node = type("Node", (), {"create_timer": lambda self, period, callback: None})()

    def released(owners: dict[str, Instance], instances: list[Instance]) -> list[str]:
        nodes = LifecycleNodes(Graph(), lambda message: None)  # type: ignore[arg-type]
        nodes.owners = owners  # type: ignore[assignment]
        nodes.instances = dict(enumerate(instances))  # type: ignore[arg-type]
        stopped.clear()
        nodes.release_all()
        return sorted(stopped)

    lamp, dosimeter = Instance("lamp", "/lamp"), Instance("dosimeter", "/dosimeter")
    camera, again = Instance("camera", "/camera"), Instance("camera, again", "/camera")
    # the reload committed: the new instance owns the node
    assert released({"/lamp": lamp, "/camera": again}, [lamp, dosimeter, camera, again]) == [
        "camera, again",
        "dosimeter",
        "lamp",
    ]
    # the reload prepared, never committed: the old one still owns it
    assert released({"/camera": camera}, [camera, again]) == ["camera"]


def test_a_bridge_whose_run_is_gone_lets_the_node_move_under_way_end_before_it_releases(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The link can break on another thread's write while the link's thread still moves a
    node; the release waits for that thread, or a node it starts would be configured after it."""
    import motivml.ros2.bridge as bridge

    done: list[str] = []

    class Nodes:
        def __init__(self, graph: object, tell: object) -> None:
            pass

        def release_all(self) -> None:
            done.append("release")

        def close(self) -> None:
            done.append("close")

    class Graph:
        def __init__(self, namespace: str) -> None:
            pass

        def close(self) -> None:
            pass

    class Link:
        def send(self, message: dict[str, object]) -> None:
            pass

        def join_reader(self) -> None:
            done.append("join")

        def close(self) -> None:
            pass

    monkeypatch.setattr(bridge, "Graph", Graph)
    monkeypatch.setattr(bridge, "LifecycleNodes", Nodes)
    server = object.__new__(bridge.Server)
    server.namespace, server.asked_to_exit, server.door = "/", False, None
    server.ended = threading.Event()
    server.worker = ThreadPoolExecutor(max_workers=1)
    server.link = Link()  # type: ignore[assignment]
    server.ended.set()  # (the run has gone)
    assert server.run() == 0
    assert done == ["join", "release", "close"]
    server.asked_to_exit, done[:] = True, []  # the run asked the bridge to end: nothing to release
    server.worker = ThreadPoolExecutor(max_workers=1)
    server.ended.set()
    assert server.run() == 0
    assert done == ["close"]

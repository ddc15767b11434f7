"""Dynamic binding in a running robot: plugins in and out as checked, atomic transactions."""

from __future__ import annotations

import contextlib
import json
import shutil
import sys
import threading
import time
import types
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from binder_sync import HANG_GUARD, Handover, ask
from click.testing import CliRunner
from helpers import config, feature
from paths import ROOT

from motivml.cli import main
from motivml.errors import DocumentError
from motivml.plugins.python import PluginError
from motivml.runtime.events import Answered, Logged, RunEvent
from motivml.runtime.launch import Robot, launch
from motivml.runtime.loop import RealClock
from motivml.runtime.requests import Load, Swap

DL = ("Late", "Dynamic")
ANY = {"time": "Any", "mode": "Any"}


@pytest.fixture
def simplebot() -> Iterator[Robot]:
    robot = launch(ROOT / "feature_models" / "simplebot", "field")
    yield robot
    robot.close()


def test_slam_alternatives_swap_while_the_robot_drives(simplebot: Robot) -> None:
    runtime = simplebot.runtime
    assert set(runtime.plugins) == {"hectorslam"}
    runtime.run(2.0)
    before = runtime.assembly.values["PoseEstimate"].copy()
    outcome = ask(simplebot, "swap hectorslam kartoslam")
    assert outcome.accepted, outcome.reason
    assert set(runtime.plugins) == {"kartoslam"} and simplebot.binder.active >= {"slam", "kartoslam"}
    change = runtime.changes[-1]
    assert change.request == "swap hectorslam kartoslam" and change.loads == ("kartoslam",)
    assert change.unloads == ("hectorslam",) and change.tick >= 2000
    # Karto continues from Hector's pose and goes on estimating from the base's motion.
    runtime.run(1.0)
    after = runtime.assembly.values["PoseEstimate"]
    assert np.linalg.norm(after[:2] - before[:2]) > 0.1
    assert np.linalg.norm(after[:2] - before[:2]) < 1.0  # no jump back to the origin


def test_a_refused_request_says_why_and_changes_nothing(simplebot: Robot) -> None:
    outcome = ask(simplebot, "load kartoslam")
    assert not outcome.accepted
    assert outcome.reason.startswith("hectorslam and kartoslam are alternatives in slam's XOR group")
    assert set(simplebot.runtime.plugins) == {"hectorslam"} and simplebot.runtime.changes == []
    static = ask(simplebot, "unload grid_map")
    assert "grid_map is bound Static Early: a Static feature never unloads" in static.reason


def test_unloading_slam_unloads_its_subtree_and_its_space(simplebot: Robot) -> None:
    outcome = ask(simplebot, "unload slam")
    assert outcome.accepted and outcome.plan is not None
    assert outcome.plan.unloads == ("hectorslam", "slam")
    assert simplebot.runtime.plugins == {} and "PoseEstimate" not in simplebot.runtime.assembly.values
    back = ask(simplebot, "load slam orbslam")
    assert back.accepted and set(simplebot.runtime.plugins) == {"orbslam"}
    assert "PoseEstimate" in simplebot.runtime.assembly.values


# ------------------------------------------------------------- robots made in the test
PLUGIN = """
from motivml.plugins.api import FeaturePlugin

class Plugin(FeaturePlugin):
    VERSION = 1
    def start(self):
        {start}
        self.steps = 0
    def step(self, time):
        {step}
        self.steps += 1
        self.context.write("Out", [self.VERSION])
    def status(self):
        return f"version {{self.VERSION}}, {{self.steps}} steps"
"""


def make_robot(tmp_path: Path, plugins: dict[str, dict[str, str]], static: tuple[str, ...] = ()) -> Path:
    """Features a and b (XOR, under alt) and d, each with a plugin; `static` ones bound Static
    Early (then b is left out: XOR members are both selected only as Dynamic alternatives)."""
    model = feature(
        "bot",
        [
            feature(
                "alt",
                [feature("a", group="XOR", **ANY), feature("b", group="XOR", **ANY)],
                isMandatory=False,
                **ANY,
            ),
            feature("d", isMandatory=False, **ANY),
        ],
    )
    binding = {f: (("Early", "Static") if f in static else DL) for f in ("alt", "a", "b", "d")}
    binding["alt"] = ("Early", "Static") if "alt" in static else ("Early", "Dynamic")
    entries = [(f, False) if f == "b" and static else (f, *b) for f, b in binding.items()]
    sources = {
        name: PLUGIN.format(start=code.get("start", "pass"), step=code.get("step", "pass"))
        for name, code in plugins.items()
    }
    return write_robot(tmp_path, model, entries, sources, "mod")


def write_robot(
    tmp_path: Path, model: dict[str, Any], entries: Any, sources: dict[str, str], prefix: str
) -> Path:
    """A robot folder: the model, variant v, one Out space, and a Python plugin per source."""
    (tmp_path / "variants").mkdir(parents=True)
    (tmp_path / "model.json").write_text(json.dumps(model, indent=1))
    (tmp_path / "variants" / "v.json").write_text(json.dumps(config(*entries), indent=1))
    (tmp_path / "robot.json").write_text(json.dumps({"pluginDirectories": ["plugins"]}))
    architecture = {"spaces": [{"id": "Out", "type": "Scalar", "dimension": 1, "feature": "bot"}]}
    (tmp_path / "architecture.json").write_text(json.dumps(architecture))
    for name, text in sources.items():
        folder = tmp_path / "plugins" / name
        folder.mkdir(parents=True)
        manifest = {
            "feature": name,
            "kind": "python",
            "entry": {"module": f"{prefix}_{name}", "class": "Plugin"},
        }
        (folder / "plugin.json").write_text(json.dumps(manifest, indent=1))
        (folder / f"{prefix}_{name}.py").write_text(text)
    return tmp_path


def test_a_failing_start_in_a_swap_leaves_the_previous_set_running(tmp_path: Path) -> None:
    folder = make_robot(tmp_path, {"a": {}, "b": {"start": "raise RuntimeError('no camera')"}, "d": {}})
    robot = launch(folder, "v")
    try:
        assert set(robot.runtime.plugins) == {"a"}
        outcome = ask(robot, "swap a b")
        assert not outcome.accepted
        assert outcome.reason == "start() of plugin b failed: RuntimeError: no camera (at mod_b.py:7)"
        assert outcome.diagnostics[0].location.path == "$.entry.class"
        assert str(outcome.diagnostics[0].location).startswith(str(folder / "plugins" / "b" / "plugin.json"))
        assert set(robot.runtime.plugins) == {"a"} and robot.binder.active >= {"alt", "a"}
        steps = robot.runtime.plugins["a"].instance.steps
        robot.runtime.run(0.01)
        assert robot.runtime.plugins["a"].instance.steps == steps + 10 and robot.runtime.changes == []
    finally:
        robot.close()


def test_only_kinds_with_an_activation_step_are_activated(tmp_path: Path) -> None:
    """A Python plugin runs from its start() on: methods of its own named activate and
    deactivate are its business, not called at a commit (only a kind's loader gives an
    activation step: ROS 2 lifecycle nodes, tests/test_ros2.py)."""
    folder = make_robot(tmp_path, {"a": {}, "b": {}})
    for name in ("a", "b"):
        with (folder / "plugins" / name / f"mod_{name}.py").open("a") as module:
            module.write("\ndef _moved(self):\n    raise RuntimeError('not to be called')\n")
            module.write("Plugin.activate = Plugin.deactivate = _moved\n")
    robot = launch(folder, "v")
    try:
        assert robot.runtime.plugins["a"].activation is None
        outcome = ask(robot, "swap a b")
        assert outcome.accepted, outcome.reason
        assert set(robot.runtime.plugins) == {"b"} and robot.runtime.plugins["b"].activation is None
    finally:
        robot.close()


def test_a_dynamic_plugin_that_raises_is_unloaded_and_the_loop_goes_on(tmp_path: Path) -> None:
    folder = make_robot(
        tmp_path, {"a": {"step": "if self.steps == 5: raise ValueError('lost track')"}, "d": {}}
    )
    robot = launch(folder, "v")
    try:
        assert ask(robot, "load d").accepted
        with Handover(robot) as handover:
            for _ in range(10):  # a raises in its 6th step
                robot.runtime.tick()
                if robot.runtime.faults:
                    break
            assert robot.runtime.faults
            # the binder's worker unloads a's feature: a change handed to the loop...
            assert handover.handed.wait(HANG_GUARD)
            robot.runtime.tick()  # ... committed by the next tick, then noted
            assert handover.wait_for_note(
                lambda text: "after the fault of a" in text or "after its fault" in text
            )
        fault = robot.runtime.faults[0]
        assert (fault.feature, fault.static) == ("a", False)
        assert fault.error == "ValueError: lost track (at mod_a.py:10)"
        # a is the only active member of alt's XOR group, so alt goes with it
        assert robot.binder.active == {"bot", "d"} and set(robot.runtime.plugins) == {"d"}
        assert any("unloaded alt after the fault of a" in text for _, _, text in robot.runtime.notes)
        steps = robot.runtime.plugins["d"].instance.steps
        robot.runtime.run(0.01)
        assert robot.runtime.failure is None and robot.runtime.plugins["d"].instance.steps == steps + 10
    finally:
        robot.close()


def test_a_static_plugin_that_raises_stops_the_run_with_a_report(tmp_path: Path) -> None:
    folder = make_robot(tmp_path, {"a": {"step": "raise KeyError('calibration')"}}, static=("alt", "a"))
    result = CliRunner().invoke(
        main, ["run", str(folder), "--variant", "v", "--duration", "1", "--clock", "simulated"]
    )
    assert result.exit_code == 1, result.output
    assert (
        "the run stopped: a raised in its step at 0.001 s (tick 1): KeyError: 'calibration' (at mod_a.py:10)"
        in result.output
    )
    assert result.output.splitlines()[-2].startswith("1 ticks")


def test_reload_picks_up_edited_code_without_a_restart(tmp_path: Path) -> None:
    folder = make_robot(tmp_path, {"a": {}})
    robot = launch(folder, "v")
    try:
        robot.runtime.run(0.01)
        assert robot.runtime.assembly.values["Out"][0] == 1.0
        module = folder / "plugins" / "a" / "mod_a.py"
        module.write_text(module.read_text().replace("VERSION = 1", "VERSION = 2"))
        outcome = ask(robot, "reload a")
        assert outcome.accepted and outcome.plan is not None and outcome.plan.after == outcome.plan.before
        robot.runtime.run(0.01)
        assert robot.runtime.assembly.values["Out"][0] == 2.0
        assert robot.runtime.plugins["a"].instance.status().startswith("version 2, ")
    finally:
        robot.close()


def test_plugins_that_cannot_load_are_reported_with_their_manifest(tmp_path: Path) -> None:
    folder = make_robot(tmp_path, {"a": {}})
    (folder / "plugins" / "a" / "mod_a.py").write_text("import nonexistent_dependency\n")
    with pytest.raises(PluginError) as caught:
        launch(folder, "v")
    [problem] = caught.value.diagnostics
    assert problem.location.path == "$.entry.module"
    assert problem.message == (
        "cannot import 'mod_a' of plugin a: ModuleNotFoundError: No module named 'nonexistent_dependency' (at mod_a.py:1)"
    )
    (folder / "plugins" / "a" / "mod_a.py").write_text("class Other:\n    pass\n")
    with pytest.raises(PluginError) as caught:
        launch(folder, "v")
    assert caught.value.diagnostics[0].message == "module 'mod_a' has no class 'Plugin' (its classes: Other)"
    result = CliRunner().invoke(main, ["run", str(folder), "--variant", "v", "--clock", "simulated"])
    assert result.exit_code == 3 and "has no class 'Plugin'" in result.output


@pytest.mark.parametrize("linked", ["file", "package"])
def test_an_entry_module_linked_from_outside_the_plugin_folder_is_refused(
    tmp_path: Path, linked: str
) -> None:
    folder = lifecycle_robot(tmp_path / "robot", {"a": {}, "a2": {}}, entries=LATE_A2)
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    module = folder / "plugins" / "a2" / "life_a2.py"
    if linked == "file":
        module.rename(outside / "life_a2.py")
        module.symlink_to(outside / "life_a2.py")
    else:
        (outside / "__init__.py").write_text(module.read_text())
        module.unlink()
        (folder / "plugins" / "a2" / "life_a2").symlink_to(outside)
    robot = launch(folder, "v")
    try:
        outcome = ask(robot, "load a2")
        assert not outcome.accepted
        assert outcome.reason == "module 'life_a2' leaves the plugin folder (a link)"
        assert outcome.diagnostics[0].location.path == "$.entry.module"
        assert set(robot.runtime.plugins) == {"a"}
    finally:
        robot.close()


def test_two_plugins_with_one_module_name_are_refused(tmp_path: Path) -> None:
    folder = make_robot(tmp_path, {"a": {}, "b": {}})
    manifest = folder / "plugins" / "b" / "plugin.json"
    manifest.write_text(manifest.read_text().replace("mod_b", "mod_a"))
    shutil.copy(folder / "plugins" / "a" / "mod_a.py", folder / "plugins" / "b" / "mod_a.py")
    with pytest.raises(DocumentError) as caught:  # an invalid manifest: validate says so too
        launch(folder, "v")
    assert "module 'mod_a' is also the entry of" in caught.value.diagnostics[0].message
    result = CliRunner().invoke(main, ["validate", str(folder)])
    assert result.exit_code == 1 and "module 'mod_a' is also the entry of" in result.output


@contextlib.contextmanager
def held_start(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[Any, Robot, Callable[[int], None]]]:
    """A robot (a, b, d) on the real clock in a thread of its own, whose d's start() holds
    until `gate.release` is set; `after(n)` returns once n more ticks have run. Events, not
    durations: nothing depends on how fast the machine is."""
    gate = types.ModuleType("motivml_test_gate")
    gate.started, gate.release = threading.Event(), threading.Event()  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, gate.__name__, gate)
    hold = "import motivml_test_gate as gate; gate.started.set(); gate.release.wait(30)"
    robot = launch(make_robot(tmp_path, {"a": {}, "b": {}, "d": {"start": hold}}), "v")
    runtime = robot.runtime
    target: list[int] = []
    ticked = threading.Event()
    runtime.after_each_tick(lambda: ticked.set() if target and runtime.ticks >= target[0] else None)
    loop = threading.Thread(target=runtime.run, args=(60.0, RealClock()))

    def after(ticks: int) -> None:
        target[:] = [runtime.ticks + ticks]
        assert ticked.wait(HANG_GUARD)

    try:
        loop.start()
        yield gate, robot, after
    finally:
        gate.release.set()
        runtime.stop()
        loop.join(HANG_GUARD)
        robot.close()
    assert not loop.is_alive()


def test_the_loop_keeps_ticking_while_a_plugin_prepares(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """d's start() holds until the test lets it go: meanwhile the loop goes on ticking and
    the request stays pending; then the change commits at a later tick."""
    with held_start(tmp_path, monkeypatch) as (gate, robot, after):
        future = robot.binder.submit(Load(("d",)), timeout=None)
        assert gate.started.wait(HANG_GUARD)  # d is being prepared, on the binder's thread
        fifty = robot.runtime.ticks + 50
        after(50)
        assert not future.done() and "d" not in robot.runtime.plugins  # ... d is still being prepared
        gate.release.set()
        outcome = future.result(HANG_GUARD)
        assert outcome.accepted and outcome.change is not None and outcome.change.tick >= fifty
        assert "d" in robot.runtime.plugins


def test_a_requests_latency_counts_the_time_it_waited_behind_another(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 31: ctl reported a change's latency from when the binder took it up, not from
    when it arrived: a request that waited behind another's slow start() said 2 ms. The
    second request here arrives while the first is held and commits after the first: its
    latency is at least the time from its arrival to the first one's commit."""
    with held_start(tmp_path, monkeypatch) as (gate, robot, after):
        first = robot.binder.submit(Load(("d",)), timeout=None)
        assert gate.started.wait(HANG_GUARD)  # d is being prepared, holding the binder
        second = robot.binder.submit(Swap("a", "b"), timeout=None)
        arrived_by = time.perf_counter()
        after(20)  # twenty ticks of waiting behind the first
        gate.release.set()
        one, two = first.result(HANG_GUARD), second.result(HANG_GUARD)
        assert one.accepted and two.accepted and one.change is not None and two.change is not None
        assert two.change.clock >= one.change.clock
        assert two.latency >= one.change.clock - arrived_by > 0


def test_scheduled_requests_make_a_deterministic_session() -> None:
    args = ["run", str(ROOT / "feature_models" / "simplebot"), "--variant", "field", "--duration", "3"]
    args += [
        "--clock",
        "simulated",
        "--no-control",
        "--at",
        "1",
        "load kartoslam",
        "--at",
        "2",
        "swap hectorslam kartoslam",
    ]
    first, second = (CliRunner().invoke(main, args) for _ in range(2))
    assert first.exit_code == 0, first.output
    assert first.output == second.output
    lines = first.output.splitlines()
    assert lines[1].startswith("at 1.000 s (tick 1000): refused load kartoslam: hectorslam and kartoslam")
    assert lines[2] == "request at 1.000 s (tick 1000): load kartoslam: refused, nothing changed"
    assert "error: hectorslam and kartoslam are alternatives in slam's XOR group" in lines[3]
    assert "request at 2.000 s (tick 2000): swap hectorslam kartoslam: accepted" in lines
    assert "changed at 2.000 s (tick 2000): swap hectorslam kartoslam" in lines
    bad = CliRunner().invoke(main, [*args[:8], "--at", "1", "explode kartoslam"])
    assert (
        bad.exit_code == 2
        and "a request is load|unload|reload FEATURE..., swap OUT IN, or event NAME" in bad.output
    )


def test_the_arms_motion_primitive_is_swapped_while_the_arm_moves() -> None:
    robot = launch(ROOT / "feature_models" / "reaching_arm", "swappable")
    try:
        assert [c.id for c in robot.assembly.components] == ["DMPReacher"]
        path = []
        for _ in range(600):
            robot.runtime.tick()
            path.append(robot.assembly.values["ArmCommand"].copy())
        moving = np.linalg.norm(path[-1] - path[-11]) * robot.runtime.rate / 10  # rad/s (it steps at 500 Hz)
        assert moving > 0.1  # mid-reach
        outcome = ask(robot, "swap dmp_reach attractor_reach")
        assert outcome.accepted and [c.id for c in robot.assembly.components] == ["AttractorReacher"]
        robot.runtime.tick()
        step = np.linalg.norm(robot.assembly.values["ArmCommand"] - path[-1])
        assert step < 0.01  # the new primitive starts where the arm is: no jump
        robot.runtime.run(2.0)
        assert np.allclose(robot.assembly.values["ArmCommand"], robot.assembly.values["ArmGoal"], atol=0.01)
        assert robot.runtime.first("AttractorReacher", "converged") is not None
    finally:
        robot.close()


# ------------------------------------------------------------------ review findings
def test_a_feature_named_twice_counts_once_and_swap_needs_two(tmp_path: Path) -> None:
    folder = make_robot(tmp_path, {"a": {}, "b": {}})
    robot = launch(folder, "v")
    try:
        same = ask(robot, "swap a a")
        assert not same.accepted and "swap takes two different features" in same.reason
        twice = ask(robot, "reload a a")
        assert twice.accepted and twice.plan is not None and twice.plan.loads == ("a",)
        assert set(robot.runtime.plugins) == {"a"}
    finally:
        robot.close()


def test_writes_in_start_wait_for_the_commit(tmp_path: Path) -> None:
    quiet = "return  # writes nothing when it steps"
    folder = make_robot(
        tmp_path,
        {
            "a": {"step": quiet},
            "b": {"step": quiet, "start": "self.context.write('Out', [7.0]); raise OSError('no device')"},
            "d": {"step": quiet, "start": "self.context.write('Out', [42.0])"},
        },
    )
    robot = launch(folder, "v")
    try:
        robot.runtime.run(0.01)
        refused = ask(robot, "swap a b")
        assert not refused.accepted and robot.runtime.assembly.values["Out"][0] == 0.0  # b's write is gone
        assert ask(robot, "load d").accepted
        assert robot.runtime.assembly.values["Out"][0] == 42.0  # d's write, applied at the commit
    finally:
        robot.close()


def test_the_start_state_holds_writes_back_while_its_plugins_activate(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Writes made while the start state's plugins activate (a ROS 2 node takes seconds)
    wait with those made in start() and come after them, in order: a plugin that wrote 1
    in start() and 2 while activating starts with 2 in its space, not 1 written over it."""
    from motivml.plugins.python import PythonPlugins

    class Activation:
        def __init__(self, instance: Any) -> None:
            self.instance = instance

        def activate(self) -> None:
            self.instance.context.write("Out", [2.0])

        def deactivate(self) -> None:
            pass

    monkeypatch.setattr(PythonPlugins, "activation", lambda self, instance: Activation(instance))
    folder = make_robot(tmp_path, {"a": {"start": "self.context.write('Out', [1.0])", "step": "return"}})
    robot = launch(folder, "v")
    try:
        assert robot.runtime.assembly.values["Out"][0] == 2.0
    finally:
        robot.close()


def test_a_plugins_status_runs_outside_the_runtimes_lock(tmp_path: Path) -> None:
    """A plugin's status() (the live view asks four times a second, ctl status too) runs
    after the runtime's lock is released: a slow one never holds up a commit or a tick."""
    folder = make_robot(tmp_path, {"a": {}})
    robot = launch(folder, "v")
    try:
        held: list[bool] = []
        instance = robot.runtime.plugins["a"].instance
        instance.status = lambda: held.append(robot.runtime._lock.locked()) or "fine"
        assert dict(robot.runtime.status().plugins)["a"] == "fine" and held == [False]
    finally:
        robot.close()


def test_a_fault_during_a_scripted_simulated_run_is_handled_between_ticks(tmp_path: Path) -> None:
    folder = make_robot(
        tmp_path, {"a": {"step": "if self.steps == 3: raise ValueError('lost track')"}, "d": {}}
    )
    result = CliRunner().invoke(
        main,
        [
            "run",
            str(folder),
            "--variant",
            "v",
            "--duration",
            "0.5",
            "--clock",
            "simulated",
            "--no-control",
            "--at",
            "0.002",
            "load d",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "did not take the change" not in result.output  # no waiting for a tick that cannot come
    assert "at 0.004 s (tick 4): unloaded alt after the fault of a" in result.output
    assert "plugin d: version 1, 498 steps" in result.output  # from the tick after its commit


def test_reloading_a_cpp_plugin_completes(tmp_path: Path) -> None:
    import subprocess
    import sys

    pytest.importorskip("motivml._cpp_plugins", reason="make cpp-plugins builds the C++ plugin extension")
    command = [
        sys.executable,
        "-m",
        "motivml.cli",
        "run",
        str(ROOT / "feature_models" / "simplebot"),
        "--variant",
        "field",
    ]
    command += ["--duration", "3", "--clock", "simulated", "--no-control"]
    command += ["--at", "1", "load gesture_recognition hands", "--at", "2", "reload hands"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "request at 2.000 s (tick 2000): reload hands: accepted" in done.stdout
    assert "plugin hands: 1 hand gesture, last: stop" in done.stdout  # the new instance counts from its start


def test_scheduled_times_must_fall_in_the_run() -> None:
    base = [
        "run",
        str(ROOT / "feature_models" / "simplebot"),
        "--variant",
        "field",
        "--duration",
        "1",
        "--clock",
        "simulated",
    ]
    for at in ("5", "nan", "inf"):
        result = CliRunner().invoke(main, [*base, "--at", at, "load kartoslam"])
        assert result.exit_code == 2 and "requests are made during the run" in result.output


# ------------------------------------------- plugins that leave, fail or wait (coverage)
LIFECYCLE = """
from motivml.plugins.api import FeaturePlugin

class Plugin(FeaturePlugin):
    def start(self):
        self.steps, self.stopped = 0, False
        {start}
    def step(self, time):
        if self.stopped:
            self.context.log("stepped after stop()")
        self.steps += 1
        {step}
    def stop(self):
        self.stopped = True
        self.context.log("stop()")
        {stop}
    def status(self):
        return f"{{self.steps}} steps"
"""


def lifecycle_robot(
    tmp_path: Path,
    plugins: dict[str, dict[str, str]],
    model: dict[str, Any] | None = None,
    entries: tuple[tuple[Any, ...], ...] = (("a", "Early", "Dynamic"), ("a2", "Early", "Dynamic")),
) -> Path:
    """By default a (optional) with a2 (optional) under it, both Dynamic Early, so both run from
    the start; each plugin says in the run's log when it is stopped, and if it is stepped after."""
    model = model or feature(
        "bot", [feature("a", [feature("a2", isMandatory=False, **ANY)], isMandatory=False, **ANY)]
    )
    sources = {
        name: LIFECYCLE.format(**{k: code.get(k, "pass") for k in ("start", "step", "stop")})
        for name, code in plugins.items()
    }
    return write_robot(tmp_path, model, entries, sources, "life")


def simulated_run(folder: Path, *extra: str, duration: str = "0.01") -> Any:
    args = [
        "run",
        str(folder),
        "--variant",
        "v",
        "--duration",
        duration,
        "--clock",
        "simulated",
        "--no-control",
    ]
    return CliRunner().invoke(main, [*args, *extra])


def test_a_plugin_unloaded_by_a_fault_between_ticks_is_not_stepped_after_its_stop(tmp_path: Path) -> None:
    folder = lifecycle_robot(
        tmp_path, {"a": {"step": "if self.steps == 3: raise ValueError('lost track')"}, "a2": {}}
    )
    result = simulated_run(folder)
    assert result.exit_code == 0, result.output
    assert "at 0.003 s (tick 3): unloaded a after the fault of a" in result.output
    assert "at 0.003 s (tick 3): a2: stop()" in result.output  # a2 went with its parent's subtree
    assert "stepped after stop()" not in result.output
    assert "a2 raised" not in result.output


def test_a_dynamic_fault_in_the_last_tick_neither_holds_the_close_nor_fails_the_run(tmp_path: Path) -> None:
    # on the real clock the fault's unload waits for the next tick; when the run ends first,
    # no tick will come: closing the robot must not wait for it, nor call the run a failure
    folder = lifecycle_robot(tmp_path, {"a": {"step": "if self.steps == 3: raise ValueError('lost track')"}})
    robot = launch(folder, "v")
    for _ in range(3):
        robot.runtime.tick()  # the last tick of the run: a faults
    assert [f.feature for f in robot.runtime.faults] == ["a"]
    robot.close()  # the run's end
    assert robot.runtime.failure is None and robot.runtime.changes == []
    assert not robot.runtime.stop_requested.is_set()
    log = [text for _, _, text in robot.runtime.notes]
    assert "the fault of a: the run ended before its unload" in log and "a: stop()" in log
    assert not any("cannot unload" in text for text in log)


LATE_A2 = (("a", "Early", "Dynamic"), ("a2", "Late", "Dynamic"))  # a runs from the start, a2 loads


def test_writes_in_start_at_launch_reach_the_spaces(tmp_path: Path) -> None:
    folder = lifecycle_robot(tmp_path, {"a": {"start": "self.context.write('Out', [5.0])"}})
    robot = launch(folder, "v")
    try:
        assert robot.runtime.assembly.values["Out"][0] == 5.0
    finally:
        robot.close()


def test_a_write_in_start_to_a_space_the_plugin_may_not_write_refuses_the_load(tmp_path: Path) -> None:
    folder = lifecycle_robot(
        tmp_path, {"a": {}, "a2": {"start": "self.context.write('Nowhere', [1.0])"}}, entries=LATE_A2
    )
    robot = launch(folder, "v")
    try:
        outcome = ask(robot, "load a2")
        assert not outcome.accepted
        assert outcome.reason == (
            "start() of plugin a2 failed: ValueError: Nowhere is not a space this plugin may write (at life_a2.py:7)"
        )
        assert set(robot.runtime.plugins) == {"a"} and robot.runtime.changes == []
    finally:
        robot.close()


def test_a_failing_start_stops_the_plugins_the_same_request_started(tmp_path: Path) -> None:
    entries = (("a", "Late", "Dynamic"), ("a2", "Late", "Dynamic"))
    folder = lifecycle_robot(
        tmp_path, {"a": {}, "a2": {"start": "raise OSError('no camera')"}}, entries=entries
    )
    robot = launch(folder, "v")
    try:
        assert robot.runtime.plugins == {}
        outcome = ask(robot, "load a a2")
        assert not outcome.accepted and outcome.reason.startswith(
            "start() of plugin a2 failed: OSError: no camera"
        )
        assert [text for _, _, text in robot.runtime.notes] == [
            "a: stop()",  # a had started: stopped again
            "refused load a a2: start() of plugin a2 failed: OSError: no camera (at life_a2.py:7)",
        ]
        assert robot.runtime.plugins == {} and robot.binder.active == {"bot"}
    finally:
        robot.close()


def test_ctrl_c_in_a_plugins_start_stops_the_started_ones_and_says_so(tmp_path: Path) -> None:
    # a real Ctrl-C (SIGINT to the process) while a2 starts; a KeyboardInterrupt a plugin
    # raises by itself is its fault instead (test_a_plugin_that_raises_a_base_exception...)
    stopped = "(self.context.folder / 'stopped').write_text('yes')"
    ctrl_c = "import os, signal; os.kill(os.getpid(), signal.SIGINT)"
    folder = lifecycle_robot(tmp_path, {"a": {"stop": stopped}, "a2": {"start": ctrl_c}})
    result = simulated_run(folder)
    assert result.exit_code == 130 and "interrupted before the run started" in result.output
    assert (folder / "plugins" / "a" / "stopped").read_text() == "yes"  # a had started before a2


# ------------------------- SystemExit, KeyboardInterrupt, GeneratorExit: the plugin's fault
BASE_EXCEPTIONS = {
    "SystemExit": "raise SystemExit(7)",  # 7: no exit code of motivml's, so an exit with it shows
    "KeyboardInterrupt": "raise KeyboardInterrupt('from the plugin')",
    "GeneratorExit": "raise GeneratorExit('from the plugin')",
}


def base_exception_robot(
    tmp_path: Path, where: str, kind: str, entries: tuple[tuple[Any, ...], ...] = LATE_A2
) -> Path:
    """lifecycle_robot, with a2 raising `kind` in `where`: import, constructor, start, step or stop."""
    raising = BASE_EXCEPTIONS[kind]
    code = {where: raising} if where in ("start", "step", "stop") else {}
    folder = lifecycle_robot(tmp_path, {"a": {}, "a2": code}, entries=entries)
    module = folder / "plugins" / "a2" / "life_a2.py"
    text = module.read_text()
    if where == "import":
        text += f"\n{raising}\n"
    elif where == "constructor":
        text += f"\n    def __init__(self, context):\n        {raising}\n"
    module.write_text(text)
    return folder


@pytest.mark.parametrize("kind", BASE_EXCEPTIONS)
@pytest.mark.parametrize("where", ["import", "constructor", "start"])
def test_a_plugin_that_raises_a_base_exception_while_loading_is_refused(
    tmp_path: Path, where: str, kind: str
) -> None:
    robot = launch(base_exception_robot(tmp_path, where, kind), "v")
    try:
        outcome = ask(robot, "load a2")
        assert not outcome.accepted and "plugin a2" in outcome.reason and kind in outcome.reason
        assert "(at life_a2.py:" in outcome.reason  # located in the plugin
        assert set(robot.runtime.plugins) == {"a"} and "a2" not in robot.binder.active
        robot.runtime.run(0.01)
        assert robot.runtime.plugins["a"].instance.steps == 10
    finally:
        robot.close()


@pytest.mark.parametrize("kind", BASE_EXCEPTIONS)
@pytest.mark.parametrize("where", ["import", "constructor", "start"])
def test_a_plugin_that_raises_a_base_exception_at_launch_is_a_located_launch_error(
    tmp_path: Path, where: str, kind: str
) -> None:
    folder = base_exception_robot(
        tmp_path, where, kind, entries=(("a", "Early", "Dynamic"), ("a2", "Early", "Dynamic"))
    )
    result = simulated_run(folder)
    assert result.exit_code == 3, result.output  # a plugin that cannot start: never the plugin's 7
    assert isinstance(result.exception, SystemExit)
    assert "plugin a2" in result.output and kind in result.output and "cannot run" in result.output
    assert "interrupted" not in result.output and "Traceback" not in result.output


@pytest.mark.parametrize("kind", BASE_EXCEPTIONS)
def test_a_dynamic_plugin_that_raises_a_base_exception_in_step_is_unloaded(tmp_path: Path, kind: str) -> None:
    folder = base_exception_robot(
        tmp_path, "step", kind, entries=(("a", "Early", "Dynamic"), ("a2", "Early", "Dynamic"))
    )
    result = simulated_run(folder)
    assert result.exit_code == 0, result.output
    assert f"at 0.001 s (tick 1): a2 raised in step: {kind}: " in result.output
    assert "at 0.001 s (tick 1): unloaded a2 after the fault of a2" in result.output
    assert "plugin a: 10 steps" in result.output and "\n10 ticks, 0.010 s of control time\n" in result.output


@pytest.mark.parametrize("kind", BASE_EXCEPTIONS)
def test_a_static_plugin_that_raises_a_base_exception_in_step_stops_the_run(
    tmp_path: Path, kind: str
) -> None:
    folder = make_robot(tmp_path, {"a": {"step": BASE_EXCEPTIONS[kind]}}, static=("alt", "a"))
    result = simulated_run(folder)
    assert result.exit_code == 1, result.output
    assert f"the run stopped: a raised in its step at 0.001 s (tick 1): {kind}: " in result.output


@pytest.mark.parametrize("kind", BASE_EXCEPTIONS)
def test_a_base_exception_in_stop_is_noted_and_the_unload_goes_through(tmp_path: Path, kind: str) -> None:
    folder = base_exception_robot(
        tmp_path, "stop", kind, entries=(("a", "Early", "Dynamic"), ("a2", "Early", "Dynamic"))
    )
    robot = launch(folder, "v")
    try:
        outcome = ask(robot, "unload a2")
        assert outcome.accepted and set(robot.runtime.plugins) == {"a"}
        assert robot.runtime.notes[-1][2].startswith(f"stop() of plugin a2 raised {kind}: ")
    finally:
        robot.close()


def test_a_stop_that_raises_is_reported_and_the_unload_goes_through(tmp_path: Path) -> None:
    folder = lifecycle_robot(tmp_path, {"a": {}, "a2": {"stop": "raise RuntimeError('device busy')"}})
    robot = launch(folder, "v")
    try:
        outcome = ask(robot, "unload a2")
        assert outcome.accepted and set(robot.runtime.plugins) == {"a"}
        assert (
            robot.runtime.notes[-1][2]
            == "stop() of plugin a2 raised RuntimeError: device busy (at life_a2.py:16)"
        )
    finally:
        robot.close()


@pytest.mark.parametrize("raising", ["raise RuntimeError('device busy')", *BASE_EXCEPTIONS.values()])
def test_a_stop_that_raises_at_the_end_of_the_run_fails_the_run(tmp_path: Path, raising: str) -> None:
    folder = lifecycle_robot(tmp_path, {"a": {}, "a2": {"stop": raising}})
    result = simulated_run(folder)
    assert result.exit_code == 1, result.output
    lines = result.output.splitlines()
    assert lines[-5].startswith("10 ticks")  # the summary, then what the stops said
    assert lines[-4:-2] == ["at 0.010 s (tick 10): a: stop()", "at 0.010 s (tick 10): a2: stop()"]
    assert lines[-2].startswith("at 0.010 s (tick 10): stop() of plugin a2 raised ")
    assert lines[-2].endswith(" (at life_a2.py:16)")
    assert lines[-1] == "the run did not end cleanly: stop() of a2 raised"


def test_a_change_the_loop_does_not_take_in_time_is_withdrawn(tmp_path: Path) -> None:
    folder = lifecycle_robot(tmp_path, {"a": {}, "a2": {}}, entries=LATE_A2)
    robot = launch(folder, "v")
    try:
        outcome = robot.binder.request(Load(("a2",)), timeout=0.01)  # nothing ticks
        assert not outcome.accepted
        assert outcome.reason == "the control loop did not take the change within 0.01 s: nothing changed"
        assert [text for _, _, text in robot.runtime.notes[-2:]] == [
            "a2: stop()",  # started for the change, stopped with it
            "refused load a2: the control loop did not take the change within 0.01 s: nothing changed",
        ]
        robot.runtime.tick()  # the withdrawn change is not applied later
        assert set(robot.runtime.plugins) == {"a"} and robot.runtime.changes == []
        assert "a2" not in robot.binder.active
    finally:
        robot.close()


def test_between_ticks_a_request_from_another_thread_waits_for_the_control_thread(tmp_path: Path) -> None:
    folder = lifecycle_robot(tmp_path, {"a": {}, "a2": {}}, entries=LATE_A2)
    robot = launch(folder, "v")
    try:
        robot.binder.make_changes_between_ticks()  # as a simulated run does
        late = robot.binder.request(Load(("a2",)), timeout=0.01)  # nothing ticks
        assert not late.accepted
        assert late.reason == "the control loop did not take the request within 0.01 s: nothing changed"
        robot.runtime.tick()
        assert robot.runtime.changes == [] and set(robot.runtime.plugins) == {"a"}  # it was taken back
        future = robot.binder.submit(Load(("a2",)))  # from the binder's thread, as the socket
        for _ in range(1_000_000):
            if future.done():
                break
            robot.runtime.tick()  # the control thread empties the inbox after each tick
        outcome = future.result(timeout=10)
        assert outcome.accepted and set(robot.runtime.plugins) == {"a", "a2"}
        assert [c.request for c in robot.runtime.changes] == ["load a2"]
    finally:
        robot.close()


def test_a_fault_whose_feature_already_left_the_loop_is_only_noted(tmp_path: Path) -> None:
    raising = "if self.steps == 3: raise ValueError('lost track')"
    folder = lifecycle_robot(tmp_path, {"a": {"step": raising}, "a2": {"step": raising}})
    robot = launch(folder, "v")  # the real clock: faults are handled on the binder's thread
    both = threading.Event()
    robot.runtime.after_each_tick(lambda: both.set() if len(robot.runtime.faults) == 2 else None)
    loop = threading.Thread(target=robot.runtime.run, args=(60.0, RealClock()), daemon=True)
    loop.start()
    try:
        assert both.wait(30)  # a and a2 raised in the same tick; a's unload takes a2 with it
        barrier = robot.binder.submit(Load(("nothing",)))  # after both fault handlers
        assert not barrier.result(timeout=30).accepted
    finally:
        robot.runtime.stop()
        loop.join()
        robot.close()
    log = [text for _, _, text in robot.runtime.notes]
    assert "unloaded a after the fault of a" in log
    assert "the fault of a2: it has already left the loop" in log
    assert robot.runtime.failure is None and robot.binder.active == {"bot"}


def test_a_fault_no_unload_can_mend_stops_the_run(tmp_path: Path) -> None:
    # a and b are the root's XOR alternatives: neither a alone nor the (Static) root unloads
    model = feature("bot", [feature("a", group="XOR", **ANY), feature("b", group="XOR", **ANY)])
    folder = lifecycle_robot(
        tmp_path,
        {"a": {"step": "if self.steps == 3: raise ValueError('lost track')"}},
        model=model,
        entries=(("a", "Early", "Dynamic"), ("b", "Late", "Dynamic")),
    )
    result = simulated_run(folder)
    assert result.exit_code == 1, result.output
    assert (
        "at 0.003 s (tick 3): cannot unload a after its fault: bot has the XOR group a, b, but bot would be active, a would be inactive"
        in result.output
    )
    assert (
        "the run stopped: a raised in its step at 0.003 s (tick 3): ValueError: lost track (at life_a.py:12)"
        in result.output
    )


# ---------------------------------------------------- slow plugin steps: named, not only counted
def stuck_robot(tmp_path: Path, awaited: str) -> tuple[Robot, threading.Event]:
    """A robot whose plugin a2 waits in its third step until its `gate` is set, with a
    watchdog of 0.05 s (1 s in a run); the event is set once a line containing `awaited`
    is noted in the run's log."""
    gate = "import threading; self.gate = threading.Event()"
    folder = lifecycle_robot(
        tmp_path, {"a": {}, "a2": {"start": gate, "step": "if self.steps == 3: self.gate.wait(60)"}}
    )
    robot = launch(folder, "v")
    runtime = robot.runtime
    runtime.watchdog = 0.05
    noticed = threading.Event()
    note = runtime.note

    def noting(text: str) -> None:
        note(text)
        if awaited in text:
            noticed.set()

    runtime.note = noting  # type: ignore[method-assign]
    return robot, noticed


def test_a_step_that_does_not_return_is_noted_by_the_watchdog_naming_its_plugin(tmp_path: Path) -> None:
    robot, noticed = stuck_robot(tmp_path, "has not returned")
    runtime = robot.runtime
    loop = threading.Thread(target=runtime.run, args=(0.01,), daemon=True)  # the simulated clock
    loop.start()
    try:
        assert noticed.wait(HANG_GUARD)  # while a2's third step waits
        assert runtime.notes[-1][1:] == (
            3,
            "a2's step has not returned after 0.05 s (the step of tick 3): the loop waits for it",
        )
    finally:
        runtime.plugins["a2"].instance.gate.set()
        loop.join(HANG_GUARD)
        robot.close()
    assert not loop.is_alive() and runtime.ticks == 10
    log = [text for _, _, text in runtime.notes]
    assert any(text.startswith("a2's step returned after ") for text in log)
    assert runtime.slowest["a2"][1] == 3  # its longest step, kept for the summary and ctl status
    assert runtime.status().slowest[0][0] == "a2"


def test_a_real_time_loop_that_stops_sleeping_gives_up_its_priority(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """At a real-time priority, a loop stuck in a step would keep its CPU from every ordinary
    thread (Ctrl-C's too): the watchdog makes it ordinary and says so."""
    import os

    calls: list[tuple[int, int, int]] = []  # (thread, policy, priority), each granted without changing anything
    monkeypatch.setattr(
        os, "sched_setscheduler", lambda pid, policy, param: calls.append((pid, policy, param.sched_priority))
    )
    robot, given_up = stuck_robot(tmp_path, "gives up its real-time priority")
    runtime = robot.runtime
    clock = RealClock(50)
    loop_thread: list[int] = []
    enter = clock.enter

    def entering() -> None:
        loop_thread.append(threading.get_native_id())
        enter()

    clock.enter = entering  # type: ignore[method-assign]
    loop = threading.Thread(target=runtime.run, args=(0.01, clock), daemon=True)
    loop.start()
    try:
        assert given_up.wait(HANG_GUARD)  # while a2's third step waits
    finally:
        runtime.plugins["a2"].instance.gate.set()
        loop.join(HANG_GUARD)
        robot.close()
    assert not loop.is_alive()
    ordinary = os.SCHED_OTHER | os.SCHED_RESET_ON_FORK
    assert calls == [(0, os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 50), (loop_thread[0], ordinary, 0)]  # (none at the end)
    assert (clock.real_time, clock.refused) == (False, "it had not slept for 0.05 s")
    log = [text for _, _, text in runtime.notes]
    assert (
        "the loop has not slept for 0.05 s: it gives up its real-time priority 50 for the rest of the run, "
        "so that the machine's other threads get the CPU"
    ) in log
    assert any(text.startswith("a2's step has not returned after 0.05 s") for text in log)


def test_a_real_time_loop_at_a_low_rate_sleeps_long_and_keeps_its_priority(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Asleep is not stuck: 0.1 s between two ticks, with a watchdog of 0.02 s."""
    import os

    calls: list[tuple[int, int]] = []
    monkeypatch.setattr(os, "sched_setscheduler", lambda pid, policy, param: calls.append((policy, param.sched_priority)))
    robot = launch(lifecycle_robot(tmp_path, {"a": {}}), "v")
    robot.runtime.watchdog = 0.02
    robot.runtime.rate = 10.0
    try:
        stats = robot.runtime.run(0.3, RealClock(50))
    finally:
        robot.close()
    assert stats.ticks == 3
    assert not [text for _, _, text in robot.runtime.notes if "real-time priority" in text]
    assert calls == [(os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 50), (os.SCHED_OTHER | os.SCHED_RESET_ON_FORK, 0)]


def test_a_real_clock_summary_names_the_slowest_plugin_steps(tmp_path: Path) -> None:
    folder = lifecycle_robot(tmp_path, {"a": {}, "a2": {}})
    result = CliRunner().invoke(
        main, ["run", str(folder), "--variant", "v", "--duration", "0.02", "--no-control"]
    )
    assert result.exit_code == 0, result.output
    [line] = [line for line in result.output.splitlines() if line.startswith("slowest plugin steps: ")]
    assert sorted(part.split()[0] for part in line.split(": ", 1)[1].split(", ")) == ["a", "a2"]
    assert "slowest plugin steps" not in simulated_run(folder).output  # wall-clock times: real clock only


def test_every_answer_of_the_binder_and_every_log_line_is_told_to_the_listeners(simplebot: Robot) -> None:
    """The ROS 2 door hears the binder's answers in order, with the active set after each;
    the live view hears the log as it is written."""
    heard: list[RunEvent] = []
    simplebot.runtime.told.listen(heard.append)
    assert ask(simplebot, "swap hectorslam kartoslam").accepted
    assert not ask(simplebot, "load hectorslam").accepted
    answers = [e for e in heard if isinstance(e, Answered)]
    assert [(a.request, a.accepted, a.loads, a.unloads) for a in answers] == [
        ("swap hectorslam kartoslam", True, ("kartoslam",), ("hectorslam",)),
        ("load hectorslam", False, (), ()),
    ]
    assert answers[0].active == answers[1].active == simplebot.binder.active
    assert "kartoslam" in answers[0].active and answers[0].change == (answers[0].tick, "swap hectorslam kartoslam")
    assert answers[1].change is None and answers[1].reason.startswith("hectorslam and kartoslam are alternatives")
    logged = [e.note for e in heard if isinstance(e, Logged)]
    assert logged == simplebot.runtime.notes[-len(logged) :] and logged[-1].text.startswith("refused load hectorslam")

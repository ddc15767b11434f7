"""The robot builder and the fixed-rate runtime, in simulated time (deterministic, no sleeping)."""

from __future__ import annotations

import gc
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

from motivml.architecture.builder import BuildError, planar_arm
from motivml.cli import main
from motivml.runtime.events import Missed
from motivml.runtime.launch import Robot, launch
from motivml.runtime.loop import Commit, RealClock, Runtime

EXAMPLES = Path(__file__).parent.parent / "feature_models"
ROOT_LAUNDRY = EXAMPLES / "laundry_gripping"
TROT = np.array([0.0, np.pi, np.pi, 0.0])


def trace(robot: Robot, seconds: float, space: str) -> np.ndarray:
    """Tick for `seconds` of simulated time and return a space's values, one row per tick."""
    rows = []
    for _ in range(round(seconds * robot.runtime.rate)):
        robot.runtime.tick()
        rows.append(robot.assembly.values[space].copy())
    return np.array(rows)


def component(robot: Robot, name: str) -> Any:
    return next(c for c in robot.assembly.components if c.id == name)


# ----------------------------------------------------------------------- reaching arm
def test_the_arm_reaches_its_goal_with_the_learned_dmp_and_its_criterion_fires() -> None:
    robot = launch(EXAMPLES / "reaching_arm", "dmp")
    assert robot.active == ["reaching_arm", "joint_control", "reaching", "dmp_reach"]
    assert [c.id for c in robot.assembly.components] == ["DMPReacher"]
    path = trace(robot, 3.0, "ArmCommand")
    goal = robot.assembly.values["ArmGoal"]
    assert np.linalg.norm(path[-1] - goal) < 1e-3
    fired = robot.runtime.first("DMPReacher", "converged")
    assert fired is not None and 1.0 < fired.time < 2.0
    # The learned shape carries over to the new goal: the elbow swings out first,
    # where a straight reach from 0 to -0.5 would never go above 0.
    assert path[:, 1].max() > 0.1
    assert component(robot, "DMPReacher").status == "converged"


def test_the_attractor_variant_binds_the_other_primitive_and_the_hand_monitor() -> None:
    robot = launch(EXAMPLES / "reaching_arm", "attractor")
    assert [c.id for c in robot.assembly.components] == ["AttractorReacher"]
    assert "HandPosition" in robot.assembly.values  # hand_monitor is Early here
    path = trace(robot, 2.0, "ArmCommand")
    assert path[:, 1].max() <= 1e-12  # a straight, critically damped reach: no swing
    assert robot.runtime.first("AttractorReacher", "converged") is not None
    hand = planar_arm(np.array([0.4, 0.3, 0.2]), robot.assembly.values["ArmCommand"])
    assert np.allclose(robot.assembly.values["HandPosition"], hand)


def test_late_features_are_not_built_unless_the_start_state_needs_them() -> None:
    assert "HandPosition" not in launch(EXAMPLES / "reaching_arm", "dmp").assembly.values
    swappable = launch(EXAMPLES / "reaching_arm", "swappable")
    assert [c.id for c in swappable.assembly.components] == ["DMPReacher"]  # first XOR member


def test_a_new_goal_restarts_the_reach_from_where_the_arm_is() -> None:
    robot = launch(EXAMPLES / "reaching_arm", "attractor")
    robot.runtime.run(2.0)
    robot.runtime.send("ArmGoal", [0.0, 0.5, 0.0])
    robot.runtime.tick()
    assert component(robot, "AttractorReacher").status == "ongoing"
    robot.runtime.run(2.0)
    assert np.allclose(robot.assembly.values["ArmCommand"], [0.0, 0.5, 0.0], atol=1e-2)
    statuses = [e.status for e in robot.runtime.events if e.component == "AttractorReacher"]
    assert statuses == ["converged", "ongoing", "converged"]


# ------------------------------------------------------------------------- quadruped
def test_the_quadruped_trots_and_keeps_its_gait() -> None:
    robot = launch(EXAMPLES / "quadruped", "trot")
    assert [c.id for c in robot.assembly.components] == ["TrotGenerator", "PostureController"]
    robot.runtime.run(5.0)
    generator = component(robot, "TrotGenerator")
    cpg = generator.module.systems[0]
    gap = np.angle(np.exp(1j * (cpg.phase_differences() - TROT)))
    assert np.abs(gap).max() < 1e-3
    events = [e for e in robot.runtime.events if e.component == "TrotGenerator"]
    assert [e.status for e in events] == ["tracking"] and events[0].time < 1.0  # locked, and stays locked
    # The legs' command is the superposition of the posture and the scaled pattern.
    posture = component(robot, "PostureController").contribution
    assert np.allclose(posture, [0.5, 0.5, -0.5, -0.5], atol=1e-3)
    assert np.allclose(robot.assembly.values["LegCommand"], posture + 0.3 * np.sin(cpg.phases))


def test_the_pace_variant_runs_the_other_gait_without_reflexes() -> None:
    robot = launch(EXAMPLES / "quadruped", "pace")
    assert [c.id for c in robot.assembly.components] == ["PaceGenerator", "PostureController"]
    assert "ContactForce" not in robot.assembly.values
    robot.runtime.run(3.0)
    cpg = component(robot, "PaceGenerator").module.systems[0]
    gap = np.angle(np.exp(1j * (cpg.phase_differences() - np.array([0.0, np.pi, 0.0, np.pi]))))
    assert np.abs(gap).max() < 1e-3


def test_a_contact_force_triggers_the_stumble_reflex() -> None:
    robot = launch(EXAMPLES / "quadruped", "gaits_at_run_time")
    assert [c.id for c in robot.assembly.components] == [
        "TrotGenerator",
        "PostureController",
        "ReflexController",
    ]
    robot.runtime.run(1.0)
    robot.runtime.send("ContactForce", [10.0, 0.0, 0.0, 0.0])
    robot.runtime.run(0.2)
    reflex = component(robot, "ReflexController").contribution
    assert np.allclose(reflex, [0.2, 0.0, 0.0, 0.0], atol=1e-3)
    assert component(robot, "ReflexController").status == "tracking"


# --------------------------------------------------------------------------- mixture
def test_the_mixture_superposes_its_scaled_controllers_every_tick() -> None:
    robot = launch(EXAMPLES / "mixture_arm", "mixed")
    trackers = [component(robot, name) for name in ("LeftTracker", "RightTracker", "CircleTracker")]
    for _ in range(500):
        robot.runtime.tick()
        expected = sum(t.contribution for t in trackers)
        assert np.allclose(robot.assembly.values["Command"], expected)
    robot.runtime.run(2.0)
    left, right, circle = (t.module.position() for t in trackers)
    assert np.allclose(left, [1.0, 0.4], atol=1e-3) and np.allclose(right, [-1.0, 0.8], atol=1e-3)
    assert np.allclose(robot.assembly.values["Command"], 0.5 * left + 0.3 * right + 0.2 * circle)
    assert all(t.status == "tracking" for t in trackers)


def test_a_variant_with_fewer_primitives_mixes_fewer() -> None:
    robot = launch(EXAMPLES / "mixture_arm", "reach_only")
    assert [c.id for c in robot.assembly.components] == ["LeftTracker", "RightTracker"]
    robot.runtime.run(3.0)
    assert np.allclose(robot.assembly.values["Command"], [0.2, 0.44], atol=1e-3)


# --------------------------------------------------------------- small inline robots
MODEL = {
    "id": "bot",
    "name": "Bot",
    "sub": [
        {"id": "base", "name": "Base", "isMandatory": True},
        {"id": "extra", "name": "Extra", "isMandatory": False},
    ],
}


def robot_folder(tmp_path: Path, architecture: dict[str, Any], extra: bool = False) -> Path:
    (tmp_path / "variants").mkdir(parents=True)
    (tmp_path / "model.json").write_text(json.dumps(MODEL))
    entry = (
        {"id": "extra", "props": {"time": "Early", "mode": "Static"}}
        if extra
        else {"id": "extra", "selected": False}
    )
    (tmp_path / "variants" / "v.json").write_text(json.dumps({"properties": [entry]}))
    (tmp_path / "architecture.json").write_text(json.dumps(architecture, indent=1))
    return tmp_path


def space(name: str, n: int, feature: str = "base", **more: Any) -> dict[str, Any]:
    return {"id": name, "type": "JointAngles", "dimension": n, "feature": feature, **more}


def test_a_sequencer_visits_its_via_points_in_order(tmp_path: Path) -> None:
    points = [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    architecture = {
        "spaces": [space("Out", 2)],
        "modules": [{"id": "m", "systems": [{"type": "pointAttractor", "dimension": 2}], "feature": "base"}],
        "components": [
            {
                "id": "seq",
                "kind": "Sequencer",
                "module": "m",
                "sequence": points,
                "output": {"space": "Out"},
                "criterion": {"type": "convergence", "tolerance": 0.01},
                "feature": "base",
            }
        ],
    }
    robot = launch(robot_folder(tmp_path, architecture), "v")
    path = trace(robot, 5.0, "Out")
    visits = [int(np.argmin(np.linalg.norm(path - p, axis=1))) for p in points]
    assert visits == sorted(visits) and all(
        np.linalg.norm(path[i] - p) < 0.01 for i, p in zip(visits, points, strict=True)
    )
    assert component(robot, "seq").status == "converged" and component(robot, "seq").via == 2


def test_an_offline_learning_module_records_then_learns_a_dmp(tmp_path: Path) -> None:
    architecture = {
        "spaces": [space("Goal", 1), space("Teacher", 1), space("Out", 1)],
        "modules": [
            {
                "id": "m",
                "systems": [{"type": "dmp", "dimension": 1}],
                "state": "offlineLearning",
                "feature": "base",
            }
        ],
        "components": [
            {
                "id": "learner",
                "kind": "ReachingController",
                "module": "m",
                "goal": {"space": "Goal"},
                "feedback": {"space": "Teacher"},
                "output": {"space": "Out"},
                "feature": "base",
            }
        ],
    }
    robot = launch(robot_folder(tmp_path, architecture), "v", rate=100)
    runtime, module = robot.runtime, robot.assembly.modules["m"]
    times = np.linspace(0.0, 1.0, 101)
    shown = np.sin(np.pi * times) * 0.5 + times  # 0 -> 1 with a bump
    for value in shown:
        runtime.send("Teacher", [value])
        runtime.tick()
    assert component(robot, "learner").status == "learning" and len(module.recording) == 101
    assert "Out" in robot.assembly.values and robot.assembly.values["Out"][0] == 0.0  # drives nothing
    module.set_state("executing")
    assert module.learned == 1 and module.recording == []
    reproduced = module.systems[0].rollout([0.0], [1.0], 0.01, 101)[:, 0]
    assert np.sqrt(np.mean((reproduced - shown) ** 2)) < 0.03


@pytest.mark.parametrize("mode", ["online", "offline"])
def test_an_adaptive_mapping_learns_from_its_teacher(tmp_path: Path, mode: str) -> None:
    architecture = {
        "spaces": [space("In", 2), {"id": "Hand", "type": "Position", "dimension": 2, "feature": "base"}],
        "mappings": [
            {
                "id": "learned",
                "kind": "adaptiveMapping",
                "from": "In",
                "to": "Hand",
                "learner": {"type": "elm", "mode": mode},
                "function": {"type": "planarArm", "links": [0.5, 0.5]},
                "feature": "base",
            }
        ],
    }
    robot = launch(robot_folder(tmp_path, architecture), "v")
    rng = np.random.default_rng(1)
    mapping = robot.assembly.adaptive["learned"]
    for x in rng.uniform(-1.0, 1.0, (2000, 2)):
        robot.runtime.send("In", x)
        robot.runtime.tick()
    assert mapping.samples == 2000 and mapping.error < 0.02
    probe = np.array([0.3, -0.2])
    assert np.linalg.norm(mapping.model.predict(probe)[0] - planar_arm(np.array([0.5, 0.5]), probe)) < 0.02


def test_an_element_of_an_inactive_feature_is_a_located_build_error(tmp_path: Path) -> None:
    architecture = {
        "spaces": [space("Out", 1, feature="extra")],
        "modules": [{"id": "m", "systems": [{"type": "pointAttractor", "dimension": 1}], "feature": "base"}],
        "components": [
            {
                "id": "c",
                "kind": "ReachingController",
                "module": "m",
                "output": {"space": "Out"},
                "feature": "base",
            }
        ],
    }
    with pytest.raises(BuildError) as caught:
        launch(robot_folder(tmp_path, architecture), "v")
    [problem] = caught.value.diagnostics
    assert problem.location.path == "$.components[0].output.space"
    assert problem.message == "c of feature base needs space Out of feature extra, which is not active"
    assert launch(robot_folder(tmp_path / "with", architecture, extra=True), "v").assembly.components


def test_a_component_rate_the_loop_cannot_keep_is_a_warning(tmp_path: Path) -> None:
    architecture = {
        "spaces": [space("Out", 1)],
        "modules": [{"id": "m", "systems": [{"type": "pointAttractor", "dimension": 1}], "feature": "base"}],
        "components": [
            {
                "id": "c",
                "kind": "ReachingController",
                "module": "m",
                "rate": 300,
                "output": {"space": "Out"},
                "feature": "base",
            }
        ],
    }
    robot = launch(robot_folder(tmp_path, architecture), "v")
    assert [w.message for w in robot.warnings] == [
        "c asks for 300 Hz; the loop runs at 1000 Hz, so it steps at 333.333 Hz"
    ]
    assert component(robot, "c").divider == 3


def test_simulated_runs_are_deterministic_and_real_runs_are_timed() -> None:
    first, second = (launch(EXAMPLES / "quadruped", "trot") for _ in range(2))
    first.runtime.run(1.0)
    second.runtime.run(1.0)
    assert np.array_equal(first.assembly.values["LegCommand"], second.assembly.values["LegCommand"])
    stats = launch(EXAMPLES / "quadruped", "trot").runtime.run(0.05, RealClock())
    assert stats.clock == "real" and stats.ticks + stats.missed >= 45 and len(stats.jitter) == stats.ticks
    assert stats.elapsed > 0.04 and stats.cpu > 0


def test_sending_to_a_written_or_misshapen_space_is_refused() -> None:
    runtime = launch(EXAMPLES / "quadruped", "trot").runtime
    with pytest.raises(ValueError, match="LegCommand is written by TrotGenerator, PostureController"):
        runtime.send("LegCommand", [0.0] * 4)
    with pytest.raises(ValueError, match="PostureGoal holds 4 numbers, not 2"):
        runtime.send("PostureGoal", [0.0, 1.0])
    with pytest.raises(KeyError):
        runtime.send("ContactForce", [0.0] * 4)  # reflexes are not in this variant


# ----------------------------------------------------------------------------- CLI
@pytest.mark.parametrize(
    ("robot", "variant", "fired"),
    [
        ("reaching_arm", "dmp", "DMPReacher"),
        ("quadruped", "trot", "TrotGenerator"),
        ("mixture_arm", "mixed", "CircleTracker"),
    ],
)
def test_run_prints_a_summary(robot: str, variant: str, fired: str) -> None:
    result = CliRunner().invoke(
        main, ["run", str(EXAMPLES / robot), "--variant", variant, "--duration", "3", "--clock", "simulated"]
    )
    assert result.exit_code == 0, result.output
    row = next(line for line in result.output.splitlines() if line.strip().startswith(fired))
    assert ("converged" in row or "tracking" in row) and row.rstrip().endswith(" s")
    assert (
        "3000 ticks, 3.000 s of control time" in result.output.splitlines()
    )  # (the arm adds its coordination)


def test_run_refuses_invalid_variants_and_robots_without_an_architecture() -> None:
    runner = CliRunner()
    broken = runner.invoke(
        main, ["run", str(EXAMPLES / "quadruped"), "--variant", "broken_two_gaits", "--clock", "simulated"]
    )
    assert broken.exit_code == 1 and "rules 2.2 and 3.3" in broken.output
    assert "cannot run" in broken.output.splitlines()[-1]
    none = runner.invoke(main, ["run", str(EXAMPLES / "tiago_service"), "--variant", "reception"])
    assert (
        none.exit_code == 3
        and "no architecture.json and no plugins: this robot has nothing to run" in none.output
    )
    assert (
        runner.invoke(
            main, ["run", str(EXAMPLES / "quadruped"), "--variant", "trot", "--rate", "0"]
        ).exit_code
        == 2
    )
    unknown = runner.invoke(main, ["run", str(EXAMPLES / "quadruped"), "--variant", "gallop"])
    assert unknown.exit_code == 2 and "no variant 'gallop'" in unknown.output


def test_the_live_view_runs_beside_the_loop() -> None:
    result = CliRunner().invoke(
        main,
        [
            "run",
            str(EXAMPLES / "quadruped"),
            "--variant",
            "trot",
            "--duration",
            "0.3",
            "--rate",
            "500",
            "--live",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "ticks" in result.output.splitlines()[-1] and "Hz achieved (asked 500 Hz)" in result.output


# ------------------------------------------------------------------ review findings
class FakeClock(RealClock):
    """A real-clock schedule with a hand-moved time: deterministic timing tests."""

    def __init__(self) -> None:
        self.t = 100.0

    def now(self) -> float:
        return self.t

    def first_deadline(self, period: float) -> float:
        return self.t + period  # (not placed on the real monotonic clock's grid: deterministic)

    def wait_until(self, deadline: float) -> float:
        self.t = max(self.t, deadline)
        return self.t


def test_an_overrunning_tick_misses_the_deadlines_it_overran_and_the_loop_keeps_its_schedule() -> None:
    robot = launch(EXAMPLES / "reaching_arm", "dmp")
    clock = FakeClock()
    work = iter([0.0001, 0.0025] + [0.0001] * 20)
    tick = robot.runtime.tick

    def timed_tick() -> None:
        tick()
        clock.t += next(work)

    robot.runtime.tick = timed_tick  # type: ignore[method-assign]
    heard: list[Any] = []
    robot.runtime.told.listen(heard.append)
    stats = robot.runtime.run(0.010, clock)
    # slot 1 ran 2.5 ms: deadlines 2 and 3 are missed, slot 4 starts on time
    assert (stats.ticks, stats.missed) == (8, 2)
    assert [e for e in heard if isinstance(e, Missed)] == [Missed(2, 2)]  # (the record's row of tick 2)
    assert stats.elapsed == pytest.approx(0.010) and stats.achieved == pytest.approx(800.0)
    assert np.all(stats.jitter == 0.0) and len(stats.work) == 8


def test_a_commit_is_applied_while_the_loop_waits_for_its_deadline_but_never_in_a_tick() -> None:
    """commit_waiting applies a queued commit at once while the real-clock loop waits for
    its next deadline with half a period or more to go, and leaves it to the next tick's
    start while a tick runs, closer to the deadline, before the loop starts and after it
    ends. (commit_waiting is called from the loop's thread inside wait_until, as another
    thread would call it while the loop waits: deterministic.)"""
    runtime = launch(EXAMPLES / "reaching_arm", "dmp").runtime
    commits = {name: Commit(name, (), (), None, {}, ()) for name in ("waiting", "late", "ticking", "before", "after")}
    answers: list[tuple[str, bool, bool, int]] = []

    def ask(name: str) -> None:
        runtime.submit(commits[name])
        answers.append((name, runtime.commit_waiting(), commits[name].done.is_set(), runtime.ticks))

    class Clock(FakeClock):
        def wait_until(self, deadline: float) -> float:
            if runtime.ticks == 3 and not answers:
                ask("waiting")
            elif runtime.ticks == 7 and len(answers) == 2:
                self.t = deadline - 0.0001  # 0.1 ms before the deadline: less than COMMIT_MARGIN
                ask("late")
            return super().wait_until(deadline)

    def in_a_tick() -> None:
        if runtime.ticks == 5 and len(answers) == 1:
            ask("ticking")

    runtime.after_each_tick(in_a_tick)
    ask("before")
    answers.clear()
    runtime.run(0.010, Clock())
    assert answers == [
        ("waiting", True, True, 3),
        ("ticking", False, False, 5),
        ("late", False, False, 7),
    ]
    ticks = {name: commit.change.tick for name, commit in commits.items() if commit.change is not None}
    assert ticks == {"before": 0, "waiting": 3, "ticking": 5, "late": 7}  # the first tick that ran with each
    runtime.submit(commits["after"])
    assert runtime.commit_waiting() is False and not commits["after"].done.is_set()


def test_a_real_time_loop_applies_every_commit_itself() -> None:
    """A loop at a real-time priority would wait for an ordinary thread applying a commit:
    commit_waiting leaves every commit to it."""
    runtime = launch(EXAMPLES / "reaching_arm", "dmp").runtime
    commit = Commit("c", (), (), None, {}, ())
    answers: list[bool] = []

    class Clock(FakeClock):
        priority = 80

        def enter(self) -> None:  # (no scheduling change in a test)
            pass

        def leave(self) -> None:
            pass

        def wait_until(self, deadline: float) -> float:
            if runtime.ticks == 3 and not answers:
                runtime.submit(commit)
                answers.append(runtime.commit_waiting())
            return super().wait_until(deadline)

    runtime.run(0.010, Clock())
    assert answers == [False]
    assert commit.change is not None and commit.change.tick == 3


def test_a_very_short_real_run_reports_sane_figures() -> None:
    stats = launch(EXAMPLES / "reaching_arm", "dmp").runtime.run(0.001, RealClock())
    assert stats.ticks == 1 and stats.elapsed >= 0.001 and stats.achieved <= 1000.0


def test_superposed_goal_directed_writers_start_from_zero(tmp_path: Path) -> None:
    modules = [
        {"id": m, "systems": [{"type": "pointAttractor", "dimension": 1}], "feature": "base"}
        for m in ("m1", "m2")
    ]
    architecture = {
        "spaces": [
            space("Out", 1, initial=[0.5]),
            space("G1", 1, initial=[1.0]),
            space("G2", 1, initial=[2.0]),
        ],
        "modules": modules,
        "components": [
            {
                "id": c,
                "kind": "ReachingController",
                "module": m,
                "goal": {"space": g},
                "output": {"space": "Out"},
                "feature": "base",
            }
            for c, m, g in (("c1", "m1", "G1"), ("c2", "m2", "G2"))
        ],
    }
    robot = launch(robot_folder(tmp_path, architecture), "v")
    robot.runtime.tick()
    assert abs(robot.assembly.values["Out"][0]) < 0.01  # not 2 x 0.5
    robot.runtime.run(3.0)
    assert robot.assembly.values["Out"] == pytest.approx([3.0], abs=1e-3)


def test_a_time_step_too_coarse_for_a_system_is_refused_before_running() -> None:
    result = CliRunner().invoke(
        main,
        [
            "run",
            str(EXAMPLES / "reaching_arm"),
            "--variant",
            "attractor",
            "--rate",
            "1",
            "--clock",
            "simulated",
        ],
    )
    assert result.exit_code == 1
    assert "the integration diverges unless alpha * step / duration < 2" in result.output


def test_a_diverging_run_says_so_and_fails(tmp_path: Path) -> None:
    architecture = {
        "spaces": [space("Goal", 1, initial=[1e308]), space("Out", 1)],
        "modules": [{"id": "m", "systems": [{"type": "pointAttractor", "dimension": 1}], "feature": "base"}],
        "components": [
            {
                "id": "c",
                "kind": "ReachingController",
                "module": "m",
                "goal": {"space": "Goal"},
                "output": {"space": "Out"},
                "feature": "base",
            }
        ],
    }
    folder = robot_folder(tmp_path, architecture)
    result = CliRunner().invoke(
        main, ["run", str(folder), "--variant", "v", "--duration", "1", "--clock", "simulated"]
    )
    assert result.exit_code == 1, result.output
    assert "space Out = [nan]" in result.output or "space Out = [inf]" in result.output
    assert "the run diverged: Out hold non-finite values" in result.output


def test_a_mixed_module_without_a_goal_oscillates_around_zero(tmp_path: Path) -> None:
    architecture = {
        "spaces": [space("Out", 2)],
        "modules": [
            {
                "id": "m",
                "systems": [
                    {"type": "pointAttractor", "dimension": 1},
                    {"type": "oscillators", "dimension": 1, "phases": [1.2], "frequency": 2.0},
                ],
                "feature": "base",
            }
        ],
        "components": [
            {
                "id": "c",
                "kind": "TrackingController",
                "module": "m",
                "output": {"space": "Out"},
                "feature": "base",
            }
        ],
    }
    robot = launch(robot_folder(tmp_path, architecture), "v")
    path = trace(robot, 2.0, "Out")
    assert abs(path[:, 1].mean()) < 0.05  # two full periods of sin around 0


def test_ctrl_c_ends_the_run_with_its_summary() -> None:
    """Ctrl-C is sent once the run is seen running (no guess at how long starting takes):
    a request scheduled early in the run is printed when it takes effect, and the loop
    that applies it starts after the Ctrl-C handler is in place."""
    import re
    import signal
    import subprocess
    import sys

    command = [sys.executable, "-m", "motivml.cli", "run", str(EXAMPLES / "quadruped")]
    command += [
        "--variant",
        "gaits_at_run_time",
        "--no-live",
        "--no-control",
        "--at",
        "0.05",
        "swap trot pace",
    ]
    process = subprocess.Popen(
        [*command, "--duration", "60"],  # ends by itself if nothing below happens: a hang guard
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert process.stdout is not None
    before = []
    for line in process.stdout:  # blocks until the run prints
        before.append(line)
        if re.fullmatch(r"\d\d:\d\d:\d\d\.\d{3} tick \d+: swap trot pace\n", line):
            break
    else:
        raise AssertionError("the run ended before the swap was reported:\n" + "".join(before))
    process.send_signal(signal.SIGINT)
    with process.stdout:
        output = process.stdout.read()  # to the end, also what the loop above read ahead
    process.wait(timeout=60)
    assert process.returncode == 130, "".join(before) + output
    assert "PaceGenerator" in output and "Hz achieved" in output.splitlines()[-1]


def test_the_live_view_shows_the_rate_and_every_component() -> None:
    from rich.console import Console

    from motivml.cli.running import _live_view
    from motivml.runtime.session import Session

    session = Session(launch(EXAMPLES / "quadruped", "trot"), 1.0, "simulated")
    session.open()
    session.start()
    assert session.wait(60)
    session.close()
    console = Console(record=True, width=120)
    console.print(_live_view(session.feed()))
    text = console.export_text()
    assert "tick 1000" in text and "t = 1.000 s" in text and "asked 1000 Hz" in text
    assert "TrotGenerator" in text and "tracking" in text and "PostureController" in text


def test_inverse_kinematics_puts_the_hand_where_asked() -> None:
    from motivml.architecture.builder import planar_arm_ik

    rng = np.random.default_rng(3)
    # reachable: the wrist (one tool length short, for 3 links) between |l1 - l2| and l1 + l2
    for links, (near, far) in (
        (np.array([0.4, 0.3]), (0.11, 0.69)),
        (np.array([0.4, 0.3, 0.2]), (0.31, 0.89)),
    ):
        for _ in range(200):
            radius, angle = rng.uniform(near, far), rng.uniform(-np.pi, np.pi)
            target = radius * np.array([np.cos(angle), np.sin(angle)])
            assert np.allclose(planar_arm(links, planar_arm_ik(links, target)), target, atol=1e-9)


def test_a_stopped_writer_lets_its_space_be_sent_to() -> None:
    robot = launch(EXAMPLES / "quadruped", "trot")
    with pytest.raises(ValueError, match="written by TrotGenerator, PostureController"):
        robot.runtime.send("LegCommand", [0.0] * 4)
    for c in robot.assembly.components:
        c.running = False
    robot.runtime.send("LegCommand", [0.1, 0.2, 0.3, 0.4])
    assert robot.assembly.values["LegCommand"].tolist() == [0.1, 0.2, 0.3, 0.4]


def test_a_tracking_controller_follows_a_moving_reference_without_restarting(tmp_path: Path) -> None:
    architecture = {
        "spaces": [space("Reference", 1), space("Out", 1)],
        "modules": [
            {
                "id": "m",
                "systems": [{"type": "pointAttractor", "dimension": 1, "alpha": 40.0}],
                "feature": "base",
            }
        ],
        "components": [
            {
                "id": "follower",
                "kind": "TrackingController",
                "module": "m",
                "goal": {"space": "Reference"},
                "output": {"space": "Out"},
                "criterion": {"type": "tracking", "tolerance": 0.05},
                "feature": "base",
            }
        ],
    }
    robot = launch(robot_folder(tmp_path, architecture), "v")
    for k in range(2000):  # a ramp at 0.5 per second
        robot.runtime.send("Reference", [0.5 * k / 1000])
        robot.runtime.tick()
    lag = robot.assembly.values["Reference"][0] - robot.assembly.values["Out"][0]
    assert 0.0 < lag < 0.06  # a critically damped follower lags by about 2 v / omega = 0.05
    assert component(robot, "follower").status == "tracking"


def test_a_goal_sent_from_outside_unsettles_the_components_that_follow_it() -> None:
    robot = launch(ROOT_LAUNDRY, "engineered")
    robot.runtime.run(2.0)
    hybrid = component(robot, "HybridController")
    robot.runtime.send("ImageCentre", [300.0, 200.0])  # unrelated to HybridController's goal
    status = hybrid.status
    robot.assembly.components[0].running = False  # the babbler: PleatPixel may be sent now
    robot.runtime.send("PleatPixel", [400.0, 200.0])  # -> PleatPosition -> JointGoal, through free mappings
    assert hybrid.status == "ongoing" and status in ("converged", "ongoing")


class _Cycle:
    """Cyclic garbage that counts how many of its kind are alive."""

    alive = 0

    def __init__(self) -> None:
        _Cycle.alive += 1
        self.me = self

    def __del__(self) -> None:
        _Cycle.alive -= 1


def test_cyclic_garbage_is_collected_in_the_real_clock_loops_slack() -> None:
    """A plugin making cyclic garbage every tick must not grow the process for the whole run."""
    runtime = launch(EXAMPLES / "quadruped", "trot").runtime
    _Cycle.alive = 0
    peak = [0]

    def litter(rt: Runtime) -> bool:
        for _ in range(100):
            _Cycle()
        peak[0] = max(peak[0], _Cycle.alive)
        return False

    stats = runtime.run(0.5, RealClock(), until=litter)
    assert stats.ticks > 100 and stats.collections > 0
    assert peak[0] < 5_000 < 100 * stats.ticks  # bounded, where nothing collected would keep them all
    assert gc.isenabled() and not gc.get_freeze_count()  # the automatic collector is back, nothing frozen

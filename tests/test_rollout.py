"""A rollout in waves (motivml.fleet.rollout, reference.md section 9), on a fake graph of
robots: the plan before anything moves, canary and waves, health watched after each wave,
the rollback (last first, each robot by the inverse call), Ctrl-C between two robots, the
record and its resumption (issue 35). The same rollout on a real ROS 2 graph is
tests/test_fleet_ros2.py's."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st
from paths import SIMPLEBOT

from motivml.cli import main
from motivml.fleet import plan_fleet
from motivml.fleet.rollout import (
    Options,
    Record,
    RecordError,
    Rollout,
    describe,
    read_record,
    resumed,
    wanted,
    waves_of,
)
from motivml.runtime.requests import Load, Set, Swap, Unload

CHANGE = Swap("hectorslam", "kartoslam")


class Said:
    def __init__(self, namespace: str, state: dict[str, Any], statuses: list[dict[str, Any]]) -> None:
        self.namespace = namespace
        self.state = state
        self.state_at = time.monotonic()
        self.statuses = statuses
        self.statuses_at = time.monotonic()
        self.reports = 1


class Log:
    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def info(self, message: str) -> None:
        self.lines.append(("info", message))

    def warning(self, message: str) -> None:
        self.lines.append(("warning", message))

    def error(self, message: str) -> None:
        self.lines.append(("error", message))


class FakeRobot:
    def __init__(self, namespace: str, active: tuple[str, ...], variant: str = "field") -> None:
        self.namespace = namespace
        self.active = list(active)
        self.variant = variant
        self.tick = 0
        self.faults = 0
        self.missed = 0
        self.ticks = 1000
        self.alive = True
        self.dies: int | None = None  # it leaves the graph after this many more looks
        self.reporting = True  # False: its last report stays its last (statuses_at frozen)
        self.reported_at = time.monotonic()
        self.frozen: dict[str, Any] | None = None  # an active-set message that stays the latest
        self.refuse: str | None = None  # the node refuses every call, saying this
        self.after_change: Any = None  # called on the robot after an accepted call
        self.calls: list[dict[str, bool]] = []
        self.configuration = ""  # the digest of the variant it runs ("": not said, as an older node)
        self.silent = False  # the next call is taken, and its answer lost

    def said(self) -> Said:
        if self.dies is not None:
            self.dies -= 1
            self.alive = self.dies > 0
        self.ticks += 100  # (every look is a report made since the last)
        loop = {
            "name": "motivml: simplebot loop",
            "level": "ERROR" if self.faults > 5 else "OK",
            "message": "running",
            "values": {"rate": "100", "achieved rate": "100.0", "ticks": str(self.ticks),
                       "missed deadlines": str(self.missed), "faults": str(self.faults)},
        }
        state = {"robot": "simplebot", "variant": self.variant, "active": list(self.active), "tick": self.tick,
                 "configuration": self.configuration}
        if self.reporting:
            self.reported_at = time.monotonic()
        said = Said(self.namespace, self.frozen or state, [loop])
        said.statuses_at = self.reported_at
        return said


class FakeGraph:
    """Robots that answer as a running robot's node does (the change is not checked here:
    the plan before it is; `refuse` makes a node refuse)."""

    def __init__(self, robots: list[FakeRobot]) -> None:
        self.robots = {r.namespace: r for r in robots}
        self.log = Log()
        self.order: list[str] = []  # the robots called, in order

    def discover(self, wait: float, expected: list[str] | None = None) -> list[str]:
        return self.namespaces()

    def namespaces(self) -> list[str]:
        return sorted(ns for ns, r in self.robots.items() if r.alive)

    def snapshot(self, namespace: str) -> Said | None:
        robot = self.robots.get(namespace)
        if robot is None or not robot.alive:
            return None
        said = robot.said()
        return said if robot.alive else None

    def alive(self, namespace: str) -> bool:
        return namespace in self.robots and self.robots[namespace].alive

    def wait_reports(self, namespaces: list[str], wait: float) -> None:
        pass

    def set(self, namespace: str, wanted: dict[str, bool], timeout: float) -> tuple[bool | None, str]:
        robot = self.robots[namespace]
        robot.calls.append(dict(wanted))
        self.order.append(namespace)
        if robot.silent:  # (it takes the change, and its answer is lost)
            robot.silent = False
            self._apply(robot, wanted)
            return None, f"{namespace}/motivml/set_parameters_atomically did not answer within {timeout:g} s"
        if not robot.alive:
            return False, f"no answer: {namespace}/motivml/set_parameters_atomically is not on the graph"
        if robot.refuse is not None:
            return False, robot.refuse
        self._apply(robot, wanted)
        return True, ""

    def _apply(self, robot: FakeRobot, wanted: dict[str, bool]) -> None:
        for feature, on in wanted.items():
            if on and feature not in robot.active:
                robot.active.append(feature)
            if not on and feature in robot.active:
                robot.active.remove(feature)
        robot.tick += 1
        if robot.after_change is not None:
            robot.after_change(robot)


def fleet_of(tmp_path: Path, names: list[str], variant: str = "field") -> Path:
    path = tmp_path / "fleet.json"
    robots = [{"namespace": n, "robot": str(SIMPLEBOT), "variant": variant} for n in names]
    path.write_text(json.dumps({"robots": robots}))
    return path


def start_state(path: Path) -> tuple[str, ...]:
    _, plans = plan_fleet(path, CHANGE)
    return plans[0].against


def setup(tmp_path: Path, count: int) -> tuple[Path, FakeGraph]:
    names = [f"/r{k}" for k in range(1, count + 1)]
    path = fleet_of(tmp_path, names)
    active = start_state(path)
    return path, FakeGraph([FakeRobot(n, active) for n in names])


def rollout(path: Path, graph: FakeGraph, record: Path, **options: Any) -> Rollout:
    settings = {"canary": 1, "waves": 2, "healthy": 0.05, "timeout": 1.0, "discover": 0.0, **options}
    return Rollout(path, CHANGE, None, graph, Options(**settings), Record(record))


def steps_of(record: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in record.read_text().splitlines()]


# ---------------------------------------------------------------------- waves
@given(st.integers(0, 40), st.integers(0, 45), st.integers(1, 10))
def test_waves_take_every_robot_once_in_order_canary_first_sizes_even(count: int, canary: int, waves: int) -> None:
    robots = [f"/r{k}" for k in range(count)]
    out = waves_of(robots, canary, waves)
    assert [r for wave in out for r in wave] == robots
    assert all(out) and (not canary or not robots or out[0] == robots[:canary])
    rest = out[1:] if canary and robots else out
    assert len(rest) <= waves
    if rest:
        sizes = [len(w) for w in rest]
        assert max(sizes) - min(sizes) <= 1 and sizes == sorted(sizes, reverse=True)


def test_each_change_is_one_call_of_features_on_and_off() -> None:
    assert wanted(Swap("a", "b")) == {"a": False, "b": True}
    assert wanted(Load(("a", "b"))) == {"a": True, "b": True}
    assert wanted(Unload(("a",))) == {"a": False}
    assert wanted(Set(("a",), ("b",))) == {"a": True, "b": False}


# ---------------------------------------------------------------------- rollouts
def test_an_applied_rollout_changes_every_robot_in_waves_and_records_each_step(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 5)
    record = tmp_path / "r.jsonl"
    outcome = rollout(path, graph, record).run()
    assert outcome.result == "applied" and outcome.exit_code == 0
    assert graph.order == ["/r1", "/r2", "/r3", "/r4", "/r5"]
    assert all(r.calls == [{"hectorslam": False, "kartoslam": True}] for r in graph.robots.values())
    assert all("kartoslam" in r.active and "hectorslam" not in r.active for r in graph.robots.values())
    steps = steps_of(record)
    kinds = [s["step"] for s in steps]
    assert kinds[0] == "start" and steps[0]["waves"] == [["/r1"], ["/r2", "/r3"], ["/r4", "/r5"]]
    assert kinds.count("planned") == 5 and kinds.count("changed") == 5 and kinds.count("healthy") == 3
    assert kinds[-1] == "end" and steps[-1]["result"] == "applied"
    changed = next(s for s in steps if s["step"] == "changed")
    assert changed["loads"] == ["kartoslam"] and changed["unloads"] == ["hectorslam"]
    # every step is on the graph's log too, in words
    assert len(graph.log.lines) == len(steps)
    assert ("info", "rollout of swap hectorslam kartoslam: /r1: changed: loads kartoslam; unloads hectorslam") in graph.log.lines


def test_a_plan_refused_by_one_robot_touches_none(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 3)
    graph.robots["/r2"].variant = "lab"  # (it runs another variant than the fleet file says)
    del graph.robots["/r3"]  # (and this one is not running)
    outcome = rollout(path, graph, tmp_path / "r.jsonl").run()
    assert outcome.result == "refused" and outcome.exit_code == 1 and graph.order == []
    assert outcome.robots == {"/r1": "unchanged", "/r2": "refused in the plan", "/r3": "refused in the plan"}
    why = {s["robot"]: s["why"] for s in steps_of(tmp_path / "r.jsonl") if s["step"] == "planned"}
    assert "runs variant lab, the fleet file gives it field" in why["/r2"][0]
    assert "not running (no node /r3/motivml on the graph)" in why["/r3"][0]


def test_a_robot_that_refuses_the_call_stops_the_rollout_and_the_others_are_changed_back(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 5)
    before = {ns: list(r.active) for ns, r in graph.robots.items()}
    graph.robots["/r3"].refuse = "the robot's run has ended: nothing changed"
    outcome = rollout(path, graph, tmp_path / "r.jsonl").run()
    assert outcome.result == "rolled back" and outcome.exit_code == 1
    # r1, r2 changed, r3 refused; then r2 and r1 changed back, last first, each by the inverse call
    assert graph.order == ["/r1", "/r2", "/r3", "/r2", "/r1"]
    assert graph.robots["/r1"].calls[1] == {"hectorslam": True, "kartoslam": False}
    assert {ns: sorted(r.active) for ns, r in graph.robots.items()} == {ns: sorted(a) for ns, a in before.items()}
    assert outcome.robots["/r3"] == "refused: the robot's run has ended: nothing changed"
    assert outcome.robots["/r1"] == outcome.robots["/r2"] == "rolled back"


@pytest.mark.parametrize(
    ("harm", "said"),
    [
        (lambda r: setattr(r, "faults", r.faults + 1), "1 new fault(s) since the change"),
        (lambda r: setattr(r, "faults", 9), "ERROR on /diagnostics: loop: running"),
        (lambda r: setattr(r, "dies", 2), "its node has left the graph"),
        (lambda r: setattr(r, "missed", r.missed + 50), "missed "),
    ],
)
def test_a_robot_unhealthy_in_the_second_wave_rolls_every_changed_robot_back(tmp_path: Path, harm: Any, said: str) -> None:
    path, graph = setup(tmp_path, 5)  # waves: /r1 (the canary), /r2 /r3, /r4 /r5
    graph.robots["/r3"].after_change = harm
    outcome = rollout(path, graph, tmp_path / "r.jsonl").run()
    assert outcome.result in ("rolled back", "failed") and outcome.exit_code == 1
    assert outcome.robots["/r3"].startswith("unhealthy: " + said)
    assert "/r4" not in graph.order  # (the third wave never started)
    if said.startswith("missed"):
        assert "of its deadlines since the change, against 0.0% before it (allowed: 1.0%)" in outcome.robots["/r3"]
    assert graph.order[3:] == ["/r3", "/r2", "/r1"]
    if said.startswith("its node"):  # (asked, and it cannot answer)
        assert outcome.robots["/r3"].endswith("NOT rolled back: no answer: /r3/motivml/set_parameters_atomically is not on the graph")
    for ns in ("/r1", "/r2"):
        assert "hectorslam" in graph.robots[ns].active and "kartoslam" not in graph.robots[ns].active


def test_a_robot_that_misses_as_many_deadlines_as_before_stays_healthy(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 2)
    for robot in graph.robots.values():
        robot.after_change = None
    busy = graph.robots["/r2"]
    # it missed 10% of its deadlines before the change, and goes on so after it
    original = busy.said

    def said() -> Said:
        report = original()
        busy.missed = busy.ticks // 10
        report.statuses[0]["values"]["missed deadlines"] = str(busy.missed)
        return report

    busy.said = said  # type: ignore[method-assign]
    assert rollout(path, graph, tmp_path / "r.jsonl").run().result == "applied"


def test_ctrl_c_stops_between_robots_and_a_kept_rollout_resumes_from_its_record(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 5)
    record = tmp_path / "r.jsonl"
    first = rollout(path, graph, record)
    graph.robots["/r2"].after_change = lambda _: first.interrupt.set()
    outcome = first.run()
    assert outcome.result == "stopped" and outcome.exit_code == 130 and graph.order == ["/r1", "/r2"]
    first.keep()
    first.record.close()
    resume = resumed(record, read_record(record))
    assert sorted(resume.done) == ["/r1", "/r2"] and resume.change == "swap hectorslam kartoslam"
    again = Rollout(path, CHANGE, None, graph, Options(1, 2, 0.05, 1.0, 0.0), Record(record, resume=True))
    assert again.run(resume).result == "applied"
    assert graph.order == ["/r1", "/r2", "/r3", "/r4", "/r5"]  # (no robot changed twice)
    again.record.close()
    with pytest.raises(RecordError, match="the rollout ended: applied"):
        resumed(record, read_record(record))


def test_ctrl_c_and_a_rollback_changes_back_what_was_changed(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 3)
    first = rollout(path, graph, tmp_path / "r.jsonl")
    graph.robots["/r1"].after_change = lambda _: first.interrupt.set()
    assert first.run().result == "stopped"
    outcome = first.roll_back()
    assert outcome.result == "rolled back" and graph.order == ["/r1", "/r1"]
    assert "hectorslam" in graph.robots["/r1"].active


def test_a_robot_that_cannot_be_changed_back_is_said_and_the_rollout_failed(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 3)
    r1 = graph.robots["/r1"]

    def harm(robot: FakeRobot) -> None:
        robot.faults += 1
        r1.refuse = "refused: no"

    graph.robots["/r2"].after_change = harm
    outcome = rollout(path, graph, tmp_path / "r.jsonl").run()
    assert outcome.result == "failed" and "1 robot(s) could not be rolled back" in outcome.why
    assert outcome.robots["/r1"] == "NOT rolled back: refused: no"


def test_a_defect_in_the_middle_still_rolls_back(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 3)

    def broken(robot: FakeRobot) -> None:
        graph.snapshot = None  # type: ignore[method-assign,assignment]

    graph.robots["/r2"].after_change = broken
    job = rollout(path, graph, tmp_path / "r.jsonl")
    with pytest.raises(TypeError):
        job.run()
    outcome = job.failed(TypeError("'NoneType' object is not callable"))
    assert outcome.result == "failed" and graph.order[-2:] == ["/r2", "/r1"]


# ---------------------------------------------------------------------- the record
def test_a_record_cut_short_is_read_to_its_last_whole_line_and_garbage_is_refused(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 2)
    record = tmp_path / "r.jsonl"
    job = rollout(path, graph, record)
    job.run()
    job.record.close()
    whole = record.read_text()
    record.write_text(whole + '{"at": "2026", "step": "cha')  # (a writer killed mid-line)
    assert read_record(record) == [json.loads(line) for line in whole.splitlines()]
    (tmp_path / "bad.jsonl").write_text("no\n{}\n")
    with pytest.raises(RecordError, match="bad.jsonl:1: not a JSON line"):
        read_record(tmp_path / "bad.jsonl")
    (tmp_path / "nostart.jsonl").write_text('{"step": "wave"}\n')
    with pytest.raises(RecordError, match="starts with its start step"):
        read_record(tmp_path / "nostart.jsonl")


def test_every_step_has_words() -> None:
    steps = [
        {"step": "start", "change": "swap a b", "waves": [["/a"], ["/b"]], "healthy": 0},
        {"step": "resume", "done": ["/a"], "waves": [["/b"]]},
        {"step": "planned", "robot": "/a", "accepted": False, "why": ["no"]},
        {"step": "interrupted", "changed": ["/a"]},
        {"step": "end", "result": "stopped", "why": "interrupted"},
        {"step": "changed", "robot": "/a", "loads": ["x", "y"], "unloads": []},
        {"step": "healthy", "wave": 0, "seconds": 2.0},
        {"step": "healthy", "wave": 3, "seconds": 0.5},
        {"step": "unhealthy", "robot": "/b", "why": "gone"},
        {"step": "no answer", "robot": "/b", "why": "silence"},
        {"step": "failed", "why": "the rollout failed: KeyError: 'x'"},
        {"step": "rolled back", "robot": "/a", "loads": [], "unloads": []},
    ]
    assert [describe(s) for s in steps] == [
        "start: swap a b to 2 robot(s) in 2 wave(s), no health waits",
        "resume: 1 robot(s) changed before, 1 wave(s) left",
        "/a: planned: refused: no",
        "interrupted: stopped between two robots (1 changed)",
        "end: stopped: interrupted",
        "/a: changed: loads x, y",
        "the robots changed before: every one healthy for 2 s",
        "wave 3: every robot changed so far healthy for 0.5 s",
        "/b: unhealthy: gone",
        "/b: no answer: silence (it may have taken the change: it is rolled back too)",
        "failed: the rollout failed: KeyError: 'x'",
        "/a: rolled back: nothing moves",
    ]


# ---------------------------------------------------------------------- the command line
def test_apply_and_list_say_what_they_need_without_ros2(tmp_path: Path) -> None:
    import importlib.util

    if importlib.util.find_spec("rclpy") is not None:
        pytest.skip("ROS 2 is installed here: tests/test_fleet_ros2.py runs these commands on a graph")
    path = fleet_of(tmp_path, ["/a"])
    for args in (["list"], ["apply", str(path), "swap", "hectorslam", "kartoslam"], ["plan", str(path), "unload", "slam"]):
        result = CliRunner().invoke(main, ["fleet", *args])
        assert result.exit_code == 3, result.output
        assert "ROS 2 is not available in this Python" in result.output and "make ros2" in result.output
    assert not (tmp_path / "build").exists()


def test_apply_refuses_a_reload_a_broken_record_and_a_fleet_file_with_errors(tmp_path: Path) -> None:
    path = fleet_of(tmp_path, ["/a"])
    reload = CliRunner().invoke(main, ["fleet", "apply", str(path), "reload", "slam"])
    assert reload.exit_code == 2 and "reload is not a change for a fleet: load, unload, swap, set" in reload.output
    (tmp_path / "r.jsonl").write_text("{}\n")
    broken = CliRunner().invoke(main, ["fleet", "apply", "--resume", str(tmp_path / "r.jsonl")])
    assert broken.exit_code == 2 and "not a step of a rollout record" in broken.output
    nothing = CliRunner().invoke(main, ["fleet", "apply"])
    assert nothing.exit_code == 2 and "needs FLEET and CHANGE (or --resume RECORD)" in nothing.output
    bad = tmp_path / "bad.fleet.json"
    bad.write_text(json.dumps({"robots": [{"namespace": "a", "robot": str(SIMPLEBOT), "variant": "field", "groups": ["x"]}]}))
    invalid = CliRunner().invoke(main, ["fleet", "apply", str(bad), "unload", "slam"])
    assert invalid.exit_code == 1 and "no group 'x' in the fleet file" in invalid.output


# ---------------------------------------------------------------------- the command, on a fake graph
@pytest.fixture
def fake_graph(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> tuple[Path, FakeGraph]:
    """`fleet apply` and `fleet list` as a user runs them, on a fake graph instead of ROS 2."""
    from contextlib import contextmanager

    import motivml.cli.fleeting as fleeting

    path, graph = setup(tmp_path, 4)

    @contextmanager
    def fake(prefix: str = "/") -> Any:
        yield graph

    monkeypatch.setattr(fleeting, "_graph", fake)
    monkeypatch.chdir(tmp_path)
    return path, graph


def test_apply_on_the_command_line_writes_its_record_under_build_and_reports_every_robot(
    fake_graph: tuple[Path, FakeGraph],
) -> None:
    path, graph = fake_graph
    result = CliRunner().invoke(main, ["fleet", "apply", str(path), "swap", "hectorslam", "kartoslam", "--healthy", "0.05"])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    record = Path(lines[0].removeprefix("record: "))
    assert record.parent == Path("build", "rollouts") and record.suffix == ".jsonl"
    assert lines[1] == "start: swap hectorslam kartoslam to 4 robot(s) in 2 wave(s), each then healthy for 0.05 s"
    assert "/r4: changed: loads kartoslam; unloads hectorslam" in lines
    assert lines[-1] == f"applied (record: {record})"
    assert [s["step"] for s in read_record(record)][-1] == "end"
    listing = CliRunner().invoke(main, ["fleet", "list", "--record", str(record)])
    assert listing.exit_code == 0, listing.output
    rows = listing.output.splitlines()
    assert rows[0].split() == ["namespace", "robot", "variant", "active", "rate", "missed", "faults", "health", "rollout"]
    assert rows[1].split()[:4] == ["/r1", "simplebot", "field", str(len(graph.robots["/r1"].active))]
    assert rows[1].split()[-2] == "changed"


def test_ctrl_c_on_the_command_line_rolls_back_off_a_terminal_and_keep_lets_it_resume(
    fake_graph: tuple[Path, FakeGraph],
) -> None:
    import os
    import signal

    path, graph = fake_graph
    graph.robots["/r2"].after_change = lambda _: os.kill(os.getpid(), signal.SIGINT)  # (Ctrl-C, in the middle)
    args = ["fleet", "apply", str(path), "swap", "hectorslam", "kartoslam", "--healthy", "0", "--record", "r.jsonl"]
    back = CliRunner().invoke(main, args)
    assert back.exit_code == 1, back.output
    assert "interrupted: rolling back (not a terminal to ask on" in back.output
    assert graph.order == ["/r1", "/r2", "/r2", "/r1"] and "rolled back: interrupted" in back.output
    graph.order.clear()
    kept = CliRunner().invoke(main, [*args[:-1], "kept.jsonl", "--on-interrupt", "keep"])
    assert kept.exit_code == 130 and graph.order == ["/r1", "/r2"], kept.output
    graph.robots["/r2"].after_change = None
    resumed_ = CliRunner().invoke(main, ["fleet", "apply", "--resume", "kept.jsonl"])
    assert resumed_.exit_code == 0, resumed_.output
    assert "resume: 2 robot(s) changed before, 1 wave(s) left" in resumed_.output
    assert graph.order == ["/r1", "/r2", "/r3", "/r4"]
    again = CliRunner().invoke(main, ["fleet", "apply", "--resume", "kept.jsonl"])
    assert again.exit_code == 2 and "the rollout ended: applied: nothing to resume" in again.output
    ended = CliRunner().invoke(main, ["fleet", "apply", "--resume", "r.jsonl"])
    assert ended.exit_code == 2 and "the rollout ended: rolled back: nothing to resume" in ended.output
    lines = Path("kept.jsonl").read_text().splitlines()
    Path("cut.jsonl").write_text("\n".join(lines[:4]) + "\n")  # (a rollout killed in its first wave)
    other = CliRunner().invoke(main, ["fleet", "apply", str(path), "unload", "slam", "--resume", "cut.jsonl"])
    assert other.exit_code == 2 and "goes on with the rollout of swap hectorslam kartoslam" in other.output


def test_a_robot_with_a_conflicting_override_is_refused_in_the_plan_with_its_layer(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 2)
    document = json.loads(path.read_text())
    document["robots"][1]["overrides"] = [{"id": "slam", "selected": False}]  # (navigation needs it)
    path.write_text(json.dumps(document))
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 1 and "(set by: robot /r2" in result.output
    outcome = rollout(path, graph, tmp_path / "r.jsonl").run()
    assert outcome.result == "refused" and graph.order == []
    why = {s["robot"]: s["why"] for s in steps_of(tmp_path / "r.jsonl") if s["step"] == "planned"}
    assert why["/r2"] == ["robot /r2: its configuration has errors (validate the fleet file): nothing planned"]


def test_list_watch_prints_the_list_again_every_second_until_ctrl_c(
    fake_graph: tuple[Path, FakeGraph], monkeypatch: pytest.MonkeyPatch
) -> None:
    import motivml.cli.fleeting as fleeting

    path, graph = fake_graph
    seconds: list[float] = []

    def sleep(s: float) -> None:  # (no real wait: the third second is a Ctrl-C)
        seconds.append(s)
        if len(seconds) == 3:
            raise KeyboardInterrupt
        graph.robots["/r2"].faults += 1

    monkeypatch.setattr(fleeting.time, "sleep", sleep)
    result = CliRunner().invoke(main, ["fleet", "list", "--fleet", str(path), "--watch", "--format", "json"])
    assert result.exit_code == 130 and result.output.endswith("interrupted\n")
    lines = [json.loads(line) for line in result.output.splitlines()[:-1]]
    assert seconds == [1.0, 1.0, 1.0] and len(lines) == 3
    assert [[row["faults"] for row in rows if row["namespace"] == "/r2"] for rows in lines] == [[0], [1], [2]]


# ---------------------------------------------------------------------- from a review
@pytest.fixture
def quick(monkeypatch: pytest.MonkeyPatch) -> None:
    """The rollout's waits for news, shortened (the rules are the same)."""
    import motivml.fleet.rollout as module

    monkeypatch.setattr(module, "STALE", 0.3)
    monkeypatch.setattr(module, "SETTLE", 0.2)


def test_a_robot_that_stops_reporting_after_its_change_is_unhealthy(tmp_path: Path, quick: None) -> None:
    path, graph = setup(tmp_path, 2)
    graph.robots["/r1"].after_change = lambda r: setattr(r, "reporting", False)
    outcome = rollout(path, graph, tmp_path / "r.jsonl", healthy=0.5, canary=1, waves=1).run()
    assert outcome.result == "rolled back" and outcome.robots["/r1"].startswith("unhealthy: no /diagnostics report")
    assert graph.order == ["/r1", "/r1"]


def test_a_wave_goes_on_only_once_each_robot_has_reported_after_its_change(tmp_path: Path, quick: None) -> None:
    path, graph = setup(tmp_path, 2)
    graph.robots["/r1"].after_change = lambda r: setattr(r, "reporting", False)
    # a wait shorter than STALE: the robot is not stale yet when it ends, but has said nothing since the change
    outcome = rollout(path, graph, tmp_path / "r.jsonl", healthy=0.05, canary=1, waves=1).run()
    assert outcome.robots["/r1"].startswith("unhealthy: no /diagnostics report for 0.3 s")


def test_a_change_whose_news_comes_late_is_rolled_back_by_its_plan(tmp_path: Path, quick: None) -> None:
    path, graph = setup(tmp_path, 3)
    r2 = graph.robots["/r2"]
    r2.frozen = r2.said().state  # (its node's active-set message does not come in time)
    graph.robots["/r3"].refuse = "no"
    record = tmp_path / "r.jsonl"
    outcome = rollout(path, graph, record).run()
    assert outcome.result == "rolled back" and graph.order == ["/r1", "/r2", "/r3", "/r2", "/r1"]
    assert r2.calls[1] == {"hectorslam": True, "kartoslam": False} and "hectorslam" in r2.active
    (changed,) = [s for s in steps_of(record) if s["step"] == "changed" and s["robot"] == "/r2"]
    assert changed["settled"] is False and changed["loads"] == ["kartoslam"]


def test_a_call_without_an_answer_is_rolled_back_too(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 3)
    graph.robots["/r2"].silent = True
    outcome = rollout(path, graph, tmp_path / "r.jsonl").run()
    assert outcome.result == "rolled back" and graph.order == ["/r1", "/r2", "/r2", "/r1"]
    assert outcome.robots["/r2"].startswith("no answer: /r2/motivml/set_parameters_atomically did not answer")
    assert all("hectorslam" in r.active and "kartoslam" not in r.active for r in graph.robots.values())


def test_a_rollback_goes_on_past_a_robot_whose_call_raises_and_a_record_that_cannot_be_written(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 3)
    record = Record(tmp_path / "r.jsonl")
    job = Rollout(path, CHANGE, None, graph, Options(1, 2, 0.05, 1.0, 0.0), record)
    real = graph.set

    def harm(robot: FakeRobot) -> None:
        robot.refuse = "refused for the test"
        record._file = open("/dev/full", "w")  # noqa: SIM115 (every write from now on: no space left)

        def broken(namespace: str, wanted: dict[str, bool], timeout: float) -> tuple[bool | None, str]:
            if namespace == "/r2":
                raise RuntimeError("rclpy broke")
            return real(namespace, wanted, timeout)

        graph.set = broken  # type: ignore[method-assign]

    graph.robots["/r2"].after_change = harm
    graph.robots["/r3"].refuse = "no"
    outcome = job.run()
    assert outcome.result == "failed" and "1 robot(s) could not be rolled back" in outcome.why
    assert outcome.robots["/r2"].startswith("NOT rolled back: RuntimeError: rclpy broke")
    assert outcome.robots["/r1"] == "rolled back" and "hectorslam" in graph.robots["/r1"].active
    assert record.failure is not None and "No space left on device" in record.failure


def test_a_resume_whose_plan_one_robot_refuses_rolls_back_the_robots_changed_before(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 3)
    record = tmp_path / "r.jsonl"
    first = rollout(path, graph, record)
    graph.robots["/r1"].after_change = lambda _: first.interrupt.set()
    assert first.run().result == "stopped"
    first.keep()
    first.record.close()
    graph.robots["/r3"].variant = "lab"  # (restarted on another variant in between)
    again = Rollout(path, CHANGE, None, graph, Options(1, 2, 0.05, 1.0, 0.0), Record(record, resume=True))
    outcome = again.run(resumed(record, read_record(record)))
    assert outcome.result == "rolled back" and graph.order == ["/r1", "/r1"]
    assert outcome.robots["/r3"] == "refused in the plan" and "hectorslam" in graph.robots["/r1"].active


def test_a_robot_changed_before_a_resume_is_judged_by_its_faults_since(tmp_path: Path) -> None:
    path, graph = setup(tmp_path, 3)
    record = tmp_path / "r.jsonl"
    first = rollout(path, graph, record)
    graph.robots["/r1"].after_change = lambda _: first.interrupt.set()
    first.run()
    first.keep()
    first.record.close()
    again = Rollout(path, CHANGE, None, graph, Options(1, 2, 0.3, 1.0, 0.0), Record(record, resume=True))
    r1 = graph.robots["/r1"]
    looks = iter(range(1000))
    original = r1.said

    def said() -> Said:  # (a fault after the resume's first look at it)
        if next(looks) == 2:  # (0: the plan's, 1: the first report's)
            r1.faults += 3
        return original()

    r1.said = said  # type: ignore[method-assign]
    outcome = again.run(resumed(record, read_record(record)))
    assert outcome.robots["/r1"].startswith("unhealthy: 3 new fault(s)")
    steps = steps_of(record)
    assert "healthy" not in [s["step"] for s in steps]  # (watched first, before any robot is changed)
    assert [(s["robot"], s["wave"]) for s in steps if s["step"] == "unhealthy"] == [("/r1", 0)]
    assert graph.order == ["/r1", "/r1"]


def test_a_record_is_new_or_resumed_whole(tmp_path: Path) -> None:
    first, second = Record.new(tmp_path), Record.new(tmp_path)
    assert first.path != second.path and second.path.name.endswith("-2.jsonl")
    first.close()
    second.close()
    with pytest.raises(FileExistsError):
        Record(first.path)
    first.path.write_text('{"step": "start"}\n{"step": "wa')  # (cut short by a killed writer)
    resumed_record = Record(first.path, resume=True)
    resumed_record.write({"step": "wave"})
    resumed_record.close()
    assert [s["step"] for s in read_record(first.path)] == ["start", "wave"]
    (tmp_path / "bad.jsonl").write_text('{"step": "start", "fleet": "f.json"}\n')
    with pytest.raises(RecordError, match="bad.jsonl:1: not the start of a rollout"):
        resumed(tmp_path / "bad.jsonl", read_record(tmp_path / "bad.jsonl"))


def test_apply_says_a_bad_selector_an_unknown_option_and_a_record_taken_before_it_starts(
    fake_graph: tuple[Path, FakeGraph],
) -> None:
    path, graph = fake_graph
    swap = ["fleet", "apply", str(path), "swap", "hectorslam", "kartoslam", "--healthy", "0"]
    group = CliRunner().invoke(main, [*swap, "--robots", "@nosuch"])
    assert group.exit_code == 2 and "no group 'nosuch' in the fleet file" in group.output
    nobody = CliRunner().invoke(main, [*swap, "--robots", "/typo*"])
    assert nobody.exit_code == 1 and "no robot of" in nobody.output
    typo = CliRunner().invoke(main, ["fleet", "apply", str(path), "set", "+kartoslam", "-hectorslam", "--ofline"])
    assert typo.exit_code == 2 and "no such option: --ofline" in typo.output
    Path("taken.jsonl").write_text("")
    taken = CliRunner().invoke(main, [*swap, "--record", "taken.jsonl"])
    assert taken.exit_code == 2 and "taken.jsonl exists: a new rollout writes a new record" in taken.output
    assert graph.order == [] and not Path("build").exists()


def test_a_defect_in_the_middle_of_apply_rolls_back_and_says_so_without_a_traceback(
    fake_graph: tuple[Path, FakeGraph],
) -> None:
    path, graph = fake_graph
    real = graph.snapshot

    def broken(robot: FakeRobot) -> None:
        calls = iter(range(1000))

        def snapshot(namespace: str) -> Said | None:
            if namespace == "/r3" and next(calls) >= 0:
                raise KeyError("a defect")
            return real(namespace)

        graph.snapshot = snapshot  # type: ignore[method-assign]

    graph.robots["/r2"].after_change = broken
    result = CliRunner().invoke(main, ["fleet", "apply", str(path), "swap", "hectorslam", "kartoslam", "--healthy", "0",
                                       "--record", "r.jsonl"])
    assert result.exit_code == 1 and "Traceback" not in result.output and result.exception is not None
    assert "failed: the rollout failed: KeyError: 'a defect'" in result.output
    assert graph.order == ["/r1", "/r2", "/r2", "/r1"]


def test_a_robot_that_runs_its_variant_without_the_fleets_layers_or_another_robot_is_refused(tmp_path: Path) -> None:
    from motivml.binding.resolve import resolve
    from motivml.fleet import validate_fleet

    path, graph = setup(tmp_path, 3)
    document = json.loads(path.read_text())
    document["robots"][0]["overrides"] = [{"id": "orbslam", "selected": False}]
    path.write_text(json.dumps(document))
    reports = validate_fleet(path)[1]
    digests = [resolve(r.model, r.config).digest() for r in reports if r.model is not None and r.config is not None]
    assert digests[0] != digests[1] and digests[1] == digests[2]  # (the override is a change of variant)
    for robot, digest in zip(graph.robots.values(), digests, strict=True):
        robot.configuration = digest
    graph.robots["/r2"].configuration = digests[0]  # (it runs /r1's configuration)
    graph.robots["/r3"].said = lambda original=graph.robots["/r3"].said: _renamed(original())  # type: ignore[method-assign]
    outcome = rollout(path, graph, tmp_path / "r.jsonl").run()
    assert outcome.result == "refused" and graph.order == []
    why = {s["robot"]: s["why"] for s in steps_of(tmp_path / "r.jsonl") if s["step"] == "planned"}
    assert why["/r1"] == []
    assert "runs variant field in another configuration than the fleet file gives it" in why["/r2"][0]
    assert "runs the robot armbot, the fleet file gives it simplebot" in why["/r3"][0]


def _renamed(said: Said) -> Said:
    assert said.state is not None
    said.state = {**said.state, "robot": "armbot"}
    return said


def test_the_command_lines_other_paths_on_a_fake_graph(fake_graph: tuple[Path, FakeGraph], monkeypatch: pytest.MonkeyPatch) -> None:
    path, graph = fake_graph
    # a plan of the running robots, and apply --dry-run (the same), with a set of words
    plan = CliRunner().invoke(main, ["fleet", "plan", str(path), "set", "+kartoslam", "-hectorslam"])
    assert plan.exit_code == 0, plan.output
    assert plan.output.splitlines()[-1].endswith("(checked against the active set each running robot reports)")
    dry = CliRunner().invoke(main, ["fleet", "apply", str(path), "swap", "hectorslam", "kartoslam", "--dry-run"])
    assert dry.exit_code == 0 and graph.order == [] and not Path("build").exists()
    # list: json, an empty graph, a record that is not one, a fleet file with errors
    rows = json.loads(CliRunner().invoke(main, ["fleet", "list", "--format", "json"]).output)
    assert [r["namespace"] for r in rows] == ["/r1", "/r2", "/r3", "/r4"] and rows[0]["configuration"] == ""
    Path("garbage.jsonl").write_bytes(b"\xff\xfe")
    bad = CliRunner().invoke(main, ["fleet", "list", "--record", "garbage.jsonl"])
    assert bad.exit_code == 2 and "not a rollout record (not text)" in bad.output
    broken = Path("broken.fleet.json")
    broken.write_text('{"robots": []}')
    invalid = CliRunner().invoke(main, ["fleet", "list", "--fleet", str(broken)])
    assert invalid.exit_code == 1 and "error in the fleet file" in invalid.output
    for robot in graph.robots.values():
        robot.alive = False
    empty = CliRunner().invoke(main, ["fleet", "list"])
    assert empty.exit_code == 0 and empty.output == "no motivml robot on the graph\n"
    gone = CliRunner().invoke(main, ["fleet", "list", "--fleet", str(path)])
    assert gone.exit_code == 1 and gone.output.count("not running: no node on the graph") == 4
    # a record that cannot be made: said, exit 3, nothing asked
    Path("ro").mkdir()
    Path("ro").chmod(0o500)
    try:
        if os.access("ro", os.W_OK):  # (root writes anywhere: a path under a file instead)
            target = "fleet.json/r.jsonl"
        else:
            target = "ro/r.jsonl"
        unwritable = CliRunner().invoke(main, ["fleet", "apply", str(path), "swap", "hectorslam", "kartoslam", "--record", target])
    finally:
        Path("ro").chmod(0o700)
    assert unwritable.exit_code == 3 and graph.order == [], unwritable.output


@pytest.mark.parametrize(("answer", "kept"), [("n\n", True), ("y\n", False), ("", True)])
def test_ctrl_c_on_a_terminal_asks_and_an_answer_or_its_absence_decides(
    fake_graph: tuple[Path, FakeGraph], monkeypatch: pytest.MonkeyPatch, answer: str, kept: bool
) -> None:
    import signal

    import motivml.cli.fleeting as fleeting

    path, graph = fake_graph
    monkeypatch.setattr(fleeting, "_terminal", lambda: True)
    graph.robots["/r1"].after_change = lambda _: os.kill(os.getpid(), signal.SIGINT)
    args = ["fleet", "apply", str(path), "swap", "hectorslam", "kartoslam", "--healthy", "0", "--record", "r.jsonl"]
    result = CliRunner().invoke(main, args, input=answer)
    assert "interrupted: roll back the 1 robot changed? [Y/n]" in result.output
    if kept:
        assert result.exit_code == 130 and graph.order == ["/r1"]
    else:
        assert result.exit_code == 1 and graph.order == ["/r1", "/r1"]

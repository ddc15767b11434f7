"""The run's side of the ROS 2 bridge without ROS: the link, the bridge process, the door.

`Link` is tested between two ends in this process; `Bridge` and `Door` against a scripted
bridge process (tests/fake_bridge.py) that speaks the real bridge's side of the link, so
that what the run does when its bridge is silent, ends, refuses or takes no `exit` is
checked in the default .venv (test_ros2.py drives the real bridge on a real ROS graph).
Waiting is on a condition with a deadline, never a sleep.
"""

from __future__ import annotations

import importlib.util
import math
import os
import queue
import socket
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from helpers import until
from paths import SIMPLEBOT

from motivml.errors import EnvironmentProblem
from motivml.plugins import bridge as bridges
from motivml.plugins.bridge import Bridge, Link, LinkBroken, socket_pairs
from motivml.ros2 import door as doors
from motivml.runtime.launch import launch
from motivml.runtime.requests import Set
from motivml.runtime.session import Session

ROS = importlib.util.find_spec("rclpy") is not None
TESTS = Path(__file__).resolve().parent


# ---------------------------------------------------------------------- Link
class End:
    """One end of a link in this process: what it heard and how its link closed."""

    def __init__(self, asking: socket.socket, hearing: socket.socket, name: str) -> None:
        self.heard: queue.Queue[dict[str, Any]] = queue.Queue()
        self.closed: list[str] = []
        self.answers: dict[str, Callable[[dict[str, Any]], dict[str, Any]]] = {}
        self.link = Link(asking, hearing, self._handle, self.closed.append, name)

    def _handle(self, message: dict[str, Any]) -> None:
        op = message.get("op")
        if op in self.answers:
            self.link.answer(message, **self.answers[op](message))
        else:
            self.heard.put(message)


@pytest.fixture
def ends() -> Iterator[tuple[End, End]]:
    ours, theirs = socket_pairs()
    pair = End(*ours, "one"), End(*theirs, "two")
    yield pair
    for end in pair:
        end.link.close()


def test_a_call_is_answered_and_a_message_heard(ends: tuple[End, End]) -> None:
    one, two = ends
    two.answers["add"] = lambda m: {"sum": m["a"] + m["b"]}
    assert one.link.call("add", 5.0, a=2, b=3)["sum"] == 5
    one.link.send({"event": "news", "text": "ü"})
    assert two.heard.get(timeout=5.0) == {"event": "news", "text": "ü"}
    two.answers["back"] = lambda m: {"ok": True}
    one.answers["back"] = lambda m: {"from": "one"}
    assert two.link.call("back", 5.0)["from"] == "one"  # both ways at once


def test_a_handler_that_raises_answers_its_call_and_the_link_reads_on(
    ends: tuple[End, End], capfd: pytest.CaptureFixture[str]
) -> None:
    one, two = ends

    def broken(message: dict[str, Any]) -> dict[str, Any]:
        raise KeyError("wanted")

    two.answers["broken"] = broken
    answer = one.link.call("broken", 5.0)
    assert answer["error"].startswith("motivml: two: a 'broken' message failed: KeyError: 'wanted' (at test_bridge.py:")
    assert answer["error"] in capfd.readouterr().err
    two.answers["fine"] = lambda m: {"fine": True}
    assert one.link.call("fine", 5.0) == {"re": 2, "fine": True}


def test_a_call_nobody_answers_times_out_and_its_late_answer_is_skipped(ends: tuple[End, End]) -> None:
    one, two = ends
    with pytest.raises(TimeoutError, match="no answer to slow within 0.05 s"):
        one.link.call("slow", 0.05)
    late = two.heard.get(timeout=5.0)
    two.link.answer(late, late=True)
    two.answers["next"] = lambda m: {"next": True}
    assert one.link.call("next", 5.0) == {"re": 2, "next": True}


def test_the_other_end_closing_breaks_a_call_under_way(ends: tuple[End, End]) -> None:
    one, two = ends
    two.answers["close"] = lambda m: two.link.close() or {}
    with pytest.raises(LinkBroken):
        one.link.call("close", 5.0)
    until(lambda: one.closed, what="one's link closed")
    assert len(one.closed) == 1
    with pytest.raises(LinkBroken):
        one.link.send({"event": "late"})
    one.link.answer({"id": 9})  # an answer nobody waits for any more is dropped, not raised


def test_a_line_that_is_not_json_breaks_the_link(ends: tuple[End, End]) -> None:
    one, two = ends
    one.link._asking.sendall(b"{not json\n")
    until(lambda: two.closed, what="two's link closed")
    assert two.closed[0].startswith("the link broke: ")


# ---------------------------------------------------------------------- Bridge
@pytest.fixture
def scripted(monkeypatch: pytest.MonkeyPatch) -> None:
    """Bridges started from now on are tests/fake_bridge.py."""
    monkeypatch.setattr(bridges, "PROGRAM", "fake_bridge")
    path = os.environ.get("PYTHONPATH")
    monkeypatch.setenv("PYTHONPATH", str(TESTS) + (os.pathsep + path if path else ""))


def test_a_bridge_answers_calls_and_ends_when_asked(scripted: None) -> None:
    bridge = Bridge("/ward")
    assert bridge.call("echo", 5.0, text="hi") == {"re": 1, "text": "hi"}
    bridge.close()
    assert bridge.process.returncode == 0


def test_a_call_from_the_bridge_nobody_handles_is_answered_with_why(scripted: None) -> None:
    bridge = Bridge("/ward")
    try:
        answer = bridge.call("ask", 5.0, kind="mystery")["answer"]
        assert answer["error"] == "nothing in this run answers 'mystery'"
        bridge.on("mystery", lambda m: bridge.link.answer(m, known=True))
        assert bridge.call("ask", 5.0, kind="mystery")["answer"]["known"] is True
    finally:
        bridge.close()


def test_a_bridge_that_cannot_be_started_is_an_environment_error(
    scripted: None, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr("sys.executable", str(tmp_path / "no-python"))
    with pytest.raises(EnvironmentProblem) as raised:
        Bridge("/ward")
    [problem] = raised.value.diagnostics
    assert problem.rule == "ros2.start"
    assert problem.message.startswith("the ROS 2 bridge could not start: [Errno 2] No such file or directory")


def test_a_bridge_that_never_gets_ready_is_killed(scripted: None, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(bridges, "START_TIMEOUT", 0.2)
    started: list[Bridge] = []
    kill = Bridge.kill

    def killing(self: Bridge) -> None:
        started.append(self)
        kill(self)

    monkeypatch.setattr(Bridge, "kill", killing)
    with pytest.raises(EnvironmentProblem, match="the ROS 2 bridge did not start within 0.2 s"):
        Bridge("/silent")
    [bridge] = started
    assert bridge.process.returncode == -9


def test_a_bridge_that_ends_as_it_starts_is_an_environment_error(scripted: None) -> None:
    with pytest.raises(EnvironmentProblem) as raised:
        Bridge("/mute")
    assert raised.value.diagnostics[0].message == "the ROS 2 bridge process ended (exit 5) as it started"


def test_a_bridge_that_dies_breaks_the_calls_and_tells_its_users(scripted: None) -> None:
    bridge = Bridge("/ward")
    told: list[str] = []
    bridge.ended.append(told.append)
    with pytest.raises(LinkBroken, match=r"^the ROS 2 bridge process ended \(exit 7\)$"):
        bridge.call("die", 5.0)
    until(lambda: told, what="the users told")
    assert told == ["the ROS 2 bridge process ended (exit 7)"]
    with pytest.raises(LinkBroken, match=r"\(exit 7\)"):
        bridge.call("echo", 5.0)
    bridge.close()  # nothing to ask: it ends quietly


def test_a_bridge_that_takes_no_exit_is_killed(scripted: None, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(bridges, "END_TIMEOUT", 0.2)
    bridge = Bridge("/stubborn")
    bridge.close()
    assert bridge.process.returncode == -9


def test_a_bridge_is_kept_to_the_cpus_it_is_given(scripted: None) -> None:
    cpus = sorted(os.sched_getaffinity(0))
    bridge = Bridge("/ward", frozenset(cpus[-1:]))
    try:
        assert bridge.call("affinity", 5.0)["cpus"] == cpus[-1:]
    finally:
        bridge.close()


def test_a_bridge_has_a_process_group_of_its_own_in_the_runs_session(scripted: None) -> None:
    """Out of the terminal's Ctrl-C (a group of its own), in the run's autogroup (its session):
    a session of its own competed with the run's loop for the CPU as an equal."""
    bridge = Bridge("/ward")
    try:
        assert os.getpgid(bridge.process.pid) == bridge.process.pid != os.getpgid(0)
        assert os.getsid(bridge.process.pid) == os.getsid(0)
    finally:
        bridge.close()


def test_one_bridge_a_namespace_ends_with_its_last_user(scripted: None) -> None:
    first = bridges.open_bridge("/ward")
    second = bridges.open_bridge("/ward")
    other = bridges.open_bridge("/other")
    assert first is second and other is not first
    bridges.release_bridge(first)
    assert first.process.poll() is None
    bridges.release_bridge(second)
    bridges.release_bridge(other)
    assert first.process.returncode == 0 and other.process.returncode == 0


# ---------------------------------------------------------------------- Door
@pytest.fixture
def running(scripted: None, monkeypatch: pytest.MonkeyPatch) -> Iterator[Session]:
    """SimpleBot field running on the real clock; doors think ROS 2 is installed."""
    monkeypatch.setattr(doors, "ros2_missing", lambda: None)
    session = Session(launch(SIMPLEBOT, "field", rate=200.0), math.inf, "real", run_dir=None)
    session.open()
    session.start()
    yield session
    session.runtime.stop()
    session.wait(10)
    session.close()


def heard(door: doors.Door) -> list[dict[str, Any]]:
    return list(door.bridge.call("heard", 5.0)["heard"])


def test_the_door_describes_the_robot_to_the_bridge(running: Session) -> None:
    door = doors.start(running.robot, "/ward")
    try:
        assert door.name == "/ward/motivml"
        [described] = heard(door)
        features = {f["id"]: f for f in described["features"]}
        assert described["robot"] == "simplebot" and described["variant"] == "field"
        assert features["base_controller"] == {"id": "base_controller", "words": "Static Early", "read_only": True}
        assert features["kartoslam"]["read_only"] is False
        assert "component_control" not in features or features["component_control"]["read_only"]
        assert described["active"] == door._ordered(running.robot.binder.active)
    finally:
        door.close()
    assert door.bridge.process.returncode == 0


def test_a_set_from_the_node_is_one_request_to_the_binder(running: Session) -> None:
    door = doors.start(running.robot, "/ward")
    try:
        swap = door.bridge.call("ask", 15.0, kind="set", fields={"wanted": {"hectorslam": False, "kartoslam": True}})
        assert swap["answer"]["accepted"] is True
        assert "kartoslam" in swap["answer"]["active"] and "hectorslam" not in swap["answer"]["active"]
        assert swap["answer"]["told"] == 1  # the number of the latest outcome told: the swap's own
        same = door.bridge.call("ask", 15.0, kind="set", fields={"wanted": {"kartoslam": True}})
        assert same["answer"] == {"re": 2, "accepted": True, "active": swap["answer"]["active"], "told": 1}
        # (the ids are the bridge's calls to the run: one per `ask`)
        odd = door.bridge.call("ask", 15.0, kind="set", fields={"wanted": 5})
        assert odd["answer"]["error"].startswith("motivml could not handle the call: TypeError")
        both = door.bridge.call("ask", 15.0, kind="set", fields={"wanted": {"kartoslam": True, "orbslam": True}})
        assert both["answer"]["accepted"] is False and "orbslam" in both["answer"]["reason"]
        news = until(lambda: [m for m in heard(door) if m.get("event") == "outcome"], what="the news")
        assert news[0]["accepted"] is True and news[0]["loads"] == ["kartoslam"]
        assert news[0]["unloads"] == ["hectorslam"] and news[0]["change"] is not None
        assert news[0]["told"] == 1 and news[0]["active"] == swap["answer"]["active"]
        until(lambda: len([m for m in heard(door) if m.get("event") == "outcome"]) == 2, what="the refusal")
        outcomes = [m for m in heard(door) if m.get("event") == "outcome"]
        assert [m["told"] for m in outcomes] == [1, 2] and outcomes[1]["accepted"] is False
    finally:
        door.close()


def test_the_door_passes_on_changes_from_elsewhere_and_the_loop_health(
    running: Session, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(doors, "DIAGNOSTICS_PERIOD", 0.05)
    door = doors.start(running.robot, "/ward")
    try:
        outcome = running.robot.binder.request(Set(("kartoslam",), ("hectorslam",)))
        assert outcome.accepted, outcome.reason
        until(lambda: any(m.get("event") == "outcome" for m in heard(door)), what="the news")
        health = until(lambda: [m for m in heard(door) if m.get("event") == "health"], what="the health")
        loop = health[0]["statuses"][0]
        assert loop["name"] == "loop" and loop["level"] in ("OK", "WARN")
        assert ["rate", "200"] in loop["values"]
    finally:
        door.close()


def test_the_health_says_what_is_wrong(running: Session, monkeypatch: pytest.MonkeyPatch) -> None:
    door = doors.start(running.robot, "/ward")
    try:
        runtime = running.runtime
        monkeypatch.setattr(runtime, "missed", runtime.missed + 1)
        [loop, *_] = door.health()
        assert loop["level"] == "OK" and loop["message"] == "running (1 deadlines missed in the last second)"
        monkeypatch.setattr(runtime, "missed", runtime.missed + 1_000_000)
        loop, *features = door.health()
        assert loop["level"] == "WARN" and loop["message"] == "1000000 deadlines missed in the last second"
        statuses = {s["name"]: s for s in features}
        assert statuses["feature hectorslam"]["message"] == "active"
        assert statuses["feature kartoslam"] == {
            "name": "feature kartoslam",
            "level": "OK",
            "message": "inactive",
            "values": [("binding", "Dynamic Late")],
        }
        instance = runtime.plugins["hectorslam"].instance

        def status() -> str:
            raise RuntimeError("no status today")

        monkeypatch.setattr(instance, "status", status)
        [_, *features] = door.health()
        values = dict({s["name"]: s for s in features}["feature hectorslam"]["values"])
        assert values["status"] == "status() raised RuntimeError"
        monkeypatch.setattr(runtime.plugins["hectorslam"], "faulted", True)
        monkeypatch.setattr(runtime, "faults", [_fault("hectorslam"), _fault("kartoslam")])
        [loop, *features] = door.health()
        statuses = {s["name"]: s for s in features}
        assert statuses["feature hectorslam"]["level"] == "ERROR"
        assert statuses["feature hectorslam"]["message"] == "faulted: RuntimeError: broken"
        assert statuses["feature kartoslam"]["level"] == "WARN"
        assert statuses["feature kartoslam"]["message"] == "unloaded after a fault: RuntimeError: broken"
        monkeypatch.setattr(runtime, "failure", _fault("base_controller"))
        [loop, *_] = door.health()
        assert loop["level"] == "ERROR" and loop["message"] == "stopped by the fault of base_controller"
    finally:
        door.close()
        door.close()  # once is enough: the second does nothing


def _fault(feature: str) -> Any:
    from motivml.runtime.loop import Fault

    return Fault(tick=0, time=0.0, feature=feature, error="RuntimeError: broken", static=True)


def test_a_door_the_bridge_refuses_is_an_environment_error(running: Session) -> None:
    with pytest.raises(EnvironmentProblem, match="the node /refusing/motivml runs already"):
        doors.start(running.robot, "/refusing")
    assert "/refusing" not in bridges._bridges  # released: its bridge has ended


def test_a_door_whose_bridge_cannot_start_is_an_environment_error(running: Session) -> None:
    with pytest.raises(EnvironmentProblem, match=r"ended \(exit 5\) as it started"):
        doors.start(running.robot, "/mute")
    with pytest.raises(EnvironmentProblem, match=r"ros2: ROS 2 could not start: the ROS 2 bridge process ended \(exit 7\)$"):
        doors.start(running.robot, "/fragile")


@pytest.mark.skipif(ROS, reason="this Python has rclpy")
def test_a_door_without_rclpy_says_how_to_get_it() -> None:
    robot = launch(SIMPLEBOT, "field")
    try:
        with pytest.raises(EnvironmentProblem, match=r"No module named 'rclpy'"):
            doors.start(robot, "/")
    finally:
        robot.close()


def test_a_door_whose_bridge_dies_carries_on_without_it(running: Session, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(doors, "DIAGNOSTICS_PERIOD", 0.05)
    door = doors.start(running.robot, "/ward")
    with pytest.raises(LinkBroken):
        door.bridge.call("die", 5.0)
    outcome = running.robot.binder.request(Set(("kartoslam",), ("hectorslam",)))
    assert outcome.accepted, outcome.reason  # the news is lost, the change is not
    until(lambda: not door._health.is_alive(), what="the health reports to end")
    door.close()

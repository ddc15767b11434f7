"""The run session: the loop's thread, scheduled requests, the control socket, Ctrl-C, shutdown."""

from __future__ import annotations

import signal
import threading
from pathlib import Path

import pytest

from motivml.errors import EnvironmentProblem
from motivml.runtime.launch import launch
from motivml.runtime.requests import Request
from motivml.runtime.session import Session

ROOT = Path(__file__).resolve().parent.parent
SIMPLEBOT = ROOT / "feature_models" / "simplebot"


def _run(session: Session) -> None:
    session.open()
    session.start()
    assert session.wait(60), "the session's loop did not end"


def test_scheduled_requests_are_answered_and_their_changes_reported_once() -> None:
    plan = [
        (1.0, Request("swap", ("kartoslam", "hectorslam"))),
        (0.5, Request("swap", ("hectorslam", "kartoslam"))),
    ]
    session = Session(launch(SIMPLEBOT, "field"), 2.0, "simulated", plan)
    _run(session)
    session.close()
    answers = session.answers()
    assert [str(a.request) for a in answers] == ["swap hectorslam kartoslam", "swap kartoslam hectorslam"]
    assert all(a.outcome.accepted for a in answers)
    assert [a.tick for a in answers] == [500, 1000]  # made between two ticks at the asked control time
    changes = session.new_changes()
    assert [c.request for c in changes] == ["swap hectorslam kartoslam", "swap kartoslam hectorslam"]
    assert session.new_changes() == []  # each change is reported once
    assert session.stats is not None and session.stats.ticks == 2000
    assert not session.interrupted.is_set() and not session.unsettled


def test_a_refused_scheduled_request_changes_nothing() -> None:
    session = Session(launch(SIMPLEBOT, "field"), 1.0, "simulated", [(0.1, Request("load", ("kartoslam",)))])
    _run(session)
    session.close()
    (answer,) = session.answers()
    assert not answer.outcome.accepted and answer.outcome.diagnostics
    assert session.new_changes() == []


def test_the_feed_reads_tick_time_and_rate() -> None:
    session = Session(launch(ROOT / "feature_models" / "quadruped", "trot"), 0.5, "simulated")
    _run(session)
    session.close()
    feed = session.feed()
    assert feed.snapshot.tick == 500 and feed.rate == 1000.0 and feed.coordination is None
    assert {c.id for c in feed.snapshot.components} >= {"TrotGenerator"}


def test_the_control_socket_is_open_during_the_run_and_removed_after(tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    session = Session(launch(SIMPLEBOT, "field"), 0.2, "simulated", run_dir=run_dir)
    session.open()
    assert session.server is not None and session.server.path.is_socket()
    session.start()
    assert session.wait(60)
    session.close()
    assert not session.server.path.exists()


def test_a_socket_that_cannot_open_closes_the_robot(tmp_path: Path) -> None:
    blocker = tmp_path / "run"
    blocker.write_text("a file where the run directory should be")
    robot = launch(SIMPLEBOT, "field")
    assert robot.runtime.plugins  # hectorslam runs from the start
    session = Session(robot, 1.0, "simulated", run_dir=blocker)
    with pytest.raises(EnvironmentProblem):
        session.open()
    assert robot.runtime.plugins == {}  # closing the robot stopped its plugins


def test_ctrl_c_ends_the_run_and_a_second_one_calls_on_stuck() -> None:
    """The handler itself, called as the signal would call it: first stop, then give up."""
    stuck = threading.Event()
    session = Session(launch(SIMPLEBOT, "field"), 3600.0, "real", on_stuck=stuck.set)
    session.open()
    session.start()  # on the main thread: the session owns SIGINT now
    assert signal.getsignal(signal.SIGINT) == session._interrupt
    session._interrupt(signal.SIGINT, None)
    assert session.wait(60) and session.interrupted.is_set() and not stuck.is_set()
    session._interrupt(signal.SIGINT, None)
    assert stuck.is_set()
    session.close()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler

"""run --priority: the loop's thread under SCHED_FIFO, and a clear refusal where it may not."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from motivml.cli import main
from motivml.runtime.loop import SPIN_REALTIME, RealClock, realtime_problem

SIMPLEBOT = Path(__file__).resolve().parent.parent / "feature_models" / "simplebot"
RUN = ["run", str(SIMPLEBOT), "--variant", "field", "--no-live", "--no-control"]


def run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, [*RUN, *args])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


def refuse(monkeypatch: pytest.MonkeyPatch) -> None:
    """This process may not use real-time scheduling, as without root or CAP_SYS_NICE."""

    def refused(*args: Any) -> None:
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(os, "sched_setscheduler", refused)


def test_a_priority_outside_1_to_99_is_a_usage_error() -> None:
    code, output = run("--priority", "0", "--duration", "0.01")
    assert code == 2 and "--priority" in output and "1<=x<=99" in output


def test_a_priority_is_for_the_real_clock() -> None:
    code, output = run("--priority", "10", "--clock", "simulated", "--duration", "0.01")
    assert code == 2 and "a priority is for the real clock" in output


def test_a_process_that_may_not_is_told_how_to_allow_it(monkeypatch: pytest.MonkeyPatch) -> None:
    refuse(monkeypatch)
    problem = realtime_problem(10)
    assert problem is not None and problem.startswith(
        "this process may not use real-time scheduling (Operation not permitted): run it as root, give it "
        "CAP_SYS_NICE, or raise its real-time priority limit (ulimit -r 10; LimitRTPRIO=10 in a systemd unit)"
    )
    code, output = run("--priority", "10", "--duration", "0.01")
    assert code == 3, output
    assert output.startswith("run --priority: this process may not use real-time scheduling"), output
    assert "Traceback" not in output


def test_the_probe_changes_no_thread_of_the_caller() -> None:
    before = os.sched_getscheduler(0)
    realtime_problem(10)
    assert os.sched_getscheduler(0) == before


def test_the_loop_ticks_under_sched_fifo_and_sleeps_closer_to_each_deadline(monkeypatch: pytest.MonkeyPatch) -> None:
    problem = realtime_problem(10)
    if problem is not None:
        pytest.skip(f"real-time scheduling is not allowed here: {problem}")
    seen: list[tuple[int, int, float]] = []
    enter = RealClock.enter

    def watched(self: RealClock) -> None:
        enter(self)
        seen.append((os.sched_getscheduler(0), os.sched_getparam(0).sched_priority, self.spin))

    monkeypatch.setattr(RealClock, "enter", watched)
    main_thread = os.sched_getscheduler(0)
    code, output = run("--priority", "10", "--duration", "0.05")
    assert code == 0, output
    assert "1000 Hz, real clock, real-time priority 10, 0.05 s" in output
    assert seen == [(os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 10, SPIN_REALTIME)]  # (children start ordinary)
    assert os.sched_getscheduler(0) == main_thread  # (the loop ran on a thread of its own)

"""The run session: the loop's thread, scheduled requests, the control socket, Ctrl-C, shutdown."""

from __future__ import annotations

import re
import signal
import threading
from pathlib import Path

import pytest
from paths import ROOT, SIMPLEBOT

from motivml.errors import EnvironmentProblem
from motivml.runtime.launch import launch
from motivml.runtime.requests import Load, Swap
from motivml.runtime.session import End, Session, ending


def _run(session: Session) -> None:
    session.open()
    session.start()
    assert session.wait(60), "the session's loop did not end"


def test_scheduled_requests_are_answered_and_their_changes_reported_once() -> None:
    plan = [
        (1.0, Swap("kartoslam", "hectorslam")),
        (0.5, Swap("hectorslam", "kartoslam")),
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
    session = Session(launch(SIMPLEBOT, "field"), 1.0, "simulated", [(0.1, Load(("kartoslam",)))])
    _run(session)
    session.close()
    (answer,) = session.answers()
    assert not answer.outcome.accepted and answer.outcome.diagnostics
    assert session.new_changes() == []


def test_how_a_run_ended_gives_its_record_row_and_its_exit_code() -> None:
    """One `End` says how the run ended; the exit code follows from it and from what went
    wrong on the way (checked here by setting what a signal or a failed stop() would)."""
    import signal

    session = Session(launch(SIMPLEBOT, "field"), 0.1, "simulated")
    _run(session)
    session.close()
    assert session.end() is End.ELAPSED and ending(session) == "its duration elapsed"
    assert session.exit_code() == 0
    session.stopped_by = signal.SIGTERM  # a service manager's stop: a normal end
    assert session.end() is End.SIGNALLED and ending(session) == "stopped by SIGTERM"
    assert session.exit_code() == 0
    session.stopped_by = signal.SIGINT
    assert session.exit_code() == 130
    session.stopped_by = None
    session.robot.binder.failed_stops.append("kartoslam")
    assert session.end() is End.ELAPSED and session.exit_code() == 1
    session.stats = None
    assert session.end() is End.NO_RESULT and session.exit_code() == 3


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
    """The handler itself, called as the signal would call it: first stop, then give up;
    and the handler before the session is given back (Python's own, or SIG_IGN where the
    process was started with Ctrl-C ignored, as a shell's background job is)."""
    before = signal.getsignal(signal.SIGINT)
    stuck = threading.Event()
    session = Session(launch(SIMPLEBOT, "field"), 3600.0, "real", on_stuck=lambda signum: stuck.set())
    session.open()
    session.start()  # on the main thread: the session owns SIGINT now
    assert signal.getsignal(signal.SIGINT) == session._interrupt
    session._interrupt(signal.SIGINT, None)
    assert session.wait(60) and session.interrupted.is_set() and not stuck.is_set()
    session._interrupt(signal.SIGINT, None)
    assert stuck.is_set()
    session.close()
    assert signal.getsignal(signal.SIGINT) is before


def test_a_second_sigterm_on_a_stuck_loop_leaves_no_socket_and_no_registration(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 31: a second SIGTERM ended the process with 130 and left the control socket
    and the run's registration for ctl to find. Both go first, and the code says SIGTERM."""
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    ended: list[int] = []
    session = Session(launch(SIMPLEBOT, "field"), 3600.0, "real", (), tmp_path / "run", on_stuck=ended.append)
    session.open()
    assert session.server is not None and session.registered is not None
    socket_path, entry = session.server.path, session.registered.entry
    assert socket_path.is_socket() and entry.exists()
    session.start()
    session._interrupt(signal.SIGTERM, None)
    assert session.wait(60)
    session._interrupt(signal.SIGTERM, None)  # as if the loop had not stopped
    assert ended == [signal.SIGTERM] and not socket_path.exists() and not entry.exists()
    session.close()


def test_sigterm_stops_the_run_like_ctrl_c_and_is_remembered() -> None:
    stuck = threading.Event()
    session = Session(launch(SIMPLEBOT, "field"), float("inf"), "real", on_stuck=lambda signum: stuck.set())
    session.open()
    session.start()
    assert signal.getsignal(signal.SIGTERM) == session._interrupt
    session._interrupt(signal.SIGTERM, None)
    assert session.wait(60) and session.stopped_by == signal.SIGTERM
    session.close()
    assert session.runtime.plugins == {}  # the plugins were stopped
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL


def test_a_run_under_a_service_manager_runs_until_sigterm_then_cleans_up(tmp_path: Path) -> None:
    """`run --duration inf` as a service: SIGTERM gives the summary, stops plugins, removes the socket, exits 0."""
    import subprocess
    import sys

    run_dir = tmp_path / "run"
    command = [sys.executable, "-m", "motivml.cli", "run", str(SIMPLEBOT), "--variant", "field"]
    command += ["--duration", "inf", "--no-live", "--run-dir", str(run_dir)]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert process.stdout is not None
    seen = []
    for line in process.stdout:  # the socket is announced once it listens: no sleeping
        seen.append(line)
        if line.startswith("control: "):
            break
    assert "until stopped" in seen[0], seen
    assert (run_dir / "control.sock").is_socket()
    process.send_signal(signal.SIGTERM)
    rest, _ = process.communicate(timeout=60)
    assert process.returncode == 0, rest
    # (the summary's ticks line; on a busy machine "slowest plugin steps" may follow it)
    assert "plugin hectorslam: " in rest and any(re.match(r"\d+ ticks?, ", line) for line in rest.splitlines()), rest
    assert not (run_dir / "control.sock").exists()


@pytest.mark.parametrize("option", ["--duration", "--rate"])
def test_nan_durations_and_rates_are_usage_errors(option: str) -> None:
    from click.testing import CliRunner

    from motivml.cli import main

    result = CliRunner().invoke(main, ["run", str(SIMPLEBOT), "--variant", "field", option, "nan"])
    assert result.exit_code == 2 and "'nan' is not a finite number" in result.output


@pytest.mark.parametrize("value", ["1e308", "1e10", "-inf"])
def test_a_duration_past_the_bound_is_a_usage_error(value: str) -> None:
    """Issue 31: `run --duration 1e308` was an OverflowError traceback; a duration above
    10^9 s (31 years; inf runs until stopped) is refused before anything starts."""
    from click.testing import CliRunner

    from motivml.cli import main

    result = CliRunner().invoke(main, ["run", str(SIMPLEBOT), "--variant", "field", "--duration", value])
    assert result.exit_code == 2, result.output
    assert "--duration" in result.output and "Traceback" not in result.output


def test_a_second_run_on_the_same_socket_is_refused_and_leaves_the_first_ones_socket(tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    first = Session(launch(SIMPLEBOT, "field"), 1.0, "simulated", run_dir=run_dir)
    first.open()
    second = Session(launch(SIMPLEBOT, "field"), 1.0, "simulated", run_dir=run_dir)
    with pytest.raises(EnvironmentProblem, match="another run is listening here"):
        second.open()
    assert (run_dir / "control.sock").is_socket()  # the first run's socket is still there
    first.close()
    assert not (run_dir / "control.sock").exists()


def test_run_refused_by_a_listening_run_announces_nothing(tmp_path: Path) -> None:
    """Issue 31: `run` printed its header ("running SimpleBot ...") and then refused,
    another run listening on its socket. The header comes once the socket is open."""
    from click.testing import CliRunner

    from motivml.cli import main

    run_dir = tmp_path / "run"
    first = Session(launch(SIMPLEBOT, "field"), 1.0, "simulated", run_dir=run_dir)
    first.open()
    try:
        args = ["run", str(SIMPLEBOT), "--variant", "field", "--clock", "simulated", "--duration", "0.1"]
        result = CliRunner().invoke(main, [*args, "--run-dir", str(run_dir)])
    finally:
        first.close()
    assert result.exit_code == 3, result.output
    assert "another run is listening here" in result.output
    assert "running" not in result.output and "control:" not in result.output


LOGGING_PLUGIN = """
from motivml.plugins.api import FeaturePlugin

class Plugin(FeaturePlugin):
    def start(self):
        self.context.log("started \\x1b[31mred\\x1b[0m")
    def step(self, time):
        pass
    def stop(self):
        self.context.log("stopping: bye")
"""


def test_the_run_logs_as_it_happens_with_refusals_stop_logs_and_no_terminal_escapes(tmp_path: Path) -> None:
    from click.testing import CliRunner
    from test_transactions import make_robot

    from motivml.cli import main

    folder = make_robot(tmp_path / "bot", {"a": {}, "b": {}, "d": {}})
    (folder / "plugins" / "a" / "mod_a.py").write_text(LOGGING_PLUGIN)
    command = [
        "run",
        str(folder),
        "--variant",
        "v",
        "--duration",
        "1",
        "--clock",
        "simulated",
        "--no-control",
    ]
    result = CliRunner().invoke(main, [*command, "--no-live", "--at", "0.5", "load b"])
    lines = result.output.splitlines()
    assert result.exit_code == 0, result.output
    assert "\x1b" not in result.output  # a plugin cannot drive the terminal
    started = lines.index("at 0.000 s (tick 0): a: started \\x1b[31mred\\x1b[0m")
    refused = next(
        i for i, line in enumerate(lines) if line.startswith("at 0.500 s (tick 500): refused load b: ")
    )
    summary = next(i for i, line in enumerate(lines) if line.startswith("1000 ticks"))
    assert started < refused < summary  # the log comes before the summary, in order
    assert lines[-1] == "at 1.000 s (tick 1000): a: stopping: bye"  # said while the run closed

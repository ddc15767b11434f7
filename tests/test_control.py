"""The run's control socket and motivml ctl: permissions, protocol, and a session."""

from __future__ import annotations

import json
import os
import socket
import stat
import sys
import threading
import types
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from paths import SIMPLEBOT

from motivml.cli import main
from motivml.errors import EnvironmentProblem
from motivml.runtime import control
from motivml.runtime.control import LINE_LIMIT, ControlServer, send
from motivml.runtime.launch import Robot, launch
from motivml.runtime.loop import RealClock


@pytest.fixture
def running(tmp_path: Path) -> Iterator[tuple[Robot, ControlServer]]:
    """SimpleBot field on the real clock in a background thread, its socket open."""
    robot = launch(SIMPLEBOT, "field")
    server = ControlServer(tmp_path / "run", robot.runtime, robot.binder)
    server.open()
    ticking = threading.Event()
    robot.runtime.after_each_tick(ticking.set)
    loop = threading.Thread(target=robot.runtime.run, args=(60.0, RealClock()), daemon=True)
    loop.start()
    assert ticking.wait(30)  # a change is then committed at a tick after the first
    yield robot, server
    robot.runtime.stop()
    loop.join()
    server.close()
    robot.close()


def test_only_the_owner_can_reach_the_socket(running: tuple[Robot, ControlServer]) -> None:
    _, server = running
    assert stat.S_IMODE(server.run_dir.stat().st_mode) == 0o700
    assert stat.S_IMODE(server.path.lstat().st_mode) == 0o600
    assert stat.S_ISSOCK(server.path.lstat().st_mode)


def test_status_swap_refusal_and_dump(running: tuple[Robot, ControlServer]) -> None:
    robot, server = running
    status = send(server.run_dir, {"op": "status"})
    assert status["ok"] and "hectorslam" in status["active"]
    assert [p["feature"] for p in status["plugins"]] == ["hectorslam"]
    [slam] = status["plugins"]  # it has stepped: its longest step is there, to find a slow plugin
    assert slam["slowest_step_ms"] >= 0 and slam["slowest_step_tick"] >= 1
    refused = send(server.run_dir, {"op": "load", "features": ["kartoslam"]})
    assert refused["ok"] and not refused["accepted"]
    assert refused["diagnostics"][0]["message"].startswith("hectorslam and kartoslam are alternatives")
    accepted = send(server.run_dir, {"op": "swap", "features": ["hectorslam", "kartoslam"]})
    assert (
        accepted["accepted"] and accepted["loads"] == ["kartoslam"] and accepted["unloads"] == ["hectorslam"]
    )
    assert accepted["tick"] > 0 and accepted["latency_ms"] >= 0
    dump = send(server.run_dir, {"op": "dump"})
    assert [c["request"] for c in dump["changes"]] == ["swap hectorslam kartoslam"]
    assert dump["changes"][0]["tick"] == accepted["tick"] and "PoseEstimate" in dump["spaces"]
    assert set(robot.runtime.plugins) == {"kartoslam"}


@pytest.mark.parametrize(
    ("line", "error"),
    [
        (b"{not json\n", "not a JSON line"),
        (b"[1, 2]\n", 'a request is an object with "op"'),
        (b'{"op": "explode"}\n', "unknown op 'explode'"),
        (b'{"op": "load"}\n', 'load needs "features"'),
        (b'{"op": "swap", "features": ["a"]}\n', "swap needs two features"),
        (b"\xff\xfe\n", "not a JSON line"),
        (b"[" * 5000 + b"\n", "not a JSON line"),
    ],
)
def test_bad_requests_get_an_answer_and_the_run_goes_on(
    running: tuple[Robot, ControlServer], line: bytes, error: str
) -> None:
    robot, server = running
    client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    client.settimeout(10)
    client.connect(str(server.path))
    with client, client.makefile("rwb") as stream:
        stream.write(line)
        stream.flush()
        answer = json.loads(stream.readline())
        assert answer["ok"] is False and error in answer["error"]
        stream.write(b'{"op": "status"}\n')  # the same connection still works
        stream.flush()
        assert json.loads(stream.readline())["ok"] is True
    assert not robot.runtime.stop_requested.is_set()


def test_a_second_run_cannot_take_a_live_socket(running: tuple[Robot, ControlServer]) -> None:
    robot, server = running
    with pytest.raises(EnvironmentProblem, match="another run is listening here"):
        ControlServer(server.run_dir, robot.runtime, robot.binder).open()


def test_ctl_prints_results_and_exit_codes(running: tuple[Robot, ControlServer]) -> None:
    _, server = running
    runner = CliRunner()
    base = ["ctl", str(SIMPLEBOT), "--variant", "field", "--run-dir", str(server.run_dir)]
    before = runner.invoke(main, [*base, "status"])
    assert before.exit_code == 0 and "plugin hectorslam: pose" in before.output
    assert " (slowest step " in before.output.split("plugin hectorslam: ")[1]
    refused = runner.invoke(main, [*base, "load", "orbslam"])
    assert refused.exit_code == 1
    assert "refused: hectorslam and orbslam are alternatives in slam's XOR group" in refused.output
    assert refused.output.splitlines()[-1] == "refused: load orbslam: nothing changed"
    accepted = runner.invoke(main, [*base, "swap", "hectorslam", "orbslam"])
    assert accepted.exit_code == 0, accepted.output
    assert accepted.output.startswith("accepted: swap hectorslam orbslam took effect at tick ")
    assert accepted.output.rstrip().endswith("loaded orbslam; unloaded hectorslam")
    status = runner.invoke(main, [*base, "status"])
    assert status.exit_code == 0 and "plugin orbslam: pose" in status.output
    assert runner.invoke(main, [*base, "swap", "orbslam"]).exit_code == 2
    dump = runner.invoke(main, [*base, "dump"])
    assert json.loads(dump.output)["changes"][0]["request"] == "swap hectorslam orbslam"


def test_ctl_without_a_run_says_so(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        main, ["ctl", str(SIMPLEBOT), "--variant", "field", "--run-dir", str(tmp_path), "status"]
    )
    assert result.exit_code == 3 and "no run is listening here" in result.output


# ------------------------------------- events, long lines, idle clients, stale sockets
ARM = SIMPLEBOT.parent / "coordinated_arm"


def converse(path: Path, *lines: bytes) -> list[Any]:
    """Send raw lines on one connection; each answer, then None if the server hung up."""
    client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    client.settimeout(30)
    client.connect(str(path))
    answers: list[Any] = []
    with client, client.makefile("rb") as stream:
        for line in lines:
            try:
                client.sendall(line)
            except (BrokenPipeError, ConnectionResetError):
                answers.append(None)  # the server had hung up
                break
            answer = stream.readline()
            answers.append(json.loads(answer) if answer else None)
            if not answer:
                break
    return answers


@pytest.fixture
def coordinated(tmp_path: Path) -> Iterator[tuple[Robot, ControlServer]]:
    """The coordinated arm on the simulated clock, ticked by the test; its socket open."""
    robot = launch(ARM, "attractor")
    server = ControlServer(tmp_path / "run", robot.runtime, robot.binder)
    server.open()
    server.coordinator = robot.coordinate(simulated=True)  # as a run's session does
    yield robot, server
    server.close()
    robot.close()


def test_ctl_event_reaches_the_coordination(coordinated: tuple[Robot, ControlServer]) -> None:
    robot, server = coordinated
    robot.runtime.run(0.1)
    assert server.coordinator.configuration() == ["Working", "ReachOut"]
    result = CliRunner().invoke(
        main, ["ctl", str(ARM), "--variant", "attractor", "--run-dir", str(server.run_dir), "event", "stop"]
    )
    assert result.exit_code == 0 and result.output == "event stop queued for the coordination\n"
    robot.runtime.run(0.1)  # handled at the chart's next step
    assert server.coordinator.finished is not None and server.coordinator.finished[2] == "Done"
    log = [text for _, _, text in robot.runtime.notes]
    assert log.index("event stop (from the control socket)") < log.index(
        "coordination: stopped by the operator"
    )
    assert send(server.run_dir, {"op": "event", "name": "again"}) == {
        "ok": True,
        "op": "event",
        "name": "again",
    }


@pytest.mark.parametrize(
    "request_",
    [
        {"op": "event"},
        {"op": "event", "name": ""},
        {"op": "event", "features": "stop"},
        {"op": "event", "features": 5},
    ],
)
def test_an_event_without_one_name_is_refused(
    coordinated: tuple[Robot, ControlServer], request_: dict[str, Any]
) -> None:
    robot, server = coordinated
    assert send(server.run_dir, request_) == {"ok": False, "error": 'event needs "name"'}
    assert not any(text.startswith("event") for _, _, text in robot.runtime.notes)


def test_an_event_for_a_robot_without_coordination_says_so(running: tuple[Robot, ControlServer]) -> None:
    _, server = running
    answer = send(server.run_dir, {"op": "event", "name": "go"})
    assert answer == {"ok": False, "error": "this robot has no coordination statechart to send events to"}
    result = CliRunner().invoke(
        main, ["ctl", str(SIMPLEBOT), "--variant", "field", "--run-dir", str(server.run_dir), "event", "go"]
    )
    assert result.exit_code == 2 and "this robot has no coordination statechart" in result.output


def test_a_request_line_over_64_kib_is_refused_and_the_connection_closed(
    coordinated: tuple[Robot, ControlServer],
) -> None:
    robot, server = coordinated
    head, tail = b'{"op": "status", "x-pad": "', b'"}\n'
    longest = head + b"x" * (LINE_LIMIT - len(head) - len(tail)) + tail  # the newline included
    assert len(longest) == LINE_LIMIT
    assert converse(server.path, longest)[0]["ok"] is True
    refused, after = converse(server.path, longest[:-3] + b'x"}\n', b'{"op": "status"}\n')
    assert refused == {"ok": False, "error": "a request line is at most 65536 bytes"}
    assert after is None  # the server hung up: the rest of such a line is not read as requests
    assert converse(server.path, b'{"op": "status"}\n')[0]["ok"] is True  # others are still served
    assert not robot.runtime.stop_requested.is_set()


def test_an_unexpected_failure_is_an_answer_and_the_connection_goes_on(
    running: tuple[Robot, ControlServer], monkeypatch: pytest.MonkeyPatch
) -> None:
    robot, server = running

    def broken(request: Any, timeout: float | None = 5.0) -> Any:
        raise RuntimeError("the binder is gone")

    monkeypatch.setattr(robot.binder, "request", broken)
    failed, status = converse(
        server.path, b'{"op": "load", "features": ["kartoslam"]}\n', b'{"op": "status"}\n'
    )
    assert failed == {"ok": False, "error": "the request failed: RuntimeError: the binder is gone"}
    assert status["ok"] is True and not robot.runtime.stop_requested.is_set()


def test_a_silent_client_is_let_go_after_the_idle_time(
    coordinated: tuple[Robot, ControlServer], monkeypatch: pytest.MonkeyPatch
) -> None:
    _, server = coordinated
    monkeypatch.setattr(control, "IDLE", 0.05)
    client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    client.settimeout(30)
    client.connect(str(server.path))
    with client:
        assert client.recv(1) == b""  # the server closed a connection that sent nothing
    assert send(server.run_dir, {"op": "status"})["ok"] is True


def test_a_stale_socket_from_a_dead_run_is_replaced(tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    run_dir.mkdir(mode=0o700)
    dead = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    dead.bind(str(run_dir / "control.sock"))
    dead.close()  # the run died without removing its socket
    ctl = ["ctl", str(SIMPLEBOT), "--variant", "field", "--run-dir", str(run_dir), "status"]
    nobody = CliRunner().invoke(main, ctl)
    assert nobody.exit_code == 3 and "cannot talk to the run: Connection refused" in nobody.output
    robot = launch(SIMPLEBOT, "field")
    server = ControlServer(run_dir, robot.runtime, robot.binder)
    try:
        server.open()
        assert send(run_dir, {"op": "status"})["ok"] is True
    finally:
        server.close()
        robot.close()


def test_a_file_where_the_socket_goes_is_not_replaced(tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "control.sock").write_text("notes")
    robot = launch(SIMPLEBOT, "field")
    try:
        with pytest.raises(EnvironmentProblem) as caught:
            ControlServer(run_dir, robot.runtime, robot.binder).open()
        assert caught.value.diagnostics[0].message == "exists and is not a socket: not replacing it"
        assert (run_dir / "control.sock").read_text() == "notes"
        too_long = tmp_path / ("d" * 120)
        with pytest.raises(EnvironmentProblem, match="the socket path is too long for a Unix socket"):
            ControlServer(too_long, robot.runtime, robot.binder).open()
        assert not too_long.exists()
    finally:
        robot.close()


def test_a_run_directory_of_another_user_is_refused_as_the_registry_refuses_it(tmp_path: Path) -> None:
    """Issue 31: a run as root put its socket in a --run-dir another user owns; the run
    registry refused the same case. (The folder is ours: os.getuid is made to say that
    someone else runs.)"""
    run_dir = tmp_path / "run"
    run_dir.mkdir(mode=0o700)
    robot = launch(SIMPLEBOT, "field")
    try:
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(os, "getuid", lambda: run_dir.stat().st_uid + 1)
            with pytest.raises(EnvironmentProblem) as caught:
                ControlServer(run_dir, robot.runtime, robot.binder).open()
        assert caught.value.diagnostics[0].message.startswith("belongs to another user: not opening a control socket")
        assert not (run_dir / "control.sock").exists()
    finally:
        robot.close()


def test_a_run_that_hangs_up_without_answering_is_said_so(tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(str(run_dir / "control.sock"))
    listener.listen(1)

    def hang_up() -> None:
        connection, _ = listener.accept()
        connection.recv(1 << 16)  # the request, then nothing
        connection.close()

    thread = threading.Thread(target=hang_up, daemon=True)
    thread.start()
    try:
        with pytest.raises(EnvironmentProblem) as caught:
            send(run_dir, {"op": "status"})
        assert caught.value.diagnostics[0].message == "the run closed the connection without an answer"
    finally:
        thread.join()
        listener.close()


def test_closing_the_server_ends_its_threads_and_removes_the_socket(tmp_path: Path) -> None:
    robot = launch(SIMPLEBOT, "field")
    server = ControlServer(tmp_path / "run", robot.runtime, robot.binder)
    before = set(threading.enumerate())
    server.open()
    [accepting] = [t for t in set(threading.enumerate()) - before if t.name == "motivml-control-accept"]
    assert send(server.run_dir, {"op": "status"})["ok"] is True  # the thread is in its accept loop
    server.close()
    accepting.join(30)
    assert not accepting.is_alive() and not server.path.exists()
    server.close()  # twice is harmless
    robot.close()


# ------------------------------------- an existing run directory
def test_an_existing_run_directory_keeps_its_mode(tmp_path: Path) -> None:
    run_dir = tmp_path / "mine"
    run_dir.mkdir()
    run_dir.chmod(0o755)
    robot = launch(SIMPLEBOT, "field")
    server = ControlServer(run_dir, robot.runtime, robot.binder)
    try:
        server.open()
        assert stat.S_IMODE(run_dir.stat().st_mode) == 0o755  # not changed to 0700
        assert send(run_dir, {"op": "status"})["ok"] is True
    finally:
        server.close()
        robot.close()


@pytest.mark.parametrize("mode", [0o1777, 0o777, 0o770, 0o702])
def test_a_run_directory_others_may_write_in_is_refused_and_left_alone(tmp_path: Path, mode: int) -> None:
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(mode)
    result = CliRunner().invoke(
        main,
        ["run", str(SIMPLEBOT), "--variant", "field", "--clock", "simulated", "--run-dir", str(shared)],
    )
    assert result.exit_code == 3, result.output
    assert f"{shared}: others may write in this directory (mode {mode:04o})" in " ".join(
        result.output.split()
    )
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert stat.S_IMODE(shared.stat().st_mode) == mode and not (shared / "control.sock").exists()


def test_a_new_run_directory_is_made_0700_whatever_the_umask(tmp_path: Path) -> None:
    robot = launch(SIMPLEBOT, "field")
    server = ControlServer(tmp_path / "a" / "run", robot.runtime, robot.binder)
    old = os.umask(0o077)
    try:
        server.open()
        assert stat.S_IMODE(server.run_dir.stat().st_mode) == 0o700
    finally:
        os.umask(old)
        server.close()
        robot.close()


# ------------------------------------- many clients at once
@pytest.mark.parametrize("backlog", [control.BACKLOG, 1])
def test_fifty_clients_at_once_are_all_answered(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, backlog: int
) -> None:
    """Each waits its turn: with a backlog of one, most find it full and connect again."""
    monkeypatch.setattr(control, "BACKLOG", backlog)
    robot = launch(SIMPLEBOT, "field")
    server = ControlServer(tmp_path / "run", robot.runtime, robot.binder)
    server.open()
    clients = 50
    start = threading.Barrier(clients)
    answers: list[Any] = [None] * clients

    def ask(i: int) -> None:
        start.wait()
        try:
            answers[i] = send(server.run_dir, {"op": "status"})
        except EnvironmentProblem as exc:
            answers[i] = exc.diagnostics[0].message

    threads = [threading.Thread(target=ask, args=(i,)) for i in range(clients)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    server.close()
    robot.close()
    failed = [a for a in answers if not isinstance(a, dict)]
    assert failed == [] and all(a["ok"] for a in answers)


# ------------------------------------- a change that takes long to prepare
SLOW_START = "import ctl_gate; ctl_gate.started.set(); ctl_gate.release.wait()"


@pytest.fixture
def slow(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[types.SimpleNamespace, Path]]:
    """A robot whose plugin d starts only when the test lets it, running with its socket open."""
    from test_transactions import make_robot

    gate = types.SimpleNamespace(started=threading.Event(), release=threading.Event())
    monkeypatch.setitem(sys.modules, "ctl_gate", gate)
    robot = launch(make_robot(tmp_path / "bot", {"a": {}, "b": {}, "d": {"start": SLOW_START}}), "v")
    server = ControlServer(tmp_path / "run", robot.runtime, robot.binder)
    server.open()
    loop = threading.Thread(target=robot.runtime.run, args=(3600.0, RealClock()), daemon=True)
    loop.start()
    yield gate, server.run_dir
    gate.release.set()
    robot.runtime.stop()
    loop.join()
    server.close()
    robot.close()


def test_a_change_is_waited_for_however_long_its_plugin_takes_to_start(
    slow: tuple[types.SimpleNamespace, Path],
) -> None:
    gate, run_dir = slow
    answers: list[Any] = []

    def load() -> None:  # a zero timeout: any wait bounded by it would fail at once
        try:
            answers.append(send(run_dir, {"op": "load", "features": ["d"]}, 0.0, wait=True))
        except EnvironmentProblem as exc:
            answers.append(exc.diagnostics[0].message)

    client = threading.Thread(target=load)
    client.start()
    assert gate.started.wait(30)  # d's start() runs, and waits for the test
    gate.release.set()
    client.join()
    (answer,) = answers
    assert isinstance(answer, dict) and answer["accepted"] and answer["loads"] == ["d"], answer
    assert "d" in send(run_dir, {"op": "status"})["active"]


def test_ctl_waits_for_a_slow_change_and_says_what_it_became(
    slow: tuple[types.SimpleNamespace, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    gate, run_dir = slow
    real = control.send
    monkeypatch.setattr(  # a zero timeout: whatever ctl waits for with a timeout fails at once
        control, "send", lambda folder, request, timeout=30.0, **wait: real(folder, request, 0.0, **wait)
    )
    results: list[Any] = []
    command = ["ctl", str(run_dir.parent / "bot"), "--variant", "v", "--run-dir", str(run_dir), "load", "d"]
    client = threading.Thread(target=lambda: results.append(CliRunner().invoke(main, command)))
    client.start()
    assert gate.started.wait(30)
    gate.release.set()
    client.join()
    (result,) = results
    assert result.exit_code == 0, result.output
    assert result.output.startswith("accepted: load d took effect at tick ")


def test_ctrl_c_while_ctl_waits_for_a_change_says_it_may_still_be_committed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def interrupted(*args: Any, **kwargs: Any) -> dict[str, Any]:
        assert kwargs["wait"] is True
        raise KeyboardInterrupt

    monkeypatch.setattr(control, "send", interrupted)
    run_dir = tmp_path / "run"
    result = CliRunner().invoke(
        main, ["ctl", str(SIMPLEBOT), "--variant", "field", "--run-dir", str(run_dir), "swap", "a", "b"]
    )
    assert result.exit_code == 130
    assert " ".join(result.output.split()) == (
        f"interrupted: swap a b was sent and may still be committed; see with: motivml ctl {SIMPLEBOT} "
        f"--variant field --run-dir {run_dir} status"
    )


# ------------------------------------- status is one moment
def test_status_under_racing_swaps_describes_states_that_existed(
    running: tuple[Robot, ControlServer],
) -> None:
    """The plugin of an active feature is listed if and only if the feature is active."""
    robot, server = running
    with_plugins = set(robot.binder.plugins)
    assert {"hectorslam", "kartoslam"} <= with_plugins
    done = threading.Event()
    answers: list[dict[str, Any]] = []

    def swap() -> None:
        try:
            for i in range(30):
                pair = ["hectorslam", "kartoslam"] if i % 2 == 0 else ["kartoslam", "hectorslam"]
                assert send(server.run_dir, {"op": "swap", "features": pair})["accepted"]
        finally:
            done.set()

    def ask() -> None:
        while not done.is_set():
            answers.append(send(server.run_dir, {"op": "status"}))

    threads = [threading.Thread(target=swap), *(threading.Thread(target=ask) for _ in range(3))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert answers
    torn = [
        (a["active"], a["plugins"])
        for a in answers
        if {p["feature"] for p in a["plugins"]} != set(a["active"]) & with_plugins
    ]
    assert torn == []

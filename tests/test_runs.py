"""Finding runs from anywhere: the per-user runs directory, ctl by robot and variant, ctl --list."""

from __future__ import annotations

import os
import shutil
import socket
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from paths import SIMPLEBOT

from motivml.cli import main
from motivml.errors import EnvironmentProblem
from motivml.runtime import runs
from motivml.runtime.control import send
from motivml.runtime.launch import launch
from motivml.runtime.session import Session


@pytest.fixture
def runtime_dir(monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A private $XDG_RUNTIME_DIR with a short path (sockets' paths are short)."""
    folder = Path(tempfile.mkdtemp(prefix="m"))
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(folder))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def session(tmp_path: Path, runtime_dir: Path) -> Iterator[Session]:
    """SimpleBot field running until stopped, its socket in a run directory of its own."""
    session = Session(
        launch(SIMPLEBOT, "field"), float("inf"), "real", run_dir=tmp_path / "somewhere" / "run"
    )
    session.open()
    session.start()
    yield session
    session.runtime.stop()
    assert session.wait(60)
    session.close()


def test_runs_go_under_xdg_runtime_dir_else_a_folder_of_the_user_in_tmp(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("XDG_RUNTIME_DIR", "/run/user/1000")
    assert runs.runs_dir() == Path("/run/user/1000/motivml/runs")
    monkeypatch.delenv("XDG_RUNTIME_DIR")
    assert runs.runs_dir() == Path(f"/tmp/motivml-{os.getuid()}/runs")


def test_ctl_finds_a_run_by_robot_and_variant_from_any_directory(
    session: Session, runtime_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # not where run started, nor its run directory's parent
    for folder in (runtime_dir / "motivml", runtime_dir / "motivml" / "runs"):
        assert stat.S_IMODE(folder.stat().st_mode) == 0o700
    status = CliRunner().invoke(main, ["ctl", str(SIMPLEBOT), "--variant", "field", "status"])
    assert status.exit_code == 0, status.output
    assert "active: " in status.output and "plugin hectorslam: " in status.output
    swap = CliRunner().invoke(
        main, ["ctl", str(SIMPLEBOT), "--variant", "field", "swap", "hectorslam", "kartoslam"]
    )
    assert swap.exit_code == 0 and swap.output.startswith("accepted: swap hectorslam kartoslam")
    listed = CliRunner().invoke(main, ["ctl", "--list"])
    assert listed.exit_code == 0
    assert f"{SIMPLEBOT} --variant field: pid {os.getpid()}, since " in listed.output
    assert session.server is not None
    assert f"control {session.server.path.absolute()}" in listed.output
    assert CliRunner().invoke(main, ["ctl", "list"]).output == listed.output
    other = CliRunner().invoke(main, ["ctl", str(SIMPLEBOT), "--variant", "lab", "status"])
    assert other.exit_code == 3 and "no run is listening here" in other.output  # nothing of that variant


def test_a_run_unregisters_when_it_ends(tmp_path: Path, runtime_dir: Path) -> None:
    session = Session(launch(SIMPLEBOT, "field"), 0.05, "simulated", run_dir=tmp_path / "run")
    session.open()
    assert session.registered is not None and session.registered.entry.is_file()
    assert [r.robot for r in runs.reachable()] == [str(SIMPLEBOT)]
    session.start()
    assert session.wait(60)
    session.close()
    assert list((runtime_dir / "motivml" / "runs").iterdir()) == []
    listed = CliRunner().invoke(main, ["ctl", "--list"])
    assert listed.exit_code == 0 and listed.output == "no run is listening (start one with motivml run)\n"


def test_stale_entries_are_ignored_and_removed(runtime_dir: Path, tmp_path: Path) -> None:
    dead = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    dead.bind(str(tmp_path / "control.sock"))
    dead.close()  # a run that died without unregistering: its socket answers no more
    stale = runs.register(SIMPLEBOT, "field", tmp_path / "control.sock")
    assert stale.entry.is_file() and stale.link.is_symlink()
    assert runs.reachable() == [] and not stale.entry.exists() and not stale.link.is_symlink()
    gone = runs.register(SIMPLEBOT, "field", tmp_path / "control.sock")
    text = gone.entry.read_text().replace(f'"pid": {os.getpid()}', '"pid": 999999999')
    gone.entry.write_text(text)  # a process that no longer exists
    assert runs.find(SIMPLEBOT, "field") == [] and not gone.entry.exists()


def test_a_runs_directory_others_may_write_in_is_refused(runtime_dir: Path, tmp_path: Path) -> None:
    (runtime_dir / "motivml").mkdir(mode=0o700)
    (runtime_dir / "motivml").chmod(0o777)
    with pytest.raises(EnvironmentProblem, match="others may write in this directory"):
        runs.register(SIMPLEBOT, "field", tmp_path / "control.sock")
    assert stat.S_IMODE((runtime_dir / "motivml").stat().st_mode) == 0o777  # left as it was
    result = CliRunner().invoke(
        main,
        [
            "run",
            str(SIMPLEBOT),
            "--variant",
            "field",
            "--clock",
            "simulated",
            "--run-dir",
            str(tmp_path / "r"),
        ],
    )
    assert result.exit_code == 3
    assert f"{runtime_dir / 'motivml'}: others may write in this directory (mode 0777)" in " ".join(
        result.output.split()
    )


def test_a_run_whose_socket_path_is_long_is_reached_through_its_short_link(
    runtime_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    deep = tmp_path / ("d" * 60) / ("e" * 60)
    deep.mkdir(parents=True)
    monkeypatch.chdir(deep)  # run started here: its relative socket path is short, the absolute one not
    session = Session(launch(SIMPLEBOT, "field"), float("inf"), "real", run_dir=Path("run"))
    session.open()
    session.start()
    try:
        (run,) = runs.find(SIMPLEBOT, "field")
        assert len(os.fsencode(run.socket)) > 108 and run.address == run.link
        monkeypatch.chdir(tmp_path)
        assert send(Path("unused"), {"op": "status"}, address=run.address)["ok"] is True
        status = CliRunner().invoke(main, ["ctl", str(SIMPLEBOT), "--variant", "field", "status"])
        assert status.exit_code == 0, status.output
    finally:
        session.runtime.stop()
        session.wait(60)
        session.close()


def test_a_runs_directory_that_is_not_ours_or_not_a_directory_is_refused(
    runtime_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (runtime_dir / "motivml").write_text("not a folder")
    with pytest.raises(EnvironmentProblem, match="is not a directory: cannot register runs here"):
        runs.register(SIMPLEBOT, "field", tmp_path / "control.sock")
    (runtime_dir / "motivml").unlink()
    uid = os.getuid()
    monkeypatch.setattr(runs.os, "getuid", lambda: uid + 1)  # as if another user had made it
    with pytest.raises(EnvironmentProblem, match="belongs to another user: cannot register runs here"):
        runs.register(SIMPLEBOT, "field", tmp_path / "control.sock")
    assert runs.reachable() == []  # and nothing is read from it
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path / "missing"))
    with pytest.raises(EnvironmentProblem, match="no such directory: cannot register runs here"):
        runs.register(SIMPLEBOT, "field", tmp_path / "control.sock")


def test_entries_that_cannot_be_read_are_left_alone(runtime_dir: Path, tmp_path: Path) -> None:
    folder = runtime_dir / "motivml" / "runs"
    folder.mkdir(parents=True, mode=0o700)
    (folder / "half.json").write_text('{"robot": ')
    assert runs.reachable() == [] and (folder / "half.json").exists()


def test_ctl_lists_only_what_it_is_asked_about_and_asks_to_choose_between_two_runs(
    session: Session, runtime_dir: Path, tmp_path: Path
) -> None:
    assert session.server is not None
    runner = CliRunner()
    mine = runner.invoke(main, ["ctl", str(SIMPLEBOT), "--variant", "field", "--list"])
    assert f"{SIMPLEBOT} --variant field: pid " in mine.output
    by_dir = runner.invoke(main, ["ctl", "--list", "--run-dir", str(session.server.run_dir)])
    assert by_dir.output == mine.output
    other = runner.invoke(main, ["ctl", str(SIMPLEBOT), "--variant", "lab", "--list"])
    assert other.output == "no run is listening (start one with motivml run)\n"
    elsewhere = runner.invoke(main, ["ctl", "--list", "--run-dir", str(tmp_path)])
    assert elsewhere.output == "no run is listening (start one with motivml run)\n"
    second = runs.register(SIMPLEBOT, "field", session.server.path)  # as a second run would
    try:
        both = runner.invoke(main, ["ctl", str(SIMPLEBOT), "--variant", "field", "status"])
        assert both.exit_code == 2
        assert "2 runs of " in both.output and "choose one with --run-dir" in both.output
    finally:
        runs.unregister(second)
    extra = runner.invoke(main, ["ctl", str(SIMPLEBOT), "--variant", "field", "--list", "status"])
    assert extra.exit_code == 2 and "--list takes no op" in extra.output
    missing = runner.invoke(main, ["ctl", str(SIMPLEBOT), "status"])
    assert missing.exit_code == 2 and "Missing option '--variant'" in missing.output

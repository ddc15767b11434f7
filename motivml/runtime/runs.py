"""Where `motivml ctl` finds the runs: a per-user directory in which every run registers.

A run with a control socket writes `<runs>/<pid>-<token>.json` (the robot folder's resolved
path, the variant, its pid, its socket's absolute path, its start time) and a symbolic link
`<runs>/<pid>-<token>.sock` to its socket, and removes both when it ends. `ctl` then finds
a run by robot and variant from any working directory, and connects through the link, whose
path is short whatever the run directory's (a Unix socket's path holds about 104 bytes; the
link's target is not bound by that).

`<runs>` is `$XDG_RUNTIME_DIR/motivml/runs` if that is set, else `/tmp/motivml-<uid>/runs`.
Its folders are created 0700; one owned by another user, or that others may write in, is
refused. Entries whose process is gone or whose socket does not answer are stale: they are
left out and removed.
"""

from __future__ import annotations

import errno
import json
import os
import secrets
import socket
import stat
import time
from dataclasses import dataclass
from pathlib import Path

from ..errors import EnvironmentProblem, Location, error

SUN_PATH = 104  # bytes a Unix socket's path may hold, on every system (Linux: 108)


@dataclass(frozen=True)
class Run:
    """A registered run."""

    robot: str  # the robot folder, resolved
    variant: str
    pid: int
    socket: str  # absolute path of the control socket
    started: float  # time.time() at registration
    entry: Path  # its file in the runs directory

    @property
    def link(self) -> Path:
        """The short path to connect to: a symbolic link to the socket."""
        return self.entry.with_suffix(".sock")

    @property
    def address(self) -> Path:
        """Where to connect: the link if it is there, else the socket itself."""
        short = len(os.fsencode(self.link)) < SUN_PATH
        return self.link if short and self.link.is_symlink() else Path(self.socket)


def _problem(path: Path, message: str) -> EnvironmentProblem:
    return EnvironmentProblem(error(Location(str(path)), message, "control"))


def runs_dir() -> Path:
    """The per-user directory of registered runs (not created here)."""
    base = os.environ.get("XDG_RUNTIME_DIR")
    if base and os.path.isabs(base):
        return Path(base) / "motivml" / "runs"
    return Path("/tmp") / f"motivml-{os.getuid()}" / "runs"


def _private(path: Path) -> None:
    """`path` exists as a directory of ours that no one else may write in (made 0700 if new)."""
    try:
        path.mkdir(mode=0o700)
        os.chmod(path, 0o700)
    except FileExistsError:
        pass
    info = path.lstat()
    if not stat.S_ISDIR(info.st_mode):
        raise _problem(path, "is not a directory: cannot register runs here")
    if info.st_uid != os.getuid():
        raise _problem(path, "belongs to another user: cannot register runs here")
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        raise _problem(
            path,
            f"others may write in this directory (mode {stat.S_IMODE(info.st_mode):04o}): "
            "cannot register runs here",
        )


def _prepare(folder: Path) -> None:
    """Create (or check) the runs directory and the directory of ours above it."""
    parent = folder.parent  # $XDG_RUNTIME_DIR/motivml or /tmp/motivml-<uid>
    if not parent.parent.is_dir():
        raise _problem(parent.parent, "no such directory: cannot register runs here")
    try:
        _private(parent)
        _private(folder)
    except OSError as exc:
        raise _problem(folder, f"cannot register runs here: {exc.strerror or exc}") from None


def register(robot: Path, variant: str, socket_path: Path, folder: Path | None = None) -> Run:
    """Register a run whose control socket is listening at `socket_path`."""
    folder = folder or runs_dir()
    _prepare(folder)
    name = f"{os.getpid()}-{secrets.token_hex(4)}"
    entry = folder / f"{name}.json"
    run = Run(str(robot.resolve()), variant, os.getpid(), str(socket_path.absolute()), time.time(), entry)
    record = {
        "robot": run.robot,
        "variant": run.variant,
        "pid": run.pid,
        "socket": run.socket,
        "started": run.started,
    }
    try:
        os.symlink(run.socket, run.link)
        staged = folder / f".{name}.json"
        staged.write_text(json.dumps(record) + "\n")
        os.replace(staged, entry)  # readers never see half an entry
    except OSError as exc:
        unregister(run)
        raise _problem(folder, f"cannot register this run: {exc.strerror or exc}") from None
    return run


def unregister(run: Run) -> None:
    """Remove a run's entry and link (whichever are there)."""
    for path in (run.entry, run.link, run.entry.with_name(f".{run.entry.name}")):
        try:
            path.unlink()
        except OSError:
            pass


def reachable(folder: Path | None = None) -> list[Run]:
    """The registered runs that answer, oldest first; stale entries are removed."""
    folder = folder or runs_dir()
    try:
        entries = sorted(folder.glob("*.json"))
    except OSError:
        return []
    if not entries:
        return []
    try:
        _prepare(folder)  # never trust a runs directory someone else could have written
    except EnvironmentProblem:
        return []
    runs = []
    for entry in entries:
        run = _read(entry)
        if run is None:
            continue
        if _gone(run.pid) or not answers(run.address):
            unregister(run)
            continue
        runs.append(run)
    return sorted(runs, key=lambda r: r.started)


def find(robot: Path, variant: str, folder: Path | None = None) -> list[Run]:
    """The reachable runs of this robot folder and variant."""
    wanted = str(robot.resolve())
    return [r for r in reachable(folder) if r.robot == wanted and r.variant == variant]


def _read(entry: Path) -> Run | None:
    try:
        record = json.loads(entry.read_text())
        return Run(
            str(record["robot"]),
            str(record["variant"]),
            int(record["pid"]),
            str(record["socket"]),
            float(record["started"]),
            entry,
        )
    except (OSError, ValueError, TypeError, KeyError):
        return None  # being written, or not ours to understand: left alone


def _gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except OSError:
        return False  # it exists (another user's, which our directory should not list)
    return False


def answers(path: Path) -> bool:
    """Something listens at `path` (a full backlog counts: the run is busy, not gone)."""
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    probe.settimeout(1.0)
    try:
        probe.connect(str(path))
        return True
    except BlockingIOError:
        return True
    except OSError as exc:
        return exc.errno in (errno.EAGAIN, errno.ETIMEDOUT)
    finally:
        probe.close()

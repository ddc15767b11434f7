"""The run's control endpoint: a Unix domain socket speaking JSON lines.

`motivml run` opens `<run dir>/control.sock`. A new run directory is created with mode 0700
(an existing one keeps its mode, and is refused if others may write in it) and the socket
with mode 0600, so only the owner can connect. Each request is one JSON
object on one line, and each answer is one line:

    {"op": "swap", "features": ["hectorslam", "kartoslam"]}
    {"ok": true, "accepted": true, "op": "swap", "tick": 2417, "time": 2.417, "latency_ms": 1.9,
     "loads": ["kartoslam"], "unloads": ["hectorslam"]}

Operations: `load`, `unload`, `reload` and `swap` (with `features`) go through the
binder's transaction; `status` gives the active set, the components and the plugins;
`dump` adds the log of changes, faults and notes, and the spaces' values. A refused or
failed request answers `"accepted": false` with the diagnostics. Malformed input answers
`"ok": false` with the reason, and never ends the run.
"""

from __future__ import annotations

import json
import os
import socket
import stat
import threading
import time
from pathlib import Path
from typing import Any

from ..errors import EnvironmentProblem, Location, error
from . import requests
from .binder import Binder
from .loop import Runtime
from .requests import VERBS, RequestError

SOCKET = "control.sock"
LINE_LIMIT = 1 << 16  # bytes per request line
IDLE = 600.0  # seconds a connection may stay silent
DRAIN_LIMIT = 1 << 20  # bytes read and dropped after a line over LINE_LIMIT
BACKLOG = socket.SOMAXCONN  # connections waiting for accept(); clients beyond it try again


def _problem(path: Path, message: str) -> EnvironmentProblem:
    return EnvironmentProblem(error(Location(str(path)), message, "control"))


class ControlServer:
    """Serves one run's control socket on background threads."""

    def __init__(self, run_dir: Path, runtime: Runtime, binder: Binder) -> None:
        self.run_dir = run_dir
        self.path = run_dir / SOCKET
        self.runtime = runtime
        self.binder = binder
        self._socket: socket.socket | None = None
        self._threads: list[threading.Thread] = []
        self._closing = threading.Event()
        self.coordinator: Any = None  # the run's Coordinator, for events

    def open(self) -> None:
        """Create the run directory (0700) if it is new, and listen on its socket (0600)."""
        if len(os.fsencode(self.path)) >= 104:  # sun_path holds 104 to 108 bytes
            raise _problem(
                self.path, "the socket path is too long for a Unix socket: choose a shorter --run-dir"
            )
        try:
            self._make_run_dir()
            if self.path.exists() or self.path.is_symlink():
                if not stat.S_ISSOCK(self.path.lstat().st_mode):
                    raise _problem(self.path, "exists and is not a socket: not replacing it")
                if _alive(self.path):
                    raise _problem(
                        self.path, "another run is listening here (stop it, or choose another --run-dir)"
                    )
                self.path.unlink()  # left over from a run that ended without cleaning up
            server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            old = os.umask(0o177)
            try:
                server.bind(str(self.path))
            finally:
                os.umask(old)
            os.chmod(self.path, 0o600)
            server.listen(BACKLOG)
        except OSError as exc:
            raise _problem(self.path, f"cannot open the control socket: {exc.strerror}") from None
        self._socket = server
        thread = threading.Thread(target=self._accept, name="motivml-control-accept", daemon=True)
        thread.start()
        self._threads.append(thread)

    def _make_run_dir(self) -> None:
        """A new run directory is made 0700; an existing one keeps its mode, and is refused
        if it belongs to another user or others may write in it (the system's shared
        temporary folder, say), as the registry of runs refuses its own."""
        try:
            self.run_dir.mkdir(parents=True, mode=0o700)
        except FileExistsError:
            info = self.run_dir.stat()
            if not stat.S_ISDIR(info.st_mode):
                raise
            if info.st_uid != os.getuid():  # (a root run's socket in a user's folder, or the other way)
                raise _problem(
                    self.run_dir,
                    "belongs to another user: not opening a control socket here; choose another --run-dir",
                ) from None
            if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
                raise _problem(
                    self.run_dir,
                    f"others may write in this directory (mode {stat.S_IMODE(info.st_mode):04o}): "
                    "not opening a control socket here; choose another --run-dir",
                ) from None
            return
        os.chmod(self.run_dir, 0o700)  # the one we made: whatever the umask left

    def _accept(self) -> None:
        assert self._socket is not None
        while not self._closing.is_set():
            try:
                connection, _ = self._socket.accept()
            except OSError:
                return  # closed
            thread = threading.Thread(
                target=self._serve, args=(connection,), name="motivml-control", daemon=True
            )
            thread.start()

    def _serve(self, connection: socket.socket) -> None:
        connection.settimeout(IDLE)  # a client that never sends does not hold a thread forever
        try:
            self._converse(connection)
        except OSError:
            return  # timed out, or the client went away

    def _converse(self, connection: socket.socket) -> None:
        with connection, connection.makefile("rwb") as stream:
            while not self._closing.is_set():
                line = stream.readline(LINE_LIMIT + 1)
                if not line:
                    return
                if len(line) > LINE_LIMIT:
                    answer: dict[str, Any] = {
                        "ok": False,
                        "error": f"a request line is at most {LINE_LIMIT} bytes",
                    }
                    stream.write((json.dumps(answer) + "\n").encode())
                    stream.flush()
                    _hang_up(connection)
                    return
                stream.write((json.dumps(self.handle(line)) + "\n").encode())
                stream.flush()

    def handle(self, line: bytes) -> dict[str, Any]:
        """One request line to one answer (never raises)."""
        try:
            return self._handle(line)
        except Exception as exc:  # an answer, whatever happened; the run goes on
            return {"ok": False, "error": f"the request failed: {type(exc).__name__}: {exc}"}

    def _handle(self, line: bytes) -> dict[str, Any]:
        try:
            request = json.loads(line)
        except (ValueError, UnicodeDecodeError, RecursionError) as exc:
            return {"ok": False, "error": f"not a JSON line: {type(exc).__name__}: {str(exc)[:200]}"}
        if not isinstance(request, dict) or not isinstance(request.get("op"), str):
            return {"ok": False, "error": 'a request is an object with "op"'}
        op = request["op"]
        if op == "status":
            return {"ok": True, "op": op, **self.status()}
        if op == "dump":
            return {"ok": True, "op": op, **self.status(), **self.dump()}
        if op == "event":
            name, features = request.get("name"), request.get("features")
            if name is None and isinstance(features, list) and len(features) == 1:
                name = features[0]  # motivml ctl sends the name as its one feature
            if not isinstance(name, str) or not name:
                return {"ok": False, "error": 'event needs "name"'}
            if self.coordinator is None:
                return {"ok": False, "error": "this robot has no coordination statechart to send events to"}
            self.coordinator.event(name)
            self.runtime.note(f"event {name} (from the control socket)")
            return {"ok": True, "op": op, "name": name}
        if op not in VERBS:
            return {
                "ok": False,
                "error": f"unknown op {op!r} (ops: {', '.join((*VERBS, 'event', 'status', 'dump'))})",
            }
        features = request.get("features")
        if not isinstance(features, list) or not features or not all(isinstance(f, str) for f in features):
            return {"ok": False, "error": f'{op} needs "features": a non-empty list of feature ids'}
        try:
            asked = requests.change(op, features)
        except RequestError as exc:
            return {"ok": False, "error": str(exc)}
        outcome = self.binder.request(asked)
        answer: dict[str, Any] = {"ok": True, "op": op, "features": features, "accepted": outcome.accepted}
        if outcome.accepted and outcome.change is not None:
            change = outcome.change
            answer |= {
                "tick": change.tick,
                "time": round(change.time, 6),
                "latency_ms": round(outcome.latency * 1e3, 3),
                "loads": list(change.loads),
                "unloads": list(change.unloads),
                "warnings": [d.as_dict() for d in outcome.diagnostics],
            }
        else:
            answer["diagnostics"] = [d.as_dict() for d in outcome.diagnostics]
        return answer

    def status(self) -> dict[str, Any]:
        snapshot = self.runtime.status()
        return {
            "tick": snapshot.tick,
            "time": round(snapshot.time, 6),
            "active": sorted(snapshot.active, key=self.binder.variant.model.index.__getitem__),
            "components": [
                {"id": c.id, "kind": c.kind, "feature": c.feature, "status": c.status, "learning": c.learning}
                for c in snapshot.components
            ],
            "plugins": [
                {"feature": f, "status": s} | _slowest(snapshot.slowest, f) for f, s in snapshot.plugins
            ],
        }

    def dump(self) -> dict[str, Any]:
        runtime = self.runtime
        return {
            "changes": [
                {"tick": c.tick, "time": round(c.time, 6), "wall": c.wall, "request": c.request}
                for c in runtime.changes
            ],
            "faults": [
                {"tick": f.tick, "time": round(f.time, 6), "feature": f.feature, "error": f.error}
                for f in runtime.faults
            ],
            "notes": [{"time": round(t, 6), "tick": k, "text": text} for t, k, text in runtime.notes],
            "spaces": {k: [float(x) for x in v] for k, v in list(runtime.assembly.values.items())},
        }

    def close(self) -> None:
        """Stop serving and remove the socket, if this server made it (never another run's)."""
        self._closing.set()
        if self._socket is None:
            return
        try:  # wakes the thread blocked in accept(), which close() alone does not on Linux
            self._socket.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self._socket.close()
        self._socket = None
        try:
            self.path.unlink()
        except OSError:
            pass


def _hang_up(connection: socket.socket) -> None:
    """End a conversation whose client sent too much: the answer already written is read.

    Closing a Unix socket with unread input resets it, and the client would lose the answer
    in its buffer; so say end-of-file first, then discard what is still coming, a bounded
    amount for a bounded time, before closing.
    """
    try:
        connection.shutdown(socket.SHUT_WR)
        connection.settimeout(1.0)
        left = DRAIN_LIMIT
        while left > 0 and (chunk := connection.recv(min(left, 1 << 16))):
            left -= len(chunk)
    except OSError:
        pass


def _alive(path: Path) -> bool:
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        probe.connect(str(path))
        return True
    except OSError:
        return False
    finally:
        probe.close()


def send(
    run_dir: Path,
    request: dict[str, Any],
    timeout: float = 30.0,
    *,
    wait: bool = False,
    address: Path | None = None,
) -> dict[str, Any]:
    """One request to a run's control socket; its answer.

    Connecting waits its turn, up to `timeout` seconds, while the run's backlog is full (a
    connect on a Unix socket does not queue: it fails at once, so it is tried again). The
    answer is waited for up to `timeout` seconds too, unless `wait`: a change (load, unload,
    reload, swap) answers when it is committed or refused, however long its plugins take to
    start, and a client that gave up earlier would say it failed when it did not. `address`:
    connect there instead of to the run directory's socket (a registered run's link).
    """
    path = address or run_dir / SOCKET
    try:
        client = _connect(path, timeout)
        client.settimeout(None if wait else timeout)
    except FileNotFoundError:
        raise _problem(path, "no run is listening here (start one with motivml run)") from None
    except OSError as exc:
        raise _problem(path, f"cannot talk to the run: {exc.strerror or exc}") from None
    try:
        with client.makefile("rwb") as stream:
            stream.write((json.dumps(request) + "\n").encode())
            stream.flush()
            line = stream.readline()
    except OSError as exc:
        raise _problem(path, f"cannot talk to the run: {exc.strerror or exc}") from None
    finally:
        client.close()
    if not line:
        raise _problem(path, "the run closed the connection without an answer")
    answer: dict[str, Any] = json.loads(line)
    return answer


def _slowest(slowest: tuple[tuple[str, float, int], ...], feature: str) -> dict[str, Any]:
    """A plugin's longest step so far, if it has stepped: which plugin holds the loop up."""
    for name, took, tick in slowest:
        if name == feature:
            return {"slowest_step_ms": round(took * 1e3, 3), "slowest_step_tick": tick}
    return {}


RETRY_FIRST, RETRY_MOST = 0.001, 0.05  # s between two connects while the backlog is full


def _connect(path: Path, timeout: float) -> socket.socket:
    """A socket connected to `path`, trying again while the listener's backlog is full."""
    deadline = time.monotonic() + timeout
    pause = RETRY_FIRST
    while True:
        client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        client.settimeout(timeout)
        try:
            client.connect(str(path))
            return client
        except BlockingIOError:  # EAGAIN: the backlog is full; the run is busy, not gone
            client.close()
            left = deadline - time.monotonic()
            if left <= 0:
                raise
            time.sleep(min(pause, left))
            pause = min(pause * 2, RETRY_MOST)
        except BaseException:
            client.close()
            raise

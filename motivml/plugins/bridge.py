"""The ROS 2 bridge: a process of its own that holds rclpy, and the link to it.

A run that speaks ROS 2 (`run --ros2`, or a robot with `ros2_lifecycle` plugins) starts one
bridge process per ROS namespace: `python -m motivml.ros2`. The bridge holds the rclpy
context, the lifecycle clients that drive the features' nodes and the `motivml` node; the
run's own process holds none of it. rclpy's executors are busy Python threads: in the loop's
process they held the interpreter's lock whenever a swap's messages came and went, and a
thread preempted by another process while holding it stalls the 1 kHz loop. In a process of
their own they cost the loop nothing but a core's share.

The two processes speak JSON lines over two socket pairs (`Link`), one for the calls each
makes: calls that wait for their answer (`{"op": ..., "id": n}` answered by `{"re": n,
...}`, read by the thread that called), and one-way messages (`{"event": ...}`). When either process ends, the other reads the end of the stream: the run
treats its nodes as lost (a fault of their features), and the bridge moves the nodes it
had activated back to unconfigured before it exits, so that a robot killed with `kill -9`
does not leave its lamp on.
"""

from __future__ import annotations

import itertools
import json
import os
import select
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

from ..errors import EnvironmentProblem, Location, describe_exception, error

START_TIMEOUT = 60.0  # s for the bridge to import rclpy and join the graph
SEND_TIMEOUT = 5  # s: a peer that takes nothing for this long is gone
END_TIMEOUT = 10.0  # s for the bridge to end once asked to (its nodes are cleaned up first)
PROGRAM = "motivml.ros2"  # the module a bridge process runs (the tests script one of their own)


class LinkBroken(Exception):
    """The other process has gone: its answer will never come."""


class Link:
    """JSON lines between two processes, over two socket pairs.

    On `asking`, this process sends its calls (`{"op": ..., "id": n}`) and one-way messages
    (`{"event": ...}` or an `op` without an id), and the thread that called reads the answer
    itself (`{"re": n}`): no thread hands it on. On `hearing`, a thread of the link reads
    the other's calls and messages and gives each to `handle`, which answers a call with
    `answer`. A handler runs on that thread, one message after the other: what it waits for
    must not come on `hearing`. `on_close(reason)` is called once, on the reading thread,
    when the other's side ends or breaks; a call under way then raises LinkBroken.
    """

    def __init__(
        self,
        asking: socket.socket,
        hearing: socket.socket,
        handle: Callable[[dict[str, Any]], None],
        on_close: Callable[[str], None],
        name: str,
    ) -> None:
        self.name = name
        self._asking = asking
        self._hearing = hearing
        for sock in (asking, hearing):
            # Sends block (they are small), but never for ever: a peer that takes nothing
            # for SEND_TIMEOUT is treated as gone.
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDTIMEO, struct.pack("ll", SEND_TIMEOUT, 0))
        self._handle = handle
        self._on_close = on_close
        self._ids = itertools.count(1)
        self._write_locks = {id(asking): threading.Lock(), id(hearing): threading.Lock()}
        self._call_lock = threading.Lock()  # one call at a time reads the answers
        self._answers = b""  # what has been read of the answers, up to a line's end
        self._lock = threading.Lock()
        self.broken: str | None = None
        self._reader = threading.Thread(target=self._read, daemon=True, name=f"motivml-link-{name}")
        self._reader.start()

    def _write(self, sock: socket.socket, message: dict[str, Any]) -> None:
        data = json.dumps(message, separators=(",", ":")).encode() + b"\n"
        if self.broken is not None:
            raise LinkBroken(self.broken)
        try:
            with self._write_locks[id(sock)]:
                sock.sendall(data)
        except OSError as exc:
            self._break(f"it took no message for {SEND_TIMEOUT} s" if isinstance(exc, BlockingIOError) else str(exc))
            raise LinkBroken(self.broken or str(exc)) from None

    def send(self, message: dict[str, Any]) -> None:
        """Send one message nobody answers; LinkBroken if the other process has gone."""
        self._write(self._asking, message)

    def call(self, op: str, wait: float, **fields: Any) -> dict[str, Any]:
        """Send `op` and read its answer: TimeoutError after `wait` s, LinkBroken if the other ends."""
        deadline = time.monotonic() + wait
        with self._call_lock:
            ident = next(self._ids)
            self._write(self._asking, {"op": op, "id": ident, **fields})
            while True:
                answer = self._next_answer(op, wait, deadline)
                if answer.get("re") == ident:
                    return answer
                # (the late answer of a call that gave up waiting: nobody wants it now)

    def _next_answer(self, op: str, wait: float, deadline: float) -> dict[str, Any]:
        poller = select.poll()
        poller.register(self._asking, select.POLLIN)
        while b"\n" not in self._answers:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"no answer to {op} within {wait:g} s")
            if not poller.poll(left * 1000):
                continue
            try:
                chunk = self._asking.recv(65536)
            except OSError as exc:
                chunk, reason = b"", str(exc)
            else:
                reason = "the other process closed the link"
            if not chunk:
                self._break(reason)
                raise LinkBroken(self.broken or reason)
            self._answers += chunk
        line, _, self._answers = self._answers.partition(b"\n")
        answer: dict[str, Any] = json.loads(line)
        return answer

    def answer(self, message: dict[str, Any], **fields: Any) -> None:
        """Answer a call received by `handle` (the other may have gone: then nobody waits)."""
        try:
            self._write(self._hearing, {"re": message["id"], **fields})
        except LinkBroken:
            pass

    def _read(self) -> None:
        reason = "the other process closed the link"
        try:
            with self._hearing.makefile("rb") as stream:
                for line in stream:
                    self._dispatch(json.loads(line))
        except (OSError, ValueError) as exc:
            reason = f"the link broke: {exc}"
        self._break(reason)

    def _dispatch(self, message: dict[str, Any]) -> None:
        """A message to its handler: a handler's failure is reported, and the link reads on
        (a call that met it is answered with it, so that nobody waits for ever)."""
        try:
            self._handle(message)
        except Exception as exc:
            text = f"motivml: {self.name}: a {message.get('op') or message.get('event')!r} message failed: {describe_exception(exc)}"
            print(text, file=sys.stderr, flush=True)
            if "id" in message:
                self.answer(message, error=text)

    def _break(self, reason: str) -> None:
        with self._lock:
            if self.broken is not None:
                return
            self.broken = reason
        for sock in (self._asking, self._hearing):
            try:
                sock.shutdown(socket.SHUT_RDWR)  # a call and the reader, if not this thread, end too
            except OSError:
                pass
        self._on_close(reason)

    def join_reader(self) -> None:
        """Wait for the reading thread to end, and the handler it runs with it (once the
        link has broken; not on that thread)."""
        if threading.current_thread() is not self._reader:
            self._reader.join()

    def close(self) -> None:
        self._break("closed")
        if threading.current_thread() is not self._reader:
            self._reader.join(timeout=2.0)
        self._asking.close()
        self._hearing.close()


def socket_pairs() -> tuple[tuple[socket.socket, socket.socket], tuple[socket.socket, socket.socket]]:
    """Two socket pairs for a link: (this process's asking, hearing), (the other's asking, hearing)."""
    run_asks, bridge_hears = socket.socketpair()
    bridge_asks, run_hears = socket.socketpair()
    return (run_asks, run_hears), (bridge_asks, bridge_hears)


class Bridge:
    """The bridge process of one namespace, as the run sees it.

    Users register handlers for the messages they expect (`on`) and call through `link`.
    `ended` lists callbacks told (once, on the link's thread) that the bridge has gone.
    """

    def __init__(self, ns: str, cpus: frozenset[int] | None = None) -> None:
        self.namespace = ns
        self.users = 0
        self.handlers: dict[str, Callable[[dict[str, Any]], None]] = {}
        self.ended: list[Callable[[str], None]] = []
        self._ready = threading.Event()
        self._failure: dict[str, Any] | None = None
        self.gone: str | None = None
        self._gone_known = threading.Event()  # set once `gone` says how the bridge ended
        ours, theirs = socket_pairs()
        fds = tuple(sock.fileno() for sock in theirs)
        command = [sys.executable, "-m", PROGRAM, "--fds", f"{fds[0]},{fds[1]}", "--namespace", ns]

        def setup() -> None:  # in the child, before it runs Python
            if cpus:
                os.sched_setaffinity(0, cpus)

        try:
            self.process = subprocess.Popen(  # noqa: S603 (our own interpreter and module)
                command,
                pass_fds=fds,
                stdin=subprocess.DEVNULL,
                # A process group of its own: a Ctrl-C at the terminal reaches the run, which
                # ends its features (through the bridge) and then the bridge. The run's
                # session, though: Linux's autogroups (where enabled and no CPU cgroup divides
                # the processes) share the CPU between sessions, and a bridge in a session of
                # its own competed with the whole run, loop included, as an equal; in the
                # run's, the loop's short slice (runtime.waiting) wins over the bridge's
                # threads. Missed deadlines during 5 x 200 swaps of bench/ros2_bench.py,
                # alternated: 0, 5, 2, 8 here; 8, 6, 12, 12 apart.
                process_group=0,
                preexec_fn=setup if cpus else None,  # noqa: PLW1509 (affinity only)
            )
        except OSError as exc:
            for sock in ours + theirs:
                sock.close()
            raise _failed(f"the ROS 2 bridge could not start: {exc}") from None
        for sock in theirs:
            sock.close()
        self.link = Link(*ours, self._handle, self._closed, "ros2-bridge")
        if not self._ready.wait(START_TIMEOUT):
            self.kill()
            raise _failed(f"the ROS 2 bridge did not start within {START_TIMEOUT:g} s")
        if self._failure is not None:
            self.wait()
            raise EnvironmentProblem(
                error(Location("ros2"), str(self._failure["message"]), str(self._failure.get("code", "ros2.start")))
            )
        if self.gone is not None:  # it ended without a word
            self.wait()
            raise _failed(f"{self.gone} as it started")

    def on(self, kind: str, handler: Callable[[dict[str, Any]], None]) -> None:
        self.handlers[kind] = handler

    def _handle(self, message: dict[str, Any]) -> None:
        kind = message.get("event") or message.get("op")
        if kind == "ready":
            self._ready.set()
        elif kind == "failed":
            self._failure = message
            self._ready.set()
        else:
            handler = self.handlers.get(str(kind))
            if handler is not None:
                handler(message)
            elif "id" in message:
                self.link.answer(message, error=f"nothing in this run answers {kind!r}")

    def _closed(self, reason: str) -> None:
        code = self.process.poll()
        if code is None:
            try:
                code = self.process.wait(timeout=1.0)
            except subprocess.TimeoutExpired:
                code = None
        ended = f"exit {code}" if code is not None and code >= 0 else f"killed by signal {-code}" if code else ""
        self.gone = "the ROS 2 bridge process ended" + (f" ({ended})" if ended else "")
        self._gone_known.set()
        self._ready.set()
        for told in list(self.ended):
            told(self.gone)

    def call(self, op: str, wait: float, **fields: Any) -> dict[str, Any]:
        """A call to the bridge; LinkBroken (with the bridge's end in words) if it has gone."""
        try:
            return self.link.call(op, wait, **fields)
        except LinkBroken:
            # (the link's reader may be the one that saw the end: it says how, within a second)
            self._gone_known.wait(2.0)
            raise LinkBroken(self.gone or "the ROS 2 bridge process ended") from None

    def wait(self) -> None:
        try:
            self.process.wait(timeout=END_TIMEOUT)
        except subprocess.TimeoutExpired:
            self.kill()
        self.link.close()

    def kill(self) -> None:
        try:
            os.killpg(self.process.pid, signal.SIGKILL)
        except OSError:
            pass
        self.process.wait()

    def close(self) -> None:
        """Ask the bridge to end (its nodes cleaned up first), and wait for it."""
        try:
            self.link.send({"op": "exit"})
        except LinkBroken:
            pass
        self.wait()


def _failed(message: str) -> EnvironmentProblem:
    return EnvironmentProblem(error(Location("ros2"), message, "ros2.start"))


_bridges: dict[str, Bridge] = {}
_bridges_lock = threading.Lock()


def open_bridge(ns: str, cpus: frozenset[int] | None = None) -> Bridge:
    """The namespace's bridge of this process, started at first use; `release_bridge` when done."""
    with _bridges_lock:
        bridge = _bridges.get(ns)
        if bridge is None or bridge.gone is not None:
            bridge = _bridges[ns] = Bridge(ns, cpus)
        bridge.users += 1
        return bridge


def release_bridge(bridge: Bridge) -> None:
    with _bridges_lock:
        bridge.users -= 1
        if bridge.users > 0:
            return
        if _bridges.get(bridge.namespace) is bridge:
            del _bridges[bridge.namespace]
    bridge.close()


# The CPUs a bridge started from now on is kept to (`run --cpus` keeps the run to some CPUs,
# and its bridge, which the loop need not wait for, to the others); None: the run's own.
BRIDGE_CPUS: frozenset[int] | None = None

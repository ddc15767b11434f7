"""One run of a launched robot: the control thread, the socket, scheduled requests, Ctrl-C, shutdown.

`motivml run` is a thin front over a `Session`: the CLI parses, launches the robot, opens a
session, shows what `feed()` gives while the session runs, prints the summary and picks
the exit code from the session's verdict. Everything with threads or signals is here:

* the loop runs on its own thread (`motivml-control`) while the caller's thread watches;
* requests scheduled at control times (`run --at`) are made between two ticks: on the
  simulated clock committed right there (deterministic), on the real clock submitted to
  the binder, which prepares them off the loop;
* Ctrl-C (SIGINT) and a service manager's SIGTERM, when the session runs on the main
  thread, end the run as its duration would: the loop stops between two ticks, the
  plugins' stop() runs, the socket is removed and the caller prints its summary. A second
  signal means the loop is stuck in a plugin: the socket and the registration are removed
  and `on_stuck(signum)` is called (by default the process exits at once, with 130 after
  Ctrl-C and 143 after SIGTERM);
* the control socket is registered in the per-user runs directory (`runs.py`), so that
  `motivml ctl` finds the run from anywhere, and unregistered when the socket closes;
* with a `Recorder` (`run --record FILE`), the run is recorded from its first tick, and
  `close()` completes the record (or removes it, for a run that never started); a loop
  stuck in a plugin and interrupted twice still has its record completed before `on_stuck`;
* `close()` closes the control socket and stops the plugins and the binder's thread.
"""

from __future__ import annotations

import collections
import enum
import os
import signal
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Future
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import NamedTuple, TypeVar

from ..errors import MotivmlError
from .binder import Outcome
from .control import ControlServer
from .coordinator import Coordinator
from .events import Changed, Logged, Note, RunEvent
from .launch import Robot
from .loop import (
    RealClock,
    RealtimeRefused,
    RunStats,
    Runtime,
    SimulatedClock,
    Snapshot,
)
from .record import Recorder, columns
from .requests import Event, Request
from .runs import Run, register, unregister

EXIT_INTERRUPTED = 130  # what a shell reports for a process ended by SIGINT
SIGNALS = (signal.SIGINT, signal.SIGTERM)  # each ends the run cleanly


class End(enum.Enum):
    """How a run ended, the first that holds of these in this order: the record's last event
    says it (`Session.ending`), and with what went wrong on the way it gives the exit code
    (`Session.exit_code`)."""

    SIGNALLED = "signalled"  # SIGINT (Ctrl-C) or SIGTERM (a service manager's stop)
    FAILED = "failed"  # a feature's step raised
    FINISHED = "finished"  # the coordination reached a final state
    COORDINATION_STOPPED = "coordination stopped"  # the coordination could not go on
    NO_RESULT = "no result"  # the loop ended without its statistics
    STOPPED = "stopped"  # asked to stop (the control socket, a test)
    ELAPSED = "elapsed"  # its duration elapsed


def keep_to_cpus(text: str) -> frozenset[int]:
    """Keep this thread, and every thread it starts from now on, to the CPUs `text` names
    ("0", "2-3", "0,2"): a robot's loop shares Python's lock with its own threads (the
    binder, the control socket), and one of them preempted by another process while it
    holds the lock stalls the loop; on CPUs of its own it is not. The run's ROS 2 bridge is
    kept to the other CPUs. ValueError if the list is not usable."""
    cpus: set[int] = set()
    for part in text.split(","):
        first, dash, last = part.strip().partition("-")
        if not _number(first) or (dash and not _number(last)):
            raise ValueError(f"{_shown(text)!r} is not a list of CPUs such as 0, 2-3 or 0,2")
        low, high = int(first), int(last or first)
        if high >= MAX_CPUS:  # (before a range of millions is made)
            raise ValueError(f"CPU {high} is beyond the {MAX_CPUS} CPUs a process can be kept to")
        cpus.update(range(low, high + 1))
    if not hasattr(os, "sched_setaffinity"):
        raise ValueError("this system cannot keep a process to some CPUs (Linux can)")
    allowed = os.sched_getaffinity(0)
    if not cpus or not cpus <= allowed:
        missing = _ranges(cpus - allowed) or _shown(text)
        raise ValueError(f"CPUs {missing} are not among this process's CPUs {_ranges(allowed)}")
    os.sched_setaffinity(0, cpus)
    from ..plugins import bridge

    # The ROS 2 bridge (rclpy's busy threads, in a process of their own) stays off the
    # run's CPUs when others are left: the loop never waits for it.
    others = frozenset(allowed - cpus)
    bridge.BRIDGE_CPUS = others or None
    return frozenset(cpus)


MAX_CPUS = 8192  # Linux's largest CPU set (CONFIG_NR_CPUS): `--cpus` names CPUs below it


def _number(text: str) -> bool:
    return text.isascii() and text.isdigit() and len(text) <= 12


def _shown(text: str) -> str:
    return text if len(text) <= 60 else text[:57] + "..."


def _ranges(cpus: set[int] | frozenset[int]) -> str:
    """CPUs as `--cpus` writes them: "0-3,8"."""
    runs: list[list[int]] = []  # [first, last] of each run of consecutive CPUs
    for cpu in sorted(cpus):
        if runs and cpu == runs[-1][1] + 1:
            runs[-1][1] = cpu
        else:
            runs.append([cpu, cpu])
    return ",".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


def _exit_now(signum: int) -> None:
    os._exit(128 + signum)  # (130 for Ctrl-C, 143 for SIGTERM: what a shell says of them)


class Heard(NamedTuple):
    """A committed change, as the live view heard of it."""

    wall: float  # wall-clock time it was heard, s since the epoch (at its commit, in its tick)
    tick: int
    request: str


T = TypeVar("T")


def _drain(heard: collections.deque[T]) -> list[T]:
    """What is in `heard` now, taken out in order (others may append meanwhile)."""
    taken: list[T] = []
    while heard:
        taken.append(heard.popleft())
    return taken


@dataclass(frozen=True)
class Feed:
    """What a live view shows of a running session, read at one moment."""

    snapshot: Snapshot
    achieved: float  # ticks per wall-clock second since the start
    rate: float  # asked
    coordination: tuple[str, ...] | None  # active states, None without coordination


@dataclass(frozen=True)
class Answer:
    """A scheduled request and what became of it."""

    time: float  # control time when it was made
    tick: int
    request: Request
    outcome: Outcome


class Session:
    """Run `robot` for `duration` seconds of `clock` time ("real" or "simulated"; inf: until stopped)."""

    def __init__(
        self,
        robot: Robot,
        duration: float,
        clock: str,
        plan: Sequence[tuple[float, Request | Event]] = (),
        run_dir: Path | None = None,
        on_stuck: Callable[[int], None] = _exit_now,
        variant: str | None = None,
        priority: int | None = None,
        record: Recorder | None = None,
        insist: bool = True,
    ) -> None:
        self.robot = robot
        self.priority = priority  # the loop thread's real-time priority (real clock), if any
        self.insist = insist  # False: that priority is given up if refused when the loop starts (run's default)
        self.realtime_refused: str | None = None  # why the loop did not start: its priority, insisted on, refused
        self.runtime: Runtime = robot.runtime
        self.duration = duration
        self.simulated = clock == "simulated"
        self.plan = sorted(plan, key=lambda item: item[0])
        self.server = ControlServer(run_dir, robot.runtime, robot.binder) if run_dir is not None else None
        self.on_stuck = on_stuck
        self.variant = variant or robot.variant.name  # as ctl names it
        self.registered: Run | None = None  # in the per-user runs directory, for ctl
        self.coordinator: Coordinator | None = None
        self.stats: RunStats | None = None
        self.finished = threading.Event()
        self.interrupted = threading.Event()  # by SIGINT or SIGTERM
        self.stopped_by: int | None = None  # the first signal that ended the run
        self._answers: list[tuple[float, int, Request, Outcome | Future[Outcome]]] = []
        # What the live view has not printed yet, as the run's listener heard it (on any
        # thread): the changes, and the log from its first line (launch's lines too).
        self._changes: collections.deque[Heard] = collections.deque()
        self._notes: collections.deque[Note] = collections.deque()
        self.runtime.log.listen_from_the_first_line(self._hear)
        self._began = 0.0
        self._previous: dict[
            int, signal.Handlers | Callable[[int, FrameType | None], object] | int | None
        ] = {}
        self._on_main = False
        self._worker: threading.Thread | None = None
        self.doors: list[Callable[[], None]] = []  # closers of other front doors (the ROS 2 node)
        self.record = record
        self.recorded: int | None = None  # ticks in the completed record
        self.record_problem: MotivmlError | None = None  # why the record could not be completed

    def open(self) -> None:
        """Take over Ctrl-C and SIGTERM, open the control socket, start the coordination.

        The signals are taken first, so that a run stopped as soon as it is announced still
        ends cleanly; if the socket cannot open, they are given back and the robot closed.
        """
        self._on_main = threading.current_thread() is threading.main_thread()
        if self._on_main:
            for signum in SIGNALS:
                self._previous[signum] = signal.signal(signum, self._interrupt)
        try:
            if self.server is not None:
                self.server.open()
                self.registered = register(self.robot.folder.path, self.variant, self.server.path)
        except BaseException:
            self.close()
            raise
        if self.simulated:
            self.robot.binder.make_changes_between_ticks()
        self.coordinator = self.robot.coordinate(simulated=self.simulated)
        if self.server is not None:
            self.server.coordinator = self.coordinator

    def start(self) -> None:
        """Start the loop on its own thread (at once over if a signal came since `open`)."""
        clock = SimulatedClock() if self.simulated else RealClock(self.priority, self.insist)

        def work() -> None:
            try:
                self.stats = self.runtime.run(self.duration, clock, until=self._scheduler)
            except RealtimeRefused as exc:  # (allowed when run asked a moment before; no tick ran)
                self.realtime_refused = str(exc)
            finally:
                self.finished.set()

        self._worker = threading.Thread(target=work, daemon=True, name="motivml-control")
        if self.record is not None:
            robot = self.robot
            selected = {d.feature.id for d in robot.variant.selected()}
            length = f"for {self.duration:g} s" if self.duration != float("inf") else "until stopped"
            self.record.start(
                self.runtime,
                columns(robot.architecture, selected),
                f"{robot.folder.name} variant {self.variant} at {self.runtime.rate:g} Hz "
                f"on the {clock.name} clock {length}",
                self.simulated,
            )
        self._began = time.perf_counter()
        self._worker.start()

    def wait(self, timeout: float) -> bool:
        """True once the loop has ended; at most `timeout` seconds."""
        return self.finished.wait(timeout)

    def stop_watching(self) -> None:
        """Give Ctrl-C back and close the control socket: no more requests from outside."""
        if self._on_main:
            for signum, previous in self._previous.items():
                signal.signal(signum, previous)
            self._on_main = False
        if self.registered is not None:
            unregister(self.registered)
            self.registered = None
        if self.server is not None:
            self.server.close()
        while self.doors:
            self.doors.pop()()

    def _leave_no_trace(self) -> None:
        """Before the process ends at once (`on_stuck`): no registration and no socket left
        for `ctl` to find (the plugins cannot be stopped: one of them holds the loop)."""
        if self.registered is not None:
            unregister(self.registered)
            self.registered = None
        if self.server is not None:
            self.server.close()

    def close(self) -> None:
        """Stop the plugins and the binder's thread (after `stop_watching`), then complete the
        record (`recorded`, or `record_problem`) with what their stop() said."""
        self.stop_watching()
        self.robot.close()
        self._finish_record(self.robot.binder.failed_stops)

    def _finish_record(self, failed_stops: Sequence[str] = (), end: str | None = None) -> None:
        if self.record is None:
            return
        if self._worker is None:  # the run never started: no record
            self.record.discard()
            return
        try:
            self.recorded = self.record.finish(end or ending(self), failed_stops)
        except MotivmlError as exc:
            self.record_problem = exc

    def end(self) -> End:
        """How the run ended (once it has)."""
        runtime, coordinator = self.runtime, self.coordinator
        if self.stopped_by is not None:
            return End.SIGNALLED
        if runtime.failure is not None:
            return End.FAILED
        if coordinator is not None and coordinator.finished is not None:
            return End.FINISHED
        if coordinator is not None and coordinator.unsettled:
            return End.COORDINATION_STOPPED
        if self.stats is None:
            return End.NO_RESULT
        return End.STOPPED if runtime.stop_requested.is_set() else End.ELAPSED

    def exit_code(self) -> int:
        """The run's exit code, once it is closed: 3 without a result, 130 after Ctrl-C, 1
        when a feature failed, the coordination could not go on, a system diverged or a
        plugin's stop() raised, 3 when the record could not be completed, else 0 (a run
        stopped by SIGTERM, a service manager's stop, ended normally)."""
        end = self.end()
        if self.stats is None:
            return 3
        if end is End.SIGNALLED and self.stopped_by == signal.SIGINT:
            return EXIT_INTERRUPTED
        if (
            self.runtime.diverged()
            or self.runtime.failure is not None
            or self.unsettled
            or self.robot.binder.failed_stops
        ):
            return 1
        return 3 if self.record_problem is not None else 0

    def _interrupt(self, signum: int, frame: FrameType | None) -> None:
        if self.interrupted.is_set():  # a second signal: the loop is stuck (a plugin that never returns)
            self._finish_record(end="the loop was stuck in a plugin's step: interrupted twice")
            self._leave_no_trace()
            self.on_stuck(signum)
            return
        self.stopped_by = signum
        self.interrupted.set()
        self.runtime.stop()

    def _scheduler(self, rt: Runtime) -> bool:
        """Each tick, on the control thread: make the requests that are due; True ends the run."""
        while self.plan and rt.time >= self.plan[0][0] - 1e-12:
            _, request = self.plan.pop(0)
            if isinstance(request, Event):
                assert self.coordinator is not None
                self.coordinator.event(request.name)
                rt.note(f"event {request.name}")
            elif self.simulated:  # deterministic: committed right here, between two ticks
                self._answers.append(
                    (rt.time, rt.ticks, request, self.robot.binder.request_between_ticks(request))
                )
            else:
                self._answers.append((rt.time, rt.ticks, request, self.robot.binder.submit(request)))
        return self.coordinator is not None and self.coordinator.finished is not None

    def _hear(self, event: RunEvent) -> None:
        """A listener of the run (on the thread where the event happened): quick, no lock."""
        if isinstance(event, Changed):
            self._changes.append(Heard(time.time(), event.tick, event.request))
        elif isinstance(event, Logged):
            self._notes.append(event.note)

    def new_changes(self) -> list[Heard]:
        """The changes committed since the last call, in order."""
        return _drain(self._changes)

    def new_notes(self) -> list[Note]:
        """The log lines (plugins' log(), refusals, faults, coordination) since the last call."""
        return _drain(self._notes)

    def feed(self) -> Feed:
        snapshot = self.runtime.status()
        wall = time.perf_counter() - self._began
        coordination = tuple(self.coordinator.configuration()) if self.coordinator is not None else None
        return Feed(snapshot, snapshot.tick / wall if wall > 0 else 0.0, self.runtime.rate, coordination)

    def answers(self) -> list[Answer]:
        """The scheduled requests made during the run, each with its outcome (waited for)."""
        return [
            Answer(at, tick, request, answer if isinstance(answer, Outcome) else answer.result())
            for at, tick, request, answer in self._answers
        ]

    @property
    def unsettled(self) -> bool:
        """The coordination stopped because its statechart never settled."""
        return self.coordinator is not None and self.coordinator.unsettled


def ending(session: Session) -> str:
    """How the run ended, in a few words (the record's last event)."""
    end, runtime = session.end(), session.runtime
    if end is End.SIGNALLED:
        assert session.stopped_by is not None
        why = f"stopped by {signal.Signals(session.stopped_by).name}"
    elif end is End.FAILED:
        assert runtime.failure is not None
        why = f"{runtime.failure.feature} failed: the run stopped"
    elif end is End.FINISHED:
        assert session.coordinator is not None and session.coordinator.finished is not None
        why = f"the coordination reached its final state {session.coordinator.finished[2]}"
    else:
        why = {
            End.COORDINATION_STOPPED: "the coordination stopped the run",
            End.NO_RESULT: "the loop ended without a result",
            End.STOPPED: "stopped",
            End.ELAPSED: "its duration elapsed",
        }[end]
    diverged = runtime.diverged()
    return why + (f"; {', '.join(diverged)} diverged" if diverged else "")

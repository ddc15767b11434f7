"""The fixed-rate loop that runs a built motion architecture, on a simulated or a real clock.

`Runtime(assembly, rate)` ticks the assembly: each tick steps the due components in
dependency order (each reads its ports, steps its module, writes its output space and
evaluates its criterion), then evaluates the free mappings, and records every change of a
component's status as an `Event` (the tick and time a criterion fired). `status()` is a snapshot for views and reports.

Two clocks:

* `SimulatedClock`: time is `tick / rate`; `run` never sleeps, so tests are deterministic and
  take as long as the computation.
* `RealClock`: ticks start on a fixed schedule of `1 / rate` seconds (default 1 kHz), placed
  so that the kernel's scheduler ticks fall between the loop's ticks, not in them. It
  sleeps until SPIN before a deadline, with the loop thread's timer slack cut to 1 us and
  its scheduler slice fitted to its ticks (0.3-0.5 ms) so that it wakes on time and is not
  preempted mid-tick on a busy machine (`motivml.runtime.waiting`), and spins the rest,
  with the cyclic garbage collector paused and a short interpreter switch interval for the
  run. (It does not spin longer: on a busy machine a thread that spins looks CPU-bound to
  the scheduler, which then wakes it late; a thread that sleeps nearly every period is
  woken at once.) When a tick ends
  after the next deadline, the deadlines it overran are *missed*: no tick starts at them,
  and the loop goes on at the first deadline still ahead (no bunching up). `RunStats` has
  the achieved rate, the jitter (start - deadline) p50/p99/max, the work time per tick and
  the CPU share of the process.
"""

from __future__ import annotations

import gc
import math
import os
import queue
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from ..architecture.builder import Assembly
from ..errors import describe_exception
from ..plugins.api import FeatureUnavailable
from ..plugins.registry import Activation
from . import waiting
from .events import Changed, Faulted, Listeners, Log, Missed, Note, StatusChanged


@dataclass
class Running:
    """A plugin instance in the loop."""

    feature: str
    instance: Any
    static: bool  # a fault stops the run (Dynamic: the feature is unloaded instead)
    folder: object = None  # the plugin's folder: where a fault's frame is looked for
    faulted: bool = False
    slowest: float = 0.0  # s, its longest step so far
    activation: Activation | None = None  # its kind's activation step, if any (ROS 2 lifecycle nodes)


@dataclass(frozen=True)
class AppliedReconfiguration:
    """An accepted reconfiguration, as it took effect."""

    tick: int  # the first tick that ran with it
    time: float  # control time, s
    wall: float  # time.time() when it was committed
    clock: float  # time.perf_counter() when it was committed
    request: str
    loads: tuple[str, ...]
    unloads: tuple[str, ...]


@dataclass(frozen=True)
class Fault:
    tick: int
    time: float
    feature: str
    error: str
    static: bool


@dataclass
class Commit:
    """What a prepared reconfiguration changes; applied by the control thread between ticks."""

    request: str
    loads: tuple[str, ...]
    unloads: tuple[str, ...]
    assembly: Assembly | None  # the new architecture, or None when it does not change
    add: dict[str, Running]
    remove: tuple[str, ...]  # features whose plugin leaves the loop
    done: threading.Event = field(default_factory=threading.Event)
    removed: list[Running] = field(default_factory=list)  # to stop, off the control thread
    change: AppliedReconfiguration | None = None
    withdrawn: bool = False
    writes: list[tuple[str, Any]] = field(default_factory=list)  # made by plugins in start()
    active: frozenset[str] | None = None  # the active set it makes (None: unknown here)


@dataclass(frozen=True)
class Event:
    tick: int
    time: float
    component: str
    status: str


# s before a deadline from which a commit is left to the loop (commit_waiting), so that the
# loop seldom begins a tick by waiting for the committing thread
COMMIT_MARGIN = 0.0002
SAMPLES = 1 << 22  # per-tick timings kept: 70 minutes at 1 kHz (64 MiB); longer runs keep the first


@dataclass
class RunStats:
    clock: str
    rate: float  # asked for
    ticks: int = 0
    elapsed: float = 0.0  # clock time of the run, s
    jitter: np.ndarray = field(default_factory=lambda: np.zeros(0))  # s, start - deadline, per tick
    work: np.ndarray = field(default_factory=lambda: np.zeros(0))  # s, per tick
    missed: int = 0  # deadlines at which no tick could start: the one before overran
    cpu: float = 0.0  # process CPU time during the run, s
    collections: int = 0  # garbage collections made in the loop's slack (real clock)

    @property
    def achieved(self) -> float:
        return self.ticks / self.elapsed if self.elapsed > 0 else 0.0

    def percentile(self, values: np.ndarray, q: float) -> float:
        return float(np.percentile(values, q)) if len(values) else 0.0

    @property
    def cpu_share(self) -> float:
        return self.cpu / self.elapsed if self.elapsed > 0 else 0.0


@dataclass(frozen=True)
class ComponentStatus:
    id: str
    kind: str
    feature: str
    status: str
    error: float
    module: str
    learning: str


@dataclass(frozen=True)
class Snapshot:
    tick: int
    time: float
    components: tuple[ComponentStatus, ...]
    modules: tuple[tuple[str, str, int], ...]  # (id, learning state, times learned)
    plugins: tuple[tuple[str, str], ...] = ()  # (feature, status line or "faulted")
    slowest: tuple[tuple[str, float, int], ...] = ()  # (feature, longest step in s, its tick), longest first
    active: frozenset[str] = frozenset()  # the active set these plugins and components belong to


def _status(instance: Any) -> str:
    try:
        return str(instance.status())[:80]
    except BaseException as exc:  # a view never fails because of a plugin
        return f"status() raised {type(exc).__name__}"


class SimulatedClock:
    name = "simulated"

    def now(self) -> float:
        return 0.0

    def wait_until(self, deadline: float) -> float:
        return deadline


class _SlackCollector:
    """Garbage collection in the loop's slack, never in the middle of a tick.

    The automatic collector is off during a real-clock run (it would pause a tick at a
    moment of its choosing), but a plugin that makes cyclic garbage must not grow the
    process without bound. After a tick, when the young generation has as many new objects
    as the automatic collector would wait for and at least half a period is left before the
    next deadline, collect it; every tenth young collection takes the middle generation too,
    and every tenth of those the old one, as the automatic collector does. Objects made
    before the loop are frozen, so even an old-generation pass scans only what the run made.
    """

    def __init__(self, period: float) -> None:
        self.needed = period / 2
        self.threshold = gc.get_threshold()[0] or 700
        self.young = 0  # young collections since the last middle one
        self.middle = 0  # middle collections since the last old one
        self.collections = 0

    def collect_if_time(self, left: float) -> None:
        if left < self.needed or gc.get_count()[0] < self.threshold:
            return
        generation = 0
        self.young += 1
        if self.young >= 10:
            self.young, generation = 0, 1
            self.middle += 1
            if self.middle >= 10:
                self.middle, generation = 0, 2
        gc.collect(generation)
        self.collections += 1


SPIN = 0.00002  # s before a deadline the loop's sleep ends; it spins the rest


DEFAULT_PRIORITY = 50  # a run's loop without --priority, where the process may (see default_priority)
_RESET_ON_FORK = getattr(os, "SCHED_RESET_ON_FORK", 0)  # threads and processes the loop's thread starts begin ordinary


def _refusal(priority: int) -> str | None:
    """The system's words refusing this process a thread under SCHED_FIFO at `priority`, or
    None (asked of a short-lived thread, so that no thread of the caller changes)."""
    problem: list[str] = []

    def probe() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO | _RESET_ON_FORK, os.sched_param(priority))
        except OSError as exc:
            problem.append(exc.strerror or str(exc))

    thread = threading.Thread(target=probe, name="motivml-realtime-probe")
    thread.start()
    thread.join()
    return problem[0] if problem else None


def realtime_problem(priority: int) -> str | None:
    """Why this process may not run a thread under SCHED_FIFO at `priority`, and how to
    allow it, or None (no thread of the caller changes)."""
    if not hasattr(os, "sched_setscheduler"):
        return "this system has no real-time scheduling (Linux has)"
    low, high = os.sched_get_priority_min(os.SCHED_FIFO), os.sched_get_priority_max(os.SCHED_FIFO)
    if not low <= priority <= high:
        return f"{priority} is not a real-time priority: {low} to {high}"
    refusal = _refusal(priority)
    return None if refusal is None else _how_to_allow(priority, refusal)


def _how_to_allow(priority: int, refusal: str) -> str:
    return (
        f"this process may not use real-time scheduling ({refusal}): run it as root, give it "
        f"CAP_SYS_NICE, or raise its real-time priority limit (ulimit -r {priority}; LimitRTPRIO={priority} "
        f"in a systemd unit)"
    )


class RealtimeRefused(OSError):
    """A real-time priority the loop insists on, refused when the loop starts (the message
    says how to allow it)."""


def default_priority() -> tuple[int | None, str | None]:
    """The real-time priority of a run's loop that was not told one (`run` without
    --priority), and if none, why, in a few words: DEFAULT_PRIORITY where this process may
    use real-time scheduling (root, CAP_SYS_NICE, or a real-time priority limit of 50 or
    more), else ordinary scheduling. ros2_control's controller manager does the same with its
    control loop. On a busy machine it is what keeps a loop that works each tick on time:
    there the scheduler may take an ordinary thread off the CPU in the middle of a tick and
    give it back only at its next tick (waiting.py), and nothing short of a privilege
    prevents that."""
    if not hasattr(os, "sched_setscheduler"):
        return None, "no real-time scheduling on this system"
    refusal = _refusal(DEFAULT_PRIORITY)
    return (DEFAULT_PRIORITY, None) if refusal is None else (None, f"real-time refused: {refusal}")


class LoopScheduling(NamedTuple):
    """How `run` schedules its loop's thread on the real clock."""

    priority: int | None  # its real-time priority; None: ordinary scheduling
    insist: bool  # False: run's own default, given up if refused when the loop starts
    said: str  # how the `running ...` line says it
    problem: str | None  # why a priority asked for may not be had (then the run does not start)


def run_scheduling(asked: int | None) -> LoopScheduling:
    """`run --priority asked`: None (not told) takes DEFAULT_PRIORITY where it may and
    ordinary scheduling where not; 0 asks for ordinary scheduling; N insists on N."""
    if asked is None:
        priority, refused = default_priority()
        said = f"real-time priority {priority}" if priority else f"ordinary priority ({refused})"
        return LoopScheduling(priority, False, said, None)
    if asked == 0:
        return LoopScheduling(None, True, "ordinary priority", None)
    return LoopScheduling(asked, True, f"real-time priority {asked}", realtime_problem(asked))


class RealClock:
    """Ticks on the wall clock: the loop's thread sleeps to within SPIN of each deadline,
    leaving the CPU to others meanwhile, with a short timer slack and slice while it ticks
    (`waiting.on_time`, Linux). With a `priority`, the thread runs under SCHED_FIFO at that priority
    (1-99) while it ticks: it then takes a CPU from any ordinary thread of any process the
    moment its sleep ends. Unless `insist`, a priority refused when the loop starts is given
    up for ordinary scheduling (`refused` says why) instead of raising OSError. A loop that
    stops sleeping (a step that never returns, ticks that overrun every period) would keep
    its CPU from every ordinary thread: the run's watchdog then makes it ordinary (`give_up`)."""

    name = "real"
    spin = SPIN  # s before a deadline: sleep until then, spin the rest
    priority: int | None = None
    insist = True
    refused: str | None = None  # why the loop's thread runs at ordinary priority although given one
    real_time = False  # the loop's thread is under SCHED_FIFO now
    awake_since: float | None = None  # perf_counter: since when the loop's thread has not slept (None: asleep)
    _thread_id: int | None = None  # the loop thread's native id, for give_up from another thread

    def __init__(self, priority: int | None = None, insist: bool = True) -> None:
        self.priority = priority
        self.insist = insist
        self._on_time: waiting.OnTime | None = None  # the thread's timer slack and slice while it ticks
        self._cpu = 0.0  # s: the thread's CPU time before its last sleep
        self._longest = 0.0  # s: the most CPU time it used between two sleeps since the last fit
        self._sleeps = 0  # since the last fit
        self._fit_at = waiting.FIRST_FIT  # sleeps between two fits

    def enter(self) -> None:
        """On the loop's thread, before the first tick: its scheduling (OSError if refused,
        if it insists) and its timer slack and slice."""
        self.refused = None
        if self.priority is not None:
            try:
                os.sched_setscheduler(0, os.SCHED_FIFO | _RESET_ON_FORK, os.sched_param(self.priority))
            except OSError as exc:
                if self.insist:
                    raise RealtimeRefused(_how_to_allow(self.priority, exc.strerror or str(exc))) from exc
                self.refused = f"real-time priority {self.priority} was refused ({exc.strerror or exc})"
                self.priority = None
            else:
                self.real_time = True
        self._thread_id, self.awake_since = threading.get_native_id(), time.perf_counter()
        self._on_time = waiting.on_time()
        self._cpu, self._longest, self._sleeps, self._fit_at = time.thread_time(), 0.0, 0, waiting.FIRST_FIT

    def leave(self) -> None:
        if self._on_time is not None:
            self._on_time.restore()
            self._on_time = None
        if self.real_time:
            self.real_time = False
            try:  # (keeping reset-on-fork: only CAP_SYS_NICE may clear it, not an rtprio limit)
                os.sched_setscheduler(0, os.SCHED_OTHER | _RESET_ON_FORK, os.sched_param(0))
            except OSError:
                pass

    def give_up(self, why: str) -> bool:
        """From any thread: the loop's thread leaves its real-time priority for ordinary
        scheduling for the rest of the run, `why` kept in `refused`; True if it did."""
        if not self.real_time or self._thread_id is None:
            return False
        try:
            os.sched_setscheduler(self._thread_id, os.SCHED_OTHER | _RESET_ON_FORK, os.sched_param(0))
        except OSError:
            return False
        self.real_time, self.refused = False, why
        return True

    def now(self) -> float:
        return time.perf_counter()

    def first_deadline(self, period: float) -> float:
        """The first deadline of a loop of `period` s starting now: one period from now, or
        up to a millisecond later, so that the scheduler's ticks fall between the loop's
        ticks, not in them (`waiting.first_deadline`)."""
        return waiting.first_deadline(self.now(), period)

    def wait_until(self, deadline: float) -> float:
        now = time.perf_counter()
        ahead = deadline - now - self.spin
        if ahead > 0:
            cpu = time.thread_time()  # (not the wall clock: the time it was preempted uses no slice)
            if cpu - self._cpu > self._longest:  # what it ran since its last sleep: its slice must cover it
                self._longest = cpu - self._cpu
            self._cpu = cpu
            self.awake_since = None
            time.sleep(ahead)
            now = self.awake_since = time.perf_counter()
            self._sleeps += 1
            if self._sleeps >= self._fit_at and self._on_time is not None:
                # (just after a wake-up: a slice changed just before a sleep makes the next wake-up late)
                self._on_time.fit(self._longest)
                self._longest, self._sleeps, self._fit_at = 0.0, 0, waiting.FIT_EVERY
                now = time.perf_counter()
        while now < deadline:
            now = time.perf_counter()
        return now


class Runtime:
    def __init__(self, assembly: Assembly, rate: float = 1000.0) -> None:
        if not rate > 0:
            raise ValueError("the rate must be positive")
        self.assembly = assembly
        self.rate = rate
        self.ticks = 0
        self.events: list[Event] = []
        self.stop_requested = threading.Event()
        self.plugins: dict[str, Running] = {}
        self.changes: list[AppliedReconfiguration] = []
        self.faults: list[Fault] = []
        self.on_fault: Callable[[Fault], None] | None = None  # Dynamic plugin faults go here
        self.hooks: list[Callable[[], None]] = []  # after every tick, on the control thread
        self.told = Listeners(self.note)  # who is told of the run's events (events.py)
        self.log = Log(self.told)  # the run's log (`notes`: its lines)
        self.notes = self.log.lines
        self.failure: Fault | None = None  # a Static plugin's fault, which ends the run
        self.slowest: dict[str, tuple[float, int]] = {}  # feature -> its longest step (s) and its tick
        self.missed = 0  # deadlines missed so far in a real-clock run (RunStats has them at the end)
        self.watchdog = 1.0  # s: a plugin step running this long is noted, naming the plugin
        self._stepping: tuple[Running, float, int] | None = None  # the plugin step under way
        self._commits: queue.SimpleQueue[Commit] = queue.SimpleQueue()
        self._lock = threading.Lock()  # commit versus withdraw, and versus status()
        # Real clock: while the loop waits for its next deadline, `_waiting_for` says so and a
        # commit may be applied from another thread (`commit_waiting`), under this lock; the
        # loop takes it to end the wait, so a commit under way ends before the tick begins
        self._ticking = threading.Lock()
        self._waiting_for: tuple[RealClock, float] | None = None  # (its clock, latest time to commit)
        self.active: frozenset[str] = frozenset()  # the features the applied commits made active
        assembly.prime()

    @property
    def time(self) -> float:
        return self.ticks / self.rate

    # ---------------- what others ask of it (its state is its own: nobody writes its attributes)
    def after_each_tick(self, hook: Callable[[], None], first: bool = False) -> None:
        """Call `hook` after every tick, on the control thread (`first`: before the others)."""
        self.hooks.insert(0 if first else len(self.hooks), hook)

    def send_faults_to(self, handler: Callable[[Fault], None]) -> None:
        """Where a Dynamic plugin's fault goes (a Static one's ends the run)."""
        self.on_fault = handler

    def begin_with(self, active: frozenset[str]) -> None:
        """The start state's active features, before the loop runs."""
        self.active = active

    def adopt(self, running: list[Running]) -> None:
        """The start state's plugins, started, into the loop (before it runs)."""
        for each in running:
            self.plugins[each.feature] = each

    def release_plugins(self) -> list[Running]:
        """Every plugin out of the loop (the run has ended), for their stop()."""
        released = list(self.plugins.values())
        self.plugins.clear()
        return released

    def fail(self, fault: Fault) -> None:
        """End the run with `fault` as its failure (a fault nothing could unload)."""
        self.failure = fault
        self.stop()

    def tick(self) -> None:
        """One control cycle; reconfigurations commit just before it, between two ticks."""
        if not self._commits.empty():
            self._apply_commits()
        before = [c.status for c in self.assembly.components]
        self.assembly.tick(self.ticks)
        self.ticks += 1
        self._record(before)
        if self.plugins:
            now = self.time
            for running in list(self.plugins.values()):
                # faulted, or unloaded during this tick (a fault's unload between ticks): stopped
                if running.faulted or self.plugins.get(running.feature) is not running:
                    continue
                began = time.perf_counter()
                self._stepping = (running, began, self.ticks)
                failure: BaseException | None = None
                try:
                    running.instance.step(now)
                except BaseException as exc:  # a plugin may raise anything (SystemExit too); the loop goes on
                    failure = exc
                took = time.perf_counter() - began
                self._stepping = None
                if took > running.slowest:
                    _slow_step(self, running, took)
                if failure is not None:
                    self._fault(running, failure)
        for hook in self.hooks:
            hook()

    # ------------------------------------------------------------ reconfiguration
    def submit(self, commit: Commit) -> None:
        """Queue a prepared reconfiguration for the next tick (any thread)."""
        self._commits.put(commit)

    def withdraw(self, commit: Commit) -> bool:
        """Take back a commit that has not been applied (the loop stopped); True if taken."""
        with self._lock:
            if commit.done.is_set():
                return False
            commit.withdrawn = True
            return True

    def commit_now(self) -> None:
        """Apply queued reconfigurations now (only between ticks, on the control thread)."""
        self._apply_commits()

    def commit_waiting(self) -> bool:
        """From any thread: apply the queued reconfigurations now if a real-clock loop is
        waiting for its next deadline (between two ticks) with COMMIT_MARGIN (at most half a
        period) or more to go, instead of at the next tick's start; True if it did. The next
        tick is the first to run with them either way; what no longer waits for that tick is
        the request's answer (half a period on average).

        Not while a tick runs, nor before the loop starts or after it ends, nor close to a
        deadline (the loop would wait for this thread), nor for a loop at a real-time
        priority (which would then wait for an ordinary thread): then the loop applies them
        itself, just before its next tick."""
        if not self._ticking.acquire(blocking=False):
            return False  # (the loop is in a tick: its next one applies them)
        try:
            if self._waiting_for is None:
                return False
            clock, latest = self._waiting_for
            if clock.now() > latest:
                return False
            self._apply_commits()
            return True
        finally:
            self._ticking.release()

    def _apply_commits(self) -> None:
        while not self._commits.empty():
            commit = self._commits.get()
            with self._lock:
                if commit.withdrawn:
                    continue
                if commit.assembly is not None:
                    new, old = commit.assembly, self.assembly.values
                    for space in new.values:
                        if space in old:
                            new.values[space] = old[space]
                    new.prime()
                    self.assembly = new
                for feature in commit.remove:
                    running = self.plugins.pop(feature, None)
                    if running is not None:
                        commit.removed.append(running)
                self.plugins.update(commit.add)
                for space, value in commit.writes:
                    if space in self.assembly.values:
                        self.assembly.values[space] = value
                commit.change = AppliedReconfiguration(
                    self.ticks,
                    self.time,
                    time.time(),
                    time.perf_counter(),
                    commit.request,
                    commit.loads,
                    commit.unloads,
                )
                if commit.active is not None:
                    self.active = commit.active
                self.changes.append(commit.change)
                self.told.publish(Changed(commit.change.tick, commit.request))
                commit.done.set()

    def _fault(self, running: Running, exc: BaseException) -> None:
        running.faulted = True
        said = str(exc) if isinstance(exc, FeatureUnavailable) else describe_exception(exc, running.folder)
        fault = Fault(self.ticks, self.time, running.feature, said, running.static)
        self.faults.append(fault)
        self.told.publish(Faulted(fault.tick, fault.feature, fault.error))
        self.note(f"{running.feature} raised in step: {fault.error}")
        if running.static:
            self.failure = fault
            self.stop()
        elif self.on_fault is not None:
            self.on_fault(fault)

    def note(self, text: str) -> None:
        """A line in the run's log, stamped with the control time and tick, and told (in the
        order of the log: lines of two threads are told as they were written)."""
        self.log.write(Note(self.time, self.ticks, text))

    def send(self, space: str, value: list[float] | np.ndarray) -> None:
        """Write a space no running component writes (a goal, a sensor value)."""
        values = self.assembly.values
        if space not in values:
            raise KeyError(f"no active space {space!r}")
        writing = [c.id for c in self.assembly.writers.get(space, []) if c.running]
        if writing:
            raise ValueError(f"{space} is written by {', '.join(writing)}")
        vector = np.asarray(value, dtype=float)
        if vector.shape != values[space].shape:
            raise ValueError(f"{space} holds {values[space].size} numbers, not {vector.size}")
        values[space] = vector
        before = [c.status for c in self.assembly.components]
        self.assembly.goal_changed(space)
        self._record(before)

    def _record(self, before: list[str]) -> None:
        """An event for every component whose status differs from `before`."""
        for component, old in zip(self.assembly.components, before, strict=True):
            if component.status != old:
                self.events.append(Event(self.ticks, self.time, component.id, component.status))
                self.told.publish(StatusChanged(self.ticks, component.id, component.status))

    def first(self, component: str, status: str) -> Event | None:
        """When a component first reached a status (e.g. its criterion fired)."""
        return next((e for e in self.events if e.component == component and e.status == status), None)

    def status(self) -> Snapshot:
        """The components, plugins and active set of one moment: never half of a commit."""
        with self._lock:  # the architecture, the plugins and the active set change together
            assembly, running, active, ticks = self.assembly, list(self.plugins.values()), self.active, self.ticks
        return _snapshot(self, assembly, running, active, ticks)  # (plugins' status() runs outside the lock)

    def run(
        self,
        duration: float,
        clock: SimulatedClock | RealClock | None = None,
        until: Callable[[Runtime], bool] | None = None,
    ) -> RunStats:
        """Tick for `duration` seconds of clock time (or until `until` or `stop()`)."""
        clock = clock or SimulatedClock()
        ticking = _Ticking(self)
        ended = threading.Event()
        watchdog = threading.Thread(target=ticking.watch, args=(ended, clock), daemon=True, name="motivml-watchdog")
        watchdog.start()
        try:
            with np.errstate(all="ignore"):  # a diverging system shows in the values, not as warnings
                return ticking.run(duration, clock, until)
        finally:
            ended.set()

    def stop(self) -> None:
        self.stop_requested.set()

    def diverged(self) -> list[str]:
        """Spaces holding a NaN or an infinity."""
        return [k for k, v in self.assembly.values.items() if not np.isfinite(v).all()]


class _Ticking:
    """How a runtime is driven by its clock for one run: ticks one after the other on the
    simulated clock; on the real clock, one per deadline (a thread that sleeps until each,
    commits from other threads while it waits, a collector that runs only in the slack); and
    the watchdog beside it."""

    def __init__(self, runtime: Runtime) -> None:
        self.runtime = runtime

    def watch(self, ended: threading.Event, clock: SimulatedClock | RealClock) -> None:
        """The watchdog's thread: note a plugin step that has not returned within `watchdog` s,
        and make a real-time loop that has not slept for that long ordinary (it would keep its
        CPU from every ordinary thread, the one that handles Ctrl-C too)."""
        rt = self.runtime
        reported: tuple[Running, float, int] | None = None
        real = clock if isinstance(clock, RealClock) else None
        while not ended.wait(rt.watchdog / 4):
            since = real.awake_since if real is not None and real.real_time else None
            if real is not None and since is not None and time.perf_counter() - since >= rt.watchdog:
                priority = real.priority
                if real.give_up(f"it had not slept for {rt.watchdog:g} s"):
                    rt.note(
                        f"the loop has not slept for {rt.watchdog:g} s: it gives up its real-time priority "
                        f"{priority} for the rest of the run, so that the machine's other threads get the CPU"
                    )
            stepping = rt._stepping
            if stepping is None or stepping is reported:
                continue
            running, began, tick = stepping
            if time.perf_counter() - began >= rt.watchdog:
                reported = stepping
                rt.note(
                    f"{running.feature}'s step has not returned after {rt.watchdog:g} s (the step of tick "
                    f"{tick}): the loop waits for it"
                )

    def run(
        self, duration: float, clock: SimulatedClock | RealClock, until: Callable[[Runtime], bool] | None
    ) -> RunStats:
        rt = self.runtime
        stats = RunStats(clock.name, rt.rate)
        total = round(duration * rt.rate) if math.isfinite(duration) else sys.maxsize  # inf: until stopped
        if isinstance(clock, SimulatedClock):
            for _ in range(total):
                if rt.stop_requested.is_set() or (until is not None and until(rt)):
                    break
                rt.tick()
                stats.ticks += 1
            stats.elapsed = stats.ticks / rt.rate
            return stats
        return self._run_real(total, clock, until, stats)

    def _run_real(
        self, total: int, clock: RealClock, until: Callable[[Runtime], bool] | None, stats: RunStats
    ) -> RunStats:
        rt = self.runtime
        period = 1.0 / rt.rate
        kept = min(total, SAMPLES)
        jitter, work = np.empty(kept), np.empty(kept)
        switch = sys.getswitchinterval()
        collecting = gc.isenabled()
        gc.collect()
        gc.freeze()  # what exists before the loop is never scanned again: collections stay short
        gc.disable()
        slack = _SlackCollector(period)
        sys.setswitchinterval(min(switch, 0.0001))
        cpu0 = time.process_time()
        start = clock.first_deadline(period)
        slot = 0
        margin = min(period / 2, COMMIT_MARGIN)
        try:
            clock.enter()
            others_commit = clock.priority is None  # (see commit_waiting)
            if clock.refused is not None:
                rt.note(f"the loop runs at ordinary priority: {clock.refused}")
            while slot < total:
                if rt.stop_requested.is_set() or (until is not None and until(rt)):
                    break
                deadline = start + slot * period
                if others_commit:  # between two ticks: a commit may come (commit_waiting)
                    with rt._ticking:
                        rt._waiting_for = (clock, deadline - margin)
                began = clock.wait_until(deadline)
                if others_commit:
                    with rt._ticking:  # (a commit being applied ends first)
                        rt._waiting_for = None
                rt.tick()
                ended = clock.now()
                if stats.ticks < kept:
                    jitter[stats.ticks] = began - deadline
                    work[stats.ticks] = ended - began
                stats.ticks += 1
                slot += 1
                slack.collect_if_time(start + slot * period - clock.now())
                if ended > start + slot * period:  # overran: skip to the first slot still ahead
                    ahead = math.ceil((ended - start) / period)
                    stats.missed += min(ahead, total) - slot
                    rt.told.publish(Missed(rt.ticks, stats.missed - rt.missed))
                    rt.missed = stats.missed
                    slot = ahead
        finally:
            with rt._ticking:
                rt._waiting_for = None
            stats.elapsed = max(clock.now() - start, min(slot, total) * period, 0.0)
            stats.cpu = time.process_time() - cpu0
            stats.jitter, stats.work = jitter[: min(stats.ticks, kept)], work[: min(stats.ticks, kept)]
            clock.leave()
            sys.setswitchinterval(switch)
            gc.unfreeze()
            stats.collections = slack.collections
            if collecting:
                gc.enable()
        return stats


def _snapshot(
    runtime: Runtime, assembly: Assembly, running: list[Running], active: frozenset[str], ticks: int
) -> Snapshot:
    """`Runtime.status` from what it took together under its lock."""
    components = tuple(
        ComponentStatus(
            c.id,
            c.kind,
            c.feature,
            c.status if c.running else "stopped",
            c.error,
            c.module.id,
            c.module.state,
        )
        for c in assembly.components
    )
    modules = tuple((m.id, m.state, m.learned) for m in assembly.modules.values())
    plugins = tuple((r.feature, "faulted" if r.faulted else _status(r.instance)) for r in running)
    slowest = tuple(
        sorted(((f, took, tick) for f, (took, tick) in list(runtime.slowest.items())), key=lambda s: -s[1])
    )
    return Snapshot(ticks, ticks / runtime.rate, components, modules, plugins, slowest, active)


def _slow_step(runtime: Runtime, running: Running, took: float) -> None:
    """A plugin's longest step so far: kept per feature (for the summary and `ctl status`)."""
    running.slowest = took
    if took > runtime.slowest.get(running.feature, (0.0, 0))[0]:
        runtime.slowest[running.feature] = (took, runtime.ticks)
    if took >= runtime.watchdog:
        runtime.note(f"{running.feature}'s step returned after {took:.3f} s: the loop waited for it")

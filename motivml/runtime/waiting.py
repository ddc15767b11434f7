"""How the real-time loop's thread asks Linux to wake it on time, without privileges.

Two attributes of the calling thread, each set for as long as the loop ticks and then
given back (both are no-ops where the system lacks them):

* its *timer slack* (`prctl(PR_SET_TIMERSLACK)`): how late the kernel may end a sleep to
  batch wake-ups; Linux's default is 50 us, the loop asks for 1 us;
* its *slice* (`sched_setattr`'s `sched_runtime` for an ordinary thread, Linux 6.12 and
  later): the EEVDF scheduler gives a thread that asks for a short slice an early virtual
  deadline, so when it wakes it preempts a thread that has run longer instead of waiting
  for that thread's slice (0.7-3 ms) to end.

  The slice must also cover the CPU time the thread uses between two sleeps: once a thread
  has run its slice, the scheduler may hand the CPU to a busy process at its next tick,
  and the loop waits for that process's slice, a missed deadline. So the loop's slice is
  *fitted* (`OnTime.fit`). It starts at SLICE_MAX_NS (or the thread's own slice, if that
  is shorter). After FIRST_FIT sleeps, then every FIT_EVERY sleeps, it becomes twice the
  most CPU time the thread used between two sleeps in them, within SLICE_NS-SLICE_MAX_NS.
  It is kept while that time is between a quarter and three quarters of it (each change
  costs a late wake-up now and then), and changed just after a wake-up, never just before
  a sleep. It is never below SLICE_NS, although the kernel takes less: a loop that works
  little, given the kernel's shortest slice, missed more deadlines than with a longer one.

Neither needs a privilege: a real-time priority does, and does more. `run` takes one
where its process may (`loop.default_priority`); these are what is left where it may not.

A third choice needs no system call at all: *where the deadlines fall* (`first_deadline`).
Linux's scheduler ticks fall on multiples of its tick (1, 4 or 10 ms for HZ = 1000, 250 or
100) on the monotonic clock, and so on whole milliseconds (not with HZ = 300, nor with
`skew_tick=1`). At a tick, kernel threads (kworkers, rcu, kdamond) and timers wake up. A
loop thread still working at that moment has used more than its share of the CPU since it
woke (its lag is negative: it is not *eligible*). Whatever wakes preempts it, and when that
sleeps again the scheduler runs the busy process instead of the ineligible loop, until the
busy process's slice ends at a tick: four missed deadlines at 1 kHz and HZ = 250. A
sleeping thread is not exposed to this at all. So the deadlines are placed TICK_PHASE of a
grid step after the grid: a scheduler tick falls after each deadline's work is done.

The grid step is the largest common step of the period and a millisecond, 1 ms at 1 kHz or
500 Hz, 0.5 ms at 2 kHz. A period with no step of at least GRID_MIN_NS in common with a
millisecond (997 Hz, 300 Hz) starts one period from now. A tick of the loop that works
longer than TICK_PHASE's remainder of a grid step (0.65 ms at 1 kHz) still meets the
scheduler's tick.

The measurements behind these numbers are in bench/waiting.md.
"""

from __future__ import annotations

import ctypes
import math
import platform
import sys
import time
from typing import Any

TIMER_SLACK_NS = 1000  # the loop thread's timer slack while it ticks
SLICE_NS = 300_000  # the loop thread's shortest slice while it ticks (the kernel's is 0.1 ms; see above)
SLICE_MAX_NS = 500_000  # its longest, and its first: below ordinary threads' slices (else its
# wake-ups wait for theirs), and never above the thread's own
SLICE_STEP_NS = 50_000  # fitted slices are whole steps of this (fewer system calls)
SLICE_PER_AWAKE = 2.0  # the slice fitted, per the longest stretch the thread ran between two sleeps
GROW_ABOVE, SHRINK_BELOW = 0.75, 0.25  # a slice is kept while that stretch is within these parts of it
FIRST_FIT = 10  # sleeps before the first fit
FIT_EVERY = 250  # sleeps between two fits after it (a quarter of a second at 1 kHz)
TICK_GRID_NS = 1_000_000  # Linux's scheduler ticks fall on multiples of this on the monotonic clock
TICK_PHASE = 0.35  # the loop's deadlines fall this part of a grid step after a multiple of it
GRID_MIN_NS = 100_000  # a shorter common step of the period and TICK_GRID_NS is not aligned to
_PR_SET_TIMERSLACK, _PR_GET_TIMERSLACK = 29, 30  # prctl(2) options (linux/prctl.h)
_SCHED_FLAG_RESET_ON_FORK = 0x01  # (linux/sched.h)
_SCHED_ATTR_CALLS = {"x86_64": (314, 315), "aarch64": (274, 275)}  # sched_setattr, sched_getattr


class _SchedAttr(ctypes.Structure):
    """struct sched_attr (linux/sched/types.h), version 1."""

    _fields_ = [
        ("size", ctypes.c_uint32),
        ("sched_policy", ctypes.c_uint32),
        ("sched_flags", ctypes.c_uint64),
        ("sched_nice", ctypes.c_int32),
        ("sched_priority", ctypes.c_uint32),
        ("sched_runtime", ctypes.c_uint64),
        ("sched_deadline", ctypes.c_uint64),
        ("sched_period", ctypes.c_uint64),
        ("sched_util_min", ctypes.c_uint32),
        ("sched_util_max", ctypes.c_uint32),
    ]


def _libc() -> Any:
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None, use_errno=True)
    except OSError:
        return None


def timer_slack() -> int | None:
    """The calling thread's timer slack in ns, or None where there is none to ask."""
    libc = _libc()
    if libc is None:
        return None
    slack = int(libc.prctl(_PR_GET_TIMERSLACK, 0, 0, 0, 0))
    return slack if slack >= 0 else None


def set_timer_slack(ns: int) -> int | None:
    """Set the calling thread's timer slack; the one it had, or None if not set."""
    before = timer_slack()
    if before is None or _libc().prctl(_PR_SET_TIMERSLACK, ns, 0, 0, 0) != 0:
        return None
    return before


def _sched_attr() -> tuple[Any, int, _SchedAttr] | None:
    libc, calls = _libc(), _SCHED_ATTR_CALLS.get(platform.machine())
    if libc is None or calls is None:
        return None
    attr = _SchedAttr()
    if libc.syscall(calls[1], 0, ctypes.byref(attr), ctypes.sizeof(attr), 0) != 0:
        return None
    return libc, calls[0], attr


def thread_slice() -> int | None:
    """The calling thread's slice in ns (0 for a real-time thread), or None where there is
    none to ask."""
    found = _sched_attr()
    return None if found is None else int(found[2].sched_runtime)


def set_thread_slice(ns: int) -> int | None:
    """Ask for a slice of `ns` for the calling ordinary thread (its policy, nice and the rest
    kept); the slice it had, or None if nothing changed (a real-time thread, an older
    kernel, another system)."""
    found = _sched_attr()
    if found is None:
        return None
    before = int(found[2].sched_runtime)
    if not _ordinary(found[2]):
        return None
    if not _ask_slice(found, ns):
        return None
    return before if thread_slice() == ns else None


def _ordinary(attr: _SchedAttr) -> bool:
    """Whether a slice may be asked for a thread of these attributes: SCHED_OTHER or
    SCHED_BATCH, with a slice of its own (a real-time thread has none)."""
    return attr.sched_policy in (0, 3) and attr.sched_runtime != 0


def _ask_slice(found: tuple[Any, int, _SchedAttr], ns: int) -> bool:
    """One system call: the attributes `found` (the calling thread's, as just read) with a
    slice of `ns`; of their flags, only reset-on-fork is kept (the others ask for more)."""
    libc, setattr_call, attr = found
    attr.size, attr.sched_runtime = ctypes.sizeof(attr), ns
    attr.sched_flags &= _SCHED_FLAG_RESET_ON_FORK
    return bool(libc.syscall(setattr_call, 0, ctypes.byref(attr), 0) == 0)


def fitted_slice(awake: float, current: int, longest: int = SLICE_MAX_NS) -> int:
    """The slice (ns) for a thread with slice `current` that used at most `awake` s of CPU
    between two sleeps: `current` while `awake` is between a quarter and three quarters of
    it (a changed slice costs a late wake-up now and then), else twice `awake`, within
    SLICE_NS and `longest`."""
    ns = awake * 1e9
    if current * SHRINK_BELOW <= ns <= current * GROW_ABOVE:
        return current
    steps = math.ceil(SLICE_PER_AWAKE * ns / SLICE_STEP_NS)
    return min(longest, max(SLICE_NS, steps * SLICE_STEP_NS))


class OnTime:
    """The calling thread's timer slack and slice, set for the loop (`on_time`)."""

    def __init__(self) -> None:
        self._slack = set_timer_slack(TIMER_SLACK_NS)
        own = thread_slice()
        # never longer than the thread's own: shorter than the others' is the point
        self._longest = min(SLICE_MAX_NS, own) if own else SLICE_MAX_NS
        self._old_slice = set_thread_slice(self._longest)
        self.slice = self._longest if self._old_slice is not None else None  # ns: the one asked, if any

    def fit(self, awake: float) -> None:
        """Fit the slice to `awake`, the most CPU time the thread used between two sleeps
        lately (on the same thread; nothing where no slice could be asked). The thread's
        other attributes are read anew first, so that a change of its nice value or policy
        meanwhile is kept (a thread made real-time is left alone)."""
        if self.slice is None:
            return
        wanted = fitted_slice(awake, self.slice, self._longest)
        if wanted == self.slice:
            return
        found = _sched_attr()
        if found is None or not _ordinary(found[2]):
            return
        if _ask_slice(found, wanted):
            self.slice = wanted

    def restore(self) -> None:
        """Give the thread its own slice and timer slack back (on the same thread)."""
        if self._old_slice is not None:
            set_thread_slice(self._old_slice)
            self._old_slice = self.slice = None
        if self._slack is not None:
            set_timer_slack(self._slack)
            self._slack = None


def first_deadline(now: float, period: float, monotonic: float | None = None) -> float:
    """The first deadline of a loop of `period` s whose clock reads `now`: one period from
    now, or up to a grid step later, so that it and every deadline after it falls TICK_PHASE
    of a grid step after a multiple of the grid on the monotonic clock (see above);
    `monotonic` is the monotonic clock's reading at `now` (read here if not given). One
    period from now if the period has no grid step in common with the ticks, is not a
    whole number of nanoseconds, or off Linux."""
    scaled = period * 1e9
    if not sys.platform.startswith("linux") or not math.isfinite(scaled) or scaled < 1:
        return now + period
    period_ns = round(scaled)
    grid_ns = math.gcd(period_ns, TICK_GRID_NS)
    if abs(scaled - period_ns) > 1e-3 or grid_ns < GRID_MIN_NS:
        return now + period  # (a period of a fraction of a ns more would drift off the grid)
    if monotonic is None:
        monotonic = time.clock_gettime(time.CLOCK_MONOTONIC)
    grid, phase = grid_ns / 1e9, TICK_PHASE * grid_ns / 1e9
    earliest = monotonic + period
    aligned = math.floor((earliest - phase) / grid) * grid + phase  # the last such time at or before it
    if aligned < earliest:
        aligned += grid
    return now + (aligned - monotonic)


def on_time() -> OnTime:
    """Set the calling thread's timer slack and slice for the loop; `restore()` gives them
    back, `fit` fits the slice (both to be called on the same thread)."""
    return OnTime()

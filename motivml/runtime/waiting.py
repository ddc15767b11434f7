"""How the real-time loop's thread asks Linux to wake it on time, without privileges.

Two attributes of the calling thread, each set for as long as the loop ticks and then
given back (both are no-ops where the system lacks them):

* its *timer slack* (`prctl(PR_SET_TIMERSLACK)`): how late the kernel may end a sleep to
  batch wake-ups; Linux's default is 50 us, the loop asks for 1 us;
* its *slice* (`sched_setattr`'s `sched_runtime` for an ordinary thread, Linux 6.12 and
  later): the EEVDF scheduler gives a thread that asks for a short slice an early virtual
  deadline, so when it wakes it preempts a thread that has run longer instead of waiting
  for that thread's slice (0.7-3 ms) to end. The loop asks for the shortest, 0.1 ms. On a
  2-core machine kept busy by two CPU-bound processes, a 1 kHz loop missed 15-215
  deadlines in 2 s with the default slice and 7-20 with 0.1 ms.

Neither needs a privilege: a real-time priority (`run --priority`) does, and does more.
"""

from __future__ import annotations

import ctypes
import platform
import sys
from collections.abc import Callable
from typing import Any

TIMER_SLACK_NS = 1000  # the loop thread's timer slack while it ticks
SLICE_NS = 100_000  # the loop thread's slice while it ticks (the kernel's shortest)
_PR_SET_TIMERSLACK, _PR_GET_TIMERSLACK = 29, 30  # prctl(2) options (linux/prctl.h)
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
    libc, setattr_call, attr = found
    before = int(attr.sched_runtime)
    if attr.sched_policy not in (0, 3) or before == 0:  # SCHED_OTHER, SCHED_BATCH only
        return None
    attr.size, attr.sched_runtime = ctypes.sizeof(attr), ns
    attr.sched_flags = 0
    if libc.syscall(setattr_call, 0, ctypes.byref(attr), 0) != 0:
        return None
    return before if thread_slice() == ns else None


def on_time() -> Callable[[], None]:
    """Set the calling thread's timer slack and slice for the loop; the function that gives
    them back (to be called on the same thread)."""
    slack = set_timer_slack(TIMER_SLACK_NS)
    old_slice = set_thread_slice(SLICE_NS)

    def restore() -> None:
        if old_slice is not None:
            set_thread_slice(old_slice)
        if slack is not None:
            set_timer_slack(slack)

    return restore

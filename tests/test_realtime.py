"""run --priority: the loop's thread under SCHED_FIFO, and a clear refusal where it may not."""

from __future__ import annotations

import math
import os
import threading
import time
from collections.abc import Callable
from types import SimpleNamespace
from typing import Any

import pytest
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st
from paths import SIMPLEBOT

from motivml.cli import main
from motivml.runtime import waiting
from motivml.runtime.loop import (
    DEFAULT_PRIORITY,
    RealClock,
    RealtimeRefused,
    default_priority,
    realtime_problem,
)
from motivml.runtime.waiting import SLICE_MAX_NS, SLICE_NS, TIMER_SLACK_NS

RUN = ["run", str(SIMPLEBOT), "--variant", "field", "--no-live", "--no-control"]


def run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, [*RUN, *args])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


def refuse(monkeypatch: pytest.MonkeyPatch) -> None:
    """This process may not use real-time scheduling, as without root or CAP_SYS_NICE."""

    def refused(*args: Any) -> None:
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(os, "sched_setscheduler", refused)


def test_a_priority_outside_0_to_99_is_a_usage_error() -> None:
    code, output = run("--priority", "100", "--duration", "0.01")
    assert code == 2 and "--priority" in output and "0<=x<=99" in output


def watch_scheduling(monkeypatch: pytest.MonkeyPatch) -> list[tuple[int, int]]:
    """Every sched_setscheduler call of this process from now on, as (policy, priority), and
    each one granted without changing anything: as where real time is allowed."""
    calls: list[tuple[int, int]] = []
    monkeypatch.setattr(os, "sched_setscheduler", lambda pid, policy, param: calls.append((policy, param.sched_priority)))
    return calls


def test_a_run_not_told_a_priority_takes_50_where_it_may(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = watch_scheduling(monkeypatch)
    assert default_priority() == (DEFAULT_PRIORITY, None) and DEFAULT_PRIORITY == 50
    calls.clear()
    code, output = run("--duration", "0.01")
    assert code == 0, output
    assert "1000 Hz, real clock, real-time priority 50, 0.01 s" in output
    # the probe, then the loop's thread while it ticks, then that thread given back, all
    # keeping reset-on-fork (which only CAP_SYS_NICE may clear, not an rtprio limit)
    assert calls == [
        (os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 50),
        (os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 50),
        (os.SCHED_OTHER | os.SCHED_RESET_ON_FORK, 0),
    ]


def test_a_run_not_told_a_priority_runs_ordinary_where_it_may_not_and_says_why(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    refuse(monkeypatch)
    assert default_priority() == (None, "real-time refused: Operation not permitted")
    seen: list[int | None] = []
    enter = RealClock.enter

    def watched(self: RealClock) -> None:
        seen.append(self.priority)
        enter(self)

    monkeypatch.setattr(RealClock, "enter", watched)
    code, output = run("--duration", "0.01")
    assert code == 0, output
    assert "1000 Hz, real clock, ordinary priority (real-time refused: Operation not permitted), 0.01 s" in output
    assert seen == [None]  # (not asked for, so not refused again in the run's log)
    assert "the loop runs at ordinary priority" not in output


def test_without_real_time_scheduling_a_run_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delattr(os, "sched_setscheduler")
    assert default_priority() == (None, "no real-time scheduling on this system")
    code, output = run("--duration", "0.01")
    assert code == 0, output
    assert "1000 Hz, real clock, ordinary priority (no real-time scheduling on this system), 0.01 s" in output


def test_a_default_priority_refused_when_the_loop_starts_is_given_up_and_said(monkeypatch: pytest.MonkeyPatch) -> None:
    """Allowed when probed, refused a moment later (a limit lowered meanwhile, say): the run
    goes on at ordinary priority and its log says so; a priority asked for is not given up."""
    monkeypatch.setattr("motivml.runtime.loop.default_priority", lambda: (50, None))
    refuse(monkeypatch)
    code, output = run("--duration", "0.01")
    assert code == 0, output
    assert "real clock, real-time priority 50, 0.01 s" in output
    assert "the loop runs at ordinary priority: real-time priority 50 was refused (Operation not permitted)" in output
    clock = RealClock(50, insist=False)
    clock.enter()
    try:
        assert (clock.priority, clock.real_time) == (None, False)
        assert clock.refused == "real-time priority 50 was refused (Operation not permitted)"
    finally:
        clock.leave()
    with pytest.raises(RealtimeRefused, match=r"^this process may not use real-time scheduling \(Operation not permitted\)"):
        RealClock(50).enter()


def test_a_priority_asked_for_and_refused_when_the_loop_starts_is_a_located_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Allowed when run checked, refused a moment later: the same message as before the
    run, exit code 3, no traceback."""
    monkeypatch.setattr("motivml.runtime.loop.realtime_problem", lambda priority: None)
    refuse(monkeypatch)
    code, output = run("--priority", "10", "--duration", "0.01")
    assert code == 3, output
    assert "real clock, real-time priority 10, 0.01 s" in output
    assert (
        "run --priority: this process may not use real-time scheduling (Operation not permitted): run it as root"
    ) in output
    assert "Traceback" not in output and "without a result" not in output


def test_priority_0_asks_for_no_real_time(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = watch_scheduling(monkeypatch)
    code, output = run("--priority", "0", "--duration", "0.01")
    assert code == 0, output
    assert "1000 Hz, real clock, ordinary priority, 0.01 s" in output
    assert calls == []  # (not even asked)
    code, output = run("--priority", "0", "--clock", "simulated", "--duration", "0.01")
    assert code == 0 and "1000 Hz, simulated clock, 0.01 s" in output, output
    assert calls == []


def test_a_priority_is_for_the_real_clock() -> None:
    code, output = run("--priority", "10", "--clock", "simulated", "--duration", "0.01")
    assert code == 2 and "a priority is for the real clock" in output


def test_a_process_that_may_not_is_told_how_to_allow_it(monkeypatch: pytest.MonkeyPatch) -> None:
    refuse(monkeypatch)
    problem = realtime_problem(10)
    assert problem is not None and problem.startswith(
        "this process may not use real-time scheduling (Operation not permitted): run it as root, give it "
        "CAP_SYS_NICE, or raise its real-time priority limit (ulimit -r 10; LimitRTPRIO=10 in a systemd unit)"
    )
    code, output = run("--priority", "10", "--duration", "0.01")
    assert code == 3, output
    assert output.startswith("run --priority: this process may not use real-time scheduling"), output
    assert "Traceback" not in output


def test_the_probe_changes_no_thread_of_the_caller() -> None:
    before = os.sched_getscheduler(0)
    realtime_problem(10)
    assert os.sched_getscheduler(0) == before


def test_the_loop_ticks_under_sched_fifo(monkeypatch: pytest.MonkeyPatch) -> None:
    problem = realtime_problem(10)
    if problem is not None:
        pytest.skip(f"real-time scheduling is not allowed here: {problem}")
    seen: list[tuple[int, int, int | None]] = []
    enter = RealClock.enter

    def watched(self: RealClock) -> None:
        enter(self)
        seen.append((os.sched_getscheduler(0), os.sched_getparam(0).sched_priority, waiting.timer_slack()))

    monkeypatch.setattr(RealClock, "enter", watched)
    main_thread = os.sched_getscheduler(0)
    code, output = run("--priority", "10", "--duration", "0.05")
    assert code == 0, output
    assert "1000 Hz, real clock, real-time priority 10, 0.05 s" in output
    # (children start ordinary; a real-time thread has no timer slack on recent kernels)
    assert seen in ([(os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 10, slack)] for slack in (0, TIMER_SLACK_NS))
    assert os.sched_getscheduler(0) == main_thread  # (the loop ran on a thread of its own)


@pytest.mark.skipif(waiting.timer_slack() is None, reason="timer slack is a Linux thread attribute")
def test_the_loop_thread_wakes_on_time_while_it_ticks_and_gets_its_own_attributes_back() -> None:
    """Timer slack 1 us, and a short slice (0.5 ms, fitted later) where the kernel lets an
    ordinary thread ask."""
    clock = RealClock()
    before = (waiting.timer_slack(), waiting.thread_slice())
    assert before[0] is not None and before[0] > TIMER_SLACK_NS  # Linux's default is 50 us
    seen: list[tuple[int | None, int | None]] = []

    def ticking() -> None:
        clock.enter()
        try:
            seen.append((waiting.timer_slack(), waiting.thread_slice()))
            clock.wait_until(clock.now() + 0.001)
        finally:
            clock.leave()
        seen.append((waiting.timer_slack(), waiting.thread_slice()))

    thread = threading.Thread(target=ticking)
    thread.start()
    thread.join()
    slices = before[1] is not None and _kernel() >= (6, 12)  # custom slices for ordinary threads
    assert seen == [(TIMER_SLACK_NS, SLICE_MAX_NS if slices else before[1]), before]
    assert (waiting.timer_slack(), waiting.thread_slice()) == before  # (another thread's are its own)


def _kernel() -> tuple[int, int]:
    major, minor = os.uname().release.split(".")[:2]
    return int(major), int("".join(c for c in minor if c.isdigit()) or 0)


@pytest.mark.skipif(waiting.thread_slice() is None, reason="no sched_getattr here")
def test_a_real_time_thread_keeps_its_scheduling_no_slice_is_asked() -> None:
    if realtime_problem(10) is not None:
        pytest.skip("real-time scheduling is not allowed here")
    seen: list[int | None] = []

    def realtime() -> None:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))
        seen.append(waiting.set_thread_slice(SLICE_NS))
        seen.append(os.sched_getscheduler(0))

    thread = threading.Thread(target=realtime)
    thread.start()
    thread.join()
    assert seen == [None, os.SCHED_FIFO]


class _RefusingLibc:
    """A C library whose calls all fail, as on a kernel without the feature or under a
    seccomp filter that refuses them."""

    def prctl(self, *args: Any) -> int:
        return -1

    def syscall(self, *args: Any) -> int:
        return -1


def test_where_linux_is_not_there_is_nothing_to_ask_and_on_time_changes_nothing(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(waiting.sys, "platform", "darwin")
    assert waiting.timer_slack() is None and waiting.thread_slice() is None
    assert waiting.set_timer_slack(TIMER_SLACK_NS) is None and waiting.set_thread_slice(SLICE_NS) is None
    waiting.on_time().restore()  # set and give back: nothing to do, and no error


def test_a_c_library_that_cannot_be_opened_is_no_error(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: Any, **kwargs: Any) -> None:
        raise OSError("no libc here")

    monkeypatch.setattr(waiting.ctypes, "CDLL", refuse)
    assert waiting.timer_slack() is None and waiting.thread_slice() is None


def test_a_machine_without_known_sched_attr_calls_gets_no_slice(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(waiting.platform, "machine", lambda: "riscv64")
    assert waiting.thread_slice() is None and waiting.set_thread_slice(SLICE_NS) is None


def test_calls_the_kernel_refuses_change_nothing_and_are_not_reported_as_done(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(waiting, "_libc", _RefusingLibc)
    assert waiting.timer_slack() is None and waiting.set_timer_slack(TIMER_SLACK_NS) is None
    assert waiting.thread_slice() is None and waiting.set_thread_slice(SLICE_NS) is None
    waiting.on_time().restore()


@pytest.mark.skipif(waiting.thread_slice() is None, reason="no sched_getattr here")
def test_a_slice_the_kernel_will_not_set_is_not_reported_as_set(monkeypatch: pytest.MonkeyPatch) -> None:
    real = waiting._libc()
    read, write = waiting._SCHED_ATTR_CALLS[waiting.platform.machine()][::-1]

    class Libc:
        def syscall(self, number: int, *args: Any) -> int:
            return -1 if number == write else int(real.syscall(number, *args))

    seen: list[int | None] = []

    def probe() -> None:  # on a thread of its own: this one's slice stays as it is
        before = waiting.thread_slice()
        monkeypatch.setattr(waiting, "_libc", Libc)
        seen.extend([waiting.set_thread_slice(SLICE_NS), before, waiting.thread_slice()])

    thread = threading.Thread(target=probe)
    thread.start()
    thread.join()
    assert seen[0] is None and seen[1] == seen[2]


def test_a_fitted_slice_is_twice_the_cpu_time_used_awake_in_whole_steps_within_its_bounds() -> None:
    assert waiting.fitted_slice(0.000_300, SLICE_NS, longest=1_000_000) == 600_000  # 0.3 ms awake outgrew 0.3 ms
    assert waiting.fitted_slice(0.000_301, SLICE_NS, longest=1_000_000) == 650_000  # (rounded up to a whole step)
    assert waiting.fitted_slice(0.000_010, SLICE_NS) == SLICE_NS  # never below the shortest
    assert waiting.fitted_slice(0.002, SLICE_NS) == SLICE_MAX_NS  # never above the longest
    assert waiting.fitted_slice(0.000_001, SLICE_MAX_NS) == SLICE_NS  # a slice far too long shrinks
    assert waiting.fitted_slice(0.000_300, SLICE_NS, longest=250_000) == 250_000  # (the thread's own)


def test_a_slice_is_kept_while_the_stretch_awake_is_between_a_quarter_and_three_quarters_of_it() -> None:
    for awake in (0.000_100, 0.000_200, 0.000_300):
        assert waiting.fitted_slice(awake, 400_000) == 400_000
    assert waiting.fitted_slice(0.000_301, 400_000) == SLICE_MAX_NS
    assert waiting.fitted_slice(0.000_099, 400_000) == SLICE_NS  # (twice it is below the shortest)
    assert waiting.fitted_slice(0.000_190, 800_000, longest=1_000_000) == 400_000


def _on_a_thread_of_its_own(work: Callable[[], list[Any]]) -> list[Any]:
    """What `work` returns, run on a new thread (its slice and nice value are its own)."""
    seen: list[list[Any]] = []
    thread = threading.Thread(target=lambda: seen.append(work()))
    thread.start()
    thread.join()
    return seen[0]


custom_slices = pytest.mark.skipif(
    waiting.thread_slice() is None or _kernel() < (6, 12), reason="no custom slices here"
)


@custom_slices
def test_on_time_fits_the_thread_s_slice_and_gives_the_thread_s_own_back() -> None:
    def ticking() -> list[Any]:
        before = waiting.thread_slice()
        asked = waiting.on_time()
        asked.fit(0.000_100)  # under a quarter of the first, 0.5 ms: twice it, or the shortest, 0.3 ms
        seen = [asked.slice, waiting.thread_slice()]
        asked.fit(0.000_120)  # within a quarter and three quarters: kept
        seen.append(waiting.thread_slice())
        asked.restore()
        return [*seen, waiting.thread_slice() == before]

    assert _on_a_thread_of_its_own(ticking) == [SLICE_NS, SLICE_NS, SLICE_NS, True]


class _Asked:
    """Stands for `waiting.OnTime`: records the fits, each after the sleeps made so far."""

    def __init__(self, events: list[Any]) -> None:
        self.events = events

    def fit(self, awake: float) -> None:
        self.events.append(("fit", awake))

    def restore(self) -> None:
        self.events.append("restore")


class _Time:
    """Stands for the `time` module in the loop: a clock that advances 1 us per reading and
    by what is slept, with every sleep recorded, and the thread's CPU time as it is set."""

    def __init__(self, events: list[Any]) -> None:
        self.events, self.now, self.cpu = events, 100.0, 5.0

    def thread_time(self) -> float:
        return self.cpu

    def perf_counter(self) -> float:
        self.now += 1e-6
        return self.now

    def sleep(self, seconds: float) -> None:
        self.events.append("sleep")
        self.now += seconds


def test_the_real_clock_fits_the_slice_just_after_a_wake_up_to_the_longest_stretch_it_ran_awake(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """After FIRST_FIT sleeps, then every FIT_EVERY, with the most CPU time the thread used
    between two sleeps (time it was preempted is not counted: it uses no slice)."""
    events: list[Any] = []
    fake = _Time(events)
    monkeypatch.setattr(waiting, "on_time", lambda: _Asked(events))
    monkeypatch.setattr(waiting, "FIT_EVERY", 3)
    monkeypatch.setattr("motivml.runtime.loop.time", fake)
    clock = RealClock()
    clock.enter()
    for k in range(waiting.FIRST_FIT + 3):
        fake.cpu += 0.0003 if k == 4 else 0.0001  # the CPU time used awake: once more
        fake.now += 0.005 if k == 7 else 0.0002  # (once preempted for long)
        clock.wait_until(fake.now + 0.001)
    clock.wait_until(fake.now - 0.001)  # (no sleep: a deadline already past)
    clock.leave()
    fits = [k for k, e in enumerate(events) if isinstance(e, tuple)]
    assert len(fits) == 2
    sleeps = [events[: fits[0]].count("sleep"), events[fits[0] : fits[1]].count("sleep")]
    assert sleeps == [waiting.FIRST_FIT, 3]
    assert events[fits[0] - 1] == events[fits[1] - 1] == "sleep"  # (no sleep between a wake-up and its fit)
    first, second = events[fits[0]][1], events[fits[1]][1]
    assert (first, second) == (pytest.approx(0.0003), pytest.approx(0.0001))  # the most since the last fit
    assert events[-1] == "restore" and events.count("sleep") == waiting.FIRST_FIT + 3


@custom_slices
def test_a_thread_whose_own_slice_is_shorter_keeps_it_as_the_longest() -> None:
    def ticking() -> list[Any]:
        waiting.set_thread_slice(200_000)
        asked = waiting.on_time()
        seen = [waiting.thread_slice()]
        asked.fit(0.000_400)  # would be 0.5 ms (0.8 at most otherwise)
        seen.append(waiting.thread_slice())
        asked.restore()
        return [*seen, waiting.thread_slice()]

    assert _on_a_thread_of_its_own(ticking) == [200_000, 200_000, 200_000]


@custom_slices
def test_a_fit_keeps_a_nice_value_the_thread_was_given_while_it_ticks() -> None:
    def ticking() -> list[Any]:
        me = threading.get_native_id()
        asked = waiting.on_time()
        os.setpriority(os.PRIO_PROCESS, me, os.getpriority(os.PRIO_PROCESS, me) + 1)  # (nicer: no privilege)
        nice = os.getpriority(os.PRIO_PROCESS, me)
        asked.fit(0.000_050)  # 0.5 ms -> the shortest
        seen = [waiting.thread_slice(), os.getpriority(os.PRIO_PROCESS, me) - nice]
        asked.restore()
        return seen

    assert _on_a_thread_of_its_own(ticking) == [SLICE_NS, 0]


@custom_slices
def test_a_fit_keeps_the_thread_s_reset_on_fork_flag() -> None:
    def ticking() -> list[Any]:
        os.sched_setscheduler(0, os.SCHED_OTHER | os.SCHED_RESET_ON_FORK, os.sched_param(0))
        asked = waiting.on_time()
        asked.fit(0.000_050)
        seen = [os.sched_getscheduler(0), waiting.thread_slice()]
        asked.restore()
        return seen

    assert _on_a_thread_of_its_own(ticking) == [os.SCHED_OTHER | os.SCHED_RESET_ON_FORK, SLICE_NS]


# ------------------------------------------------- deadlines between the scheduler's ticks
def _after_grid(monotonic: float, grid: float) -> float:
    """How far `monotonic` lies after the last multiple of `grid` (s)."""
    return monotonic - math.floor(monotonic / grid) * grid


@pytest.mark.parametrize(("rate", "grid"), [(1000, 0.001), (500, 0.001), (250, 0.001), (2000, 0.0005), (4000, 0.00025)])
def test_the_first_deadline_falls_a_fixed_part_of_a_grid_step_after_the_grid(rate: int, grid: float) -> None:
    period = 1.0 / rate
    for monotonic in (12345.0, 12345.000349, 12345.00035, 12345.000351, 777.123456789):
        first = waiting.first_deadline(7.0, period, monotonic)
        on_monotonic = monotonic + (first - 7.0)
        assert period <= first - 7.0 < period + grid
        assert _after_grid(on_monotonic, grid) == pytest.approx(waiting.TICK_PHASE * grid, abs=1e-9)


@pytest.mark.parametrize("period", [1 / 997, 1 / 300, 1 / 1024, 1 / 3, 0.001 + 1e-11, 1e300, 1e-12])
def test_a_period_with_no_step_in_common_with_the_ticks_starts_one_period_from_now(period: float) -> None:
    """Nor one that is not a whole number of nanoseconds (it would drift off the grid),
    nor one too long or too short to count in them."""
    assert waiting.first_deadline(7.0, period, 12345.000123) == 7.0 + period


def test_off_linux_the_first_deadline_is_one_period_from_now(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(waiting.sys, "platform", "win32")
    assert waiting.first_deadline(7.0, 0.001, 12345.000123) == 7.001


@given(
    st.integers(min_value=10**9, max_value=10**15),  # the monotonic clock, in ns
    st.sampled_from([1000, 500, 250, 200, 100, 2000]),
)
def test_the_first_deadline_is_the_earliest_aligned_time_a_period_or_more_ahead(monotonic_ns: int, rate: int) -> None:
    """Against a search over whole microseconds (the grid steps and the phase are whole
    microseconds for these rates)."""
    period_us = 10**6 // rate
    grid_us = math.gcd(period_us, 1000)
    phase_us = round(waiting.TICK_PHASE * grid_us)
    earliest_us = -(-(monotonic_ns + period_us * 1000) // 1000)  # rounded up
    wanted_us = next(t for t in range(earliest_us, earliest_us + grid_us + 1) if t % grid_us == phase_us)
    first = waiting.first_deadline(0.0, period_us / 1e6, monotonic_ns / 1e9)
    assert (monotonic_ns / 1e9 + first) * 1e6 == pytest.approx(wanted_us, abs=0.01)


def test_the_real_clock_places_its_first_deadline_on_the_monotonic_clock_s_grid(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The real clock (perf_counter) asks for its first deadline with the monotonic clock's
    reading: on a machine where they read 100.0 s and 50.0004 s, the first deadline at 1 kHz
    is where the monotonic clock reads 50.00235 s (0.35 ms after a whole millisecond, at
    least a period ahead). (Clocks fixed: no verdict depends on how fast the machine is.)"""
    monkeypatch.setattr(time, "perf_counter", lambda: 100.0)
    monkeypatch.setattr(time, "clock_gettime", lambda clock: 50.0004)
    first = RealClock().first_deadline(0.001)
    assert first == pytest.approx(100.0 + (50.00235 - 50.0004), abs=1e-9)
    assert _after_grid(50.0004 + (first - 100.0), 0.001) == pytest.approx(waiting.TICK_PHASE * 0.001, abs=1e-9)


def test_every_deadline_of_a_real_clock_run_falls_between_the_scheduler_s_ticks(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The loop starts at the clock's first deadline, not one period from now: on a clock
    whose monotonic twin reads 50 s when it reads 100 s, every deadline waited for is 0.35 ms
    after a whole millisecond of the monotonic clock."""
    from motivml.runtime.launch import launch

    waited: list[float] = []

    class Fake(RealClock):
        def __init__(self) -> None:
            super().__init__()
            self.t = 100.0

        def now(self) -> float:
            return self.t

        def enter(self) -> None:
            pass

        def leave(self) -> None:
            pass

        def wait_until(self, deadline: float) -> float:
            waited.append(deadline)
            self.t = max(self.t, deadline) + 0.0001
            return self.t

    clock = Fake()
    monkeypatch.setattr(waiting, "time", SimpleNamespace(CLOCK_MONOTONIC=1, clock_gettime=lambda _: clock.t - 50.0))
    stats = launch(SIMPLEBOT.parent / "reaching_arm", "dmp", rate=1000).runtime.run(0.02, clock)
    assert stats.ticks == 20 and len(waited) == 20
    assert waited[0] - 100.0 >= 0.001
    for deadline in waited:
        assert _after_grid(deadline - 50.0, 0.001) == pytest.approx(0.00035, abs=1e-9)

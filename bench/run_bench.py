"""Benchmark: the runtime's real-time loop with 20 components.

Builds a generated robot of 20 adaptive components (8 DMP reaching controllers, 6 point-
attractor tracking controllers, 6 four-oscillator pattern generators; each tracking
controller's goal is a DMP's output, so the stepping order matters, and the tracking
controllers and pattern generators superpose in shared spaces) and runs it on the real
clock at --rate Hz for --duration seconds, in this process, as `motivml run` does (the live
view off), with the loop's thread scheduled as `run` schedules it (real-time priority 50
where this process may, else ordinary; --priority N for N, 0 for ordinary). Prints the
achieved rate, tick jitter (start - deadline) p50/p99/max, work per tick p50/p99, missed
deadlines and the process's CPU share.

The floor, timed in the same run: the same clock, priority and schedule with a busy-wait of the
measured median work per tick instead of the architecture. What the floor misses, this
machine's scheduler misses (late wake-ups from sleep), not the runtime.

Then the same on a busy machine (issue 14): with --busy CPU-bound processes running (default
2, one per core of the machine this was written on), --rounds alternations of the robot's
loop and of a bare sleep loop (`time.sleep` until each deadline, nothing else: what a
program that does not care writes), each for --busy-duration seconds; their missed
deadlines summed over the rounds. Beside them, for reference, the bare sleep loop with the
robot's median work per tick as busy-waiting, and, where the robot's loop ran at a real-time
priority, the robot's loop at ordinary priority (as `run` runs it where real time is refused).

    python bench/run_bench.py [--rate 1000] [--duration 10] [--components 20] [--busy 2] [--priority N]

Targets: (issue 4) no missed deadline, p99 jitter under 0.5 ms; (issue 14) on the busy
machine, missed deadlines at most 1.5x those of the bare sleep loop.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from motivml.runtime.launch import launch
from motivml.runtime.loop import RealClock, run_scheduling


def robot(folder: Path, components: int) -> None:
    model = {"id": "bench", "name": "Bench", "sub": [{"id": "motion", "name": "Motion", "isMandatory": True}]}
    spaces: list[dict[str, Any]] = []
    modules: list[dict[str, Any]] = []
    parts: list[dict[str, Any]] = []
    for k in range(components):
        kind = ("dmp", "tracking", "cpg")[k % 3] if k < 18 else "dmp"
        out = f"Ref{k}" if kind == "dmp" else f"Out{k // 2}"  # tracking and CPGs superpose in pairs
        if not any(s["id"] == out for s in spaces):
            spaces.append({"id": out, "type": "JointAngles", "dimension": 4, "feature": "motion"})
        if kind == "dmp":
            goal = f"Goal{k}"
            spaces.append(
                {
                    "id": goal,
                    "type": "JointAngles",
                    "dimension": 4,
                    "initial": [0.1 * k] * 4,
                    "feature": "motion",
                }
            )
            system: dict[str, Any] = {"type": "dmp", "dimension": 4, "duration": 0.8}
            part: dict[str, Any] = {
                "kind": "ReachingController",
                "criterion": {"type": "convergence", "tolerance": 0.01},
            }
        elif kind == "tracking":
            goal = f"Ref{k - 1}"  # the DMP's output: it must step first in each tick
            system = {"type": "pointAttractor", "dimension": 4}
            part = {"kind": "TrackingController", "criterion": {"type": "tracking", "tolerance": 0.01}}
        else:
            system = {"type": "oscillators", "dimension": 4, "offsets": [0.0, 3.14159, 3.14159, 0.0]}
            part = {"kind": "PatternGenerator", "criterion": {"type": "tracking", "tolerance": 0.01}}
        modules.append({"id": f"M{k}", "systems": [system], "feature": "motion"})
        part.update({"id": f"C{k}", "module": f"M{k}", "output": {"space": out}, "feature": "motion"})
        if kind != "cpg":
            part["goal"] = {"space": goal}
        parts.append(part)
    (folder / "variants").mkdir(parents=True)
    (folder / "model.json").write_text(json.dumps(model))
    (folder / "variants" / "all.json").write_text(json.dumps({"properties": []}))
    architecture = {"spaces": spaces, "modules": modules, "components": parts}
    (folder / "architecture.json").write_text(json.dumps(architecture))


def floor(rate: float, duration: float, work: float, priority: int | None) -> tuple[list[float], int]:
    """The same schedule and clock (at real-time `priority`, if any) with `work` seconds of
    busy-waiting per tick."""
    clock, period = RealClock(priority), 1.0 / rate
    start = clock.first_deadline(period)
    jitter, missed, slot, total = [], 0, 0, round(duration * rate)
    clock.enter()
    try:
        while slot < total:
            deadline = start + slot * period
            began = clock.wait_until(deadline)
            while time.perf_counter() - began < work:
                pass
            jitter.append(began - deadline)
            slot += 1
            ended = clock.now()
            if ended > start + slot * period:  # as the runtime: skip the deadlines overrun
                ahead = math.ceil((ended - start) / period)
                missed += min(ahead, total) - slot
                slot = ahead
    finally:
        clock.leave()
    return jitter, missed


def sleep_loop(rate: float, duration: float, work: float = 0.0) -> int:
    """The bare sleep loop: sleep until each deadline, no work (or `work` seconds of
    busy-waiting); its missed deadlines (woken after the next one)."""
    period = 1.0 / rate
    start = time.perf_counter() + period
    missed, slot, total = 0, 0, round(duration * rate)
    while slot < total:
        ahead = start + slot * period - time.perf_counter()
        if ahead > 0:
            time.sleep(ahead)
        began = time.perf_counter()
        while time.perf_counter() - began < work:
            pass
        slot += 1
        ended = time.perf_counter()
        if ended > start + slot * period:
            late = math.ceil((ended - start) / period)
            missed += min(late, total) - slot
            slot = late
    return missed


@contextlib.contextmanager
def busy(processes: int) -> Iterator[None]:
    """`processes` CPU-bound processes for the time of the block."""
    hogs = [
        subprocess.Popen([sys.executable, "-c", "while True: pass"])  # noqa: S603 (our own interpreter)
        for _ in range(processes)
    ]
    try:
        time.sleep(0.2)  # (under way)
        yield
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()


def loop_priority(asked: int | None) -> tuple[int | None, str]:
    """The robot's loop's real-time priority (None: ordinary) and how to say it, as `run
    --priority asked` has it (exits if a priority asked for is refused)."""
    chosen = run_scheduling(asked)
    if chosen.problem is not None:
        sys.exit(f"--priority {asked}: not measured: {chosen.problem}")
    return chosen.priority, chosen.said


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--components", type=int, default=20)
    parser.add_argument("--busy", type=int, default=2, help="CPU-bound processes for the busy run (0: none)")
    parser.add_argument(
        "--rounds",
        type=int,
        default=30,
        help="alternations of the busy run (10 gave anything from 0.86 to 2.85 times in one day)",
    )
    parser.add_argument("--busy-duration", type=float, default=2.0, help="seconds of each loop per round")
    parser.add_argument(
        "--priority",
        type=int,
        help="the robot's loop's real-time priority, 0 for ordinary scheduling (default: as run, 50 where it may)",
    )
    args = parser.parse_args()
    priority, scheduling = loop_priority(args.priority)
    with tempfile.TemporaryDirectory() as tmp:
        robot(Path(tmp), args.components)
        built = launch(tmp, "all", rate=args.rate)
    assert len(built.assembly.components) == args.components
    stats = built.runtime.run(args.duration, RealClock(priority))
    ms = 1e3
    print(f"{args.components} components at {args.rate:g} Hz for {args.duration:g} s (real clock, {scheduling})")
    print(f"  ticks            {stats.ticks} in {stats.elapsed:.3f} s: {stats.achieved:,.1f} Hz achieved")
    print(
        f"  jitter           p50 {stats.percentile(stats.jitter, 50) * ms:.3f} ms, "
        f"p99 {stats.percentile(stats.jitter, 99) * ms:.3f} ms, max {max(stats.jitter) * ms:.3f} ms"
    )
    print(
        f"  work per tick    p50 {stats.percentile(stats.work, 50) * ms:.3f} ms, "
        f"p99 {stats.percentile(stats.work, 99) * ms:.3f} ms, max {max(stats.work) * ms:.3f} ms"
    )
    print(f"  missed deadlines {stats.missed}")
    print(f"  CPU share        {stats.cpu_share:.0%} of one core")
    median = float(np.percentile(stats.work, 50))
    jitter, missed = floor(args.rate, args.duration, median, priority)
    print(f"floor: the same clock with {median * ms:.3f} ms of busy-waiting per tick")
    print(
        f"  jitter           p50 {np.percentile(jitter, 50) * ms:.3f} ms, "
        f"p99 {np.percentile(jitter, 99) * ms:.3f} ms, max {max(jitter) * ms:.3f} ms"
    )
    print(f"  missed deadlines {missed}")
    if args.busy:
        loop_missed = bare_missed = working_missed = ordinary_missed = 0
        with busy(args.busy):
            for _ in range(args.rounds):
                loop_missed += built.runtime.run(args.busy_duration, RealClock(priority)).missed
                bare_missed += sleep_loop(args.rate, args.busy_duration)
                working_missed += sleep_loop(args.rate, args.busy_duration, median)
                if priority is not None:
                    ordinary_missed += built.runtime.run(args.busy_duration, RealClock()).missed
        ratio = loop_missed / max(bare_missed, 1)
        verdict = "met" if loop_missed <= 1.5 * bare_missed else "MISSED"
        print(
            f"busy machine: {args.busy} CPU-bound processes, {args.rounds} rounds of {args.busy_duration:g} s each, "
            "alternated"
        )
        print(f"  missed deadlines {loop_missed} (the robot's loop, {scheduling}), {bare_missed} (a bare sleep loop)")
        print(
            f"  and {working_missed} for the bare sleep loop with the robot's {median * ms:.3f} ms of busy-waiting"
            " per tick (what doing that much work each period costs on this busy machine)"
        )
        if priority is not None:
            print(
                f"  and {ordinary_missed} for the robot's loop at ordinary priority, as run runs it where real time is "
                f"refused (ratio {ordinary_missed / max(bare_missed, 1):.2f}; see the-motion-architecture.md section 8)"
            )
        print(f"  ratio {ratio:.2f}   target (issue 14) <= 1.5: {verdict}")
    sys.exit(0)


if __name__ == "__main__":
    main()

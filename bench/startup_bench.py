"""Benchmark: what the command line costs on top of a bare interpreter.

Process start to exit, the median of several runs of each, in fresh processes of the same
Python, measured in one run:

* the floor: `python -c pass`;
* `motivml --version` (the CLI's own start-up: click and the command table);
* `motivml validate feature_models/simplebot` (the robot folder a CI job checks: the model
  with its analyses, four variants, one of them deliberately invalid and explained, the
  architecture), which imports only what it uses;
* `motivml validate ... --variant lab` (one variant).

It also lists which heavy packages each command imported (numpy, sismic, rich's live view
should be absent from all of these). The package is byte-compiled first, as an installed
wheel is; PYTHONDONTWRITEBYTECODE is dropped for the runs.

    python bench/startup_bench.py [--runs 15]

Target (issue 11): the CLI adds under 0.15 s to the bare interpreter.
"""

from __future__ import annotations

import argparse
import compileall
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TARGET = 0.15  # seconds the CLI may add to a bare interpreter
HEAVY = ("numpy", "sismic", "rich.live", "rclpy")

COMMANDS = {
    "python -c pass (floor)": ["-c", "pass"],
    "motivml --version": ["-m", "motivml.cli", "--version"],
    "motivml validate simplebot": ["-m", "motivml.cli", "validate", "feature_models/simplebot"],
    "motivml validate simplebot --variant lab": [
        "-m",
        "motivml.cli",
        "validate",
        "feature_models/simplebot",
        "--variant",
        "lab",
    ],
}


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def _wall(args: list[str], env: dict[str, str]) -> float:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, *args], cwd=ROOT, env=env, capture_output=True)
    wall = time.perf_counter() - start
    if done.returncode not in (0, 1):  # 1: simplebot ships a deliberately invalid variant
        raise SystemExit(f"{' '.join(args)} exited {done.returncode}:\n{done.stdout.decode()}{done.stderr.decode()}")
    return wall


def _heavy_imports(args: list[str], env: dict[str, str]) -> list[str]:
    done = subprocess.run([sys.executable, "-X", "importtime", *args], cwd=ROOT, env=env, capture_output=True)
    imported = {line.rsplit("|", 1)[-1].strip() for line in done.stderr.decode().splitlines()}
    return [name for name in HEAVY if name in imported]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=15)
    runs = parser.parse_args().runs
    compileall.compile_dir(ROOT / "motivml", quiet=1)
    env = _environment()
    for args in COMMANDS.values():  # warm the page cache and write any missing bytecode
        _wall(args, env)
    times: dict[str, list[float]] = {name: [] for name in COMMANDS}
    for _ in range(runs):  # interleaved, so that a busy moment costs every command alike
        for name, args in COMMANDS.items():
            times[name].append(_wall(args, env))
    medians = {name: statistics.median(samples) for name, samples in times.items()}
    floor = medians["python -c pass (floor)"]
    print(f"start-up, median of {runs} runs each (target: the CLI adds under {TARGET:.2f} s to the floor)")
    print(f"{'command':<44} {'median':>8} {'added':>8}  {'verdict':<8} heavy imports")
    for name, args in COMMANDS.items():
        added = medians[name] - floor
        if name.startswith("python"):
            print(f"{name:<44} {medians[name]:>7.3f}s {'':>8}  {'floor':<8}")
            continue
        verdict = "met" if added < TARGET else "NOT met"
        heavy = ", ".join(_heavy_imports(args, env)) or "none"
        print(f"{name:<44} {medians[name]:>7.3f}s {added:>7.3f}s  {verdict:<8} {heavy}")


if __name__ == "__main__":
    main()

"""Benchmark: end-to-end `motivml validate` on generated models, against a bare-SAT floor.

For n = 1,000, 10,000 and 100,000 features (generate.py: deep trees, ~10% of features in
cross-tree constraints, mixed bindings) with a valid full configuration it prints

* the wall time and peak memory of `motivml validate MODEL --config CONFIG` in a fresh
  process (what a user waits for): the median of --repeat runs, alternated with the
  floor's;
* where the time goes, in-process: loading, schema check and reading of the model and of
  the configuration, encoding, solve;
* the floor: the same CNF as a DIMACS file, read by pysat and solved under the same
  assumptions in a fresh process (what any SAT-based checker must pay at least), with its
  peak memory (the median time of --repeat runs);
* `motivml validate MODEL` alone (the model analyses: void, dead features, bindings
  allowed but never possible, the first 20 of each explained), against the same floor:
  the median of --repeat runs, alternated with the others, and the larger peak memory.

    python bench/validate_bench.py [--sizes 1000 10000 100000] [--repeat 5]

Targets (issue 2): 10,000 features under 1 s and 100,000 under 10 s, end to end. Issue 14:
validate --config within 3x the floor at 10k and 2.5x at 100k with at most twice its peak
memory; validate MODEL within 5x at 10k and 10x at 100k (printed met/MISSED per row).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from generate import write  # noqa: E402

FLOOR = """
import sys, time
t0 = time.perf_counter()
from pysat.formula import CNF
from pysat.solvers import Solver
cnf = CNF(from_file=sys.argv[1])
assumptions = [int(x) for x in open(sys.argv[2]).read().split()]
with Solver(name=sys.argv[3], bootstrap_with=cnf.clauses) as solver:
    assert solver.solve(assumptions=assumptions)
print(time.perf_counter() - t0)
"""


def child_env() -> dict[str, str]:
    """The environment of the measured processes: this one's, but Python keeps the compiled
    modules it writes, as on a user's machine (a machine-wide PYTHONDONTWRITEBYTECODE would
    make every run compile motivml anew)."""
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def compile_motivml() -> None:
    """Compile motivml's modules before anything is timed (a first run would otherwise pay
    for it, as a user's first run does)."""
    import motivml

    package = str(Path(motivml.__file__).resolve().parent)
    subprocess.run(
        [sys.executable, "-m", "compileall", "-q", package],
        env=child_env(),
        stdout=subprocess.DEVNULL,
        check=False,
    )


def run_measured(args: list[str]) -> tuple[float, int, str]:
    """Wall seconds, peak RSS in MiB and stdout of a child process.

    The bench's own process stays small (the in-process stages run in a child of their own,
    `measured_stages`): a child's peak RSS counts what it shared with this process when it
    was forked."""
    start = time.perf_counter()
    child = subprocess.Popen(
        args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=child_env()
    )
    assert child.stdout is not None
    output = child.stdout.read()
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(args)} failed:\n{output}")
    return wall, usage.ru_maxrss // 1024, output


def stages(
    model_path: str, config_path: str, cnf_path: str, assumptions_path: str
) -> list[tuple[str, float]]:
    from motivml.binding import encoding as enc
    from motivml.documents.loader import load_file
    from motivml.documents.schema import check_configuration, check_feature_model
    from motivml.language.reader import read_configuration, read_model
    from motivml.process import no_gc

    times: list[tuple[str, float]] = []
    t = time.perf_counter()
    doc = load_file(model_path)
    times.append(("model: load", time.perf_counter() - t))
    t = time.perf_counter()
    with no_gc():
        assert not check_feature_model(doc)
    times.append(("schema", time.perf_counter() - t))
    t = time.perf_counter()
    with no_gc():
        model, _ = read_model(doc)
    times.append(("read", time.perf_counter() - t))
    t = time.perf_counter()
    doc = load_file(config_path)
    times.append(("configuration: load", time.perf_counter() - t))
    t = time.perf_counter()
    with no_gc():
        assert not check_configuration(doc)
    times.append(("schema", time.perf_counter() - t))
    t = time.perf_counter()
    with no_gc():
        config, _ = read_configuration(doc, model)
    times.append(("read", time.perf_counter() - t))
    t = time.perf_counter()
    with no_gc(), enc.Encoding(model, record=True) as encoding:  # as check_variant does
        encoding.set_configuration(config)
        times.append(("encode", time.perf_counter() - t))
        t = time.perf_counter()
        assert encoding.solve()
        times.append(("solve", time.perf_counter() - t))
        assert encoding.recorded is not None
        top = max(abs(lit) for clause in encoding.recorded for lit in clause)
        with open(cnf_path, "w") as handle:
            handle.write(f"p cnf {top} {len(encoding.recorded)}\n")
            handle.writelines(" ".join(map(str, clause)) + " 0\n" for clause in encoding.recorded)
        with open(assumptions_path, "w") as handle:
            handle.write(" ".join(map(str, encoding.assumptions())))
    return times


def measured_stages(
    model_path: str, config_path: str, cnf_path: str, assumptions_path: str
) -> list[tuple[str, float]]:
    """`stages` in a child process (see run_measured)."""
    _, _, output = run_measured(
        [sys.executable, __file__, "--stages", model_path, config_path, cnf_path, assumptions_path]
    )
    return [(name, seconds) for name, seconds in json.loads(output.splitlines()[-1])]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10_000, 100_000])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--repeat", type=int, default=5, help="runs of --config, MODEL and the floor (medians)")
    parser.add_argument("--stages", nargs=4, help=argparse.SUPPRESS)  # (measured_stages' child)
    args = parser.parse_args()
    if args.stages:
        print(json.dumps(stages(*args.stages)))
        return
    from motivml.binding.encoding import SOLVER

    compile_motivml()

    motivml = str(Path(sys.executable).with_name("motivml"))
    print(f"solver {SOLVER}; python {sys.version.split()[0]}; {os.cpu_count()} cores")
    print(
        f"{'features':>9} {'MB':>5} {'floor s':>8} {'MiB':>5} | {'--config s':>10} {'ratio':>5} {'MiB':>5}"
        f" {'target':>6} | {'MODEL s':>8} {'ratio':>6} {'MiB':>5} {'target':>6} |  stages of --config (s)"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            folder = os.path.join(tmp, f"m{n}")
            model_path, config_path = write(n, args.seed, folder)
            size = os.path.getsize(model_path) / 1e6
            cnf_path, assumptions_path = os.path.join(folder, "f.cnf"), os.path.join(folder, "a.txt")
            parts = measured_stages(model_path, config_path, cnf_path, assumptions_path)
            # --config, its floor and MODEL alone alternated, --repeat times each: the medians
            # (a run of a few tenths of a second varies by a tenth between runs)
            checks, floors, analyses = [], [], []
            for _ in range(args.repeat):
                checks.append(run_measured([motivml, "validate", model_path, "--config", config_path]))
                assert checks[-1][2].startswith("valid: "), checks[-1][2]
                floors.append(run_measured([sys.executable, "-c", FLOOR, cnf_path, assumptions_path, SOLVER]))
                analyses.append(run_measured([motivml, "validate", model_path]))
                assert "valid: " in analyses[-1][2], analyses[-1][2]
            wall, peak = statistics.median(c[0] for c in checks), max(c[1] for c in checks)
            floor_wall, floor_peak = statistics.median(f[0] for f in floors), max(f[1] for f in floors)
            alone, alone_peak = statistics.median(a[0] for a in analyses), max(a[1] for a in analyses)
            detail = ", ".join(f"{k} {v:.2f}" for k, v in parts)
            config_target, model_target = TARGETS.get(n, (None, None))
            print(
                f"{n:>9,} {size:>5.1f} {floor_wall:>8.2f} {floor_peak:>5} | {wall:>10.2f} {wall / floor_wall:>5.1f}"
                f" {peak:>5} {verdict(wall / floor_wall, peak / floor_peak, config_target):>6} |"
                f" {alone:>8.2f} {alone / floor_wall:>6.1f} {alone_peak:>5} {verdict(alone / floor_wall, None, model_target):>6}"
                f" |  {detail}",
                flush=True,
            )
    print(
        "targets (issue 14): validate --config at most 3x the floor at 10k and 2.5x at 100k, peak memory"
        " at most 2x the floor's; validate MODEL (the model analyses) at most 5x at 10k and 10x at 100k"
    )


# Issue 14's targets by size: (validate --config ratio, validate MODEL ratio); memory: 2x.
TARGETS = {10_000: (3.0, 5.0), 100_000: (2.5, 10.0)}
MEMORY_TARGET = 2.0


def verdict(ratio: float, memory: float | None, target: float | None) -> str:
    if target is None:
        return "-"
    return "met" if ratio <= target and (memory is None or memory <= MEMORY_TARGET) else "MISSED"


if __name__ == "__main__":
    main()

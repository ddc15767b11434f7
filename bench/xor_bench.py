"""Benchmark: a model whose root has one XOR group of N members, through `motivml validate`.

For each N it prints

* the wall time of `motivml validate MODEL --config CONFIG` in a fresh process (the first
  member selected, the others not; a configuration check does not analyse the model: the
  analysis, dead features and possible bindings, makes one witness per member and is still
  quadratic in N, 5 s at 2,000 members);
* the floor of validate_bench.py: the same CNF as a DIMACS file, read by pysat and
  solved once under the configuration's assumptions in a fresh process, and the ratio;
* the in-process time to encode the model and solve it once.

    python bench/xor_bench.py [--sizes 2000 10000]

An XOR group used to be encoded pair by pair (N (N - 1) / 2 facts of four clauses): 105 s
and 2 GB at 2,000 members, a MemoryError at 4,000. It is now linear in N.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from validate_bench import FLOOR, compile_motivml, measured_stages, run_measured  # noqa: E402

TARGET = 3.0  # issue 14: validate --config / floor at 10,000 members


def model(n: int) -> dict[str, object]:
    free = {"bindingTimeAllowed": "Any", "bindingModeAllowed": "Any"}
    members = [{"id": f"m{i}", "name": f"M{i}", "group": "XOR", "constraints": free} for i in range(n)]
    return {"id": "root", "name": "Root", "sub": members}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2000, 10000])
    sizes = parser.parse_args().sizes
    from motivml.binding.encoding import SOLVER

    motivml = str(Path(sys.executable).with_name("motivml"))
    compile_motivml()
    print(
        f"{'members':>8} {'clauses':>9} {'floor s':>8} {'MiB':>5} | {'validate s':>10} {'ratio':>5} {'MiB':>5}"
        f" {'target':>6} | encode+solve s"
    )
    for n in sizes:
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "model.json")
            Path(path).write_text(json.dumps(model(n)))
            config = os.path.join(folder, "config.json")
            entries = [{"id": f"m{i}", "selected": i == 0} for i in range(n)]
            Path(config).write_text(json.dumps({"properties": entries}))
            wall, peak, output = run_measured([motivml, "validate", path, "--config", config])
            assert output.startswith("valid: "), output
            cnf, assumptions = os.path.join(folder, "f.cnf"), os.path.join(folder, "a.txt")
            parts = dict(measured_stages(path, config, cnf, assumptions))
            with open(cnf) as handle:
                clauses = int(handle.readline().split()[3])
            floor, floor_peak, _ = run_measured([sys.executable, "-c", FLOOR, cnf, assumptions, SOLVER])
            ratio = wall / floor
            verdict = "-" if n != 10000 else ("met" if ratio <= TARGET else "MISSED")
            print(
                f"{n:>8} {clauses:>9} {floor:>8.2f} {floor_peak:>5} | {wall:>10.2f} {ratio:>5.1f} {peak:>5}"
                f" {verdict:>6} | {parts['encode'] + parts['solve']:.3f}",
                flush=True,
            )
    print(f"target (issue 14): validate --config at most {TARGET:g}x the floor at 10,000 members")


if __name__ == "__main__":
    main()

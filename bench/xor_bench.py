"""Benchmark: a model whose root has one XOR group of N members, through `motivml validate`.

For each N it prints

* the wall time of `motivml validate MODEL --config CONFIG` in a fresh process (the first
  member selected, the others not; a configuration check does not analyse the model: the
  analysis, dead features and possible bindings, makes one witness per member and is still
  quadratic in N, 13 s at 2,000 members);
* the in-process time to encode the model and solve it once;
* the floor: the same CNF as a DIMACS file, read by pysat and solved once in a fresh
  process.

    python bench/xor_bench.py [--sizes 2000 10000]

An XOR group used to be encoded pair by pair (N (N - 1) / 2 facts of four clauses): 105 s
and 2 GB at 2,000 members, a MemoryError at 4,000. It is now linear in N.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

FLOOR = """
import sys, time
t0 = time.perf_counter()
from pysat.formula import CNF
from pysat.solvers import Solver
cnf = CNF(from_file=sys.argv[1])
with Solver(name=sys.argv[2], bootstrap_with=cnf.clauses) as solver:
    assert solver.solve()
print(time.perf_counter() - t0)
"""


def model(n: int) -> dict[str, object]:
    free = {"bindingTimeAllowed": "Any", "bindingModeAllowed": "Any"}
    members = [{"id": f"m{i}", "name": f"M{i}", "group": "XOR", "constraints": free} for i in range(n)]
    return {"id": "root", "name": "Root", "sub": members}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2000, 10000])
    sizes = parser.parse_args().sizes
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from motivml.binding.encoding import SOLVER, Encoding
    from motivml.documents.loader import parse
    from motivml.language.reader import read_model

    print(f"{'members':>8} {'validate (s)':>13} {'encode+solve (s)':>17} {'floor (s)':>10} {'clauses':>9}")
    for n in sizes:
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "model.json")
            text = json.dumps(model(n))
            Path(path).write_text(text)
            config = os.path.join(folder, "config.json")
            entries = [{"id": f"m{i}", "selected": i == 0} for i in range(n)]
            Path(config).write_text(json.dumps({"properties": entries}))
            start = time.perf_counter()
            done = subprocess.run(
                [sys.executable, "-m", "motivml.cli", "validate", path, "--config", config],
                capture_output=True,
                text=True,
            )
            wall = time.perf_counter() - start
            assert done.returncode == 0, done.stdout + done.stderr
            feature_model, _ = read_model(parse(text, path))
            start = time.perf_counter()
            with Encoding(feature_model, record=True) as encoding:
                assert encoding.solve(with_config=False)
                recorded = encoding.recorded
            in_process = time.perf_counter() - start
            assert recorded is not None
            cnf = os.path.join(folder, "f.cnf")
            top = max(abs(lit) for clause in recorded for lit in clause)
            with open(cnf, "w") as handle:
                handle.write(f"p cnf {top} {len(recorded)}\n")
                handle.writelines(" ".join(map(str, clause)) + " 0\n" for clause in recorded)
            floor = float(
                subprocess.run(
                    [sys.executable, "-c", FLOOR, cnf, SOLVER], capture_output=True, text=True, check=True
                ).stdout
            )
            print(f"{n:>8} {wall:>13.2f} {in_process:>17.3f} {floor:>10.3f} {len(recorded):>9}")


if __name__ == "__main__":
    main()

"""Benchmark: `motivml configure` on generated models with half the bindings left `Any`.

For n = 1,000, 10,000 and 100,000 features (generate.py) the valid full configuration
becomes a decisions file with many open decisions (generate.open_decisions: a tenth of the
entries left out, each remaining selected feature's time and mode `Any` with probability
1/2), so the solver (MaxSAT, RC2) decides a tenth of the selections and half the bindings. Prints wall time and peak memory of
`motivml configure ROBOT --variant full -o OUT` in a fresh process (the median of --repeat
runs, each into a new folder, alternated with the floor's).

    python bench/configure_bench.py [--sizes 1000 10000 100000] [--repeat 5]

Beside it, the floor of validate_bench.py measured in the same run: the same model and
configuration as one CNF (the hard encoding and the configuration's assumptions), read by
pysat and solved once in a fresh process (the median of --repeat runs), and the ratio.

Targets: (issue 3) 10,000 features under 2 s; (issue 14) at most 3x the floor at 100k.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from generate import open_decisions, write  # noqa: E402
from validate_bench import FLOOR, compile_motivml, measured_stages, run_measured, verdict  # noqa: E402

TARGETS = {100_000: 3.0}  # issue 14: configure / floor


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10_000, 100_000])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--repeat", type=int, default=5, help="runs of configure and of the floor (medians)")
    args = parser.parse_args()
    from motivml.binding.encoding import SOLVER

    motivml = str(Path(sys.executable).with_name("motivml"))
    compile_motivml()
    print(
        f"{'features':>9} {'open selections':>15} {'open bindings':>13} {'floor s':>8} {'MiB':>5} | {'configure s':>11} {'ratio':>5}"
        f" {'peak MiB':>9} {'target':>6}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            folder = os.path.join(tmp, f"m{n}")
            _, config_path = write(n, args.seed, folder)
            with open(config_path) as handle:
                config, left_out, opened = open_decisions(json.load(handle), args.seed)
            with open(config_path, "w") as handle:
                json.dump(config, handle)
            cnf_path, assumptions_path = os.path.join(folder, "f.cnf"), os.path.join(folder, "a.txt")
            measured_stages(os.path.join(folder, "model.json"), config_path, cnf_path, assumptions_path)
            # configure (into a new folder each time: it writes every file) and the floor
            # alternated, --repeat times each: the medians, the larger peaks
            runs, floors = [], []
            for k in range(args.repeat):
                runs.append(run_measured([motivml, "configure", folder, "--variant", "full", "-o", f"{folder}/out{k}"]))
                assert any(line.startswith("variant full:") for line in runs[-1][2].splitlines()), runs[-1][2]
                floors.append(run_measured([sys.executable, "-c", FLOOR, cnf_path, assumptions_path, SOLVER]))
            wall, peak = statistics.median(r[0] for r in runs), max(r[1] for r in runs)
            floor_wall, floor_peak = statistics.median(f[0] for f in floors), max(f[1] for f in floors)
            ratio = wall / floor_wall
            print(
                f"{n:>9,} {left_out:>15,} {opened:>13,} {floor_wall:>8.2f} {floor_peak:>5} | {wall:>11.2f} {ratio:>5.1f}"
                f" {peak:>9} {verdict(ratio, None, TARGETS.get(n)):>6}",
                flush=True,
            )
    print("targets: (issue 3) 10,000 features under 2 s; (issue 14) at most 3x the floor at 100k")


if __name__ == "__main__":
    main()

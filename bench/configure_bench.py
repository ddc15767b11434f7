"""Benchmark: `motivml configure` on generated models with half the bindings left `Any`.

For n = 1,000, 10,000 and 100,000 features (generate.py) the valid full configuration has
each selected feature's time and mode replaced by `Any` with probability 1/2, so the
solver (MaxSAT, RC2) decides about half the bindings. Prints wall time and peak memory of
`motivml configure ROBOT --variant full -o OUT` in a fresh process.

    python bench/configure_bench.py [--sizes 1000 10000 100000]

Target (issue 3): 10,000 features under 2 s.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from generate import write  # noqa: E402
from validate_bench import run_measured  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10_000, 100_000])
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    motivml = str(Path(sys.executable).with_name("motivml"))
    print(f"{'features':>9} {'open bindings':>13} {'configure s':>11} {'peak MiB':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            folder = os.path.join(tmp, f"m{n}")
            _, config_path = write(n, args.seed, folder)
            with open(config_path) as handle:
                config = json.load(handle)
            rng = random.Random(args.seed)
            opened = 0
            for entry in config["properties"]:
                for key in ("time", "mode"):
                    if "props" in entry and rng.random() < 0.5:
                        entry["props"][key] = "Any"
                        opened += 1
            with open(config_path, "w") as handle:
                json.dump(config, handle)
            wall, peak, output = run_measured(
                [motivml, "configure", folder, "--variant", "full", "-o", f"{folder}/out"]
            )
            assert output.startswith("variant full:"), output
            print(f"{n:>9,} {opened:>13,} {wall:>11.2f} {peak:>9}", flush=True)


if __name__ == "__main__":
    main()

"""Benchmark: the size of `motivml sample --t 2` on every public model of bench/models,
beside a plain AETG-style greedy (greedy.py) and the published YASA/IncLing sizes where
there are some, measured in the same run (issue 33: at most 1.1x the best of them).

For each model it imports the shipped file (`motivml import`, which tells FeatureIDE XML
from S.P.L.O.T.'s SXFM), samples it as a user would (`motivml sample MODEL --t 2`, its
defaults: up to 10 orders of the features, none started after 20 s; the seed given), writes
its CNF (`motivml export dimacs`) and runs the greedy on it, which checks every variant of its
sample valid by a solve. Printed per model: motivml's size and time, the greedy's size and
time (or that it did not end within --baseline-timeout), the published sizes, and the ratio
of motivml's size to the best of the others with the verdict.

    python bench/sample_bench.py [--only xtext] [--seed 1] [--baseline-timeout 600] [--candidates 10] [--runs 10]

The models (models/README.md says where each comes from, and its licence): RouteFinding and
Xtext (SXFM, 103 and 137 features), TankWar (144), BusyBox 1.18.0 (854), FinancialServices01
(771), eCos 3.0 i386pc (1,245; the model YASA's and IncLing's sizes were published for) and
Automotive01 (2,513).
"""

from __future__ import annotations

import argparse
import lzma
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from analyse_bench import BEST_TARGET, PUBLISHED_ECOS  # noqa: E402
from greedy import all_valid, baseline, read_dimacs  # noqa: E402

MODELS = Path(__file__).resolve().parent / "models"
# file -> (name, published t=2 sizes on this very model)
PUBLIC = {
    "routefinding.sxfm.xml.xz": ("RouteFinding", {}),
    "xtext.sxfm.xml.xz": ("Xtext", {}),
    "tankwar.xml.xz": ("TankWar", {}),
    "busybox-1.18.0.xml.xz": ("BusyBox 1.18.0", {}),
    "financial-services-01-2018-05-09.xml.xz": ("FinancialServices01", {}),
    "ecos-3.0-i386pc.xml.xz": ("eCos 3.0 i386pc", PUBLISHED_ECOS),
    "automotive01.xml.xz": ("Automotive01", {}),
}


def run(*args: str, timeout: float = 3600.0) -> str:
    done = subprocess.run(args, capture_output=True, text=True, timeout=timeout, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(args)}: exit {done.returncode}: {done.stderr.strip() or done.stdout.strip()}")
    return done.stdout


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="only the models whose name holds this")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--baseline-timeout", type=float, default=600.0)
    parser.add_argument("--candidates", type=int, default=10, help="the greedy's candidates per variant (AETG's M)")
    parser.add_argument(
        "--runs", type=int, default=10, help="the greedy's runs, seeded apart (the smallest is kept: as sample's ten tries)"
    )
    args = parser.parse_args()
    motivml = str(Path(sys.executable).with_name("motivml"))
    print(
        f"{'model':22} {'features':>8} | {'motivml':>7} {'s':>6} | {'greedy':>6} {'s':>6} | published"
        f" | ratio to the best (target {BEST_TARGET:g})"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for file, (name, published) in PUBLIC.items():
            if args.only and args.only.lower() not in name.lower():
                continue
            folder = Path(tmp) / file.split(".")[0]
            source = folder.with_suffix(".xml")
            source.write_bytes(lzma.decompress((MODELS / file).read_bytes()))
            run(motivml, "import", str(source), "-o", str(folder))
            began = time.monotonic()
            said = run(motivml, "sample", str(folder), "--t", "2", "--seed", str(args.seed), "-o", str(folder / "sample"))
            ours_s = time.monotonic() - began
            found = re.search(r"(\d[\d,]*) variants? cover", said)
            if found is None:
                raise RuntimeError(f"motivml sample said: {said}")
            ours = int(found.group(1).replace(",", ""))
            dimacs = folder / "model.dimacs"
            run(motivml, "export", "dimacs", str(folder), "-o", str(dimacs))
            greedy = baseline(dimacs, args.seed, args.candidates, args.baseline_timeout, args.runs)
            features = len(read_dimacs(dimacs)[2])
            if greedy["sample"] is not None:
                _, clauses, _ = read_dimacs(dimacs)
                if not all_valid(clauses, greedy["sample"]):
                    raise RuntimeError(f"{name}: the greedy's sample has an invalid variant")
            others = dict(published)
            if greedy["size"] is not None:
                others["greedy"] = greedy["size"]
            best_name, best = min(others.items(), key=lambda item: item[1]) if others else ("", None)
            greedy_text = f"{greedy['size']:>6} {greedy['seconds']:6.1f}" if greedy["size"] is not None else (
                f"{'none':>6} {'>' + format(args.baseline_timeout, 'g'):>6}"
            )
            shown = ", ".join(f"{k} {v}" for k, v in published.items()) or "-"
            if best is None:
                verdict = "no other size to compare"
            else:
                ratio = ours / best
                verdict = f"{ratio:.2f} ({best_name} {best}): {'met' if ratio <= BEST_TARGET else 'MISSED'}"
            print(f"{name:22} {features:8,} | {ours:7} {ours_s:6.1f} | {greedy_text} | {shown} | {verdict}", flush=True)


if __name__ == "__main__":
    main()

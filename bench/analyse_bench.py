"""Benchmark: `motivml analyse` on generated models, against the bare-SAT floor of issue 14.

For n = 1,000, 10,000 and 100,000 features (generate.py) it prints, each in a fresh process:

* the floor (validate_bench.py's): the model's CNF read from a DIMACS file by pysat and
  solved once under a full configuration's assumptions, with its peak memory;
* `motivml analyse MODEL --no-counts --format json` (core, dead and false-optional
  features, atomic sets, impossible bindings): wall time, ratio to the floor, peak memory.
  Up to 10,000 features both are the medians of --repeat (5) runs, alternated;
* `motivml analyse MODEL` with the exact counts, at the sizes given to --count-sizes
  (default 1,000 only: exact counting of these models is exponential in their treewidth;
  at 3,000 features the selection count does not finish in minutes);
* `motivml sample MODEL --t 2`: its size, time and peak memory, at --sample-sizes (1,000),
  beside the published t=2 sizes of YASA and IncLing for the real model nearest in size
  (PUBLISHED, busybox: a different model, for scale);
* `motivml sample` of Automotive01 (2,513 features, shipped in models/): time and peak
  memory against issue 33's target (60 s, 500 MiB);
* `motivml sample` of eCos 3.0 i386pc (1,245 features), the very model YASA and IncLing
  were published for (PUBLISHED_ECOS): `motivml import featureide` reads the benchmark's
  FeatureIDE XML whole; the ratio to each published size and issue 15's 1.5x target, and
  to the best of them and issue 33's 1.1x target (`sample`'s defaults: up to 10 orders).

A run that does not finish within --timeout seconds is printed as such.

    python bench/analyse_bench.py [--sizes 1000 10000 100000] [--repeat 5] [--timeout 900] [--ecos XML | --no-ecos]

Targets (issue 15): analyse within 10x the floor at 10k; t=2 sample sizes within 1.5x of the
published YASA and IncLing ones on a model of the same size, judged on eCos, the same model
(printed met/MISSED). The eCos model is shipped as models/ecos-3.0-i386pc.xml.xz: the
benchmark's feature_models/original/systems_software/eCos/AlHajjaji2019-i386pc.xml
(SoftVarE-Group/feature-model-benchmark, MIT; from zahrakhoshmanesh/FIDUS, MIT), byte for
byte, compressed; models/README.md has its provenance and licence notices.
"""

from __future__ import annotations

import argparse
import json
import lzma
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from generate import write  # noqa: E402
from validate_bench import FLOOR, child_env, compile_motivml, measured_stages, run_measured  # noqa: E402

TARGETS = {10_000: 10.0}  # issue 15: analyse / floor
SAMPLE_TARGET = 1.5  # issue 15: our t=2 sample size / the published one
BEST_TARGET = 1.1  # issue 33: our t=2 sample size / the best published one on the same model
# Published t=2 sample sizes for the real model nearest to 1,000 features: busybox-1_29_2,
# 1,018 features, 997 CNF clauses; the median of 5 runs each, from the baseline that the
# SampLNS evaluation (Krupke, Krieter, Thuem et al.) ran with FeatureIDE's YASA (one
# iteration, m=1, and its best, ten, m=10) and IncLing: GitHub tubs-alg/SampLNS, commit 7741515,
# evaluation/2024-03-05/00_baseline/OUTPUT/baseline_results.json.xz.
PUBLISHED_MODEL = "busybox-1_29_2 (1,018 features, 997 clauses)"
PUBLISHED_SOURCE = (
    "tubs-alg/SampLNS@7741515 evaluation/2024-03-05/00_baseline/OUTPUT/baseline_results.json.xz"
)
PUBLISHED = {"YASA (m=1)": 44, "YASA (m=10)": 37, "IncLing": 77}
# The same baseline on eCos-3-0_i386pc (1,245 features, 3,723 clauses), shipped as ECOS: the
# same model, not only the same size.
PUBLISHED_ECOS = {"YASA (m=1)": 77, "YASA (m=10)": 66, "IncLing": 89}
ECOS = Path(__file__).resolve().parent / "models" / "ecos-3.0-i386pc.xml.xz"
AUTOMOTIVE01 = Path(__file__).resolve().parent / "models" / "automotive01.xml.xz"


def run_limited(args: list[str], timeout: float, ok: tuple[int, ...] = (0,)) -> tuple[float, int, str] | None:
    """Wall seconds, peak RSS in MiB and stdout of a child; None if it ran out of time.
    An exit code not in `ok` ends the benchmark."""
    start = time.perf_counter()
    child = subprocess.Popen(
        args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=child_env()
    )
    timer = threading.Timer(timeout, child.kill)
    timer.start()
    assert child.stdout is not None
    output = child.stdout.read()
    _, status, usage = os.wait4(child.pid, 0)
    timer.cancel()
    wall = time.perf_counter() - start
    code = os.waitstatus_to_exitcode(status)
    if code == -9 and wall >= timeout:
        return None
    if code not in ok:
        raise SystemExit(f"{' '.join(args)} failed ({code}):\n{output}")
    return wall, usage.ru_maxrss // 1024, output


def compare(output: str, published: dict[str, int], on: str, indent: str, judged: bool = True) -> None:
    """The size `motivml sample` printed beside each published size: ratio, and the verdict
    where the published size is for the same model (`judged`)."""
    size = int(output.split()[0])
    for name, theirs in published.items():
        ratio = size / theirs
        if judged:
            verdict = f"(target {SAMPLE_TARGET:g}) {'met' if ratio <= SAMPLE_TARGET else 'MISSED'}"
        else:
            verdict = "(another model: for scale, not judged)"
        print(f"{indent}vs {name} {theirs} {on}: ratio {ratio:.2f} {verdict}")
    print(f"{indent}(published sizes: {PUBLISHED_SOURCE})", flush=True)


def sample_of(motivml: str, xml: str | None, shipped: Path, timeout: float) -> tuple[float, int, str] | None:
    """`motivml sample --t 2` of a FeatureIDE model (`xml`, or the shipped .xml.xz), imported
    first: wall seconds, peak MiB and output, or None if it ran out of time."""
    with tempfile.TemporaryDirectory() as tmp:
        if xml is None:
            xml = os.path.join(tmp, shipped.name.removesuffix(".xz"))
            with open(xml, "wb") as out:
                out.write(lzma.decompress(shipped.read_bytes()))
        robot = os.path.join(tmp, "robot")
        run_measured([motivml, "import", "featureide", xml, "-o", robot])
        return run_limited([motivml, "sample", robot, "--t", "2", "-o", os.path.join(tmp, "out")], timeout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[1000, 10_000, 100_000])
    parser.add_argument("--count-sizes", type=int, nargs="*", default=[1000])
    parser.add_argument("--sample-sizes", type=int, nargs="*", default=[1000])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--timeout", type=float, default=900.0)
    parser.add_argument(
        "--repeat", type=int, default=5, help="runs of analyse and of the floor up to 10,000 features (medians)"
    )
    parser.add_argument(
        "--ecos",
        metavar="XML",
        help="the eCos 3.0 i386pc FeatureIDE XML to sample (default: the shipped models/ecos-3.0-i386pc.xml.xz)",
    )
    parser.add_argument("--no-ecos", action="store_true", help="do not sample eCos")
    parser.add_argument("--no-automotive", action="store_true", help="do not sample Automotive01 (2,513 features)")
    args = parser.parse_args()
    if args.repeat < 1:
        parser.error("--repeat must be at least 1")
    from motivml.binding.encoding import SOLVER

    motivml = str(Path(sys.executable).with_name("motivml"))
    compile_motivml()
    print(f"solver {SOLVER}; python {sys.version.split()[0]}; {os.cpu_count()} cores")
    print(
        f"{'features':>9} {'floor s':>8} {'MiB':>5} | {'analyse s':>9} {'ratio':>6} {'MiB':>5} {'target':>6}"
        f" | core dead f-opt atomic impossible | {'with counts s':>13}  selections / variants (digits)"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            folder = os.path.join(tmp, f"m{n}")
            model_path, config_path = write(n, args.seed, folder)
            cnf_path, assumptions_path = os.path.join(folder, "f.cnf"), os.path.join(folder, "a.txt")
            measured_stages(model_path, config_path, cnf_path, assumptions_path)
            # the floor and analyse alternated, --repeat times each up to 10,000 features
            # (a run of a second varies by a tenth, the floor's by half of itself): medians
            floors, runs = [], []
            for _ in range(args.repeat if n <= 10_000 else 1):
                floors.append(run_measured([sys.executable, "-c", FLOOR, cnf_path, assumptions_path, SOLVER]))
                runs.append(
                    run_limited([motivml, "analyse", model_path, "--no-counts", "--format", "json"], args.timeout)
                )
                if runs[-1] is None:  # (out of time: so would the next ones be)
                    break
            floor_wall, floor_peak = statistics.median(f[0] for f in floors), max(f[1] for f in floors)
            measured = None
            if all(r is not None for r in runs):
                finished = [r for r in runs if r is not None]
                measured = (
                    statistics.median(r[0] for r in finished),
                    max(r[1] for r in finished),
                    finished[0][2],
                )
            row = f"{n:>9,} {floor_wall:>8.2f} {floor_peak:>5} | "
            if measured is None:
                row += f"{'did not finish in ' + format(args.timeout, 'g') + ' s':>29} | {'':>33} |"
            else:
                wall, peak, output = measured
                found = json.loads(output)
                target = TARGETS.get(n)
                verdict = "-" if target is None else ("met" if wall / floor_wall <= target else "MISSED")
                sizes = [
                    len(found[k])
                    for k in ("core", "dead", "false_optional", "atomic_sets", "impossible_bindings")
                ]
                row += (
                    f"{wall:>9.2f} {wall / floor_wall:>6.1f} {peak:>5} {verdict:>6} | "
                    + " ".join(f"{k:>4}" for k in sizes)
                    + " |"
                )
            if n in args.count_sizes:
                counted = run_limited(
                    [
                        motivml,
                        "analyse",
                        model_path,
                        "--format",
                        "json",
                        "--count-timeout",
                        str(args.timeout),
                    ],
                    2 * args.timeout + 60,
                )
                if counted is None:
                    row += " did not finish"
                else:
                    found = json.loads(counted[2])
                    digits = [
                        len(str(found[k])) if found[k] is not None else "-"
                        for k in ("selection_count", "variant_count")
                    ]
                    row += f" {counted[0]:>13.2f}  {digits[0]} / {digits[1]} digits"
            else:
                row += f" {'not run':>13}"
            print(row, flush=True)
            if n in args.sample_sizes:
                out = os.path.join(folder, "sample")
                sampled = run_limited([motivml, "sample", model_path, "--t", "2", "-o", out], args.timeout)
                if sampled is None:
                    print(f"{'':>9} t=2 sample: did not finish in {args.timeout:g} s", flush=True)
                else:
                    print(
                        f"{'':>9} t=2 sample: {sampled[2].splitlines()[0]}; {sampled[0]:.1f} s, {sampled[1]} MiB",
                        flush=True,
                    )
                    compare(sampled[2], PUBLISHED, f"on {PUBLISHED_MODEL}", " " * 12, judged=False)
    if not args.no_ecos:
        sampled = sample_of(motivml, args.ecos, ECOS, args.timeout)
        if sampled is None:
            print(f"eCos 3.0 i386pc t=2 sample: did not finish in {args.timeout:g} s")
        else:
            print(f"eCos 3.0 i386pc t=2 sample: {sampled[2].splitlines()[0]}; {sampled[0]:.1f} s, {sampled[1]} MiB")
            compare(sampled[2], PUBLISHED_ECOS, "on the same model", "  ")
            best = min(PUBLISHED_ECOS.values())  # issue 33: at most 1.1x the best published size
            ratio = int(sampled[2].split()[0]) / best
            print(f"  vs the best published, {best}: ratio {ratio:.2f} (target, issue 33: {BEST_TARGET:g}) "
                  f"{'met' if ratio <= BEST_TARGET else 'MISSED'}")
    if not args.no_automotive:  # issue 33: a 2,500-feature industrial model in at most 60 s and 500 MB
        sampled = sample_of(motivml, None, AUTOMOTIVE01, args.timeout)
        if sampled is None:
            print(f"Automotive01 t=2 sample: did not finish in {args.timeout:g} s (target 60 s, 500 MiB)")
        else:
            met = sampled[0] <= 60 and sampled[1] <= 500
            print(
                f"Automotive01 t=2 sample: {sampled[2].splitlines()[0]}; {sampled[0]:.1f} s, {sampled[1]} MiB "
                f"(target, issue 33: at most 60 s and 500 MiB): {'met' if met else 'MISSED'}"
            )
    print(
        "target (issue 15): analyse (without counts) at most 10x the floor at 10k; t=2 sample sizes "
        "within 1.5x of YASA's or IncLing's published ones on a model of the same size: eCos, the very "
        "model they were published for (busybox, a different model of the generated one's size, for scale)"
    )


if __name__ == "__main__":
    main()

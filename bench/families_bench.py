"""Benchmark: `validate MODEL` and `analyse --no-counts` on every family of shapes and on
public real models, each beside its floor measured in the same run (issue 32).

For each family of families.py (deep chains, flat trees, many small groups, wide groups,
dense cross-tree constraints, formulas, mostly-`Any` and mostly-fixed bindings) at each
size (default 1,000, 10,000 and 100,000 features), for one XOR group of 10,000 members
(xor_bench.py's model), and for the public models shipped in models/ (README.md there
says where each comes from and its licence), it prints, each in a fresh process:

* the floor: the model's CNF (the encoding's hard build, as analyse solves it) read from a
  DIMACS file by pysat and solved once, and its peak memory;
* `motivml validate MODEL` and `motivml analyse MODEL --no-counts --format json`: wall
  time, ratio to the floor, peak memory, and the verdict against issue 32's targets;
* the work of the analysis in solver calls (in-process, a run of its own);
* `show --config` and `show --config --why` beside `validate --config` of the same
  complete configuration, for generate.py's model at 10,000 features and for the XOR
  group of 10,000 members (its first member selected);
* with `--flamapy`, flamapy (its PySAT plugin: core, dead and false-optional features,
  atomic sets) on each public model, in a venv of the bench's own (build/bench-flamapy,
  made with pip on first use; flamapy is GPL-3.0 and runs there only, nothing of it is in
  motivml), reading the model as `motivml export uvl` writes it (flamapy's FeatureIDE
  reader refuses these files): its wall time beside analyse's, and the ratio.

Targets (issue 32): validate MODEL and analyse --no-counts at most 5x the floor at 10k and
10x at 100k on every family; the 10,000-member XOR group at most 10x; every public model
analysed in at most 2 s and at least 10x faster than flamapy where flamapy finishes; peak
memory at most 2x the floor's at 100k; show --variant and show --why at 10k at most 3x
validate --config. A run that does not
finish within --timeout seconds is printed as such (and is a MISSED).

    python bench/families_bench.py [--sizes 1000 10000 100000] [--families deep wide ...] [--no-real]
                                   [--flamapy] [--timeout 300]
"""

from __future__ import annotations

import argparse
import json
import lzma
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from analyse_bench import run_limited  # noqa: E402
from families import FAMILIES  # noqa: E402
from families import write as write_family  # noqa: E402
from validate_bench import FLOOR, compile_motivml, run_measured  # noqa: E402

TARGETS = {1_000: None, 10_000: 5.0, 100_000: 10.0}  # analyses / floor, by size
XOR_TARGET = 10.0  # one XOR group of 10,000 members
REAL_TARGET = 2.0  # seconds, analyse --no-counts of a public model
MEMORY_TARGET = 2.0  # peak memory / the floor's, at 100k
MODELS = Path(__file__).resolve().parent / "models"
# the public models (FeatureIDE XML, xz-compressed): file -> name printed
REAL = {
    "busybox-1.18.0.xml.xz": "BusyBox 1.18.0",
    "financial-services-01-2018-05-09.xml.xz": "FinancialServices01",
    "ecos-3.0-i386pc.xml.xz": "eCos 3.0 i386pc",
    "automotive01.xml.xz": "Automotive01",
    "automotive02-v1.xml.xz": "Automotive02 (v1)",
}

CNF_OF = """
import sys
from motivml.binding import encoding as enc
from motivml.documents.loader import load_file
from motivml.language.reader import read_model
model, _ = read_model(load_file(sys.argv[1]))
with enc.Encoding(model, record=True) as hard:
    clauses = hard.recorded
    top = max(abs(lit) for clause in clauses for lit in clause)
    with open(sys.argv[2], "w") as out:
        out.write(f"p cnf {top} {len(clauses)}\\n")
        out.writelines(" ".join(map(str, clause)) + " 0\\n" for clause in clauses)
open(sys.argv[3], "w").close()
print(len(model.features))
"""

WORK = """
import json, sys
from motivml.binding import encoding as enc
from motivml.binding.analysis import analyse
from motivml.documents.loader import load_file
from motivml.language.reader import read_model
model, _ = read_model(load_file(sys.argv[1]))
done = []
close = enc.Encoding.close
def counted(self):
    done.append(self.work.solves)
    close(self)
enc.Encoding.close = counted
analyse(model, counts=False)
print(sum(done))
"""


FLAMAPY = """
import json, sys, time
start = time.perf_counter()
from flamapy.interfaces.python.flamapy_feature_model import FLAMAFeatureModel
model = FLAMAFeatureModel(sys.argv[1])
found = {}
for operation in ("core_features", "dead_features", "false_optional_features", "atomic_sets"):
    found[operation] = len(getattr(model, operation)())
print(json.dumps(found))
"""
FLAMAPY_VENV = Path(__file__).resolve().parent.parent / "build" / "bench-flamapy"
FLAMAPY_TARGET = 10.0  # flamapy's time / analyse's


def flamapy_python() -> str:
    """The bench's own venv with flamapy (made on first use)."""
    python = FLAMAPY_VENV / "bin" / "python"
    if not python.exists():
        import subprocess

        subprocess.run([sys.executable, "-m", "venv", str(FLAMAPY_VENV)], check=True)
        subprocess.run([str(python), "-m", "pip", "install", "--quiet", "flamapy"], check=True)
    return str(python)


def flamapy_row(label: str, robot: str, folder: str, timeout: float, ours: float | None) -> None:
    motivml = str(Path(sys.executable).with_name("motivml"))
    uvl = os.path.join(folder, "model.uvl")
    run_measured([motivml, "export", "uvl", robot, "-o", uvl])
    measured = run_limited([flamapy_python(), "-c", FLAMAPY, uvl], timeout)
    if measured is None:
        print(f"  flamapy on {label}: did not finish in {timeout:g} s", flush=True)
        return
    wall, peak, output = measured
    found = json.loads(output.strip().splitlines()[-1])
    ratio = "-" if ours is None else f"{wall / ours:.1f}x analyse's time"
    met = ours is not None and wall / ours >= FLAMAPY_TARGET
    print(
        f"  flamapy on {label}: {wall:.2f} s, {peak} MiB ({ratio}; target {FLAMAPY_TARGET:g}x:"
        f" {'met' if met else 'MISSED'}); core {found['core_features']}, dead {found['dead_features']},"
        f" false-optional {found['false_optional_features']}, atomic sets {found['atomic_sets']}",
        flush=True,
    )


SHOW_TARGET = 3.0  # show (and show --why) / validate --config, at 10k


def show_rows(tmp: str, timeout: float) -> None:
    """show and show --why of a complete configuration beside validate --config of it."""
    from generate import write as write_generated
    from xor_bench import model as xor_model

    motivml = str(Path(sys.executable).with_name("motivml"))
    generated = write_generated(10_000, 1, os.path.join(tmp, "show-generated"))
    xor_folder = os.path.join(tmp, "show-xor")
    os.makedirs(xor_folder)
    xor_path, xor_config = os.path.join(xor_folder, "model.json"), os.path.join(xor_folder, "config.json")
    Path(xor_path).write_text(json.dumps(xor_model(10_000)))
    entries = [{"id": f"m{i}", "selected": i == 0} for i in range(10_000)]
    Path(xor_config).write_text(json.dumps({"properties": entries}))
    for label, (model_path, config_path), why in (
        ("generated 10,000, full variant", generated, "f5000"),
        ("XOR group of 10,000, first member", (xor_path, xor_config), "m5000"),
    ):
        check = run_limited([motivml, "validate", model_path, "--config", config_path], timeout)
        cells = []
        for extra in ([], ["--why", why]):
            shown = run_limited([motivml, "show", model_path, "--config", config_path, *extra], timeout)
            if check is None or shown is None:
                cells.append(f"show{' --why' if extra else ''}: did not finish in {timeout:g} s MISSED")
                continue
            ratio = shown[0] / check[0]
            cells.append(
                f"show{' --why' if extra else ''} {shown[0]:.2f} s ({ratio:.1f}x,"
                f" target {SHOW_TARGET:g}x {'met' if ratio <= SHOW_TARGET else 'MISSED'})"
            )
        base = "-" if check is None else f"{check[0]:.2f} s"
        print(f"{label}: validate --config {base}; " + "; ".join(cells), flush=True)


def verdict(ratio: float | None, target: float | None, memory: float | None = None) -> str:
    if target is None:
        return "-"
    if ratio is None:
        return "MISSED"
    return "met" if ratio <= target and (memory is None or memory <= MEMORY_TARGET) else "MISSED"


def row(
    label: str,
    model_path: str,
    folder: str,
    timeout: float,
    target: float | None,
    memory: bool,
    seconds: float | None = None,
) -> float | None:
    """One model's line (and analyse's wall time). `target`: the ratio to the floor both commands must keep;
    `memory`: their peak memory is judged too; `seconds`: analyse's own time limit."""
    motivml = str(Path(sys.executable).with_name("motivml"))
    cnf, assumptions = os.path.join(folder, "f.cnf"), os.path.join(folder, "a.txt")
    _, _, features = run_measured([sys.executable, "-c", CNF_OF, model_path, cnf, assumptions])
    floor, floor_peak, _ = run_measured([sys.executable, "-c", FLOOR, cnf, assumptions, "glucose4"])
    cells, analysed = [], None
    for command, args in (("validate", [model_path]), ("analyse", [model_path, "--no-counts", "--format", "json"])):
        measured = run_limited([motivml, command, *args], timeout, ok=(0, 1))  # (1: warnings)
        judged = target if seconds is None or command != "analyse" else seconds
        if measured is None:
            cells.append(f"{'> ' + format(timeout, 'g') + ' s':>9} {'':>6} {'':>5} {verdict(None, judged):>6}")
            continue
        wall, peak, output = measured
        ratio = wall / floor
        if command == "analyse":
            analysed = wall
            found = json.loads(output)
            detail = "core {} dead {} f-opt {} atomic {} impossible {}".format(
                *(len(found[k]) for k in ("core", "dead", "false_optional", "atomic_sets", "impossible_bindings"))
            )
        if seconds is not None and command == "analyse":
            judgement = "met" if wall <= seconds else "MISSED"
        else:
            judgement = verdict(ratio, target, peak / floor_peak if memory else None)
        cells.append(f"{wall:>9.2f} {ratio:>6.1f} {peak:>5} {judgement:>6}")
    work = run_limited([sys.executable, "-c", WORK, model_path], timeout)
    solves = work[2].strip() if work is not None else "-"
    print(
        f"{label:<28} {int(features):>7,} {floor:>7.2f} {floor_peak:>5} | " + " | ".join(cells) + f" | {solves:>7}"
        + (f" | {detail}" if analysed is not None else ""),
        flush=True,
    )
    return analysed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[1000, 10_000, 100_000])
    parser.add_argument("--families", nargs="*", default=list(FAMILIES), choices=FAMILIES)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--timeout", type=float, default=300.0)
    parser.add_argument("--no-xor", action="store_true", help="leave out the 10,000-member XOR group")
    parser.add_argument("--no-real", action="store_true", help="leave out the public models")
    parser.add_argument("--flamapy", action="store_true", help="run flamapy on the public models too")
    parser.add_argument("--no-show", action="store_true", help="leave out show beside validate --config")
    args = parser.parse_args()
    compile_motivml()
    motivml = str(Path(sys.executable).with_name("motivml"))
    print(f"python {sys.version.split()[0]}; {os.cpu_count()} cores; solver glucose4")
    print(
        f"{'model':<28} {'features':>7} {'floor s':>7} {'MiB':>5} | {'validate':>9} {'ratio':>6} {'MiB':>5} {'target':>6}"
        f" | {'analyse':>9} {'ratio':>6} {'MiB':>5} {'target':>6} | {'solves':>7} | what analyse found"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.families:
            for n in args.sizes:
                folder = os.path.join(tmp, f"{name}{n}")
                path = write_family(name, n, args.seed, folder)
                row(f"{name} {n:,}", path, folder, args.timeout, TARGETS.get(n), n >= 100_000)
        if not args.no_xor:
            from xor_bench import model as xor_model

            folder = os.path.join(tmp, "xor")
            os.makedirs(folder)
            path = os.path.join(folder, "model.json")
            Path(path).write_text(json.dumps(xor_model(10_000)))
            row("one XOR group of 10,000", path, folder, args.timeout, XOR_TARGET, False)
        if not args.no_show:
            show_rows(tmp, args.timeout)
        if not args.no_real:
            for file, label in REAL.items():
                folder = os.path.join(tmp, file.split(".")[0])
                os.makedirs(folder)
                xml = os.path.join(folder, "model.xml")
                Path(xml).write_bytes(lzma.decompress((MODELS / file).read_bytes()))
                robot = os.path.join(folder, "robot")
                run_measured([motivml, "import", "featureide", xml, "-o", robot])
                ours = row(label, os.path.join(robot, "model.json"), folder, args.timeout, None, False, REAL_TARGET)
                if args.flamapy:
                    flamapy_row(label, robot, folder, args.timeout, ours)
    print(
        "targets (issue 32): validate MODEL and analyse --no-counts at most 5x the floor at 10k and 10x at"
        " 100k (peak memory at most 2x the floor's) on every family; one XOR group of 10,000 members at most"
        " 10x; every public model analysed in at most 2 s (its analyse target column)"
    )


if __name__ == "__main__":
    main()

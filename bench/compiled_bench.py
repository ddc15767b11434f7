"""Benchmark: compiled forms (issue 36) on the public models of models/, beside Ganak in the
same run.

For each public model (README.md there says where each comes from and its licence), imported
with `motivml import featureide` into a scratch folder:

* Ganak: the selection count and the variant count, each in a fresh process (`analyse
  --no-compiled`'s path), timed, with --timeout;
* `motivml compile --limit LIMIT`: each form's compile time (the issue's "compile finishes
  within 60 s"), and its count checked against Ganak's where both finished;
* a count under a partial configuration from a kept form: 200 random partial
  configurations (1 to 10 features decided each way), in one process after loading the
  form; p95 and maximum beside the 50 ms target;
* `analyse` with counts three times in fresh processes: as today (`--no-compiled`, Ganak),
  a first run that makes the forms, and a second run that reads them; the second beside
  today's, against the 10x target.

Targets (issue 36), on every public model whose compile finishes within 60 s: a count under
any partial configuration in at most 50 ms after the compile; the whole `analyse` at least
10x faster than today's on the second run; `menuconfig`'s live count within the 100 ms
key-press budget at 2,500 features (the count after each of 200 random decisions, timed in
the configurator as menuconfig asks it; the propagation's own time is bench/menuconfig_bench.py's).

    python bench/compiled_bench.py [--limit 60] [--timeout 300] [--models busybox ...]
"""

from __future__ import annotations

import argparse
import json
import lzma
import os
import random
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from analyse_bench import run_limited  # noqa: E402
from families_bench import MODELS, REAL  # noqa: E402
from validate_bench import run_measured  # noqa: E402

COUNT_TARGET = 0.050  # seconds: a count under a partial configuration
ANALYSE_TARGET = 10.0  # today's analyse / the second run's
PARTIAL = 200  # partial configurations counted per model
LIVE_TARGET = 0.100  # seconds: menuconfig's live count after a decision (the key-press budget)

GANAK = """
import sys, time
from motivml.binding.analysis import count_selections, count_variants
from motivml.language.reader import load_model
model, _ = load_model(sys.argv[1])
for count in (count_selections, count_variants):
    start = time.perf_counter()
    value = count(model, float(sys.argv[2]))
    print(count.__name__, value, time.perf_counter() - start, flush=True)
"""

LIVE = """
import json, random, sys, time
from pathlib import Path
from motivml.binding.compiled import Kind, NotCompiled, compiled_form
from motivml.binding.configurator import Configurator
from motivml.language.reader import load_model
model, _ = load_model(sys.argv[1])
form = compiled_form(model, Path(sys.argv[1]).parent, Kind.VARIANTS, make=False)
if isinstance(form, NotCompiled):
    form = compiled_form(model, Path(sys.argv[1]).parent, Kind.SELECTIONS, make=False)
if isinstance(form, NotCompiled):
    print(json.dumps({"missing": form.reason}))
    raise SystemExit
session = Configurator(model, "decisions.json")
session.form = form
rng = random.Random(2)
times = []
for _ in range(int(sys.argv[2])):
    f = model.features[rng.randrange(1, len(model.features))]
    session.select(f.id, rng.choice((True, False)))  # (propagates, and counts)
    if not session.valid:
        session.clear(f.id)
    start = time.perf_counter()
    session._counted(session.config)
    times.append(time.perf_counter() - start)
times.sort()
print(json.dumps({"kind": str(form.kind), "p95": times[int(0.95 * len(times)) - 1], "max": times[-1]}))
"""

PARTIALS = """
import json, random, sys, time
from pathlib import Path
from motivml.binding.compiled import Kind, NotCompiled, compiled_form
from motivml.language.reader import load_model
model, _ = load_model(sys.argv[1])
for kind in (Kind.SELECTIONS, Kind.VARIANTS):
    form = compiled_form(model, Path(sys.argv[1]).parent, kind, make=False)
    if isinstance(form, NotCompiled):
        print(json.dumps({"kind": str(kind), "missing": form.reason}), flush=True)
        continue
    rng = random.Random(1)
    n = len(model.features)
    times = []
    for _ in range(int(sys.argv[2])):
        decided = rng.sample(range(n), rng.randint(1, min(10, n)))
        assumed = [form.literal(i) * rng.choice((1, -1)) for i in decided]
        start = time.perf_counter()
        form.count(assumed)
        times.append(time.perf_counter() - start)
    times.sort()
    print(json.dumps({"kind": str(kind), "p95": times[int(0.95 * len(times)) - 1], "max": times[-1]}), flush=True)
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=float, default=60.0, help="compile limit, seconds")
    parser.add_argument("--timeout", type=float, default=300.0, help="Ganak's time per count, and analyse's")
    parser.add_argument("--models", nargs="*", help="substrings of the public models' file names")
    args = parser.parse_args()
    motivml = str(Path(sys.executable).with_name("motivml"))
    print(f"python {sys.version.split()[0]}; {os.cpu_count()} cores; compile limit {args.limit:g} s", flush=True)
    with tempfile.TemporaryDirectory() as folder:
        for file, label in REAL.items():
            if args.models and not any(m in file for m in args.models):
                continue
            xml = os.path.join(folder, file.removesuffix(".xz"))
            Path(xml).write_bytes(lzma.decompress((MODELS / file).read_bytes()))
            robot = os.path.join(folder, file.split(".")[0])
            run_measured([motivml, "import", "featureide", xml, "-o", robot])
            model = os.path.join(robot, "model.json")
            row(label, motivml, model, args.limit, args.timeout)
    print(
        f"targets (issue 36), where the compile finishes within 60 s: a count under a partial configuration"
        f" within {COUNT_TARGET * 1000:g} ms; analyse's second run at least {ANALYSE_TARGET:g}x faster than today's"
        f" (Ganak); menuconfig's live count within the {LIVE_TARGET * 1000:g} ms key-press budget at 2,500 features"
    )


def row(label: str, motivml: str, model: str, limit: float, timeout: float) -> None:
    print(f"{label}:", flush=True)
    ganak: dict[str, tuple[int | None, float]] = {}
    measured = run_limited([sys.executable, "-c", GANAK, model, str(timeout)], 2 * timeout + 30)
    if measured is not None:
        for line in measured[2].splitlines():
            name, value, seconds = line.split()
            ganak[name] = (None if value == "None" else int(value), float(seconds))
    start = time.perf_counter()
    compiled = run_limited([motivml, "compile", model, "--limit", f"{limit:g}", "--format", "json"], 3 * limit + 60, ok=(0, 3))
    wall = time.perf_counter() - start
    forms = json.loads(compiled[2])["forms"] if compiled is not None else {}
    for kind, name in (("selections", "count_selections"), ("variants", "count_variants")):
        value, seconds = ganak.get(name, (None, float("nan")))
        by_ganak = f"Ganak {seconds:.2f} s" if value is not None else f"Ganak: not counted in {timeout:g} s"
        form = forms.get(kind, {"compiled": False, "reason": "compile did not answer"})
        if not form["compiled"]:
            print(f"  {kind}: not compiled ({form['reason']}); {by_ganak}", flush=True)
            continue
        same = "" if value is None else ("; counts equal" if form["count"] == value else "; COUNTS DIFFER")
        print(
            f"  {kind}: compiled in {form['seconds']:.2f} s ({form['nodes']:,} nodes); {by_ganak}{same}",
            flush=True,
        )
    print(f"  (motivml compile took {wall:.2f} s in all)", flush=True)
    partial = run_limited([sys.executable, "-c", PARTIALS, model, str(PARTIAL)], timeout)
    for line in (partial[2].splitlines() if partial is not None else []):
        found = json.loads(line)
        if "missing" in found:
            continue
        met = "met" if found["p95"] <= COUNT_TARGET and found["max"] <= COUNT_TARGET else "MISSED"
        print(
            f"  count under a partial configuration ({found['kind']}, {PARTIAL}): p95 {found['p95'] * 1000:.2f} ms,"
            f" max {found['max'] * 1000:.2f} ms (target {COUNT_TARGET * 1000:g} ms: {met})",
            flush=True,
        )
    live = run_limited([sys.executable, "-c", LIVE, model, str(PARTIAL)], 4 * timeout)
    found = json.loads(live[2].splitlines()[-1]) if live is not None and live[2].strip() else {}
    if not found:
        print(f"  menuconfig's live count: {PARTIAL} decisions did not finish in {4 * timeout:g} s", flush=True)
    elif "missing" in found:
        print(f"  menuconfig's live count: no compiled form ({found['missing']})", flush=True)
    else:
        met = "met" if found["p95"] <= LIVE_TARGET else "MISSED"
        print(
            f"  menuconfig's live count after a decision ({found['kind']}, {PARTIAL} decisions): p95"
            f" {found['p95'] * 1000:.1f} ms, max {found['max'] * 1000:.1f} ms (the count's part of the"
            f" {LIVE_TARGET * 1000:g} ms key-press budget: {met})",
            flush=True,
        )
    today = run_limited([motivml, "analyse", model, "--no-compiled", "--count-timeout", f"{timeout:g}"], 3 * timeout)
    second = run_limited([motivml, "analyse", model, "--compile-limit", f"{limit:g}"], 3 * timeout)
    if today is None or second is None:
        print("  analyse: did not finish", flush=True)
        return
    ratio = today[0] / second[0]
    complete = all(form.get("compiled") for form in forms.values()) and len(forms) == 2
    verdict = ("met" if ratio >= ANALYSE_TARGET else "MISSED") if complete else "- (a form is not compiled)"
    print(
        f"  analyse with counts: today (Ganak) {today[0]:.2f} s; from the kept forms {second[0]:.2f} s"
        f" ({ratio:.1f}x faster; target {ANALYSE_TARGET:g}x: {verdict})",
        flush=True,
    )


if __name__ == "__main__":
    random.seed(0)
    main()

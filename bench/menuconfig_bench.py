"""Benchmark: how long menuconfig takes to propagate one decision (issue 33), on the public
models of bench/models and a generated model of 10,000 features.

For each model it makes DECISIONS random decisions one after another, as a person would in
`motivml menuconfig` (select or deselect a feature the decisions so far leave open; a
decision that leaves no valid variant is taken back), and measures `Configurator.propagate`:
what a key press waits for before the tree shows its consequences (on a model of
Propagation.LARGE features or more the key press itself is drawn at once, the
consequences when this is done). Printed beside it, measured in the same run on the same
decisions: the floor, one solve of the model's encoding under the decisions (the least a
propagation asks), and the targets (p95 at most 100 ms at 2,500 features, 300 ms at
10,000).

    python bench/menuconfig_bench.py [--decisions 200] [--only automotive01]
"""

from __future__ import annotations

import argparse
import json
import lzma
import random
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from generate import generate  # noqa: E402

MODELS = Path(__file__).resolve().parent / "models"
PUBLIC = {"financial-services-01-2018-05-09.xml.xz": "FinancialServices01", "automotive01.xml.xz": "Automotive01"}
TARGETS = {2_500: 0.100, 10_000: 0.300}  # p95, s, by model size (issue 33)


def _model(document: dict[str, object], folder: Path) -> object:
    from motivml.validate import validate

    (folder / "model.json").write_text(json.dumps(document))
    model = validate(folder / "model.json", [], partial=True, analyse=False).model.model
    assert model is not None
    return model


def measure(name: str, model: object, decisions: int, seed: int = 1) -> None:
    from motivml.binding.configurator import Choice, Configurator

    session = Configurator(model, "decisions.json")  # type: ignore[arg-type]
    rng = random.Random(seed)
    took: list[float] = []
    floor: list[float] = []
    for _ in range(decisions):
        open_ = [f.id for f in session.model.features[1:] if len(session.possible(f.id)) > 1]
        if not open_:
            break
        fid = rng.choice(open_)
        wanted = dict(session.decisions)
        wanted[fid] = Choice(rng.random() < 0.5)
        began = time.perf_counter()
        found = session.propagate(wanted)
        took.append(time.perf_counter() - began)
        kept = session._kept()  # (the floor: one solve of the same encoding under the same decisions)
        began = time.perf_counter()
        kept.set_configuration(found.config)
        kept.solve()
        floor.append(time.perf_counter() - began)
        if not found.problems:
            session.decisions = wanted
            session.install(found)
    size = len(session.model.features)
    target = next((t for n, t in sorted(TARGETS.items()) if size <= n * 1.2), None)
    p95 = statistics.quantiles(took, n=20)[-1] if len(took) >= 20 else max(took)
    p95_floor = statistics.quantiles(floor, n=20)[-1] if len(floor) >= 20 else max(floor)
    verdict = "" if target is None else f"  target {target * 1000:.0f} ms: {'met' if p95 <= target else 'missed'}"
    print(
        f"{name:28} {size:6,} features  {len(took):4} decisions  propagate p50 {statistics.median(took) * 1000:7.1f} ms"
        f"  p95 {p95 * 1000:7.1f} ms  floor p95 {p95_floor * 1000:6.2f} ms  ({p95 / p95_floor:,.0f}x){verdict}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--decisions", type=int, default=200)
    parser.add_argument("--only", help="measure only the models whose name holds this")
    args = parser.parse_args()
    from motivml.language.featureide import read_featureide

    with tempfile.TemporaryDirectory() as tmp:
        for file, name in PUBLIC.items():
            if args.only and args.only.lower() not in name.lower():
                continue
            folder = Path(tmp) / file.split(".")[0]
            folder.mkdir()
            document = read_featureide(lzma.decompress((MODELS / file).read_bytes()), file)
            measure(name, _model(document, folder), args.decisions)
        if not args.only or args.only.lower() in "generated":
            folder = Path(tmp) / "generated"
            folder.mkdir()
            document, _ = generate(10_000, 1)
            measure("generated (generate.py)", _model(document, folder), args.decisions)


if __name__ == "__main__":
    main()

"""Benchmark: how long menuconfig takes to answer one decision (issue 33), on the public
models of bench/models and a generated model of 10,000 features.

For each model it makes DECISIONS random decisions one after another, as a person would in
`motivml menuconfig` (select or deselect a feature the decisions so far leave open; a
decision that leaves no valid variant is taken back), and measures

* `Configurator.propagate`: the consequences of a decision, worked out in-process, beside
  its floor measured in the same run on the same decisions (one solve of an encoding of the
  model under the decisions: the least a propagation asks);
* the same kind of decisions made in menuconfig itself through Textual's pilot (headless):
  from the key press to the first frame drawn with the decision's consequences (on a
  model of Propagation.LARGE features or more the key press itself is drawn at once, the
  consequences when they are worked out off the UI thread). This is the target's measure.

Targets: p95 at most 100 ms at 2,500 features, 300 ms at 10,000.

    python bench/menuconfig_bench.py [--decisions 200] [--only automotive01] [--no-pilot] [--counts]
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
    from motivml.binding.encoding import Encoding

    session = Configurator(model, "decisions.json")  # type: ignore[arg-type]
    other = Encoding(model)  # type: ignore[arg-type]
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
        # the floor: one solve of an encoding of its own under the same decisions (not the
        # session's: a solve of it would change what its next propagation starts from)
        began = time.perf_counter()
        other.set_configuration(found.config)
        other.solve()
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


def measure_pilot(name: str, model: object, decisions: int, folder: Path, seed: int = 1, form: object = None) -> None:
    """The same kind of decisions made in menuconfig itself, headless through Textual's
    pilot: the cursor moved to a random open feature, then `y` or `n` pressed. Timed from
    the key press to the first frame Textual renders after the decision's consequences are
    drawn (its propagation runs off the UI thread on a model this large). A decision that
    leaves no valid variant is taken back with `u` (not timed). Without `form` the live
    counts, which would compile a form in the background, are left out; with a compiled
    form (made before, not timed), each decision also counts the variants left and every
    open feature's share of them, and the labels show the shares (issue 36's live counts)."""
    import asyncio

    from motivml.binding.configurator import Configurator
    from motivml.cli.menuconfig_app import FeatureTree, MenuConfigApp

    path = folder / "decisions.json"
    session = Configurator(model, str(path))  # type: ignore[arg-type]
    if form is not None:
        session.form = form
        session.refresh()
    app = MenuConfigApp(session, path)
    app.counts.start = lambda: None  # type: ignore[method-assign]
    rng = random.Random(seed)
    took: list[float] = []
    drawn_at: list[float] = []  # when the decision's consequences were drawn
    shown_at: list[float] = []  # when a frame was rendered after that
    redraw, display = app.redraw, app._display

    def timed_redraw() -> None:
        redraw()
        if not app.propagation.busy:
            drawn_at.append(time.perf_counter())

    def timed_display(screen: object, renderable: object) -> None:
        display(screen, renderable)  # type: ignore[arg-type]
        if renderable is not None and drawn_at and not shown_at:
            shown_at.append(time.perf_counter())

    app.redraw = timed_redraw  # type: ignore[method-assign]
    app._display = timed_display  # type: ignore[method-assign]

    async def play() -> None:
        async with app.run_test(size=(120, 40)) as pilot:
            await pilot.pause()
            tree = app.query_one(FeatureTree)
            for _ in range(decisions):
                open_ = [f.id for f in session.model.features[1:] if len(session.possible(f.id)) > 1]
                if not open_:
                    break
                tree.move_cursor(app.nodes[rng.choice(open_)])
                await pilot.pause()
                drawn_at.clear()
                shown_at.clear()
                began = time.perf_counter()
                await pilot.press("y" if rng.random() < 0.5 else "n")
                await app.workers.wait_for_complete()
                await pilot.pause()
                took.append((shown_at[0] if shown_at else time.perf_counter()) - began)
                if not session.valid:
                    await pilot.press("u")
                    await app.workers.wait_for_complete()
                    await pilot.pause()

    asyncio.run(play())
    size = len(session.model.features)
    target = next((t for n, t in sorted(TARGETS.items()) if size <= n * 1.2), None)
    p95 = statistics.quantiles(took, n=20)[-1] if len(took) >= 20 else max(took)
    verdict = "" if target is None else f"  target {target * 1000:.0f} ms: {'met' if p95 <= target else 'missed'}"
    label = name + (" (pilot, counts)" if form is not None else " (pilot)")
    print(
        f"{label:28} {size:6,} features  {len(took):4} decisions  key press to redrawn p50"
        f" {statistics.median(took) * 1000:7.1f} ms  p95 {p95 * 1000:7.1f} ms{verdict}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--decisions", type=int, default=200)
    parser.add_argument("--only", help="measure only the models whose name holds this")
    parser.add_argument("--no-pilot", action="store_true", help="leave out the decisions made through Textual's pilot")
    parser.add_argument(
        "--counts", action="store_true", help="also through the pilot with a compiled form of the public models (live counts)"
    )
    args = parser.parse_args()
    from motivml.language.featureide import read_featureide

    with tempfile.TemporaryDirectory() as tmp:
        for file, name in PUBLIC.items():
            if args.only and args.only.lower() not in name.lower():
                continue
            folder = Path(tmp) / file.split(".")[0]
            folder.mkdir()
            document = read_featureide(lzma.decompress((MODELS / file).read_bytes()), file)
            model = _model(document, folder)
            measure(name, model, args.decisions)
            if not args.no_pilot:
                measure_pilot(name, model, args.decisions, folder)
                if args.counts:
                    from motivml.binding.compiled import CompiledForm, Kind, compiled_form

                    form = compiled_form(model, None, Kind.SELECTIONS, 60.0)  # type: ignore[arg-type]
                    if isinstance(form, CompiledForm):
                        measure_pilot(name, model, args.decisions, folder, form=form)
                    else:
                        print(f"{name + ' (pilot, counts)':28} no compiled form: {form.reason}")
        if not args.only or args.only.lower() in "generated":
            folder = Path(tmp) / "generated"
            folder.mkdir()
            document, _ = generate(10_000, 1)
            model = _model(document, folder)
            measure("generated (generate.py)", model, args.decisions)
            if not args.no_pilot:
                measure_pilot("generated (generate.py)", model, args.decisions, folder)


if __name__ == "__main__":
    main()

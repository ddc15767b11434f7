"""analyse: what a feature model allows (reference.md section 7)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

import click
from rich.markup import escape

from ..errors import Diagnostic, EnvironmentProblem, Location, MotivmlError, error
from .common import Number, fail, out, plural, print_diagnostics, targets
from .progress import ProgressBar

if TYPE_CHECKING:
    from ..language.model import Binding, FeatureModel

SHOWN = 20  # ids listed per line of the text output; --format json lists them all


MAX_COUNT_SECONDS = 1e6  # the longest wait for a count that the system's poll takes is 24 days


@click.command("analyse")
@click.argument("target", default=".", type=click.Path(readable=False))
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text", show_default=True)
@click.option("--no-counts", is_flag=True, help="Leave out the selection and variant counts.")
@click.option(
    "--count-timeout",
    type=Number(min=0, min_open=True, max=MAX_COUNT_SECONDS, allow_inf=True),
    default=60.0,
    show_default=True,
    help=f"Seconds each exact count may take before it is given up (and reported as not counted), at most"
    f" {MAX_COUNT_SECONDS:g}; inf: no limit.",
)
def analyse_command(target: str, fmt: str, no_counts: bool, count_timeout: float) -> None:
    """Core, dead and false-optional features, atomic sets, impossible bindings and exact counts.

    TARGET is a model.json or a robot folder (default: the current folder). The selection
    count is the number of selections satisfying the model (section 2, formulas included:
    what other product-line tools count); the variant count also tells apart each selected
    feature's binding time and mode (sections 2-4). Counts are exact integers; exact
    counting can take very long on large models, so each is given up after --count-timeout
    seconds. Exit 1 when the model has errors or no valid variant, 3 when the model counter
    fails.
    """
    from ..binding.analysis import STEPS, CountFailed, analyse
    from ..binding.check import analyse_model
    from ..validate import validate

    try:
        model_path, _, _ = targets(target, None, None)
        with ProgressBar(len(STEPS) + 1, shown=fmt != "json") as bar:
            bar.step("reading the model")
            checked = validate(model_path, [], partial=True, analyse=False).model
            model = checked.model
            if model is None:
                _refuse(checked.errors, fmt, "the model has errors")
            try:
                limit = None if math.isinf(count_timeout) else count_timeout  # (inf: no limit)
                analysis = analyse(model, not no_counts, bar.step, limit)
            except CountFailed as exc:
                raise EnvironmentProblem(error(Location(str(model_path)), str(exc), "count")) from None
        if analysis.void:
            _refuse(analyse_model(model), fmt, "the model has no valid variant", void=True)
    except MotivmlError as exc:
        fail(exc)
    if fmt == "json":
        payload = {
            "model": str(model_path),
            "features": len(model.features),
            "void": False,
            "core": analysis.core,
            "dead": analysis.dead,
            "false_optional": analysis.false_optional,
            "atomic_sets": analysis.atomic_sets,
            "impossible_bindings": [
                {"feature": f, "aspect": aspect, "value": value} for f, aspect, value in analysis.impossible
            ],
            "selection_count": analysis.selection_count,
            "variant_count": analysis.variant_count,
            "uncounted": analysis.uncounted,
        }
        from ..documents.writing import indented_json

        click.echo(indented_json(payload))
        sys.exit(0)
    out.print(f"{escape(str(model_path))}: {plural(len(model.features), 'feature')}")
    _line("core", analysis.core)
    _line("dead", analysis.dead)
    _line("false-optional", analysis.false_optional)
    grouped = [members for members in analysis.atomic_sets if len(members) > 1]
    sets = ["{" + ", ".join(members) + "}" for members in grouped]
    alone = len(analysis.atomic_sets) - len(grouped)
    _line("atomic sets", sets, f" (and {plural(alone, 'live feature')} each in a set of its own)")
    _line("impossible bindings", [f"{f} never {value}" for f, _, value in analysis.impossible])
    if not no_counts:
        for name, value in (("selections", analysis.selection_count), ("variants", analysis.variant_count)):
            shown = str(value) if value is not None else f"not counted within {count_timeout:g} s (see --count-timeout)"
            out.print(f"{name}: {shown}")


def _line(title: str, items: list[str], tail: str = "") -> None:
    shown = ", ".join(items[:SHOWN]) + (f" and {len(items) - SHOWN} more" if len(items) > SHOWN else "")
    out.print(f"{title} ({len(items)}): {escape(shown or 'none')}{escape(tail)}")


def _refuse(found: list[Diagnostic], fmt: str, why: str, void: bool = False) -> NoReturn:
    if fmt == "json":
        click.echo(json.dumps({"void": void, "errors": [d.as_dict() for d in found]}, indent=2))
    else:
        print_diagnostics(found)
        out.print(f"[bold red]nothing analysed[/]: {why}")
    sys.exit(1)


@click.command("sample")
@click.argument("target", default=".", type=click.Path(readable=False))
@click.option("--t", "t", type=click.IntRange(1, 3), default=2, show_default=True, help="Cover every combination of t feature values.")
@click.option("--bindings", is_flag=True, help="A selected feature's values are also Early, Late, Static and Dynamic.")
@click.option(
    "-o",
    "--output",
    type=click.Path(file_okay=False, readable=False),
    help="Folder for the sample's decisions files (default build/<robot>/sample).",
)
def sample_command(target: str, t: int, bindings: bool, output: str | None) -> None:
    """Write a t-wise sample: a few valid variants such that every valid combination of t
    feature values (selected or not; with --bindings, also each time and mode) is in one.

    Each variant is a decisions file OUTPUT/sample-NNN.json ("partial": true; OUTPUT is
    build/<robot>/sample unless given) that
    `validate` accepts and `configure` completes; without --bindings it leaves the bindings
    to `configure`. TARGET is a model.json or a robot folder. Exit 1 when the model has
    errors or no valid variant, 2 when t-wise is too large for the model.
    """
    from ..binding.sampling import TooMany, sample
    from ..documents.writing import write_if_changed
    from ..validate import validate

    try:
        model_path, _, _ = targets(target, None, None)
        if output is None:  # (as export and configure: under build/, by the robot's name)
            robot = model_path.parent.name if model_path.name == "model.json" else model_path.stem
            output = str(Path("build") / robot / "sample")
        try:
            with ProgressBar(1) as bar:
                bar.step("reading the model")
                checked = validate(model_path, [], partial=True, analyse=False).model
                model = checked.model
                if model is None:
                    _refuse(checked.errors, "text", "the model has errors")
                found = sample(model, t, bindings, bar.reached)
        except TooMany as exc:
            raise click.UsageError(f"{exc}: use a smaller t") from None
        if found.void:
            from ..binding.check import analyse_model

            _refuse(analyse_model(model), "text", "the model has no valid variant", void=True)
        files = {f"sample-{k:03d}.json": _decisions(model, variant, bindings) for k, variant in enumerate(found.variants, 1)}
        folder = Path(output)
        write_if_changed(folder, files)
        for stale in folder.glob("sample-[0-9][0-9][0-9].json"):  # (an earlier, larger sample's)
            if stale.name not in files:
                stale.unlink()
    except MotivmlError as exc:
        fail(exc)
    shown = 100 * found.shown / found.valid if found.valid else 100.0
    out.print(
        f"{plural(len(found.variants), 'variant')} cover {shown:.1f}% of {found.valid:,} valid {t}-wise combinations"
        f" ({found.combinations - found.valid:,} of {found.combinations:,} have no valid variant)"
    )
    if files:
        out.print(f"  wrote {escape(str(Path(output)))}/sample-001.json ... sample-{len(files):03d}.json")
    else:
        others = plural(len(model.features) - 1, "feature")
        out.print(f"  wrote no file: no {t}-wise combination, the model has {others} besides its root")


def _decisions(model: FeatureModel, variant: dict[int, Binding | None], bindings: bool) -> str:
    properties: list[dict[str, object]] = []
    for f in model.features[1:]:
        binding = variant[f.index]
        if binding is None:
            properties.append({"id": f.id, "selected": False})
        elif bindings:
            properties.append({"id": f.id, "props": {"time": binding.time.value, "mode": binding.mode.value}})
        else:
            properties.append({"id": f.id})
    return json.dumps({"x-generated": "motivml sample", "partial": True, "properties": properties}, indent=2) + "\n"

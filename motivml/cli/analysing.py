"""analyse: what a feature model allows (reference.md section 7)."""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TypeVar

import click
from rich.markup import escape

from ..errors import Diagnostic, EnvironmentProblem, Location, MotivmlError, error
from .common import Number, fail, out, plural, print_diagnostics, targets
from .progress import ProgressBar

if TYPE_CHECKING:
    from ..language.model import Binding, FeatureModel

SHOWN = 20  # ids listed per line of the text output; --format json lists them all


MAX_COUNT_SECONDS = 1e6  # the longest wait for a count that the system's poll takes is 24 days


F = TypeVar("F", bound=Callable[..., Any])


def _seconds(name: str, help: str) -> Callable[[F], F]:
    """An option of seconds, 60 by default, `inf` for no limit."""
    kind = Number(min=0, min_open=True, max=MAX_COUNT_SECONDS, allow_inf=True)
    return click.option(name, type=kind, default=60.0, show_default=True, help=help)


@click.command("analyse")
@click.argument("target", default=".", type=click.Path(readable=False))
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text", show_default=True)
@click.option("--no-counts", is_flag=True, help="Leave out the selection and variant counts.")
@_seconds("--count-timeout", f"Seconds each exact count by Ganak may take before it is given up (and reported as not counted),"
    f" at most {MAX_COUNT_SECONDS:g}; inf: no limit.")
@_seconds("--compile-limit", "Seconds a missing compiled form may take to make before the count falls back to Ganak; inf: no limit.")
@click.option("--no-compiled", is_flag=True, help="Count with Ganak, neither reading nor making compiled forms.")
def analyse_command(
    target: str, fmt: str, no_counts: bool, count_timeout: float, compile_limit: float, no_compiled: bool
) -> None:
    """Core, dead and false-optional features, atomic sets, impossible bindings and exact counts.

    TARGET is a model.json or a robot folder (default: the current folder). The selection
    count is the number of selections satisfying the model (section 2, formulas included:
    what other product-line tools count); the variant count also tells apart each selected
    feature's binding time and mode (sections 2-4). Counts are exact integers, read from
    the model's compiled forms (kept in .motivml/compiled beside the model; a missing one is
    made, within --compile-limit seconds: `motivml compile`) or, where there is none, counted
    by Ganak, each given up after --count-timeout seconds. Exit 1 when the model has errors
    or no valid variant, 3 when the model counter fails.
    """
    from ..binding.analysis import STEPS, Compiling, CountFailed, analyse
    from ..binding.check import analyse_model
    from ..validate import validate

    try:
        model_path, _, _ = targets(target, None, None)
        with ProgressBar(len(STEPS) + 2, shown=fmt != "json") as bar:
            bar.step("reading the model")
            checked = validate(model_path, [], partial=True, analyse=False).model
            model = checked.model
            if model is None:
                _refuse(checked.errors, fmt, "the model has errors")
            try:
                limit = None if math.isinf(count_timeout) else count_timeout  # (inf: no limit)
                compiling = Compiling(
                    model_path.parent, None if math.isinf(compile_limit) else compile_limit, not no_compiled
                )
                analysis = analyse(model, not no_counts, bar.step, limit, compiling)
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
            "counted_by": analysis.counted_by,
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
            how = analysis.counted_by.get(name[:-1], "")
            fallback = f" ({how})" if how.startswith("Ganak:") else ""  # (a compiled form's count needs no word)
            if value is None:
                out.print(f"{name}: not counted within {count_timeout:g} s (see --count-timeout){escape(fallback)}")
            else:
                out.print(f"{name}: {value}{escape(fallback)}")


@click.command("compile")
@click.argument("target", default=".", type=click.Path(readable=False))
@_seconds("--limit", "Seconds each compile may take before it is given up; inf: no limit.")
@click.option(
    "--kind",
    type=click.Choice(["both", "selections", "variants", "valid-selections"]),
    default="both",
    show_default=True,
    help="Which compiled form to make (both: selections and variants; valid-selections: what sample --uniform draws from).",
)
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text", show_default=True)
def compile_command(target: str, limit: float, kind: str, fmt: str) -> None:
    """Compile the model's selections and variants into d-DNNFs kept beside it, from which
    `analyse` counts, `sample --uniform` draws and `menuconfig` shows live counts at once.

    The forms are kept in .motivml/compiled beside the model (a cache: it may be deleted at
    any time, and a changed model gets new forms); a form already there is read, not made
    again. A compile that passes --limit is given up (and not tried again with the same
    limit), and the commands count with Ganak instead. TARGET is a model.json or a robot
    folder. Exit 1 when the model has errors, 3 when a form was not compiled within --limit
    (now or before) or could not be kept.
    """
    from ..binding.compiled import Kind, NotCompiled, compiled_form
    from ..validate import validate

    kinds = [Kind.SELECTIONS, Kind.VARIANTS] if kind == "both" else [Kind(kind)]
    results: list[tuple[Any, Any]] = []
    try:
        model_path, _, _ = targets(target, None, None)
        with ProgressBar(1 + len(kinds), shown=fmt != "json") as bar:
            bar.step("reading the model")
            checked = validate(model_path, [], partial=True, analyse=False).model
            model = checked.model
            if model is None:
                _refuse(checked.errors, fmt, "the model has errors")
            for each in kinds:
                bar.step(f"compiling the {each}")
                form = compiled_form(model, model_path.parent, each, None if math.isinf(limit) else limit)
                results.append((each, form))
    except MotivmlError as exc:
        fail(exc)
    missing = [each for each, form in results if isinstance(form, NotCompiled) or form.path is None]
    if fmt == "json":
        from ..documents.writing import indented_json

        payload: dict[str, Any] = {"model": str(model_path), "features": len(model.features), "forms": {}}
        for each, form in results:
            payload["forms"][str(each)] = (
                {"compiled": False, "reason": form.reason}
                if isinstance(form, NotCompiled)
                else {
                    "compiled": True,
                    "made_now": form.made_now,
                    "seconds": round(form.seconds, 3),
                    "nodes": form.nodes,
                    "count": form.count(),
                    "path": str(form.path) if form.path is not None else None,
                }
            )
        click.echo(indented_json(payload))
        sys.exit(3 if missing else 0)
    out.print(f"{escape(str(model_path))}: {plural(len(model.features), 'feature')}")
    for each, form in results:
        if isinstance(form, NotCompiled):
            out.print(f"{each}: [bold red]not compiled[/]: {escape(form.reason)}")
            continue
        made = f"compiled in {form.seconds:.2f} s" if form.made_now else f"kept (compiled in {form.seconds:.2f} s)"
        where = f"\n  {escape(str(form.path))}" if form.path is not None else f" (not kept: {escape(form.not_kept)})"
        out.print(f"{each}: {made}, {form.nodes:,} nodes, counting {form.count()}{where}")
    if missing:
        sys.exit(3)


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


GITHUB_MATRIX_JOBS = 256  # jobs one GitHub Actions matrix may have
MAX_UNIFORM = 10_000  # variants `sample --uniform` draws at most (each is held, then written, as a file)
TRIES = 10  # orders of the features a t-wise sample tries by default, at most (YASA's m = 10)
TRY_FOR = 20.0  # seconds: by default no new order is tried after these (the first always is)


@click.command("sample")
@click.argument("target", default=".", type=click.Path(readable=False))
@click.option("--t", "t", type=click.IntRange(1, 3), default=2, show_default=True, help="Cover every combination of t feature values.")
@click.option("--bindings", is_flag=True, help="A selected feature's values are also Early, Late, Static and Dynamic.")
@click.option(
    "--uniform",
    type=click.IntRange(1, MAX_UNIFORM),
    metavar="N",
    help="N variants drawn uniformly at random from the compiled form, instead of a t-wise sample.",
)
@click.option(
    "--tries",
    type=click.IntRange(1, 1000),
    metavar="N",
    help=f"t-wise: the smallest of N samples in N orders of the features, the model's own and N-1 shuffled"
    f" (default: up to {TRIES}, as many as start within {TRY_FOR:g} s).",
)
@click.option(
    "--seed", type=click.IntRange(0, 2**63 - 1), default=0, show_default=True, help="The seed of --uniform and of the t-wise orders."
)
@_seconds("--compile-limit", "Seconds --uniform may take to make a missing compiled form; inf: no limit.")
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["files", "github-matrix"]),
    default="files",
    show_default=True,
    help="github-matrix: also a GitHub Actions matrix of the files (matrix-NNN.json) and their t-wise coverage.",
)
@click.option(
    "--max-jobs",
    type=click.IntRange(1, GITHUB_MATRIX_JOBS),
    default=GITHUB_MATRIX_JOBS,
    show_default=True,
    help="Jobs per matrix file (GitHub allows 256).",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(file_okay=False, readable=False),
    help="Folder for the sample's decisions files (default build/<robot>/sample).",
)
def sample_command(
    target: str,
    t: int,
    bindings: bool,
    uniform: int | None,
    tries: int | None,
    seed: int,
    compile_limit: float,
    fmt: str,
    max_jobs: int,
    output: str | None,
) -> None:
    """Write a t-wise sample: a few valid variants such that every valid combination of t
    feature values (selected or not; with --bindings, also each time and mode) is in one:
    the smallest that the greedy finds in --tries orders of the features (the model's own,
    then orders shuffled with --seed; printed, so that the same --seed and --tries give the
    same sample). With --uniform N, N variants drawn uniformly at random instead (independently, so one
    may come twice: each is written once), from the model's compiled form (`motivml compile`; with --bindings, over the
    variants' bindings too), reproducibly for one --seed.

    Each variant is a decisions file OUTPUT/sample-NNN.json ("partial": true; OUTPUT is
    build/<robot>/sample unless given) that
    `validate` accepts and `configure` completes; without --bindings it leaves the bindings
    to `configure`. With --format github-matrix, OUTPUT/matrix-001.json ... hold the files as
    GitHub Actions matrices (`strategy: matrix: ${{ fromJSON(...) }}`, at most --max-jobs
    jobs each) and OUTPUT/coverage.json the t-wise coverage the sample achieves. TARGET is a
    model.json or a robot folder. Exit 1 when the model has errors or no valid variant, 2
    when t-wise is too large for the model, 3 when --uniform has no compiled form.
    """
    from ..binding.sampling import TooMany
    from ..validate import validate

    try:
        model_path, _, _ = targets(target, None, None)
        if output is None:  # (as export and configure: under build/, by the robot's name)
            robot = model_path.parent.name if model_path.name == "model.json" else model_path.stem
            output = str(Path("build") / robot / "sample")
        try:
            with ProgressBar(2) as bar:
                bar.step("reading the model")
                checked = validate(model_path, [], partial=True, analyse=False).model
                model = checked.model
                if model is None:
                    _refuse(checked.errors, "text", "the model has errors")
                variants, found, covered = _sampled(model, model_path, t, bindings, (uniform, tries, seed), compile_limit, fmt, bar)
        except TooMany as exc:
            raise click.UsageError(f"{exc}: use a smaller t") from None
        if found is not None and found.void:
            from ..binding.check import analyse_model

            _refuse(analyse_model(model), "text", "the model has no valid variant", void=True)
        width = max(3, len(str(len(variants))))  # (sample-001 ... sample-999, then sample-0001 ...)
        files = {
            f"sample-{k:0{width}d}.json": _decisions(model, variant, bindings) for k, variant in enumerate(variants, 1)
        }
        folder = Path(output)
        if covered is not None:
            files.update(_matrices(folder, list(files), max_jobs, covered, uniform, seed, found.tries if found is not None else 0))
        _write_sample(folder, files)
    except MotivmlError as exc:
        fail(exc)
    _say_sampled(model, variants, found, covered, t, (uniform or 0, seed), files, Path(output))


def _sampled(
    model: FeatureModel,
    model_path: Path,
    t: int,
    bindings: bool,
    how: tuple[int | None, int | None, int],
    compile_limit: float,
    fmt: str,
    bar: ProgressBar,
) -> tuple[list[dict[int, Binding | None]], Any, Any]:
    """The sample's variants, the t-wise sample itself (None for --uniform) and, for
    github-matrix, its coverage. `how`: --uniform, --tries and --seed."""
    from ..binding.sampling import coverage, smallest

    uniform, tries, seed = how
    if uniform is not None:
        bar.step("drawing the variants")
        variants, found = _uniform(model, model_path, bindings, uniform, seed, compile_limit), None
    else:
        until = None if tries is not None else time.monotonic() + TRY_FOR
        count = tries or TRIES

        def reached(k: int, done: int, total: int, runs: int | None = None) -> None:
            if runs is None:
                bar.reached(done, total, f"order {k + 1} of at most {count}: combinations settled")
            else:
                bar.reached(done, total, f"AETG-style greedy, run {k + 1} of {runs}: pairs covered")

        found = smallest(model, t, bindings, count, seed, until, reached)
        variants = found.variants
    covered = None
    if fmt == "github-matrix":
        bar.step(f"the sample's {t}-wise coverage")
        covered = coverage(model, variants, t, bindings, bar.reached) if found is None else _as_coverage(found, t)
    return variants, found, covered


def _say_sampled(
    model: FeatureModel,
    variants: list[dict[int, Binding | None]],
    found: Any,
    covered: Any,
    t: int,
    uniform: tuple[int, int],
    files: dict[str, str],
    output: Path,
) -> None:
    drawn, seed = uniform
    if found is not None:
        shown = 100 * found.shown / found.valid if found.valid else 100.0
        out.print(
            f"{plural(len(variants), 'variant')} cover {shown:.1f}% of {found.valid:,} valid {t}-wise combinations"
            f" ({found.combinations - found.valid:,} of {found.combinations:,} have no valid variant)"
        )
        if found.combinations:
            orders = "the model's own order of the features" if found.tries == 1 else f"the smallest of {found.tries} orders of the features"
            if found.aetg:
                orders = "the AETG-style greedy's, smaller than " + ("the model's own order's" if found.tries == 1 else orders)
            out.print(f"  {orders} (--tries {found.tries} --seed {seed})")
    else:
        out.print(f"{plural(drawn, 'variant')} drawn uniformly at random (seed {seed}): {len(variants):,} distinct")
        if covered is not None:
            shown = 100 * covered.shown / covered.valid if covered.valid else 100.0
            out.print(f"  they cover {shown:.1f}% of {covered.valid:,} valid {t}-wise combinations")
    written = [name for name in files if name.startswith("sample-")]  # (in their order)
    if written:
        out.print(f"  wrote {escape(str(output))}/{written[0]} ... {written[-1]}")
    else:
        others = plural(len(model.features) - 1, "feature")
        out.print(f"  wrote no file: no {t}-wise combination, the model has {others} besides its root")
    matrices = sorted(name for name in files if name.startswith("matrix-"))
    if matrices:
        out.print(f"  and {escape(str(output))}/{', '.join(matrices)} with coverage.json")
    elif "coverage.json" in files:
        out.print(f"  and {escape(str(output))}/coverage.json (no matrix: GitHub refuses an empty one)")


def _uniform(
    model: FeatureModel, model_path: Path, bindings: bool, amount: int, seed: int, limit: float
) -> list[dict[int, Binding | None]]:
    """`amount` variants drawn uniformly from the model's compiled form (of variants with
    `bindings`, else of the selections valid variants make), each that was drawn once, in
    the order drawn."""
    from ..binding.compiled import Kind, NotCompiled, compiled_form

    kind = Kind.VARIANTS if bindings else Kind.VALID_SELECTIONS
    form = compiled_form(model, model_path.parent, kind, None if math.isinf(limit) else limit)
    if isinstance(form, NotCompiled):
        raise EnvironmentProblem(
            error(Location(str(model_path)), f"no compiled form of the {kind.words} to draw from: {form.reason}", "compile")
        )
    if form.count() == 0:
        from ..binding.check import analyse_model

        _refuse(analyse_model(model), "text", "the model has no valid variant", void=True)
    drawn = list(dict.fromkeys(tuple(literals) for literals in form.uniform(amount, seed)))  # (each once)
    if bindings:
        return [dict(enumerate(form.bindings(literals))) for literals in drawn]
    from ..language.model import Binding as Bound

    return [{i: Bound.SE if literals[i] > 0 else None for i in range(len(model.features))} for literals in drawn]


def _as_coverage(found: Any, t: int) -> Any:
    from ..binding.sampling import Coverage

    return Coverage(t, found.combinations, found.valid, found.shown)


def _matrices(
    folder: Path, names: list[str], max_jobs: int, covered: Any, uniform: int | None, seed: int, tries: int
) -> dict[str, str]:
    """The sample's decisions files as GitHub Actions matrices of at most `max_jobs` jobs,
    and its coverage."""
    jobs = [{"variant": name.removesuffix(".json"), "decisions": str(folder / name)} for name in names]
    files: dict[str, str] = {}
    for k in range(0, len(jobs), max_jobs):
        files[f"matrix-{k // max_jobs + 1:03d}.json"] = json.dumps({"include": jobs[k : k + max_jobs]}, indent=2) + "\n"
    summary = {
        "sample": f"uniform, seed {seed}" if uniform is not None else f"{covered.t}-wise, --tries {tries} --seed {seed}",
        "variants": len(names),
        "t": covered.t,
        "combinations": covered.combinations,
        "valid": covered.valid,
        "shown": covered.shown,
        "coverage": round(covered.shown / covered.valid, 6) if covered.valid else 1.0,
        "matrices": sorted(files),
    }
    files["coverage.json"] = json.dumps(summary, indent=2) + "\n"
    return files


def _write_sample(folder: Path, files: dict[str, str]) -> None:
    """Write the sample, and remove what an earlier, larger one left."""
    import re

    from ..documents.writing import write_if_changed

    write_if_changed(folder, files)
    ours = re.compile(r"(sample|matrix)-[0-9]{3,}\.json|coverage\.json")
    for stale in folder.iterdir():
        if ours.fullmatch(stale.name) and stale.name not in files and stale.is_file():
            stale.unlink()


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

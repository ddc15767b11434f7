"""graph, plot, export and import: pictures of the model and architecture and of a run's record,
SCXML of the coordination, the model in other tools' formats (DIMACS, UVL) and from UVL."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import click
from rich.markup import escape

from ..documents.robot_folder import ARCHITECTURE_FILE
from ..errors import Diagnostic, MotivmlError

if TYPE_CHECKING:
    from ..language.model import FeatureModel
from .common import fail, one_variant, out, plural, print_diagnostics, shown
from .progress import ProgressBar


@click.command("graph")
@click.argument("target", default=".", type=click.Path(readable=False))
@click.option(
    "--variant", help="Draw this variant: its selection and bindings, and the architecture it starts with."
)
@click.option(
    "--config", "config", type=click.Path(readable=False), help="Draw this configuration file, as --variant draws a variant."
)
@click.option("--format", "fmt", type=click.Choice(["dot", "graphml"]), default="dot", show_default=True)
@click.option(
    "-o", "--output", type=click.Path(readable=False), help="Output folder (default build/<robot>/<variant or model>/)."
)
def graph_command(target: str, variant: str | None, config: str | None, fmt: str, output: str | None) -> None:
    """Draw the feature model and the motion architecture of a robot folder.

    Writes feature-model.FORMAT and, when the robot has an architecture.json,
    architecture.FORMAT. With --format dot, SVG pictures are rendered beside them when
    Graphviz's `dot` is installed. With --variant (or --config FILE, named by its stem),
    unselected features are greyed out and the architecture shows the elements of the
    variant's active set at start (what `motivml run` builds).
    """
    from .. import graph
    from ..documents.writing import write_if_changed
    from ..runtime.launch import load

    drawn = "model" if config is None and variant is None else one_variant(config, variant)
    try:
        loaded = load(target, variant, config_path=config)
        robot = loaded.folder
        draw = graph.feature_model_dot if fmt == "dot" else graph.feature_model_graphml
        files = {f"feature-model.{fmt}": draw(loaded.model, loaded.variant)}
        architecture = loaded.architecture
        if architecture is not None:
            pick = graph.architecture_dot if fmt == "dot" else graph.architecture_graphml
            files[f"architecture.{fmt}"] = pick(architecture, loaded.active)
        rendered = False
        if fmt == "dot" and shutil.which("dot") is not None:
            for name in list(files):
                svg = graph.render_svg(files[name])
                if svg is not None:
                    files[name.removesuffix(".dot") + ".svg"] = svg.decode("utf-8")
                    rendered = True
        folder = Path(output) if output else Path("build") / robot.name / drawn
        written = write_if_changed(folder, files)
    except MotivmlError as exc:
        _nothing(exc, "drawn", target)
    if architecture is None:
        out.print(f"{escape(robot.name)} has no {ARCHITECTURE_FILE}: drawing the feature model only")
    for name, changed in written.items():
        out.print(f"  {'wrote' if changed else 'unchanged'} {escape(str(folder / name))}")
    if fmt == "dot" and not rendered:
        out.print(
            "Graphviz's dot is not installed: no SVG (install graphviz, or render the .dot files elsewhere)"
        )


@click.command("plot")
@click.argument("record", type=click.Path(dir_okay=False, readable=False), metavar="RECORD.csv")
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, readable=False),
    metavar="PICTURE",
    help="The picture: .svg or .png (default: RECORD with .svg for .csv).",
)
@click.option(
    "--space",
    "spaces",
    multiple=True,
    metavar="SPACE",
    help="Draw this space (repeatable; default: the first 24 of the record).",
)
def plot_command(record: str, output: str | None, spaces: tuple[str, ...]) -> None:
    """Draw a run's record (motivml run --record RECORD.csv): one panel per space, its
    numbers over time, and the run's events as vertical lines: reconfigurations, refusals,
    faults, coordination states and criteria, each kind in its own colour and dash, the
    most telling ones labelled.

    A long run is thinned to a few thousand points per number, each showing the lowest and
    highest value of its stretch of ticks. At most 24 spaces are drawn (the first ones, or
    those given with --space), at most 12 numbers of each. A file that is not a record is refused with its
    line (exit 1). The picture is replaced in one rename: never half-written.
    """
    path = Path(record)
    target = Path(output) if output else path.with_suffix(".svg")
    fmt = target.suffix.lower().removeprefix(".")
    if fmt not in ("svg", "png"):
        raise click.BadParameter(f"{shown(str(target))}: a picture is .svg or .png", param_hint="-o/--output")
    if target.resolve() == path.resolve():
        raise click.BadParameter("the picture would replace the record", param_hint="-o/--output")
    from .. import plot
    from ..documents.writing import write_if_changed
    from ..runtime.record import read_record

    try:
        read = read_record(path)
        try:
            drawn = plot.panels(read, spaces)
        except ValueError as exc:
            raise click.BadParameter(shown(str(exc)), param_hint="--space") from None
        picture = plot.draw(read, fmt, spaces)
        write_if_changed(target.parent, {target.name: picture})
    except MotivmlError as exc:
        fail(exc)
    events = plot.marked(read)
    total = len(read.spaces)
    some = f"{len(drawn)} of {plural(total, 'space')}" if len(drawn) < total else plural(total, "space")
    out.print(
        f"{escape(str(target))}: {some}, {plural(read.ticks, 'tick')} "
        f"({read.start:g} to {read.end:g} s), {plural(len(events) + read.more_events, 'event')} marked"
    )
    if len(drawn) < total and not spaces:
        out.print(f"  (a picture draws at most {plot.PANELS} spaces: choose others with --space)")
    for event, text in plot.labelled(read):
        out.print(shown(f"  {event.time:.3f} s (tick {event.tick}): {text}"))


@click.command("export")
@click.argument("what", type=click.Choice(["scxml", "dimacs", "uvl", "featureide", "sxfm"]))
@click.argument("target", default=".", type=click.Path(readable=False))
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, readable=False),
    help="Output file (default build/<robot>/coordination.scxml, or model.dimacs, model.uvl, model.xml, model-sxfm.xml there).",
)
@click.option(
    "--bindings",
    is_flag=True,
    help="dimacs: sections 2-4 (selection, time and mode, start state), not the selection alone.",
)
def export_command(what: str, target: str, output: str | None, bindings: bool) -> None:
    """Export the robot's coordination statechart as W3C SCXML, or its model as DIMACS or UVL.

    scxml: domain conditions and actions are kept in the namespace
    urn:motivml:coordination:1 (see guidelines/coordinating-behaviour.md). dimacs: the CNF
    of the model's selections (section 2, formulas included) over one variable per feature,
    named in `c <var> <id>` lines as FeatureIDE writes them; with --bindings, the CNF of
    sections 2-4 and the projection onto the variants' variables (`c p show`). uvl: the
    feature tree by id, bindings, names, includes and excludes as attributes, and every
    cross-tree rule as a constraint; `motivml import uvl` reads it back to the same model.
    featureide: FeatureIDE's <featureModel> XML, a parent's mixed groups as rules, bindings
    as attributes. sxfm: S.P.L.O.T.'s <feature_model>, groups as [1,*] and [1,1], every
    cross-tree rule as clauses; SXFM holds no bindings (said when the model has some). TARGET is a robot folder (or, for a model format, a model.json). The file
    is rewritten only when it changes.
    """
    if bindings and what != "dimacs":
        raise click.UsageError("--bindings is for dimacs")
    if what in ("dimacs", "uvl", "featureide", "sxfm"):
        _export_model(what, target, output, bindings)
        return
    from ..coordination.scxml import to_scxml
    from ..documents.writing import write_if_changed
    from ..runtime.launch import load, read_robot_coordination

    try:
        loaded = load(target, None)
        coordination = read_robot_coordination(loaded.folder, loaded.model, loaded.architecture, None)
        if coordination is None:
            out.print(
                f"[bold red]nothing to export[/]: {escape(str(loaded.folder.coordination_path))} does not exist"
            )
            sys.exit(3)
        path = Path(output) if output else Path("build") / loaded.folder.name / "coordination.scxml"
        written = write_if_changed(path.parent, {path.name: to_scxml(coordination, loaded.folder.name)})
    except MotivmlError as exc:
        _nothing(exc, "exported", target)
    out.print(f"  {'wrote' if written[path.name] else 'unchanged'} {escape(str(path))}")


def _export_model(what: str, target: str, output: str | None, bindings: bool) -> None:
    from ..binding.dimacs import selection_dimacs, variant_dimacs
    from ..documents.writing import write_if_changed
    from ..language.featureide import write_featureide
    from ..language.sxfm import write_sxfm
    from ..language.uvl import write_uvl
    from ..validate import validate
    from .common import targets

    try:
        model_path, _, _ = targets(target, None, None)
        with ProgressBar(2) as bar:
            bar.step("reading the model")
            checked = validate(model_path, [], partial=True, analyse=False).model
            model = checked.model
            if model is None:
                print_diagnostics(checked.errors)
                out.print(f"[bold red]nothing exported[/]: {escape(str(model_path))} has errors")
                sys.exit(1)
            bar.step(f"writing {what}")
            names = {"uvl": "model.uvl", "featureide": "model.xml", "sxfm": "model-sxfm.xml"}
            name = names.get(what) or ("model-variants.dimacs" if bindings else "model.dimacs")
            robot = model_path.parent.name if model_path.name == "model.json" else model_path.stem
            path = Path(output) if output else Path("build") / robot / name
            writers = {"uvl": write_uvl, "featureide": write_featureide, "sxfm": write_sxfm}
            writer = writers.get(what) or (variant_dimacs if bindings else selection_dimacs)
            written = write_if_changed(path.parent, {path.name: writer(model)})
    except MotivmlError as exc:
        _nothing(exc, "exported", target)
    out.print(f"  {'wrote' if written[path.name] else 'unchanged'} {escape(str(path))}")
    bound = [f.id for f in model.features if _binding_written(model, f.index)]
    if what == "sxfm" and bound:
        out.print(
            f"  [yellow]not written[/]: the allowed binding times and modes of {plural(len(bound), 'feature')} "
            f"({escape(_few(bound))}): SXFM has no place for them (export uvl or featureide keeps them)"
        )


def _binding_written(model: FeatureModel, index: int) -> bool:
    """Whether the model's document says the feature's allowed binding time or mode."""
    from ..language.importer import attributes

    said = attributes(model, index, "constraints")
    return "bindingTimeAllowed" in said or "bindingModeAllowed" in said


def _few(ids: list[str]) -> str:
    return ", ".join(ids[:3]) + (f" and {len(ids) - 3} more" if len(ids) > 3 else "")


@click.command("import")
@click.argument("words", nargs=-1, required=True, metavar="[uvl|featureide|sxfm] SOURCE")
@click.option(
    "-o",
    "--output",
    type=click.Path(file_okay=False, readable=False),
    help="The robot folder to create (default build/<SOURCE's name without its suffix>).",
)
def import_command(words: tuple[str, ...], output: str | None) -> None:
    """Read a UVL, FeatureIDE XML or SXFM model into a new robot folder: OUTPUT/model.json
    and an empty variants/. Without a format word, the format is told from the text (and
    said).

    UVL's Boolean level is kept whole: mandatory, optional, or and alternative children,
    abstract features, constraints (as formulas) and the attributes bindingTime and
    bindingMode; names that are not ids become ids, the name kept. What cannot be kept
    (group or feature cardinalities, typed features, arithmetic constraints, imports) is
    refused, located, and nothing is written. FeatureIDE's <featureModel> keeps the same:
    and/or/alt/feature, mandatory, abstract, and its <constraints> rules. S.P.L.O.T.'s
    <feature_model> (SXFM) keeps its tree, its groups [1,1], [1,*], [0,1] and [0,*], and
    its clauses. What a published file writes otherwise than its format's definition, and
    is read anyway, is said as a warning. An existing model.json is not overwritten.
    """
    from ..documents.writing import write_if_changed
    from ..errors import EnvironmentProblem, Location, error
    from ..language.importer import FORMATS

    if len(words) > 2 or (len(words) == 2 and words[0] not in FORMATS):
        raise click.UsageError(f"import takes [uvl|featureide|sxfm] SOURCE, not {' '.join(words)!r}")
    what, source = (words[0], words[1]) if len(words) == 2 else (None, words[0])
    folder = Path(output) if output else Path("build") / Path(source).stem
    model_path = folder / "model.json"
    try:
        if model_path.exists():
            raise EnvironmentProblem(
                error(Location(str(model_path)), "exists already: import into a new folder, or remove it", "io")
            )
        with ProgressBar(3) as bar:
            bar.step(f"reading {source}")
            document, warnings = _imported(what, source)
            bar.step("checking the model as validate does")
            written = _checked_model(document, model_path)
            bar.step(f"writing {model_path}")
            write_if_changed(folder, {"model.json": written})
        (folder / "variants").mkdir(exist_ok=True)
    except MotivmlError as exc:
        _nothing(exc, "imported", source)
    print_diagnostics(warnings)
    out.print(f"  wrote {escape(str(model_path))} ({_count(document)} features)")


def _imported(what: str | None, source: str) -> tuple[dict[str, Any], list[Diagnostic]]:
    """The document read from `source` in the format `what` (None: told from its text),
    and the warnings of what was read though written otherwise than the format says."""
    from ..documents.loader import read_bytes
    from ..errors import DocumentError, Location, error
    from ..language.importer import FORMATS, guess

    # (a regular file within the size limit of every document: not a FIFO, not /dev/zero)
    data = read_bytes(source, what="a model file")
    seen, why = guess(data)
    if what is None:
        if seen is None:
            raise DocumentError(
                error(
                    Location(source),
                    f"cannot tell which model format this is: {why}. motivml imports UVL, FeatureIDE XML "
                    "and SXFM; name the format (motivml import uvl|featureide|sxfm SOURCE) to read it as one",
                    "import",
                )
            )
        out.print(f"  reading {escape(source)} as {FORMATS[seen]} ({escape(why)})")
        what = seen
    elif seen is not None and seen != what:
        raise DocumentError(
            error(
                Location(source),
                f"this is {FORMATS[seen]}, not {FORMATS[what]} ({why}): "
                f"motivml import {seen} {source} reads it",
                what,
            )
        )
    warnings: list[Diagnostic] = []
    if what == "featureide":
        from ..language.featureide import read_featureide

        return read_featureide(data, source), warnings
    if what == "sxfm":
        from ..language.sxfm import read_sxfm

        return read_sxfm(data, source, warnings), warnings
    from ..language.uvl import read_uvl

    try:
        text = data.decode("utf-8").removeprefix("\ufeff")  # (a byte-order mark, as some editors write)
    except UnicodeDecodeError as exc:
        raise DocumentError(error(Location(source), f"is not UTF-8 text ({exc.reason})", "io")) from None
    return read_uvl(text, source, warnings), warnings


def _checked_model(document: dict[str, Any], model_path: Path) -> str:
    """The model's text, checked as `validate` checks it (the schema, then the model's
    reading): a model the importer made that motivml refuses is said, not written."""
    from ..documents.loader import load_bytes
    from ..documents.schema import check_feature_model
    from ..documents.writing import indented_json
    from ..errors import DocumentError
    from ..language.reader import read_model
    from ..process import no_gc

    written = indented_json(document, ascii=False) + "\n"  # (iterative: models nest deep)
    loaded = load_bytes(written.encode("utf-8"), str(model_path))
    problems = check_feature_model(loaded)
    if not problems:
        with no_gc():
            _, problems = read_model(loaded)
    errors = [d for d in problems if d.severity.value == "error"]
    if errors:
        raise DocumentError(errors)
    return written


def _count(document: dict[str, object]) -> int:
    total, stack = 0, [document]
    while stack:
        node = stack.pop()
        total += 1
        stack.extend(node.get("sub", []))  # type: ignore[arg-type]
    return total


def _nothing(exc: MotivmlError, done: str, what: str) -> NoReturn:
    """An error's diagnostics, then "nothing <done>: <what>", and its exit code."""
    print_diagnostics(exc.diagnostics)
    out.print(f"[bold red]nothing {done}[/]: {escape(what)}")
    sys.exit(exc.exit_code)

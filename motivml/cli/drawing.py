"""graph, plot, export and import: pictures of the model and architecture and of a run's record,
SCXML of the coordination, the model in other tools' formats (DIMACS, UVL) and from UVL."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path
from typing import NoReturn

import click
from rich.markup import escape

from ..documents.robot_folder import ARCHITECTURE_FILE
from ..errors import MotivmlError
from .common import fail, one_variant, out, plural, print_diagnostics, shown


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
@click.argument("what", type=click.Choice(["scxml", "dimacs", "uvl", "featureide"]))
@click.argument("target", default=".", type=click.Path(readable=False))
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, readable=False),
    help="Output file (default build/<robot>/coordination.scxml, or model.dimacs, model.uvl, model.xml there).",
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
    as attributes. TARGET is a robot folder (or, for a model format, a model.json). The file
    is rewritten only when it changes.
    """
    if bindings and what != "dimacs":
        raise click.UsageError("--bindings is for dimacs")
    if what in ("dimacs", "uvl", "featureide"):
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
    from ..language.uvl import write_uvl
    from ..validate import validate
    from .common import targets

    try:
        model_path, _, _ = targets(target, None, None)
        checked = validate(model_path, [], partial=True, analyse=False).model
        model = checked.model
        if model is None:
            print_diagnostics(checked.errors)
            out.print(f"[bold red]nothing exported[/]: {escape(str(model_path))} has errors")
            sys.exit(1)
        names = {"uvl": "model.uvl", "featureide": "model.xml"}
        name = names.get(what) or ("model-variants.dimacs" if bindings else "model.dimacs")
        robot = model_path.parent.name if model_path.name == "model.json" else model_path.stem
        path = Path(output) if output else Path("build") / robot / name
        if what == "uvl":
            text = write_uvl(model)
        elif what == "featureide":
            text = write_featureide(model)
        else:
            text = variant_dimacs(model) if bindings else selection_dimacs(model)
        written = write_if_changed(path.parent, {path.name: text})
    except MotivmlError as exc:
        _nothing(exc, "exported", target)
    out.print(f"  {'wrote' if written[path.name] else 'unchanged'} {escape(str(path))}")


@click.command("import")
@click.argument("what", type=click.Choice(["uvl", "featureide"]))
@click.argument("source", type=click.Path(dir_okay=False, readable=False))
@click.option("-o", "--output", required=True, type=click.Path(file_okay=False, readable=False), help="The robot folder to create.")
def import_command(what: str, source: str, output: str) -> None:
    """Read a UVL or FeatureIDE XML model into a new robot folder: OUTPUT/model.json and an
    empty variants/.

    UVL's Boolean level is kept whole: mandatory, optional, or and alternative children,
    abstract features, constraints (as formulas) and the attributes bindingTime and
    bindingMode; names that are not ids become ids, the name kept. What cannot be kept
    (group or feature cardinalities, typed features, arithmetic constraints, imports) is
    refused, located, and nothing is written. FeatureIDE's <featureModel> keeps the same:
    and/or/alt/feature, mandatory, abstract, and its <constraints> rules. An existing
    model.json is not overwritten.
    """
    from ..documents.loader import load_bytes, read_bytes
    from ..documents.schema import check_feature_model
    from ..documents.writing import indented_json, write_if_changed
    from ..errors import DocumentError, EnvironmentProblem, Location, error
    from ..language.featureide import read_featureide
    from ..language.reader import read_model
    from ..language.uvl import read_uvl
    from ..process import no_gc

    folder = Path(output)
    model_path = folder / "model.json"
    try:
        if model_path.exists():
            raise EnvironmentProblem(
                error(Location(str(model_path)), "exists already: import into a new folder, or remove it", "io")
            )
        # (a regular file within the size limit of every document: not a FIFO, not /dev/zero)
        data = read_bytes(source, what="a model file")
        if what == "featureide":
            document = read_featureide(data, source)
        else:
            try:
                text = data.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise DocumentError(error(Location(source), f"is not UTF-8 text ({exc.reason})", "io")) from None
            document = read_uvl(text, source)
        written = indented_json(document, ascii=False) + "\n"  # (iterative: models nest deep)
        # what `validate` checks of the model written: the schema, then the model's reading
        loaded = load_bytes(written.encode("utf-8"), str(model_path))
        problems = check_feature_model(loaded)
        if not problems:
            with no_gc():
                _, problems = read_model(loaded)
        errors = [d for d in problems if d.severity.value == "error"]
        if errors:  # (a model the importer made that motivml refuses: said, not written)
            raise DocumentError(errors)
        write_if_changed(folder, {"model.json": written})
        (folder / "variants").mkdir(exist_ok=True)
    except MotivmlError as exc:
        _nothing(exc, "imported", source)
    out.print(f"  wrote {escape(str(model_path))} ({_count(document)} features)")


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

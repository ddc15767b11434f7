"""graph and export: pictures of the model and architecture, SCXML of the coordination."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import click
from rich.markup import escape

from ..documents.robot_folder import ARCHITECTURE_FILE
from ..errors import MotivmlError
from .common import out, print_diagnostic


@click.command("graph")
@click.argument("target", default=".", type=click.Path())
@click.option(
    "--variant", help="Draw this variant: its selection and bindings, and the architecture it starts with."
)
@click.option("--format", "fmt", type=click.Choice(["dot", "graphml"]), default="dot", show_default=True)
@click.option(
    "-o", "--output", type=click.Path(), help="Output folder (default build/<robot>/<variant or model>/)."
)
def graph_command(target: str, variant: str | None, fmt: str, output: str | None) -> None:
    """Draw the feature model and the motion architecture of a robot folder.

    Writes feature-model.FORMAT and, when the robot has an architecture.json,
    architecture.FORMAT. With --format dot, SVG pictures are rendered beside them when
    Graphviz's `dot` is installed. With --variant, unselected features are greyed out and
    the architecture shows the elements of the variant's active set at start (what
    `motivml run` builds).
    """
    from .. import graph
    from ..documents.writing import write_if_changed
    from ..runtime.launch import load

    try:
        loaded = load(target, variant)
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
        folder = Path(output) if output else Path("build") / robot.name / (variant or "model")
        written = write_if_changed(folder, files)
    except MotivmlError as exc:
        for d in exc.diagnostics:
            print_diagnostic(d)
        out.print(f"[bold red]nothing drawn[/]: {escape(target)}")
        sys.exit(exc.exit_code)
    if architecture is None:
        out.print(f"{escape(robot.name)} has no {ARCHITECTURE_FILE}: drawing the feature model only")
    for name, changed in written.items():
        out.print(f"  {'wrote' if changed else 'unchanged'} {escape(str(folder / name))}")
    if fmt == "dot" and not rendered:
        out.print(
            "Graphviz's dot is not installed: no SVG (install graphviz, or render the .dot files elsewhere)"
        )


@click.command("export")
@click.argument("what", type=click.Choice(["scxml", "dimacs"]))
@click.argument("target", default=".", type=click.Path())
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False),
    help="Output file (default build/<robot>/coordination.scxml, build/<robot>/model.dimacs).",
)
@click.option(
    "--bindings",
    is_flag=True,
    help="dimacs: sections 2-4 (selection, time and mode, start state), not the selection alone.",
)
def export_command(what: str, target: str, output: str | None, bindings: bool) -> None:
    """Export the robot's coordination statechart as W3C SCXML, or its model as DIMACS.

    scxml: domain conditions and actions are kept in the namespace
    urn:motivml:coordination:1 (see guidelines/coordinating-behaviour.md). dimacs: the CNF
    of the model's selections (section 2, formulas included) over one variable per feature,
    named in `c <var> <id>` lines as FeatureIDE writes them; with --bindings, the CNF of
    sections 2-4 and the projection onto the variants' variables (`c p show`). TARGET is a
    robot folder (or, for dimacs, a model.json). The file is rewritten only when it changes.
    """
    if bindings and what != "dimacs":
        raise click.UsageError("--bindings is for dimacs")
    if what == "dimacs":
        _export_dimacs(target, output, bindings)
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
        for d in exc.diagnostics:
            print_diagnostic(d)
        out.print(f"[bold red]nothing exported[/]: {escape(target)}")
        sys.exit(exc.exit_code)
    out.print(f"  {'wrote' if written[path.name] else 'unchanged'} {escape(str(path))}")


def _export_dimacs(target: str, output: str | None, bindings: bool) -> None:
    from ..binding.dimacs import selection_dimacs, variant_dimacs
    from ..documents.writing import write_if_changed
    from ..validate import validate
    from .common import targets

    try:
        model_path, _, _ = targets(target, None, None)
        reports = validate(model_path, [], partial=True, analyse=False)
        model = reports[0].model
        if model is None:
            for d in reports[0].errors:
                print_diagnostic(d)
            out.print(f"[bold red]nothing exported[/]: {escape(str(model_path))} has errors")
            sys.exit(1)
        name = "model-variants.dimacs" if bindings else "model.dimacs"
        robot = model_path.parent.name if model_path.name == "model.json" else model_path.stem
        path = Path(output) if output else Path("build") / robot / name
        text = variant_dimacs(model) if bindings else selection_dimacs(model)
        written = write_if_changed(path.parent, {path.name: text})
    except MotivmlError as exc:
        for d in exc.diagnostics:
            print_diagnostic(d)
        out.print(f"[bold red]nothing exported[/]: {escape(target)}")
        sys.exit(exc.exit_code)
    out.print(f"  {'wrote' if written[path.name] else 'unchanged'} {escape(str(path))}")

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
@click.argument("what", type=click.Choice(["scxml"]))
@click.argument("target", default=".", type=click.Path())
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False),
    help="Output file (default build/<robot>/coordination.scxml).",
)
def export_command(what: str, target: str, output: str | None) -> None:
    """Export the robot's coordination statechart as W3C SCXML.

    Domain conditions and actions are kept in the namespace urn:motivml:coordination:1
    (see guidelines/coordinating-behaviour.md); the file is rewritten only when it changes.
    """
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

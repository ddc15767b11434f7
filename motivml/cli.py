"""The `motivml` command line: parse, call the library, print with rich, pick exit codes.

Exit codes: 0 valid, 1 invalid (model or configuration), 2 usage, 3 environment.
This is the only module that imports click or rich, and the only place that turns errors
into exit codes.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import NoReturn

import click
from rich.console import Console
from rich.markup import escape
from rich.tree import Tree

from . import __version__
from .check import Report, binding_states, load_configuration, load_model, validate
from .errors import Diagnostic, MotivmlError, Severity
from .model import Configuration, FeatureModel
from .robot import RobotFolder

out = Console(highlight=False, soft_wrap=True)
err = Console(stderr=True, highlight=False, soft_wrap=True)


def fail(exc: MotivmlError) -> NoReturn:
    """Print a library error (located) and exit with its code."""
    for diagnostic in exc.diagnostics:
        err.print(f"[bold red]{escape(_where(diagnostic))}[/]: {escape(diagnostic.message)}")
    sys.exit(exc.exit_code)


def _where(d: Diagnostic) -> str:
    return str(d.location)


def print_diagnostic(d: Diagnostic) -> None:
    colour = "red" if d.severity is Severity.ERROR else "yellow"
    out.print(
        f"[bold]{escape(str(d.location))}[/]: {escape(d.location.path)}: "
        f"[{colour}]{d.severity.value}[/]: {escape(d.message)}"
    )
    for fact in d.facts:
        out.print(f"    [dim]{escape(str(fact.location))}: {escape(fact.text)}[/]")


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="motivml")
def main() -> None:
    """motivml: variability models for robot software (MoTiVML)."""


def _targets(target: str, config: str | None, variant: str | None) -> tuple[Path, list[Path | None]]:
    """The model file and the configurations a `validate`/`show` call is about."""
    path = Path(target)
    if path.is_dir():
        robot = RobotFolder.open(path)
        if config is not None:
            return robot.model_path, [Path(config)]
        if variant is not None:
            return robot.model_path, [robot.variant_path(variant)]
        return robot.model_path, [None, *(robot.variant_path(n) for n in robot.variant_names())]
    if variant is not None:
        raise click.UsageError("--variant needs a robot folder (model.json, variants/NAME.json), not a file")
    return path, [Path(config) if config else None]


@main.command("validate")
@click.argument("target", default=".", type=click.Path())
@click.option(
    "--config", "config", type=click.Path(), help="A configuration file to check against the model."
)
@click.option("--variant", help="A variant of the robot folder: variants/NAME.json.")
@click.option("--partial", is_flag=True, help="Accept features without an entry (left to the configurator).")
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text", show_default=True)
def validate_command(target: str, config: str | None, variant: str | None, partial: bool, fmt: str) -> None:
    """Check a feature model, or a configuration (variant) of it.

    TARGET is a model.json or a robot folder (default: the current folder). A robot folder
    without --variant checks the model and every variant in variants/.
    """
    try:
        model_path, configs = _targets(target, config, variant)
        reports = [(c, validate(model_path, c, partial)) for c in configs]
    except MotivmlError as exc:
        fail(exc)
    valid = all(r.valid for _, r in reports)
    if fmt == "json":
        out.print_json(
            json.dumps(
                {
                    "valid": valid,
                    "errors": [d.as_dict() for _, r in reports for d in r.errors],
                    "warnings": [d.as_dict() for _, r in reports for d in r.warnings],
                }
            )
        )
    else:
        for _, report in reports:
            for d in report.errors + report.warnings:
                print_diagnostic(d)
        for c, report in reports:
            _verdict(model_path, c, report)
    sys.exit(0 if valid else 1)


def _verdict(model_path: Path, config: Path | None, report: Report) -> None:
    what = f"{model_path}" if config is None else f"{config}"
    counts = f"{len(report.errors)} error{'s' * (len(report.errors) != 1)}, {len(report.warnings)} warning{'s' * (len(report.warnings) != 1)}"
    if report.valid:
        extra = ""
        if config is None and report.model is not None:
            extra = f" ({len(report.model.features)} features)"
        elif report.open_bindings:
            extra = f" ({report.open_bindings} bindings left to the configurator)"
        out.print(f"[bold green]valid[/]: {escape(what)}{escape(extra)}, {counts}")
    else:
        kind = "model" if config is None else "configuration"
        out.print(f"[bold red]invalid[/]: {escape(what)}: {counts} in the {kind}")


@main.command("show")
@click.argument("target", default=".", type=click.Path())
@click.option("--config", "config", type=click.Path(), help="A configuration file.")
@click.option("--variant", help="A variant of the robot folder: variants/NAME.json.")
def show_command(target: str, config: str | None, variant: str | None) -> None:
    """Print the feature tree with groups, allowed, configured and forced bindings."""
    try:
        model_path, configs = _targets(target, config, variant)
        chosen = configs[0] if variant or config else None
        model, diagnostics = load_model(model_path)
        if model is None:
            for d in diagnostics:
                print_diagnostic(d)
            sys.exit(1)
        configuration: Configuration | None = None
        if chosen is not None:
            report = validate(model_path, chosen, partial=True)
            if not report.valid:
                for d in report.errors:
                    print_diagnostic(d)
                out.print("[bold red]invalid[/]: nothing to show (fix the errors above)")
                sys.exit(1)
            configuration, _ = load_configuration(chosen, model, partial=True)
        states = binding_states(model, configuration)
    except MotivmlError as exc:
        fail(exc)
    # A tree cannot soft-wrap: on a terminal it wraps at its width, into a pipe it stays whole.
    tree_console = out if out.is_terminal else Console(highlight=False, width=max(out.width, 240))
    tree_console.print(_tree(model, configuration, states))
    out.print(
        "[dim]marks: ! mandatory, ? optional, [OR]/[XOR] group member; allowed = mode/time a feature allows; "
        "set = what the configuration says; solver = what valid variants leave (one value: forced)[/]"
    )


def _tree(model: FeatureModel, config: Configuration | None, states: list[set[str]]) -> Tree:
    nodes: dict[int, Tree] = {}
    root_tree: Tree | None = None
    for f in model.features:
        if f.parent is None:
            mark = ""
        elif f.group:
            mark = f"[magenta][{f.group}][/] "
        else:
            mark = "[bold]![/] " if f.mandatory else "? "
        allowed = f"allowed {_short(f.mode_allowed)}{_short(f.time_allowed)}"
        configured = ""
        if config is not None:
            entry = config.entries.get(f.id)
            if entry is None:
                configured = " set —" if f.parent is not None else ""
            elif not entry.selected:
                configured = " set off"
            else:
                configured = f" set {_short(entry.mode)}{_short(entry.time)}"
        possible = states[f.index]
        order = ["off", "SE", "SL", "DE", "DL"]
        solver = ",".join(s for s in order if s in possible) or "none"
        colour = "green" if len(possible) == 1 else "cyan"
        label = (
            f"{mark}[bold]{escape(f.id)}[/] [dim]({escape(f.name)})[/]  {allowed}{configured}  "
            f"solver [{colour}]{solver}[/]"
        )
        if f.parent is None:
            root_tree = Tree(label)
            nodes[f.index] = root_tree
        else:
            nodes[f.index] = nodes[f.parent].add(label)
    assert root_tree is not None
    return root_tree


def _short(token: str) -> str:
    return {"Static": "S", "Dynamic": "D", "Early": "E", "Late": "L", "Any": "*"}[token]


if __name__ == "__main__":
    main()

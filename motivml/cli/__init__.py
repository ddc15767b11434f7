"""The `motivml` command line: parse, call the library, print with rich, pick exit codes.

Exit codes: 0 valid, 1 invalid (model or configuration), 2 usage, 3 environment.
This package is the only place that imports click or rich, and the only place that turns
errors into exit codes. One module per family of commands:

* `checking`: validate, show, configure, diff (the model and its variants);
* `running`: run and ctl (the robot at run time);
* `drawing`: graph and export (pictures and SCXML).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import NoReturn

import click
from rich.console import Console
from rich.markup import escape

from .. import __version__
from ..documents.robot_folder import RobotFolder
from ..errors import Diagnostic, MotivmlError, Severity

out = Console(highlight=False, soft_wrap=True, emoji=False)
err = Console(stderr=True, highlight=False, soft_wrap=True, emoji=False)


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


def _targets(target: str, config: str | None, variant: str | None) -> tuple[Path, list[Path], bool]:
    """The model file, the configurations a call is about, and whether to analyse the model.

    The model is analysed (dead features, bindings never possible) when it is checked on
    its own or with every variant of its folder, not when one variant is asked about.
    """
    if config is not None and variant is not None:
        raise click.UsageError("give --config FILE or --variant NAME, not both")
    path = Path(target)
    if path.is_dir():
        robot = RobotFolder.open(path)
        if config is not None:
            return robot.model_path, [Path(config)], False
        if variant is not None:
            return robot.model_path, [robot.variant_path(variant)], False
        return robot.model_path, [robot.variant_path(n) for n in robot.variant_names()], True
    if variant is not None:
        raise click.UsageError("--variant needs a robot folder (model.json, variants/NAME.json), not a file")
    return path, [Path(config)] if config else [], config is None


def _plural(count: int, word: str) -> str:
    return f"{count} {word}{'s' * (count != 1)}"


# The commands register themselves on `main` when their modules are imported.
from . import checking, drawing, running  # noqa: E402,F401

"""What every command shares: the consoles, printing diagnostics, the exit on an error, targets."""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

import click
from rich.console import Console
from rich.markup import escape

from ..documents.robot_folder import MODEL_FILE, VARIANTS_FOLDER, RobotFolder
from ..errors import Diagnostic, EnvironmentProblem, Location, MotivmlError, Severity, error, repair_text


class _Console(Console):
    """rich's Console, whose `print` spells out the control characters of the strings it
    is given, line by line (`printable`): every line motivml prints to the terminal goes
    through one of the two below, so no name (a file's, a feature's, a plugin's) reaches
    the terminal raw, whether or not its caller spelt it out."""

    def print(self, *objects: Any, **options: Any) -> None:
        super().print(*(_lines_printable(o) if isinstance(o, str) else o for o in objects), **options)


def _lines_printable(text: str) -> str:
    if text.isprintable():
        return text
    return "\n".join(map(printable, text.split("\n")))


out = _Console(highlight=False, soft_wrap=True, emoji=False)
err = _Console(stderr=True, highlight=False, soft_wrap=True, emoji=False)


def fail(exc: MotivmlError) -> NoReturn:
    """Print a library error (located) and exit with its code."""
    for diagnostic in exc.diagnostics:
        err.print(f"[bold red]{escape(str(diagnostic.location))}[/]: {escape(diagnostic.message)}")
    sys.exit(exc.exit_code)


def environment_problem(exc: OSError) -> EnvironmentProblem:
    """An OSError no stage turned into a located error (a permission, a name too long): exit 3."""
    place = os.fsdecode(exc.filename) if exc.filename is not None else "motivml"
    return EnvironmentProblem(error(Location(place), f"cannot read: {exc.strerror or exc}", "io"))


def print_diagnostics(diagnostics: Sequence[Diagnostic]) -> None:
    """Diagnostics in order. Conflicts of one configuration share its repairs (each repair
    fixes the whole configuration): they are printed once, under the last of them.

    All in one print: rich's own work per call is most of the time (16 ms for 104
    diagnostics of 222 lines, one call a line)."""
    lines: list[str] = []
    for k, d in enumerate(diagnostics):
        following = diagnostics[k + 1] if k + 1 < len(diagnostics) else None
        lines += _diagnostic_lines(d, repairs=following is None or following.repairs != d.repairs)
    if lines:
        out.print("\n".join(lines))


def _diagnostic_lines(d: Diagnostic, repairs: bool) -> list[str]:
    """A diagnostic's lines, in rich markup."""
    colour = "red" if d.severity is Severity.ERROR else "yellow"
    lines = [
        f"[bold]{escape(str(d.location))}[/]: {escape(d.location.path)}: "
        f"[{colour}]{d.severity.value}[/]: {escape(d.message)}"
    ]
    lines += (f"    [dim]{escape(str(fact.location))}: {escape(fact.text)}[/]" for fact in d.facts)
    if repairs and d.repairs:
        many = len(d.repairs) > 1
        lines.append(f"    [cyan]to repair{', one of' if many else ''}:[/]")
        lines += (f"      [cyan]- {escape(repair_text(repair))}[/]" for repair in d.repairs)
    return lines


def targets(target: str, config: str | None, variant: str | None) -> tuple[Path, list[Path], bool]:
    """The model file, the configurations a call is about, and whether to analyse the model.

    The model is analysed (dead features, bindings never possible) when it is checked on
    its own or with every variant of its folder, not when one variant is asked about.
    """
    _not_both(config, variant)
    path = Path(target)
    if path.is_dir():
        robot = RobotFolder.open(path)
        if config is not None:
            return robot.model_path, [Path(config)], False
        if variant is not None:
            return robot.model_path, [robot.variant_path(variant)], False
        return robot.model_path, [robot.variant_path(n) for n in robot.variant_names()], True
    if variant is not None:
        raise click.UsageError(
            f"--variant needs a robot folder ({MODEL_FILE}, {VARIANTS_FOLDER}/NAME.json), not a file"
        )
    return path, [Path(config)] if config else [], config is None


def one_variant(config: str | None, variant: str | None) -> str:
    """For a command about one variant (configure, run): exactly one of --config FILE and
    --variant NAME, and the name the variant goes by, NAME or FILE's stem (as the lock file,
    the output folder and the run's registration name it)."""
    _not_both(config, variant)
    if variant is not None:
        name = variant
    elif config is None:
        raise click.UsageError("give --variant NAME (variants/NAME.json of the robot folder) or --config FILE")
    else:
        name = Path(config).stem
    # (a folder and a registration are named by it: build/ROBOT/. was build/ROBOT itself;
    # a --variant name is checked against the robot folder's own rule where it is opened)
    if config is not None and name in ("", ".", ".."):
        raise click.UsageError(f"--config {config!r}: a variant's name ({name!r}) must be a plain file name")
    return name


def _not_both(config: str | None, variant: str | None) -> None:
    """--config FILE and --variant NAME both name the configuration: one at most."""
    if config is not None and variant is not None:
        raise click.UsageError("give --config FILE or --variant NAME, not both")


def printable(text: str) -> str:
    """Text from a document, a plugin or a socket client as it may reach a terminal:
    control characters (escape sequences, carriage returns) spelled out."""
    if text.isprintable():
        return text
    return "".join(ch if ch.isprintable() else ch.encode("unicode_escape").decode() for ch in text)


def shown(text: str) -> str:
    """Outside text ready for rich: control characters spelled out, markup escaped."""
    return escape(printable(text))


def plural(count: int, word: str) -> str:
    return f"{count} {word}{'s' * (count != 1)}"


MAX_SECONDS = 1e9  # a longer duration (31 years) is a usage error; inf is allowed where it means "no limit"


class Number(click.FloatRange):
    """A FloatRange that refuses nan (which passes every comparison) and, unless allowed,
    infinity; an allowed infinity passes whatever the maximum (it means "no limit"), and a
    finite number above the maximum is refused as any out-of-range number is."""

    def __init__(self, *, allow_inf: bool = False, **limits: Any) -> None:
        super().__init__(**limits)
        self.allow_inf = allow_inf

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        number = click.FLOAT.convert(value, param, ctx)
        # (only "inf" means no limit: 1e999 overflows to infinity, and ran until stopped)
        spelled = str(value).strip().lower().lstrip("+") in ("inf", "infinity")
        if math.isnan(number) or (math.isinf(number) and not (self.allow_inf and spelled)):
            self.fail(f"{value!r} is not a finite number" + (" (inf: no limit)" if self.allow_inf else ""), param, ctx)
        if math.isinf(number) and number > 0:
            return number
        return super().convert(number, param, ctx)

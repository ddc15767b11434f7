"""motivml menuconfig: a keyboard-driven terminal configurator (Textual).

The feature tree with each feature's selection, mode and time: what you decided in bold,
what the model and your decisions force dimmed (locked), what is left open as `*`. Every
change is propagated at once (`binding.configurator.Configurator`); a change that leaves no
valid variant shows the conflict and its repairs, and a digit applies one. `?` says why the
feature under the cursor is what it is. `s` saves the decisions file, atomically.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from ..errors import MotivmlError
from .common import fail, one_variant, targets

EXIT_INTERRUPTED = 130  # what a shell reports for a process ended by Ctrl-C (SIGINT)

if TYPE_CHECKING:
    from ..binding.configurator import Configurator

HINT = "[x]/[ ] yours  -x-/--- forced  ( ) open; in bold yours, dim forced, * open; space cycles"


@click.command("menuconfig")
@click.argument("target", default=".", type=click.Path(readable=False))
@click.option("--variant", help="The variant of the robot folder to edit: variants/NAME.json (new or not).")
@click.option("--config", "config", type=click.Path(readable=False), help="A configuration file to edit (new or not).")
@click.option(
    "--prefer",
    multiple=True,
    type=click.Choice(["late", "dynamic"]),
    help="What configure will prefer for open bindings (for the answers of ?).",
)
def menuconfig_command(target: str, variant: str | None, config: str | None, prefer: tuple[str, ...]) -> None:
    """Configure a variant interactively, in the terminal.

    TARGET is a robot folder or a model.json. The decisions are saved (s) to the variant's
    file as a decisions file ("partial": true): only what you decided; configure completes
    it. The file may be new; an existing one is read first, each entry a decision.
    """
    import sys

    one_variant(config, variant)  # exactly one: the file the decisions are saved to
    try:
        session, path = open_session(target, variant, config, prefer)
    except MotivmlError as exc:
        fail(exc)
    if not _on_a_terminal():
        raise click.UsageError("menuconfig needs a terminal (stdin and stdout)")
    app = MenuConfig(session, path)
    app.run()
    if app.return_code == EXIT_INTERRUPTED:
        click.echo("interrupted", err=True)
    if app.return_code:  # (Ctrl-C, SIGTERM, SIGHUP: unsaved decisions are not saved)
        sys.exit(app.return_code)


def _on_a_terminal() -> bool:
    import sys

    return sys.stdin.isatty() and sys.stdout.isatty()


def open_session(
    target: str, variant: str | None, config: str | None, prefer: tuple[str, ...] = ()
) -> tuple[Configurator, Path]:
    """The session on TARGET's model, begun from the variant file if it exists, and that file."""
    from ..binding.configurator import Configurator
    from ..documents.robot_folder import VARIANTS_FOLDER, RobotFolder
    from ..errors import DocumentError
    from ..language.reader import load_configuration, load_model

    one_variant(config, variant)
    if variant is not None:
        if not Path(target).is_dir():
            raise click.UsageError(
                "--variant needs a robot folder (model.json, variants/NAME.json), not a file"
            )
        if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]*", variant):
            raise click.BadParameter(
                "a variant's name is letters, digits, '_', '.' and '-'", param_hint="'--variant'"
            )
        folder = RobotFolder.open(Path(target))
        model_path = folder.model_path
        path = folder.path / VARIANTS_FOLDER / f"{variant}.json"
    else:
        model_path, _, _ = targets(target, None, None)
        assert config is not None
        path = Path(config)
    model, problems = load_model(model_path)
    if model is None:
        raise DocumentError(problems)
    start = None
    extra: dict[str, object] = {}
    if path.exists():
        start, problems = load_configuration(path, model, partial=True)
        if start is None:
            raise DocumentError(problems)
        root = start.source.root if start.source is not None else {}
        extra = {k: v for k, v in root.items() if isinstance(k, str) and k.startswith("x-")}
    session = Configurator(model, str(path), start, extra, prefer)
    session.beside = model_path.parent
    session.saved_text = session.text() if path.exists() else None
    return session, path


def MenuConfig(session: Configurator, path: Path) -> Any:  # noqa: N802 - builds the app
    """The application for a session, saving to `path` (Textual imported now)."""
    from .menuconfig_app import MenuConfigApp

    return MenuConfigApp(session, path)

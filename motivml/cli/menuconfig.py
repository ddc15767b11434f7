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
from typing import TYPE_CHECKING, Any, ClassVar

import click

from ..errors import MotivmlError, repair_text
from .common import fail, one_variant, plural, targets

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
    session.saved_text = session.text() if path.exists() else None
    return session, path


def _app_class() -> Any:
    """The Textual application class (Textual imported only when menuconfig runs)."""
    from rich.text import Text
    from textual.app import App, ComposeResult
    from textual.binding import Binding
    from textual.containers import VerticalScroll
    from textual.widgets import Footer, Header, Static, Tree

    from ..language.model import OFF, Mode, Time
    from ..language.model import Binding as FeatureBinding

    class FeatureTree(Tree[str]):
        BINDINGS: ClassVar[list[Any]] = [Binding("space", "app.cycle", "select", show=False)]

    class App_(App[None]):
        CSS = """
        FeatureTree { height: 1fr; }
        #detail { height: 8; border-top: solid $accent; padding: 0 1; }
        """
        TITLE = "motivml menuconfig"
        BINDINGS: ClassVar[list[Any]] = [
            Binding("y", "select(True)", "yes"),
            Binding("n", "select(False)", "no"),
            Binding("u", "clear", "undecide"),
            Binding("t", "time", "time"),
            Binding("m", "mode", "mode"),
            Binding("question_mark", "why", "why"),
            Binding("s", "save", "save"),
            Binding("q", "quit_menu", "quit"),
            # Ctrl+Q as q (Textual's own quit lost unsaved decisions at once); Ctrl-C, which
            # a terminal application gets as a key, ends it as an interrupt does elsewhere
            Binding("ctrl+q", "quit_menu", show=False, priority=True),
            Binding("ctrl+c", "interrupt", show=False, priority=True),
            *(Binding(str(k), f"repair({k})", show=False) for k in range(1, 6)),
        ]

        def __init__(self, session: Configurator, path: Path) -> None:
            super().__init__()
            self.session = session
            self.path = path
            self.nodes: dict[str, Any] = {}
            self.leaving = False
            self.sub_title = str(path)

        def compose(self) -> ComposeResult:
            yield Header()
            yield FeatureTree(self._label(0), id="features")
            with VerticalScroll(id="detail"):
                yield Static(id="text")
            yield Footer()

        def on_mount(self) -> None:
            import asyncio
            import signal

            # SIGTERM and SIGHUP end the application as q would, without asking: Textual
            # then gives the terminal back (they left it in the alternate screen with mouse
            # reporting on). The exit code says which signal (128 + its number).
            loop = asyncio.get_running_loop()
            for signum in (signal.SIGTERM, signal.SIGHUP):
                try:
                    loop.add_signal_handler(signum, self.exit, None, 128 + signum)
                except (NotImplementedError, RuntimeError, ValueError):  # (not the main thread: a test's)
                    pass
            tree = self.query_one(FeatureTree)
            model = self.session.model
            tree.root.data = model.features[0].id
            self.nodes[model.features[0].id] = tree.root
            for f in model.features[1:]:
                assert f.parent is not None
                parent = self.nodes[model.features[f.parent].id]
                label = self._label(f.index)
                self.nodes[f.id] = (
                    parent.add(label, data=f.id, expand=True)
                    if f.children
                    else parent.add_leaf(label, data=f.id)
                )
            tree.root.expand()
            tree.focus()
            self._show_status()

        # ------------------------------------------------------------- drawing
        def _label(self, i: int) -> Any:
            session = self.session
            f = session.model.features[i]
            decided = session.decided(f.id)
            possible = session.possible(f.id)
            bindings = [s for s in possible if s != OFF]
            text = Text()
            if f.parent is None:
                text.append("-x-", "dim")
            elif decided.selected is True:
                text.append("[x]", "bold")
            elif decided.selected is False:
                text.append("[ ]", "bold")
            elif not session.valid:
                text.append("( )")
            elif OFF not in possible:
                text.append("-x-", "dim")
            elif not bindings:
                text.append("---", "dim")
            else:
                text.append("( )")
            mark = f"[{f.group}] " if f.group else "" if f.parent is None or f.mandatory else "? "
            text.append(f" {mark}{f.id}")
            selectable = decided.selected is not False and (bindings or not session.valid)
            if selectable:
                text.append("  ")
                for said, values in (
                    (decided.mode, {FeatureBinding(b).mode for b in bindings}),
                    (decided.time, {FeatureBinding(b).time for b in bindings}),
                ):
                    if said is not None:
                        text.append(said.value[0], "bold")
                    elif len(values) == 1:
                        text.append(next(iter(values)).value[0], "dim")
                    else:
                        text.append("*")
            return text

        def _redraw(self) -> None:
            for f in self.session.model.features:
                self.nodes[f.id].set_label(self._label(f.index))
            self._show_status()

        def _detail(self, text: Any) -> None:
            self.query_one("#text", Static).update(text)

        def _show_status(self) -> None:
            session = self.session
            text = Text()
            if session.valid:
                chosen = sum(1 for s in session.states if OFF not in s)
                text.append("valid", "bold green")
                text.append(
                    f": {plural(len(session.decisions), 'decision')}, {plural(chosen, 'feature')} selected "
                    "in every variant they allow\n"
                )
                text.append(HINT, "dim")
            else:
                first = session.problems[0]
                text.append("no valid variant", "bold red")
                text.append(f": {first.message}\n")
                if session.repairs:
                    text.append("repairs (press the digit):\n", "dim")
                    for k, repair in enumerate(session.repairs, 1):
                        text.append(f"{k}", "bold cyan")
                        text.append(f" {repair_text(repair)}\n")
                else:
                    text.append("no change to the decisions helps: the model has no valid variant\n")
            self._detail(text)

        def _feature(self) -> str | None:
            node = self.query_one(FeatureTree).cursor_node
            fid = None if node is None else node.data
            if fid is None or self.session.model.index[fid] == 0:
                self.notify("the root is always selected, Static and Early (rule 2.1)", severity="warning")
                return None
            return fid

        # ------------------------------------------------------------- actions
        def action_cycle(self) -> None:
            fid = self._feature()
            if fid is not None:
                now = self.session.decided(fid).selected
                self._change(lambda: self.session.select(fid, {None: True, True: False, False: None}[now]))

        def action_select(self, value: bool | None) -> None:
            fid = self._feature()
            if fid is not None:
                self._change(lambda: self.session.select(fid, value))

        def action_clear(self) -> None:
            fid = self._feature()
            if fid is not None:
                self._change(lambda: self.session.clear(fid))

        def action_time(self) -> None:
            fid = self._feature()
            if fid is not None:
                d = self.session.decided(fid)
                after = {None: Time.EARLY, Time.EARLY: Time.LATE, Time.LATE: None}[d.time]
                self._change(lambda: self.session.bind(fid, after, d.mode))

        def action_mode(self) -> None:
            fid = self._feature()
            if fid is not None:
                d = self.session.decided(fid)
                after = {None: Mode.STATIC, Mode.STATIC: Mode.DYNAMIC, Mode.DYNAMIC: None}[d.mode]
                self._change(lambda: self.session.bind(fid, d.time, after))

        def action_repair(self, k: int) -> None:
            repairs = self.session.repairs
            if not 1 <= k <= len(repairs):
                self.notify(f"there is no repair {k}", severity="warning")
                return
            self._change(lambda: self.session.apply(repairs[k - 1]))

        def action_why(self) -> None:
            node = self.query_one(FeatureTree).cursor_node
            if node is None or node.data is None:
                return
            if not self.session.valid:
                self.notify("the decisions conflict: repair them first (1-5)", severity="warning")
                return
            text = Text()
            for reason in self.session.why(node.data):
                text.append(reason.statement, "bold")
                text.append(f": {reason.because}\n")
                for fact in reason.facts:
                    text.append(f"  {fact.location}: {fact.text}\n", "dim")
            self._detail(text)

        def action_save(self) -> None:
            from ..documents.writing import write_if_changed

            if not self.session.valid:
                self.notify(
                    "not saved: the decisions have no valid variant (apply a repair: 1-5)", severity="error"
                )
                return
            try:
                write_if_changed(self.path.parent, {self.path.name: self.session.text()})
            except MotivmlError as exc:
                self.notify(exc.diagnostics[0].message, title="not saved", severity="error")
                return
            self.session.saved()
            self.notify(f"saved {self.path}")

        def action_interrupt(self) -> None:
            self.exit(None, EXIT_INTERRUPTED)

        def action_quit_menu(self) -> None:
            if self.session.unsaved and not self.leaving:
                self.leaving = True
                self.notify(
                    "unsaved decisions: s saves them, q again quits without saving", severity="warning"
                )
                return
            self.exit()

        def _change(self, change: Any) -> None:
            self.leaving = False
            try:
                change()
            except MotivmlError as exc:  # cannot happen with the session's own documents
                self.notify(exc.diagnostics[0].message, severity="error")
            self._redraw()

    return App_


def MenuConfig(session: Configurator, path: Path) -> Any:  # noqa: N802 - builds the app
    """The application for a session, saving to `path`."""
    return _app_class()(session, path)

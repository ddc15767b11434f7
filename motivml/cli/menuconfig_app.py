"""The Textual application of `motivml menuconfig` (menuconfig.py): the feature tree, its
detail pane and the keys. A module of its own so that Textual is imported only when the
configurator runs (menuconfig.py imports this inside `MenuConfig`)."""

from __future__ import annotations

import threading
from collections.abc import Iterable
from pathlib import Path
from typing import Any, ClassVar

from rich.text import Text
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.containers import VerticalScroll
from textual.widgets import Footer, Header, Input, Static, Tree

from ..binding.configurator import Configurator, Propagated
from ..errors import MotivmlError, repair_text
from ..language.model import OFF, FeatureModel, Mode, Time
from ..language.model import Binding as FeatureBinding
from .common import plural
from .menuconfig import EXIT_INTERRUPTED, HINT


class FeatureTree(Tree[str]):
    """The feature tree: space cycles the feature under the cursor (as `y`, `n`, `u`)."""

    BINDINGS: ClassVar[list[Any]] = [Binding("space", "app.cycle", "select", show=False)]


class Search(Input):
    """`/`, as in Kconfig's menuconfig: ids and names that hold the text typed (any case),
    listed as it is typed; Enter jumps to the next match after the cursor and gives the keys
    back to the tree (`/` then Enter goes on to the next), Escape closes."""

    BINDINGS: ClassVar[list[Any]] = [Binding("escape", "close", "close", show=False)]
    SHOWN = 6  # matches listed in the detail panel

    def __init__(self, model: FeatureModel) -> None:
        super().__init__(placeholder="search ids and names (Enter: next match, Escape: close)", id="search")
        self.model = model
        self.display = False

    def matches(self) -> list[int]:
        text = self.value.strip().casefold()
        if not text:
            return []
        return [f.index for f in self.model.features if text in f.id.casefold() or text in f.name.casefold()]

    def on_input_changed(self, event: Input.Changed) -> None:
        found = self.matches()
        listed = Text()
        if not self.value.strip():
            listed.append("type part of an id or a name", "dim")
        elif not found:
            listed.append(f"no feature's id or name holds {self.value.strip()!r}", "yellow")
        else:
            listed.append(f"{len(found)} {'match' if len(found) == 1 else 'matches'}", "bold")
            listed.append(" (Enter jumps to the first one after the cursor)\n")
            for i in found[: self.SHOWN]:
                listed.append(self._where(i) + "\n")
            if len(found) > self.SHOWN:
                listed.append(f"... and {len(found) - self.SHOWN} more\n", "dim")
        app = self.app
        assert isinstance(app, MenuConfigApp)
        app._detail(listed)

    def _where(self, i: int) -> str:
        """A feature with the path down to it: "kartoslam (KartoSLAM) in root > slam"."""
        f = self.model.features[i]
        path: list[str] = []
        parent = f.parent
        while parent is not None and len(path) < 4:
            path.append(self.model.features[parent].id)
            parent = self.model.features[parent].parent
        name = f" ({f.name})" if f.name != f.id else ""
        return f"{f.id}{name} in {' > '.join(reversed(path))}" if path else f"{f.id}{name}"

    def on_input_submitted(self, event: Input.Submitted) -> None:
        found = self.matches()
        if not found:
            self.app.bell()
            return
        tree = self.app.query_one(FeatureTree)
        here = tree.cursor_node.data if tree.cursor_node is not None else None
        after = self.model.index.get(here, -1) if isinstance(here, str) else -1
        target = next((i for i in found if i > after), found[0])
        app = self.app
        assert isinstance(app, MenuConfigApp)
        app.jump_to(self.model.features[target].id)
        self.action_close()  # (the keys are the tree's again; / and Enter go on to the next match)

    def action_close(self) -> None:
        self.display = False
        self.app.query_one(FeatureTree).focus()
        app = self.app
        assert isinstance(app, MenuConfigApp)
        app.redraw()  # (the panel shows the session again, not the matches)


class Propagation:
    """A decision's consequences, worked out off the UI thread on a large model (LARGE
    features or more; a smaller one propagates in milliseconds, at once): the key press
    redraws the decision at once, the title and the panel say "propagating" once
    propagations have been under way for MARK_AFTER seconds (from the first of a burst of
    key presses) and until the last one's consequences come, and a later decision's
    consequences replace an earlier one's, which are dropped when they come (the session's
    one encoding answers them in turn).

    (The mark is not drawn at once: drawing it and taking it back were two frames of
    Textual's, some 10 ms each at Automotive01's 2,513 features, drawn on the UI thread
    while the propagation waited for Python's lock, for consequences that most often come
    within a key press's 100 ms.)"""

    LARGE = 300
    MARK_AFTER = 0.1  # s

    def __init__(self, app: MenuConfigApp) -> None:
        self.app = app
        self.asked = 0  # decisions sent to be propagated; the last one's answer is taken
        self.busy = False
        self.marked = False  # "propagating" shown
        self.turn = threading.Lock()
        self._timer: Any = None

    def start(self) -> None:
        app = self.app
        self.asked += 1
        asked, decisions = self.asked, dict(app.session.decisions)
        self.busy = True
        if self._timer is None and not self.marked:
            self._timer = app.set_timer(self.MARK_AFTER, self._mark)
        app.run_worker(lambda: self._work(decisions, asked), thread=True, group="propagate")

    def _mark(self) -> None:
        self._timer = None
        if self.busy:
            self.marked = True
            self.app.sub_title = f"{self.app.path}  (propagating...)"
            self.app._show_status()

    def _unmark(self) -> None:
        self.busy = False
        if self._timer is not None:
            self._timer.stop()
            self._timer = None
        if self.marked:
            self.marked = False
            self.app.sub_title = str(self.app.path)

    def _work(self, decisions: dict[str, Any], asked: int) -> None:
        with self.turn:  # (one propagation at a time; one whose decision is no longer the last is skipped)
            if asked != self.asked:
                return
            try:
                found = self.app.session.propagate(decisions)
            except Exception as exc:  # (a bug: said, and the session stays as it was)
                self.app.call_from_thread(self._failed, f"propagation failed: {exc}", asked)
                return
        self.app.call_from_thread(self._done, found, asked)

    def _failed(self, said: str, asked: int) -> None:
        self.app.notify(said, severity="error")
        if asked == self.asked:
            self._unmark()
            self.app.redraw()

    def _done(self, found: Propagated, asked: int) -> None:
        if asked != self.asked:
            return  # (a later decision's answer is on its way)
        self._unmark()
        self.app.session.install(found)
        self.app.redraw()

    def waiting(self) -> bool:
        """True (and said) while the last decision is being propagated."""
        if self.busy:
            self.app.notify("the last decision is still being propagated: a moment", severity="warning")
        return self.busy


class LiveCounts:
    """The variants the decisions leave and each open feature's share of them, from the
    model's compiled form (`motivml compile`): a kept form of the variants is read at once;
    else one of the selections and then one of the variants are made in the background (each
    within COMPILE_LIMIT seconds), and the counts appear when one is at hand."""

    COMPILE_LIMIT = 60.0

    def __init__(self, app: MenuConfigApp, beside: Path | None) -> None:
        self.app = app
        self.beside = beside
        self.said = "live counts: reading the compiled form..."
        self.leaving = threading.Event()  # set when the application ends: a compile under way stops

    def stop(self) -> None:
        self.leaving.set()

    def start(self) -> None:
        self.app.run_worker(self._work, thread=True, group="compile")

    def _work(self) -> None:
        from ..binding.compiled import CompiledForm, Kind, NotCompiled, compiled_form

        model = self.app.session.model
        try:
            form = compiled_form(model, self.beside, Kind.VARIANTS, make=False)
            if isinstance(form, CompiledForm):
                self.app.call_from_thread(self._installed, form, "")
                return
            self.app.call_from_thread(self._say, "live counts: compiling the model (motivml compile)...")
            installed = False
            for kind in (Kind.SELECTIONS, Kind.VARIANTS):
                form = compiled_form(model, self.beside, kind, self.COMPILE_LIMIT, stop=self.leaving.is_set)
                if self.leaving.is_set():
                    return
                if isinstance(form, CompiledForm):
                    upgrade = " (compiling the variants...)" if kind is Kind.SELECTIONS else ""
                    self.app.call_from_thread(self._installed, form, upgrade)
                    installed = True
            if isinstance(form, NotCompiled):  # (the variants' compile, at least, was given up)
                said = (
                    f" (of selections: no form of the variants, {form.reason})"
                    if installed
                    else f"no live counts: no compiled form, {form.reason}"
                )
                self.app.call_from_thread(self._say, said)
        except Exception as exc:  # noqa: BLE001 - (a bug: said; the configurator works on without counts)
            self.app.call_from_thread(self._say, f"no live counts: {type(exc).__name__}: {exc}")

    def _say(self, said: str) -> None:
        self.said = said
        self.app.redraw()

    def _installed(self, form: Any, still: str) -> None:
        self.said = still
        self.app.session.form = form
        if self.app.session.deferred:
            self.app.propagation.start()
        else:
            self.app.session.refresh()
        self.app.redraw()


class Labels:
    """The tree's labels, each drawn from what the session says of its feature: the decision,
    the states the feature can take, whether the decisions are valid, its share of the
    variants left. Only a label whose feature changed is drawn again (each label set has
    Textual look for its node's lines: all 2,513 of Automotive01's, set after each
    decision, took some 250 ms of a key press)."""

    def __init__(self, session: Configurator) -> None:
        self.session = session
        self.drawn: dict[int, tuple[Any, ...]] = {}  # per feature, what its label was drawn from
        # what the session said when `changed` last looked: a feature whose label may have
        # changed since is one whose decision, states or share differ from these (or all,
        # when the validity differs); at 10,000 features, looking at every one's took 14 ms
        self._seen: tuple[Any, ...] | None = None

    def drawn_now(self, i: int) -> Text:
        """Feature i's label, remembered as drawn."""
        self.drawn[i] = self._drawn_from(i)
        return self.label(i)

    def changed(self) -> list[tuple[str, Text]]:
        """The features whose label is not what was drawn last, with their labels now."""
        drawn, key, features = self.drawn, self._drawn_from, self.session.model.features
        found: list[tuple[str, Text]] = []
        for i in self._candidates():
            now = key(i)
            if drawn.get(i) != now:
                drawn[i] = now
                found.append((features[i].id, self.label(i)))
        return found

    def _candidates(self) -> Iterable[int]:
        """The features whose label may differ from the one drawn (in tree order)."""
        session = self.session
        seen, self._seen = self._seen, (session.valid, session.states, dict(session.decisions), session.shares, session.left)
        if seen is None or seen[0] != session.valid:
            return range(len(session.model.features))
        _, states, decisions, shares, left = seen
        index = session.model.index
        found = {index[fid] for fid in decisions.keys() | session.decisions.keys() if decisions.get(fid) != session.decided(fid)}
        if states is not session.states:
            if len(states) != len(session.states):
                return range(len(session.model.features))
            found.update(i for i, (old, new) in enumerate(zip(states, session.states, strict=True)) if old != new)
        if shares is not session.shares or left != session.left:
            if shares is None or session.shares is None or len(shares) != len(session.shares):
                return range(len(session.model.features))
            found.update(i for i, (old, new) in enumerate(zip(shares, session.shares, strict=True)) if old != new)
        return sorted(found)

    def _drawn_from(self, i: int) -> tuple[Any, ...]:
        session = self.session
        fid = session.model.features[i].id
        decided = session.decided(fid)
        shares = session.shares
        # (the share as shown: most open features' shares change a little with each
        # decision, and their labels did not: setting them all made a key press on
        # Automotive01 with live counts 110 ms, p95, where it is 82 ms)
        share = _share(shares[i]) if decided.selected is None and shares and session.left else None
        return decided, frozenset(session.possible(fid)), session.valid, share

    def label(self, i: int) -> Text:
        """Feature i's label, as the session has it now."""
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
        return _with_share(text, session, i) if decided.selected is None else text


def _with_share(text: Text, session: Configurator, i: int) -> Text:
    """An open feature's label with its share of the variants left, when they are counted."""
    shares = session.shares
    share = _share(shares[i]) if session.left and shares is not None else ""
    if share:
        text.append(f"  {share}", "cyan")
    return text


def _share(share: float) -> str:
    """A feature's share of the variants left, as a percentage ('' when forced either way)."""
    if share in (0.0, 1.0):
        return ""
    percent = 100 * share
    return "<1%" if percent < 1 else ">99%" if percent > 99 else f"{percent:.0f}%"


class MenuConfigApp(App[None]):
    """menuconfig's application: a Configurator shown as a tree, changed by keys, saved to a path."""

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
        Binding("slash", "search", "search"),
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
        self.labels = Labels(session)
        self.detail_shown: Any = None  # what the panel shows
        self.leaving = False
        self.sub_title = str(path)
        self.propagation = Propagation(self)
        self.counts = LiveCounts(self, session.beside)
        session.deferred = len(session.model.features) >= Propagation.LARGE

    def compose(self) -> ComposeResult:
        yield Header()
        yield FeatureTree(self.labels.drawn_now(0), id="features")
        yield Search(self.session.model)
        with VerticalScroll(id="detail"):
            yield Static(id="text")
        yield Footer()

    def on_unmount(self) -> None:
        self.counts.stop()  # (else leaving waits for a compile in the background to end)
        import gc

        gc.unfreeze()  # (what `on_mount` froze can go, as the session's objects go)

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
            label = self.labels.drawn_now(f.index)
            self.nodes[f.id] = (
                parent.add(label, data=f.id, expand=True)
                if f.children
                else parent.add_leaf(label, data=f.id)
            )
        tree.root.expand()
        tree.focus()
        self._show_status()
        # What lives as long as the session (the model, its encoding, the tree's nodes and
        # widgets) is moved out of the collector's way: each full collection walked it all
        # again, some 40 ms of a decision's propagation at Automotive01's 2,513 features
        # (p95 115 -> 76 ms). What is made from now on is collected as usual.
        import gc

        gc.collect()
        gc.freeze()
        self.counts.start()

    # ------------------------------------------------------------- drawing
    def redraw(self) -> None:
        """Draw again the labels whose feature changed (`Labels`), and the panel."""
        nodes = self.nodes
        for fid, text in self.labels.changed():
            nodes[fid].set_label(text)
        self._show_status()

    def _detail(self, text: Any) -> None:
        if text != self.detail_shown:  # (an update is a frame of its own, with the layout done again)
            self.detail_shown = text
            self.query_one("#text", Static).update(text)

    def _show_status(self) -> None:
        busy = Text("propagating the decision...", "bold yellow")
        self._detail(busy if self.propagation.marked else _status(self.session, self.counts.said))

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
        if self.propagation.waiting():
            return
        repairs = self.session.repairs
        if not 1 <= k <= len(repairs):
            self.notify(f"there is no repair {k}", severity="warning")
            return
        self._change(lambda: self.session.apply(repairs[k - 1]))

    def action_why(self) -> None:
        node = self.query_one(FeatureTree).cursor_node
        if node is None or node.data is None or self.propagation.waiting():
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

        if self.propagation.waiting():
            return
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

    def action_search(self) -> None:
        search = self.query_one(Search)
        search.display = True
        search.focus()

    def jump_to(self, fid: str) -> None:
        """Open the tree down to `fid` and put the cursor on it (a search's match)."""
        node = self.nodes[fid]
        parent = node.parent
        while parent is not None:
            parent.expand()
            parent = parent.parent
        tree = self.query_one(FeatureTree)
        tree.move_cursor(node)
        tree.scroll_to_node(node, animate=False)

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
        if self.session.deferred:  # (the decision drawn now, its consequences when they come)
            self.propagation.start()
        self.redraw()


def _status(session: Configurator, counting: str = "") -> Text:
    """The detail panel between questions: valid and how far, or the conflict and its repairs."""
    text = Text()
    if session.valid:
        chosen = sum(1 for s in session.states if OFF not in s)
        text.append("valid", "bold green")
        text.append(
            f": {plural(len(session.decisions), 'decision')}, {plural(chosen, 'feature')} selected "
            "in every variant they allow\n"
        )
        if session.left is not None and session.form is not None:
            kind = "variant" if session.form.kind == "variants" else "selection"
            text.append(f"{session.left:,} {kind}{'' if session.left == 1 else 's'} left", "bold cyan")
            text.append(" (beside each open feature: its share of them)", "dim")
            text.append(f"{counting}\n", "dim")
        elif counting:
            text.append(f"{counting}\n", "dim")
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
    return text

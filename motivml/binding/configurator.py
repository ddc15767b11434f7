"""An interactive configuration session: decisions, their consequences, conflicts, repairs.

What `motivml menuconfig` shows and changes, kept apart from any screen so that it can be
tested and driven headless. A session holds the person's decisions (per feature: selected
or not, a time, a mode, each possibly left open) and, after every change, what follows
from them on the one encoding:

* `states`: per feature what valid variants can still make of it (one value: forced);
* `problems`: when the decisions have no valid variant, the conflicts, each with the
  configuration's minimal repairs (section 6); `apply` makes one of them;
* `why(feature)`: the located reasons, as `show --why` gives them;
* `left` and `shares`: with a compiled form of the model (`form`, compiled.py), how many
  variants (or selections) the decisions leave, exactly, and the share of them that
  selects each feature, counted at once after every change.

The decisions are kept as the decisions file they will be saved as (reference.md section
1, `"partial": true`): after each change that text is read back by the same reader as a file
on disk, so a conflict's facts point at the lines the saved file will have.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..documents.loader import parse
from ..errors import ChangeKind, Diagnostic, Repair, Severity
from ..language.model import Configuration, Entry, FeatureModel, FeatureState, Mode, Time
from ..language.reader import read_configuration
from . import encoding as enc
from .check import binding_states, check_variant
from .why import Reason, why


@dataclass(frozen=True)
class Choice:
    """What a person decided of one feature; None: left to the configurator."""

    selected: bool | None = None
    time: Time | None = None
    mode: Mode | None = None


def decisions_text(config: Configuration, extra: dict[str, object] | None = None) -> str:
    """A configuration as a decisions file (reference.md section 1): `"partial": true`, its
    entries only, in their order; `extra` keys (a document's `x-` keys) first."""
    properties: list[dict[str, object]] = []
    for entry in config.entries.values():
        item: dict[str, object] = {"id": entry.id}
        if not entry.selected:
            item["selected"] = False
        props = {k: v.value for k, v in (("time", entry.time), ("mode", entry.mode)) if v is not None}
        if entry.selected and props:
            item["props"] = props
        properties.append(item)
    return json.dumps({**(extra or {}), "partial": True, "properties": properties}, indent=2) + "\n"


@dataclass(frozen=True)
class Propagated:
    """What follows from a set of decisions (`Configurator.propagate`)."""

    config: Configuration
    problems: list[Diagnostic]  # errors, or conflicts with their repairs ([]: valid)
    states: list[set[FeatureState]]  # per feature, what valid variants can make of it ([] while invalid)
    left: int | None = None  # with a compiled form: the variants (or selections) the decisions leave
    shares: list[float] | None = None  # with it: per feature, the share of those that select it


class Configurator:
    """Decisions about one model's features and what follows from them."""

    def __init__(
        self,
        model: FeatureModel,
        file: str,
        start: Configuration | None = None,
        extra: dict[str, object] | None = None,
        prefer: Collection[str] = (),
    ) -> None:
        """`file`: where the decisions will be saved (named in locations); `start`: a
        configuration to begin from (each of its entries a decision); `extra`: top-level
        keys to keep (a document's `x-` keys)."""
        self.model = model
        self.file = file
        self.extra = dict(extra or {})
        self.prefer = tuple(prefer)
        self.decisions: dict[str, Choice] = {}
        if start is not None:
            for entry in sorted(start.entries.values(), key=lambda e: model.index.get(e.id, 0)):
                if entry.id in model.index and model.index[entry.id] != 0:
                    self.decisions[entry.id] = Choice(
                        entry.selected,
                        entry.time if entry.selected else None,
                        entry.mode if entry.selected else None,
                    )
        self.config: Configuration
        self.states: list[set[FeatureState]] = []
        self.problems: list[Diagnostic] = []
        self.form: Any = None  # a compiled.CompiledForm of the model, once one is at hand
        self.beside: Path | None = None  # the model's folder, where its compiled forms are kept
        self.left: int | None = None
        self.shares: list[float] | None = None
        self.saved_text: str | None = None
        self._encoding: enc.Encoding | None = None  # the model's, kept for every decision
        self._asking = threading.Lock()  # (propagations of two threads ask it in turn)
        # deferred: a change updates the decisions only, and the caller propagates them
        # (menuconfig, off its UI thread on a large model); else each change propagates
        self.deferred = False
        self.refresh()

    # ------------------------------------------------------------------ reading
    def text(self, decisions: dict[str, Choice] | None = None) -> str:
        """The decisions file as it would be saved now (or of `decisions`), in definition
        order, so that the file reads as the tree does."""
        config = Configuration({}, "")
        index = self.model.index
        chosen = sorted((self.decisions if decisions is None else decisions).items(), key=lambda item: index[item[0]])
        for position, (fid, d) in enumerate(chosen):
            config.entries[fid] = Entry(fid, d.selected is not False, d.time, d.mode, position)
        return decisions_text(config, self.extra)

    def refresh(self) -> None:
        """Work out what follows from the decisions, now."""
        self.install(self.propagate(dict(self.decisions)))

    def propagate(self, decisions: dict[str, Choice]) -> Propagated:
        """What follows from `decisions` (read back as the file they will be saved as); from
        any thread, one at a time (the session's one encoding is asked)."""
        with self._asking:
            doc = parse(self.text(decisions), self.file)
            config, diagnostics = read_configuration(doc, self.model, partial=True)
            errors = [d for d in diagnostics if d.severity is Severity.ERROR]
            if errors:
                return Propagated(config, errors, [])
            kept = self._kept()  # (one encoding for the session: a decision asks it again, not built again)
            kept.set_configuration(config)
            problems = [] if kept.solve() else check_variant(self.model, config)
            if problems:
                return Propagated(config, problems, [])
            left, shares = self._counted(config)
            return Propagated(config, problems, binding_states(self.model, config, kept), left, shares)

    def _counted(self, config: Configuration) -> tuple[int | None, list[float] | None]:
        """With a compiled form: the variants `config` leaves (ddnnife's exact count), and
        per feature the share of them that select it (`CompiledForm.shares`)."""
        form = self.form
        if form is None:
            return None, None
        assumed: list[int] = []
        index = self.model.index
        variants = form.kind == "variants"
        for entry in config.entries.values():
            i = index[entry.id]
            assumed.append(form.literal(i) if entry.selected else -form.literal(i))
            if entry.selected and variants:
                if entry.time is not None:
                    assumed.append(form.literal(i, "early") * (1 if entry.time is Time.EARLY else -1))
                if entry.mode is not None:
                    assumed.append(form.literal(i, "static") * (1 if entry.mode is Mode.STATIC else -1))
        left = form.count(assumed)
        if not left:
            return 0, [0.0] * len(self.model.features)
        return left, form.shares(assumed, [form.literal(i) for i in range(len(self.model.features))])

    def install(self, propagated: Propagated) -> None:
        """Take what `propagate` worked out as the session's."""
        self.config, self.problems, self.states = propagated.config, propagated.problems, propagated.states
        self.left, self.shares = propagated.left, propagated.shares

    def _kept(self) -> enc.Encoding:
        if self._encoding is None:
            self._encoding = enc.Encoding(self.model)
        return self._encoding

    @property
    def valid(self) -> bool:
        return not self.problems

    @property
    def repairs(self) -> tuple[Repair, ...]:
        """The minimal repairs of the current conflicts (each fixes all of them), fewest first."""
        return self.problems[0].repairs if self.problems else ()

    def forced(self, fid: str) -> FeatureState | None:
        """The one value valid variants give a feature the decisions leave open; else None."""
        if not self.states:
            return None
        possible = self.states[self.model.index[fid]]
        return next(iter(possible)) if len(possible) == 1 else None

    def possible(self, fid: str) -> set[FeatureState]:
        return self.states[self.model.index[fid]] if self.states else set()

    def why(self, fid: str) -> list[Reason]:
        """Why the feature is what it is (`show --why`); [] while the decisions conflict."""
        if not self.valid:
            return []
        from .resolve import resolve, start_state

        variant = resolve(self.model, self.config, self.prefer)
        decision = variant.decisions[self.model.index[fid]]
        active = {f.id for f in start_state(variant)}
        return why(
            self.model,
            self.config,
            fid,
            self.states,
            self.prefer,
            (decision.selected, decision.binding),
            fid in active,
        )

    # ----------------------------------------------------------------- changing
    def select(self, fid: str, selected: bool | None) -> None:
        """Decide whether a feature is selected (None: leave it open). Deselecting drops its
        time and mode (they mean nothing then); leaving it open keeps them only if set."""
        old = self._old(fid)
        if selected is False:
            self._set(fid, Choice(False))
        elif selected is None and old.time is None and old.mode is None:
            self._set(fid, Choice())
        else:
            self._set(fid, Choice(True, old.time, old.mode))

    def bind(self, fid: str, time: Time | None, mode: Mode | None) -> None:
        """Decide a feature's time and mode (None: leave it open); a binding is decided of a
        selected feature, so a feature not yet selected becomes selected."""
        old = self._old(fid)
        if time is None and mode is None:
            self._set(fid, Choice(old.selected) if old.selected else Choice())
        else:
            self._set(fid, Choice(True, time, mode))

    def clear(self, fid: str) -> None:
        """Leave everything about a feature to the configurator again."""
        self._old(fid)
        self._set(fid, Choice())

    def decided(self, fid: str) -> Choice:
        return self.decisions.get(fid, Choice())

    def _old(self, fid: str) -> Choice:
        if self.model.index[fid] == 0:
            raise ValueError("the root is always selected, Static and Early (rule 2.1)")
        return self.decided(fid)

    def _set(self, fid: str, decision: Choice) -> None:
        if decision == Choice():
            self.decisions.pop(fid, None)
        else:
            self.decisions[fid] = decision
        if not self.deferred:
            self.refresh()

    def apply(self, repair: Repair) -> None:
        """Make every change of a repair, then refresh once."""
        for change in repair:
            old = self.decisions.get(change.feature, Choice())
            if change.change is ChangeKind.SELECT:
                new = Choice(True, old.time, old.mode) if change.value else Choice(False)
            elif change.change is ChangeKind.TIME:
                new = Choice(True, Time(str(change.value)), old.mode)
            elif change.change is ChangeKind.MODE:
                new = Choice(True, old.time, Mode(str(change.value)))
            else:
                raise ValueError(f"not a change to a configuration: {change.change}")
            self.decisions[change.feature] = new
        if not self.deferred:
            self.refresh()

    def saved(self) -> None:
        self.saved_text = self.text()

    @property
    def unsaved(self) -> bool:
        return self.saved_text != self.text()

"""Resolution: from a (possibly partial) configuration to one complete variant.

What the configuration fixes is kept; the solver decides the rest (reference.md section 4):
undecided features are left out unless the model needs them, and open bindings take the
published defaults, Early and Static, unless the user prefers Late or Dynamic. The three
wishes are optimised together, lexicographically (fewest undecided features selected, then
the time preference, then the mode preference), with MaxSAT (RC2) over the one encoding.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, replace
from enum import StrEnum
from typing import NamedTuple

from ..errors import MotivmlError
from ..language.model import Binding, Configuration, Entry, Feature, FeatureModel
from ..process import no_gc
from . import PREFERENCES
from . import encoding as enc
from .check import check_variant


class NoVariant(MotivmlError):
    """The configuration has no valid completion; the diagnostics explain why."""


class DecidedBy(StrEnum):
    """Who decided a part of a resolved feature (the lock file's `x-decided`)."""

    MODEL = "model"  # the root, or a binding the model allows one way only
    CONFIGURATION = "configuration"
    SOLVER = "solver"


class Decision(NamedTuple):
    """One feature of a resolved variant, and who decided each part of it. (A named tuple:
    `configure` makes one per feature of the model, 100,000 of them.)"""

    feature: Feature
    selected: bool
    binding: Binding  # meaningful when selected
    selection_by: DecidedBy
    time_by: DecidedBy
    mode_by: DecidedBy


@dataclass(frozen=True)
class Variant:
    model: FeatureModel
    name: str
    decisions: tuple[Decision, ...]  # definition order, root first
    # the start state's feature indices, when `resolve` found it on its own encoding
    active_at_start: tuple[int, ...] | None = None

    def selected(self) -> list[Decision]:
        return [d for d in self.decisions if d.selected]

    def digest(self) -> str:
        """A fingerprint of what the variant selects and how each selected feature is bound
        (16 hex digits): two runs of one model with equal digests run the same variant, so
        a fleet's plan can tell a robot that runs its variant without the fleet's layers."""
        import hashlib

        fingerprint = hashlib.sha256()
        for d in self.decisions:
            if d.selected:
                fingerprint.update(f"{d.feature.id}\0{d.binding.words}\n".encode())
        return fingerprint.hexdigest()[:16]


def resolve(
    model: FeatureModel, config: Configuration, prefer: Collection[str] = (), start: bool = True
) -> Variant:
    """The variant the configuration and the preferences ask for; NoVariant if none exists.

    With `start`, its start state too (`start_state` then asks no solver), found on the
    encoding that resolved it instead of a second one.
    """
    unknown = set(prefer) - set(PREFERENCES)
    if unknown:
        raise ValueError(f"unknown preference {sorted(unknown)}: choose from {PREFERENCES}")
    with no_gc(), enc.Encoding(model) as encoding:
        encoding.set_configuration(config)
        soft = _preferences(encoding, model, config, set(prefer))
        values = encoding.optimise(soft)
        if values is None:
            raise NoVariant(check_variant(model, config))
        variant = _variant(encoding, model, config, values)
        if start:
            active = _start_on(encoding, variant)
            if active is not None:  # (None cannot happen: start_state says so if it does)
                variant = replace(variant, active_at_start=tuple(active))
    return variant


def _variant(encoding: enc.Encoding, model: FeatureModel, config: Configuration, values: list[int]) -> Variant:
    """The variant of a solution of the encoding (values in variable order: variable v's
    literal at index v - 1): who decided what, feature by feature."""
    entries, from_flags = config.entries, Binding.from_flags
    s, E, S = encoding.s, encoding.E, encoding.S  # noqa: N806 - the spec's names
    decisions = []
    for f in model.features:
        entry = entries.get(f.id)
        i = f.index
        root = f.parent is None
        # a time or mode the configuration leaves open is the model's if it allows one only
        # (or for the root), else the solver's
        time_by = DecidedBy.MODEL if root or f.time_allowed is not None else DecidedBy.SOLVER
        mode_by = DecidedBy.MODEL if root or f.mode_allowed is not None else DecidedBy.SOLVER
        if entry is not None:
            time_by = DecidedBy.CONFIGURATION if entry.time is not None else time_by
            mode_by = DecidedBy.CONFIGURATION if entry.mode is not None else mode_by
        selection_by = DecidedBy.MODEL if root else DecidedBy.CONFIGURATION if entry is not None else DecidedBy.SOLVER
        selected, binding = values[s(i) - 1] > 0, from_flags(values[E(i) - 1] > 0, values[S(i) - 1] > 0)
        decisions.append(Decision(f, selected, binding, selection_by, time_by, mode_by))
    return Variant(model, config.name, tuple(decisions))



def _preferences(
    encoding: enc.Encoding, model: FeatureModel, config: Configuration, prefer: set[str]
) -> list[tuple[int, int]]:
    """Soft literals, weighted so that each wish outweighs all the ones after it."""
    undecided: list[int] = []
    times: list[int] = []
    modes: list[int] = []
    s, E, S = encoding.s, encoding.E, encoding.S  # noqa: N806 - the spec's names
    towards_time = -1 if "late" in prefer else 1  # (Early unless Late is preferred)
    towards_mode = -1 if "dynamic" in prefer else 1  # (Static unless Dynamic is preferred)
    entry_of = config.entries.get
    for f in model.features[1:]:
        entry = entry_of(f.id)
        i = f.index
        if entry is None:
            undecided.append(-s(i))
        if entry is None or entry.time is None:
            times.append(towards_time * E(i))
        if entry is None or entry.mode is None:
            modes.append(towards_mode * S(i))
    mode_weight = 1
    time_weight = len(modes) + 1
    selection_weight = time_weight * (len(times) + 1)
    return (
        [(lit, selection_weight) for lit in undecided]
        + [(lit, time_weight) for lit in times]
        + [(lit, mode_weight) for lit in modes]
    )


def as_configuration(variant: Variant) -> Configuration:
    """The variant as a complete configuration (every feature decided, no Any)."""
    entries = {}
    for position, d in enumerate(variant.decisions):
        entries[d.feature.id] = Entry(d.feature.id, d.selected, d.binding.time, d.binding.mode, position)
    return Configuration(entries, variant.name)


def start_state(variant: Variant) -> list[Feature]:
    """The active set at start (reference.md section 4), in definition order.

    Every selected Early feature, completed with the fewest Late ones (earlier features
    first among equals). A resolved variant always has one (its start state is part of
    the encoding that resolved it); NoVariant says otherwise if that ever fails.
    """
    model = variant.model
    if variant.active_at_start is not None:
        return [model.features[i] for i in variant.active_at_start]
    with enc.Encoding(model) as encoding:
        active = _start_on(encoding, variant)
    if active is None:
        raise NoVariant(check_variant(model, as_configuration(variant)))
    return [model.features[i] for i in active]


def _start_on(encoding: enc.Encoding, variant: Variant) -> list[int] | None:
    """The start state's feature indices, found on `encoding`, which then holds the variant
    for good; None if there is none."""
    s, E, S = encoding.s, encoding.E, encoding.S
    literals, late = [], []
    for d in variant.decisions:
        i = d.feature.index
        if not d.selected:
            literals.append(-s(i))
            continue
        early, static = d.binding.early, d.binding.static
        literals += (s(i), E(i) if early else -E(i), S(i) if static else -S(i))
        if not early:
            late.append(i)
    return encoding.start_state(late, literals)


def decisions(variant: Variant, prefer: Collection[str] = ()) -> Configuration:
    """The smallest decisions file from which `resolve`, with the same preferences, derives
    `variant` again (like Kconfig's savedefconfig): entries the solver would decide the
    same way are left out.

    Greedy, as savedefconfig is, in definition order (a feature before its sub-features, so
    that a selected sub-feature, which implies its parent, is the entry that stays): each
    entry is dropped if the rest still derives the variant, else its time and then its mode
    are dropped if they may be. Every trial is one
    resolution, so a model of n features costs up to 3n MaxSAT solves: fine for a robot's
    hundreds of features, slow for tens of thousands.
    """
    model = variant.model
    wanted = [(d.selected, d.binding if d.selected else None) for d in variant.decisions]
    entries: dict[str, Entry] = {
        d.feature.id: Entry(
            d.feature.id,
            d.selected,
            d.binding.time if d.selected else None,
            d.binding.mode if d.selected else None,
            d.feature.index,
        )
        for d in variant.decisions[1:]
    }

    def derives(trial: dict[str, Entry]) -> bool:
        found = resolve(model, Configuration(trial, variant.name), prefer, start=False)
        return [(d.selected, d.binding if d.selected else None) for d in found.decisions] == wanted

    for d in variant.decisions[1:]:
        fid = d.feature.id
        without = {k: v for k, v in entries.items() if k != fid}
        if derives(without):
            entries = without
            continue
        entry = entries[fid]
        if entry.time is not None:
            weaker = Entry(fid, entry.selected, None, entry.mode, entry.position)
            if derives({**entries, fid: weaker}):
                entries[fid] = entry = weaker
        if entry.mode is not None:
            weaker = Entry(fid, entry.selected, entry.time, None, entry.position)
            if derives({**entries, fid: weaker}):
                entries[fid] = weaker
    ordered = dict(sorted(entries.items(), key=lambda item: item[1].position))
    return Configuration(ordered, variant.name)

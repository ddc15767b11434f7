"""Interchangeable features: sub-features that no statement of the model tells apart.

Two features are interchangeable when swapping them maps every valid variant to a valid
variant: the same parent, the same group (or both ungrouped with the same `isMandatory`),
the same allowed time and mode, no sub-features, and no include, exclude or formula naming
either (nor a configuration entry that differs). Every rule of reference.md sections 2-4
treats such features alike: a group's rules are the same for each member, the sub-feature
rules look only at the parent, and the start state exists for a variant iff it exists for
the swapped one.

So a question about one of them (is it dead, core, can it be Early) has the same answer for
each, and is asked of the class's first feature only: a group of 10,000 alternatives that
allow the same bindings is one question, not 10,000 solves. (The XOR rule of a large group
is encoded with counters in the members' order, which is not symmetric clause by clause;
the variants it allows are, and those are what the answers are about.)

Atomic sets need one more question per class (`analysis._atomic_classes`): two members are selected
together in every variant, or (if some variant selects one without the other) no member is
in an atomic set with any other feature but itself: if x were always selected with some z
outside the class, swapping x and y would show y always selected with z too, and so x with y.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import TypeVar

from ..language.model import Configuration, FeatureModel

T = TypeVar("T")


class Classes:
    """The classes of interchangeable features of a model (and configuration): which
    feature each question is asked of, and each answer given back to every member."""

    def __init__(self, model: FeatureModel, config: Configuration | None = None) -> None:
        self.representative = interchangeable(model, config)
        # the features asked about (the first of each class, and every feature of none), in
        # pre-order, and where each is among them
        self.asked = [i for i, r in enumerate(self.representative) if r == i]
        self.position = {i: k for k, i in enumerate(self.asked)}

    def spread(self, answers: Sequence[T]) -> list[T]:
        """Per feature, the answer of its class's first feature, from `answers`, one per
        feature asked about, in their order."""
        position = self.position
        return [answers[position[r]] for r in self.representative]

    def members(self) -> dict[int, list[int]]:
        """The classes of more than one feature, by their first feature: its members in order."""
        found: dict[int, list[int]] = {}
        for i, r in enumerate(self.representative):
            if r != i:
                found.setdefault(r, [r]).append(i)
        return found


def interchangeable(model: FeatureModel, config: Configuration | None = None) -> list[int]:
    """Per feature (in pre-order), the first feature of its class of interchangeable ones:
    itself when it has none."""
    named = model.named()
    first: dict[Hashable, int] = {}
    representative = list(range(len(model.features)))
    entries = config.entries if config is not None else {}
    for f in model.features:
        if f.parent is None or f.children or f.id in named:
            continue
        entry = entries.get(f.id)
        key = (
            f.parent,
            f.group,
            f.mandatory,
            f.time_allowed,
            f.mode_allowed,
            f.abstract,
            None if entry is None else (entry.selected, entry.time, entry.mode),
        )
        representative[f.index] = first.setdefault(key, f.index)
    return representative

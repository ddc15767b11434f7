"""Change impact: what moving a running robot from one variant to another takes.

reference.md section 4, feature by feature between two resolved variants of one model:
*rebuild* if the feature enters or leaves the set of Static Early features (they are
compiled in); otherwise *restart* if a Static Late feature leaves the selection or changes
its binding, or the feature changes mode; otherwise *run time* (a Dynamic feature enters,
leaves or changes time; a Static Late feature enters). The variants can be swapped in a
running program iff every change is *run time*.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from ..language.model import OFF, Binding, FeatureState
from .resolve import Decision, Variant


class Impact(StrEnum):
    """What a feature's change takes, worst first (the words `diff` prints)."""

    REBUILD = "rebuild"
    RESTART = "restart"
    RUN_TIME = "run time"


ORDER = tuple(Impact)


@dataclass(frozen=True)
class FeatureChange:
    """One feature's difference between two variants, and what making it takes."""

    feature: str
    before: FeatureState
    after: FeatureState
    impact: Impact
    reason: str


def _state(d: Decision) -> FeatureState:
    return d.binding if d.selected else OFF


def classify(before: FeatureState, after: FeatureState) -> tuple[Impact, str]:
    """(impact, reason) of one feature's change from `before` to `after`."""
    if (before == Binding.SE) != (after == Binding.SE):
        verb = "enters" if after == Binding.SE else "leaves"
        return Impact.REBUILD, f"{verb} the Static Early features, which are compiled in"
    if before == Binding.SL and after != Binding.SL:
        what = "leaves the selection" if after == OFF else "changes its binding"
        return Impact.RESTART, f"a Static Late feature {what}: once loaded it stays until the program ends"
    if isinstance(before, Binding) and isinstance(after, Binding) and before.mode != after.mode:
        return Impact.RESTART, "changes mode (Static / Dynamic): its loader is chosen when the program starts"
    if after == Binding.SL:
        return Impact.RUN_TIME, "a Static Late feature enters: it is loaded while the program runs"
    if before == OFF:
        return Impact.RUN_TIME, "a Dynamic feature enters: it is loaded while the program runs"
    if after == OFF:
        return Impact.RUN_TIME, "a Dynamic feature leaves: it is unloaded while the program runs"
    return Impact.RUN_TIME, "a Dynamic feature changes time: it is unloaded and loaded again while the program runs"


def diff(first: Variant, second: Variant) -> list[FeatureChange]:
    """Every feature whose selection or binding differs, worst impact first, then model order."""
    changes = []
    for a, b in zip(first.decisions, second.decisions, strict=True):
        before, after = _state(a), _state(b)
        if before != after:
            impact, reason = classify(before, after)
            changes.append(FeatureChange(a.feature.id, before, after, impact, reason))
    return sorted(changes, key=lambda c: ORDER.index(c.impact))


def verdict(changes: list[FeatureChange]) -> Impact:
    """The worst impact of all changes ("run time" when there are none)."""
    return min((c.impact for c in changes), key=ORDER.index, default=Impact.RUN_TIME)

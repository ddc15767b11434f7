"""Change impact: what moving a running robot from one variant to another takes.

semantics.md section 4, feature by feature between two resolved variants of one model:
*rebuild* if the feature enters or leaves the set of Static Early features (they are
compiled in); otherwise *restart* if a Static Late feature leaves the selection or changes
its binding, or the feature changes mode; otherwise *run time* (a Dynamic feature enters,
leaves or changes time; a Static Late feature enters). The variants can be swapped in a
running program iff every change is *run time*.
"""

from __future__ import annotations

from dataclasses import dataclass

from .resolve import Decision, Variant

REBUILD, RESTART, RUN_TIME = "rebuild", "restart", "run time"
ORDER = (REBUILD, RESTART, RUN_TIME)


@dataclass(frozen=True)
class Change:
    feature: str
    before: str  # "off", "SE", "SL", "DE" or "DL"
    after: str
    impact: str
    reason: str


def _state(d: Decision) -> str:
    return d.binding if d.selected else "off"


def classify(before: str, after: str) -> tuple[str, str]:
    """(impact, reason) of one feature's change from `before` to `after`."""
    if (before == "SE") != (after == "SE"):
        verb = "enters" if after == "SE" else "leaves"
        return REBUILD, f"{verb} the Static Early features, which are compiled in"
    if before == "SL" and after != "SL":
        what = "leaves the selection" if after == "off" else "changes its binding"
        return RESTART, f"a Static Late feature {what}: once loaded it stays until the program ends"
    if before != "off" and after != "off" and before[0] != after[0]:
        return RESTART, "changes mode (Static / Dynamic): its loader is chosen when the program starts"
    if after == "SL":
        return RUN_TIME, "a Static Late feature enters: it is loaded while the program runs"
    if before == "off":
        return RUN_TIME, "a Dynamic feature enters: it is loaded while the program runs"
    if after == "off":
        return RUN_TIME, "a Dynamic feature leaves: it is unloaded while the program runs"
    return RUN_TIME, "a Dynamic feature changes time: it is unloaded and loaded again while the program runs"


def diff(first: Variant, second: Variant) -> list[Change]:
    """Every feature whose selection or binding differs, worst impact first, then model order."""
    changes = []
    for a, b in zip(first.decisions, second.decisions, strict=True):
        before, after = _state(a), _state(b)
        if before != after:
            impact, reason = classify(before, after)
            changes.append(Change(a.feature.id, before, after, impact, reason))
    return sorted(changes, key=lambda c: ORDER.index(c.impact))


def verdict(changes: list[Change]) -> str:
    """The worst impact of all changes ("run time" when there are none)."""
    return min((c.impact for c in changes), key=ORDER.index, default=RUN_TIME)

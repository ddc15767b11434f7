"""t-wise samples (issue 15): a few valid variants that together show every valid
combination of t feature values.

A *value* is what one feature is in a variant: selected or not, and with `bindings` also
selected and Early, selected and Late, selected and Static, selected and Dynamic (so that a
team tests the Static and the Dynamic build of a feature). A *combination* is t values of t
different features; it is *valid* when some valid variant (sections 2-4) has all of them.

Greedy, on one hard build of the encoding, in the manner of IncLing and YASA: take the
first combination not yet shown; unit propagation refutes most invalid ones at once; else
add, in order, the next combinations that propagation finds compatible with it, and solve
under all of them (falling back to the first alone). The variant found shows every
combination of its values, which are struck off. Every combination ends shown or proven
invalid, so the coverage of valid combinations is complete by construction.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from itertools import combinations

from ..documents.loader import no_gc
from ..language.model import Binding, FeatureModel
from . import encoding as enc

PACK = 16384  # combinations tried for packing into one variant beside the one it is for
LIMIT = 20_000_000  # combinations at most (their set is held in memory)


class TooMany(ValueError):
    """More t-wise combinations than LIMIT."""


@dataclass
class Sample:
    variants: list[dict[int, Binding | None]]  # per variant: feature index -> binding, None = off
    combinations: int  # how many t-wise combinations there are
    valid: int  # how many of them some valid variant has
    shown: int  # how many valid ones the variants show (all of them, unless this has a bug)
    void: bool = False


def sample(
    model: FeatureModel, t: int = 2, bindings: bool = False, progress: Callable[[int, int], None] | None = None
) -> Sample:
    """A t-wise sample (t = 1, 2, 3); `progress(shown or refuted, combinations)` now and then."""
    features = [f.index for f in model.features if f.parent is not None]
    with no_gc(), enc.Encoding(model) as hard:
        if not hard.solve(with_config=False):
            return Sample([], 0, 0, 0, void=True)
        s, E, S = hard.s, hard.E, hard.S  # noqa: N806
        values: list[tuple[int, tuple[int, ...]]] = []  # (feature, literals)
        for i in features:
            values += [(i, (s(i),)), (i, (-s(i),))]
            if bindings:
                values += [(i, (s(i), E(i))), (i, (s(i), -E(i))), (i, (s(i), S(i))), (i, (s(i), -S(i)))]
        per_feature = 6 if bindings else 2
        total = _count(len(features), per_feature, t)
        if total > LIMIT:
            raise TooMany(
                f"{total:,} {t}-wise combinations over {len(features):,} features: more than {LIMIT:,}"
            )
        ids = range(len(values))
        open_ = sorted(
            combo for combo in combinations(ids, t) if len({values[v][0] for v in combo}) == t
        )
        uncovered = set(open_)
        waiting = [0] * len(values)  # per value: the open combinations it is in
        for combo in open_:
            for v in combo:
                waiting[v] += 1
        invalid = shown_count = 0
        variants: list[dict[int, Binding | None]] = []
        position = 0

        def literals(combo: tuple[int, ...]) -> list[int]:
            return [lit for v in combo for lit in values[v][1]]

        while position < len(open_):
            first = open_[position]
            position += 1
            if first not in uncovered:
                continue
            wanted = literals(first)
            if not hard.solver.propagate(assumptions=wanted)[0] or not hard.solver.solve(assumptions=wanted):
                uncovered.discard(first)
                for v in first:
                    waiting[v] -= 1
                invalid += 1
                continue
            # pack: the next open combinations that propagation finds compatible
            packed = list(wanted)
            tried = 0
            stride = max(1, (len(open_) - position) // PACK)  # spread over what is open, not its next few
            for combo in open_[position::stride]:
                if tried >= PACK:
                    break
                if combo not in uncovered:
                    continue
                tried += 1
                more = literals(combo)
                if hard.solver.propagate(assumptions=packed + more)[0]:
                    packed += more
            # the rest decided the way that shows most of what is still open
            hard.solver.set_phases(_phases(values, waiting))
            if not hard.solver.solve(assumptions=packed):
                hard.solver.solve(assumptions=wanted)
            truth = set(hard.assignment())
            shown = [v for v in ids if all(lit in truth for lit in values[v][1])]
            for combo in combinations(shown, t):
                if combo in uncovered:
                    uncovered.remove(combo)
                    shown_count += 1
                    for v in combo:
                        waiting[v] -= 1
            variants.append(
                {
                    i: Binding.from_flags(E(i) in truth, S(i) in truth) if s(i) in truth else None
                    for i in range(len(model.features))
                }
            )
            if progress is not None:
                progress(len(open_) - len(uncovered), len(open_))
    return Sample(variants, len(open_), len(open_) - invalid, shown_count)


def _phases(values: list[tuple[int, tuple[int, ...]]], waiting: list[int]) -> list[int]:
    """Per variable, the polarity of the value with the most open combinations."""
    best: dict[int, tuple[int, int]] = {}  # variable -> (open combinations, literal)
    for (_, literals), count in zip(values, waiting, strict=True):
        literal = literals[-1]  # (a binding value's own literal; s(f) for the selection's)
        if count > best.get(abs(literal), (-1, 0))[0]:
            best[abs(literal)] = (count, literal)
    return [literal for _, literal in best.values()]


def _count(features: int, per_feature: int, t: int) -> int:
    """C(features, t) * per_feature**t: the combinations of t values of distinct features."""
    from math import comb

    return int(comb(features, t) * per_feature**t)


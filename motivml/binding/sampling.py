"""t-wise samples (issue 15): a few valid variants that together show every valid
combination of t feature values.

A *value* is what one feature is in a variant: selected or not, and with `bindings` also
selected and Early, selected and Late, selected and Static, selected and Dynamic (so that a
team tests the Static and the Dynamic build of a feature). A *combination* is t values of t
different features; it is *valid* when some valid variant (sections 2-4) has all of them.

Greedy over partial variants, in the manner of YASA (Krieter et al., VaMoS 2020), on one
hard build of the encoding. Each partial variant is a set of literals with a *witness*: a
valid variant that has all of them. The combinations are taken in order, streamed, never
held; each one is

* already shown, when some partial variant has its literals;
* added to the first partial variant whose witness already shows it (no solve);
* refuted, when unit propagation of its literals alone fails;
* else added to the first partial variant that propagation and a solve find compatible with
  it (the solve's model is the new witness), or to a new partial variant; a combination no
  valid variant has is refuted by that last solve.

Every valid combination thus ends in some partial variant, whose witness has it: the
witnesses are the sample and its coverage of valid combinations is complete by construction
(`Sample.shown` counts it again over the witnesses). Solves prefer, for each free variable,
the value in most combinations still to come, so that witnesses show much for free.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from itertools import combinations
from math import comb

from ..language.model import Binding, FeatureModel
from ..process import no_gc
from . import encoding as enc

LIMIT = 20_000_000  # combinations at most (each is looked at a few times in Python)
REPORT = 1 << 16  # combinations between two progress reports


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
    model: FeatureModel,
    t: int = 2,
    bindings: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> Sample:
    """A t-wise sample (t = 1, 2, 3); `progress(settled, combinations)` now and then."""
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
        solver = hard.solver
        # per literal of a value's variable: a bit mask of the partial variants that have it,
        # and of those whose witness has it
        held: dict[int, int] = {}
        for _, literals in values:
            for lit in literals:
                held[lit] = held[-lit] = 0
        witnessed = dict(held)
        partial: list[dict[int, None]] = []  # per partial variant: its literals (an ordered set)
        witnesses: list[list[int]] = []  # per partial variant: its witness, a solver model
        everyone = 0  # the mask of all partial variants
        # per value: the combinations still to come that have it (all of them, at first)
        waiting = [comb(max(len(features) - 1, 0), t - 1) * per_feature ** (t - 1)] * len(values)

        def hold(k: int, literals: list[int]) -> None:
            bit = 1 << k
            for lit in literals:
                if lit not in partial[k]:
                    partial[k][lit] = None
                    if lit in held:
                        held[lit] |= bit

        def witness(k: int) -> None:
            bit = 1 << k
            if k < len(witnesses):
                for lit in witnesses[k]:
                    if lit in witnessed:
                        witnessed[lit] &= ~bit
                witnesses[k] = hard.assignment()
            else:
                witnesses.append(hard.assignment())
            for lit in witnesses[k]:
                if lit in witnessed:
                    witnessed[lit] |= bit

        def solve(assumptions: list[int]) -> bool:
            solver.set_phases(_phases(values, waiting))
            return bool(solver.solve(assumptions=assumptions))

        invalid = 0
        for done, combo in enumerate(_combinations(values, t), 1):
            if progress is not None and done % REPORT == 0:
                progress(done, total)
            for v in combo:
                waiting[v] -= 1
            wanted = [lit for v in combo for lit in values[v][1]]
            mask = -1
            for lit in wanted:
                mask &= held[lit]
            if mask:
                continue
            mask = -1
            for lit in wanted:
                mask &= witnessed[lit]
            if mask:
                hold((mask & -mask).bit_length() - 1, wanted)
                continue
            consistent, implied = solver.propagate(assumptions=wanted)
            if not consistent:
                invalid += 1
                continue
            clashing = 0  # partial variants with a literal that contradicts one implied
            for lit in implied:
                clashing |= held.get(-lit, 0)
            candidates = everyone & ~clashing
            while candidates:
                k = (candidates & -candidates).bit_length() - 1
                candidates &= candidates - 1
                assumed = [*partial[k], *wanted]
                consistent, implied_there = solver.propagate(assumptions=assumed)
                if consistent and solve(assumed):
                    witness(k)
                    hold(k, wanted + implied_there)
                    break
            else:
                if not solve(wanted):
                    invalid += 1
                    continue
                k = len(partial)
                partial.append({})
                everyone |= 1 << k
                witness(k)
                hold(k, wanted + implied)
        shown = 0  # counted again over the witnesses, the variants the sample is made of
        for combo in _combinations(values, t):
            mask = -1
            for v in combo:
                for lit in values[v][1]:
                    mask &= witnessed[lit]
            shown += mask != 0
        if progress is not None:
            progress(total, total)
        variants: list[dict[int, Binding | None]] = []
        for truth_list in witnesses:
            truth = set(truth_list)
            variants.append(
                {
                    i: Binding.from_flags(E(i) in truth, S(i) in truth) if s(i) in truth else None
                    for i in range(len(model.features))
                }
            )
    return Sample(variants, total, total - invalid, shown)


def _combinations(values: list[tuple[int, tuple[int, ...]]], t: int) -> Iterator[tuple[int, ...]]:
    """The combinations, in order: t values (by index) of t different features."""
    for combo in combinations(range(len(values)), t):
        if len({values[v][0] for v in combo}) == t:
            yield combo


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
    return int(comb(features, t) * per_feature**t)


@dataclass(frozen=True)
class Coverage:
    """What t-wise combinations some variants show (`coverage`)."""

    t: int
    combinations: int
    valid: int  # how many of them some valid variant has
    shown: int  # how many valid ones the variants show


def coverage(
    model: FeatureModel,
    variants: list[dict[int, Binding | None]],
    t: int = 2,
    bindings: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> Coverage:
    """The t-wise coverage of `variants` (each valid): a combination they show is valid; one
    they do not is refuted by unit propagation or else solved for."""
    features = [f.index for f in model.features if f.parent is not None]
    per_feature = 6 if bindings else 2
    total = _count(len(features), per_feature, t)
    if total > LIMIT:
        raise TooMany(f"{total:,} {t}-wise combinations over {len(features):,} features: more than {LIMIT:,}")
    # per value (feature, what): the bit mask of the variants that have it
    values: list[tuple[int, int]] = []
    for i in features:
        states = [variant[i] for variant in variants]
        masks = [sum(1 << k for k, b in enumerate(states) if b is None), sum(1 << k for k, b in enumerate(states) if b is not None)]
        if bindings:
            masks += [
                sum(1 << k for k, b in enumerate(states) if b is not None and test(b))
                for test in (_early, _late, _static, _dynamic)
            ]
        values += [(i, mask) for mask in masks]
    shown = invalid = 0
    with no_gc(), enc.Encoding(model) as hard:
        s, E, S = hard.s, hard.E, hard.S  # noqa: N806
        literals: list[tuple[int, ...]] = []
        for i in features:
            literals += [(-s(i),), (s(i),)]
            if bindings:
                literals += [(s(i), E(i)), (s(i), -E(i)), (s(i), S(i)), (s(i), -S(i))]
        solver = hard.solver
        for done, combo in enumerate(_combinations([(i, ()) for i, _ in values], t), 1):
            if progress is not None and done % REPORT == 0:
                progress(done, total)
            mask = -1
            for v in combo:
                mask &= values[v][1]
            if mask:
                shown += 1
                continue
            wanted = [lit for v in combo for lit in literals[v]]
            if not solver.propagate(assumptions=wanted)[0] or not solver.solve(assumptions=wanted):
                invalid += 1
    if progress is not None:
        progress(total, total)
    return Coverage(t, total, total - invalid, shown)


def _early(b: Binding) -> bool:
    return b.early


def _late(b: Binding) -> bool:
    return not b.early


def _static(b: Binding) -> bool:
    return b.static


def _dynamic(b: Binding) -> bool:
    return not b.static

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

For t = 2 the combinations are judged a row at a time (`_pairs`): each value against every
later value at once, over bit sets (numpy) of the partial variants that have each literal
and of the witnesses that do. The shown ones are skipped, those witnesses show are added
together, and those refuted by what propagation of either value alone implies (computed
once per value) are counted; the few left go one by one as above, but that the next few
pairs (LOOKAHEAD) that the same partial variant is the first to take are solved for with the
pair, in one solve.

Most of those solves are not needed (2-wise): a partial variant's witness, with what
propagation of its literals and the new pair's implies set, is often again a valid variant.
Only the clauses over the variables that changed can be broken (`_Clauses`), so only those
are checked, in numpy; when none is broken that assignment is the new witness, without a
solve (Automotive01: 24,952 solves -> 6,164; 65 -> 42 s; 1,203 -> 1,201 variants). The
sample is the last witness of each partial variant.

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
from typing import Any

import numpy as np

from ..language.model import Binding, FeatureModel
from ..process import no_gc
from . import encoding as enc

LIMIT = 20_000_000  # combinations at most (each is looked at a few times in Python)
REPORT = 1 << 16  # combinations between two progress reports
LOOKAHEAD = 16  # pairs looked ahead at for a solve together (2-wise)
LOOKAHEAD_FAILURES = 3  # failed solves of pairs together before the first goes alone
TRIES_APART = 1_000_003  # the seeds of one `smallest` call's shuffled orders are seed * this + 1, 2, ...
REPAIR_AT_MOST = 4096  # variables a witness may change without a solve (2-wise; beyond, a solve is cheaper)
# `smallest` also runs the AETG-style greedy (2-wise, selections: `aetg`) when the model has
# at most AETG_AT_MOST features: as many runs as orders were tried, but no more than AETG_STEPS
# steps in all (the orders' sample, times its features, times the candidates of each variant,
# AETG's M, times the runs). More candidates do better than more runs: Xtext, five runs of
# 10 candidates gave 22 to 24 variants, of 50 candidates 18 to 22 (1.4 s a run). TankWar
# (432 x 144 x 50): not run, one run of 10 candidates takes 12 s for 475 where the orders give 432.
AETG_AT_MOST, AETG_CANDIDATES, AETG_STEPS = 400, 50, 2_000_000


class TooMany(ValueError):
    """More t-wise combinations than LIMIT."""


@dataclass
class Sample:
    variants: list[dict[int, Binding | None]]  # per variant: feature index -> binding, None = off
    combinations: int  # how many t-wise combinations there are
    valid: int  # how many of them some valid variant has
    shown: int  # how many valid ones the variants show (all of them, unless this has a bug)
    void: bool = False
    tries: int = 1  # the orders tried (`smallest`)
    aetg: bool = False  # made by the AETG-style greedy (`smallest`), not in one of the orders


def sample(
    model: FeatureModel,
    t: int = 2,
    bindings: bool = False,
    progress: Callable[[int, int], None] | None = None,
    shuffle: int | None = None,
) -> Sample:
    """A t-wise sample (t = 1, 2, 3); `progress(settled, combinations)` now and then.
    `shuffle`: the features are taken in an order shuffled with this seed (`random.Random`),
    not the model's."""
    features = [f.index for f in model.features if f.parent is not None]
    if shuffle is not None:
        import random

        random.Random(shuffle).shuffle(features)
    with no_gc(), enc.Encoding(model, record=t == 2) as hard:
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
        if t == 2:
            found = _pairs(hard, values, total, progress)
            return Sample(_variants(model, hard, found.witnesses), total, total - found.invalid, found.shown)
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
            placed = _place(solver, everyone & ~clashing, lambda k: list(partial[k]), wanted, solve)
            if placed is not None:
                witness(placed[0])
                hold(placed[0], wanted + placed[1])
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


def smallest(
    model: FeatureModel,
    t: int = 2,
    bindings: bool = False,
    tries: int = 1,
    seed: int = 0,
    until: float | None = None,
    progress: Callable[..., None] | None = None,
) -> Sample:
    """The smallest of `tries` samples, each taken in its own order of the features, as
    YASA's iterations do: the model's own order first, then try k (from 1) shuffled with the
    seed `seed * TRIES_APART + k`; the first of equal sizes is kept. The greedy's size
    depends much on the order (eCos: 66 to 74 variants over six shuffled orders, 80 in its
    own; BusyBox: 36 to 354 over shuffled orders, 48 in its own), so one try is never worse
    than the model's order and more are usually better. No try starts after `until` (a
    `time.monotonic()`), but the first: `Sample.tries` says how many were made, and the
    same `seed` and that many `tries` give the same sample again (with this version of
    motivml, its solver and Python's `random`). `progress(k, settled, combinations)` reports
    each try k's own progress; `progress(k, covered, pairs, runs)` each AETG run's (below).

    Then, for 2-wise samples of selections of a model of at most AETG_AT_MOST features, the
    AETG-style greedy (`aetg`) runs as many times as orders were tried (fewer where
    AETG_STEPS says so), run k seeded with `seed * TRIES_APART + k`, every one of them
    whatever `until` says (so that the same seed and tries give the same sample), and its
    sample is kept where smaller (`Sample.aetg`).
    The valid combinations are then still those the orders counted, so that a pair the
    AETG sample missed would show as less than full coverage."""
    import time

    best: Sample | None = None
    for k in range(tries):
        if best is not None and until is not None and time.monotonic() >= until:
            break
        report = None if progress is None else (lambda done, total, k=k: progress(k, done, total))
        found = sample(model, t, bindings, report, shuffle=None if k == 0 else seed * TRIES_APART + k)
        if best is None or len(found.variants) < len(best.variants):
            best = found
        best.tries = k + 1
        if found.void or len(found.variants) <= 1:  # (no other order does better)
            break
    assert best is not None
    orders = best.tries
    runs = min(orders, AETG_STEPS // max(1, len(best.variants) * len(model.features) * AETG_CANDIDATES))
    if t != 2 or bindings or best.void or len(model.features) > AETG_AT_MOST or runs < 1:
        return best
    valid = best.valid  # (as the orders' refutations counted it: an AETG sample's own count is what it shows)
    for k in range(runs):  # (each seeded apart; all of them, so that the same --tries and --seed give
        # the same sample again: AETG_STEPS bounds their time)
        if len(best.variants) <= 1:
            break
        report = None if progress is None else (lambda done, total, k=k: progress(k, done, total, runs))
        other = aetg(model, seed * TRIES_APART + k, report)
        if len(other.variants) < len(best.variants):
            best = other
    best.tries, best.valid = orders, valid
    return best


def aetg(model: FeatureModel, seed: int = 0, progress: Callable[[int, int], None] | None = None) -> Sample:
    """A 2-wise sample of selections by the AETG-style greedy (Cohen et al., 1997), with the
    constraints asked of the solver: variant after variant, each the best of AETG_CANDIDATES
    candidates at covering pairs not yet covered. A candidate starts from the value in most
    uncovered pairs, then takes the features in a random order (seeded), each with the value
    that covers most uncovered pairs with those taken so far, if a valid variant has both
    (the last variant found is kept: a value it already has needs no solve).

    On small models it beats the order-by-order greedy by far (Xtext, 137 features: 21 to 24
    variants where the best of ten orders had 40; RouteFinding, 103: 13 to 14 where 20), and loses
    on large ones, where it is also slow (BusyBox, 854: 47 variants in 40 s where 33): so
    `smallest` runs it too up to AETG_AT_MOST features and keeps the smaller sample."""
    import random

    features = [f.index for f in model.features if f.parent is not None]
    n = len(features)
    with no_gc(), enc.Encoding(model) as hard:
        if not hard.solve(with_config=False):
            return Sample([], 0, 0, 0, void=True)
        solver = hard.solver
        literal = [hard.s(i) * sign for i in features for sign in (1, -1)]  # index 2k: k-th selected, 2k + 1: not
        variable = {hard.s(i): k for k, i in enumerate(features)}
        uncovered = np.ones((2 * n, 2 * n), dtype=bool)
        for k in range(n):  # (pairs of two features only)
            uncovered[2 * k : 2 * k + 2, 2 * k : 2 * k + 2] = False
        for a in range(2 * n):  # pairs that propagation of one of their values refutes
            ok, forced = solver.propagate(assumptions=[literal[a]])
            if not ok:
                uncovered[a, :] = uncovered[:, a] = False
                continue
            for lit in forced:
                at = variable.get(abs(lit))
                if at is not None:
                    b = 2 * at + (1 if lit > 0 else 0)  # the other value of a forced feature
                    uncovered[a, b] = uncovered[b, a] = False
        rng = random.Random(seed)
        witnesses: list[Any] = []
        # (where each feature's s, E and S variables are in a model: a witness is their truth)
        kept = np.array([[hard.s(i), hard.E(i), hard.S(i)] for i in range(len(model.features))], dtype=np.int64).ravel() - 1

        def candidate() -> tuple[list[int], list[int]] | None:
            counts = uncovered.sum(axis=1)
            chosen = [int(np.argmax(counts))]
            if not solver.solve(assumptions=[literal[chosen[0]]]):  # (a value no variant has: none of its pairs)
                uncovered[chosen[0], :] = uncovered[:, chosen[0]] = False
                return None
            seen = solver.get_model()
            order = [k for k in range(n) if k != chosen[0] // 2]
            rng.shuffle(order)
            for k in order:
                gains = uncovered[2 * k : 2 * k + 2, chosen].sum(axis=1)
                first = 0 if gains[0] > gains[1] else 1 if gains[1] > gains[0] else rng.randrange(2)
                for a in (2 * k + first, 2 * k + 1 - first):
                    lit = literal[a]
                    if seen[abs(lit) - 1] == lit:
                        chosen.append(a)
                        break
                    if solver.solve(assumptions=[literal[c] for c in chosen] + [lit]):
                        seen = solver.get_model()
                        chosen.append(a)
                        break
            return chosen, seen

        pairs = int(np.triu(uncovered).sum())  # (those propagation leaves: `progress(covered, pairs)`)
        while uncovered.any():
            if progress is not None:
                progress(pairs - int(np.triu(uncovered).sum()), pairs)
            best: tuple[list[int], list[int]] | None = None
            gain = 0
            for _ in range(AETG_CANDIDATES):
                made = candidate()
                if made is None:
                    break
                covers = int(uncovered[np.ix_(made[0], made[0])].sum())
                if covers > gain:
                    best, gain = made, covers
            if best is None and made is None:  # (a value no variant has was taken out: again)
                continue
            if best is None:  # no candidate covers a pair: the next one a valid variant has, or none
                for a, b in zip(*np.nonzero(np.triu(uncovered)), strict=True):
                    if solver.solve(assumptions=[literal[a], literal[b]]):
                        seen = solver.get_model()
                        best = ([2 * k + (0 if seen[abs(literal[2 * k]) - 1] > 0 else 1) for k in range(n)], seen)
                        break
                    uncovered[a, b] = uncovered[b, a] = False
                if best is None:
                    break
            chosen, seen = best
            uncovered[np.ix_(chosen, chosen)] = False
            witnesses.append((np.asarray(seen) > 0)[kept])
        variants = _variants(model, hard, witnesses)
        if progress is not None:
            progress(pairs, pairs)
    total = _count(n, 2, 2)
    shown = _shown_pairs(variants, features)
    return Sample(variants, total, shown, shown, aetg=True)


def _shown_pairs(variants: list[dict[int, Binding | None]], features: list[int]) -> int:
    """The pairs of selections of two features that some of the variants have."""
    if not variants:
        return 0
    on = np.asarray([[v[i] is not None for i in features] for v in variants], dtype=np.int32)
    values = np.concatenate([on, 1 - on], axis=1)  # per variant: each feature selected, then each not
    together = (values.T @ values) > 0
    n = len(features)
    for k in range(n):  # (a feature's own two values are no pair)
        together[k, n + k] = together[n + k, k] = False
    return int(np.triu(together, 1).sum())


def _place(
    solver: Any,
    candidates: int,
    partial: Callable[[int], list[int]],
    wanted: list[int],
    solve: Callable[[list[int]], bool],
    repair: Callable[[int, list[int]], bool] | None = None,
) -> tuple[int, list[int], bool] | None:
    """The first partial variant of `candidates` (a bit set) that propagation and a solve
    find compatible with the combination `wanted`, what propagation implied there, and
    whether `repair(k, implied)` found it so without the solve (it then set the witness);
    else the solver's model is its new witness. None: none is."""
    while candidates:
        k = (candidates & -candidates).bit_length() - 1
        candidates &= candidates - 1
        assumed = [*partial(k), *wanted]
        consistent, implied = solver.propagate(assumptions=assumed)
        if consistent:
            if repair is not None and repair(k, implied):
                return k, implied, True
            if solve(assumed):
                return k, implied, False
    return None


@dataclass
class _Found:
    witnesses: list[Any]  # per variant: the truth of its s, E, S variables (a bool array, `_variants`)
    invalid: int
    shown: int


def _variants(model: FeatureModel, hard: enc.Encoding, witnesses: list[Any]) -> list[dict[int, Binding | None]]:
    """The variants of witnesses that hold the truth of every feature's s, E and S, in that order."""
    variants = []
    for truth in witnesses:
        variants.append(
            {
                i: Binding.from_flags(bool(truth[3 * i + 1]), bool(truth[3 * i + 2])) if truth[3 * i] else None
                for i in range(len(model.features))
            }
        )
    return variants


class _Bits:
    """Per literal, a bit set of partial variants (rows of 64-bit words; more words as the
    variants grow)."""

    def __init__(self, rows: int) -> None:
        self.words = np.zeros((rows, 4), dtype=np.uint64)

    def room(self, k: int) -> None:
        while k >= 64 * self.words.shape[1]:
            self.words = np.concatenate([self.words, np.zeros_like(self.words)], axis=1)

    def set(self, rows: Any, k: int) -> None:
        self.room(k)
        self.words[rows, k >> 6] |= np.uint64(1 << (k & 63))

    def clear(self, rows: Any, k: int) -> None:
        self.words[rows, k >> 6] &= ~np.uint64(1 << (k & 63))


def _lowest(words: Any) -> Any:
    """Per row of 64-bit words (at least one not zero): the index of its lowest set bit."""
    first = (words != 0).argmax(axis=1)
    chosen = words[np.arange(len(words)), first]
    low = chosen & (~chosen + np.uint64(1))
    return first * 64 + np.log2(low.astype(np.float64)).astype(np.int64)


def _as_int(words: Any) -> int:
    return int.from_bytes(np.ascontiguousarray(words, dtype="<u8").tobytes(), "little")


def _pairs(
    hard: enc.Encoding,
    values: list[tuple[int, tuple[int, ...]]],
    total: int,
    progress: Callable[[int, int], None] | None,
) -> _Found:
    """The 2-wise greedy, a row at a time: for each value, the combinations with every later
    value are judged at once (numpy, over bit sets of the partial variants per literal):
    those a partial variant has are shown; those a witness has are added to the first such
    partial variant, all together; those unit propagation of the row's value alone refutes
    are refuted. Only the rest go one by one, as the module says.

    The literals of a partial variant are those of the values' literals whose bit it has
    (what propagation implied besides is implied again by them)."""
    if not values:  # (a model of its root alone: nothing to combine)
        return _Found([], 0, 0)
    solver = hard.solver
    universe = sorted({lit for _, literals in values for lit in literals} | {-lit for _, literals in values for lit in literals})
    at = {lit: k for k, lit in enumerate(universe)}
    lits = np.array(universe, dtype=np.int64)
    negation = np.array([at[-lit] for lit in universe], dtype=np.int64)
    first = np.array([at[literals[0]] for _, literals in values], dtype=np.int64)
    second = np.array([at[literals[-1]] for _, literals in values], dtype=np.int64)
    feature = np.array([i for i, _ in values], dtype=np.int64)
    held, witnessed = _Bits(len(universe)), _Bits(len(universe))
    witnesses: list[Any] = []  # per partial variant (as many as there are): the universe indices its witness has
    # per value: the combinations still to come with it, all of them at first (every value of another feature)
    _, first_of, per_feature = np.unique(feature, return_inverse=True, return_counts=True)
    waiting = len(values) - per_feature[first_of]
    variables = np.array([[hard.s(i), hard.E(i), hard.S(i)] for i in range(len(hard.model.features))], dtype=np.int64).ravel()

    lit_var, lit_positive = np.abs(lits) - 1, lits > 0  # (each universe literal's place in a model)
    checker = _Clauses(hard.recorded) if hard.recorded is not None else None

    # per partial variant: its witness's truth of every variable, a bit each (as bools, a
    # byte per variable: Automotive01's 1,201 partial variants held 21 MB that way)
    full: list[Any] = []
    variable_count = solver.nof_vars()

    def truth_of(k: int) -> Any:
        return np.unpackbits(full[k], count=variable_count).view(bool)

    def witness(k: int, truth: Any = None) -> None:
        """The solver's model (or `truth`, a full assignment) as partial variant k's witness."""
        if truth is None:
            truth = np.array(solver.get_model(), dtype=np.int32) > 0
        has = np.nonzero(truth[lit_var] == lit_positive)[0]
        if k < len(witnesses):
            witnessed.clear(witnesses[k], k)
            witnesses[k], full[k] = has, np.packbits(truth)
        else:
            witnesses.append(has)
            full.append(np.packbits(truth))
        witnessed.set(has, k)

    def repair(k: int, implied: list[int]) -> bool:
        """Whether k's witness with `implied` set is again a model of the clauses (only
        those over the variables it changes are looked at); if so it is k's new witness."""
        if checker is None:
            return False
        forced = np.array(implied, dtype=np.int64)
        at, value = np.abs(forced) - 1, forced > 0
        truth = truth_of(k)
        changed = at[truth[at] != value]
        if len(changed) > REPAIR_AT_MOST:
            return False
        moved = truth.copy()
        moved[changed] = ~truth[changed]
        if not checker.holds(moved, changed):
            return False
        witness(k, moved)
        return True

    def hold(k: int, literals: list[int]) -> None:
        held.set(indices(literals), k)

    def partial(k: int) -> list[int]:
        return list(lits[np.nonzero(held.words[:, k >> 6] & np.uint64(1 << (k & 63)))[0]].tolist())

    phases = _Phases(values)

    def solve(assumptions: list[int]) -> bool:
        solver.set_phases(phases(waiting))
        return bool(solver.solve(assumptions=assumptions))

    # universe indices of solver literals, by the literal (offset by the variable count)
    top = int(max((abs(lit) for lit in universe), default=0))
    index_of = np.full(2 * top + 1, -1, dtype=np.int64)
    index_of[lits + top] = np.arange(len(universe))

    def indices(literals: list[int], negated: bool = False) -> Any:
        """The universe indices of those of `literals` (or of their negations) in it."""
        found = np.array(literals, dtype=np.int64)
        found = found[np.abs(found) <= top]
        found = index_of[(-found if negated else found) + top]
        return found[found >= 0]

    # What unit propagation of each value alone implies, for all pairs at once: implies[u]
    # packs one bit per value whose propagation implies universe literal u (a pair one of
    # whose values implies the negation of one of the other's literals is refuted).
    implies = np.zeros((len(universe), (len(values) + 7) // 8), dtype=np.uint8)
    void = np.zeros(len(values), dtype=bool)  # values no valid variant has (propagation fails)
    for v, (_, literals) in enumerate(values):
        consistent, implied = solver.propagate(assumptions=list(literals))
        if not consistent:
            void[v] = True
            continue
        implies[indices(implied), v >> 3] |= np.uint8(0x80 >> (v & 7))

    def implied_by(rows: Any, v: int) -> Any:
        """Per universe literal of `rows`: whether value v's propagation implies it."""
        return (implies[rows, v >> 3] & np.uint8(0x80 >> (v & 7))) != 0

    def both(bits: _Bits, a: int, partners: Any) -> Any:
        """Per partner value (an index or an array of them), the words of the partial
        variants of `bits` (held or witnessed) that have value a's literals and its own."""
        words = bits.words
        return words[first[partners]] & words[second[partners]] & words[first[a]] & words[second[a]]

    def clashing(known: Any) -> int:
        """The partial variants holding one of the universe literals at indices `known`, as a
        bit set."""
        return _as_int(np.bitwise_or.reduce(held.words[known], axis=0)) if len(known) else 0

    def place(a: int, own: tuple[int, ...], rest: list[int]) -> int:
        """Place, in order, the pairs of value a with each of `rest` (values) that no partial
        variant has yet; how many of them no valid variant has.

        As the module says, one by one, but for one saving: where the first partial variant
        that a pair may join (no literal it holds contradicts what the pair's propagation
        implies) is also the first for some of the next pairs, not shown by any witness now,
        they are solved for together, and a success adds them all (what one by one would
        most likely have done, with one solve for each). A failed solve's core takes out the
        pairs it names (LOOKAHEAD_FAILURES times at most); then the pair goes alone. Each
        pair is looked ahead at once at most; propagation is done once per pair."""
        refuted = 0
        propagated: dict[int, tuple[list[int], Any] | None] = {}  # w -> (implied, its negations' indices); None: refuted

        def propagation(w: int) -> tuple[list[int], Any] | None:
            if w not in propagated:
                consistent, implied = solver.propagate(assumptions=[*own, *values[w][1]])
                propagated[w] = (implied, indices(implied, negated=True)) if consistent else None
            return propagated[w]

        seen_to = 0  # the pairs of `rest` before this one have been looked ahead at
        for i, w in enumerate(rest):
            wanted = [*own, *values[w][1]]
            if both(held, a, w).any():
                continue
            common = both(witnessed, a, w)
            if common.any():
                hold(int(_lowest(common[None, :])[0]), wanted)
                continue
            found = propagation(w)
            if found is None:
                refuted += 1
                continue
            implied, known = found
            candidates = ((1 << len(witnesses)) - 1) & ~clashing(known)
            if candidates:
                seen_to = max(seen_to, i + 1)
                k = (candidates & -candidates).bit_length() - 1
                batch, seen_to = ahead(a, own, rest, seen_to, k, wanted, propagation)
                if batch:
                    fits = together(k, [*partial(k), *wanted], batch)
                    if fits:
                        continue
                    if fits is None:  # (k cannot take the pair itself: not asked again below)
                        candidates &= ~(1 << k)
            placed = _place(solver, candidates, partial, wanted, solve, repair)
            if placed is not None:
                if not placed[2]:
                    witness(placed[0])
                hold(placed[0], wanted + placed[1])
            elif solve(wanted):
                new(wanted + implied)
            else:
                refuted += 1
        return refuted

    def ahead(
        a: int, own: tuple[int, ...], rest: list[int], start: int, k: int, wanted: list[int],
        propagation: Callable[[int], tuple[list[int], Any] | None],
    ) -> tuple[list[list[int]], int]:
        """The next pairs of value a with `rest` from `start` (up to LOOKAHEAD of them) that
        partial variant k is the first one to take, not shown by a witness now, whose values'
        literals contradict neither `wanted`'s nor each other's (what propagation implies
        is left to the solve): those literals; and where the look ended."""
        window = np.array(rest[start : start + LOOKAHEAD], dtype=np.int64)
        if not len(window):
            return [], start
        open_ = ~(both(held, a, window).any(axis=1) | both(witnessed, a, window).any(axis=1))
        below = (1 << (k + 1)) - 1  # (k and every partial variant before it)
        taken = {abs(literal): literal for literal in wanted}
        batch = []
        for w in window[open_].tolist():
            found = propagation(w)
            if found is None or (below & ~clashing(found[1])) != 1 << k:
                continue
            theirs = values[w][1]
            if all(taken.get(abs(literal), literal) == literal for literal in theirs):
                taken.update((abs(literal), literal) for literal in theirs)
                batch.append(list(theirs))
        return batch, start + len(window)

    def together(k: int, base: list[int], batch: list[list[int]]) -> bool | None:
        """Solve for partial variant k with `base` (its literals and a pair's) and the
        literals of `batch`, less those a failed solve's core names: True when that adds
        the pair and some of them to k, with the new witness; None when a core shows that k
        cannot take the pair; False when LOOKAHEAD_FAILURES solves failed or none is left."""
        innocent = set(base)
        for tried in range(1, LOOKAHEAD_FAILURES + 1):
            assumed = [*base, *(literal for theirs in batch for literal in theirs)]
            # (solved first, not repaired: a propagation before the solve leaves its values
            # as the solver's saved phases, and the witnesses found after it showed less:
            # BusyBox's sample was 106 variants that way, 48 this way)
            if solve(assumed):
                witness(k)
                _, implied = solver.propagate(assumptions=assumed)
                hold(k, assumed + implied)
                return True
            if tried == LOOKAHEAD_FAILURES:
                break
            core = set(solver.get_core() or ()) - innocent
            if not core:
                return None
            batch = [theirs for theirs in batch if core.isdisjoint(theirs)]
            if not batch:
                return False
        return False

    def new(literals: list[int]) -> None:
        """A new partial variant of `literals`, with the solver's model as its witness."""
        k = len(witnesses)
        held.room(k)
        witnessed.room(k)
        witness(k)
        hold(k, literals)

    invalid = done = 0
    for a, (_, own) in enumerate(values):
        partners = np.nonzero(feature[a + 1 :] != feature[a])[0] + a + 1
        if progress is not None and done // REPORT != (done + len(partners)) // REPORT:
            progress(done, total)
        done += len(partners)
        waiting[a] -= len(partners)
        waiting[partners] -= 1
        if not len(partners):
            continue
        if void[a]:  # (no valid variant has this value: no combination with it is valid)
            invalid += len(partners)
            continue
        mine = np.unpackbits(implies[negation[first[a]]] | implies[negation[second[a]]], count=len(values)) != 0
        bad = (
            void[partners]
            | mine[partners]  # (the partner implies the negation of one of this value's literals)
            | implied_by(negation[first[partners]], a)  # (this value implies the negation of one of the partner's)
            | implied_by(negation[second[partners]], a)
        )
        invalid += int(np.count_nonzero(bad))
        partners = partners[~bad]
        partners = partners[~both(held, a, partners).any(axis=1)]
        if not len(partners):
            continue
        common = both(witnessed, a, partners)
        free = common.any(axis=1)
        if free.any():  # (added to the first partial variant whose witness has them)
            ks = _lowest(common[free])
            for k in np.unique(ks):
                group = partners[free][ks == k]
                rows = np.concatenate([first[group], second[group], [first[a], second[a]]])
                held.set(rows, int(k))
        rest = partners[~free]
        if len(rest):
            invalid += place(a, own, rest.tolist())
    # The sample: the last witness of each partial variant (it has every literal the
    # partial variant holds, so every valid combination is in one of them).
    truths = [truth_of(k)[variables - 1] for k in range(len(witnesses))]
    # counted again over those variants, the sample
    shown_total = 0
    for a in range(len(values)):
        partners = np.nonzero(feature[a + 1 :] != feature[a])[0] + a + 1
        if len(partners):
            shown_total += int(np.count_nonzero(both(witnessed, a, partners).any(axis=1)))
    if progress is not None:
        progress(total, total)
    return _Found(truths, invalid, shown_total)


class _Clauses:
    """The clauses by variable, to check whether a full assignment changed on a few
    variables still satisfies them: only the clauses over those variables are looked at."""

    def __init__(self, clauses: enc.Clauses) -> None:
        flat, lengths = clauses.arrays()
        self.literals = flat.astype(np.int64)
        self.lengths = np.asarray(lengths, dtype=np.int64)
        self.starts = np.cumsum(self.lengths) - self.lengths
        owner = np.repeat(np.arange(len(self.lengths), dtype=np.int64), self.lengths)
        variable = np.abs(self.literals)
        order = np.argsort(variable, kind="stable")
        self.occurs = owner[order]  # the clauses of variable v: occurs[first[v - 1] : first[v]]
        self.first = np.searchsorted(variable[order], np.arange(1, int(variable.max(initial=0)) + 2))
        self.at, self.positive = variable - 1, self.literals > 0

    def holds(self, truth: Any, changed: Any) -> bool:
        """Whether `truth` (per variable, from 0) satisfies every clause over `changed`."""
        changed = changed[changed < len(self.first) - 1]
        clauses = np.unique(self.occurs[_ranges(self.first[changed], self.first[changed + 1])])
        if not len(clauses):
            return True
        lengths = self.lengths[clauses]
        where = _ranges(self.starts[clauses], self.starts[clauses] + lengths)
        true = truth[self.at[where]] == self.positive[where]
        return bool(np.logical_or.reduceat(true, np.cumsum(lengths) - lengths).all())


def _ranges(starts: Any, ends: Any) -> Any:
    """The indices of the ranges [starts[i], ends[i]), one after the other."""
    lengths = ends - starts
    total = int(lengths.sum())
    return np.repeat(starts - (np.cumsum(lengths) - lengths), lengths) + np.arange(total)


def _combinations(values: list[tuple[int, tuple[int, ...]]], t: int) -> Iterator[tuple[int, ...]]:
    """The combinations, in order: t values (by index) of t different features."""
    for combo in combinations(range(len(values)), t):
        if len({values[v][0] for v in combo}) == t:
            yield combo


class _Phases:
    """`_phases` for the 2-wise greedy, on numpy: per variable, the polarity of the value
    with the most open combinations (the first value, on a tie)."""

    def __init__(self, values: list[tuple[int, tuple[int, ...]]]) -> None:
        last = np.array([literals[-1] for _, literals in values], dtype=np.int64)
        variable = np.abs(last)
        order = np.lexsort((np.arange(len(values)), variable))  # by variable, then by value
        self.order, self.last = order, last[order]
        starts = np.r_[True, variable[order][1:] != variable[order][:-1]]
        self.starts = np.nonzero(starts)[0]
        self.pairs = bool(np.all(np.diff(np.r_[self.starts, len(order)]) == 2))

    def __call__(self, waiting: Any) -> list[int]:
        counts = waiting[self.order]
        if self.pairs:  # (every variable has its two values: the usual case)
            firsts = self.starts
            pick = np.where(counts[firsts] >= counts[firsts + 1], firsts, firsts + 1)
        else:
            pick = np.array([start + int(np.argmax(counts[start:end]))
                             for start, end in zip(self.starts, np.r_[self.starts[1:], len(counts)], strict=True)])
        return list(self.last[pick].tolist())


def _phases(values: list[tuple[int, tuple[int, ...]]], waiting: Any) -> list[int]:
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

"""Analyses of a model alone (reference.md section 7): core, dead and false-optional
features, atomic sets, impossible bindings, and exact counts.

Every question but the counts is asked of one hard (selector-free) build of the one
encoding, on one solver, with `Encoding.cover`: a few solves under polarity hints settle
most questions at once, and what is left is solved for in batches, whose failed solves'
cores set aside the questions that cannot go together (for the bindings, unit
propagation first refutes most impossible ones). Atomic sets are classes of features that every valid variant
selects together: the variants found while answering the other questions split the
features by what they select, and so do the variants derived from the first few of them
without a solve (`cuts`: a valid variant less one of its subtrees); the classes left are
settled in rounds (`_atomic_sets`).

Counts are exact (Python integers). They come from the model's compiled forms
(`compiled.py`: d-DNNFs kept beside the model, made on first use within a time limit) and,
where no compiled form is at hand, from Ganak (`pyganak`), an exact projected
model counter: the selection count counts `selection_cnf` (section 2 alone, as other tools
read it); the variant count counts the hard build of the encoding projected onto each
feature's selection, time and mode, with the time and mode of a feature left out fixed (the
start state's variables are existential: a variant counts when some start state exists).
Exact counting is #P-hard: the variant count of a generated model of 3,000 features takes a
minute, so each count has a time limit and is reported as not done when it runs out.
"""

from __future__ import annotations

from array import array
from collections.abc import Callable, Hashable, Iterable, Sequence
from dataclasses import dataclass, field
from operator import neg
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from ..language.model import FeatureModel, GroupKind, Mode, Time
from ..process import no_gc
from . import encoding as enc
from .symmetry import Classes

if TYPE_CHECKING:
    from .cuts import Cuts

T = TypeVar("T")
Progress = Callable[[str], None]  # told the name of each step as it begins
# Variants whose cuts split the atomic-set candidates before the first round: at 10,000
# generated features, 8 take the rounds from 407 solves to 130 (each costs a linear pass over
# the clauses, 16 ms there; 64 save 9 more solves and cost a second)
CUT_WITNESSES = 8
# The atomic sets' later rounds, while the cuts of their variants pay (`_atomic_sets`): the
# neighbours asked about in one round (at least ROUND_PAIRS, and at least a CUT_ROUNDS-th of
# those open, so that there are few such rounds), and the classes its cuts must split per
# variant (a cut costs some two solves' time) for the next round to be cut too
ROUND_PAIRS, CUT_ROUNDS, CUT_PAYS = 128, 8, 8
COUNT_TIMEOUT = 60.0  # seconds per count, by default: exact counting can take exponential time

SAMPLED = 24  # uniform variants whose selections split the atomic sets' candidates (`_from_form`)
PAIRWISE_UP_TO = 64  # features of one such group compared pair by pair; ddnnife's atomic sets past it
COMPILED_STEP = "the compiled form"  # (analyse's first step, before STEPS)
STEPS = (
    "satisfiability",
    "core and dead features",
    "atomic sets",
    "impossible bindings",
    "false-optional features",
    "selection count",
    "variant count",
)


@dataclass
class Analysis:
    """What section 7 asks of a model; feature ids in pre-order throughout."""

    void: bool  # no valid variant at all: every list below is empty, both counts 0
    core: list[str] = field(default_factory=list)
    dead: list[str] = field(default_factory=list)
    false_optional: list[str] = field(default_factory=list)
    atomic_sets: list[list[str]] = field(default_factory=list)  # every class, singletons too
    impossible: list[tuple[str, str, str]] = field(default_factory=list)  # (id, "time"/"mode", value)
    selection_count: int | None = None  # None: not asked for, or not done in time (`uncounted`)
    variant_count: int | None = None
    uncounted: list[str] = field(default_factory=list)  # the counts given up on ("selection", "variant")
    # per count done ("selection", "variant"): how, "compiled form" or "Ganak", and why Ganak
    counted_by: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Compiling:
    """Whether and how `analyse` answers from compiled forms (`compiled.py`): `use` (the
    command line does; a library caller asks for it, else the solver and Ganak answer),
    kept in `beside`/.motivml/compiled (None: kept nowhere; MOTIVML_COMPILED_DIR, when set,
    names the folder instead), made within `limit` seconds per form (None: no limit) when
    missing."""

    beside: Path | None = None
    limit: float | None = 60.0
    use: bool = False


def analyse(
    model: FeatureModel,
    counts: bool = True,
    progress: Progress | None = None,
    count_timeout: float | None = COUNT_TIMEOUT,
    compiling: Compiling = Compiling(),
) -> Analysis:
    """Every analysis of section 7 (the counts only with `counts`: from the compiled
    forms as `compiling` says, else by Ganak, each given up after `count_timeout`
    seconds).

    With `counts` and a compiled form of the variants at hand (kept, or made within
    `compiling.limit`), every answer comes from it (`_from_form`); else from the SAT
    solver, as below."""
    step = progress or (lambda _: None)
    step(COMPILED_STEP)
    variants_form: Any = None  # (the variants' form, or why there is none: asked once)
    if compiling.use and counts:  # (without counts the solver is quicker: Automotive01 0.6 s, its form 3.5 s)
        from .compiled import CompiledForm, Kind, compiled_form

        variants_form = compiled_form(model, compiling.beside, Kind.VARIANTS, compiling.limit)
        if isinstance(variants_form, CompiledForm):
            return _from_form(model, variants_form, counts, step, compiling, count_timeout)
    features = model.features
    n = len(features)
    with no_gc(), enc.Encoding(model, record=True) as hard:
        step(STEPS[0])
        if not hard.solve(with_config=False):
            return Analysis(True, selection_count=0 if counts else None, variant_count=0 if counts else None)
        selections: list[bytes] = []  # what each variant found selects, one byte per feature
        # the first CUT_WITNESSES variants found, in full (as C ints: at 100,000 features
        # eight Python lists of 400,000 ints were 115 MB)
        first: list[array[int]] = []

        def witness(values: list[int]) -> None:
            if len(first) < CUT_WITNESSES:
                first.append(array("i", values))
            selections.append(hard.selection_of(values))

        step(STEPS[1])
        # one question per class of interchangeable features (symmetry.py), for its first
        same = Classes(model)
        asked, at = same.asked, same.position  # (a parent is never in a class: it has sub-features)
        s = [hard.s(i) for i in range(n)]
        parents = [f.parent for f in features]
        apart = alternatives_apart(model, asked)
        possible = hard.cover(
            [[s[i]] for i in asked] + [[-s[i]] for i in asked],
            with_config=False,
            order=apart + [len(asked) + k for k in apart],
            # (selection alone first: its variant splits the atomic sets' candidates better than
            # one hinted active too, 173 solves where 733 for the groups shape at 10,000)
            hints=[s, _everything(hard, model), [s[0], *(-literal for literal in s[1:])]],
            witness=witness,
            batch=True,  # (most of what the hints leave open is possible)
            refute=False,
            # (a feature is selected only with its parent: below a dead one, dead without a solve)
            requires=[None if (p := parents[i]) is None else at[p] for i in asked] + [None] * len(asked),
        )
        alive = same.spread(possible[: len(asked)])
        is_core = [not can for can in same.spread(possible[len(asked) :])]
        core = [i for i in range(n) if is_core[i]]

        step(STEPS[2])
        # Cuts of the first variants found (`cuts.Cuts`): each valid cut is a variant
        # that drops a subtree, found without a solve. Two features that a variant selects
        # and whose deepest valid cuts differ are told apart by one of those cuts, so the
        # candidates are split by their deepest cut in each of these variants before the
        # first round.
        assert hard.recorded is not None
        from .cuts import Cuts

        cuts = Cuts(model, hard.recorded)
        first += _covering(hard, model, alive, selections, witness)
        key = list(zip(*(_deepest_cuts(cuts, values).tolist() for values in first), strict=True))
        live_asked = [i for i in asked if alive[i]]
        atomic = _atomic_sets(
            hard, live_asked, core, selections, witness, key, cut_key=lambda values: _deepest_cuts(cuts, values)
        )
        atomic = _atomic_classes(hard, atomic, same.members(), alive, is_core)
        # The bindings on the same solver: the variants the questions above left in its
        # saved phases select most live features, so few solves are left to do (at 10,000
        # features, 23 solves where a fresh solver takes 75, and no second encoding).
        step(STEPS[3])
        impossible = _for_each_member(
            same, impossible_bindings(hard, model, [alive[i] and i in at for i in range(n)])
        )
    step(STEPS[4])
    analysis = _answered(model, core, alive, atomic, impossible)
    if counts:
        from .compiled import Kind

        step(STEPS[5])
        analysis.selection_count = _counted(model, Kind.SELECTIONS, compiling, count_timeout, analysis.counted_by)
        step(STEPS[6])
        analysis.variant_count = _counted(
            model, Kind.VARIANTS, compiling, count_timeout, analysis.counted_by, variants_form
        )
        analysis.uncounted = [
            name
            for name, value in (("selection", analysis.selection_count), ("variant", analysis.variant_count))
            if value is None
        ]
    return analysis


def _from_form(
    model: FeatureModel, form: Any, counts: bool, step: Progress, compiling: Compiling, timeout: float | None
) -> Analysis:
    """Section 7 from the compiled form of the variants (`compiled.CompiledForm`): one pass
    counts, for every feature, the variants that select it, make it Early and make it
    Static; core and dead features and impossible bindings are read off those counts.
    Two live features neither core nor dead are in one atomic set when as many variants
    select both as select each: features are grouped by their count and by what SAMPLED
    uniform variants make of them, and compared by one count per pair within a group of
    at most PAIRWISE_UP_TO; the members of larger groups are left to ddnnife's atomic sets
    (in Rust, from counts: 4 s for Automotive02's 14,010 features, where its groups of 2,001
    and 1,608 features with the same count, compared pair by pair, took minutes; on
    BusyBox, ddnnife over every feature takes 0.15 s, the pairs 0.03 s)."""
    step(STEPS[0])
    total = form.count()
    if total == 0:
        return Analysis(True, selection_count=0 if counts else None, variant_count=0 if counts else None)
    features = model.features
    n = len(features)
    step(STEPS[1])
    _, through = form.every_literal()
    selected = [through.get(form.literal(i), 0) for i in range(n)]
    early = [through.get(form.literal(i, "early"), 0) for i in range(n)]
    static = [through.get(form.literal(i, "static"), 0) for i in range(n)]
    alive = [c > 0 for c in selected]
    core = [i for i in range(n) if selected[i] == total]
    step(STEPS[2])
    drawn = form.uniform(SAMPLED, seed=0)
    groups: dict[tuple[int, tuple[bool, ...]], list[int]] = {}
    for i in range(n):
        if alive[i] and selected[i] != total:
            groups.setdefault((selected[i], tuple(d[form.literal(i) - 1] > 0 for d in drawn)), []).append(i)
    atomic: list[list[int]] = [core]
    large: list[int] = []  # (members of groups too large to compare pair by pair)
    for members in groups.values():
        if len(members) > PAIRWISE_UP_TO:
            large += members
            continue
        sets: list[list[int]] = []
        for i in members:
            for found in sets:
                if form.count([form.literal(i), form.literal(found[0])]) == selected[i]:
                    found.append(i)
                    break
            else:
                sets.append([i])
        atomic += sets
    together: set[int] = set()
    for members in form.atomic_sets([form.literal(i) for i in large]) if large else []:
        atomic.append([form.feature_of(literal) for literal in members])
        together.update(atomic[-1])
    atomic += [[i] for i in large if i not in together]
    atomic = sorted(sorted(members) for members in atomic)
    step(STEPS[3])
    impossible: list[tuple[int, str, Time | Mode]] = []
    for f in features:
        i = f.index
        if not alive[i]:
            continue
        if f.time_allowed is None:
            impossible += [(i, "time", v) for v, c in ((Time.EARLY, early[i]), (Time.LATE, selected[i] - early[i])) if not c]
        if f.mode_allowed is None:
            impossible += [
                (i, "mode", v) for v, c in ((Mode.STATIC, static[i]), (Mode.DYNAMIC, selected[i] - static[i])) if not c
            ]
    step(STEPS[4])
    analysis = _answered(model, core, alive, atomic, impossible)
    if counts:
        from .compiled import Kind

        step(STEPS[5])
        analysis.selection_count = _counted(model, Kind.SELECTIONS, compiling, timeout, analysis.counted_by)
        step(STEPS[6])
        analysis.variant_count = total
        analysis.counted_by["variant"] = "compiled form"
        analysis.uncounted = ["selection"] if analysis.selection_count is None else []
    return analysis


def _answered(
    model: FeatureModel,
    core: list[int],
    alive: Sequence[bool],
    atomic: list[list[int]],
    impossible: list[tuple[int, str, Time | Mode]],
) -> Analysis:
    """The analysis of a satisfiable model from its answers by feature index, with the
    false-optional features derived: s(f) -> s(parent) always holds, so f is selected
    whenever its parent is iff the two are selected together in every variant, iff they
    share an atomic set."""
    features = model.features
    atomic_set_of = {i: k for k, members in enumerate(atomic) for i in members}
    false_optional = [
        f.index
        for f in features
        if f.parent is not None and not f.mandatory and alive[f.index] and atomic_set_of[f.index] == atomic_set_of[f.parent]
    ]
    return Analysis(
        False,
        core=[features[i].id for i in core],
        dead=[f.id for f in features if not alive[f.index]],
        false_optional=[features[i].id for i in false_optional],
        atomic_sets=[[features[i].id for i in members] for members in atomic],
        impossible=[(features[i].id, aspect, str(value)) for i, aspect, value in impossible],
    )


def _counted(
    model: FeatureModel,
    kind: Any,
    compiling: Compiling,
    timeout: float | None,
    how: dict[str, str],
    known: Any = None,
) -> int | None:
    """A count from the compiled form of `kind` (`known`: the form, or why there is none,
    if already asked), or by Ganak where there is none (`how` says which, and why)."""
    from .compiled import Kind, NotCompiled, compiled_form

    name = "selection" if kind is Kind.SELECTIONS else "variant"
    if compiling.use:
        form = known if known is not None else compiled_form(model, compiling.beside, kind, compiling.limit)
        if not isinstance(form, NotCompiled):
            how[name] = "compiled form"
            return form.count()
        how[name] = f"Ganak: no compiled form, {form.reason}"
    else:
        how[name] = "Ganak"
    return (count_selections if kind is Kind.SELECTIONS else count_variants)(model, timeout)


COVERING = 4  # variants asked for what no variant found selects yet (`_covering`)


def _covering(
    hard: enc.Encoding,
    model: FeatureModel,
    alive: Sequence[bool],
    selections: list[bytes],
    witness: Callable[[list[int]], None],
) -> list[array[int]]:
    """Up to COVERING more variants for the cuts, each hinted towards selecting the live
    features that no variant found so far selects (as `_everything` hints, from the
    emptiest variant). A feature no variant selects is in one candidate class with every
    other such feature, and the atomic sets' rounds then compare them pair by pair, a
    search each; a variant that selects many of them, and its cuts, tell most apart at
    once."""
    import numpy as np

    n = len(model.features)
    inherited = _inherited(model)
    seen = np.zeros(n, dtype=bool)
    for row in selections:
        seen |= np.frombuffer(row, dtype=np.uint8).astype(bool)
    wanted = np.asarray(alive, dtype=bool) & ~seen
    found: list[array[int]] = []
    base = hard.assumptions(with_config=False)
    for _ in range(COVERING):
        if wanted.sum() < 2:
            break
        with_ancestors: set[int] = set()
        for i in np.flatnonzero(wanted).tolist():  # (and their ancestors: a feature is selected only with its parent)
            j: int | None = i
            while j is not None and j not in with_ancestors:
                with_ancestors.add(j)
                j = model.features[j].parent
        hard.unhint()
        hard.hint(_selecting(hard, sorted(with_ancestors), inherited))
        if not hard.solve_counted(base):
            break
        values = hard.assignment()
        witness(values)
        chosen = np.frombuffer(selections[-1], dtype=np.uint8).astype(bool)
        if not (wanted & chosen).any():
            break
        wanted &= ~chosen
        found.append(array("i", values))
    return found


def _everything(hard: enc.Encoding, model: FeatureModel) -> list[int]:
    """Polarity hints towards a variant that selects every feature: each one selected,
    active, Early where it can be (it allows Early and its parent can be Early) and Static
    likewise. Selection alone is not enough: the time and mode left from the last variant
    (of features it did not select, any value) can deselect a feature as soon as they are
    decided (an Early child needs an Early parent), and its subtree with it: at 30,000
    features of deep chains, a variant hinted so selected the root alone."""
    return _selecting(hard, range(len(model.features)), _inherited(model))


def _selecting(
    hard: enc.Encoding, features: Iterable[int], inherited: tuple[list[bool], list[bool]]
) -> list[int]:
    """Hints that select `features`, active, Early and Static where each can be (`inherited`:
    `_inherited`'s never-Early and never-Static)."""
    never_early, never_static = inherited
    hint: list[int] = []
    for i in features:
        early, static = hard.E(i), hard.S(i)
        hint += [hard.s(i), -early if never_early[i] else early, -static if never_static[i] else static, hard.a(i)]
    return hint


def _deepest_cuts(cuts: Cuts, values: Sequence[int]) -> Any:
    """Per feature, 0 if the variant `values` leaves it out, else 1 + its deepest ancestor
    (or itself) where the variant's cut is valid (the root, where none is): a numpy array.

    (Pointer jumping: each feature points at itself where its cut is valid, else at its
    parent, and every pointer is replaced by its target's until none moves: a number of
    passes logarithmic in the depth, in C, where a Python pass over the features took
    2 ms at 10,000.)"""
    import numpy as np

    n = cuts.n
    up = cuts.parents.copy()
    at = np.arange(n, dtype=np.int64)
    cut = cuts.valid(values)
    up[cut] = at[cut]
    while True:
        further = up[up]
        if np.array_equal(further, up):
            break
        up = further
    selected = np.asarray(values[0 : 4 * n : 4], dtype=np.int64) > 0
    return np.where(selected, up + 1, 0)


def _atomic_classes(
    hard: enc.Encoding,
    atomic: list[list[int]],
    members: dict[int, list[int]],
    alive: Sequence[bool],
    core: Sequence[bool],
) -> list[list[int]]:
    """The atomic sets of every live feature, from those of the first feature of each class
    of interchangeable ones (`atomic`; the core class holds every core feature already).

    A live class that is not core is selected together as a whole in every variant, and
    then its members join its first feature's set, or not, and then each member is a set
    of its own (symmetry.py says why): one `cover` of two targets per class decides it
    (can the first member be selected without the second, or the second without the first).
    """
    open_classes = [r for r in members if alive[r] and not core[r]]
    if not open_classes:
        return atomic
    s = hard.s
    targets: list[list[int]] = []
    for r in open_classes:
        second = members[r][1]
        targets += [[s(r), -s(second)], [-s(r), s(second)]]
    possible = hard.cover(targets, with_config=False, batch=True)
    set_of = {i: k for k, found in enumerate(atomic) for i in found}
    for k, r in enumerate(open_classes):
        others = members[r][1:]
        if possible[2 * k] or possible[2 * k + 1]:
            atomic += [[i] for i in others]
        else:
            atomic[set_of[r]] = sorted([*atomic[set_of[r]], *others])
    return sorted(atomic)


def alternatives_apart(model: FeatureModel, features: Sequence[int]) -> list[int]:
    """An order of questions about `features` (their positions, a question per feature,
    or several in a row) in which alternatives are asked about far apart: the first
    member of every XOR group, then the second of every group, and so on, each feature
    after its parent (it comes at the latest of its own and its ancestors' places among
    their alternatives; within one place, in their order).

    No variant selects two alternatives of a group (two Dynamic ones at most, a rare case),
    so a batch of `cover`'s over the members of one group fails, and a solve hinted towards
    them shows one. Asked in the features' own order, the members of a group came together:
    Automotive02's 14,010 features took 88 satisfiable solves (1.5 s) for their core and
    dead features, 61 (0.7 s) in this order, whose windows and batches span many groups."""
    place = [0] * len(model.features)
    for group in model.groups:
        if group.kind is GroupKind.XOR:
            for k, member in enumerate(group.members):
                place[member] = k
    for f in model.features:  # (pre-order: a parent before its sub-features)
        if f.parent is not None:
            place[f.index] = max(place[f.index], place[f.parent])
    return sorted(range(len(features)), key=lambda k: (place[features[k]], k))


def _for_each_member(
    same: Classes, found: list[tuple[int, str, Time | Mode]]
) -> list[tuple[int, str, Time | Mode]]:
    """Answers about the first feature of each class, given to every member, in pre-order."""
    of: list[list[tuple[str, Time | Mode]]] = [[] for _ in same.asked]
    for i, aspect, value in found:
        of[same.position[i]].append((aspect, value))
    return [(i, aspect, value) for i, answers in enumerate(same.spread(of)) for aspect, value in answers]


def _atomic_sets(
    hard: enc.Encoding,
    alive: list[int],
    core: list[int],
    selections: list[bytes],
    witness: Callable[[list[int]], None],
    key: Sequence[Hashable] | None = None,
    cut_key: Callable[[list[int]], Any] | None = None,
) -> list[list[int]]:
    """The classes of `alive` features selected together in every valid variant, pre-order.

    The core features (`core`, all alive) are one class: every variant selects them. The
    others are split into candidate classes by what the variants found so far select, then
    settled in rounds, each ending with one `cover` over the pairs it asks about; the
    variants that answer "yes, they can differ" split the classes again before the next
    round.

    - The first round compares each class's first member with each other member. Unit
      propagation from the first member selected, and from it deselected, settles most
      pairs (two propagations per class). The members that can differ from the first in
      neither direction form its class, which is final; the others are candidates again.
    - Later rounds compare neighbours: the first member with the second, the second with
      the third, and so on. Neighbours that cannot differ are merged; a class whose
      neighbours all merge is final. Where most members differ from each other, one
      variant that shows several neighbours apart halves a class, where comparing
      everything with the first member would split off one member per round.
    """
    import numpy as np  # lazy: only this analysis needs it

    s = hard.s
    base = hard.assumptions(with_config=False)
    is_core = set(core)
    rest = [i for i in alive if i not in is_core]
    first_round: list[list[int]] = [rest]
    if key is not None:  # a first split, by what valid variants known otherwise select
        by_key: dict[Hashable, list[int]] = {}
        for i in rest:
            by_key.setdefault(key[i], []).append(i)
        first_round = list(by_key.values())
    # a candidate class is a list of groups: features already known to be selected together
    if hard.recorded is not None:
        candidates = _implied_both_ways(hard.recorded, first_round, hard.n, np)
    else:
        candidates = [[[i] for i in members] for members in first_round]
    final: list[list[int]] = [core] if core else []
    seen = 0  # the variants already used to split
    star = True
    cut_rows: list[Any] = []  # per variant of the last round: the deepest cut keys of `watched`
    watched: dict[int, int] = {}  # the features whose keys are kept: feature -> its column
    while candidates:
        if len(selections) > seen:
            # split every candidate class by what the variants found since the last split
            # select (per feature, its column of the variants' selections, packed to bits;
            # the members of a group have the same column), and by their cuts
            rows = np.frombuffer(b"".join(selections[seen:]), dtype=np.uint8).reshape(len(selections) - seen, -1)
            columns = np.ascontiguousarray(np.packbits(rows, axis=0).T)
            cut_columns = np.ascontiguousarray(np.stack(cut_rows).T) if cut_rows else None
            split: list[list[list[int]]] = []
            by_cuts = 0  # classes that the cuts split further than the selections
            for groups in candidates:
                by_pattern: dict[bytes, list[list[int]]] = {}
                plain: set[bytes] = set()
                for group in groups:
                    pattern = columns[group[0]].tobytes()
                    plain.add(pattern)
                    if cut_columns is not None and group[0] in watched:
                        pattern += cut_columns[watched[group[0]]].tobytes()
                    by_pattern.setdefault(pattern, []).append(group)
                by_cuts += len(by_pattern) - len(plain)
                split += by_pattern.values()
            if cut_rows and by_cuts < CUT_PAYS * len(cut_rows):
                cut_key = None  # (from here, rounds without cuts and of every pair)
            cut_rows = []  # (used: a round without cuts must not split by them again)
            seen = len(selections)
            candidates = split
        final += [sorted(groups[0]) for groups in candidates if len(groups) == 1]
        open_classes = [groups for groups in candidates if len(groups) > 1]
        targets: list[list[int]] = []
        asked: list[tuple[int, int]] = []  # per target: (its class, the later group compared)
        chained: list[tuple[list[int], tuple[int, int]]] = []
        unasked: set[tuple[int, int]] = set()  # neighbours left for the next round
        round_witness = witness
        if not star and cut_key is not None:
            # A variant that shows x without y, its cuts valid along x's path, shows x apart
            # from each feature it selects below them too: the neighbours of a class of a
            # chain of optional sub-features (selected together in every variant known,
            # as a formula elsewhere asks of one of them) are one solve each, but the first
            # variant that shows a pair of them apart cuts the chain above at every level.
            # So while the cuts pay, a round asks about few pairs (ROUND_PAIRS, each
            # class's deepest first, across classes) and the next round is split by the
            # cuts of its variants too (at 10,000 features of the dense family: 1,656
            # pairs took 317 solves in one round, and 87 in four rounds of 128 pairs).
            watched = {g[0]: j for j, g in enumerate(g for groups in open_classes for g in groups)}
            at = np.fromiter(watched, dtype=np.int64, count=len(watched))
            cut_rows = []

            def round_witness(
                values: list[int], rows: list[Any] = cut_rows, at: Any = at, cut: Callable[..., Any] = cut_key
            ) -> None:
                witness(values)
                rows.append(cut(values)[at].astype(np.int32))

            pairs = _round_robin([[(k, j) for j in range(len(groups) - 1, 0, -1)] for k, groups in enumerate(open_classes)])
            unasked = set(pairs[max(ROUND_PAIRS, len(pairs) // CUT_ROUNDS) :])
        for k, groups in enumerate(open_classes):
            if star:
                first = s(groups[0][0])
                implied = set(hard.solver.propagate(assumptions=[*base, first])[1])
                excluded = set(hard.solver.propagate(assumptions=[*base, -first])[1])
                for j in range(1, len(groups)):
                    other = s(groups[j][0])
                    if other not in implied:
                        targets.append([first, -other])
                        asked.append((k, j))
                    if -other not in excluded:
                        targets.append([-first, other])
                        asked.append((k, j))
            else:
                for j in range(1, len(groups)):
                    if (k, j) in unasked:
                        continue
                    one, other = s(groups[j - 1][0]), s(groups[j][0])
                    chained += [([one, -other], (k, j)), ([-one, other], (k, j))]
        # neighbours' pairs share a feature: in an order that puts every other pair first,
        # the pairs that can be shown by one variant come together in cover's batches
        for parity in (0, 1):
            for sign in (1, -1):
                for target, owner in chained:
                    if owner[1] % 2 == parity and target[0] * sign > 0:
                        targets.append(target)
                        asked.append(owner)
        # (the first round's pairs are what propagating each first member did not settle)
        possible = hard.cover(targets, with_config=False, witness=round_witness, batch=True, refute=not star)
        differs = {asked[t] for t, can in enumerate(possible) if can} | unasked  # (unasked: kept apart)
        candidates = []
        for k, groups in enumerate(open_classes):
            if star:  # the first group and those that cannot differ from it are a class
                same = [*groups[0], *(i for j in range(1, len(groups)) if (k, j) not in differs for i in groups[j])]
                final.append(sorted(same))
                others = [groups[j] for j in range(1, len(groups)) if (k, j) in differs]
                if others:
                    candidates.append(others)
                continue
            merged = [list(groups[0])]  # neighbours that cannot differ join one group
            for j in range(1, len(groups)):
                if (k, j) in differs:
                    merged.append(list(groups[j]))
                else:
                    merged[-1] += groups[j]
            if len(merged) == 1:
                final.append(sorted(merged[0]))
            else:
                candidates.append(merged)
        star = False
    return sorted(final)


def _round_robin(lists: list[list[T]]) -> list[T]:
    """The first item of each list, then the second of each, and so on (by sorting: a
    pass per place over every list would cost the longest list times their number)."""
    places = sorted((j, k) for k, items in enumerate(lists) for j in range(len(items)))
    return [lists[k][j] for j, k in places]


def _implied_both_ways(clauses: enc.Clauses, classes: list[list[int]], n: int, np: Any) -> list[list[list[int]]]:
    """Each class (features in pre-order) as groups of features that the encoding's
    two-literal clauses make imply each other's selection: the strongly connected
    components of the graph s(x) -> s(y) of those clauses, within the class. A mandatory
    sub-feature and its parent are one, so is a feature and a sub-feature it includes:
    selected together in every variant, known without a solve (at 10,000 features of a
    dense model, half the pairs the rounds asked about were these)."""
    cls = np.full(n, -1, dtype=np.int64)
    for k, members in enumerate(classes):
        if len(members) > 1:
            cls[members] = k
    literals, lengths = clauses.arrays()
    starts = (np.cumsum(lengths) - lengths)[lengths == 2]
    a, b = literals[starts].astype(np.int64), literals[starts + 1].astype(np.int64)
    first = (a < 0) & (b > 0)  # -x | y: x -> y
    second = (b < 0) & (a > 0)
    x = np.concatenate((-a[first], -b[second]))
    y = np.concatenate((b[first], a[second]))
    selection = ((x - 1) % 4 == 0) & ((y - 1) % 4 == 0) & (x <= 4 * n) & (y <= 4 * n)  # s(f) is 4f + 1
    i, j = (x[selection] - 1) // 4, (y[selection] - 1) // 4
    within = (cls[i] >= 0) & (cls[i] == cls[j]) & (i != j)
    after: dict[int, list[int]] = {}
    for u, v in zip(i[within].tolist(), j[within].tolist(), strict=True):
        after.setdefault(u, []).append(v)
    component = _components(after)
    candidates: list[list[list[int]]] = []
    for members in classes:
        groups: dict[int, list[int]] = {}
        for f in members:
            groups.setdefault(component.get(f, -1 - f), []).append(f)
        candidates.append(list(groups.values()))
    return candidates


def _components(after: dict[int, list[int]]) -> dict[int, int]:
    """node -> its strongly connected component (Tarjan's algorithm, iterative: chains of
    mandatory sub-features run thousands deep), for the nodes of the graph `after`."""
    index: dict[int, int] = {}
    low: dict[int, int] = {}
    on_stack: set[int] = set()
    stack: list[int] = []
    component: dict[int, int] = {}
    for root in after:
        if root in index:
            continue
        work = [(root, 0)]
        while work:
            v, k = work.pop()
            if k == 0:
                index[v] = low[v] = len(index)
                stack.append(v)
                on_stack.add(v)
            nexts = after.get(v, ())
            if k < len(nexts):
                work.append((v, k + 1))
                w = nexts[k]
                if w not in index:
                    work.append((w, 0))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            if low[v] == index[v]:  # v roots a component: it is what the stack holds down to v
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    component[w] = v
                    if w == v:
                        break
            if work:  # (back in v's parent: what v reaches, its parent reaches)
                u = work[-1][0]
                low[u] = min(low[u], low[v])
    return component


def impossible_bindings(
    hard: enc.Encoding, model: FeatureModel, alive: Sequence[bool]
) -> list[tuple[int, str, Time | Mode]]:
    """(feature, aspect, value) for each time or mode a live feature allows and never takes
    (`alive`: which features some valid variant selects).

    Most are inherited, and found without the solver: a selected feature is Early only if
    its parent is (rule 3.2's sub-feature time: s(f) and E(f) imply E(parent), and s(f)
    implies s(parent)), and Static only if its parent is; so a feature whose parent (or
    the parent itself, by its allowed binding) is never Early, or never Static, is never
    so either. Each such step follows from clauses of the encoding, so what it finds is
    impossible; the solver decides the rest (`cover`). At 10,000 generated features this
    finds 9,626 of the 9,743 impossible bindings, which otherwise cost one propagation
    each (0.2 ms apiece at 100,000 features).
    """
    question = _Bindings(hard, model, alive)
    possible = hard.cover(
        question.asked_targets,
        with_config=False,
        hints=question.hints,
        implied=question.implied,
        batch=True,
        start_empty=True,
        order=question.order,
    )
    return question.impossible(possible)


def live_features_and_impossible_bindings(
    hard: enc.Encoding, model: FeatureModel, on_alive: Callable[[list[bool]], None] | None = None
) -> tuple[list[bool], list[tuple[int, str, Time | Mode]]]:
    """Which features some valid variant selects, and `impossible_bindings` of those, in
    one `cover`: a variant that shows a binding shows its feature selected, so the
    bindings' solves settle most selections too. `on_alive`, if given, is called with the
    first answer as soon as it is known, while the bindings are still searched.

    Each feature's selection is a target, before those of every feature's bindings (each
    `requires` its feature's selection: a dead feature's bindings are impossible without a
    solve, and are not propagated). At 100,000 generated features this took 3.9 s where
    a cover of the selections and then one of the live features' bindings took 5.5 s.
    """
    n = len(model.features)
    # one question per class of interchangeable features (symmetry.py), for its first
    same = Classes(model)
    features, position = same.asked, same.position  # (a parent is never in a class: it has sub-features)
    m = len(features)
    question = _Bindings(hard, model, [i in position for i in range(n)])
    asked = question.asked
    targets = [[hard.s(i)] for i in features] + question.asked_targets
    parents = [model.features[i].parent for i in features]
    implied = [None if p is None else position[p] for p in parents] + [
        None if j is None else m + j for j in question.implied
    ]

    possible = hard.cover(
        targets,
        with_config=False,
        hints=question.hints,
        implied=implied,
        batch=True,
        refute=[False] * m + [True] * len(asked),  # (the selections: as for dead features alone)
        # (a feature is selected only with its parent: below a dead one, dead without a solve)
        requires=[None if p is None else position[p] for p in parents]
        + [position[question.owners[k][0]] for k in asked],
        settled=(m, lambda selected: on_alive(same.spread(selected))) if on_alive is not None else None,
        start_empty=True,
        order=alternatives_apart(model, features) + [m + k for k in question.order],
    )
    alive = same.spread(possible[:m])
    return alive, _for_each_member(same, [b for b in question.impossible(possible[m:]) if alive[b[0]]])


class _Bindings:
    """The question of `impossible_bindings` about the live features (`alive`; None: every
    feature): per feature allowing Any time or mode, "selected and bound so" per value
    (`owners` says which), those that inheritance does not already rule out (`asked`),
    the polarity hints and the implications (`cover`'s) to ask them with."""

    def __init__(self, hard: enc.Encoding, model: FeatureModel, alive: Sequence[bool] | None) -> None:
        never_early, never_static = _inherited(model)
        targets, self.owners = _binding_targets(hard, model, alive)
        owners = self.owners
        self.inherited = [
            (value is Time.EARLY and never_early[i]) or (value is Mode.STATIC and never_static[i])
            for i, _, value in owners
        ]
        self.asked = asked = [k for k in range(len(targets)) if not self.inherited[k]]
        self.asked_targets = [targets[k] for k in asked]
        self.order = alternatives_apart(model, [owners[k][0] for k in asked])  # (for `cover`)
        # Late and Static first: its solve is the one that searches (at 100,000 generated
        # features 0.7 s as the third hint, 0.4 s as the first, while the saved phases still
        # select everything). The four took 1.2 s in the order ES, ED, LS, LD and 0.8 s in
        # this one, and left fewer targets open: the whole analysis went from 10.5 to 10.1 s
        # and from 12.1 to 10.1 s on the models of seeds 1 and 0 (the answers are the same).
        self.hints = binding_hints(hard, len(model.features))
        # s(f) and E(f) propagate to s(parent) and E(parent) (the sub-feature time); the same
        # for Static (the sub-feature mode)
        position = {owners[k]: at for at, k in enumerate(asked)}
        parents = [model.features[owners[k][0]].parent for k in asked]
        self.implied = [
            position.get((p, owners[k][1], owners[k][2])) if p is not None and owners[k][2] in _UPWARD else None
            for k, p in zip(asked, parents, strict=True)
        ]

    def impossible(self, possible: Sequence[bool]) -> list[tuple[int, str, Time | Mode]]:
        """The bindings never taken, given which of those asked are `possible`."""
        ruled_out = set(k for k, can in zip(self.asked, possible, strict=True) if not can)
        return [owner for k, owner in enumerate(self.owners) if self.inherited[k] or k in ruled_out]


def binding_hints(hard: enc.Encoding, n: int) -> list[Sequence[int]]:
    """Four polarity hints, each towards a variant that selects every feature with one
    time and one mode: Late and Static, Early and Static, Early and Dynamic, Late and
    Dynamic (C ints: four Python lists were 58 MB at 100,000 features)."""
    features = range(n)
    selected, early, static = list(map(hard.s, features)), list(map(hard.E, features)), list(map(hard.S, features))
    late, dynamic = list(map(neg, early)), list(map(neg, static))
    # Each feature active too: a selected Early feature is active at start, and a
    # feature fixed Early whose activity the solver decided (inactive) before its
    # selection is a conflict that undoes every decision since; at 100,000 features of
    # a flat tree, the first hint took 12,489 such conflicts and 7.3 s, 0.05 s so.
    active = list(map(hard.a, features))
    hints: list[Sequence[int]] = []
    for times, modes in ((late, static), (early, static), (early, dynamic), (late, dynamic)):
        hint = [0] * (4 * n)  # per feature: s(f), its time's literal, its mode's, a(f)
        hint[0::4], hint[1::4], hint[2::4], hint[3::4] = selected, times, modes, active
        hints.append(array("i", hint))
    return hints


_UPWARD = (Time.EARLY, Mode.STATIC)  # the values a feature can take only if its parent does


def _inherited(model: FeatureModel) -> tuple[list[bool], list[bool]]:
    """Per feature: provably never selected Early; never selected Static (pre-order: a
    parent before its sub-features)."""
    n = len(model.features)
    never_early, never_static = [False] * n, [False] * n
    late, dynamic = Time.LATE, Mode.DYNAMIC
    for f in model.features:
        p = f.parent
        never_early[f.index] = f.time_allowed is late or (p is not None and never_early[p])
        never_static[f.index] = f.mode_allowed is dynamic or (p is not None and never_static[p])
    return never_early, never_static


def _binding_targets(
    hard: enc.Encoding, model: FeatureModel, alive: Sequence[bool] | None
) -> tuple[list[list[int]], list[tuple[int, str, Time | Mode]]]:
    """For each live feature (None: every one) allowing Any time or mode, "selected and
    bound so" per value."""
    targets: list[list[int]] = []
    owners: list[tuple[int, str, Time | Mode]] = []
    for f in model.features:
        if alive is not None and not alive[f.index]:
            continue
        i = f.index
        if f.time_allowed is None:
            targets += [[hard.s(i), hard.E(i)], [hard.s(i), -hard.E(i)]]
            owners += [(i, "time", Time.EARLY), (i, "time", Time.LATE)]
        if f.mode_allowed is None:
            targets += [[hard.s(i), hard.S(i)], [hard.s(i), -hard.S(i)]]
            owners += [(i, "mode", Mode.STATIC), (i, "mode", Mode.DYNAMIC)]
    return targets, owners


# ----------------------------------------------------------------------------- counts
def _count(
    variables: int, clauses: list[list[int]], projection: Sequence[int], timeout: float | None
) -> int | None:
    """The exact count of the CNF projected onto `projection`; None if not done in `timeout`.

    Ganak runs in a child process (forked: the clauses are not copied or pickled) that is
    killed when the time is up or the caller is interrupted, since a count cannot be
    stopped from within.
    """
    import multiprocessing

    context = multiprocessing.get_context("fork")
    receive, send = context.Pipe(duplex=False)
    child = context.Process(target=_count_here, args=(variables, clauses, projection, send), daemon=True)
    child.start()
    send.close()
    try:
        if not receive.poll(timeout):
            return None
        try:
            outcome = receive.recv()
        except EOFError:  # the child died without an answer (killed, out of memory)
            raise CountFailed(
                f"the model counter stopped without an answer (exit code {child.exitcode})"
            ) from None
    finally:
        child.kill()
        child.join()
    if isinstance(outcome, str):
        raise CountFailed(outcome)
    return int(outcome)


def _count_here(variables: int, clauses: list[list[int]], projection: Sequence[int], send: Any) -> None:
    try:
        from pyganak import Counter

        counter = Counter(verbose=0, seed=0)
        counter.new_vars(variables)
        counter.add_clauses(clauses)
        counter.set_sampling_set(list(projection))
        send.send(int(counter.count()))
    except BaseException as exc:  # noqa: BLE001 - whatever it is, the parent says it
        send.send(f"the model counter failed: {type(exc).__name__}: {exc}")


class CountFailed(RuntimeError):
    """The model counter ended without a count."""


def count_selections(model: FeatureModel, timeout: float | None = COUNT_TIMEOUT) -> int | None:
    """The number of selections satisfying section 2 (the count of `selection_cnf`); None if
    not counted within `timeout` seconds."""
    cnf = enc.selection_cnf(model)
    return _count(cnf.variables, cnf.clauses, range(1, cnf.features + 1), timeout)


def count_variants(model: FeatureModel, timeout: float | None = COUNT_TIMEOUT) -> int | None:
    """The number of variants (section 4): each feature's selection and, when selected, its
    time and mode, with some start state; counted over those values only. None if not
    counted within `timeout` seconds."""
    cnf = variant_cnf(model)
    return _count(cnf.variables, cnf.clauses, cnf.projection, timeout)


@dataclass(frozen=True, slots=True)
class VariantCNF:
    """Sections 2-4 as a CNF whose count projected onto `projection` is the variant count."""

    variables: int
    clauses: list[list[int]]
    projection: list[int]  # s(f), E(f), S(f) of every feature, in pre-order


def variant_cnf(model: FeatureModel) -> VariantCNF:
    """The hard build of the encoding, with the time and mode of a feature left out fixed
    (Late, Dynamic: false), so that a variant is counted once, not once per value of what it
    leaves out. Nothing else constrains them: every clause on them has the feature selected."""
    with enc.Encoding(model, record=True) as hard:
        assert hard.recorded is not None
        clauses = list(hard.recorded)
        projection: list[int] = []
        for i in range(len(model.features)):
            s, e, st = hard.s(i), hard.E(i), hard.S(i)
            clauses += [[s, -e], [s, -st]]
            projection += [s, e, st]
        return VariantCNF(hard.top, clauses, projection)

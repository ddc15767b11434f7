"""Repairs (reference.md section 6): the smallest changes that make something refused valid.

A repair of an invalid configuration changes the configuration's own entries (deselect F,
select F, set F's time, set F's mode); the model never changes. The minimal repairs are the
minimal correction subsets of the configuration's facts: sets of facts whose opposite makes
the configuration valid, such that no smaller subset does. Each fact is one literal (a
feature is selected or not, Early or Late, Static or Dynamic), so taking a fact back and
turning it over are the same here: in every variant without the facts of a minimal
correction set, each of them is false (were one true, the set without it would be one).

They are enumerated fewest first with MaxSAT (RC2) over the one encoding's recorded clauses:
the facts are soft units of weight 1, a solution of cost k falsifies a set of k facts, and
blocking each set found (one of its facts must hold) leaves the next solution a set that
contains none found before, hence minimal: every smaller correction set would contain a
minimal one, all of which were found and blocked at lower costs.

A run-time request gets the same over the activity of the features it could also move
(`request_corrections`): which features would have to be active or inactive besides, or
not, for the new active set to satisfy section 2.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Sequence

from ..errors import Change, ChangeKind, Repair
from ..language.model import Configuration, FeatureModel, Mode, Time
from . import encoding as enc

MOST = 5  # repairs shown, fewest changes first ("a handful at most")


def corrections(
    clauses: Iterable[list[int]], hard: Sequence[int], soft: Sequence[Sequence[int]], most: int = MOST
) -> list[list[int]]:
    """Minimal correction subsets of the `soft` clauses (most of them units) under `clauses`
    and the `hard` units, fewest first, at most `most`: each as indices into `soft`. [] when
    the hard part alone is unsatisfiable, or when every soft clause can hold."""
    from pysat.examples.rc2 import RC2
    from pysat.formula import WCNF

    formula = WCNF()
    formula.extend(clauses)
    formula.extend([literal] for literal in hard)
    formula.extend([list(clause) for clause in soft], weights=[1] * len(soft))
    found: list[list[int]] = []
    with RC2(formula, solver="g4") as maxsat:
        for values in maxsat.enumerate(block=-1):
            truth = set(values)
            falsified = [k for k, clause in enumerate(soft) if truth.isdisjoint(clause)]
            if not falsified:
                break
            found.append(falsified)
            if len(found) >= most:
                break
    return found


def configuration_repairs(model: FeatureModel, config: Configuration, most: int = MOST) -> list[Repair]:
    """The minimal repairs of a configuration that has no valid variant, fewest first.

    [] when the configuration is valid, or when no change to it helps (the model has no
    valid variant at all)."""
    with enc.Encoding(model, record=True) as encoding:
        encoding.set_configuration(config)
        facts = list(encoding.facts)  # hard build: the configuration's facts only
        literals = encoding.literals[: len(facts)]
        soft = [[literal] for literal in literals]
        # A deselected entry keeps its props: once a repair selects the feature ("select a"
        # turns `selected` over, as a person would), they hold. So each is a fact "if a is
        # selected, it is Early" that a repair may have to turn over too (a repair that
        # selected a Dynamic entry where only Static works did not work, applied).
        for entry in config.entries.values():
            i = model.index.get(entry.id)
            if entry.selected or i is None:
                continue
            for kind, value, variable, first in (
                (enc.FactKind.CONFIG_TIME, entry.time, encoding.E(i), Time.EARLY),
                (enc.FactKind.CONFIG_MODE, entry.mode, encoding.S(i), Mode.STATIC),
            ):
                if value is not None:
                    literal = variable if value is first else -variable
                    facts.append(enc.EncodedFact(kind, i))
                    literals.append(literal)
                    soft.append([-encoding.s(i), literal])
        recorded: Sequence[list[int]] = encoding.recorded if encoding.recorded is not None else []
        found = corrections(recorded, [], soft, most)
    return [tuple(_config_change(model, facts[k], literals[k]) for k in _ordered(facts, mcs)) for mcs in found]


def _ordered(facts: Sequence[enc.EncodedFact], mcs: list[int]) -> list[int]:
    """A repair's changes in definition order, a feature's selection before its binding."""
    rank = {enc.FactKind.CONFIG_SELECTED: 0, enc.FactKind.CONFIG_DESELECTED: 0, enc.FactKind.CONFIG_TIME: 1, enc.FactKind.CONFIG_MODE: 2}
    return sorted(mcs, key=lambda k: (facts[k].a, rank[facts[k].kind]))


def _config_change(model: FeatureModel, fact: enc.EncodedFact, literal: int) -> Change:
    """The change that turns a configuration fact (assumed as `literal`) over, in the user's words."""
    name = model.features[fact.a].id
    if fact.kind == enc.FactKind.CONFIG_SELECTED:
        return Change(name, ChangeKind.SELECT, False, f"deselect {name}")
    if fact.kind == enc.FactKind.CONFIG_DESELECTED:
        return Change(name, ChangeKind.SELECT, True, f"select {name}")
    # the configuration says one value (a positive literal: Early, Static); the repair, the other
    if fact.kind == enc.FactKind.CONFIG_TIME:
        time = Time.LATE if literal > 0 else Time.EARLY
        return Change(name, ChangeKind.TIME, time.value, f"make {name} {time.value}")
    mode = Mode.DYNAMIC if literal > 0 else Mode.STATIC
    return Change(name, ChangeKind.MODE, mode.value, f"make {name} {mode.value}")


def request_corrections(
    encoding: enc.Encoding,
    fixed: Sequence[int],
    after: Collection[int],
    movable: Collection[int],
    most: int = MOST,
) -> list[list[tuple[int, bool]]]:
    """The smallest changes to a refused request's active set that section 2 accepts.

    `encoding` is the run time's explain build, `fixed` the variant's literals, `after`
    (feature indices) the active set the request asked for, and `movable` the features
    whose activity a request may change besides (selected, and not Static once active).
    Each answer is a minimal list of (feature, active) that differ from `after`, fewest
    first; the start-state rule that every Early feature is active is left out, as in
    `Encoding.active_set_conflicts`."""
    wanted = set(after)
    model_facts = [
        encoding.literals[k] for k in range(encoding.model_facts) if encoding.facts[k].kind != enc.FactKind.START_EARLY
    ]
    hard = [*fixed, *model_facts]
    soft: list[int] = []
    moves: list[tuple[int, bool]] = []
    for i in range(encoding.n):
        literal = encoding.a(i) if i in wanted else -encoding.a(i)
        if i in movable:
            soft.append(literal)
            moves.append((i, i not in wanted))
        else:
            hard.append(literal)
    found = corrections(encoding.kept_clauses(), hard, [[literal] for literal in soft], most)
    return [[moves[k] for k in mcs] for mcs in found]

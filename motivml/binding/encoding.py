"""The one SAT encoding of MoTiVML (reference.md sections 2, 3 and the start state of 4).

Variables, per feature f (index i in definition order): s(f) selected, E(f) Early,
S(f) Static, a(f) active at start. Every model statement the rules apply to is a *fact*
with its own selector variable, and each of its clauses carries the selector negated, so
a fact is in force exactly when its selector is assumed. A configuration adds facts that
are plain literals (s(f), E(f), S(f) or their negations).

The same clauses come in two builds of one encoding:

* `Encoding(model)`: model facts are hard clauses and configuration facts are
  assumptions. Validity is one solve; `cover()` finds which conjunctions of literals some
  valid variant satisfies (dead features, possible and forced bindings) with one solve per
  batch of new witnesses, incrementally on the same solver.
* `Encoding(model, explain=True)`: every model fact gets a selector variable that its
  clauses carry negated, so a fact is in force only while its selector is assumed. The
  solver's core is then a set of facts, shrunk to a minimal one by deletion; the search
  goes on with each found core's facts set aside, so every independent conflict is found.
  Assuming half a million selectors costs ~0.15 s per solve at 100,000 features, which is
  why the questions that need many solves use the hard build, and this one is made only
  when there is something to explain.

This is the only module that imports pysat. Solvers are opened with `with Encoding(...)`.
"""

from __future__ import annotations

import functools
from array import array
from collections import ChainMap, deque
from collections.abc import Callable, Collection, Container, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from itertools import accumulate, chain, compress, repeat
from operator import itemgetter
from types import TracebackType
from typing import Any, NamedTuple

from pysat.solvers import Solver

from ..language.formula import AND, IFF, IMPLIES, OR, Formula, Var, fold
from ..language.model import Configuration, FeatureModel, GroupKind, Mode, Time
from ..process import keep_till_exit, keeping_all

SOLVER = "glucose4"  # forgiving API, assumptions and cores; CaDiCaL aborts the process on misuse

class FactKind(StrEnum):
    """What a fact of the encoding states, and the rule of reference.md it is used under
    (explain.py puts each in words). A fact of the model has a selector; a fact of the
    configuration, and a query, are literals (no selector)."""

    ROOT = "root"  # 2.1: the root is selected, Static and Early
    PARENT = "parent"  # 2.1: s(c) -> s(p)
    MANDATORY = "mandatory"  # 2.2: s(p) -> s(c) for an ungrouped mandatory child
    GROUP_OR = "or-group"  # 2.2: s(p) -> some member
    GROUP_XOR = "xor-group"  # 2.2: s(p) -> some member (at most one: XOR_PAIR)
    XOR_PAIR = "xor-pair"  # 2.2 + 3.3: two members selected together only as Dynamic alternatives
    XOR_ALTERNATIVES = "xor-alternatives"  # XOR_PAIR over a whole group (linear: `_all_alternatives`)
    INCLUDE = "include"  # 2.3: s(x) -> s(y)
    EXCLUDE = "exclude"  # 2.3 + 3.3: like XOR_PAIR
    INCLUDE_STATIC = "include-static"  # 3.1: an included feature is Static
    INCLUDE_TIME = "include-time"  # 3.1: ... and bound no later than its includer
    MANDATORY_STATIC = "mandatory-static"  # 3.1: a Static parent requires its mandatory child Static
    MANDATORY_TIME = "mandatory-time"  # 3.1: ... bound no later
    SUB_MODE = "sub-mode"  # 3.2: a Dynamic parent has no Static child
    SUB_TIME = "sub-time"  # 3.2: a child is not bound before its parent
    UNIT_TIME = "unit-time"  # 3.2: a Dynamic parent's mandatory child has its time (both ways)
    UNIT_MODE = "unit-mode"  # 3.2: ... and its mode (Dynamic)
    FORMULA = "formula"  # 2.4: a formula of the root holds over s and (with START) over a; `a` is its index
    ALLOWED_TIME = "allowed-time"  # 3: bindingTimeAllowed
    ALLOWED_MODE = "allowed-mode"  # 3: bindingModeAllowed
    START = "start"  # 4: the active set is part of the selection and satisfies section 2
    START_EARLY = "start-early"  # 4: at start, every selected Early feature is active
    ACTIVE = "active"  # run time: a feature is in the active set a reconfiguration asks for
    INACTIVE = "inactive"  # run time: ... or not
    # a query (no selector): a feature already shown dead, so a conflict can say "y is dead"
    # where it would otherwise repeat y's own conflict (`check._dead_warnings`); shrinking
    # drops it last
    DEAD = "dead"
    # configuration facts (literals, no selector)
    CONFIG_SELECTED = "config-selected"
    CONFIG_DESELECTED = "config-deselected"
    CONFIG_TIME = "config-time"
    CONFIG_MODE = "config-mode"
    # questions asked of the model (literals): "f would be selected", "f would be Early" ...
    QUERY_SELECTED = "query-selected"
    QUERY_BINDING = "query-binding"


# XOR groups: pair by pair (one FactKind.XOR_PAIR fact each) up to PAIRWISE_UP_TO members, beyond that
# a linear encoding of the same rule; the explain build keeps the pairs, whose facts name two
# members, for groups up to PAIRWISE_EXPLAINED members, and one FactKind.XOR_ALTERNATIVES fact above.
PAIRWISE_UP_TO = 8
# Encoding.cover: a witness solve is worth another while it settles this many open targets
# (a solve of a large model costs about as much as a few hundred unit propagations).
WITNESS_GAIN = 256
PAIRWISE_EXPLAINED = 64
CONFIG_KINDS = frozenset({FactKind.CONFIG_SELECTED, FactKind.CONFIG_DESELECTED, FactKind.CONFIG_TIME, FactKind.CONFIG_MODE})


class EncodedFact(NamedTuple):
    """A model or configuration statement as the encoding holds it: a kind over features.

    `a` and `b` are feature indices (-1: none; for group facts `a` is the group's index in
    `FeatureModel.groups`). Its literal in `Encoding.literals` puts it in force: a selector
    over its clauses, or the configuration's literal itself. Explanations put it in words
    and locate it as an `errors.LocatedFact`. (A named tuple: half a million of them are
    made for an explanation of a 100,000-feature model, twice as fast as a dataclass.)
    """

    kind: FactKind
    a: int
    b: int = -1


# Tseitin's definitions of a formula's operators: v <-> (x op y), both directions, since a
# subformula may stand under a negation (which is the negated literal, no variable).
_GATES: dict[str, Callable[[int, int, int], tuple[list[int], ...]]] = {
    AND: lambda v, x, y: ([-v, x], [-v, y], [v, -x, -y]),
    OR: lambda v, x, y: ([-v, x, y], [v, -x], [v, -y]),
    IMPLIES: lambda v, x, y: ([-v, -x, y], [v, x], [v, -y]),
    IFF: lambda v, x, y: ([-v, -x, y], [-v, x, -y], [v, x, y], [v, -x, -y]),
}


def tseitin(
    formula: Formula,
    literal: Callable[[str], int],
    new_var: Callable[[], int],
    emit: Callable[[list[int]], None],
) -> int:
    """The literal equivalent to `formula` (ids read by `literal`), its definitions emitted.

    Every variable it makes is defined by the others, so a count over the feature
    variables is not changed by them.
    """

    def gate(op: str) -> Callable[[int, int], int]:
        define = _GATES[op]

        def make(x: int, y: int) -> int:
            v = new_var()
            for clause in define(v, x, y):
                emit(clause)
            return v

        return make

    leaf: Callable[[Var], int] = lambda var: literal(var.id)  # noqa: E731
    negate: Callable[[int], int] = lambda x: -x  # noqa: E731
    return fold(formula.tree, leaf, negate, {op: gate(op) for op in _GATES})


def add_clauses(solver: Solver, clauses: Iterable[list[int]]) -> None:
    """`solver.append_formula(clauses)`, without a Python call per clause for Glucose.

    pysat adds a formula one `add_clause` method call at a time; for Glucose this hands each
    clause straight to the C function that method calls (a sixth of `validate --config` at
    100,000 features went to those calls). The clauses, their order and the solver's answers
    are the same; the "formula already unsatisfiable" flag that `add_clause` keeps is not
    kept, and needs not be: every `solve` sets it anew.
    """
    from pysat.solvers import Glucose4

    backend = solver.solver
    add = getattr(_glucose_functions(), "glucose41_add_cl", None)
    if not isinstance(backend, Glucose4) or add is None:
        solver.append_formula(clauses)
        return
    deque(map(add, repeat(backend.glucose), clauses), maxlen=0)


VECTOR_FROM = 50_000  # open targets (or features): from here cover's checks use numpy arrays
# failed solves of one batch before its first target is left to its own (8 asked more
# solves for no gain: 3,593 -> 2,382 for analyse of the mostly-Any family at 10,000
# features, 1,218 -> 1,006 for Automotive01's, a third fewer for menuconfig's decisions)
BATCH_FAILURES = 4
BATCH, BATCH_TRIED = 32, 128  # cover's last step: targets solved for together, of the next ones


class _Targets:
    """`cover`'s targets and, made when thousands are open at once, the same as an array
    (each row padded with its last literal, which changes neither what holds nor which
    literal of a variable comes last), so that a variant is checked against them in C."""

    def __init__(self, targets: Sequence[Sequence[int]]) -> None:
        self.targets = targets
        self._rows: Any = None  # numpy (targets x widest) array of literals, 0 for none

    def rows(self) -> Any:
        if self._rows is None:
            import numpy as np  # lazy: only analyses of large models get here

            width = max(map(len, self.targets), default=1) or 1
            rows = np.zeros((len(self.targets), width), dtype=np.int64)
            for k, target in enumerate(self.targets):
                if target:
                    rows[k, : len(target)] = target
                    rows[k, len(target) :] = target[-1]
            self._rows = rows
        return self._rows

    def split(self, values: list[int], candidates: list[int]) -> tuple[list[int], list[int]]:
        """(the candidates the variant `values` shows, the others), each in their order."""
        import numpy as np

        chosen = np.asarray(candidates, dtype=np.int64)
        rows = self.rows()[chosen]
        padded = np.concatenate(([0], np.asarray(values, dtype=np.int64)))  # literal of variable v at v
        shown = (padded[np.abs(rows)] == rows).all(axis=1)  # (an empty target: 0 == 0, shown)
        return chosen[shown].tolist(), chosen[~shown].tolist()

    def last_literals(self, todo: list[int]) -> list[int]:
        """Per variable in the targets `todo`, its literal in the last of them that has it."""
        import numpy as np

        literals = self.rows()[np.asarray(todo, dtype=np.int64)].ravel()[::-1]
        literals = literals[literals != 0]
        _, first = np.unique(np.abs(literals), return_index=True)
        return literals[first].tolist()  # type: ignore[no-any-return]


class Clauses(Sequence[list[int]]):
    """Clauses kept compactly, as the encoding recorded them: their literals one after
    the other (C ints) and where each clause ends. As Python lists, the 500,000 clauses of
    a 100,000-feature model were 140 MB of `analyse`'s memory; so, 7 MB. Read back one
    clause at a time as a list, or all at once as numpy arrays (`arrays`)."""

    def __init__(self) -> None:
        self.literals = array("i")
        self.ends = array("q")

    def extend(self, clauses: Sequence[list[int]]) -> None:
        end = len(self.literals)
        self.literals.extend(chain.from_iterable(clauses))
        self.ends.extend(accumulate(map(len, clauses), initial=end))
        self.ends.pop(len(self.ends) - len(clauses) - 1)  # (`end` itself: the last clause's end already)

    def __len__(self) -> int:
        return len(self.ends)

    def _clause(self, k: int) -> list[int]:
        return self.literals[self.ends[k - 1] if k else 0 : self.ends[k]].tolist()

    def __getitem__(self, k: Any) -> Any:
        if isinstance(k, slice):
            return [self._clause(j) for j in range(*k.indices(len(self)))]
        if k < 0:
            k += len(self)
        if not 0 <= k < len(self):
            raise IndexError(k)
        return self._clause(k)

    def __iter__(self) -> Iterator[list[int]]:
        return map(self._clause, range(len(self)))

    def arrays(self) -> tuple[Any, Any]:
        """(every literal, each clause's length) as numpy arrays (int32, int64), no copy of
        the literals."""
        import numpy as np

        ends = np.frombuffer(self.ends, dtype=np.int64)
        return np.frombuffer(self.literals, dtype=np.int32), np.diff(ends, prepend=0)


@dataclass
class Work:
    """What an encoding's `cover` calls did, counted (tests check that it grows linearly
    with the number of targets; `bench/` prints it)."""

    solves: int = 0  # solver calls, failed ones included
    propagations: int = 0  # unit propagations (step 2)
    phases: int = 0  # literals handed to the solver as polarity hints
    checks: int = 0  # targets checked against a witness
    resets: int = 0  # phases set back to the emptiest variant before a target's own solve (`unhint`)


FLUSH_EVERY = 1 << 16  # clauses made before they are handed to the solver (`Encoding.__init__`)
ONE_HINTED_FROM = 32  # members: a larger XOR group has one member hinted selected at most (`hint`)
SELECTION_IN_NUMPY = 1000  # features: from here `selection_of` reads a variant in numpy
HINT_WINDOW = 256  # open targets that a target's own solve is hinted towards (`_Cover`)
DIFF_IN_NUMPY = 4096  # the targets' variables: from here a new witness is compared with the last in numpy


class _Cover:
    """The state of one `Encoding.cover`: which targets are open, and the last witness,
    every open target checked against it.

    Nothing here costs more per target the more targets are open:

    * Hints. The solver saves each variable's phase as the last variant had it, over any
      hint, so hints are set anew before each solve. While witnesses settle many targets at
      once (step 1) they are set towards every open target, but only while each witness
      settles a sixteenth of them (so that the hints' work is at most 16 times the
      targets'); for a target's own solve (step 3), towards the open targets of the next
      HINT_WINDOW only.
    * Witnesses. A target the last witness did not show can be shown by the next only if
      the next changed one of its variables: a new witness is compared with the last (in
      C from DIFF_IN_NUMPY variables), and only the open targets over the changed
      variables are checked.
    * Order. The open targets are taken in their order from a list that is compacted when
      half of it is settled.
    """

    def __init__(
        self, encoding: Encoding, targets: Sequence[Sequence[int]], order: Sequence[int] | None = None
    ) -> None:
        self.encoding, self.targets = encoding, targets
        self.work = encoding.work
        self.table = _Targets(targets)
        n = len(targets)
        self.possible = [False] * n
        self.is_open = bytearray(b"\x01") * n
        self.left = n  # open targets
        # open targets in the order they are taken, settled ones not yet removed
        self.order: list[int] = list(range(n)) if order is None else list(order)
        self.head = 0  # order[:head] is settled
        self.settled_in_order = 0  # settled targets in order[head:]
        self.last: Any = None  # the last witness's literals of `variables` (a tuple, or a numpy array)
        self.variables: list[int] | None = None  # the targets' variables, in order
        self.pick: Callable[[list[int]], tuple[int, ...]] | None = None  # their literals of a witness
        self.occurs: dict[int, list[int]] | None = None  # variable -> the targets that have it

    # --------------------------------------------------------------- the open targets
    def close(self, k: int, possible: bool) -> None:
        """Settle target k."""
        if not self.is_open[k]:
            return
        self.is_open[k] = 0
        self.possible[k] = possible
        self.left -= 1
        self.settled_in_order += 1

    def open_targets(self) -> list[int]:
        return [k for k in self.order[self.head :] if self.is_open[k]]

    def next_open(self) -> int | None:
        """The first open target (in the targets' order), or None."""
        order, is_open = self.order, self.is_open
        if self.settled_in_order * 2 > len(order) - self.head:  # compact (amortised: half is settled)
            self.order = order = [k for k in order[self.head :] if is_open[k]]
            self.head = self.settled_in_order = 0
        while self.head < len(order) and not is_open[order[self.head]]:
            self.head += 1
            self.settled_in_order -= 1
        return order[self.head] if self.head < len(order) else None

    def open_after(self, count: int) -> list[int]:
        """Up to `count` open targets after the first, looking at no more than 4 x `count`."""
        order, is_open, start = self.order, self.is_open, self.head + 1
        return [k for k in order[start : start + 4 * count] if is_open[k]][:count]

    # ----------------------------------------------------------------------- hints
    def prefer(self, window: int | None = None) -> None:
        """Hint the variables of the open targets (the first `window` of them; None: all) as
        the last of those with a variable wants it."""
        if window is None:
            todo = self.open_targets()
        else:
            first = self.next_open()
            todo = [first, *self.open_after(window - 1)] if first is not None else []
        if len(todo) >= VECTOR_FROM:
            literals = self.table.last_literals(todo)
        else:
            preferred: dict[int, int] = {}
            targets = self.targets
            for k in todo:
                for literal in targets[k]:
                    preferred[abs(literal)] = literal
            literals = list(preferred.values())
        self.encoding.hint(literals)

    # ------------------------------------------------------------------- witnesses
    def mark(self, witness: Callable[[list[int]], None] | None) -> None:
        """Settle as possible the open targets that the solver's present variant shows."""
        values = self.encoding.assignment()
        if witness is not None:
            witness(values)
        if self.variables is None:  # the variables the targets have: only they are compared
            self.variables = sorted({abs(literal) for target in self.targets for literal in target})
        variables = self.variables
        if len(variables) < 2 or len(values) < variables[-1]:  # (too few for a getter; a model short of them)
            self.last = None
            self._check_all(values)
            return
        if self.pick is None:
            self.pick = itemgetter(*(v - 1 for v in variables))
        picked = self.pick(values)  # (in C: the targets' variables' literals, in order)
        last = self.last
        if len(variables) >= DIFF_IN_NUMPY:
            import numpy as np  # lazy: only large models get here

            self.last = np.frombuffer(array("i", picked), dtype=np.int32)
        else:
            self.last = picked
        if last is None:  # the first witness: every open target
            self._check_all(values)
            return
        if len(variables) >= DIFF_IN_NUMPY:
            import numpy as np

            changed = [variables[at] for at in np.flatnonzero(self.last != last).tolist()]
        else:
            changed = [v for v, old, new in zip(variables, last, picked, strict=True) if old != new]
        if self.occurs is None:
            occurs: dict[int, list[int]] = {}
            for k, target in enumerate(self.targets):
                if self.is_open[k]:
                    for literal in target:
                        occurs.setdefault(abs(literal), []).append(k)
            self.occurs = occurs
        occurs, is_open, targets, close = self.occurs, self.is_open, self.targets, self.close
        for v in changed:
            for k in occurs.get(v, ()):
                if is_open[k]:
                    self.work.checks += 1
                    if all(values[abs(literal) - 1] == literal for literal in targets[k]):
                        close(k, True)

    def _check_all(self, values: list[int]) -> None:
        candidates = self.open_targets()
        self.work.checks += len(candidates)
        if len(candidates) >= VECTOR_FROM:
            shown, _ = self.table.split(values, candidates)
        else:
            true = set(values)
            shown = list(compress(candidates, map(true.issuperset, map(self.targets.__getitem__, candidates))))
        for k in shown:
            self.close(k, True)


class _Rotation:
    """Recursive model rotation (Belov and Marques-Silva, 2011) for `_minimise`.

    When the facts of a candidate conflict less one, f, have a variant M, f is needed. If
    flipping one variable of M satisfies f's clauses and breaks the clauses of exactly one
    other fact g of the candidate, the flipped variant satisfies every fact but g: g is
    needed too, without a solve, and the same is tried from g. A conflict that is a chain
    (a feature that requires its parent, that requires its parent, ...) is shown needed
    link by link this way: a deletion solve per fact becomes one for the whole chain (20
    conflicts of hundreds of facts each took 15,000 solves and 10 s of `validate` at
    10,000 features).

    Clauses are the explain build's, renumbered: each begins with its fact's selector
    negated, and a clause under FactKind.START has FactKind.START's selector too. A selector counts as true
    exactly when its fact is assumed; selectors and `fixed` literals are never flipped.
    """

    def __init__(self, clauses: list[list[int]], by_literal: Mapping[int, int], fixed: Sequence[int]) -> None:
        self.clauses = clauses
        self.by_literal = by_literal  # selector -> fact
        self.critical: set[int] = set()
        self.owner = [by_literal.get(-clause[0]) if clause else None for clause in clauses]
        self.of_fact: dict[int, list[int]] = {}
        self.occurs: dict[int, list[int]] = {}
        self.frozen = {abs(literal) for literal in fixed} | {abs(literal) for literal in by_literal}
        for c, clause in enumerate(clauses):
            owner = self.owner[c]
            if owner is not None:
                self.of_fact.setdefault(owner, []).append(c)
            for literal in clause:
                if abs(literal) not in self.frozen:
                    self.occurs.setdefault(abs(literal), []).append(c)

    def rotate(self, needed: int, assumed: set[int], model: list[int]) -> None:
        """Mark needed the facts that rotations of `model` (a variant of the facts `assumed`
        less `needed`) show needed."""
        values = bytearray(len(model) + 1)
        for literal in model:
            if literal > 0:
                values[literal] = 1
        by_literal, clauses = self.by_literal, self.clauses

        def false(c: int) -> bool:
            for literal in clauses[c]:
                k = by_literal.get(abs(literal))
                if k is not None:  # a selector: true iff its fact is assumed
                    if (literal > 0) == (k in assumed):
                        return False
                elif values[abs(literal)] == (literal > 0):
                    return False
            return True

        stack = [(needed, values)]
        while stack:
            fact, values = stack.pop()
            broken = [c for c in self.of_fact.get(fact, ()) if false(c)]
            if not broken:
                continue
            common = {abs(literal) for literal in clauses[broken[0]] if abs(literal) not in self.frozen}
            for c in broken[1:]:
                common &= {abs(literal) for literal in clauses[c]}
            for v in sorted(common):
                values[v] ^= 1
                owners = {self.owner[c] for c in self.occurs.get(v, ()) if false(c)}
                if len(owners) == 1 and fact not in owners:
                    (other,) = owners
                    if other is not None and other in assumed and other not in self.critical:
                        self.critical.add(other)
                        stack.append((other, bytearray(values)))
                values[v] ^= 1


class _AllFacts(Collection[int]):
    """`conflicts`' facts when it is not told which: its queries, the configuration's facts
    and every model fact, in that order, without a set of them all (480,000 at 100,000
    features, made anew for each question)."""

    def __init__(self, queries: Sequence[int], model_facts: int, last: int) -> None:
        self._queries, self._asked = queries, set(queries)
        self._model_facts, self._last = model_facts, last

    def __contains__(self, k: object) -> bool:
        return isinstance(k, int) and (0 <= k < self._last or k in self._asked)

    def __iter__(self) -> Iterator[int]:
        return chain(self._queries, range(self._model_facts, self._last), range(self._model_facts))

    def __len__(self) -> int:
        return len(self._queries) + self._last


def solver_interrupted(exc: BaseException) -> bool:
    """Whether `exc` is how pysat's solvers report Ctrl-C during a solve: they catch SIGINT
    themselves while they search and raise their C module's `error`, "Caught keyboard
    interrupt", instead of KeyboardInterrupt."""
    error = getattr(_glucose_functions(), "error", None)
    return isinstance(error, type) and isinstance(exc, error) and "keyboard interrupt" in str(exc).lower()


def _glucose_functions() -> object:
    """pysat's C extension (None if this pysat has none by that name: pysat's own methods
    are used then)."""
    try:
        import pysolvers  # type: ignore[import-not-found]
    except ImportError:
        return None
    return pysolvers


@functools.cache
def _rc2() -> Any:
    """pysat's RC2, with its list of soft selectors kept at C speed (`filter_assumps`).

    After each core RC2 rebuilds that list without the selectors the core used up, one
    Python comparison per selector: 35 cores times 150,000 selectors took 0.14 s of
    `configure` at 100,000 features. This one keeps the list's order in a dict as well
    (made anew if the list is not the dict's), drops those selectors from it and lists it
    anew, all in C; RC2's own method then does the rest (the sums, its tables, its set of
    selectors) on a list it finds empty. The list is the same, in the same order: so are
    the search and its result.
    """
    from pysat.examples.rc2 import RC2

    class FastRC2(RC2):  # type: ignore[misc]
        _order: dict[int, None] | None = None  # the selectors, in order, as keys

        def filter_assumps(self) -> None:
            selectors: list[int] = self.sels  # type: ignore[has-type]
            garbage, order = self.garbage, self._order
            if order is None or list(order) != selectors:  # (RC2 added selectors since: anew)
                order = dict.fromkeys(selectors)
            if len(order) != len(selectors):  # (a selector twice: never, but then as RC2 does)
                kept, order = [literal for literal in selectors if literal not in garbage], None
            else:
                for literal in garbage:
                    order.pop(literal, None)
                kept = list(order)
            self.sels = []
            super().filter_assumps()
            self.sels, self._order = kept, order

    return FastRC2


class Encoding:
    """A feature model (and optionally a configuration) in one incremental SAT solver."""

    def __init__(
        self, model: FeatureModel, explain: bool = False, solver: str = SOLVER, record: bool = False
    ) -> None:
        self.model = model
        self.explain = explain
        self.recorded: Clauses | None = Clauses() if record else None  # the hard build's CNF (analyses, bench/)
        n = len(model.features)
        self.n = n
        self.facts: list[EncodedFact] = []  # explain build: every fact; hard build: config facts
        self.literals: list[int] = []  # the assumption literal of each fact
        self._top = 4 * n
        self._activity: int | None = None  # index of the first FactKind.ACTIVE fact, once made
        self._final = False  # a configuration or variant is in the solver as units (optimise, start_state)
        self._config_units = False  # ... the configuration is (fix_configuration): not assumed any more
        self._clauses: list[list[int]] = []
        # explain build: every clause, flat, with its selector, so that a conflict is shrunk
        # in a solver of its own facts' clauses only (`_minimise`), not in the whole model's
        self._kept_literals = array("i")  # the clauses one after the other
        self._kept_starts = array("q", [0])  # where each clause begins (and, last, the end)
        self._kept_selectors = array("i")  # each clause's selector
        self._clauses_of: dict[int, list[int]] | None = None  # selector -> its kept clauses
        self._model_by_literal: dict[int, int] | None = None  # (see _by_literal)
        self.work = Work()  # what `cover` did
        self._xor_member: dict[int, int] | None = None  # s(member) -> its XOR group (`hint`)
        self._xor_group_of: Any = None  # the same as a numpy table by variable (`_hint_in_numpy`)
        self._unhinted: list[int] | None = None  # (`unhint`)
        # valid variants found by the last questions asked of this encoding, as `binding_states`
        # keeps them (each feature's selection, time and mode, a byte each): under the next
        # configuration, those that still hold answer at once
        self.recent: list[bytes] = []
        # and what they answered, with the configuration's literals then (`check._Known`):
        # the targets no variant had and those some variant had
        self.recent_answers: tuple[frozenset[int], set[int | tuple[int, ...]], set[int | tuple[int, ...]]] = (
            frozenset(),
            set(),
            set(),
        )
        self.memo: dict[str, Any] = {}  # what questions of this encoding make once for all (`check._memo`)
        self.solver_name = solver
        # The clauses go to the solver FLUSH_EVERY at a time while they are made: held all
        # at once as Python lists, they were a third of `validate`'s peak memory at
        # 100,000 features (450 MB, 312 MB once handed over).
        self.solver = Solver(name=solver)
        try:
            self._encode_model()
            self._flush()
        except BaseException:
            self.solver.delete()  # (nothing else would: the caller never gets this encoding)
            raise
        self.model_facts = len(self.facts)
        self._config_fact_range = (len(self.facts), len(self.facts))

    # ----------------------------------------------------------------- variables
    @staticmethod
    def s(i: int) -> int:
        return 4 * i + 1

    @staticmethod
    def E(i: int) -> int:  # noqa: N802 - the spec's name
        return 4 * i + 2

    @staticmethod
    def S(i: int) -> int:  # noqa: N802 - the spec's name
        return 4 * i + 3

    @staticmethod
    def a(i: int) -> int:
        return 4 * i + 4

    @property
    def top(self) -> int:
        """The highest variable in use."""
        return self._top

    def selection_of(self, values: Sequence[int]) -> bytes:
        """Which features an assignment selects: one byte (0 or 1) per feature, in pre-order."""
        chosen = values[0 : 4 * self.n : 4]  # s(i) is variable 4i + 1
        if self.n >= SELECTION_IN_NUMPY:
            import numpy as np

            return (np.frombuffer(array("i", chosen), dtype=np.int32) > 0).astype(np.uint8).tobytes()
        return bytes(map((0).__lt__, chosen))

    def _new_var(self) -> int:
        self._top += 1
        return self._top

    def _fact(self, kind: FactKind, a: int, b: int = -1) -> int:
        """A model fact: its selector in the explain build, 0 (always in force) otherwise."""
        if not self.explain:
            return 0
        selector = self._new_var()
        self.facts.append(EncodedFact(kind, a, b))
        self.literals.append(selector)
        return selector

    def _add(self, selector: int, *clauses: list[int]) -> None:
        if selector:
            for clause in clauses:
                self._clauses.append([-selector, *clause])
        else:  # hard build: drop the (absent) selectors, including FactKind.START's inside clauses
            for clause in clauses:
                self._clauses.append([lit for lit in clause if lit] if 0 in clause else clause)
        if len(self._clauses) >= FLUSH_EVERY:
            self._flush()

    def _flush(self) -> None:
        """Hand the clauses made since the last flush to the solver (and keep them, in the
        explain build or when recording)."""
        if self.recorded is not None:
            self.recorded.extend(self._clauses)
        if self.explain:  # each clause of the explain build begins with its selector, negated
            clauses = self._clauses
            self._kept_literals.extend(chain.from_iterable(clauses))
            end = self._kept_starts[-1]
            self._kept_starts.extend(accumulate(map(len, clauses), initial=end))
            self._kept_starts.pop(len(self._kept_starts) - len(clauses) - 1)  # (`end` twice)
            self._kept_selectors.extend(-clause[0] for clause in clauses)
        add_clauses(self.solver, self._clauses)
        self._clauses.clear()

    # ------------------------------------------------------------------ encoding
    def _guard(self, kind: FactKind, a: int, b: int = -1) -> list[int]:
        """A new model fact (explain build): `[-selector]`, to begin each of its clauses."""
        return [-self._fact(kind, a, b)]

    def _encode_model(self) -> None:
        s, E, S, a = self.s, self.E, self.S, self.a  # noqa: N806
        early_time, static_mode = Time.EARLY, Mode.STATIC  # local: an enum member lookup is slow
        features = self.model.features
        start = self._fact(FactKind.START, 0)
        early = self._fact(FactKind.START_EARLY, 0)
        # The clauses of the many per-feature facts are built here directly, as `_add` would
        # (the same literals in the same order): each begins with the fact's guard (`head`), its
        # negated selector in the explain build and nothing in the hard build, and a clause
        # under FactKind.START has FactKind.START's guard next. A call per clause cost a fifth of a
        # configuration check at 100,000 features.
        explain, guard = self.explain, self._guard
        always: list[int] = []
        clauses = self._clauses  # (emptied in place by each flush: `add` stays bound to it)
        add = clauses.append
        under_start = [-start] if start else always
        under_early = [-early] if early else always
        # Section 4: A is a subset of the selection and satisfies section 2 in full (the
        # a-level clauses below, each under FactKind.START too); at start it holds every selected
        # Early feature (FactKind.START_EARLY, left out when the run time checks a reconfiguration).
        for i in range(self.n):
            add([*under_start, -a(i), s(i)])
            add([*under_early, -s(i), -E(i), a(i)])
        root = self._fact(FactKind.ROOT, 0)
        self._add(root, [s(0)], [E(0)], [S(0)])
        # The root is active because it is the root (so FactKind.START cannot stand in for FactKind.ROOT).
        self._add(start, [-root, a(0)])

        for f in features:
            i = f.index
            si, ei, mi, ai = 4 * i + 1, 4 * i + 2, 4 * i + 3, 4 * i + 4  # s, E, S, a of f
            if f.time_allowed is not None:
                head = guard(FactKind.ALLOWED_TIME, i) if explain else always
                add([*head, -si, ei if f.time_allowed is early_time else -ei])
            if f.mode_allowed is not None:
                head = guard(FactKind.ALLOWED_MODE, i) if explain else always
                add([*head, -si, mi if f.mode_allowed is static_mode else -mi])
            p = f.parent
            if p is None:
                continue
            sp, ep, mp, ap = 4 * p + 1, 4 * p + 2, 4 * p + 3, 4 * p + 4  # s, E, S, a of the parent
            head = guard(FactKind.PARENT, i) if explain else always
            add([*head, -si, sp])
            add([*head, *under_start, -ai, ap])
            head = guard(FactKind.SUB_MODE, i) if explain else always
            add([*head, -si, mp, -mi])
            head = guard(FactKind.SUB_TIME, i) if explain else always
            add([*head, -si, -ei, ep])
            if f.mandatory:
                head = guard(FactKind.MANDATORY, i) if explain else always
                add([*head, -sp, si])
                add([*head, *under_start, -ap, ai])
                head = guard(FactKind.MANDATORY_STATIC, i) if explain else always
                add([*head, -sp, -si, -mp, mi])
                head = guard(FactKind.MANDATORY_TIME, i) if explain else always
                add([*head, -sp, -si, -mp, -ep, ei])
                # 3.2: with a Dynamic parent, one binding unit: same time and mode. FactKind.SUB_TIME
                # and FactKind.SUB_MODE say half of this of every child; the mandatory statement says
                # all of it by itself, so that a conflict setting the sub-feature facts
                # aside does not hide another one that the unit alone makes.
                head = guard(FactKind.UNIT_TIME, i) if explain else always
                add([*head, -sp, -si, mp, -ep, ei])
                add([*head, -sp, -si, mp, ep, -ei])
                head = guard(FactKind.UNIT_MODE, i) if explain else always
                add([*head, -sp, -si, mp, -mi])
            if not i & 4095 and len(clauses) >= FLUSH_EVERY:
                self._flush()

        for g, group in enumerate(self.model.groups):
            p, members = group.parent, group.members
            kind = FactKind.GROUP_OR if group.kind is GroupKind.OR else FactKind.GROUP_XOR
            sel = self._fact(kind, g)
            self._add(sel, [-s(p), *(s(m) for m in members)], [-start, -a(p), *(a(m) for m in members)])
            if group.kind is GroupKind.XOR:
                if self.explain and len(members) <= PAIRWISE_EXPLAINED:
                    for x, m1 in enumerate(members):
                        for m2 in members[x + 1 :]:
                            sel = self._fact(FactKind.XOR_PAIR, m1, m2)
                            self._alternatives(sel, start, m1, m2)
                elif len(members) <= PAIRWISE_UP_TO:
                    for x, m1 in enumerate(members):
                        for m2 in members[x + 1 :]:
                            self._alternatives(0, start, m1, m2)
                else:
                    self._all_alternatives(self._fact(FactKind.XOR_ALTERNATIVES, g), start, members)

        index = self.model.index
        for f in features:
            for target in dict.fromkeys(f.includes):
                y = index.get(target)
                if y is None or y == f.index:
                    continue
                x = f.index
                head = guard(FactKind.INCLUDE, x, y) if explain else always
                add([*head, -s(x), s(y)])
                add([*head, *under_start, -a(x), a(y)])
                head = guard(FactKind.INCLUDE_STATIC, x, y) if explain else always
                add([*head, -s(x), -s(y), S(y)])
                head = guard(FactKind.INCLUDE_TIME, x, y) if explain else always
                add([*head, -s(x), -s(y), -E(x), E(y)])
            for target in dict.fromkeys(f.excludes):
                y = index.get(target)
                if y is None or y == f.index:
                    continue
                sel = self._fact(FactKind.EXCLUDE, f.index, y)
                self._alternatives(sel, start, f.index, y)

        for k, formula in enumerate(self.model.formulas):
            self._formula(self._fact(FactKind.FORMULA, k), start, formula)

    def _formula(self, sel: int, start: int, formula: Formula) -> None:
        """Rule 2.4: the formula holds over the selection and, under FactKind.START, over the active set."""
        index = self.model.index
        for variable, guard in ((self.s, 0), (self.a, start)):
            top = tseitin(
                formula,
                lambda name, variable=variable: variable(index[name]),  # type: ignore[misc]
                self._new_var,
                lambda clause: self._add(sel, clause),
            )
            self._add(sel, [-guard, top] if guard else [top])

    def _alternatives(self, sel: int, start: int, x: int, y: int) -> None:
        """Rule 3.3: not (s(x) and s(y) and (S(x) or S(y) or (E(x) and E(y)))); never both active."""
        s, E, S, a = self.s, self.E, self.S, self.a  # noqa: N806
        self._add(
            sel,
            [-s(x), -s(y), -S(x)],
            [-s(x), -s(y), -S(y)],
            [-s(x), -s(y), -E(x), -E(y)],
            [-start, -a(x), -a(y)],
        )

    def _all_alternatives(self, sel: int, start: int, members: Sequence[int]) -> None:
        """Rule 3.3 over every pair of `members` at once, in O(n) clauses instead of O(n^2).

        Pair by pair (`_alternatives`), two members are selected together only if neither is
        Static and not both are Early, and never both active. The same over the whole group:
        at most one member selected and Early, at most one active (each a sequential counter,
        Sinz 2005), and once two members are selected (a counter's "at least two"), none is
        Static.
        """
        s, E, S, a = self.s, self.E, self.S, self.a  # noqa: N806
        early: list[int] = []
        for m in members:
            both = self._new_var()  # implied by s(m) and E(m)
            self._add(sel, [-s(m), -E(m), both])
            early.append(both)
        self._at_most_one(sel, 0, early)
        self._at_most_one(sel, start, [a(m) for m in members])
        two = self._at_least_two(sel, [s(m) for m in members])
        for m in members:
            self._add(sel, [-two, -s(m), -S(m)])

    def _at_most_one(self, sel: int, guard: int, literals: Sequence[int]) -> None:
        """At most one of `literals` (while `guard` holds, if given): r_i = some of the first i."""
        g = [-guard] if guard else []
        previous = 0
        for literal in literals:
            some = self._new_var()
            self._add(sel, [*g, -literal, some])
            if previous:
                self._add(sel, [*g, -previous, some], [*g, -literal, -previous])
            previous = some

    def _at_least_two(self, sel: int, literals: Sequence[int]) -> int:
        """A variable that is true whenever two of `literals` are."""
        some = two = 0
        for literal in literals:
            new_some, new_two = self._new_var(), self._new_var()
            self._add(sel, [-literal, new_some])
            if some:
                self._add(sel, [-some, new_some], [-literal, -some, new_two])
            if two:
                self._add(sel, [-two, new_two])
            some, two = new_some, new_two
        return two

    # ------------------------------------------------------------ configuration
    def set_configuration(self, config: Configuration) -> None:
        """Put a configuration's facts (literals to assume) in place of the previous
        configuration's, if any: one encoding answers for several configurations."""
        if self._final:
            raise ValueError("this encoding's configuration is in its solver for good (optimise, start_state)")
        del self.facts[self.model_facts :], self.literals[self.model_facts :]
        self._activity = None  # (the active-set facts came after the configuration's)
        first = len(self.facts)
        index = self.model.index
        early_time, static_mode = Time.EARLY, Mode.STATIC
        s, E, S = self.s, self.E, self.S  # noqa: N806 - the spec's names
        fact, literal = self.facts.append, self.literals.append  # (a call less per fact: 100,000s)
        for entry in config.entries.values():
            i = index.get(entry.id)
            if i is None:
                continue
            if not entry.selected:
                fact(EncodedFact(FactKind.CONFIG_DESELECTED, i))
                literal(-s(i))
                continue
            fact(EncodedFact(FactKind.CONFIG_SELECTED, i))
            literal(s(i))
            if entry.time is not None:
                fact(EncodedFact(FactKind.CONFIG_TIME, i))
                literal(E(i) if entry.time is early_time else -E(i))
            if entry.mode is not None:
                fact(EncodedFact(FactKind.CONFIG_MODE, i))
                literal(S(i) if entry.mode is static_mode else -S(i))
        self._config_fact_range = (first, len(self.facts))

    # ----------------------------------------------------------------- queries
    def assumptions(self, with_config: bool = True) -> list[int]:
        """The literals that put every model fact (explain build) and the configuration in force.

        Without the configuration only while it is not in the solver for good (after
        `optimise` or `start_state(variant=...)` it is: the answer would not be the model's)."""
        if self._final and not with_config:
            raise ValueError("this encoding's configuration is in its solver for good: no answer without it")
        last = self._config_fact_range[1] if with_config and not self._config_units else self.model_facts
        return self.literals[:last]

    def fix_configuration(self) -> None:
        """Put the configuration in the solver as unit clauses, for good, for questions that
        are all asked under it (the hard build). Glucose makes a decision level per
        assumption: `show` of a complete configuration of 10,000 features propagated 40,000
        questions under 25,000 assumptions each, 60 s, where units make each propagation
        cost only what it propagates. Afterwards `assumptions()` holds the model's facts only,
        and no other configuration can be set."""
        first, last = self._config_fact_range
        add_clauses(self.solver, [[literal] for literal in self.literals[first:last]])
        self._final = self._config_units = True

    def solve(self, with_config: bool = True, extra: Sequence[int] = ()) -> bool:
        return bool(self.solver.solve(assumptions=[*self.assumptions(with_config), *extra]))

    def assignment(self) -> list[int]:
        model = self.solver.get_model()
        return list(model) if model is not None else []

    def query(self, kind: FactKind, i: int, literal: int) -> int:
        """A hypothetical fact ("f is selected") to explain why it cannot hold; its index."""
        self.facts.append(EncodedFact(kind, i))
        self.literals.append(literal)
        return len(self.facts) - 1

    def conflicts(
        self,
        with_config: bool = True,
        limit: int = 20,
        queries: Sequence[int] = (),
        order: Sequence[int] | None = None,
        fixed: Sequence[int] = (),
    ) -> list[list[int]]:
        """Minimal sets of conflicting facts (indices into `facts`), disjoint, best first.

        Each is a minimal unsatisfiable subset of the facts: drop any one and the rest has a
        valid variant. After one is found its facts are set aside and the search goes on,
        so independent problems are all reported (up to `limit`). `queries` (from
        `query()`) are assumed too, so a dead feature's reason can be asked for. `order`
        replaces the facts considered (and their order); `fixed` literals are assumed
        throughout without being facts of a conflict.
        """
        if not self.explain:
            raise ValueError("conflicts() needs Encoding(model, explain=True)")
        last = self._config_fact_range[1] if with_config else self.model_facts
        # Queries and configuration facts first: the solver's core tends to use the earliest.
        literal_of = self.literals.__getitem__
        by_literal: Mapping[int, int]
        remaining: dict[int, None] | None = None  # the facts left (an ordered set), once one is found
        considered: Collection[int]
        if order is None:
            considered = _AllFacts(queries, self.model_facts, last)
            by_literal = self._by_literal([*queries, *range(self.model_facts, last)])
            # (the first assumptions in C: at 100,000 features there are 480,000)
            facts = self.literals
            first = [*fixed, *map(literal_of, queries), *facts[self.model_facts : last], *facts[: self.model_facts]]
        else:
            considered = order
            by_literal = {}
            for k in order:
                by_literal.setdefault(self.literals[k], k)
            remaining = dict.fromkeys(order)
            first = []  # (the assumptions are made from `remaining`)
        found: list[list[int]] = []
        while len(found) < limit:
            assumptions = first if remaining is None else [*fixed, *map(literal_of, remaining)]
            if self.solver.solve(assumptions=assumptions):
                break
            core = self._core(by_literal, considered if remaining is None else remaining)
            core = self._minimise(core, fixed)
            found.append(sorted(core))
            if len(found) == limit:
                break
            if remaining is None:  # (made only now: a question asked once, limit=1, needs none)
                remaining = dict.fromkeys(considered)
            for k in core:
                remaining.pop(k, None)
        found.sort(key=lambda mus: (len(mus), min(self._first_feature(k) for k in mus)))
        return found

    def _by_literal(self, first: Sequence[int]) -> Mapping[int, int]:
        """literal -> fact for the facts `first` and then every model fact, the first fact
        of each literal winning; the model facts' part is made once per encoding (and not
        copied: 480,000 entries at 100,000 features)."""
        if self._model_by_literal is None:
            self._model_by_literal = {}
            for k in range(self.model_facts):
                self._model_by_literal.setdefault(self.literals[k], k)
        ahead: dict[int, int] = {}
        for k in first:
            ahead.setdefault(self.literals[k], k)
        return ChainMap(ahead, self._model_by_literal)

    def _core(
        self, by_literal: Mapping[int, int], allowed: Container[int], solver: Solver | None = None
    ) -> list[int]:
        """The facts `allowed` whose literals are in the solver's core, in the core's order."""
        core = (solver or self.solver).get_core() or []
        return [by_literal[lit] for lit in core if by_literal.get(lit) in allowed]

    def _minimise(self, core: list[int], fixed: Sequence[int] = ()) -> list[int]:
        """Deletion-based shrinking of an unsatisfiable set of facts to a minimal one.

        In a solver of the core's own clauses: every clause of the explain build is under
        its fact's selector, so facts not assumed are switched off, and a set of facts has
        a variant in the whole model iff its clauses are satisfiable on their own. (In the
        whole model, each of these solves assigned every variable of every feature.) Their
        variables are numbered anew, 1, 2, ... in their order: a solver numbered as the
        model decides every variable up to the highest one (7 ms a solve at 100,000
        features, for a core of 4 clauses).
        """
        # (the facts' selectors, and any in `fixed`; other literals have no clauses)
        wanted = {*fixed, *(self.literals[k] for k in core)}
        literals, starts = self._kept_literals, self._kept_starts
        if self._clauses_of is None:  # (all clauses are kept when the encoding is made)
            self._clauses_of = {}
            for c, selector in enumerate(self._kept_selectors):
                self._clauses_of.setdefault(selector, []).append(c)
        clauses_of = self._clauses_of
        clauses = [  # in the order they were made, as a scan of every clause would give them
            literals[starts[c] : starts[c + 1]].tolist()
            for c in sorted(chain.from_iterable(clauses_of.get(w, ()) for w in wanted))
        ]
        used = sorted({abs(lit) for clause in clauses for lit in clause} | {abs(lit) for lit in wanted})
        number = {variable: k for k, variable in enumerate(used, 1)}

        def renumbered(lit: int) -> int:
            return number[lit] if lit > 0 else -number[-lit]

        clauses = [[renumbered(lit) for lit in clause] for clause in clauses]
        fixed = [renumbered(lit) for lit in fixed]
        literal_of = {k: renumbered(self.literals[k]) for k in core}
        by_literal = {literal_of[k]: k for k in core}
        # Facts tried for deletion first are the least likely to stay: the start-state
        # fact goes first, so a conflict that section 2 or 3 explains is not blamed on it.
        # A fact already shown (a dead feature) goes last: it stands for a conflict of its own,
        # which the facts before it would otherwise spell out again.
        current = sorted(core, key=lambda k: (self.facts[k].kind not in (FactKind.START, FactKind.START_EARLY), self.facts[k].kind == FactKind.DEAD))
        rotation = _Rotation(clauses, by_literal, fixed)
        with Solver(name=self.solver_name, bootstrap_with=clauses) as solver:
            i = 0
            while i < len(current):
                if current[i] in rotation.critical:  # (shown needed by a rotated variant)
                    i += 1
                    continue
                trial = current[:i] + current[i + 1 :]
                if solver.solve(assumptions=[*fixed, *(literal_of[k] for k in trial)]):
                    rotation.rotate(current[i], set(current), solver.get_model())
                    i += 1  # needed
                else:
                    smaller = set(self._core(by_literal, set(trial), solver))
                    current = [k for k in trial if k in smaller]
        return current

    def kept_clauses(self) -> Iterator[list[int]]:
        """Every clause of the explain build, each under its fact's selector (for MaxSAT)."""
        if not self.explain:
            raise ValueError("kept_clauses() needs Encoding(model, explain=True)")
        literals, starts = self._kept_literals, self._kept_starts
        for c in range(len(starts) - 1):
            yield literals[starts[c] : starts[c + 1]].tolist()

    def _first_feature(self, k: int) -> int:
        fact = self.facts[k]
        if fact.kind in (FactKind.GROUP_OR, FactKind.GROUP_XOR, FactKind.XOR_ALTERNATIVES):
            return self.model.groups[fact.a].parent
        if fact.kind == FactKind.FORMULA:
            return min(self.model.index[name] for name in self.model.formulas[fact.a].ids())
        return fact.a

    def unhint(self) -> None:
        """Polarity hints of the emptiest variant: every feature deselected and inactive,
        over the phases the last variant left (set before `hint`s that ask for more).

        Glucose tries the last variant's values first. When a target's assumptions clash
        with many of them at once (a group of thousands of members selected Early, the
        target wants their parent Late), each clash is a conflict that undoes the thousands
        of decisions made since (it backjumps, it does not backtrack chronologically): one
        solve of a 10,000-feature model took 1,147 conflicts, 9.4 million decisions and
        2.2 s, and none hinted from here. A solve that succeeds assigns every variable
        anyway, so this costs what it already does (`work.resets` counts them)."""
        if self._unhinted is None:
            self._unhinted = [-v for i in range(self.n) for v in (4 * i + 1, 4 * i + 4)]
        self.solver.set_phases(self._unhinted)
        self.work.resets += 1

    def hint(self, literals: Iterable[int]) -> None:
        """Polarity hints for the next solve: `literals`, with at most one member of each
        large XOR group (over ONE_HINTED_FROM members) hinted selected (the first one). A
        hint that selects a thousand alternatives costs the solver a conflict per member,
        each undoing thousands of decisions: 1 s for one solve of a model with groups of
        thousands of members, 10 ms hinted so. Small groups are hinted as asked: Dynamic
        alternatives may be selected together, and a variant that selects them all shows
        more at once. (Hinting every other member of a large group not selected as well
        would cost the group's size per solve.)"""
        if self._xor_member is None:
            self._xor_member = {
                self.s(m): g
                for g, group in enumerate(self.model.groups)
                if group.kind is GroupKind.XOR and len(group.members) > ONE_HINTED_FROM
                for m in group.members
            }
        member = self._xor_member
        if not member:
            literals = list(literals)
            self.solver.set_phases(literals)
            self.work.phases += len(literals)
            return
        if not isinstance(literals, (list, array)):
            literals = list(literals)
        if len(literals) >= VECTOR_FROM // 8:
            self._hint_in_numpy(literals)
            return
        hinted: set[int] = set()
        out: list[int] = []
        for literal in literals:
            g = member.get(literal)
            if g is not None:
                if g in hinted:
                    literal = -literal
                else:
                    hinted.add(g)
            out.append(literal)
        self.solver.set_phases(out)
        self.work.phases += len(out)

    def _hint_in_numpy(self, literals: Sequence[int]) -> None:
        """`hint`'s rule over many literals at once (the wide family's 32 hints of 40,000
        literals each took 0.07 s of a 0.8 s `analyse`, one dict lookup per literal)."""
        import numpy as np  # lazy: only large models get here

        values = np.asarray(literals, dtype=np.int64)
        highest = int(np.abs(values).max())
        if self._xor_group_of is None or len(self._xor_group_of) <= highest:  # variable -> its large XOR group, or -1
            assert self._xor_member is not None
            table = np.full(max(self._top, highest) + 1, -1, dtype=np.int64)
            table[np.fromiter(self._xor_member, dtype=np.int64)] = np.fromiter(self._xor_member.values(), dtype=np.int64)
            self._xor_group_of = table
        groups = np.where(values > 0, self._xor_group_of[np.abs(values)], -1)
        at = np.flatnonzero(groups >= 0)  # selected members of large groups, in order
        if len(at):
            _, first = np.unique(groups[at], return_index=True)
            later = np.ones(len(at), dtype=bool)
            later[first] = False
            values[at[later]] = -values[at[later]]  # all but each group's first: deselected
        self.solver.set_phases(values.tolist())
        self.work.phases += len(values)

    def cover(
        self,
        targets: Sequence[Sequence[int]],
        with_config: bool = True,
        hints: Sequence[Sequence[int]] = (),
        witness: Callable[[list[int]], None] | None = None,
        implied: Sequence[int | None] | None = None,
        batch: bool = False,
        refute: bool | Sequence[bool] = True,
        requires: Sequence[int | None] | None = None,
        settled: tuple[int, Callable[[list[bool]], None]] | None = None,
        start_empty: bool = False,
        order: Sequence[int] | None = None,
        shown: Sequence[bool] | None = None,
        refuted: Sequence[bool] | None = None,
    ) -> list[bool]:
        """Which conjunctions of literals hold in some valid variant.

        `witness`, if given, is called with each valid variant found on the way (the
        solver's assignment), so that a caller can learn more from them (atomic sets).
        `implied`, if given, names for each target an earlier one (or None) whose literals
        unit propagation derives from it: a feature's "selected" target names its parent's.
        `requires`, if given, names for each target an earlier one (or None) that holds
        whenever it does (a binding of a feature needs the feature's selection): a target
        whose required one is impossible is impossible too, without a solve, and step 2
        propagates a target only once the one it requires is shown possible.
        `settled=(m, tell)`: `tell` is called once with the answers for the first m targets
        as soon as they are known (step 3 settles the targets in their order), before the
        others are.
        `start_empty`: each solve of step 3 starts from the emptiest variant's phases
        (`unhint`), not the last variant's: for targets that fix bindings, which clash
        with the last variant's times and modes of thousands of features at once. Targets
        of selections alone do better from the last variant (it selects much, and a
        witness shows more): at 100,000 features of mostly fixed bindings, the first round
        of atomic sets took 2,075 solves from the emptiest variant and 463 from the last.
        `shown`, if given, says for each target whether the caller knows already that it
        holds (in a variant found before); those are settled without a question.
        `refuted`, likewise, whether the caller knows already that it cannot hold (no
        variant had it under a subset of these assumptions: menuconfig's last decisions,
        when it asks again after one more).
        `order`: the order in which the targets are taken (a permutation of their indices;
        by default theirs), in which `implied` and `requires` name earlier targets and,
        with `settled`, the first m targets come first. Targets that no variant shows
        together (alternatives of one XOR group) are best far apart in it: a batch of
        them fails, and a solve hinted towards the next ones shows one of them only.
        `batch`: solve for several open targets at once in step 3 (where most of what is
        left is possible, as for bindings; where most is not, the batches mostly fail).
        `refute=False` (or False for a target) skips step 2, where it would refute almost
        nothing and cost one propagation per open target (0.25 ms each at 100,000
        features, more for targets that imply much): for targets that unit propagation has
        already failed to refute one literal at a time (atomic sets' first round), and for
        features' selections (dead features), which batches settle. An impossible target
        is still found so, by a solve in step 3.

        1. Solves under polarity hints (each of `hints`, then towards the targets still
           open, again while a witness settles at least WITNESS_GAIN of them) find
           witnesses that cover most targets at once, one solve for thousands.
        2. Unit propagation refutes most impossible targets without a search.
        3. Each target still open is solved for under its literals as assumptions (with
           `batch`, with those of later open targets, less those a failed solve's core
           blames, `_solve_batch`; alone when none is left), with the hints towards the
           next open targets, so its witness settles others too.

        No step costs more per target the more targets are open (`_Cover`): a target's own
        solve is hinted towards the next HINT_WINDOW open targets, not every open one, and
        a new witness is checked only against the open targets over the variables it
        changed. `work` counts what the calls did (a test checks that it grows linearly).
        """
        state = _Cover(self, targets, order)
        if shown is not None:
            for known in compress(range(len(targets)), shown):
                state.close(known, True)
        if refuted is not None:
            for known in compress(range(len(targets)), refuted):
                state.close(known, False)
        first, tell = settled if settled is not None else (0, None)

        def answered() -> list[bool]:  # (the first ones too, if not told yet)
            if tell is not None:
                tell(state.possible[:first])
            return state.possible

        base = self.assumptions(with_config)
        for hint in hints:
            self.hint(hint)
            if not self._solve(base):
                return answered()
            state.mark(witness)
        while state.left:
            state.prefer()
            if not self._solve(base):
                return answered()
            before = state.left
            state.mark(witness)
            if before - state.left < max(WITNESS_GAIN, before // 16):
                break
        if refute is not False and state.left:
            # what the assumptions alone propagate refutes some targets at once (under a
            # configuration of many decisions each propagation repeats theirs: 0.2 ms
            # apiece), also those not to be refuted one by one (each of which a failed
            # batch solve would refute otherwise)
            ok, forced = self.solver.propagate(assumptions=base)
            if ok:
                against = {-literal for literal in forced}
                for j in [j for j in state.open_targets() if not against.isdisjoint(targets[j])]:
                    state.close(j, False)
            asked = [
                k
                for k in state.open_targets()
                if (refute is True or refute[k]) and (requires is None or (r := requires[k]) is None or state.possible[r])
            ]
            consistent = set(self._propagating(targets, base, asked, implied))
            for j in asked:
                if j not in consistent:
                    state.close(j, False)
        while (k := state.next_open()) is not None:
            if tell is not None and k >= first:
                tell(state.possible[:first])
                tell = None
            if requires is not None and (r := requires[k]) is not None and not state.possible[r]:
                # (every target before k in the order is settled: so is r, as impossible)
                state.close(k, False)
                continue
            if start_empty:
                self.unhint()
            state.prefer(HINT_WINDOW)
            found = self._solve_batch(targets, base, [k, *state.open_after(BATCH_TRIED - 1)]) if batch else None
            if found is None:
                found = self._solve([*base, *targets[k]])
            if found:
                state.mark(witness)  # (k among them)
            else:
                state.close(k, False)
        return answered()

    def _solve(self, assumptions: list[int]) -> bool:
        self.work.solves += 1
        return bool(self.solver.solve(assumptions=assumptions))

    def solve_counted(self, assumptions: list[int]) -> bool:
        """One solve under `assumptions` (with the model's own, `assumptions()`, if wanted),
        counted in `work`."""
        return self._solve(assumptions)

    def _solve_batch(
        self, targets: Sequence[Sequence[int]], base: list[int], pending: list[int]
    ) -> bool | None:
        """Solve for the first open target together with up to BATCH - 1 of the next
        BATCH_TRIED, those whose literals do not contradict the ones taken before them:
        True when that succeeds (the solver's variant then shows them all), False when the
        first target cannot hold, None when no other target is left (its own solve decides).

        A failed solve's core names assumptions that cannot hold together: the targets
        that own one of them (other than the first target's and the configuration's) leave,
        and the rest is solved for again; a core within the first target's literals and the
        configuration's says that the first cannot hold. Failed solves are cheap (unit
        propagation finds most conflicts); a successful one assigns every variable (50 ms
        at 100,000 features), so one for many targets is what saves time. After
        BATCH_FAILURES failed solves the batch gives up (None): alternatives of one XOR
        group exclude each other, and each core blames one of them only.
        """
        first = targets[pending[0]]
        taken = {abs(literal): literal for literal in [*base, *first]}
        members: list[Sequence[int]] = []
        for j in pending[1:BATCH_TRIED]:
            target = targets[j]
            if any(taken.get(abs(literal), literal) != literal for literal in target):
                continue
            taken.update((abs(literal), literal) for literal in target)
            members.append(target)
            if len(members) >= BATCH - 1:
                break
        innocent = {*base, *first}
        for _ in range(BATCH_FAILURES):
            if not members:
                break
            if self._solve([*base, *first, *chain.from_iterable(members)]):
                return True
            blamed = set(self.solver.get_core() or ()) - innocent
            if not blamed:
                return False
            members = [target for target in members if blamed.isdisjoint(target)]
        return None

    def _propagating(
        self,
        targets: Sequence[Sequence[int]],
        base: list[int],
        pending: list[int],
        implied: Sequence[int | None] | None,
    ) -> list[int]:
        """The pending targets that unit propagation does not refute, in their order.

        Propagation is monotone: when a target's literals propagate without a conflict, so
        do those of every target they imply (`implied`, followed up the chain), which are
        then not propagated again. Deeper targets go first, so that a chain is walked once.
        """
        consistent: set[int] = set()
        for k in reversed(pending):
            if k in consistent:
                continue
            self.work.propagations += 1
            if not self.solver.propagate(assumptions=[*base, *targets[k]])[0]:
                continue
            j: int | None = k
            while j is not None and j not in consistent:
                consistent.add(j)
                j = implied[j] if implied is not None else None
        return [k for k in pending if k in consistent]

    def optimise(self, soft: Sequence[tuple[int, int]], with_config: bool = True) -> list[int] | None:
        """A valid variant that minimises the weight of the soft literals it leaves false.

        MaxSAT with RC2: the encoding's clauses, the configuration as hard units and `soft`
        as (literal, weight) pairs; None when no variant exists. The values come in variable
        order (variable v's literal at index v - 1), up to `top`.

        RC2 runs on the encoding's own solver, which must not have solved anything yet:
        that solver got the same clauses in the same order as RC2's own would from a WCNF
        built clause by clause (RC2 adds nothing for unit soft clauses), so the search and
        its result are the same, without a second copy of the formula (2 s of `configure`
        at 100,000 features). Afterwards the solver keeps the configuration as units (the
        encoding takes no other configuration) and RC2's totalizers, which leave the
        features' variables free: `start_state` may follow.
        """
        from pysat.solvers import Glucose4

        if not isinstance(self.solver.solver, Glucose4):
            raise ValueError("optimise() runs RC2 on Glucose 4: make the encoding with solver='glucose4'")
        if self.solver.accum_stats().get("restarts"):
            raise ValueError("optimise() needs an encoding that has not solved anything yet")
        from pysat.formula import WCNF

        formula = WCNF()
        formula.soft = [[literal] for literal, _ in soft]
        formula.wght = [weight for _, weight in soft]
        formula.topw += sum(formula.wght)
        # the highest variable of the clauses: every variable up to `top` occurs in the
        # encoding's clauses (a test checks it), and the units and soft literals are features'
        formula.nv = self._top
        maxsat = _rc2()(formula, solver="g4")  # (its own solver is empty: nothing is copied)
        try:
            maxsat.oracle.delete()
            maxsat.oracle = self.solver
            add_clauses(self.solver, [[literal] for literal in self.assumptions(with_config)])
            self._final = True
            # what `compute` returns, without its sort by a Python key of every literal: the
            # model lists variables 1, 2, ... in order, and RC2 maps 1..nv to themselves
            values = list(self.solver.get_model()[: formula.nv]) if maxsat.compute_() else None
            self._top = max(self._top, maxsat.pool.top)  # past RC2's totalizers
        finally:
            maxsat.oracle = None  # the solver stays the encoding's
            maxsat.delete()
        return values

    def active_set_conflicts(
        self, fixed: Sequence[int], active: Collection[int], limit: int = 5
    ) -> list[list[int]]:
        """Why `active` (feature indices) cannot be the run time's active set; [] if it can.

        Explain build only. `fixed` are the variant's literals (s, E, S of every feature),
        assumed but never blamed. The facts are every model fact except FactKind.START_EARLY (a
        Dynamic Early feature may be unloaded at run time) and, per feature, "active" or
        "inactive" as asked: a conflict names the model statements and the features whose
        activity contradicts them (reference.md section 4: A satisfies section 2).
        """
        if not self.explain:
            raise ValueError("active_set_conflicts() needs Encoding(model, explain=True)")
        if self._activity is None:
            self._activity = len(self.facts)
            for kind, sign in ((FactKind.ACTIVE, 1), (FactKind.INACTIVE, -1)):
                for i in range(self.n):
                    self.facts.append(EncodedFact(kind, i))
                    self.literals.append(sign * self.a(i))
        wanted = set(active)
        chosen = [self._activity + (i if i in wanted else self.n + i) for i in range(self.n)]
        model = [k for k in range(self.model_facts) if self.facts[k].kind != FactKind.START_EARLY]
        assumptions = [*fixed, *(self.literals[k] for k in model), *(self.literals[k] for k in chosen)]
        if self.solver.solve(assumptions=assumptions):
            return []
        return self.conflicts(limit=limit, order=[*chosen, *model], fixed=fixed)

    def start_state(self, late: Sequence[int], variant: Sequence[int] | None = None) -> list[int] | None:
        """The active set at start (reference.md section 4), as feature indices; None if none.

        Call after `set_configuration` with a complete variant, or give the variant's
        literals as `variant` (s of every feature, E and S of each selected one). `late`
        are the selected Late features in definition order: the fewest of them are
        activated (an incremental totalizer bounds the count, tightened until
        unsatisfiable), and among the smallest sets the one that activates earlier features
        first (greedy in pre-order, each choice kept as an assumption). One solver
        throughout; the answer is unique, so it does not depend on the solver's path.

        A `variant` becomes unit clauses, not assumptions, which makes each solve cheap at
        100,000 features (Glucose makes a decision level per assumption); the encoding then
        takes no configuration any more.
        """
        if variant is not None:
            add_clauses(self.solver, [[literal] for literal in variant])
            self._final = True
            base = self.literals[: self.model_facts]  # (the model's facts, in an explain build)
        else:
            base = self.assumptions()
        if not self.solver.solve(assumptions=base):
            return None
        truth = set(self.assignment())
        if late:
            from pysat.card import ITotalizer

            literals = [self.a(i) for i in late]
            counter = ITotalizer(lits=literals, ubound=len(literals), top_id=self._top)
            self._top = counter.top_id
            add_clauses(self.solver, counter.cnf.clauses)
            bound = sum(1 for literal in literals if literal in truth)
            while bound and self.solver.solve(assumptions=[*base, -counter.rhs[bound - 1]]):
                truth = set(self.assignment())
                bound = sum(1 for literal in literals if literal in truth)
            fixed = [*base, -counter.rhs[bound]] if bound < len(literals) else list(base)
            for literal in literals:
                # `truth` satisfies every choice so far (a refused literal is false in each
                # solution of the earlier ones): where it holds `literal`, so may the choice
                if literal not in truth:
                    if not self.solver.solve(assumptions=[*fixed, literal]):
                        fixed.append(-literal)
                        continue
                    truth = set(self.assignment())
                fixed.append(literal)
            counter.delete()
        return [i for i in range(self.n) if self.a(i) in truth]

    # --------------------------------------------------------------- lifecycle
    def close(self) -> None:
        if keep_till_exit():  # (the process ends soon, and frees the last one at no cost)
            _LEFT_TILL_EXIT.append(self.solver)
            # (a command of many encodings keeps one at most; a forked child, all: deleting
            # one would come before its answer, and would touch the parent's pages it shares)
            while len(_LEFT_TILL_EXIT) > 1 and not keeping_all():
                _LEFT_TILL_EXIT.pop(0).delete()
        else:
            self.solver.delete()

    def __enter__(self) -> Encoding:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, value: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


_LEFT_TILL_EXIT: list[Solver] = []  # the last closed encoding's solver, left for the process's end


@dataclass(frozen=True, slots=True)
class SelectionCNF:
    """The CNF of section 2 alone (formulas included): the selections, as other tools read them.

    Variable i + 1 is feature i's selection, in pre-order; the variables after `features`
    (XOR counters, formula operators) are each defined by the feature variables, so the
    count of the CNF is the count of selections, read projected or not.
    """

    features: int
    variables: int
    clauses: list[list[int]]


COMPACT_CLAUSES, COMPACT_LITERALS = 64, 1024  # a formula written as clauses by `selection_cnf(compact=True)`


def selection_cnf(model: FeatureModel, compact: bool = False) -> SelectionCNF:
    """Section 2 over one variable per feature: root, hierarchy, mandatory children, OR and
    XOR groups (exactly one member: no run-time alternatives without bindings), includes,
    excludes and formulas; the DIMACS export and the selection count read it.

    `compact`: a formula whose clauses (by distribution) are at most COMPACT_CLAUSES is
    written as them, without Tseitin's variables (the compiled selections: eCos's 2,478
    formulas are 3,723 clauses over its 1,245 features, where with Tseitin's they were
    12,102 over 4,038 variables, and the compile twice as slow)."""
    n = len(model.features)
    clauses: list[list[int]] = [[1]]
    top = n

    def new_var() -> int:
        nonlocal top
        top += 1
        return top

    for f in model.features:
        if f.parent is None:
            continue
        child, parent = f.index + 1, f.parent + 1
        clauses.append([-child, parent])
        if f.mandatory:
            clauses.append([-parent, child])
    for group in model.groups:
        members = [m + 1 for m in group.members]
        clauses.append([-(group.parent + 1), *members])
        if group.kind is not GroupKind.XOR:
            continue
        if len(members) <= PAIRWISE_UP_TO:
            clauses += [[-x, -y] for k, x in enumerate(members) for y in members[k + 1 :]]
            continue
        # at most one, as a sequential counter whose variables are defined, not only implied:
        # some_k <-> some_(k-1) or m_k, and never some_(k-1) and m_k
        some = members[0]
        for member in members[1:]:
            clauses.append([-some, -member])
            both = new_var()
            clauses += [[-both, some, member], [both, -some], [both, -member]]
            some = both
    index = model.index
    for f in model.features:
        for target in dict.fromkeys(f.includes):
            if target in index and index[target] != f.index:
                clauses.append([-(f.index + 1), index[target] + 1])
        for target in dict.fromkeys(f.excludes):
            if target in index and index[target] != f.index:
                clauses.append([-(f.index + 1), -(index[target] + 1)])
    for formula in model.formulas:
        if compact:
            from ..language.formula import clauses_of

            found = clauses_of(formula.tree, COMPACT_CLAUSES, COMPACT_LITERALS)
            if found is not None:
                clauses += [[index[fid] + 1 if positive else -(index[fid] + 1) for fid, positive in c] for c in found]
                continue
        top_literal = tseitin(formula, lambda name: index[name] + 1, new_var, clauses.append)
        clauses.append([top_literal])
    return SelectionCNF(n, top, clauses)

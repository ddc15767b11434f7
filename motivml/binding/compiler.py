"""A knowledge compiler: a CNF, projected onto some of its variables, as a smooth d-DNNF.

A d-DNNF answers counting questions in one pass over its nodes: how many assignments of
the projected variables extend to a model, also under assumptions, how many of them set
each variable, and a uniformly random one (`compiled.py` asks ddnnife). It is made once per
model and kept (`compiled.py`); this module makes it.

The method is a decision-DNNF compiler with component caching (as Dsharp and d4 are): the
clauses left open by unit propagation fall into connected components, each compiled on its
own and joined by an AND node (decomposable: no shared variables); within a component the
compiler decides a variable and joins both outcomes in an OR node (deterministic: the
outcomes disagree on it). A component met again with the same open clauses over the same
open variables is the node compiled before (the cache). Nothing is learnt from conflicts:
feature models are mostly satisfiable everywhere, and no component of the public models
was refuted once (eCos, 15,401 decisions).

What makes it fast on feature models is the order of decisions. A component is split by
deciding first the variables that a min-degree elimination of the clauses' variable graph
removes last: those are the ones many others hang on (a feature with many sub-features and
constraints), so that deciding them separates the rest into independent parts. Deciding the
variables that occur in most open clauses compiled BusyBox in 0.1 s but not Automotive01's
published DIMACS in 60 s; this order compiles it in 1 s.

Projection: a decision is made on a projected variable while the component has one, so an
OR node's outcomes differ on a projected variable and stay disjoint after the others are
forgotten; a component left with unprojected variables only is satisfiable or not (TRUE or
FALSE), found by deciding until one outcome is. (A variable defined by the projected ones,
as a Tseitin variable is by its formula's, may be projected too without changing the count:
`compiled.py` projects the selection CNF onto all its variables so, which compiles eCos's in
31 s, where leaving its 2,793 definitions unprojected did not finish in 120 s.)

Smoothness (every outcome of an OR node mentions the same projected variables) is kept as
the nodes are made: a projected variable of a component that ends up in no clause of an
outcome joins it as "x or not x". ddnnife counts only smooth d-DNNFs right.

The search is iterative (each component is a generator that yields the sub-components it
needs, driven by an explicit stack): a compile can be 40,000 decisions deep.
"""

from __future__ import annotations

import heapq
import time
from collections.abc import Callable, Generator, Iterable, Sequence
from dataclasses import dataclass
from itertools import chain
from typing import Any, TextIO

FALSE, TRUE = 0, 1  # the nodes every d-DNNF here starts with: an empty OR, an empty AND
LITERAL, AND, OR = 0, 1, 2
CLIQUE_UP_TO = 64  # neighbours joined into a clique when a variable is eliminated (`decision_order`)
CHECK_EVERY = 16  # decisions between two looks at the clock


class CompileTimeout(Exception):
    """The compile did not end before its deadline."""


@dataclass(frozen=True, slots=True)
class Dnnf:
    """A smooth d-DNNF over variables 1..variables (the projection, renumbered in its order).

    `nodes[k]` is (LITERAL, literal), (AND, children) or (OR, decision variable, children),
    children before their parents; `root` is the last node. Node 0 is FALSE and node 1 TRUE.
    """

    variables: int
    nodes: list[tuple[Any, ...]]
    root: int
    decisions: int

    def write_c2d(self, out: TextIO) -> None:
        """The nodes reachable from the root in c2d's format ("nnf", "L", "A", "O" lines),
        which ddnnife reads."""
        nodes, root = self.nodes, self.root
        keep = bytearray(root + 1)
        keep[root] = 1
        for k in range(root, -1, -1):
            if keep[k]:
                node = nodes[k]
                for child in node[-1] if node[0] != LITERAL else ():
                    keep[child] = 1
        number: dict[int, int] = {}
        lines: list[str] = []
        edges = 0
        for k in range(root + 1):
            if not keep[k]:
                continue
            node = nodes[k]
            number[k] = len(lines)
            if node[0] == LITERAL:
                lines.append(f"L {node[1]}")
                continue
            children = node[-1]
            edges += len(children)
            listed = " ".join(str(number[c]) for c in children)
            head = f"A {len(children)}" if node[0] == AND else f"O {node[1]} {len(children)}"
            lines.append(f"{head} {listed}" if children else head)
        out.write(f"nnf {len(lines)} {edges} {self.variables}\n")
        out.write("\n".join(lines))
        out.write("\n")


def compile_cnf(
    variables: int,
    clauses: Iterable[Sequence[int]],
    projection: Sequence[int] | None = None,
    deadline: float | None = None,
    stop: Callable[[], bool] | None = None,
) -> Dnnf:
    """The CNF over variables 1..`variables`, projected onto `projection` (None: all, in
    order), as a smooth d-DNNF whose variable k + 1 is projection[k]. `deadline` is a
    `time.monotonic()` value; past it, or once `stop()` is true, CompileTimeout."""
    given_up = _GivenUp(deadline, stop)
    given_up.check()
    order = decision_order(variables, clauses if isinstance(clauses, list) else list(clauses), given_up)
    projected = range(1, variables + 1) if projection is None else projection
    return _Compiler(variables, clauses, projected, given_up, order).run()


class _GivenUp:
    """When a compile is to end: past its deadline, or when told to stop."""

    def __init__(self, deadline: float | None, stop: Callable[[], bool] | None) -> None:
        self.deadline, self.stop = deadline, stop

    def check(self) -> None:
        if (self.deadline is not None and time.monotonic() > self.deadline) or (self.stop is not None and self.stop()):
            raise CompileTimeout


def decision_order(variables: int, clauses: Sequence[Sequence[int]], given_up: _GivenUp | None = None) -> list[int]:
    """Per variable, its rank in a min-degree elimination of the graph in which two
    variables are neighbours when a clause has both (the higher, the later eliminated: the
    compiler decides those first). An eliminated variable's neighbours become neighbours
    of each other, unless it has more than CLIQUE_UP_TO of them (a feature with hundreds of
    sub-features would join them all)."""
    around: list[set[int]] = [set() for _ in range(variables + 1)]
    for clause in clauses:
        if len(clause) < 2:
            continue
        named = [abs(literal) for literal in clause]
        for v in named:
            around[v].update(named)
    for v in range(variables + 1):
        around[v].discard(v)
    heap = [(len(around[v]), v) for v in range(1, variables + 1)]
    heapq.heapify(heap)
    rank = [0] * (variables + 1)
    done = bytearray(variables + 1)
    place = 0
    while heap:
        degree, v = heapq.heappop(heap)
        if done[v] or degree != len(around[v]):
            continue  # (a stale entry: v's degree changed since)
        done[v] = 1
        place += 1
        if given_up is not None and place % 1024 == 0:
            given_up.check()
        rank[v] = place
        neighbours = around[v]
        for w in neighbours:
            around[w].discard(v)
        if len(neighbours) <= CLIQUE_UP_TO:
            for w in neighbours:
                around[w].update(neighbours)
                around[w].discard(w)
        for w in neighbours:
            heapq.heappush(heap, (len(around[w]), w))
        around[v] = set()
    return rank


class _Compiler:
    """The state of one compile: the clauses with their occurrence lists, the assignment
    (values, trail, and per clause its true and unassigned literals, kept as literals are
    assigned and undone), the nodes made and the components' cache."""

    def __init__(
        self,
        variables: int,
        clauses: Iterable[Sequence[int]],
        projection: Sequence[int],
        given_up: _GivenUp,
        order: list[int],
    ) -> None:
        self.variables = variables
        self.given_up = given_up
        self.empty = False  # an empty clause: nothing satisfies the CNF
        kept: list[tuple[int, ...]] = []
        for clause in clauses:
            literals = tuple(dict.fromkeys(clause))
            if not literals:
                self.empty = True
            elif not any(-literal in literals for literal in literals):  # (a tautology says nothing)
                kept.append(literals)
        self.clauses = kept
        self.new = [0] * (variables + 1)  # variable -> its number in the d-DNNF (0: not projected)
        for k, v in enumerate(projection):
            self.new[v] = k + 1
        self.projected = len(projection)
        self.occurs: list[list[int]] = [[] for _ in range(2 * variables + 1)]  # literal + variables -> clauses
        for k, clause in enumerate(kept):
            for literal in clause:
                self.occurs[literal + variables].append(k)
        self.value = [0] * (variables + 1)
        self.stamp = 0  # `_split`'s marks: a variable or clause met in the split of this stamp
        self.met_variable = [0] * (variables + 1)
        self.met_clause = [0] * len(kept)
        self.trail: list[int] = []
        self.true = [0] * len(kept)
        self.unassigned = [len(clause) for clause in kept]
        self.rank = order
        self.nodes: list[tuple[Any, ...]] = [(OR, 0, ()), (AND, ())]
        self.literal_node: dict[int, int] = {}
        self.either_node: dict[int, int] = {}
        self.cache: dict[tuple[tuple[int, ...], tuple[int, ...]], int] = {}
        self.decisions = 0

    # ------------------------------------------------------------------------ nodes
    def _literal(self, literal: int) -> int:
        """The node of an original projected literal."""
        node = self.literal_node.get(literal)
        if node is None:
            node = self.literal_node[literal] = len(self.nodes)
            new = self.new[abs(literal)]
            self.nodes.append((LITERAL, new if literal > 0 else -new))
        return node

    def _either(self, v: int) -> int:
        """The node "v or not v" of a projected variable that nothing constrains."""
        node = self.either_node.get(v)
        if node is None:
            children = (self._literal(v), self._literal(-v))
            node = self.either_node[v] = len(self.nodes)
            self.nodes.append((OR, self.new[v], children))
        return node

    def _and(self, children: list[int]) -> int:
        if FALSE in children:
            return FALSE
        children = [c for c in children if c != TRUE]
        if not children:
            return TRUE
        if len(children) == 1:
            return children[0]
        self.nodes.append((AND, tuple(children)))
        return len(self.nodes) - 1

    # ---------------------------------------------------------------- the assignment
    def _assign(self, literal: int) -> bool:
        """Assign `literal` and what unit propagation derives from it; False on a
        conflict (what was assigned stays on the trail: `_undo` takes it back)."""
        value, occurs, base, clauses, trail = self.value, self.occurs, self.variables, self.clauses, self.trail
        true, unassigned = self.true, self.unassigned
        queue = [literal]
        while queue:
            lit = queue.pop()
            v, sign = (lit, 1) if lit > 0 else (-lit, -1)
            if value[v]:
                if value[v] != sign:
                    return False
                continue
            value[v] = sign
            trail.append(lit)
            for k in occurs[base + lit]:
                true[k] += 1
                unassigned[k] -= 1
            conflict = False
            for k in occurs[base - lit]:
                unassigned[k] -= 1
                if true[k] or conflict:
                    continue
                left = unassigned[k]
                if left == 0:
                    conflict = True
                elif left == 1:
                    for other in clauses[k]:
                        if not value[other if other > 0 else -other]:
                            queue.append(other)
                            break
            if conflict:
                return False
        return True

    def _undo(self, mark: int) -> None:
        value, trail, occurs, base = self.value, self.trail, self.occurs, self.variables
        true, unassigned = self.true, self.unassigned
        for lit in trail[mark:]:
            value[lit if lit > 0 else -lit] = 0
            for k in occurs[base + lit]:
                true[k] -= 1
                unassigned[k] += 1
            for k in occurs[base - lit]:
                unassigned[k] += 1
        del trail[mark:]

    def _split(self, variables: Iterable[int]) -> tuple[list[tuple[list[int], list[int]]], list[int]]:
        """The components of the open clauses over the unassigned ones of `variables`, as
        (variables, clauses), and those variables that no open clause has. (Variables and
        clauses met are marked with this call's stamp, not put in sets: two list reads
        where a set took two hashes.)"""
        value, occurs, base, clauses, true = self.value, self.occurs, self.variables, self.clauses, self.true
        self.stamp += 1
        stamp, met_variable, met_clause = self.stamp, self.met_variable, self.met_clause
        parts: list[tuple[list[int], list[int]]] = []
        free: list[int] = []
        for start in variables:
            if value[start] or met_variable[start] == stamp:
                continue
            met_variable[start] = stamp
            found, open_clauses = [start], []
            for v in found:  # (grows as it is walked)
                for k in chain(occurs[base + v], occurs[base - v]):
                    if true[k] or met_clause[k] == stamp:
                        continue
                    met_clause[k] = stamp
                    open_clauses.append(k)
                    for literal in clauses[k]:
                        w = literal if literal > 0 else -literal
                        if not value[w] and met_variable[w] != stamp:
                            met_variable[w] = stamp
                            found.append(w)
            if open_clauses:
                parts.append((found, open_clauses))
            else:
                free.append(start)
        return parts, free

    # -------------------------------------------------------------------- the search
    def _component(self, found: list[int], open_clauses: list[int]) -> Generator[tuple[list[int], list[int]], int, int]:
        """The node of one component; yields each sub-component it needs and is sent its
        node."""
        key = (tuple(sorted(open_clauses)), tuple(sorted(found)))
        cached = self.cache.get(key)
        if cached is not None:
            return cached
        self.decisions += 1
        if self.decisions % CHECK_EVERY == 0:
            self.given_up.check()
        new, rank = self.new, self.rank
        projected = [v for v in found if new[v]]
        decided = max(projected or found, key=rank.__getitem__)
        outcomes: list[int] = []
        for literal in (decided, -decided):
            mark = len(self.trail)
            if self._assign(literal):
                parts, free = self._split(found)
                children = [self._literal(lit) for lit in self.trail[mark:] if new[abs(lit)]]
                for part in parts:
                    node = yield part
                    if node == FALSE:
                        children = [FALSE]
                        break
                    children.append(node)
                children += [self._either(v) for v in free if new[v]]
                outcome = self._and(children)
                if outcome != FALSE:
                    outcomes.append(outcome)
            self._undo(mark)
            if outcomes and not projected:
                break  # (no projected variable: one way to satisfy it is enough)
        if not outcomes:
            node = FALSE
        elif not projected:
            node = TRUE
        elif len(outcomes) == 1:
            node = outcomes[0]
        else:
            self.nodes.append((OR, new[decided], tuple(outcomes)))
            node = len(self.nodes) - 1
        self.cache[key] = node
        return node

    def _compiled(self, part: tuple[list[int], list[int]]) -> int:
        stack = [self._component(*part)]
        sent: int | None = None
        result = FALSE
        while stack:
            try:
                request = stack[-1].send(sent)  # type: ignore[arg-type]
            except StopIteration as done:
                stack.pop()
                sent = result = done.value
                continue
            stack.append(self._component(*request))
            sent = None
        return result

    def run(self) -> Dnnf:
        root = self._root()
        return Dnnf(self.projected, self.nodes, self._last(root), self.decisions)

    def _root(self) -> int:
        if self.empty:
            return FALSE
        for clause in self.clauses:
            if len(clause) == 1 and not self._assign(clause[0]):
                return FALSE
        parts, free = self._split(range(1, self.variables + 1))
        children = [self._literal(lit) for lit in self.trail if self.new[abs(lit)]]
        children += [self._either(v) for v in free if self.new[v]]
        for part in parts:
            node = self._compiled(part)
            if node == FALSE:
                return FALSE
            children.append(node)
        return self._and(children)

    def _last(self, root: int) -> int:
        """The root as the last node (FALSE and TRUE are the first two: copied to the end)."""
        if root == len(self.nodes) - 1 and root > TRUE:
            return root
        self.nodes.append(self.nodes[root])
        return len(self.nodes) - 1

"""Valid variants for free: which subtrees a known valid variant can drop and stay valid.

Given a full assignment W of the hard build (a valid variant, with its start state and
every auxiliary variable), the *cut* at feature c is W with every feature of c's subtree
that W selects deselected and inactive at start (s and a false), all else as in W. Which
cuts are again full models of the same clauses is decided for every feature at once, in
time linear in the size of the formula, without a solve:

A cut only turns true s and a variables false. So a clause stays satisfied unless all its
true literals are such variables, positive (its *supports*, features F), and none of its
negative literals on a true s or a variable (features N) comes to be true. Features being
in pre-order, c's subtree is the interval [c, c + size(c)): it holds all of F iff c is an
ancestor-or-self of L = the lowest common ancestor of F, and it holds some n of N iff c is
an ancestor-or-self of n. So the clause breaks exactly the cuts on the path from L up to,
not including, M = the deepest of the LCAs of L and each n (the root's parent if N is
empty). Each clause marks its path (+1 at L, -1 at M); the cuts a clause breaks are those
whose subtree sums of marks are positive. Lowest common ancestors come from a range-minimum
table of depths in pre-order (for u < v, the parent of the shallowest node in (u, v]).

The result is exact for the clauses given: a cut reported valid *is* a model of them, so
anything it shows (a feature deselected under a selected parent) holds in a valid variant.
A cut reported broken may still be fixable by changing auxiliary variables; callers ask
the solver about what they still need.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import chain

import numpy as np

from ..language.model import FeatureModel


def subtree_ends(model: FeatureModel) -> np.ndarray:
    """For each feature (pre-order index i), the end of its subtree's interval [i, end)."""
    n = len(model.features)
    size = np.ones(n, dtype=np.int64)
    parent = np.array([-1 if f.parent is None else f.parent for f in model.features], dtype=np.int64)
    for i in range(n - 1, 0, -1):  # children after their parents: sizes flow up in one pass
        size[parent[i]] += size[i]
    return np.arange(n, dtype=np.int64) + size


def valid_cuts(model: FeatureModel, clauses: Sequence[Sequence[int]], values: Sequence[int]) -> np.ndarray:
    """For each feature, whether the cut at it is a model of `clauses` (see the module's
    text); False where W does not select the feature, and at the root. `values` is W as the
    solver gives it (values[v - 1] is v or -v); variables s(i) = 4i + 1 and a(i) = 4i + 4."""
    return Cuts(model, clauses).valid(values)


class Cuts:
    """`valid_cuts` for several variants of one model and one set of clauses: what does not
    depend on the variant (the clauses as flat arrays, the tree's depths, its table of
    lowest common ancestors, its subtree ends) is made once."""

    def __init__(self, model: FeatureModel, clauses: Sequence[Sequence[int]]) -> None:
        n = self.n = len(model.features)
        arrays = getattr(clauses, "arrays", None)  # (the encoding's recorded Clauses: no Python lists)
        if arrays is not None:
            flat, lengths = arrays()
            lits = flat.astype(np.int64)
        else:
            lengths = np.fromiter(map(len, clauses), dtype=np.int64, count=len(clauses))
            lits = np.fromiter(chain.from_iterable(clauses), dtype=np.int64, count=int(lengths.sum()))
        self.count = len(clauses)
        self.owner = np.repeat(np.arange(len(clauses), dtype=np.int64), lengths)
        self.var = np.abs(lits)
        self.positive = lits > 0
        kind = (self.var - 1) % 4
        self.movable = (self.var <= 4 * n) & ((kind == 0) | (kind == 3))  # an s or an a variable
        self.feature = (self.var - 1) // 4
        depth = np.zeros(n, dtype=np.int64)
        parent = np.array([-1 if f.parent is None else f.parent for f in model.features], dtype=np.int64)
        for i in range(1, n):
            depth[i] = depth[parent[i]] + 1
        self.depth = depth
        self.lca = _LowestCommonAncestors(depth, parent)
        self.ends = subtree_ends(model)

    def valid(self, values: Sequence[int]) -> np.ndarray:
        """`valid_cuts` of the variant `values`."""
        n, owner, feature = self.n, self.owner, self.feature
        truth = np.asarray(values, dtype=np.int64) > 0  # truth[v - 1]: v is true in W
        true_var = truth[self.var - 1]
        changing = self.movable & true_var  # s or a, true in W
        holds = true_var == self.positive
        supports = holds & self.positive & changing
        solid = holds & ~supports  # a true literal no cut can falsify
        frees = ~holds & ~self.positive & changing  # a false literal that a cut over its feature makes true
        fragile = np.ones(self.count, dtype=bool)
        fragile[owner[solid]] = False

        picked = supports & fragile[owner]
        low = np.full(self.count, n, dtype=np.int64)
        high = np.full(self.count, -1, dtype=np.int64)
        np.minimum.at(low, owner[picked], feature[picked])
        np.maximum.at(high, owner[picked], feature[picked])
        broken_clauses = np.flatnonzero(fragile)
        if np.any(high[broken_clauses] < 0):  # a clause W does not satisfy: W is not a model
            raise ValueError("the assignment is not a model of the clauses")
        lowest = np.full(self.count, -1, dtype=np.int64)  # L per fragile clause
        lowest[broken_clauses] = self.lca(low[broken_clauses], high[broken_clauses])

        freed = frees & fragile[owner]
        deepest = np.full(self.count, -1, dtype=np.int64)  # depth * n + M, the deepest M per clause
        if np.any(freed):
            k = owner[freed]
            meet = self.lca(lowest[k], feature[freed])
            np.maximum.at(deepest, k, self.depth[meet] * n + meet)
        marks = np.zeros(n + 1, dtype=np.int64)
        np.add.at(marks, lowest[broken_clauses], 1)
        stops = deepest[broken_clauses]
        stops = stops[stops >= 0] % n
        np.add.at(marks, stops, -1)
        sums = np.concatenate(([0], np.cumsum(marks[:n])))
        broken = (sums[self.ends] - sums[np.arange(n)]) > 0
        selected = truth[np.arange(n, dtype=np.int64) * 4]
        cuts: np.ndarray = selected & ~broken
        cuts[0] = False
        return cuts


class _LowestCommonAncestors:
    """LCA queries on a tree in pre-order, vectorised: a sparse table of the index of the
    shallowest node over each power-of-two range."""

    def __init__(self, depth: np.ndarray, parent: np.ndarray) -> None:
        self.depth, self.parent = depth, parent
        n = len(depth)
        table = [np.arange(n, dtype=np.int64)]
        width = 1
        while 2 * width <= n:
            last = table[-1]
            left, right = last[: n - 2 * width + 1], last[width : n - width + 1]
            table.append(np.where(depth[right] < depth[left], right, left))
            width *= 2
        self.table = table

    def __call__(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        u, v = np.minimum(u, v), np.maximum(u, v)
        same = u == v
        lo, hi = u + 1, v  # the shallowest node in (u, v] is a child of the LCA
        lo = np.where(same, v, lo)
        span = hi - lo + 1
        level = np.floor(np.log2(np.maximum(span, 1))).astype(np.int64)
        result = np.empty(len(u), dtype=np.int64)
        for j in np.unique(level):
            at = level == j
            a = self.table[j][lo[at]]
            b = self.table[j][hi[at] - (1 << int(j)) + 1]
            result[at] = np.where(self.depth[b] < self.depth[a], b, a)
        return np.where(same, u, self.parent[result])

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
        lengths = np.asarray(lengths, dtype=np.int64)
        if self.count and not lengths.all():  # (the encoding makes none; reduceat needs none)
            raise ValueError("an empty clause has no model")
        self.owner = np.repeat(np.arange(len(clauses), dtype=np.int64), lengths)
        self.ends_at = np.cumsum(lengths)  # each clause's literals are [starts, ends_at)
        self.starts = self.ends_at - lengths
        self.var = np.abs(lits)
        self.at = self.var - 1  # (where each literal's variable is in a variant)
        self.positive = lits > 0
        kind = (self.var - 1) % 4
        self.movable = (self.var <= 4 * n) & ((kind == 0) | (kind == 3))  # an s or an a variable
        self.feature = (self.var - 1) // 4
        depth = np.zeros(n, dtype=np.int64)
        parent = np.array([-1 if f.parent is None else f.parent for f in model.features], dtype=np.int64)
        for i in range(1, n):
            depth[i] = depth[parent[i]] + 1
        self.depth = depth
        self.parents = np.where(parent < 0, np.arange(n, dtype=np.int64), parent)  # (the root: itself)
        self.lca = _LowestCommonAncestors(depth, parent)
        self.ends = subtree_ends(model)

    def valid(self, values: Sequence[int]) -> np.ndarray:
        """`valid_cuts` of the variant `values`. (Per clause, over its literals, which are
        consecutive: segment reductions, `reduceat`; `ufunc.at` took twice as long.)"""
        n, owner, feature, starts = self.n, self.owner, self.feature, self.starts
        truth = np.asarray(values, dtype=np.int64) > 0  # truth[v - 1]: v is true in W
        true_var = truth[self.at]
        changing = self.movable & true_var  # s or a, true in W
        holds = true_var == self.positive
        supports = holds & self.positive & changing
        solid = holds & ~supports  # a true literal no cut can falsify
        frees = ~holds & ~self.positive & changing  # a false literal that a cut over its feature makes true
        solid_so_far = np.concatenate(([0], np.cumsum(solid, dtype=np.int32)))  # (reduceat: twice as long)
        fragile = solid_so_far[self.ends_at] == solid_so_far[starts]  # no solid literal in the clause

        broken_clauses = np.flatnonzero(fragile)
        in_fragile = fragile[owner]
        picked = np.flatnonzero(supports & in_fragile)  # (few: grouped by clause, in order)
        if len(np.unique(owner[picked])) < len(broken_clauses):  # a clause W does not satisfy
            raise ValueError("the assignment is not a model of the clauses")
        first = np.flatnonzero(np.diff(owner[picked], prepend=-1))  # each broken clause's first
        low = np.minimum.reduceat(feature[picked], first) if len(picked) else picked
        high = np.maximum.reduceat(feature[picked], first) if len(picked) else picked
        lowest = np.full(self.count, -1, dtype=np.int64)  # L per fragile clause
        lowest[broken_clauses] = self.lca(low, high)

        freed = np.flatnonzero(frees & in_fragile)
        stops = np.zeros(0, dtype=np.int64)
        if len(freed):
            k = owner[freed]
            meet = self.lca(lowest[k], feature[freed])
            first = np.flatnonzero(np.diff(k, prepend=-1))  # (freed literals come grouped by clause)
            stops = np.maximum.reduceat(self.depth[meet] * n + meet, first) % n  # the deepest M per clause
        marks = np.bincount(lowest[broken_clauses], minlength=n + 1)[: n + 1]
        marks -= np.bincount(stops, minlength=n + 1)[: n + 1]
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

"""Model families of differently shaped MoTiVML models, for benchmarks and tests (issue 32).

`generate.py` makes one shape: deep random trees with a fifth of the parents grouped, a
tenth of the features in includes and excludes, and bindings mostly fixed. Analyses that are
fast on it can crawl on other shapes, so the benchmarks run each of these families too:

* `deep`: long chains (optional sub-features below optional sub-features, 4,000 deep at
  most, which the loader allows), with side branches;
* `flat`: a root with every other feature an optional child, no constraints;
* `groups`: many small OR and XOR groups (2-5 members), two features in three allowing `Any`
  time and mode (the first row of issue 32);
* `wide`: a few XOR and OR groups of 1,000-10,000 members under the root;
* `dense`: cross-tree includes and excludes on a fifth of the features, and formulas;
* `formulas`: cross-tree constraints as root formulas only (clauses of two to four literals
  and implications, over a quarter of the features);
* `any`: a random tree whose features nearly all allow `Any` time and mode;
* `fixed`: a random tree whose features nearly all fix time and mode.

`family(name, n, seed)` returns the model as a JSON-ready dict with exactly `n` features;
`tiny(name, n, seed)` the same shape at a size brute force can enumerate (tests use it).

    python bench/families.py wide 10000 --seed 1 -o /tmp/wide   # writes /tmp/wide/model.json
"""

from __future__ import annotations

import argparse
import json
import os
import random
import sys
from collections.abc import Callable
from typing import Any

FAMILIES = ("deep", "flat", "groups", "wide", "dense", "formulas", "any", "fixed")
MAX_CHAIN = 4000  # features nest 2 JSON levels deep each; the loader allows 10,000 levels


class _Shape:
    """A tree under construction: parents, groups, mandatory flags, bindings, constraints."""

    def __init__(self, n: int, rng: random.Random) -> None:
        self.n, self.rng = n, rng
        self.parent = [-1] * n
        self.group = [""] * n
        self.mandatory = [False] * n
        self.time = ["Any"] * n
        self.mode = ["Any"] * n
        self.includes: list[list[int]] = [[] for _ in range(n)]
        self.excludes: list[list[int]] = [[] for _ in range(n)]
        self.formulas: list[str] = []
        self.time[0], self.mode[0] = "Early", "Static"

    def bindings(self, any_share: float) -> None:
        """Each feature but the root allows `Any` time (and, independently, mode) with
        probability `any_share`, else one value kept consistent with its parent's (rule 3.2:
        not bound before its parent, no Static child under a Dynamic parent; 3.1: a mandatory
        child as its parent), so that the shapes stay mostly alive."""
        rng = self.rng
        for i in range(1, self.n):
            p = self.parent[i]
            if self.mandatory[i] and not self.group[i]:
                self.time[i], self.mode[i] = self.time[p], self.mode[p]
                continue
            if rng.random() >= any_share:
                self.time[i] = "Late" if self.time[p] == "Late" or rng.random() < 0.25 else "Early"
            elif self.time[p] == "Late":
                self.time[i] = "Late"
            if rng.random() >= any_share:
                self.mode[i] = "Dynamic" if self.mode[p] == "Dynamic" or rng.random() < 0.2 else "Static"
            elif self.mode[p] == "Dynamic":
                self.mode[i] = "Dynamic"

    def _forced(self) -> list[bool]:
        """Per feature: a chain of mandatory sub-features from the root (every variant has it)."""
        forced = [True] + [False] * (self.n - 1)
        for i in range(1, self.n):  # (a parent before its children in every shape)
            forced[i] = forced[self.parent[i]] and self.mandatory[i] and not self.group[i]
        return forced

    def _staticable(self) -> list[bool]:
        """Per feature: it and its ancestors may all be Static (an included feature must be)."""
        ok = [True] * self.n
        for i in range(1, self.n):
            ok[i] = ok[self.parent[i]] and self.mode[i] != "Dynamic"
        return ok

    def random_tree(self, window: int = 100) -> None:
        """Each feature under one of the `window` before it, no deeper than MAX_CHAIN (at
        100,000 features a window of 30 nests 6,000 deep: more than a document may)."""
        rng = self.rng
        depth = [0] * self.n
        for i in range(1, self.n):
            p = max(0, i - 1 - rng.randrange(window))
            while depth[p] >= MAX_CHAIN:
                p = self.parent[p]
            self.parent[i], depth[i] = p, depth[p] + 1

    def group_some(self, share: float, sizes: tuple[int, int]) -> None:
        """About `share` of the parents get an OR or XOR group of some of their children."""
        children = self.children()
        rng = self.rng
        for kids in children:
            if len(kids) >= 2 and rng.random() < share:
                label = rng.choice(["OR", "XOR"])
                for c in kids[: rng.randint(sizes[0], min(sizes[1], len(kids)))]:
                    self.group[c] = label
        for kids in children:
            for c in kids:
                if not self.group[c]:
                    self.mandatory[c] = rng.random() < 0.2

    def children(self) -> list[list[int]]:
        kids: list[list[int]] = [[] for _ in range(self.n)]
        for i in range(1, self.n):
            kids[self.parent[i]].append(i)
        return kids

    def cross_tree(self, share: float) -> None:
        """Includes and excludes between random features, on about `share` of them: never
        from a feature every variant has (nor an exclude of one), and includes only of
        features that may be Static and bound no later, so the model keeps its variants."""
        rng, forced, staticable = self.rng, self._forced(), self._staticable()
        for _ in range(int(self.n * share / 2)):
            x, y = rng.randrange(1, self.n), rng.randrange(1, self.n)
            if x == y or forced[x]:
                continue
            if rng.random() < 0.5:
                if staticable[y] and (self.time[y] != "Late" or self.time[x] == "Late"):
                    self.includes[x].append(y)
            elif not forced[y]:
                self.excludes[x].append(y)

    def root_formulas(self, share: float) -> None:
        """Formulas over about `share` of the features, none of which every variant has:
        clauses of 2-4 literals with a negated one, and implications from a feature to a
        disjunction."""
        rng, forced = self.rng, self._forced()
        free = [i for i in range(1, self.n) if not forced[i]]
        used = 0
        while free and used < self.n * share:
            k = rng.randint(2, 4)
            ids = [f"f{rng.choice(free)}" for _ in range(k)]
            used += k
            if rng.random() < 0.5:
                self.formulas.append(" | ".join([f"!{ids[0]}", *(("!" if rng.random() < 0.3 else "") + x for x in ids[1:])]))
            else:
                self.formulas.append(f"{ids[0]} => ({' | '.join(ids[1:])})")

    def document(self) -> dict[str, Any]:
        nodes: list[dict[str, Any]] = []
        for i in range(self.n):
            node: dict[str, Any] = {
                "id": f"f{i}",
                "name": f"Feature {i}",
                "constraints": {
                    "featuresIncluded": [f"f{j}" for j in self.includes[i]],
                    "featuresExcluded": [f"f{j}" for j in self.excludes[i]],
                    "bindingTimeAllowed": self.time[i],
                    "bindingModeAllowed": self.mode[i],
                },
                "group": self.group[i],
                "isMandatory": self.mandatory[i] and not self.group[i],
                "sub": [],
            }
            nodes.append(node)
            if i:
                nodes[self.parent[i]]["sub"].append(node)
        root = nodes[0]
        root["isSelected"] = True
        if self.formulas:
            root["formulas"] = self.formulas
        return root


def _deep(s: _Shape) -> None:
    # chains of up to MAX_CHAIN features, each hanging from a random earlier feature
    rng, i = s.rng, 1
    depth = [0] * s.n
    while i < s.n:
        length = min(s.n - i, rng.randint(MAX_CHAIN // 2, MAX_CHAIN))
        start = rng.randrange(0, i)
        while depth[start] + length > MAX_CHAIN:  # (the document's nesting stays allowed)
            start = s.parent[start]
        if i > 1 and rng.random() < 0.5:  # a side branch of a few features
            length = min(length, rng.randint(1, 20))
        for k in range(length):
            s.parent[i + k] = start if k == 0 else i + k - 1
            s.mandatory[i + k] = rng.random() < 0.1
            depth[i + k] = depth[s.parent[i + k]] + 1
        i += length
    s.bindings(0.5)
    s.cross_tree(0.02)


def _flat(s: _Shape) -> None:
    s.parent[1:] = [0] * (s.n - 1)
    s.bindings(0.5)


def _groups(s: _Shape) -> None:
    s.random_tree(window=30)
    s.group_some(0.5, (2, 5))
    s.bindings(2 / 3)
    s.cross_tree(0.05)


def _wide(s: _Shape) -> None:
    # each group under a parent of its own (the members of one label under one parent are
    # one group), the parent optional or mandatory
    rng = s.rng
    i = 1
    while i < s.n:
        size = min(s.n - i - 1, rng.randint(1000, 10_000))
        s.parent[i], s.mandatory[i] = 0, rng.random() < 0.5
        label = "XOR" if rng.random() < 0.7 else "OR"
        for k in range(i + 1, i + 1 + size):
            s.parent[k], s.group[k] = i, label
        i += size + 1
    s.bindings(0.5)


def _random(
    groups: float, sizes: tuple[int, int], any_share: float, cross: float, formulas: float
) -> Callable[[_Shape], None]:
    """A random tree (generate.py's shape) with `groups` of its parents grouped, bindings
    `Any` with probability `any_share`, and `cross` and `formulas` of its features in
    includes and excludes, and in formulas."""

    def build(s: _Shape) -> None:
        s.random_tree()
        s.group_some(groups, sizes)
        s.bindings(any_share)
        if cross:
            s.cross_tree(cross)
        if formulas:
            s.root_formulas(formulas)

    return build


_dense = _random(0.2, (2, 5), 0.5, 0.2, 0.05)
_formulas = _random(0.1, (2, 4), 0.5, 0.0, 0.25)
_any = _random(0.2, (2, 5), 0.95, 0.1, 0.0)
_fixed = _random(0.2, (2, 5), 0.05, 0.1, 0.0)


_BUILDERS: dict[str, Callable[[_Shape], None]] = {
    "deep": _deep,
    "flat": _flat,
    "groups": _groups,
    "wide": _wide,
    "dense": _dense,
    "formulas": _formulas,
    "any": _any,
    "fixed": _fixed,
}


def family(name: str, n: int, seed: int = 0) -> dict[str, Any]:
    """A model of the family `name` with `n` features (at least 2)."""
    if name not in _BUILDERS:
        raise ValueError(f"unknown family {name!r}: one of {', '.join(FAMILIES)}")
    shape = _Shape(max(2, n), random.Random(f"{name}/{n}/{seed}"))
    _BUILDERS[name](shape)
    return shape.document()


def tiny(name: str, n: int, seed: int = 0) -> dict[str, Any]:
    """The family's shape at a size brute force enumerates: chains of a few features, groups
    of up to n - 1 members."""
    global MAX_CHAIN
    saved = MAX_CHAIN
    MAX_CHAIN = 4
    try:
        shape = _Shape(max(2, n), random.Random(f"tiny/{name}/{n}/{seed}"))
        if name == "wide":  # a group of most of the features under the root's first child
            for i in range(2, shape.n):
                shape.parent[i], shape.group[i] = 1, "XOR" if seed % 3 else "OR"
            shape.bindings(0.5)
        else:
            _BUILDERS[name](shape)
        return shape.document()
    finally:
        MAX_CHAIN = saved


def write(name: str, n: int, seed: int, out: str) -> str:
    model = family(name, n, seed)
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "model.json")
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 4 * MAX_CHAIN + 2000))  # json.dumps recurses
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(json.dumps(model))
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("family", choices=FAMILIES)
    parser.add_argument("n", type=int)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("-o", "--out", required=True)
    args = parser.parse_args()
    print(f"wrote {write(args.family, args.n, args.seed, args.out)}")


if __name__ == "__main__":
    main()

"""A plain AETG-style greedy for 2-wise samples: the baseline that sample_bench.py holds
motivml's `sample --t 2` to (issue 33). It shares no code with motivml's sampler: it reads
the model's CNF as `motivml export dimacs` writes it (the `c <variable> <feature>` lines name
the features' variables) and asks pysat's solver directly.

The algorithm is the one of AETG (Cohen, Dalal, Fredman, Patton, 1997) with the constraints
handled by a SAT solver, as CASA's and ICPL's greedy stages do:

* a pair is two literals of two features; one that no valid variant has is found once, by
  the propagation of each literal (most) or a solve of the two (the rest, when the greedy
  stalls on them);
* each new variant is the best of CANDIDATES made as follows: the literal of the most
  uncovered pairs first, then the features in a random order, each given the value that
  covers the most uncovered pairs with the values given so far, if a valid variant has it
  with them (the solver's last variant is kept as a witness, so a value it already has
  needs no solve);
* until every pair a valid variant has is covered.

    python bench/greedy.py MODEL.dimacs [--seed 1] [--candidates 10] [--runs 1] [--timeout 300]
"""

from __future__ import annotations

import argparse
import random
import sys
import time
from pathlib import Path
from typing import Any


def read_dimacs(path: Path) -> tuple[int, list[list[int]], list[int]]:
    """The variables, clauses and the features' variables (from the `c <var> <name>` lines)."""
    clauses: list[list[int]] = []
    features: list[int] = []
    top = 0
    for line in path.read_text().splitlines():
        if line.startswith("c "):
            parts = line.split()
            if len(parts) >= 3 and parts[1].isdigit():
                features.append(int(parts[1]))
        elif line.startswith("p "):
            top = int(line.split()[2])
        elif line.strip():
            literals = [int(x) for x in line.split()]
            clauses.append([x for x in literals if x != 0])
    return top, clauses, features


class Greedy:
    def __init__(self, clauses: list[list[int]], features: list[int], seed: int, deadline: float) -> None:
        import numpy as np
        from pysat.solvers import Glucose4

        self.np, self.rng, self.deadline = np, random.Random(seed), deadline
        self.solver = Glucose4(bootstrap_with=clauses)
        self.features = features
        n = len(features)
        self.n = n
        # literal index: 2k for feature k selected, 2k + 1 for not selected
        self.uncovered = np.ones((2 * n, 2 * n), dtype=bool)
        for k in range(n):  # (no pair of one feature's two literals, nor of a literal with itself)
            self.uncovered[2 * k : 2 * k + 2, 2 * k : 2 * k + 2] = False
        self.solves = 0
        self._drop_impossible_by_propagation()

    def literal(self, index: int) -> int:
        v = self.features[index // 2]
        return v if index % 2 == 0 else -v

    def index_of(self, literal: int, at: dict[int, int]) -> int:
        return 2 * at[abs(literal)] + (0 if literal > 0 else 1)

    def _drop_impossible_by_propagation(self) -> None:
        """A pair (a, b) where propagating a forces not-b (or a alone fails) has no variant."""
        at = {v: k for k, v in enumerate(self.features)}
        unc = self.uncovered
        for i in range(2 * self.n):
            ok, forced = self.solver.propagate(assumptions=[self.literal(i)])
            if not ok:
                unc[i, :] = False
                unc[:, i] = False
                continue
            for lit in forced:
                if abs(lit) in at:
                    j = self.index_of(-lit, at)  # the opposite of a forced value
                    unc[i, j] = unc[j, i] = False

    def solve(self, assumptions: list[int]) -> bool:
        self.solves += 1
        return bool(self.solver.solve(assumptions=assumptions))

    def witness(self) -> dict[int, bool]:
        model = self.solver.get_model() or []
        return {abs(x): x > 0 for x in model}

    def candidate(self) -> list[int]:
        """One variant, as literal indices (one per feature), built greedily."""
        np, unc, n = self.np, self.uncovered, self.n
        counts = unc.sum(axis=1)
        first = int(np.argmax(counts)) if counts.any() else 0
        while not self.solve([self.literal(first)]):  # (a value no variant has: none of its pairs)
            unc[first, :] = False
            unc[:, first] = False
            if not unc.any():
                return []
            counts = unc.sum(axis=1)
            first = int(np.argmax(counts))
        chosen = [first]
        assumptions = [self.literal(first)]
        seen = self.witness()
        order = [k for k in range(n) if k != first // 2]
        self.rng.shuffle(order)
        rows = np.asarray(chosen)
        for k in order:
            gains = unc[2 * k : 2 * k + 2, rows].sum(axis=1)
            prefer = 0 if gains[0] > gains[1] else 1 if gains[1] > gains[0] else self.rng.randrange(2)
            for i in (2 * k + prefer, 2 * k + 1 - prefer):
                literal = self.literal(i)
                if seen.get(abs(literal), False) == (literal > 0) or self.solve([*assumptions, literal]):
                    if seen.get(abs(literal), False) != (literal > 0):
                        seen = self.witness()
                    chosen.append(i)
                    assumptions.append(literal)
                    break
            rows = np.asarray(chosen)
        return chosen

    def gain(self, chosen: list[int]) -> int:
        rows = self.np.asarray(chosen)
        return int(self.uncovered[self.np.ix_(rows, rows)].sum()) // 2

    def cover(self, chosen: list[int]) -> None:
        rows = self.np.asarray(chosen)
        self.uncovered[self.np.ix_(rows, rows)] = False

    def stalled(self) -> list[int] | None:
        """When no candidate covers a new pair: the next uncovered pair that a valid variant
        has, as the first two choices of a variant built around it (None: none is left)."""
        np, unc = self.np, self.uncovered
        for i, j in zip(*np.nonzero(np.triu(unc)), strict=True):
            if self.solve([self.literal(int(i)), self.literal(int(j))]):
                return [int(i), int(j)]
            unc[i, j] = unc[j, i] = False
        return None

    def around(self, pair: list[int]) -> list[int]:
        """A variant with the pair's two literals, the rest as the witness has them."""
        seen = self.witness()
        at = {v: k for k, v in enumerate(self.features)}
        return [self.index_of(v if seen.get(v, False) else -v, at) for v in self.features]

    def run(self, candidates: int) -> list[list[int]] | None:
        sample: list[list[int]] = []
        while self.uncovered.any():
            if time.monotonic() > self.deadline:
                return None
            best, best_gain = None, 0
            for _ in range(candidates):
                chosen = self.candidate()
                if not chosen:
                    break
                g = self.gain(chosen)
                if g > best_gain:
                    best, best_gain = chosen, g
            if best is None:
                pair = self.stalled()
                if pair is None:
                    break
                best = self.around(pair)
            self.cover(best)
            sample.append([self.literal(i) for i in best])
        return sample


def all_valid(clauses: list[list[int]], sample: list[list[int]]) -> bool:
    """Each variant of the sample valid: a solve under its literals."""
    from pysat.solvers import Glucose4

    with Glucose4(bootstrap_with=clauses) as solver:
        return all(solver.solve(assumptions=variant) for variant in sample)


def covered_pairs(sample: list[list[int]]) -> set[tuple[int, int]]:
    """The pairs of literals of two features that the sample's variants have (quadratic in
    the features: for small models)."""
    pairs: set[tuple[int, int]] = set()
    for variant in sample:
        ordered = sorted(variant, key=abs)
        for a in range(len(ordered)):
            for b in range(a + 1, len(ordered)):
                pairs.add((ordered[a], ordered[b]))
    return pairs


def baseline(
    dimacs: Path, seed: int = 1, candidates: int = 10, timeout: float = 300.0, runs: int = 1
) -> dict[str, Any]:
    """The smallest sample of `runs` runs of the greedy on a DIMACS file (run k seeded with
    seed + k), all within `timeout` seconds: its size, the time, the solves; size None if
    no run ended in time."""
    _, clauses, features = read_dimacs(dimacs)
    began = time.monotonic()
    best: list[list[int]] | None = None
    solves = 0
    for k in range(runs):
        greedy = Greedy(clauses, features, seed + k, began + timeout)
        sample = greedy.run(candidates)
        solves += greedy.solves
        if sample is not None and (best is None or len(sample) < len(best)):
            best = sample
        if sample is None:
            break
    took = time.monotonic() - began
    return {"size": None if best is None else len(best), "seconds": took, "solves": solves, "sample": best}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dimacs", type=Path)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--candidates", type=int, default=10)
    parser.add_argument("--timeout", type=float, default=300.0)
    parser.add_argument("--runs", type=int, default=1, help="runs seeded apart; the smallest sample is kept")
    args = parser.parse_args()
    found = baseline(args.dimacs, args.seed, args.candidates, args.timeout, args.runs)
    if found["size"] is None:
        print(f"not finished in {args.timeout:g} s")
        sys.exit(1)
    _, clauses, _ = read_dimacs(args.dimacs)
    valid = all_valid(clauses, found["sample"])
    print(f"{found['size']} variants in {found['seconds']:.1f} s ({found['solves']} solves), all valid: {valid}")


if __name__ == "__main__":
    main()

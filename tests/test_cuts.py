"""`binding.cuts.valid_cuts` against evaluating every cut's assignment clause by clause.

The reference here drops each subtree from the variant by hand (walking the tree from the
document's parents, not the product's intervals) and checks every clause of the hard
build; a cut is valid exactly when all hold.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from helpers import model_of as read
from hypothesis import HealthCheck, given, settings
from test_property_sat import models

from motivml.binding import encoding as enc
from motivml.binding.cuts import valid_cuts
from motivml.language.model import FeatureModel

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))
from generate import generate  # noqa: E402


def descendants_or_self(model: FeatureModel, c: int) -> set[int]:
    children: dict[int, list[int]] = {}
    for f in model.features:
        if f.parent is not None:
            children.setdefault(f.parent, []).append(f.index)
    found, stack = set(), [c]
    while stack:
        node = stack.pop()
        found.add(node)
        stack.extend(children.get(node, []))
    return found


def by_hand(model: FeatureModel, clauses: list[list[int]], values: list[int]) -> list[bool]:
    valid = []
    for c in range(len(model.features)):
        if c == 0 or values[4 * c] < 0:
            valid.append(False)
            continue
        cut = list(values)
        for f in descendants_or_self(model, c):
            for v in (4 * f + 1, 4 * f + 4):  # s(f) and a(f) false
                cut[v - 1] = -v
        valid.append(all(any((cut[abs(lit) - 1] > 0) == (lit > 0) for lit in clause) for clause in clauses))
    return valid


def check(model: FeatureModel, phases: str) -> int:
    with enc.Encoding(model, record=True) as hard:
        n = len(model.features)
        sign = {"all": 1, "none": -1}
        hard.solver.set_phases([sign.get(phases, 1 if i % 2 else -1) * hard.s(i) for i in range(n)])
        if not hard.solve(with_config=False):
            return 0
        values = hard.assignment()
        assert hard.recorded is not None
        found = valid_cuts(model, hard.recorded, values).tolist()
        assert found == by_hand(model, hard.recorded, values)
        return sum(found)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=10))
def test_valid_cuts_are_exactly_the_cuts_that_keep_every_clause(raw: dict[str, Any]) -> None:
    model = read(raw)
    for phases in ("all", "none", "alternate"):
        check(model, phases)


def test_valid_cuts_on_generated_deep_models() -> None:
    found = 0
    for seed in range(4):
        raw, _ = generate(150, seed)
        found += check(read(raw), "all")
    assert found > 0  # (the generated models have optional subtrees to drop)

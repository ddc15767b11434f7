"""Property: the SAT encoding agrees with brute-force enumeration of the spec.

`reference_semantics.py` was written separately, straight from semantics.md, as a
backtracking enumeration of sections 2-4; here both judge random models of up to 12
features and random (partial) configurations.
"""

from __future__ import annotations

import json
from typing import Any

import reference_semantics as ref
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from semantic_helpers import variant_errors

from motivml.binding.check import analyse_model
from motivml.documents.loader import parse
from motivml.language.reader import read_model


@st.composite
def models(draw: st.DrawFn, max_features: int = 12) -> dict[str, Any]:
    n = draw(st.integers(2, max_features))
    ids = [f"f{i}" for i in range(n)]
    nodes: list[dict[str, Any]] = []
    for i in range(n):
        node: dict[str, Any] = {"id": ids[i], "name": ids[i].upper()}
        if i:
            node["group"] = draw(st.sampled_from(["", "", "OR", "XOR"]))
            node["isMandatory"] = draw(st.booleans())
            others = [x for x in ids[1:] if x != ids[i]]
            constraints = {
                "bindingTimeAllowed": draw(st.sampled_from(["Early", "Late", "Any", "Any"])),
                "bindingModeAllowed": draw(st.sampled_from(["Static", "Dynamic", "Any", "Any"])),
                "featuresIncluded": draw(st.lists(st.sampled_from(others), max_size=1, unique=True))
                if others
                else [],
                "featuresExcluded": draw(st.lists(st.sampled_from(others), max_size=1, unique=True))
                if others
                else [],
            }
            node["constraints"] = constraints
            parent = draw(st.integers(0, i - 1))
            nodes[parent].setdefault("sub", []).append(node)
        nodes.append(node)
    return nodes[0]


@st.composite
def configurations(draw: st.DrawFn, model: dict[str, Any]) -> dict[str, Any]:
    properties = []
    stack = list(model.get("sub", []))
    while stack:
        node = stack.pop()
        stack.extend(node.get("sub", []))
        choice = draw(st.sampled_from(["absent", "off", "on", "on", "on"]))
        if choice == "absent":
            continue
        if choice == "off":
            properties.append({"id": node["id"], "selected": False})
            continue
        props = {
            "time": draw(st.sampled_from(["Early", "Late", "Any"])),
            "mode": draw(st.sampled_from(["Static", "Dynamic", "Any"])),
        }
        properties.append({"id": node["id"], "props": props})
    return {"properties": properties}


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_sat_verdict_equals_brute_force(data: st.DataObject) -> None:
    model = data.draw(models())
    config = data.draw(configurations(model))
    expected = ref.is_valid(model, config)
    errors = variant_errors(model, config)
    assert (errors == []) == expected, (json.dumps(model), json.dumps(config), [e.message for e in errors])


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=9))
def test_dead_features_equal_brute_force(model: dict[str, Any]) -> None:
    feature_model, _ = read_model(parse(json.dumps(model), "model.json"))
    diagnostics = analyse_model(feature_model)
    if not ref.is_valid(model, None):
        assert diagnostics and all(
            d.message.startswith("the model has no valid variant: ") for d in diagnostics
        )
        return
    dead = {
        f.id
        for f in feature_model.features
        if not ref.is_valid(model, {"properties": [{"id": f.id}]} if f.parent is not None else None)
    }
    reported = {d.feature for d in diagnostics if d.rule == "model.dead-feature"}
    # only the topmost dead feature of a dead subtree is reported
    topmost = {
        f
        for f in dead
        if feature_model[f].parent is None or feature_model.features[feature_model[f].parent].id not in dead
    }
    assert reported == topmost


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_reported_conflicts_are_disjoint_minimal_unsatisfiable_sets(data: st.DataObject) -> None:
    from motivml.binding.encoding import Encoding
    from motivml.language.reader import read_configuration

    model = data.draw(models())
    config = data.draw(configurations(model))
    feature_model, _ = read_model(parse(json.dumps(model), "model.json"))
    configuration, _ = read_configuration(parse(json.dumps(config), "c.json"), feature_model, partial=True)
    with Encoding(feature_model, explain=True) as encoding:
        encoding.set_configuration(configuration)
        conflicts = encoding.conflicts()
        assert (conflicts == []) == ref.is_valid(model, config)
        seen: set[int] = set()
        for mus in conflicts:
            literals = [encoding.literals[k] for k in mus]
            assert not encoding.solver.solve(assumptions=literals)
            for drop in range(len(literals)):
                assert encoding.solver.solve(assumptions=literals[:drop] + literals[drop + 1 :])
            assert not seen & set(mus)
            seen |= set(mus)
        assert [len(m) for m in conflicts] == sorted(len(m) for m in conflicts)

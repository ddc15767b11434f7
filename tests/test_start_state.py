"""The start state of reference.md section 4 equals the brute-force reference's.

The expected active set comes from tests/reference_semantics.py alone (every active set
the rules allow, then the spec's order: fewest Late activations, then pre-order); the
product's parsed model is not used to decide it.
"""

from __future__ import annotations

import json
from dataclasses import replace
from typing import Any

import reference_semantics as ref
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_property_sat import configurations, models

from motivml.binding.resolve import NoVariant, Variant, resolve, start_state
from motivml.documents.loader import parse
from motivml.language.reader import read_configuration, read_model


def selection_of(variant: Variant) -> dict[str, tuple[bool, bool]]:
    return {d.feature.id: (d.binding.early, d.binding.static) for d in variant.selected()}


def complete(raw: dict[str, Any], variant: dict[str, tuple[bool, bool]]) -> dict[str, Any]:
    """A complete configuration that says exactly `variant` (the root needs no entry)."""
    properties = []
    stack = list(reversed(raw.get("sub", [])))
    while stack:
        node = stack.pop()
        stack.extend(reversed(node.get("sub", [])))
        binding = variant.get(node["id"])
        if binding is None:
            properties.append({"id": node["id"], "selected": False})
        else:
            early, static = binding
            props = {"time": "Early" if early else "Late", "mode": "Static" if static else "Dynamic"}
            properties.append({"id": node["id"], "props": props})
    return {"properties": properties}


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_start_state_of_resolved_variants_equals_the_reference(data: st.DataObject) -> None:
    raw = data.draw(models(max_features=9))
    config = data.draw(configurations(raw))
    prefer = data.draw(st.sampled_from([(), ("late",), ("late", "dynamic")]))
    model, _ = read_model(parse(json.dumps(raw), "model.json"))
    configuration, problems = read_configuration(parse(json.dumps(config), "v.json"), model, partial=True)
    assert not [p for p in problems if p.severity.value == "error"]
    try:
        variant = resolve(model, configuration, prefer)
    except NoVariant:
        assert not ref.is_valid(raw, config)
        return
    expected = ref.preferred_start_state(raw, selection_of(variant))
    assert expected is not None, "a resolved variant has a start state (section 4)"
    assert [f.id for f in start_state(variant)] == expected


@st.composite
def start_models(draw: st.DrawFn, max_features: int = 7) -> dict[str, Any]:
    """Small models where the start state has work to do: many groups (an active parent
    needs an active member, which may be Late), few mandatory features and few features
    that must be Static or Early (so that the model is seldom void)."""
    n = draw(st.integers(3, max_features))
    ids = [f"f{i}" for i in range(n)]
    nodes: list[dict[str, Any]] = []
    for i in range(n):
        node: dict[str, Any] = {"id": ids[i], "name": ids[i].upper()}
        if i:
            others = [x for x in ids[1:] if x != ids[i]]
            node["group"] = draw(st.sampled_from(["OR", "XOR", "XOR", ""]))
            node["isMandatory"] = draw(st.sampled_from([True, False, False]))
            node["constraints"] = {
                "bindingTimeAllowed": draw(st.sampled_from(["Late", "Any", "Any", "Any"])),
                "bindingModeAllowed": draw(st.sampled_from(["Dynamic", "Any", "Any"])),
                # about one feature in four includes (excludes) another
                "featuresIncluded": [
                    x for x in [draw(st.sampled_from([""] * 3 * len(others) + others))] if x
                ],
                "featuresExcluded": [
                    x for x in [draw(st.sampled_from([""] * 3 * len(others) + others))] if x
                ],
            }
            nodes[draw(st.integers(0, i - 1))].setdefault("sub", []).append(node)
        nodes.append(node)
    return nodes[0]


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_start_state_of_any_valid_variant_equals_the_reference(data: st.DataObject) -> None:
    """Any variant the reference finds, not only those resolve prefers (mostly Early, so
    that their start state is trivial): Late group members an active parent needs, and
    several start states to choose from."""
    raw = data.draw(start_models())
    variants = list(ref.valid_variants(raw, None))
    if not variants:
        return
    chosen = variants[data.draw(st.integers(0, len(variants) - 1))]
    model, _ = read_model(parse(json.dumps(raw), "model.json"))
    configuration, problems = read_configuration(parse(json.dumps(complete(raw, chosen)), "v.json"), model)
    assert not [p for p in problems if p.severity.value == "error"]
    variant = resolve(model, configuration)
    assert selection_of(variant) == chosen  # a complete configuration is kept as it is
    expected = ref.preferred_start_state(raw, chosen)
    assert [f.id for f in start_state(variant)] == expected  # found by resolve, on its encoding
    fresh = replace(variant, active_at_start=None)
    assert [f.id for f in start_state(fresh)] == expected  # found on an encoding of its own


def test_the_first_xor_alternative_in_definition_order_starts() -> None:
    """An active Early parent needs one of its Late XOR members: the first one starts."""
    raw: dict[str, Any] = {
        "id": "bot",
        "name": "Bot",
        "sub": [
            {
                "id": "slam",
                "name": "SLAM",
                "isMandatory": False,
                "constraints": {"bindingTimeAllowed": "Early", "bindingModeAllowed": "Dynamic"},
                "sub": [
                    {
                        "id": name,
                        "name": name,
                        "group": "XOR",
                        "constraints": {"bindingTimeAllowed": "Late", "bindingModeAllowed": "Dynamic"},
                    }
                    for name in ("hector", "karto", "orb")
                ],
            }
        ],
    }
    model, _ = read_model(parse(json.dumps(raw), "model.json"))
    config = {
        "properties": [
            {"id": f, "props": {"time": "Early" if f == "slam" else "Late", "mode": "Dynamic"}}
            for f in ("slam", "hector", "karto", "orb")
        ]
    }
    configuration, _ = read_configuration(parse(json.dumps(config), "v.json"), model)
    active = [f.id for f in start_state(resolve(model, configuration))]
    assert active == ["bot", "slam", "hector"]


def test_fewest_late_activations_come_before_definition_order() -> None:
    """The root needs d or a (OR group). d comes first but pulls in e and f; a pulls in
    only b: two Late activations beat three."""

    def late(fid: str, group: str = "", includes: tuple[str, ...] = ()) -> dict[str, Any]:
        constraints = {"bindingTimeAllowed": "Late", "featuresIncluded": list(includes)}
        return {"id": fid, "name": fid, "group": group, "isMandatory": False, "constraints": constraints}

    raw: dict[str, Any] = {
        "id": "bot",
        "name": "Bot",
        "sub": [late("d", "OR", ("e", "f")), late("a", "OR", ("b",)), late("e"), late("f"), late("b")],
    }
    model, _ = read_model(parse(json.dumps(raw), "model.json"))
    chosen = {"bot": ref.SE, **{f: ref.SL for f in ("d", "a", "e", "f", "b")}}
    configuration, _ = read_configuration(parse(json.dumps(complete(raw, chosen)), "v.json"), model)
    expected = ref.preferred_start_state(raw, chosen)
    assert expected == ["bot", "a", "b"]
    assert [f.id for f in start_state(resolve(model, configuration))] == expected

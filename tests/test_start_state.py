"""The start state of semantics.md section 4 equals a brute-force reading of it."""

from __future__ import annotations

import itertools
import json
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motivml.binding.resolve import NoVariant, resolve, start_state
from motivml.documents.loader import parse
from motivml.language.model import FeatureModel
from motivml.language.reader import read_configuration, read_model
from tests.test_property_sat import configurations, models


def satisfies_section_2(model: FeatureModel, active: set[int]) -> bool:
    if 0 not in active:
        return False
    for f in model.features:
        if f.parent is not None and f.index in active and f.parent not in active:
            return False
        if f.parent is not None and f.mandatory and f.parent in active and f.index not in active:
            return False
        for target in f.includes:
            if f.index in active and model.index.get(target, f.index) not in active:
                return False
        for target in f.excludes:
            other = model.index.get(target, f.index)
            if other != f.index and {f.index, other} <= active:
                return False
    for group in model.groups:
        if group.parent in active:
            count = sum(1 for m in group.members if m in active)
            if count == 0 or (group.kind == "XOR" and count > 1):
                return False
    return True


def brute_force(model: FeatureModel, early: set[int], late: list[int]) -> set[int] | None:
    """Fewest Late activations, then the earliest features in definition order first."""
    best: tuple[int, tuple[bool, ...]] | None = None
    chosen = None
    for bits in itertools.product([False, True], repeat=len(late)):
        active = early | {i for i, on in zip(late, bits, strict=True) if on}
        if not satisfies_section_2(model, active):
            continue
        key = (-sum(bits), bits)  # larger is better: fewer Late, then earlier ones on
        if best is None or key > best:
            best, chosen = key, active
    return chosen


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_start_state_equals_brute_force(data: st.DataObject) -> None:
    raw = data.draw(models(max_features=9))
    config = data.draw(configurations(raw))
    prefer = data.draw(st.sampled_from([(), ("late",), ("late", "dynamic")]))
    model, _ = read_model(parse(json.dumps(raw), "model.json"))
    configuration, problems = read_configuration(parse(json.dumps(config), "v.json"), model, partial=True)
    assert not [p for p in problems if p.severity.value == "error"]
    try:
        variant = resolve(model, configuration, prefer)
    except NoVariant:
        return
    selected = variant.selected()
    early = {d.feature.index for d in selected if d.binding.early}
    late = [d.feature.index for d in selected if not d.binding.early]
    expected = brute_force(model, early, late)
    assert expected is not None, "a resolved variant has a start state (section 4)"
    assert {f.index for f in start_state(variant)} == expected


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

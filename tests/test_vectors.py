"""The test vectors of reference.md section 5, one test each, through the SAT encoding."""

from __future__ import annotations

import itertools
from typing import Any

import pytest
from semantic_helpers import variant_errors

BINDINGS = {
    "SE": ("Early", "Static"),
    "SL": ("Late", "Static"),
    "DE": ("Early", "Dynamic"),
    "DL": ("Late", "Dynamic"),
}
ALL = list(BINDINGS)


def any_feature(fid: str, **extra: Any) -> dict[str, Any]:
    node: dict[str, Any] = {
        "id": fid,
        "name": fid.upper(),
        "isMandatory": False,
        "constraints": {"bindingTimeAllowed": "Any", "bindingModeAllowed": "Any"},
    }
    constraints = extra.pop("constraints", {})
    node["constraints"].update(constraints)
    node.update(extra)
    return node


def both_selected(first: str, second: str) -> dict[str, Any]:
    (t1, m1), (t2, m2) = BINDINGS[first], BINDINGS[second]
    return {
        "properties": [
            {"id": "a", "props": {"time": t1, "mode": m1}},
            {"id": "b", "props": {"time": t2, "mode": m2}},
        ]
    }


def model_for(relation: str) -> dict[str, Any]:
    root: dict[str, Any] = {"id": "root", "name": "Root"}
    if relation == "includes":
        root["sub"] = [any_feature("a", constraints={"featuresIncluded": ["b"]}), any_feature("b")]
    elif relation == "optional child":
        root["sub"] = [any_feature("a", sub=[any_feature("b")])]
    elif relation == "mandatory child":
        root["sub"] = [any_feature("a", sub=[any_feature("b", isMandatory=True)])]
    elif relation == "excludes":
        root["sub"] = [any_feature("a", constraints={"featuresExcluded": ["b"]}), any_feature("b")]
    elif relation == "xor":
        root["sub"] = [
            any_feature(
                "g", isMandatory=True, sub=[any_feature("a", group="XOR"), any_feature("b", group="XOR")]
            )
        ]
    return root


VALID = {
    # X requires Y (the 4x4 table): rows X, columns Y
    "includes": {("SE", "SE"), ("SL", "SE"), ("SL", "SL"), ("DE", "SE"), ("DL", "SE"), ("DL", "SL")},
    "optional child": {("SE", y) for y in ALL}
    | {("SL", "SL"), ("SL", "DL"), ("DE", "DE"), ("DE", "DL"), ("DL", "DL")},
    "mandatory child": {("SE", "SE"), ("SL", "SL"), ("DE", "DE"), ("DL", "DL")},
    "excludes": {("DE", "DL"), ("DL", "DE"), ("DL", "DL")},
    "xor": {("DE", "DL"), ("DL", "DE"), ("DL", "DL")},
}

CASES = [
    (relation, first, second, (first, second) in VALID[relation])
    for relation in VALID
    for first, second in itertools.product(ALL, ALL)
]


@pytest.mark.parametrize(
    ("relation", "first", "second", "valid"), CASES, ids=[f"{r}:{a}->{b}" for r, a, b, _ in CASES]
)
def test_section_5_vector(relation: str, first: str, second: str, valid: bool) -> None:
    config = both_selected(first, second)
    if relation == "xor":
        config["properties"].insert(0, {"id": "g", "props": {"time": "Early", "mode": "Static"}})
    errors = variant_errors(model_for(relation), config)
    assert (errors == []) is valid, [e.message for e in errors]

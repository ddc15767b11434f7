"""Schema checks: every kind of syntax error, located and phrased word for word."""

from __future__ import annotations

import json

import pytest
from jsonschema import Draft202012Validator

from motivml.documents.loader import parse
from motivml.documents.schema import (
    CONFIGURATION,
    FEATURE_MODEL,
    check_configuration,
    check_feature_model,
    load_schema,
)


def model_errors(text: str) -> list[str]:
    return [
        f"{d.location}: {d.location.path}: {d.message}" for d in check_feature_model(parse(text, "m.json"))
    ]


def config_errors(text: str) -> list[str]:
    return [
        f"{d.location}: {d.location.path}: {d.message}" for d in check_configuration(parse(text, "c.json"))
    ]


def test_schemas_are_valid_draft_2020_12_with_ids() -> None:
    for name in (FEATURE_MODEL, CONFIGURATION):
        schema = load_schema(name)
        Draft202012Validator.check_schema(schema)
        assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
        assert schema["$id"].startswith("urn:motivml:schema:")


def test_published_schema_accepts_what_the_shallow_check_accepts() -> None:
    model = {
        "$schema": "../../schemas/feature-model.schema.json",
        "id": "r",
        "name": "R",
        "x-note": {"any": ["thing"]},
        "sub": [{"id": "a", "name": "A", "group": "", "constraints": {"bindingTimeAllowed": "Any"}}],
    }
    assert not list(Draft202012Validator(load_schema(FEATURE_MODEL)).iter_errors(model))
    assert model_errors(json.dumps(model)) == []


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            '{"id": "r", "name": "R",\n "isMandtory": true}',
            "m.json:2:2: $.isMandtory: unknown key 'isMandtory' (did you mean 'isMandatory'?); known keys are "
            "$schema, abstract, constraints, formulas, group, id, isMandatory, isSelected, name, sub (keys starting with x- are free "
            "for tools)",
        ),
        (
            '{"id": "r", "name": "R", "sub": [{"id": "a", "name": "A", "group": "xor"}]}',
            "m.json:1:68: $.sub[0].group: 'xor' is not one of \"\", 'OR', 'XOR' (did you mean 'XOR'?)",
        ),
        (
            '{"id": "r", "name": "R", "sub": [{"id": "a", "name": "A",\n'
            ' "constraints": {"bindingTimeAllowed": "early"}}]}',
            "m.json:2:40: $.sub[0].constraints.bindingTimeAllowed: 'early' is not one of 'Early', 'Late', 'Any' "
            "(did you mean 'Early'?)",
        ),
        (
            '{"id": "r", "name": "R", "constraints": {"bindingModeAllowed": "Dynamc"}}',
            "m.json:1:64: $.constraints.bindingModeAllowed: 'Dynamc' is not one of 'Static', 'Dynamic', 'Any' "
            "(did you mean 'Dynamic'?)",
        ),
        (
            '{"id": "3d", "name": "R"}',
            "m.json:1:8: $.id: '3d' is not a valid id: use letters, digits and _, not starting with a digit",
        ),
        ('{"id": "r", "name": ""}', "m.json:1:21: $.name: must not be empty"),
        ('{"id": "r"}', "m.json:1:1: $: missing required key 'name'"),
        (
            '{"id": "r", "name": "R", "isMandatory": "yes"}',
            "m.json:1:41: $.isMandatory: expected true or false, found the string 'yes'",
        ),
        (
            '{"id": "r", "name": "R", "sub": [5]}',
            "m.json:1:34: $.sub[0]: expected an object, found the number 5",
        ),
        ('{"id": "r", "name": "R", "sub": {}}', "m.json:1:33: $.sub: expected an array, found an object"),
        (
            '{"id": "r", "name": "R", "sub": [{"id": "a", "name": "A", "$schema": "x"}]}',
            "m.json:1:59: $.sub[0].$schema: unknown key '$schema'; known keys are abstract, constraints, group, id, "
            "isMandatory, isSelected, name, sub (keys starting with x- are free for tools)",
        ),
        ("[1, 2]", "m.json:1:1: $: a feature model is one JSON object (the root feature), found an array"),
    ],
)
def test_feature_model_errors(text: str, expected: str) -> None:
    assert model_errors(text) == [expected]


def test_all_errors_at_once_in_document_order() -> None:
    text = '{"id": "r", "name": "", "sub": [{"id": "a", "name": "A", "group": "or", "x-ok": 1}, {"id": "b"}]}'
    assert [e.split(": ")[1] for e in model_errors(text)] == ["$.name", "$.sub[0].group", "$.sub[1]"]


def test_deep_value_in_a_wrong_place_is_reported_not_crashing() -> None:
    text = '{"id": "r", "name": ' + "[" * 3000 + "]" * 3000 + "}"
    assert model_errors(text) == [
        "m.json:1:1: $: holds a value nested too deeply for its place (only `sub` nests features)"
    ]


def test_deep_model_is_checked_iteratively() -> None:
    text = '{"id": "leaf", "name": "Leaf", "group": "bad"}'
    for i in range(2000):
        text = f'{{"id": "f{i}", "name": "F", "sub": [{text}]}}'
    errors = model_errors(text)
    assert len(errors) == 1 and errors[0].endswith(".group: 'bad' is not one of \"\", 'OR', 'XOR'")


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            '{"properties": [{"id": "a", "props": {"time": "late"}}]}',
            "c.json:1:47: $.properties[0].props.time: 'late' is not one of 'Early', 'Late', 'Any' "
            "(did you mean 'Late'?)",
        ),
        (
            '{"properties": [{"id": "a", "selectd": false}]}',
            "c.json:1:29: $.properties[0].selectd: unknown key 'selectd' (did you mean 'selected'?); known keys "
            "are id, props, selected (keys starting with x- are free for tools)",
        ),
        ('{"properties": [{"selected": true}]}', "c.json:1:17: $.properties[0]: missing required key 'id'"),
        ('{"propertys": []}', "c.json:1:1: $: missing required key 'properties'"),
        (
            '{"properties": [{"id": "a", "selected": 1}]}',
            "c.json:1:41: $.properties[0].selected: expected true or false, found the number 1",
        ),
        (
            '"lab"',
            "c.json:1:1: $: a configuration is a JSON object {\"properties\": [...]}, found the string 'lab'",
        ),
    ],
)
def test_configuration_errors(text: str, expected: str) -> None:
    errors = config_errors(text)
    assert errors[0] == expected


def test_configuration_allows_schema_and_x_keys() -> None:
    text = (
        '{"$schema": "s", "x-description": "d", "properties": [{"id": "a", "x-n": 1, "props": {"x-m": 2}}]}'
    )
    assert config_errors(text) == []


def test_an_id_ending_in_a_newline_is_not_an_id() -> None:
    assert model_errors('{"id": "r\\n", "name": "R"}') == [
        "m.json:1:8: $.id: 'r\\n' is not a valid id: use letters, digits and _, not starting with a digit"
    ]

"""The compiled schema check agrees with jsonschema, and `validate` no longer imports jsonschema.

jsonschema's `Draft202012Validator.is_valid` is the reference: for every schema in
`schemas/` and the shallow schemas `documents/schema.py` derives from them, the compiled
verdict must equal jsonschema's on valid documents (generated from the schema), on those
documents with one value replaced, one key removed or one added, on arbitrary JSON values,
and on random schemas built from the keywords the compiler covers.
"""

from __future__ import annotations

import copy
import functools
import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis_jsonschema import from_schema
from jsonschema import Draft202012Validator
from paths import ROOT

from motivml.documents.fastschema import Unsupported, compile_schema, equal
from motivml.documents.loader import parse
from motivml.documents.schema import (
    FEATURE_MODEL,
    _Checker,
    _errors,
    entry_schema,
    feature_schemas,
    schema_path,
)

pytestmark = pytest.mark.slow  # random schemas and documents against jsonschema

COVERED = [
    "architecture.schema.json",
    "configuration.schema.json",
    "coordination.schema.json",
    "plugin.schema.json",
    "robot.schema.json",
]


def all_schemas() -> dict[str, dict[str, Any]]:
    """Fresh copies: hypothesis-jsonschema rewrites the schemas it is given in place (and
    other test modules hand it parts of `load_schema`'s cached dicts)."""
    schemas = {name: json.loads(schema_path(name).read_text(encoding="utf-8")) for name in COVERED}
    root, inner = copy.deepcopy(feature_schemas())
    schemas.update(
        {
            "root feature (shallow)": root,
            "feature (shallow)": inner,
            "configuration entry": copy.deepcopy(entry_schema()),
        }
    )
    return schemas


SCHEMAS = all_schemas()
SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)


def agree(schema: dict[str, Any], value: Any) -> None:
    expected = Draft202012Validator(schema).is_valid(value)
    assert compile_schema(schema)(value) is expected, (expected, value)


def generation_schema(schema: dict[str, Any], levels: int = 1, longest: int = 2) -> Any:
    """A stricter copy of `schema` that hypothesis-jsonschema generates from quickly.

    References are inlined (a recursive one `levels` deep, then nothing more) and arrays
    hold at most `longest` items (or their minimum); whatever it generates is valid under
    `schema` too.
    """
    defs = schema.get("$defs", {})

    def inline(node: Any, seen: tuple[str, ...]) -> Any:
        if isinstance(node, list):
            return [inline(n, seen) for n in node]
        if not isinstance(node, dict):
            return node
        rest = {k: inline(v, seen) for k, v in node.items() if k not in ("$ref", "$defs")}
        if rest.get("type") == "array":
            rest["maxItems"] = max(rest.get("minItems", 0), min(rest.get("maxItems", longest), longest))
        if "$ref" not in node:
            return rest
        name = node["$ref"].removeprefix("#/$defs/")
        if seen.count(name) >= levels:
            return False
        return dict(inline(defs[name], (*seen, name)), **rest)

    return inline(schema, ())


def constants(schema: Any) -> list[Any]:
    """Values near what `schema` tells apart: its enum members, bounds and keys, and lookalikes."""
    found: list[Any] = [None, True, False, 0, 1, -1, 1.0, 3.0, 0.5, "", "a", "3d", "r\n", "x-a", "A_b1"]
    found += [[], {}, [1], [True], [1.0], {"a": 1}, "é" * 1000, "é" * 1001, "\x01", "a.b", "a::B", "lib/x.so"]
    stack = [schema]
    while stack:
        node = stack.pop()
        if isinstance(node, list):
            stack.extend(node)
        elif isinstance(node, dict):
            for key, value in node.items():
                if key in ("enum",):
                    found += value
                elif key == "const":
                    found.append(value)
                elif key in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"):
                    found += [value, value + 1, value - 1, value + 0.5, float(value), -value]
                elif key in ("properties", "$defs", "patternProperties"):
                    found += list(value)
                    stack.extend(value.values())
                elif isinstance(value, (dict, list)):
                    stack.append(value)
    return found


def paths(value: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    found = [path]
    if isinstance(value, dict):
        for key, item in value.items():
            found += paths(item, (*path, key))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            found += paths(item, (*path, i))
    return found


def replaced(document: Any, path: tuple[Any, ...], value: Any) -> Any:
    if not path:
        return value
    document = copy.deepcopy(document)
    node = document
    for step in path[:-1]:
        node = node[step]
    node[path[-1]] = value
    return document


@functools.cache
def valid_documents(name: str) -> st.SearchStrategy[Any]:
    return from_schema(generation_schema(SCHEMAS[name]))


@st.composite
def mutants(draw: st.DrawFn, document: Any, pool: list[Any]) -> Any:
    """`document` with one value replaced, or one key of an object removed or added."""
    path = draw(st.sampled_from(paths(document)))
    node = document
    for step in path:
        node = node[step]
    how = draw(st.sampled_from(["replace", "remove", "add"] if isinstance(node, dict) else ["replace"]))
    value = draw(st.sampled_from(pool) | json_values)
    if how == "replace":
        return replaced(document, path, value)
    if how == "remove" and node:
        key = draw(st.sampled_from(sorted(node)))
        return replaced(document, path, {k: v for k, v in node.items() if k != key})
    key = draw(st.sampled_from([k for k in pool if isinstance(k, str)]) | st.text(max_size=4))
    return replaced(document, path, dict(node, **{key: value}))


@pytest.mark.parametrize("name", list(SCHEMAS))
@SETTINGS
@given(data=st.data())
def test_valid_documents_and_their_mutants_get_jsonschemas_verdict(name: str, data: st.DataObject) -> None:
    schema = SCHEMAS[name]
    document = data.draw(valid_documents(name), label="document")
    assert compile_schema(schema)(document) is True
    agree(schema, document)
    pool = constants(schema)
    for _ in range(5):
        agree(schema, data.draw(mutants(document, pool), label="mutant"))


@pytest.mark.parametrize("name", list(SCHEMAS))
@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
@given(value=json_values)
def test_arbitrary_json_values_get_jsonschemas_verdict(name: str, value: Any) -> None:
    agree(SCHEMAS[name], value)


# Random schemas from the keywords the compiler covers, on random values near them.

PATTERNS = ["^a", "b$", "^x-", "", "a|b", "^[A-Za-z_][A-Za-z0-9_]*(?!\\n)$", "(a)\\1", "é"]
KEYS = ["a", "b", "x-1", "ab", "é", ""]
SCALARS = [None, True, False, 0, 1, -1, 1.0, 3.0, 2.5, -0.0, 10**20]
SCALARS += ["", "a", "b", "ab", "x-1", "aa", "é", "😀"]
TYPES = ["object", "array", "string", "boolean", "integer", "number", "null"]
VALUES = st.recursive(
    st.sampled_from(SCALARS) | st.integers(-3, 3) | st.floats(allow_nan=False),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.sampled_from(KEYS), inner, max_size=3),
    max_leaves=10,
)
COUNTS = st.integers(0, 3)
BOUNDS = st.sampled_from([0, 1, -1, 0.5, 2.5, 3, 3.0])


def keyword_schemas(inner: st.SearchStrategy[Any]) -> st.SearchStrategy[dict[str, Any]]:
    children = st.dictionaries(st.sampled_from(KEYS), inner, max_size=3)
    plain = st.fixed_dictionaries(
        {},
        optional={
            "type": st.sampled_from(TYPES) | st.lists(st.sampled_from(TYPES), max_size=3),
            "enum": st.lists(VALUES, max_size=4),
            "const": VALUES,
            "pattern": st.sampled_from(PATTERNS),
            "minLength": COUNTS,
            "maxLength": COUNTS,
            "minimum": BOUNDS,
            "maximum": BOUNDS,
            "exclusiveMinimum": BOUNDS,
            "exclusiveMaximum": BOUNDS,
            "items": inner,
            "minItems": COUNTS,
            "maxItems": COUNTS,
            "properties": children,
            "patternProperties": st.dictionaries(st.sampled_from(PATTERNS), inner, max_size=2),
            "additionalProperties": inner,
            "required": st.lists(st.sampled_from(KEYS), max_size=3),
            "minProperties": COUNTS,
            "maxProperties": COUNTS,
            "allOf": st.lists(inner, max_size=2),
            "anyOf": st.lists(inner, max_size=2),
            "oneOf": st.lists(inner, max_size=3),
            "$ref": st.sampled_from(["#/$defs/leaf", "#/$defs/tree"]),
            "description": st.text(max_size=3),
        },
    )
    unevaluated = st.fixed_dictionaries(
        {"unevaluatedProperties": inner},
        optional={
            "type": st.just("object"),
            "properties": children,
            "patternProperties": st.dictionaries(st.sampled_from(PATTERNS), inner, max_size=2),
        },
    )
    return plain | unevaluated


random_subschemas = st.recursive(st.booleans() | st.just({}), keyword_schemas, max_leaves=8)
TREE = {
    "type": ["array", "object"],
    "items": {"$ref": "#/$defs/tree"},
    "additionalProperties": {"$ref": "#/$defs/leaf"},
}


@settings(max_examples=200, deadline=None, suppress_health_check=list(HealthCheck))
@given(
    schema=keyword_schemas(random_subschemas),
    leaf=keyword_schemas(st.booleans()),
    values=st.lists(VALUES, max_size=8),
)
def test_random_schemas_get_jsonschemas_verdict(schema: dict[str, Any], leaf: Any, values: list[Any]) -> None:
    leaf.pop("$ref", None)
    schema = dict(schema, **{"$defs": {"leaf": leaf, "tree": TREE}})
    check = compile_schema(schema)
    validator = Draft202012Validator(schema)
    for value in values:
        assert check(value) is validator.is_valid(value), value


# Each tricky point of jsonschema's semantics, one at a time.

NESTED_LISTS = {
    "$ref": "#/$defs/list",
    "$defs": {"list": {"type": "array", "items": {"$ref": "#/$defs/list"}}},
}


@pytest.mark.parametrize(
    ("schema", "value", "valid"),
    [
        ({"type": "integer"}, 3.0, True),
        ({"type": "integer"}, 3.5, False),
        ({"type": "integer"}, True, False),
        ({"type": "integer"}, 10**30, True),
        ({"type": "integer"}, math.inf, False),
        ({"type": "number"}, False, False),
        ({"type": "number"}, 1.5, True),
        ({"type": "boolean"}, 0, False),
        ({"type": ["string", "null"]}, None, True),
        ({"type": "integer", "minimum": 3}, 3.0, True),
        ({"enum": [1]}, True, False),
        ({"enum": [True]}, 1, False),
        ({"enum": [1]}, 1.0, True),
        ({"enum": [0]}, False, False),
        ({"enum": [[1]]}, [True], False),
        ({"enum": [[1]]}, [1.0], True),
        ({"enum": [{"a": 1}]}, {"a": 1.0}, True),
        ({"enum": [{"a": 1}]}, {"a": True}, False),
        ({"enum": [{"a": 1}]}, {"a": 1, "b": 2}, False),
        ({"enum": ["1"]}, 1, False),
        ({"const": False}, 0, False),
        ({"const": [1, [2]]}, [1.0, [2]], True),
        ({"const": None}, None, True),
        ({"pattern": "b"}, "abc", True),
        ({"pattern": "^b"}, "abc", False),
        ({"pattern": "^[a-z]+(?!\\n)$"}, "abc\n", False),
        ({"maxLength": 1}, "😀", True),
        ({"minLength": 2}, "é", False),
        ({"minLength": 2}, 5, True),
        ({"minimum": 3}, "a", True),
        ({"minimum": 3}, True, True),
        ({"exclusiveMinimum": 0}, 0, False),
        ({"exclusiveMinimum": 0}, 0.0001, True),
        ({"maximum": 1}, 1.0, True),
        ({"required": ["a"]}, [], True),
        ({"required": ["a"]}, {}, False),
        ({"items": {"type": "string"}}, {"a": 1}, True),
        ({"items": False}, [], True),
        ({"items": False}, [1], False),
        ({"minItems": 1}, "", True),
        ({"maxProperties": 1}, {"a": 1, "b": 2}, False),
        ({"properties": {"a": False}}, {"b": 1}, True),
        ({"properties": {"a": False}}, {"a": 1}, False),
        ({"patternProperties": {"^x-": False}}, {"x-a": 1}, False),
        ({"patternProperties": {"^x-": True}, "additionalProperties": False}, {"x-a": 1}, True),
        ({"patternProperties": {"": True}, "additionalProperties": False}, {"a": 1}, False),  # "" joined
        ({"patternProperties": {"": True}, "unevaluatedProperties": False}, {"a": 1}, True),  # each pattern
        ({"additionalProperties": {"type": "string"}}, {"a": 1}, False),
        ({"oneOf": [{"type": "number"}, {"type": "integer"}]}, 1, False),
        ({"oneOf": [{"type": "number"}, {"type": "integer"}]}, 1.5, True),
        ({"anyOf": []}, 1, False),
        ({"allOf": []}, 1, True),
        (NESTED_LISTS, [[[]]], True),
        (NESTED_LISTS, [[1]], False),
        ({"type": "array", "items": {"$ref": "#"}}, [[], [[]]], True),
        ({"$defs": {"a/b": {"type": "null"}}, "$ref": "#/$defs/a~1b"}, None, True),
    ],
)
def test_jsonschemas_semantics(schema: dict[str, Any], value: Any, valid: bool) -> None:
    assert Draft202012Validator(schema).is_valid(value) is valid  # the reference says so
    assert compile_schema(schema)(value) is valid


def test_equal_is_jsonschemas() -> None:
    assert equal(True, True) and equal([True], [True]) and not equal(True, 1) and not equal([0], [False])
    assert equal(1, 1.0) and equal({"a": [1]}, {"a": [1.0]}) and not equal({"a": 1}, {"b": 1})


@pytest.mark.parametrize(
    "schema",
    [
        {"format": "email"},
        {"not": {}},
        {"properties": {"a": {"if": {}}}},
        {"prefixItems": [{}]},
        {"$ref": "#/$defs/featureBody", "unevaluatedProperties": False, "$defs": {"featureBody": {}}},
        {"additionalProperties": False, "unevaluatedProperties": False},
        {"$ref": "urn:elsewhere"},
        {"$ref": "#/properties/a"},
        {"$ref": "#/$defs/missing"},
        {"items": {"$id": "urn:nested", "type": "string"}},
        {"$schema": "http://json-schema.org/draft-07/schema#"},
        {"type": "integr"},
        {"pattern": "("},
        {"minLength": "1"},
    ],
)
def test_what_is_not_covered_is_unsupported(schema: dict[str, Any]) -> None:
    with pytest.raises(Unsupported):
        compile_schema(schema)


def test_the_published_feature_model_schema_is_left_to_jsonschema() -> None:
    """Its `unevaluatedProperties` sits beside a `$ref`: the shallow copies are what we check."""
    with pytest.raises(Unsupported):
        compile_schema(json.loads(schema_path(FEATURE_MODEL).read_text(encoding="utf-8")))
    for name in COVERED:
        compile_schema(SCHEMAS[name])


def test_an_unsupported_schema_falls_back_to_jsonschema_for_the_verdict_and_messages() -> None:
    checker = _Checker({"type": "object", "required": ["a"], "not": {"required": ["b"]}})
    assert checker.fast is None
    doc = parse('{"b": 1}', "d.json")
    messages = [f"{d.location}: {d.message}" for d in _errors(checker, doc.root, doc, (), None)]
    assert messages == [
        "d.json:1:1: missing required key 'a'",
        "d.json:1:1: {'b': 1} should not be valid under {'required': ['b']}",
    ]
    assert _errors(checker, {"a": 1}, doc, (), None) == []


# What `motivml validate` imports.

PROBE = """
import sys
from motivml.cli import main
try:
    main(sys.argv[1:], prog_name="motivml")
except SystemExit as exit:
    print("EXIT:", exit.code, file=sys.stderr)
print("JSONSCHEMA:", "jsonschema" in sys.modules, file=sys.stderr)
"""


def run_validate(*args: str) -> tuple[str, list[str]]:
    done = subprocess.run(
        [sys.executable, "-c", PROBE, "validate", *args], cwd=ROOT, capture_output=True, text=True
    )
    return done.stdout, done.stderr.splitlines()[-2:]


def test_importing_the_schema_module_does_not_import_jsonschema() -> None:
    code = "import motivml.documents.schema, sys; assert 'jsonschema' not in sys.modules"
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_validating_valid_documents_does_not_import_jsonschema() -> None:
    output, status = run_validate("feature_models/simplebot", "--variant", "lab")
    assert status == ["EXIT: 0", "JSONSCHEMA: False"], output
    assert "valid" in output


def test_an_invalid_document_still_gets_jsonschemas_located_message(tmp_path: Path) -> None:
    model = tmp_path / "model.json"
    model.write_text(json.dumps({"id": "r", "name": "R", "sub": [{"id": "a", "name": "A", "group": "xor"}]}))
    output, status = run_validate(str(model))
    assert status == ["EXIT: 1", "JSONSCHEMA: True"], output
    assert (
        f"{model}:1:68: $.sub[0].group: error: 'xor' is not one of \"\", 'OR', 'XOR' (did you mean 'XOR'?)"
        in output
    )

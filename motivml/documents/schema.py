"""JSON Schema checks of documents, with our own located messages.

The schemas in `schemas/` are the single description of the syntax (editors use them too).
`jsonschema`'s validator finds the errors; this module turns each into one located line
(`file:line:col: path: message`) with a suggestion where one helps.

A feature model nests features thousands of levels deep and `jsonschema` descends
recursively, so the model is not validated in one call: each feature object is validated
against a *shallow* copy of the feature schema (its `sub` items are only required to be
objects) while an explicit stack walks the tree.
"""

from __future__ import annotations

import copy
import difflib
import functools
import json
import re
from collections.abc import Callable, Iterator
from importlib import resources
from pathlib import Path
from typing import Any

from jsonschema import Draft202012Validator
from jsonschema.exceptions import ValidationError

from ..errors import Diagnostic, EnvironmentProblem, Location, MotivmlError, error
from .loader import Document, JSONPath, load_file, no_gc

FEATURE_MODEL = "feature-model.schema.json"
CONFIGURATION = "configuration.schema.json"
PLUGIN = "plugin.schema.json"
ROBOT = "robot.schema.json"
IDENTIFIER_PATTERN = "^[A-Za-z_][A-Za-z0-9_]*(?!\\n)$"

_TYPE_NAMES = {
    "object": "an object",
    "array": "an array",
    "string": "a string",
    "boolean": "true or false",
    "integer": "an integer",
    "number": "a number",
    "null": "null",
}


def schema_path(name: str) -> Path:
    """Where a schema file is: packaged in the wheel, or `schemas/` of a source checkout."""
    packaged = resources.files("motivml").joinpath("schemas", name)
    if packaged.is_file():
        return Path(str(packaged))
    return Path(__file__).resolve().parents[2] / "schemas" / name


@functools.cache
def load_schema(name: str) -> dict[str, Any]:
    path = schema_path(name)
    try:
        with open(path, encoding="utf-8") as handle:
            schema: dict[str, Any] = json.load(handle)
    except OSError as exc:
        raise EnvironmentProblem(
            error(Location(str(path)), f"schema not found ({exc.strerror}): reinstall motivml", "io")
        ) from None
    return schema


@functools.cache
def _feature_validators() -> tuple[Draft202012Validator, Draft202012Validator]:
    """Validators for the root feature and for any other feature, both shallow."""
    published = load_schema(FEATURE_MODEL)
    defs = copy.deepcopy(published["$defs"])
    body = defs["featureBody"]
    body["properties"]["sub"]["items"] = {"type": "object"}
    # `unevaluatedProperties` makes jsonschema re-validate every property value; with the
    # body inlined, `additionalProperties` says the same thing for one object at a time.
    inner = _inline(dict(body, additionalProperties=False), defs)
    root = dict(inner, properties=dict(inner["properties"], **published["properties"]))
    return Draft202012Validator(root), Draft202012Validator(inner)


def _inline(schema: Any, defs: dict[str, Any]) -> Any:
    """Replace local `#/$defs/...` references by their targets (non-recursive ones only).

    jsonschema resolves a `$ref` on every use, which made up most of the time spent per
    feature; the shallow schemas have no recursion left, so they can be inlined.
    """
    if isinstance(schema, list):
        return [_inline(item, defs) for item in schema]
    if not isinstance(schema, dict):
        return schema
    ref = schema.get("$ref")
    if isinstance(ref, str) and ref.startswith("#/$defs/"):
        target = _inline(defs[ref.removeprefix("#/$defs/")], defs)
        rest = {k: _inline(v, defs) for k, v in schema.items() if k != "$ref"}
        return dict(target, **rest)
    return {k: _inline(v, defs) for k, v in schema.items()}


@functools.cache
def _validator(name: str) -> Draft202012Validator:
    return Draft202012Validator(load_schema(name))


def _show(value: Any) -> str:
    return json.dumps(value) if value == "" else repr(value) if isinstance(value, str) else json.dumps(value)


def _suggest(value: str, choices: list[str]) -> str:
    """`(did you mean 'X'?)` for a wrong-case or misspelt token, or ''."""
    for choice in choices:
        if choice.lower() == value.lower() and choice != value:
            return f" (did you mean {choice!r}?)"
    close = difflib.get_close_matches(value, choices, n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _messages(
    err: ValidationError, doc: Document, base: JSONPath, feature: str | None
) -> Iterator[Diagnostic]:
    path = base + tuple(err.absolute_path)
    instance = err.instance
    kind = err.validator
    if kind in ("additionalProperties", "unevaluatedProperties"):
        allowed = _allowed_keys(err.schema)
        for key in instance:
            if key in allowed or key.startswith("x-"):
                continue
            hint = _suggest(key, allowed)
            yield error(
                doc.locate(path + (key,), key=True),
                f"unknown key {key!r}{hint}; known keys are {', '.join(allowed)} (keys starting with x- are free for tools)",
                "schema.unknown-key",
                feature,
            )
        return
    location = doc.locate(path)
    if kind == "enum":
        choices = [str(c) for c in err.validator_value]
        shown = ", ".join(_show(c) for c in err.validator_value)
        hint = _suggest(instance, choices) if isinstance(instance, str) else ""
        message = f"{_show(instance)} is not one of {shown}{hint}"
    elif kind == "type":
        wanted = err.validator_value if isinstance(err.validator_value, list) else [err.validator_value]
        message = f"expected {' or '.join(_TYPE_NAMES.get(str(w), str(w)) for w in wanted)}, found {_describe(instance)}"
    elif kind == "required":
        missing = [key for key in err.validator_value if key not in instance]
        message = f"missing required key {', '.join(repr(k) for k in missing)}"
    elif kind == "pattern" and err.validator_value == IDENTIFIER_PATTERN:
        message = f"{instance!r} is not a valid id: use letters, digits and _, not starting with a digit"
    elif kind == "pattern":
        message = (
            f"{instance!r} is not of the required form ({err.schema.get('description', err.validator_value)})"
        )
    elif kind == "minLength":
        message = "must not be empty"
    else:  # a schema keyword we do not phrase specially: still located, never the schema dump
        message = err.message
    yield error(location, message, f"schema.{kind}", feature)


def _allowed_keys(schema: dict[str, Any]) -> list[str]:
    """Keys a schema object allows, following a `$ref` to the feature body."""
    keys = set(schema.get("properties", {}))
    if str(schema.get("$ref", "")).endswith(("/featureBody", "/feature")):
        keys |= set(load_schema(FEATURE_MODEL)["$defs"]["featureBody"]["properties"])
    return sorted(keys)


def _describe(value: Any) -> str:
    if isinstance(value, bool):
        return f"the boolean {json.dumps(value)}"
    if isinstance(value, (int, float)):
        return f"the number {value}"
    if isinstance(value, str):
        return f"the string {value!r}"
    if value is None:
        return "null"
    if isinstance(value, list):
        return "an array"
    return "an object"


def _ordered(diagnostics: list[Diagnostic]) -> list[Diagnostic]:
    return sorted(diagnostics, key=lambda d: (d.location.line or 0, d.location.column or 0))


def check_feature_model(doc: Document) -> list[Diagnostic]:
    """All schema errors of a feature model, in document order (iterative over the tree)."""
    root_validator, inner_validator = _feature_validators()
    found: list[Diagnostic] = []
    stack: list[tuple[JSONPath, Any]] = [((), doc.root)]
    while stack:
        path, node = stack.pop()
        validator = root_validator if not path else inner_validator
        feature = node.get("id") if isinstance(node, dict) and isinstance(node.get("id"), str) else None
        found.extend(_errors(validator, node, doc, path, feature))
        if isinstance(node, dict) and isinstance(node.get("sub"), list):
            for i in range(len(node["sub"]) - 1, -1, -1):
                child = node["sub"][i]
                if isinstance(child, dict):
                    stack.append((path + ("sub", i), child))
    if not isinstance(doc.root, dict):
        return [
            error(
                doc.locate(()),
                f"a feature model is one JSON object (the root feature), found {_describe(doc.root)}",
                "schema.type",
            )
        ]
    return _ordered(found)


def check_configuration(doc: Document) -> list[Diagnostic]:
    """All schema errors of a configuration, in document order."""
    if not isinstance(doc.root, dict):
        return [
            error(
                doc.locate(()),
                f'a configuration is a JSON object {{"properties": [...]}}, found {_describe(doc.root)}',
                "schema.type",
            )
        ]
    found: list[Diagnostic] = []
    entries = doc.root.get("properties")
    top = {
        key: (value if key != "properties" or not isinstance(value, list) else [])
        for key, value in doc.root.items()
    }
    found.extend(_errors(_validator(CONFIGURATION), top, doc, (), None))
    if isinstance(entries, list):
        entry_validator = _entry_validator()
        for i, entry in enumerate(entries):
            feature = (
                entry.get("id") if isinstance(entry, dict) and isinstance(entry.get("id"), str) else None
            )
            found.extend(_errors(entry_validator, entry, doc, ("properties", i), feature))
    return _ordered(found)


def check_document(doc: Document, name: str, what: str) -> list[Diagnostic]:
    """Schema errors of a small, shallow document (a plugin manifest, robot.json)."""
    if not isinstance(doc.root, dict):
        return [error(doc.locate(()), f"{what} is a JSON object, found {_describe(doc.root)}", "schema.type")]
    return _ordered(_errors(_validator(name), doc.root, doc, (), None))


@functools.cache
def _entry_validator() -> Draft202012Validator:
    schema = load_schema(CONFIGURATION)
    return Draft202012Validator(_inline(schema["$defs"]["entry"], schema["$defs"]))


_SHAPE_KEYWORDS = frozenset(
    {
        "type",
        "enum",
        "pattern",
        "minLength",
        "properties",
        "additionalProperties",
        "patternProperties",
        "required",
        "items",
        "default",
        "description",
        "title",
        "$defs",
    }
)


class _Shape:
    """Memo of the shapes a (non-recursive) schema accepts.

    jsonschema needs ~80 µs per feature object, too slow for 100,000 features. Most
    features look alike once what the schema cannot tell apart is forgotten: a string
    only matters through its enum membership, pattern matches and emptiness; a number,
    boolean or null only through its type; a value under a `true` subschema not at all.
    `key()` maps a value to that abstraction, walking the schema beside it (so its depth
    is the schema's, never the document's). A shape jsonschema once found valid is valid
    again; anything else is validated for real. Schemas using other keywords get no memo.
    """

    def __init__(self, schema: dict[str, Any]) -> None:
        self.schema = schema
        self.valid: set[Any] = set()
        self.enabled = _uses_only(schema, _SHAPE_KEYWORDS)

    def key(self, value: Any, schema: Any = None) -> Any:
        schema = self.schema if schema is None else schema
        if schema is True or schema == {}:
            return None
        if isinstance(value, bool):
            return ("bool",)
        if isinstance(value, str):
            enum = schema.get("enum", ())
            pattern = schema.get("pattern")
            return (
                "str",
                value if value in enum else None,
                bool(re.search(pattern, value)) if pattern else None,
                len(value) >= schema.get("minLength", 0),
            )
        if isinstance(value, (int, float)) or value is None:
            return (type(value).__name__,)
        if isinstance(value, list):
            items = schema.get("items", True)
            return ("list", frozenset(self.key(v, items) for v in value))
        if isinstance(value, dict):
            props = schema.get("properties", {})
            patterns = schema.get("patternProperties", {})
            parts = []
            for k, v in value.items():
                if k in props:
                    parts.append((k, self.key(v, props[k])))
                    continue
                matched = [p for p in patterns if re.search(p, k)]
                if matched:
                    parts.append(
                        (tuple(matched), self.key(v, patterns[matched[0]]) if len(matched) == 1 else v)
                    )
                else:
                    parts.append((k, None))
            return ("dict", frozenset(parts))
        raise TypeError(f"not a JSON value: {type(value).__name__}")


def _uses_only(schema: Any, allowed: frozenset[str]) -> bool:
    stack = [schema]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            if not set(node) <= allowed:
                return False
            for key in ("properties", "patternProperties", "$defs"):
                stack.extend(node.get(key, {}).values())
            stack.extend(node[k] for k in ("items", "additionalProperties") if k in node)
    return True


_shapes: dict[int, _Shape] = {}


def _shape(validator: Draft202012Validator) -> _Shape:
    """The memo of one (cached, long-lived) validator."""
    shape = _shapes.get(id(validator))
    if shape is None:
        shape = _shapes[id(validator)] = _Shape(validator.schema)
    return shape


def _errors(
    validator: Draft202012Validator, instance: Any, doc: Document, path: JSONPath, feature: str | None
) -> list[Diagnostic]:
    """Located schema errors of one object.

    jsonschema builds each message with `repr` of the offending value, which recurses; a
    value nested thousands of levels deep (where only a small one belongs) is reported as
    such instead of crashing.
    """
    shape = _shape(validator)
    try:
        if shape.enabled:
            key = shape.key(instance)
            if key in shape.valid:
                return []
            found = [d for err in validator.iter_errors(instance) for d in _messages(err, doc, path, feature)]
            if not found:
                shape.valid.add(key)
            return found
        return [d for err in validator.iter_errors(instance) for d in _messages(err, doc, path, feature)]
    except RecursionError:
        return [
            error(
                doc.locate(path),
                "holds a value nested too deeply for its place (only `sub` nests features)",
                "limits",
                feature,
            )
        ]


def read_checked(
    path: str | Path, schema_check: Callable[[Document], list[Diagnostic]]
) -> tuple[Document | None, list[Diagnostic]]:
    """Load a document and check it against its schema; None (and why) when unusable.

    Only invalid documents become diagnostics; environment problems (a missing file)
    propagate, so that the caller's exit code says so.
    """
    try:
        doc = load_file(path)
    except MotivmlError as exc:
        if exc.exit_code != 1:
            raise
        return None, exc.diagnostics
    with no_gc():
        problems = schema_check(doc)
    return (None, problems) if problems else (doc, [])

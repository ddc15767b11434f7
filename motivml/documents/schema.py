"""JSON Schema checks of documents, with our own located messages.

The schemas in `schemas/` are the single description of the syntax (editors use them too).
Each object is first checked by the schema compiled in `fastschema.py` (a yes/no answer,
without importing `jsonschema`); only an object it finds invalid, or a schema it does not
cover, goes to `jsonschema`'s validator, which finds the errors; this module turns each
into one located line (`file:line:col: path: message`) with a suggestion where one helps.

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
from collections.abc import Callable, Iterator
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from ..errors import Diagnostic, EnvironmentProblem, JSONPath, Location, MotivmlError, error
from ..process import no_gc
from ..process.forked import Failed, InChild, can_fork
from .fastschema import Check, Unsupported, compile_schema
from .loader import Document, load_file

if TYPE_CHECKING:  # imported where a document is invalid: it takes ~60 ms to import
    from jsonschema import Draft202012Validator
    from jsonschema.exceptions import ValidationError

R = TypeVar("R")

FEATURE_MODEL = "feature-model.schema.json"
CONFIGURATION = "configuration.schema.json"
PLUGIN = "plugin.schema.json"
ROBOT = "robot.schema.json"
FLEET = "fleet.schema.json"
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


class _Checker:
    """One schema: its compiled yes/no check, and jsonschema's validator when messages are needed."""

    def __init__(self, schema: dict[str, Any]) -> None:
        self.schema = schema
        self.fast: Check | None
        try:
            self.fast = compile_schema(schema)
        except Unsupported:
            self.fast = None
        self._validator: Draft202012Validator | None = None

    def valid(self, instance: Any) -> bool:
        """True when the compiled check accepts `instance`; False: ask jsonschema."""
        if self.fast is None:
            return False
        try:
            return self.fast(instance)
        except RecursionError:  # jsonschema decides (and reports), as it always did
            return False

    @property
    def validator(self) -> Draft202012Validator:
        if self._validator is None:
            from jsonschema import Draft202012Validator

            self._validator = Draft202012Validator(self.schema)
        return self._validator


@functools.cache
def feature_schemas() -> tuple[dict[str, Any], dict[str, Any]]:
    """The schemas of the root feature and of any other feature, both shallow."""
    published = load_schema(FEATURE_MODEL)
    defs = copy.deepcopy(published["$defs"])
    body = defs["featureBody"]
    body["properties"]["sub"]["items"] = {"type": "object"}
    # `unevaluatedProperties` makes jsonschema re-validate every property value; with the
    # body inlined, `additionalProperties` says the same thing for one object at a time.
    inner = _inline(dict(body, additionalProperties=False), defs)
    root = dict(inner, properties=dict(inner["properties"], **published["properties"]))
    return root, inner


@functools.cache
def _feature_checkers() -> tuple[_Checker, _Checker]:
    root, inner = feature_schemas()
    return _Checker(root), _Checker(inner)


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
def _checker(name: str) -> _Checker:
    return _Checker(load_schema(name))


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


_Link = tuple[Any, int] | None  # (the parent feature's link, index in its `sub`); None: the root


def _path(link: _Link) -> JSONPath:
    indices: list[int] = []
    while link is not None:
        link, i = link
        indices.append(i)
    return tuple(step for i in reversed(indices) for step in ("sub", i))


def check_feature_model(doc: Document) -> list[Diagnostic]:
    """All schema errors of a feature model, in document order (iterative over the tree).

    A feature's place is kept as a link to its parent's, `(parent link, index)`, and spelt
    out as a JSON path only for a feature with errors: copying the whole path for each
    feature costs time proportional to the depth, thousands of levels in large models.
    """
    root_checker, inner_checker = _feature_checkers()
    found: list[Diagnostic] = []
    stack: list[tuple[_Link, Any]] = [(None, doc.root)]
    while stack:
        link, node = stack.pop()
        checker = root_checker if link is None else inner_checker
        if not checker.valid(node):
            feature = node.get("id") if isinstance(node, dict) and isinstance(node.get("id"), str) else None
            found.extend(_located_errors(checker, node, doc, _path(link), feature))
        if isinstance(node, dict) and isinstance(node.get("sub"), list):
            for i in range(len(node["sub"]) - 1, -1, -1):
                child = node["sub"][i]
                if isinstance(child, dict):
                    stack.append(((link, i), child))
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
    found.extend(_errors(_checker(CONFIGURATION), top, doc, (), None))
    if isinstance(entries, list):
        entry_checker = _entry_checker()
        for i, entry in enumerate(entries):
            feature = (
                entry.get("id") if isinstance(entry, dict) and isinstance(entry.get("id"), str) else None
            )
            found.extend(_errors(entry_checker, entry, doc, ("properties", i), feature))
    return _ordered(found)


def check_document(doc: Document, name: str, what: str) -> list[Diagnostic]:
    """Schema errors of a small, shallow document (a plugin manifest, robot.json)."""
    if not isinstance(doc.root, dict):
        return [error(doc.locate(()), f"{what} is a JSON object, found {_describe(doc.root)}", "schema.type")]
    return _ordered(_errors(_checker(name), doc.root, doc, (), None))


@functools.cache
def entry_schema() -> dict[str, Any]:
    """The schema of one configuration entry, its references inlined."""
    schema = load_schema(CONFIGURATION)
    inlined: dict[str, Any] = _inline(schema["$defs"]["entry"], schema["$defs"])
    return inlined


@functools.cache
def _entry_checker() -> _Checker:
    return _Checker(entry_schema())


def _errors(
    checker: _Checker, instance: Any, doc: Document, path: JSONPath, feature: str | None
) -> list[Diagnostic]:
    """Located schema errors of one object: none when the compiled check accepts it."""
    return [] if checker.valid(instance) else _located_errors(checker, instance, doc, path, feature)


def _located_errors(
    checker: _Checker, instance: Any, doc: Document, path: JSONPath, feature: str | None
) -> list[Diagnostic]:
    """The errors jsonschema finds in one object, located.

    jsonschema builds each message with `repr` of the offending value, which recurses; a
    value nested thousands of levels deep (where only a small one belongs) is reported as
    such instead of crashing.
    """
    try:
        return [
            d for err in checker.validator.iter_errors(instance) for d in _messages(err, doc, path, feature)
        ]
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
    doc, problems = read_with_problems(path, schema_check)
    return (None, problems) if problems else (doc, [])


BESIDE_FROM = 1 << 20  # characters: from here `read_checked_then` checks in a child, beside `then`


def read_checked_then(
    path: str | Path, schema_check: Callable[[Document], list[Diagnostic]], then: Callable[[Document], R]
) -> tuple[Document | None, list[Diagnostic], R | None]:
    """`read_checked`, then `then(doc)` on the sound document: (the document, [], what
    `then` returned); (None, why, None) when it is unusable.

    A document of BESIDE_FROM characters or more is checked in a child process (where one
    can be forked: `forked.can_fork`) while `then` runs here on it, not yet known sound:
    what `then` returns, or raises, counts only once the check has found nothing. The
    check and the reading of a model of 100,000 features take 0.27 s each. If the child
    fails, the check runs here after all.
    """
    doc, unusable = _loaded(path)
    if doc is None:
        return None, unusable, None
    beside: InChild[list[Diagnostic]] | None = None
    failure: Exception | None = None
    try:
        if len(doc.text) >= BESIDE_FROM and can_fork():
            beside = InChild.start(lambda requests: _checked(schema_check, doc))
        if beside is None:
            problems = _checked(schema_check, doc)
            return (None, problems, None) if problems else (doc, [], then(doc))
        try:
            outcome: R | None = then(doc)
        except Exception as exc:  # noqa: BLE001 - on a document the check may yet refuse: said below
            outcome, failure = None, exc
        found = beside.result()
    finally:
        if beside is not None:
            beside.close()
    problems = _checked(schema_check, doc) if isinstance(found, Failed) else found
    if problems:
        return None, problems, None
    if failure is not None:
        raise failure
    return doc, [], outcome


def _checked(schema_check: Callable[[Document], list[Diagnostic]], doc: Document) -> list[Diagnostic]:
    with no_gc():
        return schema_check(doc)


def read_with_problems(
    path: str | Path, schema_check: Callable[[Document], list[Diagnostic]]
) -> tuple[Document | None, list[Diagnostic]]:
    """Like `read_checked`, but the document comes back with its schema errors (None only when
    it cannot be loaded at all), for a reader that checks its sound parts all the same."""
    doc, unusable = _loaded(path)
    return (doc, _checked(schema_check, doc)) if doc is not None else (None, unusable)


def _loaded(path: str | Path) -> tuple[Document | None, list[Diagnostic]]:
    """The document; None and why when it is invalid JSON (environment problems, a missing
    file, propagate: the caller's exit code says so)."""
    try:
        return load_file(path), []
    except MotivmlError as exc:
        if exc.exit_code != 1:
            raise
        return None, exc.diagnostics

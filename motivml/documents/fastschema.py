"""A yes/no JSON Schema checker, compiled once per schema into nested closures.

Why: `jsonschema` costs 50-75 ms of start-up to import (referencing, attrs, rpds, the
bundled metaschemas) and tens of microseconds per feature object to validate, yet nearly
every document a user checks is valid and needs no message at all. So `schema.py` asks
this checker first and imports `jsonschema` only when the answer is "invalid" (or when a
schema uses a keyword this compiler does not cover); `jsonschema` stays the one source of
every error message.

`compile_schema(schema)` turns a draft 2020-12 schema (a Python dict) into a function
`value -> bool` that agrees with `jsonschema.Draft202012Validator(schema).is_valid(value)`.
It covers exactly the keywords our schemas (and the shallow copies `schema.py` derives
from them) use:

* type, enum, const;
* strings: pattern (`re.search`), minLength, maxLength (code points);
* numbers: minimum, maximum, exclusiveMinimum, exclusiveMaximum;
* arrays: items, minItems, maxItems;
* objects: properties, patternProperties, additionalProperties, required, minProperties,
  maxProperties, and unevaluatedProperties where it means additionalProperties (the same
  object has no in-place applicator and no additionalProperties);
* oneOf, anyOf, allOf, and `$ref` to `#` or `#/$defs/NAME` of the root (recursive
  references are bound once their target is compiled);
* annotations, ignored: title, description, default, examples, $comment, $id (at the root
  only) and $schema (draft 2020-12 only); $defs is read only through `$ref`.

Any other keyword raises `Unsupported`, and the caller validates with `jsonschema`.
`jsonschema`'s semantics are followed to the letter: a keyword applies only to instances
of its type; "integer" accepts 3.0 but no boolean, "number" no boolean; enum and const
compare as `jsonschema._utils.equal` does (True is not 1, 1 is 1.0, lists and objects
element by element); additionalProperties sees the patternProperties joined with `|`, as
`jsonschema` does, while unevaluatedProperties tries them one by one.
"""

from __future__ import annotations

import numbers
import re
from collections.abc import Callable, Mapping, Sequence
from typing import Any

Check = Callable[[Any], bool]

DRAFT_2020_12 = "https://json-schema.org/draft/2020-12/schema"
_ANNOTATIONS = frozenset(
    {"title", "description", "default", "examples", "$comment", "$defs", "$id", "$schema"}
)
_STRING = frozenset({"pattern", "minLength", "maxLength"})
_NUMBER = frozenset({"minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"})
_ARRAY = frozenset({"items", "minItems", "maxItems"})
_OBJECT = frozenset(
    {
        "properties",
        "patternProperties",
        "additionalProperties",
        "unevaluatedProperties",
        "required",
        "minProperties",
        "maxProperties",
    }
)
_APPLICATORS = frozenset({"allOf", "anyOf", "oneOf", "$ref"})
_KEYWORDS_OF = {"object": _OBJECT, "array": _ARRAY, "string": _STRING, "number": _NUMBER, "integer": _NUMBER}
_KEYWORDS = _ANNOTATIONS | _STRING | _NUMBER | _ARRAY | _OBJECT | _APPLICATORS | {"type", "enum", "const"}
_INFINITY = float("inf")


class Unsupported(Exception):
    """The schema uses something this compiler does not cover: validate with jsonschema."""


def _true(value: Any) -> bool:
    return True


def _false(value: Any) -> bool:
    return False


def _undeclared(value: Any) -> bool:  # a marker: the key is not under `properties`
    return True


def _is_integer(value: Any) -> bool:
    if isinstance(value, float):
        return value.is_integer()
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    kind = type(value)
    if kind is int or kind is float:
        return True
    return not isinstance(value, bool) and isinstance(value, numbers.Number)


def _is_object(value: Any) -> bool:
    return isinstance(value, dict)


def _is_array(value: Any) -> bool:
    return isinstance(value, list)


def _is_string(value: Any) -> bool:
    return isinstance(value, str)


def _is_boolean(value: Any) -> bool:
    return isinstance(value, bool)


def _is_null(value: Any) -> bool:
    return value is None


_TYPES: dict[str, Check] = {
    "object": _is_object,
    "array": _is_array,
    "string": _is_string,
    "boolean": _is_boolean,
    "integer": _is_integer,
    "number": _is_number,
    "null": _is_null,
}


def _unbool(value: Any, true: object = object(), false: object = object()) -> Any:
    if value is True:
        return true
    if value is False:
        return false
    return value


def equal(one: Any, two: Any) -> bool:
    """JSON equality as jsonschema's `equal`: booleans are not numbers, containers recurse."""
    if one is two:
        return True
    if isinstance(one, str) or isinstance(two, str):
        return bool(one == two)
    if isinstance(one, Sequence) and isinstance(two, Sequence):
        return len(one) == len(two) and all(equal(i, j) for i, j in zip(one, two, strict=True))
    if isinstance(one, Mapping) and isinstance(two, Mapping):
        return len(one) == len(two) and all(
            key in two and equal(value, two[key]) for key, value in one.items()
        )
    return bool(_unbool(one) == _unbool(two))


def compile_schema(schema: Any) -> Check:
    """A function telling whether a value is valid under `schema`; `Unsupported` if not covered."""
    return _Compiler(schema).compile(schema, root=True)


def _number(schema: dict[str, Any], keyword: str, default: float | None) -> Any:
    """The number a keyword holds, or `default` when absent."""
    if keyword not in schema:
        return default
    value = schema[keyword]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise Unsupported(f"{keyword} must be a number")
    return value


def _regex(pattern: Any) -> re.Pattern[str]:
    if not isinstance(pattern, str):
        raise Unsupported("a pattern must be a string")
    try:
        return re.compile(pattern)
    except re.error as exc:
        raise Unsupported(f"pattern {pattern!r}: {exc}") from None


def _all(checks: list[Check]) -> Check:
    checks = [c for c in checks if c is not _true]
    if _false in checks:
        return _false
    if not checks:
        return _true
    if len(checks) == 1:
        return checks[0]
    if len(checks) == 2:
        first, second = checks

        def both(value: Any) -> bool:
            return first(value) and second(value)

        return both
    every = tuple(checks)

    def each(value: Any) -> bool:
        for check in every:
            if not check(value):
                return False
        return True

    return each


class _Compiler:
    def __init__(self, root: Any) -> None:
        self.root = root
        self.refs: dict[str, list[Check]] = {}

    def compile(self, schema: Any, root: bool = False) -> Check:
        if schema is True:
            return _true
        if schema is False:
            return _false
        if not isinstance(schema, dict):
            raise Unsupported(f"a schema is an object or a boolean, not {type(schema).__name__}")
        unknown = schema.keys() - _KEYWORDS
        if unknown:
            raise Unsupported(f"keyword {sorted(unknown)[0]!r}")
        if "$id" in schema and not root:
            raise Unsupported("$id below the root (a new base for references)")
        if "$schema" in schema and schema["$schema"] not in (DRAFT_2020_12, DRAFT_2020_12 + "#"):
            raise Unsupported(f"$schema {schema['$schema']!r}")

        types = self._types(schema)
        # With a single type, the keywords of that type test it too (one call, not two).
        only = types[0] if types is not None and len(types) == 1 else None
        keywords = schema.keys()
        checks: list[Check] = []
        if keywords & _OBJECT:
            checks.append(self._object(schema, strict=only == "object"))
        if keywords & _ARRAY:
            checks.append(self._array(schema, strict=only == "array"))
        if keywords & _STRING:
            checks.append(self._string(schema, strict=only == "string"))
        if keywords & _NUMBER:
            checks.append(
                self._numeric(schema, strict=only in ("number", "integer"), integer=only == "integer")
            )
        if types is not None and not (only in _KEYWORDS_OF and keywords & _KEYWORDS_OF[only]):
            checks.insert(0, self._type(types))
        if "enum" in schema:
            checks.append(self._enum(schema["enum"]))
        if "const" in schema:
            checks.append(self._const(schema["const"]))
        if "$ref" in schema:
            checks.append(self._ref(schema["$ref"]))
        if "allOf" in schema:
            checks.append(_all([self.compile(s) for s in self._list(schema, "allOf")]))
        if "anyOf" in schema:
            checks.append(self._any([self.compile(s) for s in self._list(schema, "anyOf")]))
        if "oneOf" in schema:
            checks.append(self._one([self.compile(s) for s in self._list(schema, "oneOf")]))
        return _all(checks)

    @staticmethod
    def _list(schema: dict[str, Any], keyword: str) -> list[Any]:
        value = schema[keyword]
        if not isinstance(value, list):
            raise Unsupported(f"{keyword} must be an array")
        return value

    @staticmethod
    def _types(schema: dict[str, Any]) -> list[str] | None:
        if "type" not in schema:
            return None
        types = schema["type"]
        if isinstance(types, str):
            types = [types]
        if not isinstance(types, list) or not all(isinstance(t, str) and t in _TYPES for t in types):
            raise Unsupported(f"type {schema['type']!r}")
        return types

    @staticmethod
    def _type(types: list[str]) -> Check:
        tests = tuple(_TYPES[t] for t in dict.fromkeys(types))
        if len(tests) == 1:
            return tests[0]

        def any_type(value: Any) -> bool:
            for test in tests:
                if test(value):
                    return True
            return False

        return any_type

    def _object(self, schema: dict[str, Any], strict: bool) -> Check:
        properties = schema.get("properties", {})
        patterns = schema.get("patternProperties", {})
        required = schema.get("required", [])
        if not isinstance(properties, dict) or not isinstance(patterns, dict):
            raise Unsupported("properties and patternProperties must be objects")
        if not isinstance(required, list) or not all(isinstance(k, str) for k in required):
            raise Unsupported("required must be an array of strings")
        fewest = _number(schema, "minProperties", 0)
        most = _number(schema, "maxProperties", _INFINITY)
        declared: dict[str, Check | None] = {}
        for key, subschema in properties.items():
            check = self.compile(subschema)
            declared[key] = None if check is _true else check
        by_pattern = tuple(
            (regex.search, check)
            for regex, check in ((_regex(p), self.compile(s)) for p, s in patterns.items())
            if check is not _true
        )
        # Keys neither declared nor matched; jsonschema's additionalProperties searches the
        # patterns joined by "|" (none when that is ""), unevaluatedProperties each one.
        extra: Check | None = None
        matched: Callable[[str], Any] | None = None
        if "additionalProperties" in schema:
            extra = self.compile(schema["additionalProperties"])
            joined = "|".join(patterns)
            matched = _regex(joined).search if joined else None
        if "unevaluatedProperties" in schema:
            if schema.keys() & _APPLICATORS or "additionalProperties" in schema:
                raise Unsupported("unevaluatedProperties beside applicators or additionalProperties")
            extra = self.compile(schema["unevaluatedProperties"])
            searches = tuple(_regex(p).search for p in patterns)
            if len(searches) == 1:
                matched = searches[0]
            elif searches:

                def matched_any(key: str) -> bool:
                    for search in searches:
                        if search(key):
                            return True
                    return False

                matched = matched_any
        if extra is _true:
            extra = None
        needed = tuple(dict.fromkeys(required))

        def check_object(value: Any) -> bool:
            if not isinstance(value, dict):
                return not strict
            for key in needed:
                if key not in value:
                    return False
            size = len(value)
            if size < fewest or size > most:
                return False
            for key, item in value.items():
                check = declared.get(key, _undeclared)
                if check is _undeclared:
                    if extra is not None and not (matched is not None and matched(key)) and not extra(item):
                        return False
                elif check is not None and not check(item):
                    return False
                for search, check_matched in by_pattern:
                    if search(key) and not check_matched(item):
                        return False
            return True

        return check_object

    def _array(self, schema: dict[str, Any], strict: bool) -> Check:
        items = self.compile(schema["items"]) if "items" in schema else _true
        fewest = _number(schema, "minItems", 0)
        most = _number(schema, "maxItems", _INFINITY)
        each: Check | None = None if items is _true else items

        def check_array(value: Any) -> bool:
            if not isinstance(value, list):
                return not strict
            size = len(value)
            if size < fewest or size > most:
                return False
            if each is not None:
                for item in value:
                    if not each(item):
                        return False
            return True

        return check_array

    def _string(self, schema: dict[str, Any], strict: bool) -> Check:
        search = _regex(schema["pattern"]).search if "pattern" in schema else None
        shortest = _number(schema, "minLength", 0)
        longest = _number(schema, "maxLength", _INFINITY)

        def check_string(value: Any) -> bool:
            if not isinstance(value, str):
                return not strict
            size = len(value)
            if size < shortest or size > longest:
                return False
            return search is None or search(value) is not None

        return check_string

    def _numeric(self, schema: dict[str, Any], strict: bool, integer: bool) -> Check:
        low = _number(schema, "minimum", None)
        high = _number(schema, "maximum", None)
        above = _number(schema, "exclusiveMinimum", None)
        below = _number(schema, "exclusiveMaximum", None)
        is_type = _is_integer if integer else _is_number

        def check_number(value: Any) -> bool:
            if not is_type(value):
                return not strict
            if low is not None and value < low:
                return False
            if high is not None and value > high:
                return False
            if above is not None and value <= above:
                return False
            return not (below is not None and value >= below)

        return check_number

    @staticmethod
    def _enum(choices: Any) -> Check:
        if not isinstance(choices, list):
            raise Unsupported("enum must be an array")
        strings = frozenset(c for c in choices if isinstance(c, str))
        others = tuple(c for c in choices if not isinstance(c, str))

        def check_enum(value: Any) -> bool:
            if isinstance(value, str):
                return value in strings
            for choice in others:
                if equal(choice, value):
                    return True
            return False

        return check_enum

    @staticmethod
    def _const(expected: Any) -> Check:
        def check_const(value: Any) -> bool:
            return equal(value, expected)

        return check_const

    @staticmethod
    def _any(checks: list[Check]) -> Check:
        if _true in checks:
            return _true
        options = tuple(c for c in checks if c is not _false)

        def check_any(value: Any) -> bool:
            for check in options:
                if check(value):
                    return True
            return False

        return check_any

    @staticmethod
    def _one(checks: list[Check]) -> Check:
        options = tuple(checks)

        def check_one(value: Any) -> bool:
            found = False
            for check in options:
                if check(value):
                    if found:
                        return False
                    found = True
            return found

        return check_one

    def _ref(self, ref: Any) -> Check:
        if ref == "#":
            name, target = "", self.root
        elif isinstance(ref, str) and ref.startswith("#/$defs/") and "%" not in ref:
            name = ref.removeprefix("#/$defs/")
            if "/" in name:
                raise Unsupported(f"$ref {ref!r} (only #/$defs/NAME)")
            name = name.replace("~1", "/").replace("~0", "~")
            defs = self.root.get("$defs") if isinstance(self.root, dict) else None
            if not isinstance(defs, dict) or name not in defs:
                raise Unsupported(f"$ref {ref!r} does not resolve")
            target = defs[name]
        else:
            raise Unsupported(f"$ref {ref!r} (only #/$defs/NAME)")
        cell = self.refs.get(ref)
        if cell is None:
            cell = self.refs[ref] = []
            cell.append(self.compile(target, root=name == ""))
        if cell:
            return cell[0]
        bound = cell  # a recursive reference: its target is being compiled; call it once it is

        def check_ref(value: Any) -> bool:
            return bound[0](value)

        return check_ref

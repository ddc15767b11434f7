"""The located JSON loader: positions, refusals, limits, deep documents."""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motivml.documents import loader
from motivml.documents.loader import MAX_DEPTH, Document, _index, load_bytes, load_file, parse
from motivml.errors import DocumentError, EnvironmentProblem, MotivmlError, format_path


def message(text: str) -> str:
    with pytest.raises(DocumentError) as info:
        parse(text, "f.json")
    (diagnostic,) = info.value.diagnostics
    return f"{diagnostic.location}: {diagnostic.message}"


def test_values_and_positions() -> None:
    doc = parse('{\n  "a": [1, 2.5, {"b": null}],\n  "c": "x\\u00e9"\n}', "f.json")
    assert doc.root == {"a": [1, 2.5, {"b": None}], "c": "xé"}
    assert str(doc.locate(("a",))) == "f.json:2:8"
    assert str(doc.locate(("a",), key=True)) == "f.json:2:3"
    assert str(doc.locate(("a", 2, "b"))) == "f.json:2:23"
    assert doc.locate(("a", 2, "b")).path == "$.a[2].b"
    assert str(doc.locate(("c",))) == "f.json:3:8"


def test_missing_path_points_at_deepest_existing_node() -> None:
    doc = parse('{"a": {"b": 1}}', "f.json")
    assert str(doc.locate(("a", "zz"))) == "f.json:1:7"


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ('{"a": 1, "a": 2}', "f.json:1:10: duplicate key 'a' (first at line 1, column 2)"),
        ("[NaN]", "f.json:1:2: NaN is not valid JSON (use a number or null)"),
        ("[-Infinity]", "f.json:1:2: -Infinity is not valid JSON (use a number or null)"),
        ("[1e999]", "f.json:1:2: number 1e999 is out of range"),
        ("[1,]", "f.json:1:4: expected a value, found ']'"),
        ('{"a" 1}', "f.json:1:6: expected ':' after an object key"),
        ("[1] 2", "f.json:1:5: extra data after the end of the document"),
        ('{"a": "\x01"}', "f.json:1:8: invalid string: invalid control character"),
        ('{"a": "abc', "f.json:1:7: invalid string: unterminated string"),
        ('["\\x"]', "f.json:1:3: invalid string: invalid \\escape"),
        ("", "f.json:1:1: unexpected end of document"),
        ("[tru]", "f.json:1:2: unexpected text 'tru]'"),
        ("[01]", "f.json:1:2: unexpected text '01]'"),
        ("{,}", "f.json:1:2: expected a string key in double quotes"),
        ("[1 2]", "f.json:1:4: expected ',' or ']'"),
        ("\n\n  {]", "f.json:3:4: expected a string key in double quotes"),
    ],
)
def test_refusals_are_located(text: str, expected: str) -> None:
    assert message(text) == expected


def test_invalid_utf8_is_located() -> None:
    with pytest.raises(DocumentError) as info:
        load_bytes(b'{"a":\n "\xff"}', "f.json")
    assert str(info.value) == "f.json:2:3: not valid UTF-8 (byte 0xff at offset 8)"


def test_bom_is_skipped() -> None:
    assert load_bytes(b'\xef\xbb\xbf{"a": 1}', "f.json").root == {"a": 1}


def test_size_limit() -> None:
    with pytest.raises(DocumentError) as info:
        load_bytes(b"[" + b" " * 100 + b"]", "f.json", max_bytes=50)
    assert str(info.value) == "f.json: file is 102 bytes, over the limit of 50 bytes"


def test_size_limit_of_a_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "big.json"
    path.write_text("[" + " " * 100 + "]")
    with pytest.raises(DocumentError) as info:
        load_file(path, max_bytes=50)
    assert info.value.diagnostics[0].message == "file is 102 bytes, over the limit of 50 bytes"


def test_missing_file_is_an_environment_problem(tmp_path) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(EnvironmentProblem) as info:
        load_file(tmp_path / "nope.json")
    assert info.value.diagnostics[0].message == "no such file or folder"
    assert info.value.exit_code == 3


def deep(levels: int) -> str:
    return '{"sub": [' * levels + "1" + "]}" * levels


def test_deep_document_parses_and_locates() -> None:
    doc = parse(deep(2500), "f.json")  # 5,000 JSON levels: a 2,500-feature-deep model
    node = doc.root
    path: list[str | int] = []
    for _ in range(2500):
        node = node["sub"][0]
        path += ["sub", 0]
    assert node == 1
    assert doc.locate(tuple(path)).column == 2500 * 9 + 1


def test_too_deep_document_is_refused_cleanly() -> None:
    with pytest.raises(DocumentError) as info:
        parse("[" * 100_000 + "]" * 100_000, "f.json")
    assert str(info.value) == (
        f"f.json:1:{MAX_DEPTH + 1}: nesting deeper than {MAX_DEPTH:,} levels (the limit for a document)"
    )


def _nested(depth: int, kind: str) -> str:
    """`depth` levels of arrays, of objects with a number at the bottom, or of both."""
    if kind == "arrays":
        return "[" * depth + "]" * depth
    if kind == "objects":
        return '{"a":' * depth + "1" + "}" * depth
    opening = ['{"k":' if level % 2 else "[" for level in range(depth)]
    return "".join(opening) + "1.5" + "".join("}" if level % 2 else "]" for level in reversed(range(depth)))


@pytest.mark.parametrize("kind", ["arrays", "objects", "both"])
@pytest.mark.parametrize("limit", [3, 64, 2000, MAX_DEPTH])
def test_the_depth_limit_is_kept_by_the_fast_decoder_itself(
    kind: str, limit: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Up to the limit documents are read, and near it by the C decoder (with the real
    limits, without a walk of the value); one level deeper they are refused, and the
    located parser says where. (Limits under the interpreter's recursion limit, and
    Pythons from 3.12, whose C recursion limit is their own, have the depth measured by a
    walk; at the limit itself the decoder's calls of our hooks for the innermost values
    may take it over, and the located parser reads the document.)"""
    assert parse(_nested(limit, kind), "f.json", limit).root is not None
    if sys.version_info < (3, 12) and limit > sys.getrecursionlimit():
        monkeypatch.setattr(loader, "_PROBED", 0)  # as for a big document
        monkeypatch.setattr(loader, "_depth", lambda value: pytest.fail("the depth was walked"))
        # (8 levels below: the calls of our hooks at the innermost values take one or two,
        # and a tracer such as coverage's one more for each)
        near = parse(_nested(limit - 8, kind), "f.json", limit)
        assert near._index is None  # read by the C decoder
    with pytest.raises(DocumentError, match=f"nesting deeper than {limit:,} levels"):
        parse(_nested(limit + 1, kind), "f.json", limit)


def test_format_path() -> None:
    assert format_path(("sub", 0, "constraints", "x y")) == '$.sub[0].constraints["x y"]'


json_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers()
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text()
    | st.sampled_from(['"[{', "\\", '}]\\"', "ü]"]),  # brackets, quotes and backslashes in strings
    lambda children: st.lists(children) | st.dictionaries(st.text(), children),
    max_leaves=30,
)


@settings(max_examples=200, deadline=None)
@given(json_values)
def test_agrees_with_stdlib_json(value: object) -> None:
    text = json.dumps(value)
    assert parse(text).root == json.loads(text)


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet='{}[],:"\\ 0123456789.eE+-truefalsnNaIiy\n\x01', max_size=40))
def test_arbitrary_text_never_crashes(text: str) -> None:
    try:
        doc = parse(text, "f.json")
    except MotivmlError as exc:
        assert exc.diagnostics[0].location.line is not None
    else:
        assert doc.root == json.loads(text)


def test_lone_surrogate_is_refused() -> None:
    assert (
        message('{"a": "\\ud800"}')
        == "f.json:1:7: invalid string: a lone surrogate escape (\\ud800-\\udfff) is not text"
    )
    assert parse('{"a": "\\ud83d\\ude00"}').root == {"a": "\U0001f600"}


def test_overlong_integer_is_refused() -> None:
    assert message('{"x": ' + "9" * 5000 + "}") == "f.json:1:7: number of 5,000 digits is too long"


def test_a_named_pipe_is_not_read(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import os

    fifo = tmp_path / "f.json"
    os.mkfifo(fifo)
    with pytest.raises(EnvironmentProblem) as info:
        load_file(fifo)
    assert info.value.diagnostics[0].message == "is not a regular file"


# ---------------------------------------------------------------- locating without an index
def _paths(value: Any, prefix: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    yield prefix
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _paths(item, (*prefix, key))
        yield (*prefix, "no such key")
    elif isinstance(value, list):
        for position, item in enumerate(value):
            yield from _paths(item, (*prefix, position))
        yield (*prefix, len(value))


@settings(max_examples=300, deadline=None)
@given(
    json_values,
    st.sampled_from([None, 0, 1, 2]),
    st.booleans(),
    st.booleans(),
    st.booleans(),
    st.sampled_from([0, 40, loader.READ_BUDGET]),
)
def test_a_location_found_by_scanning_is_the_located_parsers(
    value: Any, indent: int | None, ascii: bool, big: bool, ready: bool, budget: int
) -> None:
    """Locations in a document the C decoder read are found by scanning only the containers
    on their path; each is where the located parser (which reads everything) puts it. (`big`:
    brackets matched as for a big document, with numpy; `ready`: matched beforehand;
    `budget`: containers read to their end until that many characters were read, then all
    brackets matched.)"""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(loader, "READ_BUDGET", budget)
        if big:
            patch.setattr(loader, "_BIG", 0)
        _check_scanned_locations(value, json.dumps(value, indent=indent, ensure_ascii=ascii), ready)


def _check_scanned_locations(value: Any, text: str, ready: bool = False) -> None:
    scanned, indexed = parse(text), Document("<string>", value, text, _index(text))
    if ready:
        scanned.ready_to_locate()
        assert scanned._ends is not None or scanned._index is not None  # (the located parser indexed it all)
    paths = list(_paths(value))
    for path in paths:
        for key in (False, True):
            assert scanned.locate(list(path), key) == indexed.locate(list(path), key), (path, key)
    backwards = parse(text)  # the last members first: the scan then reads each container once
    for path in reversed(paths):
        assert backwards.locate(list(path)) == indexed.locate(list(path)), path
    if "\\u" not in text:  # (a \\uD800-style escape sends a document to the located parser)
        assert scanned._index is None and backwards._index is None  # nothing read it all


def test_a_walk_that_stopped_early_is_gone_on_from_only_as_far_as_it_went() -> None:
    """A path that runs past the document stops where it ends; the next walk reuses the
    values of that one only up to there. Each location is the one a fresh document gives."""
    text = '{"a": {"b": [1, {"c": 2, "e": [3, 4]}], "f": 5}, "d": 6}'
    document = parse(text)
    paths = [
        ("a", "b", 1, "c"),
        ("a", "b", 7),
        ("a", "b", 7, "x"),
        ("a", "b", 7, "x", 1),  # (not b's second value: the walk stops at 7)
        ("a", "b", 1, "c"),
        ("a", "b", 7, "c"),
        ("a", "x", "y"),
        ("a", "b", 1, "e", 1),
        ("a", "b", 1, "e", 9),
        ("a", "b", 1, "e", 1),
        ("d",),
        ("a", "f"),
    ]
    for key in (False, True):
        for path in paths:
            assert document.locate(path, key) == parse(text).locate(path, key), (path, key)


def test_containers_are_read_to_their_end_until_the_budget_is_spent_then_all_brackets_matched(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    text = json.dumps({"first": [[k] for k in range(100)], "second": {"a": [1]}})
    where = parse(text).locate(["second", "a"])
    near = parse(text)
    assert near.locate(["second", "a"]) == where and near._ends is None  # (read: 800 characters)
    monkeypatch.setattr(loader, "READ_BUDGET", 100)
    far = parse(text)
    assert far.locate(["second", "a"]) == where and far._ends is not None

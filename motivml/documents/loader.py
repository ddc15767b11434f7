"""Located JSON loading.

The standard `json` module forgets where values came from, accepts duplicate keys, NaN and
Infinity, and recurses in C (a model nested ~2,000 features deep is ~4,000 JSON levels, past
Python's default recursion limit). Values come from that C decoder all the same (it is fast),
run on a thread with a large stack and with hooks that refuse duplicate keys and NaN; when it
refuses or fails, and whenever a message needs a position, a small iterative parser over a
regular-expression tokenizer reads the text again. That parser

* keeps the offset of every key and value, so any JSON path can be turned into
  `file:line:col` (lines and columns are computed only when a message needs them);
* rejects duplicate keys, NaN/Infinity (and numbers that overflow to them), invalid UTF-8,
  control characters in strings, and trailing data;
* refuses files larger than `MAX_BYTES` and nesting deeper than `MAX_DEPTH` with a clear
  message instead of exhausting memory or the stack.

Limits (documented in guidelines/validating.md): 64 MiB per document and 10,000 levels of
JSON nesting (a feature is two levels: its object and its `sub` array, so ~5,000 feature
levels).
"""

from __future__ import annotations

import bisect
import json
import os
import re
import stat
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ..errors import DocumentError, EnvironmentProblem, JSONPath, Location, error
from ..process import no_gc

MAX_BYTES = 64 * 1024 * 1024
MAX_DEPTH = 10_000


_TOKEN = re.compile(
    r"""[ \t\n\r]*(?:
      ("(?:[^"\\\x00-\x1f]|\\.)*")      # 1 string (escapes decoded by json.scanstring)
    | ([{}\[\],:])                        # 2 punctuation
    | (-?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?(?:[eE][-+]?[0-9]+)?)(?![0-9A-Za-z_.+-])  # 3 number
    | (true|false|null)(?![0-9A-Za-z_])   # 4 literal
    | (-?(?:NaN|Infinity))                # 5 not JSON
    | (\Z)                                # 6 end of text
    )""",
    re.VERBOSE | re.DOTALL,
)
_LITERALS: dict[str, Any] = {"true": True, "false": False, "null": None}
_SURROGATE = re.compile(r"\\u[dD][89a-fA-F]")


class Document:
    """A parsed JSON document that can say where each value and key stands.

    The values come from the C decoder of the `json` module (fast; run on a thread with a
    large stack so deep documents parse). Positions are needed only when a message is
    written, so the located parser of this module indexes the text the first time a
    location is asked for.
    """

    def __init__(self, file: str, root: Any, text: str, index: _Index | None = None) -> None:
        self.file = file
        self.root = root
        self.text = text
        self._index = index
        self._line_starts: list[int] | None = None
        # id(container) -> what a scan of its text found so far (`_member`): located
        # messages read only the containers on their paths, not the whole document
        self._scans: dict[int, _Scan] = {}
        self._ends: Callable[[int], int] | None = None  # a container's offset -> the offset after it
        self._budget = READ_BUDGET  # characters `_read_to_end` may still read
        # the last path walked through the values and the values on it (`_scanned_offset`)
        self._walk: tuple[JSONPath, list[Any]] | None = None

    def _indexed(self) -> _Index:
        if self._index is None:
            self._index = _index(self.text, self.file, MAX_DEPTH + 1)
        return self._index

    def ready_to_locate(self) -> None:
        """Do now what the first located message would do (index the brackets of a big
        text, which imports numpy; find the line starts): for a process with time to spare
        before its messages are asked for."""
        if self._index is None and self._ends is None:  # (the C decoder read it: valid JSON)
            self._ends = _bracket_ends(self.text)
        self.position(0)

    def position(self, offset: int) -> tuple[int, int]:
        """1-based (line, column) of a character offset."""
        if self._line_starts is None:
            self._line_starts = [0] + [m.end() for m in re.finditer("\n", self.text)]
        line = bisect.bisect_right(self._line_starts, offset)
        return line, offset - self._line_starts[line - 1] + 1

    def _offset(self, path: JSONPath, key: bool) -> int:
        if self._index is None:  # (the C decoder read it: the text is valid JSON)
            return self._scanned_offset(path, key)
        index = self._indexed()
        node, offset = index.root, index.root_offset
        for i, item in enumerate(path):
            table = index.offsets.get(id(node))
            if table is None:
                break
            try:
                if isinstance(node, dict):
                    key_offset, offset = table[item]
                    if key and i == len(path) - 1:
                        return int(key_offset)
                else:
                    offset = table[item]
                node = node[item]
            except (KeyError, IndexError, TypeError):
                break
        return int(offset)

    def _scanned_offset(self, path: JSONPath, key: bool) -> int:
        """`_offset` for a document the C decoder read (valid JSON): the text of each
        container on the path is scanned up to the member asked for, and no further.

        The walk starts at the deepest container of the path an earlier walk scanned (its
        `_Scan` knows where it opens): messages about one feature deep in a model share
        most of their paths."""
        steps = tuple(path[: len(path) - 1 if key else len(path)])
        # the values on the path, from those of the last walk as far as the paths agree
        # (two messages about features deep in a model share thousands of steps)
        walked, known = self._walk or ((), [self.root])
        same = _common_prefix(steps, walked)
        nodes = known[: same + 1]
        for item in steps[same:]:
            node = nodes[-1]
            if isinstance(node, dict) and isinstance(item, str) and item in node:
                nodes.append(node[item])
            elif isinstance(node, list) and isinstance(item, int) and 0 <= item < len(node):
                nodes.append(node[item])
            else:
                break
        self._walk = (steps[: len(nodes) - 1], nodes)
        scans = self._scans
        start = next((j for j in range(len(nodes) - 1, 0, -1) if id(nodes[j]) in scans), 0)
        node = nodes[start]
        offset = scans[id(node)].opening if start else _WHITESPACE.match(self.text).end()  # type: ignore[union-attr]
        for i, item in enumerate(path[start:], start):
            if not isinstance(node, (dict, list)):
                break
            found = self._member(node, offset, item)
            if found is None:
                break
            key_offset, offset = found
            if key and i == len(path) - 1 and isinstance(node, dict):
                return key_offset
            node = node[item]  # type: ignore[index]
        return offset

    def _member(self, node: dict[str, Any] | list[Any], start: int, item: str | int) -> tuple[int, int] | None:
        """(key offset, value offset) of `node[item]`, whose text begins at `start`; None if
        absent. (A list's member has no key: both offsets are its value's.)"""
        is_dict = isinstance(node, dict)
        if not isinstance(item, str if is_dict else int) or (not is_dict and item < 0):  # type: ignore[operator]
            return None
        scan = self._scans.get(id(node))
        if scan is None:
            scan = self._scans[id(node)] = _Scan(start, start + 1)
        keys, values = scan.keys, scan.values
        text, space = self.text, _WHITESPACE.match
        while True:
            if is_dict:
                if item in keys:
                    return keys[item]
            elif item < len(values):  # type: ignore[operator]
                offset = values[item]  # type: ignore[index]
                return offset, offset
            if scan.done:
                return None
            pos = scan.position if scan.pending is None else self._skip(scan.pending)
            scan.pending = None
            pos = space(text, pos).end()  # type: ignore[union-attr]
            if text[pos] == ",":
                pos = space(text, pos + 1).end()  # type: ignore[union-attr]
            if text[pos] in "]}":
                scan.done = True
                continue
            if is_dict:
                name, after = _scanstring(text, pos + 1, True)
                value = space(text, space(text, after).end() + 1).end()  # type: ignore[union-attr]
                keys[name] = (pos, value)
            else:
                value = pos
                values.append(value)
            scan.pending = scan.position = value

    def _skip(self, start: int) -> int:
        """The offset just after the value that begins at `start`."""
        text = self.text
        first = text[start]
        if first == '"':
            return int(_scanstring(text, start + 1, True)[1])
        if first in "[{":
            if self._ends is None:
                end = self._read_to_end(start)
                if end is not None:
                    return end
                self._ends = _bracket_ends(text)
            return self._ends(start)
        return _SCALAR_END.match(text, start).end()  # type: ignore[union-attr]

    def _read_to_end(self, start: int) -> int | None:
        """The offset just after the container that begins at `start`, found by reading its
        text, while the document's reading budget (READ_BUDGET characters in all) lasts;
        None once it is spent (all brackets are then matched at once, `_bracket_ends`).
        Messages about the first part of a big document so cost no index of all of it (at
        100,000 features, 0.1 s and the import of numpy)."""
        depth, budget = 0, self._budget
        for match in _SKIPPED.finditer(self.text, start):
            if match.start() - start > budget:
                break
            token = match.group()
            if token in "[{":
                depth += 1
            elif token in "]}":
                depth -= 1
                if not depth:
                    self._budget -= match.end() - start
                    return match.end()
        self._budget = 0
        return None

    def locate(self, path: JSONPath, key: bool = False) -> Location:
        """Location of the value at `path` (or of its key, with `key=True`).

        A path that runs past the document stops at the deepest node that exists, so a
        message about a missing key points at the object that lacks it.
        """
        line, column = self.position(self._offset(path, key))
        return Location(self.file, line, column, tuple(path))

    def locate_in_string(self, path: JSONPath, index: int) -> Location:
        """Location of character `index` of the string value at `path` (its escapes counted as
        written: `\\n` is two characters of the text, one of the value)."""
        text = self.text
        offset = self._offset(path, False)
        if not text.startswith('"', offset):
            return self.locate(path)
        raw = offset + 1
        for _ in range(index):
            if text[raw] != "\\":
                raw += 1
            elif text[raw + 1] != "u":
                raw += 2
            elif 0xD800 <= int(text[raw + 2 : raw + 6], 16) < 0xDC00 and text.startswith("\\u", raw + 6):
                raw += 12  # a surrogate pair: one character of the value
            else:
                raw += 6
        line, column = self.position(raw)
        return Location(self.file, line, column, tuple(path))


def _common_prefix(a: JSONPath, b: JSONPath) -> int:
    """How many first steps two paths share (by halving, each comparison in C)."""
    low, high = 0, min(len(a), len(b))
    while low < high:
        middle = (low + high + 1) // 2
        if a[:middle] == b[:middle]:
            low = middle
        else:
            high = middle - 1
    return low


@dataclass
class _Scan:
    """How far the text of one container has been read: where it opens, its members'
    offsets so far (an object's keys to (key offset, value offset), an array's value
    offsets), where the next member's text begins (after the value at `pending`, once that
    is skipped), and whether the closing bracket was reached."""

    opening: int  # where the container's text begins (its bracket)
    position: int
    keys: dict[str, tuple[int, int]] = field(default_factory=dict)
    values: list[int] = field(default_factory=list)
    pending: int | None = None
    done: bool = False


_WHITESPACE = re.compile(r"[ \t\n\r]*")
_SKIPPED = re.compile(r'"(?:[^"\\]|\\.)*"|[\[\]{}]')  # strings and brackets (inside a container)
_SCALAR_END = re.compile(r"[^,\]} \t\n\r]*")
_scanstring = json.decoder.scanstring  # type: ignore[attr-defined]


READ_BUDGET = 1 << 18  # characters read to skip containers before all brackets are matched
_BIG = 1 << 20  # characters: above this, brackets are matched with numpy


def _bracket_ends(text: str) -> Callable[[int], int]:
    """For valid JSON: a function from the offset of each '[' or '{' to the offset just after
    its matching bracket, from one pass over the text (C speed with numpy for big texts)."""
    if len(text) < _BIG:
        ends: dict[int, int] = {}
        opened: list[int] = []
        for match in _SKIPPED.finditer(text):
            token = match.group()
            if token in "[{":
                opened.append(match.start())
            elif token in "]}":
                ends[opened.pop()] = match.end()
        return ends.__getitem__
    import numpy as np

    if text.isascii():
        chars = np.frombuffer(text.encode("ascii"), dtype=np.uint8)
    else:  # one element per character, so that positions are the text's own
        chars = np.frombuffer(text.encode("utf-32-le"), dtype=np.uint32)
    quotes = np.flatnonzero(chars == ord('"'))
    # A quote is escaped when an odd number of backslashes precedes it (rare: in Python).
    after_backslash = quotes[chars[np.maximum(quotes - 1, 0)] == ord("\\")]
    escaped = []
    for quote in after_backslash.tolist():
        start = quote - 1
        while start >= 0 and text[start] == "\\":
            start -= 1
        if (quote - 1 - start) % 2:
            escaped.append(quote)
    if escaped:
        quotes = np.setdiff1d(quotes, np.array(escaped, dtype=quotes.dtype), assume_unique=True)
    brackets = np.flatnonzero(
        (chars == ord("[")) | (chars == ord("{")) | (chars == ord("]")) | (chars == ord("}"))
    )
    brackets = brackets[np.searchsorted(quotes, brackets) % 2 == 0]  # outside strings
    opening = (chars[brackets] == ord("[")) | (chars[brackets] == ord("{"))
    depth = np.cumsum(np.where(opening, 1, -1))
    level = np.where(opening, depth, depth + 1)  # an open and its close share a level
    if len(level) and level.max() < np.iinfo(np.int16).max:
        level = level.astype(np.int16)  # (a stable sort of small integers is a radix sort)
    order = np.argsort(level, kind="stable")  # by level, then position: open, close, open, ...
    stops = np.zeros_like(brackets)  # for each opening bracket, the offset after its closing one
    stops[order[0::2]] = brackets[order[1::2]] + 1

    def end(offset: int) -> int:
        return int(stops[np.searchsorted(brackets, offset)])

    return end


@dataclass
class _Index:
    root: Any
    root_offset: int
    # id(container) -> {key: (key_offset, value_offset)} for objects, [value_offset] for arrays
    offsets: dict[int, Any]


def _fail(text: str, file: str, offset: int, message: str, rule: str = "json") -> DocumentError:
    line, column = Document(file, None, text).position(offset)
    return DocumentError(error(Location(file, line, column), message, rule))


def _index(text: str, file: str = "<string>", max_depth: int = MAX_DEPTH) -> _Index:
    """The located parser: values plus the offset of every key and value.

    Iterative, so nesting costs heap, not stack. About 4x slower than the C decoder, so it
    runs only to explain bad input or to locate a message.
    """
    offsets: dict[int, Any] = {}
    # Each frame: [container, pending key, pending key offset]
    stack: list[list[Any]] = []
    root: Any = None
    root_offset = 0
    done = False
    expect_value = True  # next token must start a value
    after_open = False  # just saw '{' or '[' (a closing bracket is allowed)
    expect_colon = False
    match = _TOKEN.match
    scanstring = json.decoder.scanstring  # type: ignore[attr-defined]
    pos = 0
    n = len(text)

    while True:
        m = match(text, pos)
        if m is None:
            start = pos
            while start < n and text[start] in " \t\n\r":
                start += 1
            if start < n and text[start] == '"':
                try:
                    scanstring(text, start + 1, True)
                except json.JSONDecodeError as exc:
                    raise _string_error(text, file, exc) from None
            snippet = text[start : start + 12].split("\n")[0]
            raise _fail(text, file, start, f"unexpected text {snippet!r}")
        pos = m.end()
        kind = m.lastindex
        start = m.start(kind) if kind else pos

        if done:
            if kind == 6:
                break
            raise _fail(text, file, start, "extra data after the end of the document")
        if kind == 6:
            raise _fail(text, file, start, "unexpected end of document")
        if kind == 5:
            raise _fail(text, file, start, f"{m.group(5)} is not valid JSON (use a number or null)")

        if expect_colon:
            if kind == 2 and m.group(2) == ":":
                expect_colon = False
                expect_value = True
                continue
            raise _fail(text, file, start, "expected ':' after an object key")

        frame = stack[-1] if stack else None
        token = m.group(2) if kind == 2 else None

        # An object waiting for a key (after '{' or ',').
        if frame is not None and isinstance(frame[0], dict) and frame[1] is None and expect_value:
            if token == "}" and after_open:
                value = stack.pop()[0]
                after_open = False
                expect_value = False
                done = not stack
                if done:
                    root = value
                continue
            if kind != 1:
                raise _fail(text, file, start, "expected a string key in double quotes")
            raw = m.group(1)
            key = raw[1:-1] if "\\" not in raw else _decode(text, file, start)
            container = frame[0]
            if key in container:
                first = offsets[id(container)][key][0]
                line, col = Document(file, None, text).position(first)
                raise _fail(text, file, start, f"duplicate key {key!r} (first at line {line}, column {col})")
            frame[1] = key
            frame[2] = start
            after_open = False
            expect_colon = True
            continue

        if expect_value:
            if token == "]" and after_open:
                value = stack.pop()[0]
                after_open = False
                expect_value = False
                done = not stack
                if done:
                    root = value
                continue
            after_open = False
            if kind == 1:
                raw = m.group(1)
                value = raw[1:-1] if "\\" not in raw else _decode(text, file, start)
            elif kind == 3:
                literal = m.group(3)
                if "." in literal or "e" in literal or "E" in literal:
                    value = float(literal)
                    if value in (float("inf"), float("-inf")):
                        raise _fail(text, file, start, f"number {literal} is out of range")
                elif len(literal) > 4000:  # Python refuses to convert longer ones
                    raise _fail(text, file, start, f"number of {len(literal):,} digits is too long")
                else:
                    value = int(literal)
                    if len(literal) > 300 and abs(value) > sys.float_info.max:
                        raise _fail(text, file, start, f"number of {len(literal):,} digits is out of range")
            elif kind == 4:
                value = _LITERALS[m.group(4)]
            elif token in ("{", "["):
                if len(stack) >= max_depth:
                    raise _fail(
                        text,
                        file,
                        start,
                        f"nesting deeper than {max_depth:,} levels (the limit for a document)",
                        "limits",
                    )
                value = {} if token == "{" else []
                offsets[id(value)] = {} if token == "{" else []
                _attach(stack, offsets, value, start)
                if not stack:
                    root_offset = start
                stack.append([value, None, 0])
                after_open = True
                continue
            else:
                raise _fail(text, file, start, f"expected a value, found {token!r}")
            _attach(stack, offsets, value, start)
            expect_value = False
            if not stack:
                root, root_offset, done = value, start, True
            continue

        # After a value inside a container: ',' or the closing bracket.
        assert frame is not None
        closing = "}" if isinstance(frame[0], dict) else "]"
        if token == ",":
            expect_value = True
            continue
        if token == closing:
            value = stack.pop()[0]
            done = not stack
            if done:
                root = value
            continue
        raise _fail(text, file, start, f"expected ',' or '{closing}'")

    return _Index(root, root_offset, offsets)


class _Rejected(Exception):
    """The fast decoder met something we refuse; the located parser says what and where."""


def _pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result = dict(pairs)
    if len(result) != len(pairs):
        raise _Rejected
    return result


def _constant(name: str) -> Any:
    raise _Rejected


def _int(literal: str) -> int:
    value = int(literal)  # (longer than 4300 digits: ValueError, and the located parser says so)
    if len(literal) > 300 and abs(value) > sys.float_info.max:
        raise _Rejected  # no number this tool computes with can be that large
    return value


def _float(literal: str) -> float:
    value = float(literal)
    if value in (float("inf"), float("-inf")):
        raise _Rejected
    return value


_STACK_BYTES = 512 * 1024 * 1024
_parse_lock = threading.Lock()


_PROBED = 256 * 1024  # characters: from here the depth limit is left to the decoder (probes cost ~3 ms)
_overhead: int | None = None  # recursion levels the decoder's thread uses before the document's first container


def _fast(text: str, max_depth: int) -> tuple[bool, Any]:
    """Decode with the C `json` decoder on a thread with a large stack.

    Returns (ok, value). Anything unusual (a refusal, a syntax error, nesting beyond the
    recursion allowance) returns ok=False and the located parser takes over. The
    recursion limit is set so that the decoder itself refuses nesting deeper than
    `max_depth` (each container is one level of its recursion), checked on probes at the
    limit; where that cannot be (a `max_depth` under the process's recursion limit, or a
    Python whose C recursion limit is its own), the depth is measured by a walk.
    """
    result: list[Any] = [False, None, False]  # ok, value, nesting held by the recursion limit

    def attempt(document: str) -> tuple[bool, Any]:
        try:
            return True, json.loads(
                document, object_pairs_hook=_pairs, parse_constant=_constant, parse_float=_float, parse_int=_int
            )
        except (_Rejected, ValueError, RecursionError, MemoryError):
            return False, None

    def run() -> None:
        # Probes and the document take the same path to the decoder (run -> attempt): the
        # levels of recursion used before the document's first container are the same.
        global _overhead
        if len(text) < _PROBED:  # the walk of a small value costs less than the probes
            result[0], result[1] = attempt(text)
            return
        if _overhead is None:  # (once: the path does not change)
            limit = deepest = sys.getrecursionlimit()
            while deepest > limit - 200 and not attempt("[" * deepest + "]" * deepest)[0]:
                deepest -= 1
            _overhead = limit - deepest if deepest > limit - 200 else -1
        # (Never below the limit the process had: its other threads run under it too.)
        if _overhead >= 0 and max_depth + _overhead >= previous_limit:
            sys.setrecursionlimit(max_depth + _overhead)
            at, beyond = max_depth, max_depth + 1
            result[2] = attempt("[" * at + "]" * at)[0] and not attempt("[" * beyond + "]" * beyond)[0]
            if not result[2]:
                sys.setrecursionlimit(max_depth + 200 + _overhead)
        result[0], result[1] = attempt(text)

    previous_limit = sys.getrecursionlimit()
    with _parse_lock:  # the recursion limit and thread stack size are process-wide
        old_limit, old_stack = sys.getrecursionlimit(), threading.stack_size()
        try:
            sys.setrecursionlimit(max(old_limit, max_depth + 200))
            threading.stack_size(_STACK_BYTES)
            worker = threading.Thread(target=run, name="motivml-json")
            worker.start()
        finally:
            threading.stack_size(old_stack)
        worker.join()
        sys.setrecursionlimit(old_limit)
    ok, value, held = result
    if ok and not held and _depth(value) > max_depth:
        return False, None
    return ok, value


def _depth(value: Any) -> int:
    best, stack = 0, [(value, 1)]
    while stack:
        node, d = stack.pop()
        if isinstance(node, dict):
            node = list(node.values())
        if isinstance(node, list):
            best = max(best, d)
            stack.extend((child, d + 1) for child in node if isinstance(child, (dict, list)))
    return best


def parse(text: str, file: str = "<string>", max_depth: int = MAX_DEPTH) -> Document:
    """Parse JSON text into a `Document`; raise `DocumentError` with a location on bad input."""
    with no_gc():
        # A \uD800-\uDFFF escape may be a lone surrogate, which the C decoder lets through.
        ok, root = (False, None) if _SURROGATE.search(text) else _fast(text, max_depth)
        if ok:
            return Document(file, root, text)
    index = _index(text, file, max_depth)
    return Document(file, index.root, text, index)


def _string_error(text: str, file: str, exc: json.JSONDecodeError) -> DocumentError:
    reason = exc.msg.removesuffix(" starting at").removesuffix(" at").lower()
    return _fail(text, file, exc.pos, f"invalid string: {reason}")


def _decode(text: str, file: str, start: int) -> str:
    """Decode a string token with escapes (the C scanner of the json module)."""
    try:
        value = str(json.decoder.scanstring(text, start + 1, True)[0])  # type: ignore[attr-defined]
    except json.JSONDecodeError as exc:
        raise _string_error(text, file, exc) from None
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise _fail(
            text, file, start, "invalid string: a lone surrogate escape (\\ud800-\\udfff) is not text"
        ) from None
    return value


def _attach(stack: list[list[Any]], offsets: dict[int, Any], value: Any, start: int) -> None:
    """Store a new value in the container on top of the stack, with its offsets."""
    if not stack:
        return
    frame = stack[-1]
    container = frame[0]
    table = offsets[id(container)]
    if isinstance(container, dict):
        key = frame[1]
        container[key] = value
        table[key] = (frame[2], start)
        frame[1] = None
    else:
        container.append(value)
        table.append(start)


def load_bytes(data: bytes, file: str, max_bytes: int = MAX_BYTES, max_depth: int = MAX_DEPTH) -> Document:
    """Decode UTF-8 (an optional BOM is skipped) and parse, within the size limit."""
    if len(data) > max_bytes:
        raise DocumentError(
            error(
                Location(file),
                f"file is {len(data):,} bytes, over the limit of {max_bytes:,} bytes",
                "limits",
            )
        )
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        prefix = data[: exc.start].decode("utf-8", errors="replace")
        line = prefix.count("\n") + 1
        column = len(prefix) - (prefix.rfind("\n") + 1) + 1
        raise DocumentError(
            error(
                Location(file, line, column),
                f"not valid UTF-8 (byte 0x{data[exc.start]:02x} at offset {exc.start})",
                "json",
            )
        ) from None
    return parse(text, file, max_depth)


def read_bytes(path: str | os.PathLike[str], max_bytes: int = MAX_BYTES, what: str = "a JSON file") -> bytes:
    """The bytes of a document: a regular file (not a folder, FIFO, device or link to
    nothing: an environment problem) of at most `max_bytes` (over it, a document error).
    Every document motivml reads comes through here, the ones `import` reads too."""
    name = os.fspath(path)
    try:
        info = os.stat(name)
        if os.path.isdir(name):
            raise IsADirectoryError
        if not stat.S_ISREG(info.st_mode):
            raise EnvironmentProblem(error(Location(name), "is not a regular file", "io"))
        size = info.st_size
        if size > max_bytes:
            raise DocumentError(
                error(
                    Location(name),
                    f"file is {size:,} bytes, over the limit of {max_bytes:,} bytes",
                    "limits",
                )
            )
        with open(name, "rb") as handle:
            data = handle.read(max_bytes + 1)
    except IsADirectoryError:
        raise EnvironmentProblem(error(Location(name), f"is a folder, not {what}", "io")) from None
    except FileNotFoundError:
        raise EnvironmentProblem(error(Location(name), "no such file or folder", "io")) from None
    except OSError as exc:
        raise EnvironmentProblem(error(Location(name), f"cannot read: {exc.strerror}", "io")) from None
    if len(data) > max_bytes:  # (it grew while read)
        raise DocumentError(error(Location(name), f"file is over the limit of {max_bytes:,} bytes", "limits"))
    return data


def load_file(
    path: str | os.PathLike[str], max_bytes: int = MAX_BYTES, max_depth: int = MAX_DEPTH
) -> Document:
    """Read and parse a JSON file; a missing or unreadable file is an environment problem."""
    return load_bytes(read_bytes(path, max_bytes), os.fspath(path), max_bytes, max_depth)

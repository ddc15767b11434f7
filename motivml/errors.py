"""Typed, located diagnostics and errors.

Every message a user sees carries where it comes from: file, line and column from the JSON
text, the JSON path, the feature it concerns (if any) and the rule it applies. Library code
builds `Diagnostic` values and raises `MotivmlError` subclasses holding them; only the CLI
turns them into text and exit codes.
"""

from __future__ import annotations

import functools
import json
import re
from dataclasses import dataclass, field
from enum import StrEnum

PathItem = str | int
JSONPath = tuple[PathItem, ...]  # a place inside a JSON document: keys and indices, from its root


def format_path(path: JSONPath) -> str:
    """`$.sub[0].constraints` style path, as users see it in messages."""
    return "$" + "".join(map(_path_part, path))


@functools.lru_cache(maxsize=4096, typed=True)  # paths thousands of steps deep repeat their steps
def _path_part(item: str | int) -> str:
    if isinstance(item, int):
        return f"[{item}]"
    if re.fullmatch(r"[A-Za-z_$][A-Za-z0-9_$-]*", item):
        return f".{item}"
    return f"[{json.dumps(item)}]"


class Severity(StrEnum):
    ERROR = "error"
    WARNING = "warning"


@dataclass(frozen=True)
class Location:
    """A place in a document: file, 1-based line and column, and the JSON path (`steps`,
    kept as keys and indices; `path` is how users see it)."""

    file: str
    line: int | None = None
    column: int | None = None
    steps: JSONPath = ()

    @property
    def path(self) -> str:
        return format_path(self.steps)

    def __str__(self) -> str:
        if self.line is None:
            return self.file
        return f"{self.file}:{self.line}:{self.column}"


@dataclass(frozen=True)
class LocatedFact:
    """One model or configuration fact of an explanation: in words, located, with its rule."""

    text: str
    location: Location
    rule: str

    def as_dict(self) -> dict[str, object]:
        where = self.location
        return {
            "file": where.file,
            "line": where.line,
            "column": where.column,
            "path": where.path,
            "rule": self.rule,
            "text": self.text,
        }


class ChangeKind(StrEnum):
    """What a repair changes of a feature: its selection, time or mode in a configuration;
    its load or unload in a run-time request."""

    SELECT = "select"
    TIME = "time"
    MODE = "mode"
    LOAD = "load"
    UNLOAD = "unload"


@dataclass(frozen=True)
class Change:
    """One change of a repair (reference.md section 6), in the user's words and as data.

    `change` is SELECT (value True or False), TIME (Early, Late) or MODE (Static, Dynamic)
    for a configuration; LOAD or UNLOAD (value True: add it to the request, False: take it
    out) for a run-time request."""

    feature: str
    change: ChangeKind
    value: bool | str
    text: str

    @property
    def verb(self) -> str:
        """The words before the feature in `text`: "deselect", "make", "also load" ..."""
        if self.change in (ChangeKind.TIME, ChangeKind.MODE):
            return "make"
        if self.change == ChangeKind.SELECT:
            return "select" if self.value else "deselect"
        return f"also {self.change}" if self.value else f"do not {self.change}"

    def as_dict(self) -> dict[str, object]:
        return {"feature": self.feature, "change": self.change, "value": self.value, "text": self.text}


Repair = tuple[Change, ...]


@dataclass(frozen=True)
class Diagnostic:
    """One error or warning: what, where, which feature, which rule, and (for a conflict)
    the smallest changes that would fix it, fewest first."""

    severity: Severity
    location: Location
    message: str
    rule: str
    feature: str | None = None
    facts: tuple[LocatedFact, ...] = field(default=())
    repairs: tuple[Repair, ...] = field(default=())

    def as_dict(self) -> dict[str, object]:
        return {
            "file": self.location.file,
            "line": self.location.line,
            "column": self.location.column,
            "path": self.location.path,
            "feature": self.feature,
            "rule": self.rule,
            "message": self.message,
            "facts": [f.as_dict() for f in self.facts],
            "repairs": [
                {"text": repair_text(r), "changes": [c.as_dict() for c in r]} for r in self.repairs
            ],
        }


def repair_text(repair: Repair) -> str:
    """A repair in one line: "make grid_map Static", "deselect slam and kartoslam",
    "make dmp_reach Dynamic and attractor_reach Dynamic Late"."""
    verbs: dict[str, list[str]] = {}  # verb -> objects, in the repair's order
    binding: dict[str, list[str]] = {}  # feature -> its new mode and time, for one "make"
    for c in repair:
        if c.change in (ChangeKind.TIME, ChangeKind.MODE):
            if c.feature not in binding:
                verbs.setdefault("make", []).append(c.feature)
            binding.setdefault(c.feature, []).append(str(c.value))
        else:
            verbs.setdefault(c.verb, []).append(c.feature)
    groups = []
    for verb, objects in verbs.items():
        if verb == "make":
            objects = [f"{f} {' '.join(sorted(binding[f], key=_MODE_FIRST.index))}" for f in objects]
        groups.append((verb, _and(objects)))
    between = "; " if any(len(objects) > 1 for objects in verbs.values()) else " and "
    return between.join(f"{verb} {objects}" for verb, objects in groups)


_MODE_FIRST = ["Static", "Dynamic", "Early", "Late"]  # "Static Early", as bindings are spoken


def _and(parts: list[str]) -> str:
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


class MotivmlError(Exception):
    """Base of all errors motivml raises on purpose; carries located diagnostics."""

    exit_code = 1

    def __init__(self, diagnostics: list[Diagnostic] | Diagnostic) -> None:
        if isinstance(diagnostics, Diagnostic):
            diagnostics = [diagnostics]
        self.diagnostics = diagnostics
        super().__init__("; ".join(f"{d.location}: {d.message}" for d in diagnostics))


class DocumentError(MotivmlError):
    """A document cannot be read as JSON within our limits (syntax, encoding, size, depth)."""


class EnvironmentProblem(MotivmlError):
    """Something outside the documents is wrong: a missing file, an unreadable folder."""

    exit_code = 3


class Judged:
    """Something checked, judged by its diagnostics: a document's report, a fleet's robot."""

    diagnostics: list[Diagnostic]

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.severity is Severity.ERROR]

    @property
    def warnings(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.severity is Severity.WARNING]

    @property
    def valid(self) -> bool:
        return not self.errors


def error(location: Location, message: str, rule: str, feature: str | None = None) -> Diagnostic:
    return Diagnostic(Severity.ERROR, location, message, rule, feature)


def warning(location: Location, message: str, rule: str, feature: str | None = None) -> Diagnostic:
    return Diagnostic(Severity.WARNING, location, message, rule, feature)


def describe_exception(exc: BaseException, within: object = None) -> str:
    """`Type: first line` and the innermost frame that raised (inside folder `within`, if given)."""
    import traceback
    from pathlib import Path

    frames = list(traceback.extract_tb(exc.__traceback__))
    if within is not None:
        root = str(Path(str(within)).resolve())
        frames = [f for f in frames if str(Path(f.filename).resolve()).startswith(root)]
    inner = f" (at {Path(frames[-1].filename).name}:{frames[-1].lineno})" if frames else ""
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}{inner}"

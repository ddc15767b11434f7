"""Typed, located diagnostics and errors.

Every message a user sees carries where it comes from: file, line and column from the JSON
text, the JSON path, the feature it concerns (if any) and the rule it applies. Library code
builds `Diagnostic` values and raises `MotivmlError` subclasses holding them; only the CLI
turns them into text and exit codes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum


class Severity(StrEnum):
    ERROR = "error"
    WARNING = "warning"


@dataclass(frozen=True)
class Location:
    """A place in a document: file, 1-based line and column, and the JSON path."""

    file: str
    line: int | None = None
    column: int | None = None
    path: str = "$"

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


@dataclass(frozen=True)
class Diagnostic:
    """One error or warning: what, where, which feature, which rule."""

    severity: Severity
    location: Location
    message: str
    rule: str
    feature: str | None = None
    facts: tuple[LocatedFact, ...] = field(default=())

    def as_dict(self) -> dict[str, object]:
        return {
            "file": self.location.file,
            "line": self.location.line,
            "column": self.location.column,
            "path": self.location.path,
            "feature": self.feature,
            "rule": self.rule,
            "message": self.message,
            "facts": [
                {
                    "file": f.location.file,
                    "line": f.location.line,
                    "column": f.location.column,
                    "path": f.location.path,
                    "rule": f.rule,
                    "text": f.text,
                }
                for f in self.facts
            ],
        }


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

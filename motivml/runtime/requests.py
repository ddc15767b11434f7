"""What a client may ask of a running robot: plain data, cheap to import (the CLI parses with it).

A request is one of five small values, each saying what it moves: `Load`, `Unload` and
`Reload` name features, `Swap` the one to unload and the one to load, `Set` the ones to load
and the ones to unload in one reconfiguration (the ROS 2 node's parameters). An `Event` goes
to the coordination statechart and is kept apart: it changes no feature itself.

Every door parses with `parse`: `run --at`, `motivml ctl`, the control socket and the
statechart's actions, so a request means the same and is refused in the same words
wherever it comes from. (The ROS 2 node builds its `Set` directly: its parameters are
already features and values.)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar, TypeAlias

VERBS = ("load", "unload", "reload", "swap")  # the requests of `run --at` and `motivml ctl` that move features


class RequestError(ValueError):
    """A request that is not one: its message says what a request of that verb takes."""


@dataclass(frozen=True)
class _Features:
    """A request that names features, said as its verb and them."""

    features: tuple[str, ...]
    cause: str = ""  # why the run asked it itself (a fault), shown after the request
    verb: ClassVar[str] = ""

    def __str__(self) -> str:
        return _said(f"{self.verb} {' '.join(self.features)}", self.cause)


@dataclass(frozen=True)
class Load(_Features):
    """Load these features (each with its selected mandatory sub-features)."""

    verb: ClassVar[str] = "load"


@dataclass(frozen=True)
class Unload(_Features):
    """Unload these features (each with its subtree)."""

    verb: ClassVar[str] = "unload"


@dataclass(frozen=True)
class Reload(_Features):
    """Unload these features and load them again, their new implementations if changed."""

    verb: ClassVar[str] = "reload"


@dataclass(frozen=True)
class Swap:
    """Unload one feature and load another in one reconfiguration (run-time alternatives)."""

    out: str
    into: str
    cause: str = ""

    def __str__(self) -> str:
        return _said(f"swap {self.out} {self.into}", self.cause)


@dataclass(frozen=True)
class Set:
    """Load some features and unload others in one reconfiguration (the ROS 2 node's
    parameters: one call setting `features.<id>.active`, true or false, is one of these)."""

    loads: tuple[str, ...]
    unloads: tuple[str, ...] = ()
    cause: str = ""

    def __str__(self) -> str:
        text = " ".join(["set", *(f"+{f}" for f in self.loads), *(f"-{f}" for f in self.unloads)])
        return _said(text, self.cause)


Request: TypeAlias = Load | Unload | Reload | Swap | Set


@dataclass(frozen=True)
class Event:
    """An event to the coordination statechart."""

    name: str

    def __str__(self) -> str:
        return f"event {self.name}"


def parse(verb: str, words: Sequence[str]) -> Request | Event:
    """The request `verb words...` (as `run --at` and `motivml ctl` write it); RequestError
    says what is wrong with it."""
    if verb == "event":
        if len(words) != 1:
            raise RequestError("event needs one name")
        return Event(words[0])
    if verb not in VERBS:
        raise RequestError(f"unknown request {verb!r} (requests: {', '.join((*VERBS, 'event'))})")
    if verb == "swap":
        if len(words) != 2:
            raise RequestError("swap needs two features: the one to unload, then the one to load")
        return Swap(words[0], words[1])
    if not words:
        raise RequestError(f"{verb} needs at least one feature")
    if verb == "load":
        return Load(tuple(words))
    return Unload(tuple(words)) if verb == "unload" else Reload(tuple(words))


def change(verb: str, words: Sequence[str]) -> Request:
    """`parse` of a request that moves features (not an event)."""
    request = parse(verb, words)
    if isinstance(request, Event):
        raise RequestError(f"unknown request {verb!r} (requests: {', '.join(VERBS)})")
    return request


def named(request: Request) -> tuple[str, ...]:
    """Every feature the request names, in its order."""
    if isinstance(request, Swap):
        return (request.out, request.into)
    if isinstance(request, Set):
        return request.loads + request.unloads
    return request.features


def _said(text: str, cause: str) -> str:
    return f"{text} ({cause})" if cause else text

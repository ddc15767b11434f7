"""What happens in a run, typed: the vocabulary of its record, its log, its front doors and
the pictures drawn from it.

Each event has the tick it happened at, a kind (the word a record writes before it: `run`,
`change`, `refused`, `status`, `state`, `fault`, `missed`, `end`) and its text (what the
record writes after it). `parse` reads an event back from its kind and text, so that what
reads a record (`plot`) asks an event for its parts (`Refused.request`, `Faulted.feature`)
and its label, instead of cutting them out of the text. The run's log is typed too: a
`Note` is a line of it, stamped with the control time and the tick.

The runtime publishes every event to one list of `Listeners`, on the thread where it
happened: the recorder writes the recorded kinds; the live view prints the log (`Logged`)
and the changes; the ROS 2 door tells its node every answer of the binder (`Answered`).
`Logged` and `Answered` are not written to a record (`recorded` is False): the record keeps
what happened to the robot, not the run's words about it or the binder's replies.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from ..errors import describe_exception


class Note(NamedTuple):
    """A line of the run's log (`Runtime.note`): plugins' log(), refusals, faults, the coordination."""

    time: float  # control time, s
    tick: int
    text: str


@dataclass(frozen=True)
class RunEvent:
    """Something that happened at a tick of a run."""

    tick: int
    kind: ClassVar[str] = ""
    recorded: ClassVar[bool] = True  # a record writes it (its kind is one of KINDS)

    @property
    def text(self) -> str:
        raise NotImplementedError

    @property
    def label(self) -> str | None:
        """The words beside the event's line in a picture (None: a line only)."""
        return None


@dataclass(frozen=True)
class Started(RunEvent):
    description: str  # robot, variant, rate, clock and length
    kind: ClassVar[str] = "run"

    @property
    def text(self) -> str:
        return self.description


@dataclass(frozen=True)
class Changed(RunEvent):
    request: str  # an accepted reconfiguration, as it was asked for
    kind: ClassVar[str] = "change"

    @property
    def text(self) -> str:
        return self.request

    @property
    def label(self) -> str:
        return self.request


@dataclass(frozen=True)
class Refused(RunEvent):
    request: str  # a refused reconfiguration
    reason: str
    kind: ClassVar[str] = "refused"

    @property
    def text(self) -> str:
        return f"{self.request}: {self.reason}"

    @property
    def label(self) -> str:
        return f"refused {self.request}"


@dataclass(frozen=True)
class Faulted(RunEvent):
    feature: str
    error: str | None  # what its step raised; None: its stop() raised, at the end of the run
    kind: ClassVar[str] = "fault"

    @property
    def text(self) -> str:
        if self.error is None:
            return f"stop() of plugin {self.feature} raised"
        return f"{self.feature} raised in its step: {self.error}"

    @property
    def label(self) -> str:
        return f"fault: {self.feature}" if self.error is not None else f"fault: stop() of plugin {self.feature}"


@dataclass(frozen=True)
class StatusChanged(RunEvent):
    component: str  # a component whose criterion changed its verdict
    status: str
    kind: ClassVar[str] = "status"

    @property
    def text(self) -> str:
        return f"{self.component} {self.status}"

    @property
    def label(self) -> str:
        return self.text


@dataclass(frozen=True)
class StateChanged(RunEvent):
    entered: bool  # the coordination entered the state (False: exited it)
    state: str
    kind: ClassVar[str] = "state"

    @property
    def text(self) -> str:
        return f"{'entered' if self.entered else 'exited'} {self.state}"

    @property
    def label(self) -> str | None:
        return self.state if self.entered else None


@dataclass(frozen=True)
class Missed(RunEvent):
    deadlines: int  # skipped by the real clock after the tick
    kind: ClassVar[str] = "missed"

    @property
    def text(self) -> str:
        return f"{self.deadlines} deadline{'s' * (self.deadlines != 1)}"


@dataclass(frozen=True)
class Ended(RunEvent):
    why: str  # how the run ended, in a few words
    kind: ClassVar[str] = "end"

    @property
    def text(self) -> str:
        return self.why


@dataclass(frozen=True)
class Written(RunEvent):
    """An event read from a record whose text is not one this version writes for its kind
    (a record edited by hand, or written by another version): kept as it is."""

    written_kind: str
    written: str

    @property
    def text(self) -> str:
        return self.written


@dataclass(frozen=True)
class Logged(RunEvent):
    """A line written to the run's log (`Runtime.note`), as it is written."""

    note: Note
    kind: ClassVar[str] = "log"
    recorded: ClassVar[bool] = False

    @property
    def text(self) -> str:
        return self.note.text


@dataclass(frozen=True)
class Answered(RunEvent):
    """The binder's answer to a request (ctl's, a front door's, a scheduled one, a fault's
    unloads), accepted or refused, told on the requesting thread with the binder held: the
    answers reach a listener in the order the binder gave them."""

    request: str
    accepted: bool
    reason: str  # its diagnostics in words: why it was refused (when accepted: its warnings)
    loads: tuple[str, ...]  # what the plan loads and unloads (empty when it never got a plan)
    unloads: tuple[str, ...]
    active: frozenset[str]  # the active set after the answer
    change: tuple[int, str] | None  # the tick and request of the change it made, if any
    kind: ClassVar[str] = "answer"
    recorded: ClassVar[bool] = False

    @property
    def text(self) -> str:
        return self.request if self.accepted else f"{self.request}: {self.reason}"


class Listeners:
    """Who is told of a run's events (the recorder, and whoever else listens): each event is
    published on the thread it happened on, so a listener is quick and thread-safe (the
    recorder queues it). A listener's bug is said through `said`, never raised."""

    def __init__(self, said: Callable[[str], None]) -> None:
        self._listeners: list[Callable[[RunEvent], None]] = []
        self._said = said
        self._saying = threading.local()  # .now: this thread is saying a listener's bug

    def listen(self, listener: Callable[[RunEvent], None]) -> None:
        """Tell `listener` of every event from now on."""
        self._listeners.append(listener)

    def forget(self, listener: Callable[[RunEvent], None]) -> None:
        """Tell `listener` nothing more (nothing happens if it was not listening)."""
        if listener in self._listeners:
            self._listeners.remove(listener)

    def publish(self, event: RunEvent) -> None:
        for listener in list(self._listeners):  # (a copy: one may come or go meanwhile)
            try:
                listener(event)
            except Exception as exc:
                if getattr(self._saying, "now", False):
                    continue  # it failed again on the words of a failure: said once is enough
                self._saying.now = True
                try:
                    self._said(f"a listener of the run raised {describe_exception(exc)}")
                finally:
                    self._saying.now = False


class Log:
    """The run's log: its lines (`Runtime.note`), each told to the listeners as a `Logged`
    event as it is written, in the log's order (one lock: lines of two threads are told
    in the order they were written; reentrant, since a listener's bug is logged too)."""

    def __init__(self, told: Listeners) -> None:
        self.lines: list[Note] = []
        self._told = told
        self._lock = threading.RLock()

    def write(self, note: Note) -> None:
        with self._lock:
            self.lines.append(note)
            self._told.publish(Logged(note.tick, note))

    def listen_from_the_first_line(self, listener: Callable[[RunEvent], None]) -> None:
        """Tell `listener` the log so far, then every event from now on: each line once, in
        the log's order (a live view that starts after the launch has logged)."""
        with self._lock:
            for note in self.lines:
                listener(Logged(note.tick, note))
            self._told.listen(listener)


KINDS = ("run", "change", "refused", "status", "state", "fault", "missed", "end")


def kind_of(event: RunEvent) -> str:
    """The word a record writes before the event."""
    return event.written_kind if isinstance(event, Written) else event.kind


def parse(tick: int, kind: str, text: str) -> RunEvent:
    """The event a record wrote as `kind: text` at `tick` (the inverse of `kind_of` and `text`)."""
    if kind == "run":
        return Started(tick, text)
    if kind == "change":
        return Changed(tick, text)
    if kind == "end":
        return Ended(tick, text)
    if kind == "refused" and ": " in text:
        request, reason = text.split(": ", 1)
        return Refused(tick, request, reason)
    if kind == "fault":
        if text.startswith("stop() of plugin ") and text.endswith(" raised"):
            return Faulted(tick, text.removeprefix("stop() of plugin ").removesuffix(" raised"), None)
        feature, said, error = text.partition(" raised in its step: ")
        if said:
            return Faulted(tick, feature, error)
    if kind == "status" and " " in text:
        component, status = text.rsplit(" ", 1)
        return StatusChanged(tick, component, status)
    if kind == "state" and text.startswith(("entered ", "exited ")):
        what, state = text.split(" ", 1)
        return StateChanged(tick, what == "entered", state)
    if kind == "missed":
        count, _, rest = text.partition(" ")
        if count.isascii() and count.isdigit() and len(count) < 20 and rest in ("deadline", "deadlines"):
            return Missed(tick, int(count))
    return Written(tick, kind, text)

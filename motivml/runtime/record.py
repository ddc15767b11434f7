"""A run's record: one CSV row per tick, the spaces' values and what happened at that tick.

`motivml run --record FILE` keeps one row per control tick:

    tick,time,Pose[0],Pose[1],...,events

`tick` and `time` (s of control time) first, then every component of every space of the
architecture (document order; a space that is not active at that tick leaves its cells
empty), then `events`: what happened at that tick, each event `kind: text`, several joined
by ` | `. The kinds are `reconfiguration` (a committed change), `component` (a component's
status changed, e.g. its criterion fired), `fault` (a plugin raised in its step) and `note`
(the run's log: refused requests, coordination states entered, plugins' log lines).

The loop does no file I/O: after each tick it copies the values into a block of rows in
memory, and a block that is full goes to a writer thread, so an hour at 1 kHz (3.6 million
rows) is streamed, never held. The file is written beside its place under a temporary name
and renamed to FILE when the run has ended, however it ended (its duration, Ctrl-C, a
failing plugin): a record is whole or absent, never half-written.
"""

from __future__ import annotations

import csv
import os
import queue
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

import numpy as np

from ..errors import EnvironmentProblem, Location, error

if TYPE_CHECKING:
    from ..architecture.elements import Space
    from .loop import Runtime

BLOCK = 1024  # rows copied in memory before they go to the writer thread
SEPARATOR = " | "  # between the events of one tick


class Recorder:
    def __init__(self, path: str | Path, runtime: Runtime, spaces: list[Space]) -> None:
        """Open the record (a temporary file beside `path`); EnvironmentProblem if it cannot be."""
        self.path = Path(path)
        self.runtime = runtime
        self.spaces = [(s.id, s.dimension) for s in spaces]
        self.header = (
            ["tick", "time"] + [f"{sid}[{i}]" for sid, n in self.spaces for i in range(n)] + ["events"]
        )
        self.width = 2 + sum(n for _, n in self.spaces)
        folder = self.path.parent
        try:
            if self.path.is_dir():
                raise IsADirectoryError(21, "it is a folder")
            handle, temporary = tempfile.mkstemp(dir=folder, prefix=f".{self.path.name}.", suffix=".tmp")
        except OSError as exc:
            raise EnvironmentProblem(
                error(Location(str(self.path)), f"cannot write the record: {exc.strerror or exc}", "io")
            ) from None
        self.temporary = Path(temporary)
        self.file: TextIO = os.fdopen(handle, "w", encoding="utf-8", newline="")
        self.file.write(",".join(_quoted(h) for h in self.header) + "\n")
        self.rows = 0
        self.failure: str | None = None
        self._block = np.full((BLOCK, self.width), np.nan)
        self._events: dict[int, str] = {}  # row in block -> its events
        self._used = 0
        self._seen = (0, 0, 0, 0)  # changes, component events, faults, notes reported so far
        self._queue: queue.SimpleQueue[tuple[np.ndarray, dict[int, str], int] | None] = queue.SimpleQueue()
        self._writer = threading.Thread(target=self._write, daemon=True, name="motivml-record")
        self._writer.start()

    # ----------------------------------------------------------- the loop's side
    def after_tick(self) -> None:
        """A row for the tick just made (a hook of the runtime, on the control thread)."""
        runtime = self.runtime
        row = self._block[self._used]
        tick = runtime.ticks - 1
        row[0], row[1] = tick, tick / runtime.rate
        values = runtime.assembly.values
        column = 2
        for sid, n in self.spaces:
            value = values.get(sid)
            if value is not None and value.size == n:
                row[column : column + n] = value
            else:
                row[column : column + n] = np.nan
            column += n
        events = self._new_events()
        if events:
            self._events[self._used] = SEPARATOR.join(events)
        self._used += 1
        if self._used == BLOCK:
            self._hand_over()

    def _new_events(self) -> list[str]:
        runtime = self.runtime
        changes, components, faults, notes = self._seen
        found = [f"reconfiguration: {c.request}" for c in runtime.changes[changes:]]
        found += [f"component: {e.component} {e.status}" for e in runtime.events[components:]]
        found += [f"fault: {f.feature}: {f.error}" for f in runtime.faults[faults:]]
        found += [f"note: {text}" for _, _, text in runtime.notes[notes:]]
        if found:
            self._seen = (len(runtime.changes), len(runtime.events), len(runtime.faults), len(runtime.notes))
        return found

    def _hand_over(self) -> None:
        self._queue.put((self._block, self._events, self._used))
        self.rows += self._used
        self._block = np.full((BLOCK, self.width), np.nan)
        self._events = {}
        self._used = 0

    # ------------------------------------------------------------ the writer
    def _write(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            if self.failure is not None:
                continue  # the file failed: the rest is dropped, close() says so
            block, events, used = item
            try:
                self.file.write("".join(_row(block[k], events.get(k, "")) for k in range(used)))
            except (OSError, ValueError) as exc:
                self.failure = getattr(exc, "strerror", None) or str(exc)

    # ----------------------------------------------------------------- end
    def close(self) -> None:
        """Write the last rows and put the record in its place; EnvironmentProblem if it
        could not be written (nothing is left behind then)."""
        if self._used:
            self._hand_over()
        self._queue.put(None)
        self._writer.join()
        try:
            self.file.flush()
            os.fsync(self.file.fileno())
            self.file.close()
            if self.failure is None:
                os.replace(self.temporary, self.path)
        except OSError as exc:
            self.failure = exc.strerror or str(exc)
        if self.failure is not None:
            self.discard()
            raise EnvironmentProblem(
                error(Location(str(self.path)), f"cannot write the record: {self.failure}", "io")
            )

    def discard(self) -> None:
        """Leave nothing behind (a run that could not start, a record that failed)."""
        if not self.file.closed:
            self._queue.put(None)
            self._writer.join()
            self.file.close()
        self.temporary.unlink(missing_ok=True)


def _row(values: np.ndarray, events: str) -> str:
    tick = int(values[0])
    cells = [str(tick), f"{values[1]:.6f}"]
    cells += ["" if v != v else f"{v:.9g}" for v in values[2:].tolist()]  # (v != v: NaN, not active)
    cells.append(_quoted(events) if events else "")
    return ",".join(cells) + "\n"


def _quoted(text: str) -> str:
    """A CSV field: quoted when it holds a comma, a quote or a line break (RFC 4180)."""
    if any(c in text for c in ',"\n\r'):
        return '"' + text.replace('"', '""') + '"'
    return text


class RecordError(Exception):
    """A file that is not a well-formed record: `line` (1-based) and what is wrong there."""

    def __init__(self, line: int, message: str) -> None:
        super().__init__(message)
        self.line = line
        self.message = message


class Record:
    """A record read back: the spaces' columns, the time of each row, the events."""

    def __init__(
        self, time: np.ndarray, spaces: dict[str, np.ndarray], events: list[tuple[float, str]]
    ) -> None:
        self.time = time  # s, one per row
        self.spaces = spaces  # space -> (rows x dimension), NaN where it was not active
        self.events = events  # (time, "kind: text") for every event, in order


def read_record(path: str | Path) -> Record:
    """Read a record written by `Recorder`; RecordError (with the line) if it is not one.
    (An unreadable file raises OSError; one that is not UTF-8, UnicodeDecodeError.)"""
    with open(path, encoding="utf-8", newline="") as handle:
        rows = csv.reader(handle)
        header = next(rows, None)
        if header is None:
            raise RecordError(1, "the file is empty: not a run record")
        if len(header) < 3 or header[:2] != ["tick", "time"] or header[-1] != "events":
            raise RecordError(
                1, "not a run record of motivml run --record: the header is tick,time,...,events"
            )
        spaces: dict[str, int] = {}
        for position, name in enumerate(header[2:-1], 3):
            sid, bracket, rest = name.partition("[")
            if (
                not bracket
                or not rest.endswith("]")
                or not rest[:-1].isdigit()
                or int(rest[:-1]) != spaces.get(sid, 0)
            ):
                raise RecordError(1, f"column {position}, {name!r}, is not SPACE[i] in order")
            spaces[sid] = spaces.get(sid, 0) + 1
        width = len(header)
        times: list[float] = []
        values: list[list[float]] = []
        events: list[tuple[float, str]] = []
        for line, row in _rows(rows):
            if len(row) != width:
                raise RecordError(line, f"{len(row)} fields where the header has {width}")
            try:
                int(row[0])
                at = float(row[1])
                numbers = [float(cell) if cell else float("nan") for cell in row[2:-1]]
            except ValueError:
                raise RecordError(line, "a tick, a time and the spaces' values must be numbers") from None
            times.append(at)
            values.append(numbers)
            if row[-1]:
                events += [(at, event) for event in row[-1].split(SEPARATOR)]
        if not times:
            raise RecordError(2, "the record has no rows (the run made no tick)")
    table = np.array(values, dtype=float).reshape(len(times), width - 3)
    columns: dict[str, np.ndarray] = {}
    first = 0
    for sid, n in spaces.items():
        columns[sid] = table[:, first : first + n]
        first += n
    return Record(np.array(times), columns, events)


def _rows(rows: Iterator[list[str]]) -> Iterator[tuple[int, list[str]]]:
    """The data rows with their line numbers; a line csv cannot read is a RecordError."""
    line = 1
    while True:
        line += 1
        try:
            row = next(rows)
        except StopIteration:
            return
        except csv.Error as exc:
            raise RecordError(line, f"not CSV: {exc}") from None
        yield line, row

"""The record of a run: the spaces' values at every tick and what happened at it, as one CSV file.

`motivml run --record FILE` writes it while the loop runs; `motivml plot FILE` reads it back.
One row per tick, columns in this order::

    tick,time,ArmGoal[0],ArmGoal[1],ArmGoal[2],ArmCommand[0],...,events

* `tick` counts the loop's ticks from 1, and `time` is the control time after the tick,
  tick / rate, in seconds: the stamps every message of the run uses. "changed at 0.600 s
  (tick 600)" is in row 600: the change took effect after that row's values, before the next
  tick. (On the real clock, a tick that overruns makes the loop skip deadlines, which a
  `missed` event says; `time` then runs behind the wall clock by the deadlines missed so far,
  divided by the rate.)
* `SPACE[i]`: the i-th number of a space, for every space that a feature selected in the
  variant brings, in the architecture's order, so the columns are the same for the whole run
  whatever is swapped in or out. A space whose feature is not active at a tick has empty
  cells there. Numbers are written exactly (Python's shortest repr), `nan` and `inf` where a
  system diverged.
* `events`: what happened at the tick, each `kind: text`, several joined by ` | ` (a `|` or
  a backslash in a text is escaped with a backslash, control characters are spelled out, so
  that every row is one line). The kinds: `run` (in the first row: robot, variant, rate,
  clock), `change` (an accepted reconfiguration), `refused` (a refused one, and why),
  `status` (a component's criterion changed its verdict), `state` (the coordination entered
  or exited a state), `fault` (a plugin raised in its step, or in its stop() at the end),
  `missed` (deadlines the real clock skipped after the tick) and `end` (why the run ended,
  in the last row). An event made before the first tick, or after its row was written (a
  refusal answered on another thread), goes in the first row still open and says its tick.

It is plain CSV (RFC 4180: a field holding a comma or a quote is quoted), read as it is by
spreadsheets, pandas.read_csv or Python's csv module.

Writing never makes the loop wait for the disk. After every tick a hook on the control
thread copies the spaces' values into a block of rows (numpy) and looks for new entries in
the run's logs; every CHUNK ticks it hands the block to a writer thread, which formats and
writes it. Only the simulated clock, which has no deadline, waits when the writer is QUEUED
blocks behind, so that memory stays bounded however fast it ticks; on the real clock the
queue is not bounded (a block of a second at 1 kHz is a few tens of kilobytes). So a record
streams: an hour at 1 kHz is 3.6 million rows on disk, never in memory.

The record is written to a file without a name in FILE's folder (Linux's O_TMPFILE; where
a file system has none, a hidden `.FILE.*.tmp`), given a hidden name when the run ends and
renamed to FILE, however it ends (its duration, Ctrl-C, SIGTERM, a failing plugin, a loop
stuck in a plugin's step and interrupted twice): FILE is a complete record or is not
there, never half of one. A process killed outright (SIGKILL) leaves nothing: a file
without a name is freed with its last descriptor.
"""

from __future__ import annotations

import collections
import csv
import math
import os
import queue
import re
import secrets
import tempfile
import threading
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from ..errors import DocumentError, EnvironmentProblem, Location, error
from .events import (
    KINDS,
    Ended,
    Faulted,
    RunEvent,
    Started,
    kind_of,
    parse,
)

if TYPE_CHECKING:
    from ..architecture.document import Architecture
    from .loop import Runtime

SEPARATOR = " | "
CHUNK = 1024  # rows per block handed to the writer: about a second at 1 kHz
QUEUED = 16  # blocks the simulated clock lets the writer fall behind
COLUMN = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\[([0-9]+)\]")
EVENT = re.compile(r"([a-z]+): ")


def columns(architecture: Architecture | None, selected: set[str]) -> list[tuple[str, int]]:
    """The spaces a run of these selected features may hold, (id, dimension), in document order."""
    if architecture is None:
        return []
    return [(s.id, s.dimension) for s in architecture.spaces.values() if s.feature in selected]


def header(spaces: Sequence[tuple[str, int]]) -> list[str]:
    return ["tick", "time", *(f"{name}[{i}]" for name, size in spaces for i in range(size)), "events"]


def escape(text: str) -> str:
    """An event's text as it goes in the events cell: `|` and `\\` escaped, control characters spelled out."""
    if text.isprintable() and "|" not in text and "\\" not in text:
        return text
    out = []
    for ch in text:
        if ch in "|\\":
            out.append("\\" + ch)
        elif ch.isprintable():
            out.append(ch)
        else:
            out.append(ch.encode("unicode_escape").decode("ascii"))
    return "".join(out)


def split_events(cell: str) -> list[str]:
    """The events of one cell, unescaped (the inverse of joining escaped texts with SEPARATOR)."""
    if not cell:
        return []
    texts, current, chars = [], [], iter(cell)
    for ch in chars:
        if ch == "\\":
            following = next(chars, "")
            current.append(following if following in "|\\" else ch + following)
        elif ch == "|":
            texts.append("".join(current).strip(" "))
            current = []
        else:
            current.append(ch)
    texts.append("".join(current).strip(" "))
    return texts


@dataclass
class _Block:
    """Rows on their way to the writer: values, which spaces were there, and the events by tick."""

    first: int  # the tick of its first row
    values: np.ndarray  # rows x numbers
    present: np.ndarray  # rows x spaces: False where the space's feature was not active
    events: dict[int, str] = field(default_factory=dict)


def _hidden_file(path: Path) -> tuple[Path | None, IO[str]]:
    """A file for the record that no one sees before it is complete: unnamed in `path`'s
    folder where Linux can name it at the end (O_TMPFILE), else a hidden name (returned)."""
    try:
        if path.is_dir():
            raise IsADirectoryError(21, "a folder is in the way")
        path.parent.mkdir(parents=True, exist_ok=True)
        name: str | None = None
        try:  # (the mode less the umask, as any output: a record is shared like one)
            if not os.path.isdir("/proc/self/fd"):  # (where it would be named at the end)
                raise NotImplementedError
            descriptor = os.open(path.parent, os.O_TMPFILE | os.O_WRONLY | os.O_CLOEXEC, 0o666)
        except (AttributeError, NotImplementedError, OSError) as exc:  # a hidden name from the start
            if isinstance(exc, PermissionError):
                raise
            descriptor, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(name, 0o666 & ~umask)  # (not mkstemp's 0600)
        handle = os.fdopen(descriptor, "w", encoding="utf-8", newline="", buffering=1 << 16)
    except OSError as exc:
        raise EnvironmentProblem(
            error(Location(str(path)), f"cannot write the record: {exc.strerror or exc}", "io")
        ) from None
    return (Path(name) if name is not None else None), handle


class Recorder:
    """Streams a run into a record file (see the module's docstring).

    `create` makes the hidden file at once, so that a path that cannot be written fails before
    the run starts; `start` writes the header and hooks into the loop; `finish` writes the
    rest and renames the file into place; `discard` removes it (a run that never started).
    """

    def __init__(self, path: Path, temporary: Path | None, handle: IO[str]) -> None:
        self.path = path
        self.temporary = temporary
        self.rows = 0  # written so far
        self._handle = handle
        self._writer: Any = csv.writer(handle, lineterminator="\n")
        self._lock = threading.Lock()  # the hook versus finish() from another thread
        self._closed = False  # the hook does nothing any more
        self._ended = False  # finished or discarded
        self._outside: collections.deque[RunEvent] = collections.deque()  # other threads' events
        self._pending: list[RunEvent] = []  # not yet in a block
        self._problem: BaseException | None = None  # what stopped the writer
        self._thread: threading.Thread | None = None
        self._runtime: Runtime | None = None

    @classmethod
    def create(cls, path: Path) -> Recorder:
        """A recorder writing to `path`: its hidden file is made now (EnvironmentProblem if it cannot be)."""
        return cls(path, *_hidden_file(path))

    # ------------------------------------------------------------------ running
    def start(
        self,
        runtime: Runtime,
        spaces: Sequence[tuple[str, int]],
        description: str,
        simulated: bool = False,
    ) -> None:
        """Write the header and record every tick, and every event the runtime publishes,
        from now on (call before the loop starts)."""
        self._runtime = runtime
        self._layout: list[tuple[str, int, int]] = []
        width = 0
        for name, size in spaces:
            self._layout.append((name, width, width + size))
            width += size
        self._width = width
        self._rate = runtime.rate
        self._first = runtime.ticks + 1  # the tick of the block's first row
        self._filled = 0
        self._new_block()
        self._pending.append(Started(self._first, description))
        self._queue: queue.Queue[_Block | None] = queue.Queue(QUEUED if simulated else 0)
        try:
            self._writer.writerow(header(spaces))
        except OSError as exc:
            self._problem = exc
        self._thread = threading.Thread(target=self._write_blocks, daemon=True, name="motivml-record")
        self._thread.start()
        runtime.told.listen(self.event)
        runtime.after_each_tick(self._after_tick)

    def event(self, event: RunEvent) -> None:
        """An event, from any thread (a listener of the runtime: `Runtime.publish`); it goes
        into the row of its tick, or the first row still open (the kinds a record keeps)."""
        if self._runtime is not None and event.recorded:
            self._outside.append(event)

    def _new_block(self) -> None:
        self._values = np.empty((CHUNK, self._width))
        self._present = np.ones((CHUNK, len(self._layout)), dtype=bool)

    def _after_tick(self) -> None:
        """After every tick, on the control thread: the values into the block, new events aside."""
        with self._lock:
            if self._closed:
                return
            runtime = self._runtime
            assert runtime is not None
            self._collect(runtime)
            row = self._filled
            values = runtime.assembly.values
            present = self._present[row]
            for column, (space, start, stop) in enumerate(self._layout):
                value = values.get(space)
                if value is None:
                    present[column] = False
                else:
                    self._values[row, start:stop] = value
            self._filled = row + 1
            if self._filled == CHUNK:
                self._hand_off(final=False)

    def _collect(self, runtime: Runtime) -> None:
        """The events published since the last tick (each stamped with its own tick)."""
        while self._outside:
            self._pending.append(self._outside.popleft())

    def _hand_off(self, final: bool) -> None:
        """Send the block's rows to the writer. Before the end the last row stays: events
        stamped with its tick may still come (a change commits between this tick and the next)."""
        filled = self._filled
        last = self._first + filled - 1
        sent = filled if final else filled - 1
        upto = self._first + sent - 1
        block = _Block(self._first, self._values[:sent], self._present[:sent])
        keep = []
        if sent:
            texts: dict[int, list[str]] = {}
            for event in self._pending:
                tick = event.tick
                if tick > upto and not final:
                    keep.append(event)
                    continue
                at = min(max(tick, self._first), last)
                said = f"{kind_of(event)}: {event.text}" + (f" (at tick {tick})" if at != tick else "")
                texts.setdefault(at, []).append(escape(said))
            block.events = {tick: SEPARATOR.join(said) for tick, said in texts.items()}
            self._queue.put(block)
        self._pending = keep
        values, present = self._values, self._present
        self._new_block()
        self._first = upto + 1
        self._filled = filled - sent
        if self._filled:
            self._values[0] = values[filled - 1]
            self._present[0] = present[filled - 1]

    # ------------------------------------------------------------------ the writer's thread
    def _write_blocks(self) -> None:
        while True:
            block = self._queue.get()
            if block is None:
                return
            if self._problem is not None:
                continue  # keep taking blocks: the loop never waits for a writer that gave up
            try:
                self._writer.writerows(self._rows(block))
                self.rows += len(block.values)
            except BaseException as exc:  # a full disk (OSError), or a bug: the run goes on
                self._problem = exc
                if self._runtime is not None:
                    self._runtime.note(f"record {self.path}: cannot write: {_reason(exc)}: recording stopped")

    def _rows(self, block: _Block) -> Iterator[list[object]]:
        absent = ~block.present
        gaps = set(np.flatnonzero(absent.any(axis=1)).tolist())  # rows with a space missing
        rate, layout, events = self._rate, self._layout, block.events
        for i, numbers in enumerate(block.values.tolist()):
            tick = block.first + i
            if i in gaps:
                for column in np.flatnonzero(absent[i]):
                    _, start, stop = layout[column]
                    numbers[start:stop] = [None] * (stop - start)
            yield [tick, tick / rate, *numbers, events.get(tick, "")]

    # ------------------------------------------------------------------ ending
    def finish(self, end: str, failed_stops: Sequence[str] = ()) -> int:
        """Write the rest, with a fault of each plugin whose stop() raised (`failed_stops`)
        and the `end` event in the last row,
        and rename the file into place; the rows written. EnvironmentProblem if it could not be
        written (the hidden file is then removed). Any thread; the loop should have ended."""
        with self._lock:
            if self._ended:
                return self.rows
            self._ended = self._closed = True
            runtime = self._runtime
            if runtime is None or self._thread is None:  # never started
                self._remove()
                return 0
            self._collect(runtime)
            self._pending += [Faulted(runtime.ticks, feature, None) for feature in failed_stops]
            self._pending.append(Ended(runtime.ticks, end))
            self._hand_off(final=True)
            self._queue.put(None)
        self._thread.join()
        try:
            self._handle.flush()
            if self.temporary is None:  # a file without a name: named now, beside FILE
                temporary = self.path.parent / f".{self.path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
                _name(self._handle.fileno(), temporary)
                self.temporary = temporary
            self._handle.close()
        except OSError as exc:
            self._problem = self._problem or exc
        if self._problem is not None:
            self._remove()
            raise EnvironmentProblem(
                error(Location(str(self.path)), f"cannot write the record: {_reason(self._problem)}", "io")
            )
        try:
            assert self.temporary is not None
            os.replace(self.temporary, self.path)
        except OSError as exc:
            self._remove()
            raise EnvironmentProblem(
                error(Location(str(self.path)), f"cannot write the record: {exc.strerror or exc}", "io")
            ) from None
        return self.rows

    def discard(self) -> None:
        """Remove the record (a run that failed to start); nothing once finished."""
        with self._lock:
            if self._ended:
                return
            self._ended = self._closed = True
            if self._thread is not None:
                self._queue.put(None)
        if self._thread is not None:
            self._thread.join()
        self._remove()

    def _remove(self) -> None:
        try:
            self._handle.close()
        except OSError:
            pass
        if self.temporary is not None:
            try:
                self.temporary.unlink()
            except OSError:
                pass


def _name(descriptor: int, path: Path) -> None:
    """Give the file without a name open as `descriptor` the name `path`: linkat(2) through
    /proc/self/fd, following the link (os.link follows it only given a directory
    descriptor: otherwise it calls link(2), which links /proc's symbolic link itself)."""
    fds = os.open("/proc/self/fd", os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    try:
        os.link(str(descriptor), path, src_dir_fd=fds, follow_symlinks=True)
    finally:
        os.close(fds)


def _reason(exc: BaseException) -> str:
    return (exc.strerror or str(exc)) if isinstance(exc, OSError) else f"{type(exc).__name__}: {exc}"


# ---------------------------------------------------------------------- reading
POINTS = 1500  # a record read for a picture keeps between this and twice as many points per number
MAX_EVENTS = 10_000  # events kept for a picture; more are counted


@dataclass(frozen=True)
class RecordedEvent:
    """An event as a record holds it: when, and what (typed, events.py)."""

    tick: int
    time: float
    kind: str
    text: str
    event: RunEvent


@dataclass
class Record:
    """A record read back, thinned for a picture.

    `time` and `low`/`high` hold one point per row while the record has at most twice
    `points` rows; a longer one is cut into buckets of `bucket` rows (a power of two), each shown by
    its first row's time and the lowest and highest value of every number in it, so that a
    peak of one tick is never lost. NaN where a space was not active (or diverged)."""

    path: Path
    spaces: list[tuple[str, int]]
    ticks: int  # rows
    start: float  # time of the first row, s
    end: float  # time of the last row, s
    time: np.ndarray
    low: np.ndarray  # points x numbers
    high: np.ndarray
    bucket: int
    events: list[RecordedEvent]
    more_events: int  # not kept (past MAX_EVENTS)

    @property
    def description(self) -> str | None:
        """What the run was (its `run` event), if the record says."""
        return next((e.text for e in self.events if e.kind == "run"), None)


class _Lines:
    """The file's lines for csv.reader, remembering the last one and counting them."""

    def __init__(self, handle: IO[str]) -> None:
        self.handle = handle
        self.number = 0
        self.last = ""

    def __iter__(self) -> Iterator[str]:
        for line in self.handle:
            self.number += 1
            self.last = line
            yield line


def read_record(path: Path, points: int = POINTS) -> Record:
    """Read a record of `motivml run --record`, streaming (DocumentError, located, if it is not one)."""
    try:
        handle = open(path, encoding="utf-8-sig", newline="")  # (a byte-order mark, as spreadsheets write, is not data)
    except OSError as exc:
        raise EnvironmentProblem(
            error(Location(str(path)), f"cannot read: {exc.strerror or exc}", "io")
        ) from None
    with handle:
        lines = _Lines(handle)
        try:
            return _RecordReader(path, lines, points).read()
        except UnicodeDecodeError:
            raise _bad(path, lines.number + 1, 1, "not UTF-8 text: not a record of motivml run") from None
        except csv.Error as exc:
            raise _bad(path, max(lines.number, 1), 1, f"not CSV: {exc}") from None
        except OSError as exc:
            raise EnvironmentProblem(
                error(Location(str(path)), f"cannot read: {exc.strerror or exc}", "io")
            ) from None


def _bad(path: Path, line: int, column: int, message: str) -> DocumentError:
    return DocumentError(error(Location(str(path), line, column), message, "record"))


class _RecordReader:
    BLOCK = 8192  # rows parsed before they are thinned

    def __init__(self, path: Path, lines: _Lines, points: int) -> None:
        self.path = path
        self.lines = lines
        self.points = max(points, 2)
        self.bucket = 1
        self.ids = np.zeros(0, dtype=np.int64)  # each kept point's bucket: row index // bucket
        self.time = np.zeros(0)
        self.low = np.zeros((0, 0))
        self.high = np.zeros((0, 0))
        self.events: list[RecordedEvent] = []
        self.more_events = 0

    def column(self, fields: list[str], index: int) -> int:
        """The character column of a field on the current line (1 if quoting makes it unsure)."""
        if '"' in self.lines.last:
            return 1
        return sum(len(f) + 1 for f in fields[:index]) + 1

    def read(self) -> Record:
        reader = csv.reader(self.lines, strict=True)
        names = next(reader, None)
        expected = "its first line names the columns tick,time,SPACE[i]...,events"
        if names is None:
            raise _bad(self.path, 1, 1, f"empty: not a record of motivml run ({expected})")
        if len(names) < 3 or names[:2] != ["tick", "time"] or names[-1] != "events":
            raise _bad(self.path, 1, 1, f"not a record of motivml run: {expected}")
        spaces = self.spaces(names)
        width = len(names) - 3
        self.low = self.high = np.zeros((0, width))
        rows: list[list[float]] = []
        times: list[float] = []
        previous: int | None = None
        first_time = last_time = 0.0
        count = 0
        for fields in reader:
            line = self.lines.number
            if len(fields) != len(names):
                raise _bad(
                    self.path,
                    line,
                    1,
                    f"{len(fields)} fields, where the first line names {len(names)} columns",
                )
            tick, time, numbers = self.row(fields, names, line, previous)
            previous = tick
            rows.append(numbers)
            times.append(time)
            if fields[-1]:
                self.read_events(fields, tick, time)
            if count == 0:
                first_time = time
            last_time = time
            count += 1
            if len(rows) == self.BLOCK:
                self.thin(count - len(rows), rows, times, width)
                rows, times = [], []
        if count == 0:
            raise _bad(
                self.path,
                max(self.lines.number, 1) + 1,
                1,
                "the record has no ticks: the run ended before its first",
            )
        if rows:
            self.thin(count - len(rows), rows, times, width)
        return Record(
            self.path,
            spaces,
            count,
            first_time,
            last_time,
            self.time,
            self.low,
            self.high,
            self.bucket,
            self.events,
            self.more_events,
        )

    def row(
        self, fields: list[str], names: list[str], line: int, previous: int | None
    ) -> tuple[int, float, list[float]]:
        """One row's tick (the one after `previous`), time and numbers, or where it is wrong."""
        try:
            tick = int(fields[0])
        except ValueError:
            raise _bad(self.path, line, 1, f"tick {fields[0]!r} is not a whole number") from None
        if previous is not None and tick != previous + 1:
            raise _bad(
                self.path, line, 1, f"tick {tick} follows tick {previous}: a record has one row per tick, in order"
            )
        try:
            time = float(fields[1])
        except ValueError:
            time = math.nan
        if not math.isfinite(time):
            raise _bad(self.path, line, self.column(fields, 1), f"time {fields[1]!r} is not a number of seconds")
        try:
            return tick, time, [float(v) if v else math.nan for v in fields[2:-1]]
        except ValueError:
            index = next(i for i, v in enumerate(fields[2:-1], 2) if v and not _is_number(v))
            raise _bad(
                self.path, line, self.column(fields, index), f"{names[index]}: {fields[index]!r} is not a number"
            ) from None

    def spaces(self, names: list[str]) -> list[tuple[str, int]]:
        spaces: list[tuple[str, int]] = []
        for index, name in enumerate(names[2:-1], 2):
            match = COLUMN.fullmatch(name)
            column = self.column(names, index)
            if match is None:
                raise _bad(self.path, 1, column, f"column {name!r} is not a space's number, SPACE[i]")
            space, number = match.group(1), int(match.group(2))
            if spaces and spaces[-1][0] == space and number == spaces[-1][1]:
                spaces[-1] = (space, number + 1)
            elif number == 0 and all(s != space for s, _ in spaces):
                spaces.append((space, 1))
            else:
                wanted = (
                    f"{spaces[-1][0]}[{spaces[-1][1]}]"
                    if spaces and spaces[-1][0] == space
                    else f"{space}[0]"
                )
                raise _bad(
                    self.path,
                    1,
                    column,
                    f"column {name!r} where {wanted} should be: a space's numbers come in order, together",
                )
        return spaces

    def read_events(self, fields: list[str], tick: int, time: float) -> None:
        for said in split_events(fields[-1]):
            match = EVENT.match(said)
            if match is None:
                raise _bad(
                    self.path,
                    self.lines.number,
                    self.column(fields, len(fields) - 1),
                    f"event {said!r} is not 'kind: text' (kinds: {', '.join(KINDS)})",
                )
            if len(self.events) < MAX_EVENTS:
                kind, text = match.group(1), said[match.end() :]
                self.events.append(RecordedEvent(tick, time, kind, text, parse(tick, kind, text)))
            else:
                self.more_events += 1

    def thin(self, offset: int, rows: list[list[float]], times: list[float], width: int) -> None:
        """Add parsed rows (the first is row `offset` of the record) as points; merge the
        points two buckets at a time while there are more than twice `points`."""
        values = np.array(rows, dtype=float).reshape(len(rows), width)
        values[np.isinf(values)] = np.nan  # a diverged number shows as a gap, as an inactive space does
        ids = (offset + np.arange(len(rows))) // self.bucket
        self.add(ids, np.array(times), values, values)
        while len(self.ids) > 2 * self.points:
            self.bucket *= 2
            self.ids, self.time, self.low, self.high = _regroup(self.ids // 2, self.time, self.low, self.high)

    def add(self, ids: np.ndarray, time: np.ndarray, low: np.ndarray, high: np.ndarray) -> None:
        ids, time, low, high = _regroup(ids, time, low, high)
        if len(self.ids) and ids[0] == self.ids[-1]:  # a bucket that began in the block before
            low[0] = np.fmin(low[0], self.low[-1])
            high[0] = np.fmax(high[0], self.high[-1])
            time[0] = self.time[-1]
            self.ids, self.time, self.low, self.high = (
                self.ids[:-1],
                self.time[:-1],
                self.low[:-1],
                self.high[:-1],
            )
        self.ids = np.concatenate([self.ids, ids])
        self.time = np.concatenate([self.time, time])
        self.low = np.concatenate([self.low, low])
        self.high = np.concatenate([self.high, high])


def _regroup(
    ids: np.ndarray, time: np.ndarray, low: np.ndarray, high: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One point per run of equal ids: its first time, the lowest low and highest high (NaN-blind)."""
    starts = np.flatnonzero(np.concatenate([[True], ids[1:] != ids[:-1]]))
    if low.shape[1] == 0:
        empty = np.zeros((len(starts), 0))
        return ids[starts], time[starts], empty, empty
    return (
        ids[starts],
        time[starts],
        np.fmin.reduceat(low, starts, axis=0),
        np.fmax.reduceat(high, starts, axis=0),
    )


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True

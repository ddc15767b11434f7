"""A change rolled out to the running robots of a fleet in stages (reference.md section 9).

The selected robots, in the fleet file's order, go in waves: the first `canary` of them on
their own, then the rest in `waves` waves of nearly equal size. Before anything moves, the
change is planned for every robot against the active set it reports (`layers.plan_fleet`),
so a change one robot would refuse touches none. Then, robot by robot, one atomic parameter
call makes the change (the robot's node checks it again, on its own encoding); after each
wave every robot changed so far must stay healthy for `healthy` seconds before the next wave
starts. Healthy means: its node is on the graph and reporting, its loop and features report
no ERROR, no new fault, and its missed deadlines since the change no larger a share of its
ticks than before the change plus one percent (the node's own WARN threshold).

A refusal, an unhealthy robot or a call that goes unanswered stops the rollout, and every
robot changed is changed back, last first: each by the inverse call (every feature that
moved, set back to what it was), which its node checks like any other. Ctrl-C (`interrupt`)
stops between two robots and asks whether to roll back; a rollout stopped and kept can go
on later from its record (`resume`).

Every step is one JSON line of the record, written whole and flushed before the next step
starts, and one line of the graph's log (rosout, through the `Graph`'s logger).
"""

from __future__ import annotations

import errno
import json
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Protocol

from ..runtime.requests import Load, Request, Set, Swap, Unload
from .layers import RobotPlan, Running, plan_fleet

STALE = 3.0  # s without a /diagnostics report: the robot is not reporting (the node reports every second)
SETTLE = 5.0  # s to wait for the active-set message of a change the node accepted
MISSED_MARGIN = 0.01  # the share of deadlines a change may add to the robot's own recent share
WATCH_STEP = 0.1  # s between two looks at the robots during a health wait


# ------------------------------------------------------------------ the graph
class Said(Protocol):
    """What one robot's node has said (motivml.ros2.fleet.Seen)."""

    namespace: str
    state: dict[str, Any] | None
    state_at: float
    statuses: list[dict[str, Any]]
    statuses_at: float
    reports: int


class Logger(Protocol):
    def info(self, message: str) -> Any: ...
    def warning(self, message: str) -> Any: ...
    def error(self, message: str) -> Any: ...


class Graph(Protocol):
    """The running robots (motivml.ros2.fleet.Watch on a real ROS 2 graph)."""

    log: Logger

    def discover(self, wait: float, expected: list[str] | None = None) -> list[str]: ...
    def namespaces(self) -> list[str]: ...
    def snapshot(self, namespace: str) -> Said | None: ...
    def alive(self, namespace: str) -> bool: ...
    def set(self, namespace: str, wanted: dict[str, bool], timeout: float) -> tuple[bool | None, str]: ...
    # (accepted; refused; None: no answer in time, it may have taken the change)
    def wait_reports(self, namespaces: list[str], wait: float) -> None: ...


@dataclass(frozen=True)
class Health:
    """A robot's loop as its last /diagnostics report said it."""

    level: str  # the worst level of its statuses: OK, WARN, ERROR
    worst: str  # the status at that level ("loop: running")
    ticks: int
    missed: int
    faults: int
    rate: float
    achieved: float
    at: float  # monotonic time of the report


def health(said: Said) -> Health | None:
    """The robot's last report, read (None: none yet, or not motivml's)."""
    loop = next((s for s in said.statuses if s["name"].endswith(" loop")), None)
    if loop is None:
        return None
    order = {"OK": 0, "WARN": 1, "ERROR": 2, "STALE": 3}
    worst = max(said.statuses, key=lambda s: order.get(s["level"], 3))
    values = loop["values"]

    def number(key: str) -> float:
        try:
            return float(values.get(key, "nan"))
        except ValueError:
            return math.nan

    name = str(worst["name"]).split(" ", 2)[-1]  # ("motivml: ROBOT loop" -> "loop")
    return Health(
        str(worst["level"]),
        f"{name}: {worst['message']}",
        int(number("ticks")) if math.isfinite(number("ticks")) else 0,
        int(number("missed deadlines")) if math.isfinite(number("missed deadlines")) else 0,
        int(number("faults")) if math.isfinite(number("faults")) else 0,
        number("rate"),
        number("achieved rate"),
        said.statuses_at,
    )


def running(said: Said | None) -> Running | None:
    """The robot's active-set message, read (None: none yet, or not well formed)."""
    if said is None or not isinstance(said.state, dict):
        return None
    state = said.state
    active = state.get("active")
    tick = state.get("tick") or 0
    if not isinstance(active, list) or not isinstance(tick, int):
        return None
    return Running(
        said.namespace,
        str(state.get("robot", "")),
        str(state.get("variant", "")),
        tuple(str(f) for f in active),
        tick,
        str(state.get("configuration") or ""),
    )


def ask(graph: Graph, wait: float) -> Callable[[list[str]], dict[str, Running]]:
    """`plan_fleet`'s question to the running robots: those of the given namespaces found within `wait` s."""

    def answer(namespaces: list[str]) -> dict[str, Running]:
        graph.discover(wait, expected=namespaces)
        found = {}
        for namespace in namespaces:
            said = running(graph.snapshot(namespace))
            if said is not None:
                found[namespace] = said
        return found

    return answer


# ------------------------------------------------------------------ requests
def wanted(request: Request) -> dict[str, bool]:
    """The parameter call that asks the robot for `request`: features on and off."""
    if isinstance(request, Load):
        return dict.fromkeys(request.features, True)
    if isinstance(request, Unload):
        return dict.fromkeys(request.features, False)
    if isinstance(request, Swap):
        return {request.out: False, request.into: True}
    if isinstance(request, Set):
        return {**dict.fromkeys(request.loads, True), **dict.fromkeys(request.unloads, False)}
    raise ValueError(f"{request} is not a change of parameters: a rollout takes load, unload, swap or set")


def waves_of(robots: list[str], canary: int, waves: int) -> list[list[str]]:
    """The robots in the order they are changed: the canary wave (the first `canary`),
    then the rest in `waves` waves, the earlier ones larger by one at most. No empty wave."""
    first, rest = robots[:canary], robots[canary:]
    count = max(1, min(waves, len(rest))) if rest else 0
    out = [first] if first else []
    start = 0
    for k in range(count):
        size = len(rest) // count + (1 if k < len(rest) % count else 0)
        out.append(rest[start : start + size])
        start += size
    return out


# ------------------------------------------------------------------ the record
class Record:
    """The rollout's record: one JSON object per line, each written whole and flushed.

    A new record is a new file (an existing one is never appended to by a new rollout:
    `resume` would take the first rollout's start for its own); a resumed one is appended
    to, after its last whole line (a line cut short by a killed writer is cut off). A
    record that cannot be written (a full disk) does not stop the rollout, nor its
    rollback: `failure` says why, and the rest goes to the log only."""

    def __init__(self, path: Path, resume: bool = False) -> None:
        self.path = path
        self.failure: str | None = None
        if resume:
            whole = path.read_bytes()
            cut = whole.rfind(b"\n") + 1
            if cut != len(whole):
                with path.open("r+b") as file:
                    file.truncate(cut)
            self._file = path.open("a", encoding="utf-8")
        else:
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
            except FileExistsError:  # (a file where a folder of the path should be)
                raise NotADirectoryError(errno.ENOTDIR, "not a folder", str(path.parent)) from None
            self._file = path.open("x", encoding="utf-8")

    @classmethod
    def new(cls, folder: Path) -> Record:
        """A new record in `folder`, named by the UTC time (-2, -3 ... when taken)."""
        stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
        for k in range(1, 1000):
            try:
                return cls(folder / (stamp + (f"-{k}" if k > 1 else "") + ".jsonl"))
            except FileExistsError:
                continue
        raise FileExistsError(f"{folder}: no free record name for {stamp}")

    def write(self, step: dict[str, Any]) -> None:
        if self.failure is not None:
            return
        line = json.dumps({"at": datetime.now(UTC).isoformat(timespec="milliseconds"), **step})
        try:
            self._file.write(line + "\n")
            self._file.flush()
        except OSError as exc:
            self.failure = f"{self.path}: {exc.strerror or exc}"

    def close(self) -> None:
        try:
            self._file.close()
        except OSError as exc:
            self.failure = self.failure or f"{self.path}: {exc.strerror or exc}"


class RecordError(ValueError):
    """A record that cannot be read or resumed; the message says why, with its line."""


def read_record(path: Path) -> list[dict[str, Any]]:
    """The steps of a record (a line cut short by a killed writer, the last one, is left out)."""
    steps = []
    lines = path.read_text(encoding="utf-8").splitlines()
    for number, line in enumerate(lines, 1):
        try:
            step = json.loads(line)
        except ValueError:
            if number == len(lines):
                break
            raise RecordError(f"{path}:{number}: not a JSON line of a rollout record") from None
        if not isinstance(step, dict) or not isinstance(step.get("step"), str):
            raise RecordError(f"{path}:{number}: not a step of a rollout record")
        steps.append(step)
    if not steps or steps[0]["step"] != "start":
        raise RecordError(f"{path}:1: a rollout record starts with its start step")
    return steps


def last_steps(steps: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Each robot's latest step in a record."""
    latest: dict[str, dict[str, Any]] = {}
    for step in steps:
        if isinstance(step.get("robot"), str):
            latest[step["robot"]] = step
    return latest


@dataclass
class Resumed:
    """What a record says of a rollout stopped and kept."""

    fleet: str
    change: str
    selector: str | None
    canary: int
    healthy: float
    waves: list[list[str]]  # the rollout's waves, as it started
    done: dict[str, tuple[int, tuple[str, ...], tuple[str, ...]]]  # robot -> (wave, before, after)


def resumed(path: Path, steps: list[dict[str, Any]]) -> Resumed:
    """A record's rollout to go on with; RecordError when there is nothing to resume, or a
    step is not as a rollout writes it (said with its line)."""

    def strings(value: Any) -> bool:
        return isinstance(value, list) and all(isinstance(v, str) for v in value)

    start = steps[0]
    ends = [s for s in steps if s["step"] == "end"]
    if ends and ends[-1].get("result") != "stopped":
        raise RecordError(f"{path}: the rollout ended: {ends[-1].get('result')}: nothing to resume (start a new one)")
    waves = start.get("waves")
    if not (
        isinstance(start.get("fleet"), str)
        and isinstance(start.get("change"), str)
        and isinstance(start.get("canary"), int)
        and isinstance(start.get("healthy"), int | float)
        and isinstance(start.get("robots"), str | None)
        and isinstance(waves, list)
        and all(strings(w) for w in waves)
    ):
        raise RecordError(f"{path}:1: not the start of a rollout as fleet apply writes it")
    done: dict[str, tuple[int, tuple[str, ...], tuple[str, ...]]] = {}
    for number, s in enumerate(steps, 1):
        if s["step"] == "changed":
            if not (isinstance(s.get("robot"), str) and isinstance(s.get("wave"), int)
                    and strings(s.get("before")) and strings(s.get("after"))):
                raise RecordError(f"{path}:{number}: not a changed step as fleet apply writes it")
            done[s["robot"]] = (s["wave"], tuple(s["before"]), tuple(s["after"]))
        elif s["step"] == "rolled back" and isinstance(s.get("robot"), str):
            done.pop(s["robot"], None)
    return Resumed(start["fleet"], start["change"], start["robots"], start["canary"], float(start["healthy"]),
                   [list(w) for w in waves], done)


# ------------------------------------------------------------------ the rollout
@dataclass
class Options:
    canary: int = 1
    waves: int = 1
    healthy: float = 10.0  # s every changed robot stays healthy after a wave
    timeout: float = 20.0  # s for one call to a robot's node
    discover: float = 10.0  # s at most to find the robots on the graph


@dataclass
class Changed:
    """A robot the rollout changed: its active sets before and after, what moved."""

    namespace: str
    wave: int
    before: tuple[str, ...]
    after: tuple[str, ...]
    baseline: Health | None  # its last report before the change
    recent: float  # its share of missed deadlines before the change
    changed_at: float


@dataclass
class Outcome:
    """How the rollout ended, and what happened to every robot."""

    result: str  # "applied", "refused" (nothing changed), "rolled back", "stopped", "failed"
    why: str = ""
    robots: dict[str, str] = field(default_factory=dict)  # namespace -> what happened to it
    plans: list[RobotPlan] = field(default_factory=list)
    order: list[str] = field(default_factory=list)  # the robots in the order they are changed

    @property
    def exit_code(self) -> int:
        return {"applied": 0, "stopped": 130}.get(self.result, 1)


class Rollout:
    """One rollout of `request` to the selected running robots of a fleet file."""

    def __init__(
        self,
        fleet: Path,
        request: Request,
        selector: str | None,
        graph: Graph,
        options: Options,
        record: Record,
        say: Callable[[dict[str, Any]], None] = lambda step: None,
    ) -> None:
        self.fleet = fleet
        self.request = request
        self.selector = selector
        self.graph = graph
        self.options = options
        self.record = record
        self.say = say
        self.interrupt = threading.Event()  # set by Ctrl-C: stop between two robots
        self.changed: list[Changed] = []
        self.outcome = Outcome("applied")
        self._first: dict[str, Health] = {}
        self._plans: dict[str, RobotPlan] = {}
        self._back_done: set[str] = set()  # robots rolled back (a second rollback skips them)

    # ------------------------------------------------------------ steps
    def step(self, kind: str, level: str = "info", **said: Any) -> None:
        """One step: in the record, in the graph's log, and told to the caller."""
        step = {"step": kind, **said}
        self.record.write(step)
        text = f"rollout of {self.request}: {describe(step)}"
        try:  # (rclpy's logger: one severity per line of code that calls it)
            if level == "error":
                self.graph.log.error(text)
            elif level == "warning":
                self.graph.log.warning(text)
            else:
                self.graph.log.info(text)
        except Exception:  # noqa: S110 (rosout is a copy of the record: a rollout never stops for it)
            pass
        self.say(step)

    # ------------------------------------------------------------ running
    def run(self, resume: Resumed | None = None) -> Outcome:
        """The rollout; with `resume`, the rest of a rollout stopped and kept (its robots
        changed before are not planned for again: they are watched first)."""
        problems, plans = plan_fleet(self.fleet, self.request, self.selector, ask(self.graph, self.options.discover))
        if problems:
            self.outcome = Outcome("failed", "the fleet file has errors: nothing changed")
            self.step("end", "error", result="failed", why=self.outcome.why)
            return self.outcome
        done = resume.done if resume is not None else {}
        plans = [p for p in plans if p.namespace not in done]
        self.outcome.plans = plans
        self._plans = {p.namespace: p for p in plans}
        if resume is None:
            waves = waves_of([p.namespace for p in plans], self.options.canary, self.options.waves)
            self.step(
                "start",
                fleet=str(self.fleet),
                change=str(self.request),
                robots=self.selector,
                canary=self.options.canary,
                waves=waves,
                healthy=self.options.healthy,
            )
        else:  # (the record's waves, less the robots changed; a robot the file no longer selects is
            # left out, and one it selects now and no wave has goes last)
            waves = [[ns for ns in w if ns in self._plans or ns in done] for w in resume.waves]
            placed = {ns for w in waves for ns in w}
            waves.append([p.namespace for p in plans if p.namespace not in placed])
            left = [[ns for ns in w if ns not in done] for w in waves]
            self.step("resume", waves=[w for w in left if w], done=sorted(done))
        self.outcome.order = [ns for w in waves for ns in w]
        for p in plans:
            self.step(
                "planned",
                robot=p.namespace,
                accepted=p.accepted,
                loads=list(p.loads),
                unloads=list(p.unloads),
                why=[d.message for d in p.diagnostics],
            )
        # each robot's first report: its recent share of missed deadlines is measured from it
        everyone = [p.namespace for p in plans] + list(done)
        self.graph.wait_reports(everyone, 1.5)
        for namespace in everyone:
            said = self.graph.snapshot(namespace)
            report = health(said) if said is not None else None
            if report is not None:
                self._first[namespace] = report
        now = time.monotonic()  # (the robots changed before: judged from their first report here)
        self.changed = [
            Changed(ns, wave, before, after, self._first.get(ns), 0.0, now) for ns, (wave, before, after) in done.items()
        ]
        refused = [p for p in plans if not p.accepted]
        if refused:
            self.outcome.why = f"{len(refused)} of {len(plans)} robots refuse it in the plan"
            self.outcome.robots = {p.namespace: "refused in the plan" if not p.accepted else "unchanged" for p in plans}
            if self.changed:  # (resuming: the robots changed before are changed back)
                return self._back(self.outcome.why)
            self.outcome.result = "refused"
            self.outcome.why += ": nothing changed"
            self.step("end", "warning", result="refused", why=self.outcome.why)
            return self.outcome
        if self.changed and not self._healthy(0):  # resuming: the robots changed before, watched first
            return self._interrupted() if self.interrupt.is_set() else self._back("unhealthy")
        for number, wave in enumerate(waves, 1):
            wave = [ns for ns in wave if ns not in done]
            if not wave:
                continue
            self.step("wave", wave=number, robots=wave)
            for namespace in wave:
                if self.interrupt.is_set():
                    return self._interrupted()
                if not self._change(namespace, number):
                    return self._back("refused")
            if not self._healthy(number):
                return self._interrupted() if self.interrupt.is_set() else self._back("unhealthy")
        self.outcome.result = "applied"
        for c in self.changed:
            self.outcome.robots[c.namespace] = "changed"
        self.step("end", result="applied")
        return self.outcome

    def _change(self, namespace: str, wave: int) -> bool:
        """One robot changed by one call; False: refused, or no answer (then it is rolled
        back too: it may have taken the change)."""
        said = self.graph.snapshot(namespace)
        now = running(said)
        before = now.active if now is not None else self._plans[namespace].against
        baseline = health(said) if said is not None else None
        recent = 0.0
        first = self._first.get(namespace)
        if baseline is not None and first is not None and baseline.ticks > first.ticks:
            recent = (baseline.missed - first.missed) / (baseline.ticks - first.ticks)
        elif baseline is not None and baseline.ticks > 0:  # (no report between: its whole run's share)
            recent = baseline.missed / baseline.ticks
        accepted, reason = self.graph.set(namespace, wanted(self.request), self.options.timeout)
        if accepted is False:
            self.outcome.robots[namespace] = f"refused: {reason}"
            self.step("refused", "error", robot=namespace, wave=wave, why=reason)
            return False
        after = self._settled(namespace, now)
        settled = after is not None
        if after is None:  # (no news of it in time: what the plan said it would do)
            after = self._planned_after(namespace, before)
        self.changed.append(Changed(namespace, wave, before, after, baseline, recent, time.monotonic()))
        loads = [f for f in after if f not in before]
        unloads = [f for f in before if f not in after]
        extra: dict[str, Any] = {} if settled else {"settled": False}
        if accepted is None:
            self.outcome.robots[namespace] = f"no answer: {reason}"
            self.step("no answer", "error", robot=namespace, wave=wave, why=reason, loads=loads, unloads=unloads,
                      before=list(before), after=list(after))
            return False
        self.step("changed", robot=namespace, wave=wave, loads=loads, unloads=unloads, before=list(before),
                  after=list(after), **extra)
        return True

    def _planned_after(self, namespace: str, before: tuple[str, ...]) -> tuple[str, ...]:
        plan = self._plans[namespace]
        kept = [f for f in before if f not in plan.unloads]
        return tuple(kept + [f for f in plan.loads if f not in kept])

    def _settled(self, namespace: str, before: Running | None) -> tuple[str, ...] | None:
        """The robot's active set once its node has said the change (None: not within SETTLE s)."""
        deadline = time.monotonic() + SETTLE
        while True:
            now = running(self.graph.snapshot(namespace))
            if now is not None and (before is None or now.tick != before.tick or now.active != before.active):
                return now.active
            if time.monotonic() >= deadline:
                return None
            time.sleep(0.01)

    # ------------------------------------------------------------ health
    def _healthy(self, wave: int) -> bool:
        """Every robot changed so far healthy for `healthy` seconds (each then with a report
        made after its change); False at the first that is not, or on Ctrl-C."""
        if self.options.healthy <= 0:
            return True
        start = time.monotonic()
        end = start + self.options.healthy
        while True:
            for c in self.changed:
                why = self._unhealthy(c)
                if why is not None:
                    self.outcome.robots[c.namespace] = f"unhealthy: {why}"
                    self.step("unhealthy", "error", robot=c.namespace, wave=wave, why=why)
                    return False
            if self.interrupt.is_set():
                return False
            # the wait ends once every robot has reported since its change: one that does
            # not is stale STALE s after its last report (its health says so, above)
            if time.monotonic() >= end and all(self._last_report(c) > c.changed_at for c in self.changed):
                break
            self.interrupt.wait(WATCH_STEP)
        self.step("healthy", wave=wave, seconds=self.options.healthy, robots=[c.namespace for c in self.changed])
        return True

    def _last_report(self, c: Changed) -> float:
        said = self.graph.snapshot(c.namespace)
        return said.statuses_at if said is not None and said.reports else 0.0

    def _unhealthy(self, c: Changed) -> str | None:
        """Why the changed robot is not healthy now (None: it is)."""
        said = self.graph.snapshot(c.namespace)
        if said is None or not self.graph.alive(c.namespace):
            return "its node has left the graph"
        report = health(said)
        if report is None:
            return None if time.monotonic() - c.changed_at < STALE else "no /diagnostics report"
        if time.monotonic() - report.at > STALE:
            return f"no /diagnostics report for {STALE:g} s"
        if report.at <= c.changed_at:
            return None  # (the reports from before the change say nothing of it)
        if report.level == "ERROR":
            return f"ERROR on /diagnostics: {report.worst}"
        if c.baseline is not None and report.faults > c.baseline.faults:
            return f"{report.faults - c.baseline.faults} new fault(s) since the change ({report.worst})"
        if c.baseline is not None and report.ticks > c.baseline.ticks:
            share = (report.missed - c.baseline.missed) / (report.ticks - c.baseline.ticks)
            if share > c.recent + MISSED_MARGIN:
                return (
                    f"missed {share:.1%} of its deadlines since the change, "
                    f"against {c.recent:.1%} before it (allowed: {c.recent + MISSED_MARGIN:.1%})"
                )
        return None

    # ------------------------------------------------------------ ending
    def _interrupted(self) -> Outcome:
        """Ctrl-C: stopped between two robots; the caller decides on the rollback (`roll_back`)."""
        self.outcome.result = "stopped"
        self.outcome.why = "interrupted"
        for c in self.changed:
            self.outcome.robots[c.namespace] = "changed"
        self.step("interrupted", "warning", changed=[c.namespace for c in self.changed])
        return self.outcome

    def _back(self, cause: str) -> Outcome:
        self.outcome.why = cause
        return self.roll_back()

    def roll_back(self) -> Outcome:
        """Every robot changed, changed back (last first); the outcome says how each went.
        A robot whose inverse call is refused, unanswered or fails is said, and the others
        are still changed back."""
        failed = 0
        for c in reversed(self.changed):
            if c.namespace in self._back_done:
                continue
            said = self.outcome.robots.get(c.namespace, "")
            said = (said + "; ") if said and said != "changed" else ""
            moved = sorted(set(c.before) ^ set(c.after))
            inverse = {f: f in c.before for f in moved}
            if not inverse:
                self._back_done.add(c.namespace)
                self.outcome.robots[c.namespace] = said + "rolled back (nothing had moved)"
                continue
            try:
                accepted, reason = self.graph.set(c.namespace, inverse, self.options.timeout)
            except Exception as exc:  # (rclpy failing under the call: the others are still changed back)
                from ..errors import describe_exception

                accepted, reason = False, describe_exception(exc)
            if accepted:
                self._back_done.add(c.namespace)
                self.outcome.robots[c.namespace] = said + "rolled back"
                loads = [f for f in moved if inverse[f]]
                unloads = [f for f in moved if not inverse[f]]
                self.step("rolled back", robot=c.namespace, loads=loads, unloads=unloads)
            else:
                failed += 1
                why = reason if accepted is False else f"no answer: {reason}"
                self.outcome.robots[c.namespace] = said + f"NOT rolled back: {why}"
                self.step("not rolled back", "error", robot=c.namespace, why=why)
        self.outcome.result = "rolled back" if not failed else "failed"
        if failed:
            self.outcome.why += f"; {failed} robot(s) could not be rolled back"
        self.step("end", "warning", result=self.outcome.result, why=self.outcome.why)
        return self.outcome

    def failed(self, exc: BaseException) -> Outcome:
        """Something nobody expected went wrong in the rollout: every robot changed, changed back."""
        from ..errors import describe_exception

        self.outcome.why = f"the rollout failed: {describe_exception(exc)}"
        self.step("failed", "error", why=self.outcome.why)
        outcome = self.roll_back()
        outcome.result = "failed"
        return outcome

    def keep(self) -> Outcome:
        """Ctrl-C, and the changes kept: the record can be resumed."""
        self.step("end", "warning", result="stopped", why="interrupted; the robots changed keep the change")
        return self.outcome


def _moves(step: dict[str, Any]) -> str:
    moves = [f"loads {', '.join(step['loads'])}"] if step.get("loads") else []
    moves += [f"unloads {', '.join(step['unloads'])}"] if step.get("unloads") else []
    return "; ".join(moves) or "nothing moves"


def describe(step: dict[str, Any]) -> str:
    """A step of a rollout in words, one line (the CLI's and rosout's)."""
    kind = step["step"]
    robot = step.get("robot", "")
    if kind == "start":
        waves = step["waves"]
        robots = sum(map(len, waves))
        healthy = f", each then healthy for {step['healthy']:g} s" if step["healthy"] else ", no health waits"
        return f"start: {step['change']} to {robots} robot(s) in {len(waves)} wave(s){healthy}"
    if kind == "resume":
        return f"resume: {len(step['done'])} robot(s) changed before, {len(step['waves'])} wave(s) left"
    if kind == "planned":
        verdict = f"accepted: {_moves(step)}" if step["accepted"] else f"refused: {'; '.join(step['why'])}"
        return f"{robot}: planned: {verdict}"
    if kind == "wave":
        return f"wave {step['wave']}: {', '.join(step['robots'])}"
    if kind in ("changed", "rolled back"):
        return f"{robot}: {kind}: {_moves(step)}"
    if kind in ("refused", "unhealthy", "not rolled back"):
        return f"{robot}: {kind}: {step['why']}"
    if kind == "no answer":
        return f"{robot}: no answer: {step['why']} (it may have taken the change: it is rolled back too)"
    if kind == "failed":
        return f"failed: {step['why']}"
    if kind == "healthy" and step["wave"] == 0:
        return f"the robots changed before: every one healthy for {step['seconds']:g} s"
    if kind == "healthy":
        return f"wave {step['wave']}: every robot changed so far healthy for {step['seconds']:g} s"
    if kind == "interrupted":
        return f"interrupted: stopped between two robots ({len(step['changed'])} changed)"
    if kind == "end":
        return f"end: {step['result']}" + (f": {step['why']}" if step.get("why") else "")
    return str(kind)

"""fleet: many robots of one fleet file at once (reference.md section 9)."""

from __future__ import annotations

import json
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click
from rich.markup import escape

from ..errors import MotivmlError
from .common import Number, err, fail, out, plural, print_diagnostics

if TYPE_CHECKING:
    from ..fleet.rollout import Graph
    from ..runtime.requests import Request

T = TypeVar("T")
VERBS = ("load", "unload", "reload", "swap", "set")
APPLIED = ("load", "unload", "swap", "set")  # (a reload is no parameter call)


@click.group("fleet")
def fleet_group() -> None:
    """Many robots of one fleet file (FLEET.json), running or not (guidelines/a-fleet.md).

    `fleet list` shows the motivml robots running on the ROS 2 graph; `fleet plan` checks
    a change for every robot of a fleet file, touching none; `fleet apply` rolls it out to
    the running robots in waves, watching their health, and takes it back when one refuses
    or goes unhealthy. list, apply and a plan of running robots need ROS 2 (`make ros2`).
    A fleet's robot runs with `motivml run FLEET.json --ros2 --ros-namespace NS`.
    """


def _request(change: tuple[str, ...], verbs: tuple[str, ...]) -> Request:
    """CHANGE as a request: load F..., unload F..., reload F..., swap OUT IN, set +F -G..."""
    from ..runtime.requests import RequestError, Set
    from ..runtime.requests import change as parse

    if change[0] not in verbs:
        raise click.UsageError(f"{change[0]} is not a change for a fleet: {', '.join(verbs)}")
    options = [w for w in change if w.startswith("--")]
    if options:  # (the change's words may start with -, so unknown options come here: said as such)
        raise click.UsageError(f"no such option: {options[0]}")
    if change[0] == "set":
        signs = [w for w in change[1:] if w[:1] not in "+-" or len(w) < 2]
        if signs or len(change) < 2:
            raise click.UsageError(f"{' '.join(change)!r}: set takes +FEATURE and -FEATURE words, at least one")
        return Set(tuple(w[1:] for w in change[1:] if w[0] == "+"), tuple(w[1:] for w in change[1:] if w[0] == "-"))
    try:
        return parse(change[0], change[1:])
    except RequestError as exc:
        raise click.UsageError(f"{' '.join(change)!r}: {exc}") from None


@contextmanager
def _graph(prefix: str = "/") -> Iterator[Graph]:
    """The running robots, through ROS 2 (exit 3 with how to install it, when it is not there)."""
    try:
        from ..ros2.fleet import Watch

        watch = Watch(prefix)
    except MotivmlError as exc:
        fail(exc)
    try:
        yield watch
    finally:
        watch.close()


SELECTOR_HELP = "The robots: a glob over namespaces (/bay*; * also crosses /), or @GROUP for a group's robots (default: all)."
WAIT_HELP = "Seconds at most to find the running robots on the graph (discovery) [default: 10]."


@fleet_group.command("plan", context_settings={"ignore_unknown_options": True, "help_option_names": ["--help"]})
@click.argument("fleet", type=click.Path(dir_okay=False, readable=False))
@click.argument("change", nargs=-1, required=True)
@click.option("--robots", "selector", metavar="SELECTOR", help=SELECTOR_HELP)
@click.option(
    "--offline",
    is_flag=True,
    help="Plan against the active set each robot's variant starts with; ask no running robot (needs no ROS 2).",
)
@click.option("--wait", type=Number(min=0.0), default=10.0, metavar="SECONDS", help=WAIT_HELP)
def plan_command(fleet: str, change: tuple[str, ...], selector: str | None, offline: bool, wait: float) -> None:
    """Check CHANGE (load F..., unload F..., reload F..., swap OUT IN, set +F -G...) for
    each robot of FLEET as `ctl` checks it on a running robot, without touching anything:
    per robot, accepted with what loads and unloads, or refused with the reason and the
    repairs.

    The change is checked against the active set each running robot reports (its node
    `NS/motivml` on the ROS 2 graph); a robot not found within --wait seconds, or running
    another variant than the fleet file gives it, is refused. With --offline, against the
    active set each robot's variant starts with (with the fleet's overrides). Exit 0 when
    every robot accepts it, 1 when one refuses it or its configuration has errors, 2 for a
    change that is not one, 3 without ROS 2.
    """
    request = _request(change, VERBS)
    if offline:
        _plan(fleet, change, request, selector, None)
    _expected(fleet)  # (the fleet file's own errors are said before ROS 2 is asked for)
    with _graph() as graph:
        from ..fleet.rollout import ask

        _plan(fleet, change, request, selector, graph, ask(graph, wait))


def _plan(fleet: str, change: tuple[str, ...], request: Request, selector: str | None, graph: Graph | None, asking: Any = None) -> None:
    from ..fleet import plan_fleet

    plans = _checked(fleet, lambda: plan_fleet(fleet, request, selector, asking), ": nothing planned")
    if not plans:
        out.print(f"[yellow]no robot[/] of {escape(fleet)} is selected by {escape(str(selector))}")
        sys.exit(1)
    for plan in plans:
        if plan.accepted:
            moves = [f"loads {', '.join(plan.loads)}"] if plan.loads else []
            moves += [f"unloads {', '.join(plan.unloads)}"] if plan.unloads else []
            out.print(f"{escape(plan.namespace)}: [green]accepted[/]: {escape('; '.join(moves) or 'nothing moves')}")
        else:
            print_diagnostics(plan.diagnostics)
            out.print(f"{escape(plan.namespace)}: [bold red]refused[/]")
    refused = sum(1 for plan in plans if not plan.accepted)
    against = (
        "each robot's start state: no running robot was asked"
        if graph is None
        else "the active set each running robot reports"
    )
    out.print(
        f"{escape(' '.join(change))}: accepted by {len(plans) - refused} of {plural(len(plans), 'robot')}, "
        f"refused by {refused} (checked against {against})"
    )
    sys.exit(1 if refused else 0)


# ---------------------------------------------------------------------- list
@fleet_group.command("list")
@click.option(
    "--fleet",
    "fleet",
    type=click.Path(dir_okay=False, readable=False),
    help="List the robots of this fleet file (those not running too), in its order.",
)
@click.option("--prefix", default="/", show_default=True, metavar="NS", help="Only the robots under this namespace.")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table", show_default=True)
@click.option("--watch", is_flag=True, help="Keep the list live (once a second) until Ctrl-C.")
@click.option(
    "--record",
    type=click.Path(dir_okay=False, exists=True),
    help="A rollout record (fleet apply's): each robot's latest step in it, in a column of its own.",
)
@click.option("--wait", type=Number(min=0.0), default=10.0, metavar="SECONDS", help=WAIT_HELP)
def list_command(fleet: str | None, prefix: str, fmt: str, watch: bool, record: str | None, wait: float) -> None:
    """The motivml robots running on the ROS 2 graph (each `motivml run --ros2`'s node
    NS/motivml): namespace, robot, variant, active features, rate, missed deadlines, faults
    and health (the worst of its /diagnostics statuses).

    Robots are searched for --wait seconds at most: the search ends when no new robot has
    appeared for a moment (with --fleet, as soon as every robot of the file is found). Exit
    0, 1 when a robot of the fleet file is not running or one reports ERROR, 3 without ROS 2.
    """
    expected = _expected(fleet) if fleet else None
    steps = _record_steps(Path(record)) if record else None
    with _graph(prefix) as graph:
        graph.discover(wait, expected)
        names = expected if expected is not None else graph.namespaces()
        graph.wait_reports(names, min(wait, 1.5))
        rows = _rows(graph, names, steps)
        if not watch:
            _show(rows, fmt)
            sys.exit(1 if any(r["health"] in ("ERROR", "not running") for r in rows) else 0)
        _watch(graph, expected, steps, fmt)


def _expected(fleet: str) -> list[str]:
    """The namespaces of FLEET's robots, once the file itself is checked (its errors said, exit 1)."""
    from ..fleet import fleet_file, namespaces

    doc = _checked(fleet, lambda: fleet_file(fleet), "")
    assert doc is not None
    return namespaces(doc)


def _checked(fleet: str, call: Callable[[], tuple[list[Any], T]], said: str) -> T:
    """What `call` gives beside the fleet file's errors; those said, exit 1 (an unknown
    group of --robots: usage error; a file that cannot be read: exit 3)."""
    from ..fleet import UnknownGroup

    try:
        problems, result = call()
    except UnknownGroup as unknown:
        raise click.BadParameter(str(unknown), param_hint="'--robots'") from None
    except (MotivmlError, OSError) as exc:
        from .common import environment_problem

        fail(exc if isinstance(exc, MotivmlError) else environment_problem(exc))
    if problems:
        print_diagnostics(problems)
        out.print(f"[bold red]invalid[/]: {escape(fleet)}: {plural(len(problems), 'error')} in the fleet file{said}")
        sys.exit(1)
    return result


def _record_steps(path: Path) -> list[dict[str, Any]]:
    from ..fleet.rollout import RecordError, read_record

    try:
        return read_record(path)
    except RecordError as exc:
        raise click.BadParameter(str(exc), param_hint="'--record'") from None
    except UnicodeDecodeError:
        raise click.BadParameter(f"{path}: not a rollout record (not text)", param_hint="'--record'") from None


def _rows(graph: Graph, names: list[str], steps: list[dict[str, Any]] | None) -> list[dict[str, Any]]:
    from ..fleet.rollout import health, last_steps, running

    latest = last_steps(steps) if steps is not None else {}
    rows = []
    for namespace in names:
        said = graph.snapshot(namespace)
        state = running(said)
        report = health(said) if said is not None else None
        row: dict[str, Any] = {"namespace": namespace}
        if state is None:
            row.update(robot=None, variant=None, configuration=None, active=[], rate=None, achieved=None, missed=None, faults=None,
                       health="not running", status="no node on the graph")
        else:
            row.update(robot=state.robot, variant=state.variant, configuration=state.configuration,
                       active=list(state.active), tick=state.tick)
            if report is None:
                row.update(rate=None, achieved=None, missed=None, faults=None, health="unknown", status="no /diagnostics yet")
            else:
                row.update(rate=report.rate, achieved=report.achieved, missed=report.missed, faults=report.faults,
                           health=report.level, status=report.worst)
        if steps is not None:
            last = latest.get(namespace)
            row["rollout"] = None if last is None else {k: v for k, v in last.items() if k not in ("before", "after")}
        rows.append(row)
    return rows


def _table(rows: list[dict[str, Any]]) -> str:
    """The rows as aligned columns (rich markup: the health coloured)."""
    header = ["namespace", "robot", "variant", "active", "rate", "missed", "faults", "health"]
    recorded = any("rollout" in row for row in rows)
    if recorded:
        header.append("rollout")
    colours = {"OK": "green", "WARN": "yellow", "ERROR": "bold red", "not running": "bold red"}
    lines = [header]
    for row in rows:
        rate = "" if row.get("rate") is None else f"{row['achieved']:.0f}/{row['rate']:g} Hz"
        cells = [
            row["namespace"],
            row["robot"] or "",
            row["variant"] or "",
            str(len(row["active"])) if row["robot"] else "",
            rate,
            "" if row.get("missed") is None else str(row["missed"]),
            "" if row.get("faults") is None else str(row["faults"]),
            row["health"] + ("" if row["health"] == "OK" else f": {row['status']}"),
        ]
        if recorded:
            step = row.get("rollout")
            cells.append("" if step is None else f"{step['step']} ({step.get('at', '')})")
        lines.append(cells)
    widths = [max(len(line[k]) for line in lines) for k in range(len(header))]
    text = []
    for number, line in enumerate(lines):
        cells = [escape(cell.ljust(width)) for cell, width in zip(line[:-1], widths, strict=False)] + [escape(line[-1])]
        if number:
            colour = colours.get(rows[number - 1]["health"], "yellow")
            cells[7] = f"[{colour}]{cells[7]}[/]"
        text.append("  ".join(cells).rstrip())
    return "\n".join(text)


def _show(rows: list[dict[str, Any]], fmt: str) -> None:
    if fmt == "json":
        click.echo(json.dumps(rows, indent=2))
    elif not rows:
        out.print("no motivml robot on the graph")
    else:
        out.print(_table(rows))


def _watch(graph: Graph, expected: list[str] | None, steps: list[dict[str, Any]] | None, fmt: str) -> None:
    """The list, again every second, until Ctrl-C: live on a terminal, one JSON line (or
    table) a second on a pipe."""
    def rows() -> list[dict[str, Any]]:
        graph.discover(0.0, expected)
        names = expected if expected is not None else graph.namespaces()
        return _rows(graph, names, steps)

    if fmt == "table" and out.is_terminal:
        from rich.live import Live

        with Live(_table(rows()), console=out, refresh_per_second=2) as view:
            while True:
                time.sleep(1.0)
                view.update(_table(rows()))
    while True:
        if fmt == "json":
            click.echo(json.dumps(rows()))
        else:
            out.print(_table(rows()))
        sys.stdout.flush()
        time.sleep(1.0)


# ---------------------------------------------------------------------- apply
@fleet_group.command("apply", context_settings={"ignore_unknown_options": True, "help_option_names": ["--help"]})
@click.argument("fleet", type=click.Path(dir_okay=False, readable=False), required=False)
@click.argument("change", nargs=-1)
@click.option("--robots", "selector", metavar="SELECTOR", help=SELECTOR_HELP)
@click.option("--canary", type=click.IntRange(min=0), default=1, show_default=True, help="Robots changed first, on their own.")
@click.option("--waves", type=click.IntRange(min=1), default=1, show_default=True, help="Waves the other robots are changed in.")
@click.option(
    "--healthy",
    type=Number(min=0.0),
    default=10.0,
    show_default=True,
    metavar="SECONDS",
    help="Seconds every changed robot must stay healthy before the next wave (0: no health waits).",
)
@click.option("--timeout", type=Number(min=0.1), default=20.0, show_default=True, metavar="SECONDS", help="Seconds one robot's call may take.")
@click.option("--wait", type=Number(min=0.0), default=10.0, metavar="SECONDS", help=WAIT_HELP)
@click.option(
    "--record",
    type=click.Path(dir_okay=False),
    help="The rollout record (JSON lines) [default: build/rollouts/UTC-TIME.jsonl].",
)
@click.option("--dry-run", is_flag=True, help="Plan only: fleet plan against the running robots.")
@click.option(
    "--resume",
    type=click.Path(dir_okay=False, exists=True),
    metavar="RECORD",
    help="Go on with a rollout stopped by Ctrl-C and kept (its record; FLEET and CHANGE from it).",
)
@click.option(
    "--on-interrupt",
    type=click.Choice(["ask", "rollback", "keep"]),
    default="ask",
    show_default=True,
    help="On Ctrl-C: ask whether to roll back (on a terminal; roll back elsewhere), roll back, or keep the changes.",
)
def apply_command(
    fleet: str | None,
    change: tuple[str, ...],
    selector: str | None,
    canary: int,
    waves: int,
    healthy: float,
    timeout: float,
    wait: float,
    record: str | None,
    dry_run: bool,
    resume: str | None,
    on_interrupt: str,
) -> None:
    """Roll CHANGE (load F..., unload F..., swap OUT IN, set +F -G...) out to the running
    robots of FLEET in stages: the --canary robots first, then the others in --waves waves.

    First the change is planned for every selected robot against the active set it reports;
    when one would refuse it, nothing is touched. Then each robot is changed by one atomic
    parameter call on its node, and after each wave every robot changed so far must stay
    healthy for --healthy seconds (on the graph and reporting, no ERROR on /diagnostics, no
    new fault, missed deadlines within its own recent share plus 1%). A refusal or an
    unhealthy robot stops the rollout, and every robot changed is changed back. Ctrl-C stops
    between two robots (see --on-interrupt). Every step goes to the record and to rosout.

    Exit 0 applied, 1 refused, unhealthy or rolled back, 2 usage, 3 without ROS 2, 130 stopped by Ctrl-C.
    """
    from ..fleet.rollout import Options, Record, Rollout

    resuming = _resumed(resume, fleet, change) if resume is not None else None
    if resuming is not None:
        fleet, change = resuming.fleet, tuple(resuming.change.split())
        selector, canary, healthy = resuming.selector, resuming.canary, resuming.healthy
    if fleet is None or not change:
        raise click.UsageError("fleet apply needs FLEET and CHANGE (or --resume RECORD)")
    request = _request(change, APPLIED)
    _expected(fleet)  # (the fleet file's own errors: said, and nothing is asked of any robot)
    _some_robot(fleet, selector)
    if dry_run:
        with _graph() as graph:
            from ..fleet.rollout import ask

            _plan(fleet, change, request, selector, graph, ask(graph, wait))
    try:
        if resume is not None:
            book = Record(Path(resume), resume=True)
        elif record is not None:
            book = Record(Path(record))
        else:
            book = Record.new(Path("build", "rollouts"))
    except FileExistsError:
        raise click.BadParameter(f"{record} exists: a new rollout writes a new record (--resume goes on with one)",
                                 param_hint="'--record'") from None
    except OSError as exc:
        from .common import environment_problem

        fail(environment_problem(exc))
    out.print(f"record: {escape(str(book.path))}")
    with _graph() as graph:
        rollout = Rollout(Path(fleet), request, selector, graph, Options(canary, waves, healthy, timeout, wait), book, _say)
        try:
            with _interruptible(rollout.interrupt):
                try:
                    outcome = rollout.run(resuming)
                except Exception as exc:  # (a defect, or rclpy failing under it: never leave robots half changed)
                    outcome = rollout.failed(exc)
            if outcome.result == "stopped":
                back = _roll_back(on_interrupt, len(rollout.changed))
                with _interruptible(threading.Event()):  # (a rollback is not cut short by another Ctrl-C)
                    outcome = rollout.roll_back() if back else rollout.keep()
        finally:
            book.close()
    _report(outcome, book)
    sys.exit(outcome.exit_code)


def _resumed(resume: str, fleet: str | None, change: tuple[str, ...]) -> Any:
    """The record's rollout to go on with (usage errors for one that cannot be, or for a
    FLEET and CHANGE that are not its own)."""
    from ..fleet.rollout import RecordError, read_record, resumed

    try:
        steps = read_record(Path(resume))
        resuming = resumed(Path(resume), steps)
    except RecordError as exc:
        raise click.BadParameter(str(exc), param_hint="'--resume'") from None
    except UnicodeDecodeError:
        raise click.BadParameter(f"{resume}: not a rollout record (not text)", param_hint="'--resume'") from None
    if fleet is not None:
        same = Path(fleet) == Path(resuming.fleet)
        if change:
            same = same and str(_request(change, APPLIED)) == resuming.change
        if not same:
            raise click.UsageError(
                f"--resume {resume} goes on with the rollout of {resuming.change} to {resuming.fleet}: "
                "give no FLEET and CHANGE, or those"
            )
    return resuming


def _some_robot(fleet: str, selector: str | None) -> None:
    """A selector that names no group of the file is a usage error; one that selects no robot, exit 1."""
    from ..fleet import selected_namespaces

    if not _checked(fleet, lambda: ([], selected_namespaces(fleet, selector)), ""):
        out.print(f"[yellow]no robot[/] of {escape(fleet)} is selected by {escape(str(selector))}")
        sys.exit(1)


@contextmanager
def _interruptible(flag: Any) -> Iterator[None]:
    """Ctrl-C sets `flag` (the rollout stops between two robots) instead of raising (in the
    main thread: only it gets signals)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGINT, lambda *_: flag.set())
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


def _roll_back(choice: str, changed: int) -> bool:
    if choice != "ask":
        return choice == "rollback"
    if not changed:
        return True
    if not _terminal():
        err.print("interrupted: rolling back (not a terminal to ask on; --on-interrupt keep keeps the changes)")
        return True
    try:
        return click.confirm(f"interrupted: roll back the {plural(changed, 'robot')} changed?", default=True, err=True)
    except click.Abort:  # (Ctrl-C or the end of input at the question: the changes are kept, the record resumable)
        err.print("kept: the robots changed keep the change (fleet apply --resume goes on with it)")
        return False


def _terminal() -> bool:
    """Whether a person can be asked (standard input is a terminal)."""
    return sys.stdin.isatty()


def _say(step: dict[str, Any]) -> None:
    from ..fleet.rollout import describe

    if step["step"] == "planned" and step["accepted"] or step["step"] == "end":
        return  # (the accepted plans are the changes that follow; the end is the report's)
    colour = {"changed": "green", "healthy": "green", "refused": "bold red", "unhealthy": "bold red",
              "not rolled back": "bold red", "planned": "bold red", "interrupted": "yellow"}.get(step["step"])
    text = escape(describe(step))
    out.print(f"[{colour}]{text}[/]" if colour else text)


def _report(outcome: Any, book: Any) -> None:
    path = book.path
    colour = {"applied": "green", "stopped": "yellow"}.get(outcome.result, "bold red")
    order = {namespace: k for k, namespace in enumerate(outcome.order)}  # (the order of the waves)
    for namespace, what in sorted(outcome.robots.items(), key=lambda item: order.get(item[0], len(order))):
        out.print(f"  {escape(namespace)}: {escape(what)}")
    why = f": {outcome.why}" if outcome.why else ""
    out.print(f"[{colour}]{outcome.result}[/]{escape(why)} (record: {escape(str(path))})")
    if book.failure is not None:
        err.print(f"[bold red]the record is incomplete[/]: {escape(book.failure)} (every step went to rosout)")

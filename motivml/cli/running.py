"""run and ctl: the robot at run time (the loop, its live view and summary, its socket)."""

from __future__ import annotations

import json
import math
import os
import signal
import sys
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import click
from rich import box
from rich.console import Console, Group
from rich.markup import escape
from rich.table import Table

from ..binding import PREFERENCES
from ..errors import EnvironmentProblem, Location, MotivmlError, error
from ..runtime.requests import VERBS, Event, Request, RequestError, parse
from .common import (
    MAX_SECONDS,
    Number,
    err,
    fail,
    one_variant,
    out,
    plural,
    print_diagnostics,
    printable,
    shown,
)

if TYPE_CHECKING:
    from ..runtime.launch import Robot
    from ..runtime.loop import RunStats, Runtime, Snapshot
    from ..runtime.record import Recorder
    from ..runtime.session import Feed, Session


@click.command("run")
@click.argument("target", type=click.Path(readable=False))
@click.option("--variant", help="The variant of the robot folder: variants/NAME.json.")
@click.option(
    "--config",
    "config",
    type=click.Path(readable=False),
    help="A configuration file, instead of --variant (the run goes by its stem, for ctl --variant).",
)
@click.option(
    "--duration",
    type=Number(min=0, min_open=True, max=MAX_SECONDS, allow_inf=True),
    default=5.0,
    show_default=True,
    help=f"Seconds of clock time to run, at most {MAX_SECONDS:g}; inf: until stopped (Ctrl-C, SIGTERM).",
)
@click.option(
    "--rate",
    type=Number(min=1, max=100_000),
    default=1000.0,
    show_default=True,
    help="Control loop rate in Hz.",
)
@click.option(
    "--clock",
    type=click.Choice(["real", "simulated"]),
    default="real",
    show_default=True,
    help="real: tick on the wall clock; simulated: tick as fast as possible in simulated time.",
)
@click.option("--live/--no-live", default=None, help="Show the live view (default: when on a terminal).")
@click.option(
    "--prefer",
    type=click.Choice(PREFERENCES),
    multiple=True,
    help="Resolve the variant as configure --prefer does.",
)
@click.option(
    "--run-dir",
    type=click.Path(file_okay=False, readable=False),
    help="Where the control socket goes (default build/<robot>/<variant>/run).",
)
@click.option(
    "--control/--no-control", default=True, show_default=True, help="Open the control socket for motivml ctl."
)
@click.option(
    "--strict",
    is_flag=True,
    help="Refuse a Dynamic feature that nothing implements (no plugin, no architecture element, not abstract).",
)
@click.option(
    "--cpus",
    metavar="LIST",
    help="Run on these CPUs only, e.g. 0 or 2-3 (Linux): the loop and its threads keep a core of their own.",
)
@click.option(
    "--priority",
    type=click.IntRange(0, 99),
    metavar="N",
    help="Run the loop's thread under SCHED_FIFO at real-time priority N (1-99; Linux, needs root, "
    "CAP_SYS_NICE or an rtprio limit): it then wakes on time however busy the machine is. Without "
    "it, a real-clock run takes priority 50 where it may and ordinary scheduling where not, and says "
    "which; 0: ordinary scheduling.",
)
@click.option(
    "--ros2",
    is_flag=True,
    help="Start the ROS 2 node NS/motivml: features.<id>.active parameters, ~/active_features, /diagnostics (needs make ros2).",
)
@click.option(
    "--ros-namespace",
    default="/",
    show_default=True,
    help="The ROS namespace of the motivml node and of relative ros2_lifecycle node names.",
)
@click.option(
    "--at",
    "scheduled",
    type=(click.FloatRange(min=0), str),
    multiple=True,
    metavar="SECONDS REQUEST",
    help='Make a request at a control time, e.g. --at 2 "swap hectorslam kartoslam" (repeatable).',
)
@click.option(
    "--record",
    type=click.Path(dir_okay=False, readable=False),
    metavar="FILE.csv",
    help="Record the spaces' values at every tick and what happened at it (reconfigurations, coordination "
    "states, faults) in FILE.csv; draw it with motivml plot.",
)
def run_command(
    target: str,
    variant: str | None,
    config: str | None,
    duration: float,
    rate: float,
    clock: str,
    live: bool | None,
    prefer: tuple[str, ...],
    run_dir: str | None,
    control: bool,
    strict: bool,
    cpus: str | None,
    priority: int | None,
    ros2: bool,
    ros_namespace: str,
    scheduled: tuple[tuple[float, str], ...],
    record: str | None,
) -> None:
    """Build the motion architecture of a variant's active features and run it at a fixed rate.

    The active set at start is every Early feature plus the fewest Late ones the model
    needs (reference.md section 4); exactly their spaces, mappings, modules and components
    run. Ends with a summary: each component's status and when its criterion fired, each
    module's learning state, the final space values and the loop's timing.

    With --ros2 the run is also a ROS 2 node (guidelines/running-with-ros2.md): its features
    are parameters that any ROS 2 client may set, every change checked against the model.

    The variant is --variant NAME (variants/NAME.json) or --config FILE, a configuration
    document anywhere; a run of FILE goes by FILE's stem (its run folder, ctl --variant).
    TARGET may be a fleet file with --ros-namespace NS: its robot there, with the fleet's layers.

    With --record FILE.csv, one row per tick: tick, time, every number of every space the
    variant may run, and the tick's events; the file appears whole when the run ends.
    """
    target, variant, config = _fleet_robot(target, variant, config, ros_namespace)
    name = one_variant(config, variant)
    ros_namespace = _ros_options(ros2, ros_namespace)
    priority, insist, scheduling = _scheduling(clock, priority)
    if cpus is not None:
        from ..runtime.session import keep_to_cpus

        try:
            keep_to_cpus(cpus)  # before any thread starts: every thread of the run inherits it
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--cpus") from None
    plan = _plan(scheduled, duration)
    recorder = _recorder(record)
    robot = _launched(target, variant, rate, prefer, strict, ros_namespace, config, name)
    from ..runtime.session import Session

    print_diagnostics(robot.warnings)
    if not out.is_terminal:  # a log or a pipe: never cut the summary table to 80 columns
        out.width = max(out.width, 160)
    folder = (
        (Path(run_dir) if run_dir else Path("build") / robot.folder.name / name / "run")
        if control
        else None
    )
    session = Session(
        robot, duration, clock, plan, folder, on_stuck=_stuck, variant=name, priority=priority, record=recorder, insist=insist
    )
    try:
        session.open()
    except MotivmlError as exc:
        fail(exc)
    # (after the socket opened: a run refused, another run listening there, announces nothing)
    _announce(robot, name, rate, clock, scheduling, duration)
    if session.server is not None:
        out.print(f"control: {escape(str(session.server.path))} (motivml ctl)")
    if ros2:
        _open_door(session, ros_namespace)
    if session.coordinator is None and any(isinstance(request, Event) for _, request in plan):
        session.close()
        raise click.BadParameter(
            "events go to a coordination statechart, and this robot has none", param_hint="--at"
        )
    _watch(session, out.is_terminal if live is None else live)
    _ended(session, recorder)


def _announce(robot: Robot, name: str, rate: float, clock: str, scheduling: str, duration: float) -> None:
    out.print(
        f"running {escape(robot.folder.name)} variant {escape(name)}: "
        f"{plural(len(robot.assembly.components), 'component')} of {plural(len(robot.active), 'active feature')} "
        f"({escape(', '.join(robot.active))}) at {rate:g} Hz, {clock} clock, "
        + scheduling
        + (f"{duration:g} s" if math.isfinite(duration) else "until stopped")
    )


def _ros_options(ros2: bool, ros_namespace: str) -> str:
    """The ROS 2 namespace, checked; with --ros2, ROS 2 there (before anything starts)."""
    from ..plugins.ros2 import namespace, ros2_missing

    try:
        ros_namespace = namespace(ros_namespace)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--ros-namespace") from None
    if ros2:
        missing = ros2_missing()  # say at once that ROS 2 is missing
        if missing is not None:
            fail(missing)
    return ros_namespace


def _open_door(session: Session, ros_namespace: str) -> None:
    """The run's ROS 2 node (the session closes it), or the reason there is none, and exit."""
    try:
        from ..ros2.door import start

        door = start(session.robot, ros_namespace)
    except MotivmlError as exc:
        session.close()
        fail(exc)
    session.doors.append(door.close)
    out.print(f"ROS 2: node {escape(door.name)} (features.<id>.active parameters)")


def _scheduling(clock: str, priority: int | None) -> tuple[int | None, bool, str]:
    """The loop's priority, whether to insist on it, and how the `running ...` line says it
    (the runtime's policy, `run_scheduling`: without --priority, real time where it may, as
    ros2_control does)."""
    if clock != "real":
        if priority:
            raise click.BadParameter("a priority is for the real clock", param_hint="--priority")
        return None, True, ""
    from ..runtime.loop import run_scheduling

    chosen = run_scheduling(priority)
    if chosen.problem is not None:
        fail(EnvironmentProblem(error(Location("run --priority"), chosen.problem, "run.priority")))
    return chosen.priority, chosen.insist, f"{chosen.said}, "


def _plan(scheduled: tuple[tuple[float, str], ...], duration: float) -> list[tuple[float, Request | Event]]:
    """The --at requests, parsed, checked to fall in the run, in their order in time."""
    plan: list[tuple[float, Request | Event]] = []
    for at, text in scheduled:
        verb, *words = text.split() or [""]
        try:
            plan.append((at, parse(verb, words)))
        except RequestError as exc:
            raise click.BadParameter(
                f"{text!r}: {exc}; a request is load|unload|reload FEATURE..., swap OUT IN, or event NAME",
                param_hint="--at",
            ) from None
    for at, request in plan:
        if not math.isfinite(at) or at >= duration:
            raise click.BadParameter(
                f"{at:g} s for {request}: requests are made during the run, before {duration:g} s",
                param_hint="--at",
            )
    plan.sort(key=lambda item: item[0])
    return plan


_FLEET_CONFIGS: list[Any] = []  # the temporary folders of a fleet robot's configuration (removed at exit)


def _fleet_robot(
    fleet: str, variant: str | None, config: str | None, namespace: str
) -> tuple[str, str | None, str | None]:
    """TARGET, --variant and --config as they are, or, when TARGET is a fleet file, its
    robot's folder and configuration file in `namespace` (its variant with the fleet's
    layers, written to a temporary file named as the variant; reference.md section 9)."""
    import tempfile

    from ..fleet import fleet_robot, is_fleet_file

    if not is_fleet_file(fleet):
        return fleet, variant, config

    if variant is not None or config is not None:
        raise click.UsageError("a fleet file names each robot's variant: no --variant or --config with it")
    if namespace.strip("/") == "":
        raise click.UsageError("a fleet file needs --ros-namespace NS: the robot of the file to run")
    try:
        problems, robot = fleet_robot(fleet, namespace)
    except MotivmlError as exc:
        fail(exc)
    if problems:
        print_diagnostics(problems)
        out.print(f"[bold red]cannot run[/]: {escape(fleet)} has errors")
        sys.exit(1)
    if robot is None:
        raise click.UsageError(f"no robot of {fleet} has the namespace {'/' + namespace.strip('/')}")
    if not robot.valid or robot.document is None:
        print_diagnostics(robot.errors)
        out.print(f"[bold red]cannot run[/]: robot {escape(robot.namespace)} of {escape(fleet)}: its configuration has errors")
        sys.exit(1)
    folder = tempfile.TemporaryDirectory(prefix="motivml-fleet-")
    _FLEET_CONFIGS.append(folder)
    path = Path(folder.name) / f"{robot.variant}.json"
    path.write_text(json.dumps(robot.document))
    return robot.folder, None, str(path)


def _launched(
    target: str,
    variant: str | None,
    rate: float,
    prefer: tuple[str, ...],
    strict: bool,
    ros_namespace: str,
    config: str | None,
    name: str,
) -> Robot:
    """The robot launched (its plugins started), or the reason it cannot run, and exit."""
    from ..runtime.launch import launch
    from ..runtime.session import EXIT_INTERRUPTED

    interrupted = []  # a real Ctrl-C while launching (a plugin's KeyboardInterrupt is its fault)

    def interrupt(signum: int, frame: object) -> None:
        interrupted.append(signum)
        raise KeyboardInterrupt

    guarding = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, interrupt) if guarding else None
    try:
        robot = launch(target, variant, rate, prefer, strict, ros_namespace, config_path=config)
    except MotivmlError as exc:
        if interrupted:  # the Ctrl-C came while a plugin started: it failed because of it
            out.print("interrupted before the run started")
            sys.exit(EXIT_INTERRUPTED)
        print_diagnostics(exc.diagnostics)
        out.print(f"[bold red]cannot run[/]: {escape(target)} variant {escape(name)}")
        sys.exit(exc.exit_code)
    except KeyboardInterrupt:
        out.print("interrupted before the run started")
        sys.exit(EXIT_INTERRUPTED)
    finally:
        if guarding:
            signal.signal(signal.SIGINT, previous)
    return robot


def _stuck(signum: int) -> None:
    """A second Ctrl-C (or SIGTERM) while the loop is stuck in a plugin: exit now."""
    err.print(
        "[bold red]interrupted twice[/]: the control loop did not stop (a plugin's step that never returns?); exiting now"
    )
    os._exit(128 + signum)  # (130 after Ctrl-C, as before; 143 after SIGTERM)


def _watch(session: Session, show: bool) -> None:
    """Start the run and follow it (a live view on a terminal) until it ends."""
    from rich.live import Live

    session.start()
    try:
        if show:
            with Live(_live_view(session.feed()), console=out, refresh_per_second=4, transient=True) as view:
                while not session.wait(0.25):
                    _report(session, view.console)
                    view.update(_live_view(session.feed()))
        else:
            while not session.wait(0.25):
                _report(session, out)
        _report(session, out)  # the rest of the log (and of the changes, if the run ended first), before the summary
    finally:
        session.stop_watching()


def _ended(session: Session, recorder: Recorder | None) -> NoReturn:
    """The run's summary, how it ended, and its exit code."""
    robot = session.robot
    runtime = robot.runtime
    if session.realtime_refused is not None:  # as before the run, had it been refused then
        session.close()
        fail(EnvironmentProblem(error(Location("run --priority"), session.realtime_refused, "run.priority")))
    if session.stats is None:
        out.print("[bold red]the run ended without a result[/]")
        session.close()  # the plugins stopped, and the record (if any) completed
        sys.exit(session.exit_code())
    for answer in session.answers():
        verdict = "accepted" if answer.outcome.accepted else "refused, nothing changed"
        out.print(escape(f"request at {answer.time:.3f} s (tick {answer.tick}): {answer.request}: {verdict}"))
        print_diagnostics(answer.outcome.diagnostics)
    _summary(runtime, session.stats)
    coordinator = session.coordinator
    if coordinator is not None:
        if coordinator.finished is not None:
            at, tick, state = coordinator.finished
            out.print(escape(f"coordination reached its final state {state} at {at:.3f} s (tick {tick})"))
        else:
            out.print(escape(f"coordination in: {', '.join(coordinator.configuration())}"))
    if runtime.failure is not None:
        fault = runtime.failure
        out.print(
            f"[bold red]the run stopped[/]: {escape(fault.feature)} raised in its step at {fault.time:.3f} s "
            f"(tick {fault.tick}): {escape(fault.error)}"
        )
    diverged = runtime.diverged()
    if diverged:
        out.print(
            f"[bold red]the run diverged[/]: {escape(', '.join(diverged))} hold non-finite values "
            "(a system too stiff for its time step, or a goal out of range)"
        )
    session.close()
    _report_notes(session, out)  # what plugins said while they stopped
    failed_stops = robot.binder.failed_stops
    if failed_stops:
        out.print(
            f"[bold red]the run did not end cleanly[/]: stop() of {escape(', '.join(failed_stops))} raised"
        )
    if session.record_problem is not None:
        for d in session.record_problem.diagnostics:
            err.print(f"[bold red]{escape(str(d.location))}[/]: {escape(d.message)}")
    elif recorder is not None and session.recorded is not None:
        out.print(f"recorded {plural(session.recorded, 'tick')} in {escape(str(recorder.path))}")
    sys.exit(session.exit_code())


def _recorder(record: str | None) -> Recorder | None:
    """The run's recorder: its file made now, before anything starts, and removed if the
    command ends before the run does (an invalid variant, a plugin that cannot start)."""
    if record is None:
        return None
    path = Path(record)
    suffix = path.suffix.lower()
    if suffix in (".parquet", ".pq"):
        raise click.BadParameter(
            f"{record!r}: Parquet is not supported: a record is CSV (give a FILE ending in .csv)",
            param_hint="--record",
        )
    if suffix != ".csv":
        raise click.BadParameter(
            f"{record!r}: a record is CSV: give a FILE ending in .csv", param_hint="--record"
        )
    from ..runtime.record import Recorder

    try:
        recorder = Recorder.create(path)
    except MotivmlError as exc:
        fail(exc)
    click.get_current_context().call_on_close(recorder.discard)
    return recorder


def _report(session: Session, console: Console) -> None:
    """Print what happened since the last call, as it happens: accepted changes (on the real
    clock: the summary lists them all by control time), log lines.

    A run on the simulated clock is a replay: its output is the same bytes every time, so
    nothing in it depends on when this is called (a change stamped with the wall clock
    showed up in some runs and not in others, as the machine was busy or not)."""
    changes = session.new_changes()
    if not session.simulated:
        for change in changes:
            stamp = time.strftime("%H:%M:%S", time.localtime(change.wall)) + f".{int(change.wall % 1 * 1000):03d}"
            console.print(escape(printable(f"{stamp} tick {change.tick}: {change.request}")))
    _report_notes(session, console)


def _report_notes(session: Session, console: Console) -> None:
    for at, tick, text in session.new_notes():
        console.print(shown(f"at {at:.3f} s (tick {tick}): {text}"))


STATUS_COLOURS = {"converged": "green", "tracking": "green", "ongoing": "yellow", "learning": "cyan"}


def _components_table(snapshot: Snapshot, runtime: Runtime | None = None) -> Table:
    table = Table(box=box.SIMPLE_HEAD, show_edge=False, pad_edge=False)
    for column in ("component", "kind", "status", "error", "learning"):
        table.add_column(column, justify="right" if column == "error" else "left", no_wrap=True)
    if runtime is not None:
        table.add_column("fired at", no_wrap=True)
    for c in snapshot.components:
        colour = STATUS_COLOURS.get(c.status, "white")
        row = [
            escape(c.id),
            c.kind,
            f"[{colour}]{c.status}[/]",
            "" if c.error != c.error else f"{c.error:.4f}",
            c.learning,
        ]
        if runtime is not None:
            fired = next(
                (e for e in runtime.events if e.component == c.id and e.status in ("converged", "tracking")),
                None,
            )
            row.append(f"{fired.time:.3f} s" if fired else "-")
        table.add_row(*row)
    return table


def _live_view(feed: Feed) -> Group:
    snapshot = feed.snapshot
    head = f"tick {snapshot.tick}  t = {snapshot.time:.3f} s  achieved {feed.achieved:,.0f} Hz (asked {feed.rate:g} Hz)"
    if feed.coordination is not None:
        head += f"\ncoordination: {', '.join(feed.coordination)}"
    return Group(head, _components_table(snapshot))


def _summary(runtime: Runtime, stats: RunStats) -> None:
    snapshot = runtime.status()
    if snapshot.components:
        out.print(_components_table(snapshot, runtime))
    for module, state, learned in snapshot.modules:
        extra = f", learned {learned} time{'s' if learned != 1 else ''}" if learned else ""
        out.print(f"module {escape(module)}: {state}{extra}")
    for feature, status in snapshot.plugins:
        out.print(escape(printable(f"plugin {feature}: {status}")))
    for change in runtime.changes:
        out.print(escape(f"changed at {change.time:.3f} s (tick {change.tick}): {change.request}"))
    for space, value in runtime.assembly.values.items():
        numbers = ", ".join(f"{v:.3f}" for v in value)
        out.print(escape(f"space {space} = [{numbers}]"))
    line = f"{stats.ticks} ticks, {snapshot.time:.3f} s of control time"
    if stats.clock == "real":
        p50, p99 = (stats.percentile(stats.jitter, q) * 1e3 for q in (50, 99))
        worst = (float(stats.jitter.max()) if len(stats.jitter) else 0.0) * 1e3
        line += (
            f" in {stats.elapsed:.3f} s: {stats.achieved:,.1f} Hz achieved (asked {stats.rate:g} Hz); "
            f"jitter p50 {p50:.3f} ms, p99 {p99:.3f} ms, max {worst:.3f} ms; "
            f"{plural(stats.missed, 'missed deadline')}; CPU {stats.cpu_share:.0%}"
        )
    out.print(line)
    if stats.clock == "real" and snapshot.slowest:  # which plugin made the ticks overrun (wall-clock times)
        steps = ", ".join(
            f"{feature} {took * 1e3:.3f} ms (tick {tick})" for feature, took, tick in snapshot.slowest
        )
        out.print(escape(printable(f"slowest plugin steps: {steps}")))


@click.command("ctl")
@click.argument("target", type=click.Path(readable=False), required=False, metavar="TARGET")
@click.option("--variant", help="The variant that runs (to find its run).")
@click.option(
    "--run-dir", type=click.Path(file_okay=False, readable=False), help="The run's directory, if run was given one."
)
@click.option("--list", "listing", is_flag=True, help="List the runs ctl can reach, and exit.")
@click.argument(
    "op",
    type=click.Choice(["load", "unload", "reload", "swap", "event", "status", "dump"]),
    required=False,
    metavar="{load|unload|reload|swap|event|status|dump}",
)
@click.argument("features", nargs=-1)
def ctl_command(
    target: str | None,
    variant: str | None,
    run_dir: str | None,
    listing: bool,
    op: str | None,
    features: tuple[str, ...],
) -> None:
    """Talk to a running robot: load, unload, reload or swap features, or ask its status.

    TARGET and --variant name the run, from any working directory: every run registers in a
    per-user directory ($XDG_RUNTIME_DIR/motivml/runs, else /tmp/motivml-<uid>/runs), and
    ctl looks it up there (else in build/<robot>/<variant>/run below the working directory;
    --run-dir names a run's directory outright). --list (or ctl list) prints the runs ctl
    can reach, of TARGET and --variant if given. A change is checked against the model and the variant first; a refused one
    changes nothing and says why (exit 1); ctl waits for a change's outcome, however long
    its plugins take to start. status prints the active set, components and plugins; dump
    prints everything as JSON.
    """
    from ..runtime.control import send

    if listing or (target == "list" and op is None):  # ctl --list [TARGET], or ctl list
        if op is not None:
            raise click.UsageError("--list takes no op")
        _list_runs(target if target != "list" else None, variant, run_dir)
        return
    ctx = click.get_current_context()
    params = {p.name: p for p in ctx.command.params}
    for name, value in (("target", target), ("op", op), ("variant", variant)):
        if value is None:  # required unless listing, and said as click says it
            raise click.MissingParameter(ctx=ctx, param=params[name])
    assert target is not None and variant is not None and op is not None
    if op in ("status", "dump") and features:
        raise click.UsageError(f"{op} takes no features")
    if op not in ("status", "dump"):
        try:
            parse(op, features)
        except RequestError as exc:
            raise click.UsageError(str(exc)) from None
    folder = Path(run_dir) if run_dir else Path("build") / Path(target).resolve().name / variant / "run"
    address = None if run_dir else _registered(target, variant)
    change = op in VERBS  # answered once committed or refused: waited for, however long
    try:
        answer = send(
            folder,
            {"op": op, "features": list(features)} if features else {"op": op},
            wait=change,
            address=address,
        )
    except MotivmlError as exc:
        fail(exc)
    except KeyboardInterrupt:
        if not change:
            raise
        err.print(
            f"[bold yellow]interrupted[/]: {shown(op + ' ' + ' '.join(features))} was sent and may still be "
            f"committed; see with: motivml ctl {shown(target)} --variant {shown(variant)}"
            + (f" --run-dir {shown(run_dir)}" if run_dir else "")
            + " status"
        )
        sys.exit(130)
    if not answer.get("ok"):
        err.print(f"[bold red]error[/]: {shown(str(answer.get('error')))}")
        sys.exit(2)
    if op == "dump":
        click.echo(json.dumps(answer, indent=2))
        return
    if op == "status":
        _print_status(answer)
        return
    if op == "event":
        out.print(f"event {shown(features[0])} queued for the coordination")
        return
    _print_outcome(op + " " + " ".join(features), answer)


def _print_outcome(asked: str, answer: dict[str, Any]) -> None:
    """A change's outcome as the running robot answered it; refused: exit 1."""
    if answer["accepted"]:
        moved = [
            f"loaded {', '.join(answer['loads'])}" if answer["loads"] else "",
            f"unloaded {', '.join(answer['unloads'])}" if answer["unloads"] else "",
        ]
        detail = "; ".join(m for m in moved if m) or "reloaded in place"
        out.print(
            f"[green]accepted[/]: {shown(asked)} took effect at tick {answer['tick']} "
            f"({answer['time']:.3f} s), {answer['latency_ms']:.1f} ms after the request; {shown(detail)}"
        )
        for d in answer.get("warnings", []):
            out.print(f"[yellow]warning[/]: {shown(d['message'])}")
        return
    for d in answer["diagnostics"]:
        where = f"{d['file']}:{d['line']}:{d['column']}" if d.get("line") else str(d["file"])
        out.print(f"[bold]{shown(where)}[/]: {shown(str(d['path']))}: [red]refused[/]: {shown(d['message'])}")
        for fact in d["facts"]:
            place = (
                f"{fact['file']}:{fact['line']}:{fact['column']}" if fact.get("line") else str(fact["file"])
            )
            out.print(f"    [dim]{shown(place)}: {shown(fact['text'])}[/]")
    out.print(f"[bold red]refused[/]: {shown(asked)}: nothing changed")
    sys.exit(1)


def _print_status(answer: dict[str, object]) -> None:
    out.print(
        f"tick {answer['tick']}, t = {answer['time']:.3f} s" if isinstance(answer["time"], float) else ""
    )
    active = answer["active"]
    assert isinstance(active, list)
    out.print(shown("active: " + ", ".join(active)))
    components = answer["components"]
    assert isinstance(components, list)
    for c in components:
        out.print(shown(f"component {c['id']} ({c['kind']}, {c['feature']}): {c['status']}, {c['learning']}"))
    plugins = answer["plugins"]
    assert isinstance(plugins, list)
    for plugin in plugins:
        slowest = (
            f" (slowest step {plugin['slowest_step_ms']:.3f} ms, tick {plugin['slowest_step_tick']})"
            if isinstance(plugin.get("slowest_step_ms"), float | int)
            else ""
        )
        out.print(shown(f"plugin {plugin['feature']}: {plugin['status']}{slowest}"))


def _registered(target: str, variant: str) -> Path | None:
    """Where the registered run of this robot and variant listens (None: not registered)."""
    from ..runtime.runs import find

    runs = find(Path(target), variant)
    if len(runs) > 1:
        err.print(
            f"[bold red]error[/]: {len(runs)} runs of {shown(target)} variant {shown(variant)} are "
            "listening; choose one with --run-dir:"
        )
        for run in runs:
            err.print(shown(f"    {Path(run.socket).parent} (pid {run.pid})"))
        sys.exit(2)
    return runs[0].address if runs else None


def _list_runs(target: str | None, variant: str | None, run_dir: str | None) -> None:
    """Print the runs ctl can reach: registered ones (of TARGET and --variant, if given)."""
    from ..runtime.control import SOCKET
    from ..runtime.runs import answers, reachable

    runs = reachable()
    if target is not None:
        wanted = str(Path(target).resolve())
        runs = [r for r in runs if r.robot == wanted]
    if variant is not None:
        runs = [r for r in runs if r.variant == variant]
    if run_dir is not None:
        socket_path = str((Path(run_dir) / SOCKET).absolute())
        runs = [r for r in runs if Path(r.socket).resolve() == Path(socket_path).resolve()]
        if not runs and answers(Path(socket_path)):  # a run that did not register
            out.print(shown(f"a run is listening at {socket_path}"))
            return
    if not runs:
        out.print("no run is listening (start one with motivml run)")
        return
    for run in runs:
        started = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(run.started))
        out.print(
            shown(
                f"{run.robot} --variant {run.variant}: pid {run.pid}, since {started}, control {run.socket}"
            )
        )

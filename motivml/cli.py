"""The `motivml` command line: parse, call the library, print with rich, pick exit codes.

Exit codes: 0 valid, 1 invalid (model or configuration), 2 usage, 3 environment.
This is the only module that imports click or rich, and the only place that turns errors
into exit codes.
"""

from __future__ import annotations

import json
import math
import re
import shutil
import signal
import sys
import threading
import time
from concurrent.futures import Future
from pathlib import Path
from typing import NoReturn

import click
from rich import box
from rich.console import Console, Group
from rich.live import Live
from rich.markup import escape
from rich.table import Table
from rich.tree import Tree

from . import __version__, graph, impact
from .check import Report, analyse_model, binding_states, validate
from .codegen import late_or_dynamic, outputs, write_if_changed
from .configure import PREFERENCES, resolve
from .control import ControlServer, send
from .coordinator import Coordinator
from .errors import Diagnostic, MotivmlError, Severity
from .launch import ARCHITECTURE_FILE, COORDINATION_FILE, launch, load, read_robot_coordination
from .model import Configuration, FeatureModel
from .plugins import discover
from .plugins import missing as missing_plugins
from .reconfigure import ACTIONS, Request
from .robot import RobotFolder
from .runtime import RealClock, RunStats, Runtime, SimulatedClock, Snapshot
from .scxml import to_scxml
from .transactions import Outcome

out = Console(highlight=False, soft_wrap=True, emoji=False)
err = Console(stderr=True, highlight=False, soft_wrap=True, emoji=False)


def fail(exc: MotivmlError) -> NoReturn:
    """Print a library error (located) and exit with its code."""
    for diagnostic in exc.diagnostics:
        err.print(f"[bold red]{escape(_where(diagnostic))}[/]: {escape(diagnostic.message)}")
    sys.exit(exc.exit_code)


def _where(d: Diagnostic) -> str:
    return str(d.location)


def print_diagnostic(d: Diagnostic) -> None:
    colour = "red" if d.severity is Severity.ERROR else "yellow"
    out.print(
        f"[bold]{escape(str(d.location))}[/]: {escape(d.location.path)}: "
        f"[{colour}]{d.severity.value}[/]: {escape(d.message)}"
    )
    for fact in d.facts:
        out.print(f"    [dim]{escape(str(fact.location))}: {escape(fact.text)}[/]")


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="motivml")
def main() -> None:
    """motivml: variability models for robot software (MoTiVML)."""


def _targets(target: str, config: str | None, variant: str | None) -> tuple[Path, list[Path], bool]:
    """The model file, the configurations a call is about, and whether to analyse the model.

    The model is analysed (dead features, bindings never possible) when it is checked on
    its own or with every variant of its folder, not when one variant is asked about.
    """
    if config is not None and variant is not None:
        raise click.UsageError("give --config FILE or --variant NAME, not both")
    path = Path(target)
    if path.is_dir():
        robot = RobotFolder.open(path)
        if config is not None:
            return robot.model_path, [Path(config)], False
        if variant is not None:
            return robot.model_path, [robot.variant_path(variant)], False
        return robot.model_path, [robot.variant_path(n) for n in robot.variant_names()], True
    if variant is not None:
        raise click.UsageError("--variant needs a robot folder (model.json, variants/NAME.json), not a file")
    return path, [Path(config)] if config else [], config is None


@main.command("validate")
@click.argument("target", default=".", type=click.Path())
@click.option(
    "--config", "config", type=click.Path(), help="A configuration file to check against the model."
)
@click.option("--variant", help="A variant of the robot folder: variants/NAME.json.")
@click.option("--partial", is_flag=True, help="Accept features without an entry (left to the configurator).")
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text", show_default=True)
def validate_command(target: str, config: str | None, variant: str | None, partial: bool, fmt: str) -> None:
    """Check a feature model, or a configuration (variant) of it.

    TARGET is a model.json or a robot folder (default: the current folder). A robot folder
    without --variant checks the model and every variant in variants/.
    """
    try:
        model_path, configs, analyse = _targets(target, config, variant)
        architecture = model_path.parent / "architecture.json" if Path(target).is_dir() else None
        if architecture is not None and not architecture.is_file():
            architecture = None
        coordination = model_path.parent / COORDINATION_FILE if Path(target).is_dir() else None
        if coordination is not None and not coordination.is_file():
            coordination = None
        reports = validate(model_path, configs, partial, analyse, architecture, coordination)
    except MotivmlError as exc:
        if fmt == "json":
            _print_json(False, exc.diagnostics, [], [])
            sys.exit(exc.exit_code)
        fail(exc)
    expected = 1 + len(configs) + (architecture is not None) + (coordination is not None)
    valid = all(r.valid for r in reports) and len(reports) == expected
    if fmt == "json":
        _print_json(
            valid,
            [d for r in reports for d in r.errors],
            [d for r in reports for d in r.warnings],
            [
                {
                    "file": r.file,
                    "kind": r.kind,
                    "valid": r.valid,
                    "errors": len(r.errors),
                    "warnings": len(r.warnings),
                }
                for r in reports
            ],
        )
    else:
        for report in reports:
            for d in report.errors + report.warnings:
                print_diagnostic(d)
            if report.kind != "model" or report.analysed or report.diagnostics:
                _verdict(report, checked_variants=len(reports) > 1 or not configs)
    sys.exit(0 if valid else 1)


def _print_json(
    valid: bool, errors: list[Diagnostic], warnings: list[Diagnostic], documents: list[object]
) -> None:
    payload = {
        "valid": valid,
        "errors": [d.as_dict() for d in errors],
        "warnings": [d.as_dict() for d in warnings],
        "documents": documents,
    }
    click.echo(json.dumps(payload, indent=2))


def _plural(count: int, word: str) -> str:
    return f"{count} {word}{'s' * (count != 1)}"


def _verdict(report: Report, checked_variants: bool) -> None:
    counts = f"{_plural(len(report.errors), 'error')}, {_plural(len(report.warnings), 'warning')}"
    if report.valid:
        extra = ""
        if report.kind == "model" and report.model is not None and report.analysed:
            extra = f" ({len(report.model.features)} features)"
        elif report.open_bindings:
            extra = f" ({_plural(report.open_bindings, 'binding')} left to the configurator)"
        out.print(f"[bold green]valid[/]: {escape(report.file)}{escape(extra)}, {counts}")
    else:
        unchecked = (
            " (its variants were not checked)" if report.kind == "model" and not checked_variants else ""
        )
        out.print(f"[bold red]invalid[/]: {escape(report.file)}: {counts} in the {report.kind}{unchecked}")


@main.command("configure")
@click.argument("target", default=".", type=click.Path())
@click.option("--variant", required=True, help="The variant of the robot folder: variants/NAME.json.")
@click.option("-o", "--output", type=click.Path(), help="Output folder (default build/<robot>/<variant>/).")
@click.option(
    "--prefer",
    type=click.Choice(PREFERENCES),
    multiple=True,
    help="Decide open bindings Late and/or Dynamic instead of the defaults Early and Static.",
)
@click.option("--prefix", default="MOTIVML_", show_default=True, help="Prefix of the C++ macros.")
def configure_command(
    target: str, variant: str, output: str | None, prefer: tuple[str, ...], prefix: str
) -> None:
    """Resolve a variant; write variant.lock.json, features.h, static_loader.hpp, bindings.yaml, plugins.json.

    TARGET is a robot folder (default: the current folder). Files are rewritten only when
    their content changes; nothing is written when the variant is invalid.
    """
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", prefix):
        raise click.UsageError(f"--prefix {prefix!r} cannot start a C++ macro name (letters, digits, _)")
    try:
        robot = RobotFolder.open(target)
        reports = validate(robot.model_path, [robot.variant_path(variant)], partial=True, analyse=False)
        problems = [d for r in reports for d in r.errors]
        if problems or len(reports) != 2:
            for d in problems:
                print_diagnostic(d)
            out.print(f"[bold red]invalid[/]: {escape(reports[-1].file)}: nothing written")
            sys.exit(1)
        model, config = reports[1].model, reports[1].config
        assert model is not None and config is not None
        plugins, problems = discover(robot, model)
        if problems:
            for d in problems:
                print_diagnostic(d)
            out.print("[bold red]invalid[/]: plugin manifests: nothing written")
            sys.exit(1)
        resolved = resolve(model, config, prefer)
        folder = Path(output) if output else Path("build") / robot.name / variant
        written = write_if_changed(folder, outputs(resolved, prefix, plugins, robot.path))
    except MotivmlError as exc:
        fail(exc)
    for d in missing_plugins(model, late_or_dynamic(resolved), plugins):
        print_diagnostic(d)
    chosen = resolved.selected()
    by_solver = sum(
        1
        for d in resolved.decisions
        if d.selection_by == "solver" or (d.selected and "solver" in (d.time_by, d.mode_by))
    )
    counts = ", ".join(
        f"{sum(1 for d in chosen if d.binding == b)} {name}"
        for b, name in (
            ("SE", "Static Early"),
            ("SL", "Static Late"),
            ("DE", "Dynamic Early"),
            ("DL", "Dynamic Late"),
        )
    )
    out.print(
        f"variant {escape(variant)}: {len(chosen)} features selected ({counts}); {by_solver} decided by the solver"
    )
    for name, changed in written.items():
        out.print(f"  {'wrote' if changed else 'unchanged'} {escape(str(folder / name))}")


@main.command("diff")
@click.argument("target", type=click.Path())
@click.argument("first")
@click.argument("second")
@click.option(
    "--prefer",
    type=click.Choice(PREFERENCES),
    multiple=True,
    help="Resolve both variants as configure --prefer does.",
)
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text", show_default=True)
def diff_command(target: str, first: str, second: str, prefer: tuple[str, ...], fmt: str) -> None:
    """What moving from variant FIRST to SECOND of the robot folder TARGET takes.

    Both are resolved as `configure` resolves them (give the same --prefer). Each feature
    whose selection or binding differs is a rebuild, a restart or a run-time change
    (semantics.md section 4). Exit 0 when every change can be made at run time.
    """
    try:
        robot = RobotFolder.open(target)
        paths = [robot.variant_path(first), robot.variant_path(second)]
        reports = validate(robot.model_path, paths, partial=True, analyse=False)
        problems = [d for r in reports for d in r.errors]
        if problems or len(reports) != 3:
            for d in problems:
                print_diagnostic(d)
            out.print("[bold red]invalid[/]: nothing to compare (fix the errors above)")
            sys.exit(1)
        model = reports[0].model
        assert model is not None and reports[1].config is not None and reports[2].config is not None
        changes = impact.diff(
            resolve(model, reports[1].config, prefer), resolve(model, reports[2].config, prefer)
        )
    except MotivmlError as exc:
        fail(exc)
    worst = impact.verdict(changes)
    if fmt == "json":
        click.echo(
            json.dumps(
                {
                    "from": first,
                    "to": second,
                    "swappable_at_run_time": worst == impact.RUN_TIME,
                    "needs": worst,
                    "changes": [vars(c) for c in changes],
                },
                indent=2,
            )
        )
    else:
        for c in changes:
            colour = {impact.REBUILD: "red", impact.RESTART: "yellow", impact.RUN_TIME: "green"}[c.impact]
            out.print(
                f"[{colour}]{c.impact:>8}[/]  {escape(c.feature)}: {c.before} -> {c.after}  [dim]{escape(c.reason)}[/]"
            )
        summary = {
            impact.RUN_TIME: "can be swapped while the robot runs",
            impact.RESTART: "needs a restart (no rebuild)",
            impact.REBUILD: "needs a rebuild",
        }[worst]
        out.print(f"{escape(first)} -> {escape(second)}: {_plural(len(changes), 'change')}; {summary}")
    sys.exit(0 if worst == impact.RUN_TIME else 1)


@main.command("show")
@click.argument("target", default=".", type=click.Path())
@click.option("--config", "config", type=click.Path(), help="A configuration file.")
@click.option("--variant", help="A variant of the robot folder: variants/NAME.json.")
def show_command(target: str, config: str | None, variant: str | None) -> None:
    """Print the feature tree with groups, allowed, configured and forced bindings."""
    try:
        model_path, configs, _ = _targets(target, config, variant)
        chosen = configs[:1] if variant or config else []
        reports = validate(model_path, chosen, partial=True, analyse=False)
        problems = [d for r in reports for d in r.errors]
        if problems or len(reports) != 1 + len(chosen):
            for d in problems:
                print_diagnostic(d)
            out.print("[bold red]invalid[/]: nothing to show (fix the errors above)")
            sys.exit(1)
        model = reports[0].model
        assert model is not None
        configuration = reports[-1].config if chosen else None
        states = binding_states(model, configuration)
        if not states[0]:  # not even the root: the model has no valid variant
            for d in analyse_model(model):
                print_diagnostic(d)
            out.print("[bold red]invalid[/]: nothing to show (fix the errors above)")
            sys.exit(1)
    except MotivmlError as exc:
        fail(exc)
    # A tree cannot soft-wrap: on a terminal it wraps at its width, into a pipe it stays whole.
    tree_console = (
        out if out.is_terminal else Console(highlight=False, emoji=False, width=max(out.width, 240))
    )
    tree_console.print(_tree(model, configuration, states))
    out.print(
        "[dim]marks: ! mandatory, ? optional, [OR]/[XOR] group member; allowed = mode/time a feature allows; "
        "set = what the configuration says; solver = what valid variants leave (one value: forced)[/]"
    )


def _tree(model: FeatureModel, config: Configuration | None, states: list[set[str]]) -> Tree:
    nodes: dict[int, Tree] = {}
    root_tree: Tree | None = None
    for f in model.features:
        if f.parent is None:
            mark = ""
        elif f.group:
            mark = f"[magenta][{f.group}][/] "
        else:
            mark = "[bold]![/] " if f.mandatory else "? "
        allowed = f"allowed {_short(f.mode_allowed)}{_short(f.time_allowed)}"
        configured = ""
        if config is not None:
            entry = config.entries.get(f.id)
            if entry is None:
                configured = " set —" if f.parent is not None else ""
            elif not entry.selected:
                configured = " set off"
            else:
                configured = f" set {_short(entry.mode)}{_short(entry.time)}"
        possible = states[f.index]
        order = ["off", "SE", "SL", "DE", "DL"]
        solver = ",".join(s for s in order if s in possible) or "none"
        colour = "green" if len(possible) == 1 else "cyan"
        label = (
            f"{mark}[bold]{escape(f.id)}[/] [dim]({escape(_printable(f.name))})[/]  {allowed}{configured}  "
            f"solver [{colour}]{solver}[/]"
        )
        if f.parent is None:
            root_tree = Tree(label)
            nodes[f.index] = root_tree
        else:
            nodes[f.index] = nodes[f.parent].add(label)
    assert root_tree is not None
    return root_tree


def _printable(text: str) -> str:
    """A name as it can be shown: control characters (terminal escapes) spelled out."""
    return "".join(ch if ch.isprintable() else ch.encode("unicode_escape").decode() for ch in text)


def _short(token: str) -> str:
    return {"Static": "S", "Dynamic": "D", "Early": "E", "Late": "L", "Any": "*"}[token]


@main.command("run")
@click.argument("target", type=click.Path())
@click.option("--variant", required=True, help="The variant of the robot folder: variants/NAME.json.")
@click.option(
    "--duration",
    type=click.FloatRange(min=0, min_open=True, max=86400),
    default=5.0,
    show_default=True,
    help="Seconds of clock time to run.",
)
@click.option(
    "--rate",
    type=click.FloatRange(min=1, max=100_000),
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
    type=click.Path(file_okay=False),
    help="Where the control socket goes (default build/<robot>/<variant>/run).",
)
@click.option(
    "--control/--no-control", default=True, show_default=True, help="Open the control socket for motivml ctl."
)
@click.option(
    "--at",
    "scheduled",
    type=(click.FloatRange(min=0), str),
    multiple=True,
    metavar="SECONDS REQUEST",
    help='Make a request at a control time, e.g. --at 2 "swap hectorslam kartoslam" (repeatable).',
)
def run_command(
    target: str,
    variant: str,
    duration: float,
    rate: float,
    clock: str,
    live: bool | None,
    prefer: tuple[str, ...],
    run_dir: str | None,
    control: bool,
    scheduled: tuple[tuple[float, str], ...],
) -> None:
    """Build the motion architecture of a variant's active features and run it at a fixed rate.

    The active set at start is every Early feature plus the fewest Late ones the model
    needs (semantics.md section 4); exactly their spaces, mappings, modules and components
    run. Ends with a summary: each component's status and when its criterion fired, each
    module's learning state, the final space values and the loop's timing.
    """
    plan: list[tuple[float, Request]] = []
    for at, text in scheduled:
        action, *features = text.split() or [""]
        if action == "event" and len(features) == 1:
            plan.append((at, Request("event", (features[0],))))
            continue
        if action not in ACTIONS or not features or (action == "swap" and len(features) != 2):
            raise click.BadParameter(
                f"{text!r}: a request is load|unload|reload FEATURE..., swap OUT IN, or event NAME",
                param_hint="--at",
            )
        plan.append((at, Request(action, tuple(features))))
    for at, request in plan:
        if not math.isfinite(at) or at >= duration:
            raise click.BadParameter(
                f"{at:g} s for {request}: requests are made during the run, before {duration:g} s",
                param_hint="--at",
            )
    plan.sort(key=lambda item: item[0])
    try:
        robot = launch(target, variant, rate, prefer)
    except MotivmlError as exc:
        for d in exc.diagnostics:
            print_diagnostic(d)
        out.print(f"[bold red]cannot run[/]: {escape(target)} variant {escape(variant)}")
        sys.exit(exc.exit_code)
    except KeyboardInterrupt:
        out.print("interrupted before the run started")
        sys.exit(130)
    for d in robot.warnings:
        print_diagnostic(d)
    runtime = robot.runtime
    if not out.is_terminal:  # a log or a pipe: never cut the summary table to 80 columns
        out.width = max(out.width, 160)
    out.print(
        f"running {escape(robot.folder.name)} variant {escape(variant)}: "
        f"{_plural(len(robot.assembly.components), 'component')} of {_plural(len(robot.active), 'active feature')} "
        f"({escape(', '.join(robot.active))}) at {rate:g} Hz, {clock} clock, {duration:g} s"
    )
    server = None
    if control:
        folder = Path(run_dir) if run_dir else Path("build") / robot.folder.name / variant / "run"
        server = ControlServer(folder, runtime, robot.binder)
        try:
            server.open()
        except MotivmlError as exc:
            robot.close()
            fail(exc)
        out.print(f"control: {escape(str(server.path))} (motivml ctl)")
    chosen = RealClock() if clock == "real" else SimulatedClock()
    if clock == "simulated":
        robot.binder.make_changes_between_ticks()
    coordinator = robot.coordinate(simulated=clock == "simulated")
    if coordinator is None and any(request.action == "event" for _, request in plan):
        robot.close()
        raise click.BadParameter(
            "events go to a coordination statechart, and this robot has none", param_hint="--at"
        )
    if server is not None:
        server.coordinator = coordinator
    show = out.is_terminal if live is None else live
    result: list[RunStats] = []
    finished = threading.Event()
    answers: list[tuple[float, int, Request, Outcome | Future[Outcome]]] = []

    def scheduler(rt: Runtime) -> bool:
        """Each tick, on the control thread: make the requests that are due."""
        while plan and rt.time >= plan[0][0] - 1e-12:
            _, request = plan.pop(0)
            if request.action == "event":
                assert coordinator is not None
                coordinator.event(request.features[0])
                rt.note(f"event {request.features[0]}")
            elif clock == "simulated":  # deterministic: committed right here, between two ticks
                answers.append((rt.time, rt.ticks, request, robot.binder.request_between_ticks(request)))
            else:
                answers.append((rt.time, rt.ticks, request, robot.binder.submit(request)))
        return coordinator is not None and coordinator.finished is not None

    def work() -> None:
        try:
            result.append(runtime.run(duration, chosen, until=scheduler))
        finally:
            finished.set()

    interrupted = threading.Event()

    def interrupt(signum: int, frame: object) -> None:  # Ctrl-C: end the run, keep the summary
        interrupted.set()
        runtime.stop()

    on_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, interrupt) if on_main else None
    worker = threading.Thread(target=work, daemon=True, name="motivml-control")
    began = time.perf_counter()
    try:
        worker.start()
        reported = 0
        if show:
            with Live(
                _live_view(runtime, began, coordinator), console=out, refresh_per_second=4, transient=True
            ) as view:
                while not finished.wait(0.25):
                    reported = _report_changes(runtime, reported, view.console)
                    view.update(_live_view(runtime, began, coordinator))
        else:
            while not finished.wait(0.25):
                reported = _report_changes(runtime, reported, out)
    finally:
        if on_main:
            signal.signal(signal.SIGINT, previous)
        if server is not None:
            server.close()
    if not result:
        out.print("[bold red]the run ended without a result[/]")
        sys.exit(3)
    for at, tick, request, answer in answers:
        outcome = answer if isinstance(answer, Outcome) else answer.result()
        verdict = "accepted" if outcome.accepted else "refused, nothing changed"
        out.print(escape(f"request at {at:.3f} s (tick {tick}): {request}: {verdict}"))
        for d in outcome.diagnostics:
            print_diagnostic(d)
    _summary(runtime, result[0])
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
    robot.close()
    sys.exit(130 if interrupted.is_set() else 1 if diverged or runtime.failure is not None else 0)


def _report_changes(runtime: Runtime, reported: int, console: Console) -> int:
    """Print the changes accepted since the last call, as they happen; the new count."""
    changes = runtime.changes[reported:]
    for change in changes:
        stamp = time.strftime("%H:%M:%S", time.localtime(change.wall)) + f".{int(change.wall % 1 * 1000):03d}"
        console.print(escape(f"{stamp} tick {change.tick}: {change.request}"))
    return reported + len(changes)


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


def _live_view(runtime: Runtime, began: float, coordinator: Coordinator | None = None) -> Group:
    snapshot = runtime.status()
    wall = time.perf_counter() - began
    achieved = snapshot.tick / wall if wall > 0 else 0.0
    head = f"tick {snapshot.tick}  t = {snapshot.time:.3f} s  achieved {achieved:,.0f} Hz (asked {runtime.rate:g} Hz)"
    if coordinator is not None:
        head += f"\ncoordination: {', '.join(coordinator.configuration())}"
    return Group(head, _components_table(snapshot))


def _summary(runtime: Runtime, stats: RunStats) -> None:
    snapshot = runtime.status()
    if snapshot.components:
        out.print(_components_table(snapshot, runtime))
    for module, state, learned in snapshot.modules:
        extra = f", learned {learned} time{'s' if learned != 1 else ''}" if learned else ""
        out.print(f"module {escape(module)}: {state}{extra}")
    for feature, status in snapshot.plugins:
        out.print(escape(f"plugin {feature}: {status}"))
    for change in runtime.changes:
        out.print(escape(f"changed at {change.time:.3f} s (tick {change.tick}): {change.request}"))
    for at, tick, text in runtime.notes:
        out.print(escape(f"at {at:.3f} s (tick {tick}): {text}"))
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
            f"{_plural(stats.missed, 'missed deadline')}; CPU {stats.cpu_share:.0%}"
        )
    out.print(line)


@main.command("graph")
@click.argument("target", default=".", type=click.Path())
@click.option(
    "--variant", help="Draw this variant: its selection and bindings, and the architecture it starts with."
)
@click.option("--format", "fmt", type=click.Choice(["dot", "graphml"]), default="dot", show_default=True)
@click.option(
    "-o", "--output", type=click.Path(), help="Output folder (default build/<robot>/<variant or model>/)."
)
def graph_command(target: str, variant: str | None, fmt: str, output: str | None) -> None:
    """Draw the feature model and the motion architecture of a robot folder.

    Writes feature-model.FORMAT and, when the robot has an architecture.json,
    architecture.FORMAT. With --format dot, SVG pictures are rendered beside them when
    Graphviz's `dot` is installed. With --variant, unselected features are greyed out and
    the architecture shows the elements of the variant's active set at start (what
    `motivml run` builds).
    """
    try:
        loaded = load(target, variant)
        robot = loaded.folder
        draw = graph.feature_model_dot if fmt == "dot" else graph.feature_model_graphml
        files = {f"feature-model.{fmt}": draw(loaded.model, loaded.variant)}
        architecture = loaded.architecture
        if architecture is not None:
            pick = graph.architecture_dot if fmt == "dot" else graph.architecture_graphml
            files[f"architecture.{fmt}"] = pick(architecture, loaded.active)
        rendered = False
        if fmt == "dot" and shutil.which("dot") is not None:
            for name in list(files):
                svg = graph.render_svg(files[name])
                if svg is not None:
                    files[name.removesuffix(".dot") + ".svg"] = svg.decode("utf-8")
                    rendered = True
        folder = Path(output) if output else Path("build") / robot.name / (variant or "model")
        written = write_if_changed(folder, files)
    except MotivmlError as exc:
        for d in exc.diagnostics:
            print_diagnostic(d)
        out.print(f"[bold red]nothing drawn[/]: {escape(target)}")
        sys.exit(exc.exit_code)
    if architecture is None:
        out.print(f"{escape(robot.name)} has no {ARCHITECTURE_FILE}: drawing the feature model only")
    for name, changed in written.items():
        out.print(f"  {'wrote' if changed else 'unchanged'} {escape(str(folder / name))}")
    if fmt == "dot" and not rendered:
        out.print(
            "Graphviz's dot is not installed: no SVG (install graphviz, or render the .dot files elsewhere)"
        )


@main.command("ctl")
@click.argument("target", type=click.Path())
@click.option("--variant", required=True, help="The variant that runs (to find its run directory).")
@click.option(
    "--run-dir", type=click.Path(file_okay=False), help="The run's directory, if run was given one."
)
@click.argument("op", type=click.Choice(["load", "unload", "reload", "swap", "event", "status", "dump"]))
@click.argument("features", nargs=-1)
def ctl_command(target: str, variant: str, run_dir: str | None, op: str, features: tuple[str, ...]) -> None:
    """Talk to a running robot: load, unload, reload or swap features, or ask its status.

    TARGET and --variant name the run (its control socket is in build/<robot>/<variant>/run
    unless run was given --run-dir). A change is checked against the model and the variant
    first; a refused one changes nothing and says why (exit 1). status prints the active set,
    components and plugins; dump prints everything as JSON.
    """
    if op in ("status", "dump") and features:
        raise click.UsageError(f"{op} takes no features")
    if op not in ("status", "dump") and not features:
        raise click.UsageError(f"{op} needs at least one feature")
    if op == "swap" and len(features) != 2:
        raise click.UsageError("swap needs two features: the one to unload, then the one to load")
    if op == "event" and len(features) != 1:
        raise click.UsageError("event needs one name")
    folder = Path(run_dir) if run_dir else Path("build") / Path(target).resolve().name / variant / "run"
    try:
        answer = send(folder, {"op": op, "features": list(features)} if features else {"op": op})
    except MotivmlError as exc:
        fail(exc)
    if not answer.get("ok"):
        err.print(f"[bold red]error[/]: {escape(str(answer.get('error')))}")
        sys.exit(2)
    if op == "dump":
        click.echo(json.dumps(answer, indent=2))
        return
    if op == "status":
        _print_status(answer)
        return
    if op == "event":
        out.print(f"event {escape(features[0])} queued for the coordination")
        return
    if answer["accepted"]:
        moved = [
            f"loaded {', '.join(answer['loads'])}" if answer["loads"] else "",
            f"unloaded {', '.join(answer['unloads'])}" if answer["unloads"] else "",
        ]
        detail = "; ".join(m for m in moved if m) or "reloaded in place"
        out.print(
            f"[green]accepted[/]: {escape(op + ' ' + ' '.join(features))} took effect at tick {answer['tick']} "
            f"({answer['time']:.3f} s), {answer['latency_ms']:.1f} ms after the request; {escape(detail)}"
        )
        return
    for d in answer["diagnostics"]:
        where = f"{d['file']}:{d['line']}:{d['column']}" if d.get("line") else str(d["file"])
        out.print(
            f"[bold]{escape(where)}[/]: {escape(str(d['path']))}: [red]refused[/]: {escape(d['message'])}"
        )
        for fact in d["facts"]:
            place = (
                f"{fact['file']}:{fact['line']}:{fact['column']}" if fact.get("line") else str(fact["file"])
            )
            out.print(f"    [dim]{escape(place)}: {escape(fact['text'])}[/]")
    out.print(f"[bold red]refused[/]: {escape(op + ' ' + ' '.join(features))}: nothing changed")
    sys.exit(1)


def _print_status(answer: dict[str, object]) -> None:
    out.print(
        f"tick {answer['tick']}, t = {answer['time']:.3f} s" if isinstance(answer["time"], float) else ""
    )
    active = answer["active"]
    assert isinstance(active, list)
    out.print(escape("active: " + ", ".join(active)))
    components = answer["components"]
    assert isinstance(components, list)
    for c in components:
        out.print(
            escape(f"component {c['id']} ({c['kind']}, {c['feature']}): {c['status']}, {c['learning']}")
        )
    plugins = answer["plugins"]
    assert isinstance(plugins, list)
    for plugin in plugins:
        out.print(escape(f"plugin {plugin['feature']}: {plugin['status']}"))


@main.command("export")
@click.argument("what", type=click.Choice(["scxml"]))
@click.argument("target", default=".", type=click.Path())
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False),
    help="Output file (default build/<robot>/coordination.scxml).",
)
def export_command(what: str, target: str, output: str | None) -> None:
    """Export the robot's coordination statechart as W3C SCXML.

    Domain conditions and actions are kept in the namespace urn:motivml:coordination:1
    (see guidelines/coordinating-behaviour.md); the file is rewritten only when it changes.
    """
    try:
        loaded = load(target, None)
        coordination = read_robot_coordination(loaded.folder, loaded.model, loaded.architecture, None)
        if coordination is None:
            out.print(
                f"[bold red]nothing to export[/]: {escape(str(loaded.folder.path / COORDINATION_FILE))} does not exist"
            )
            sys.exit(3)
        path = Path(output) if output else Path("build") / loaded.folder.name / "coordination.scxml"
        written = write_if_changed(path.parent, {path.name: to_scxml(coordination, loaded.folder.name)})
    except MotivmlError as exc:
        for d in exc.diagnostics:
            print_diagnostic(d)
        out.print(f"[bold red]nothing exported[/]: {escape(target)}")
        sys.exit(exc.exit_code)
    out.print(f"  {'wrote' if written[path.name] else 'unchanged'} {escape(str(path))}")


if __name__ == "__main__":
    main()

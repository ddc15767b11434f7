"""validate, show, configure, diff: the model and its variants."""

from __future__ import annotations

import difflib
import json
import re
import sys
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

import click
from rich.markup import escape

from ..binding import PREFERENCES
from ..documents.robot_folder import RobotFolder, optional_document
from ..errors import MotivmlError
from ..language.model import OFF, Binding, FeatureState, Mode, Time, token
from .common import environment_problem, fail, one_variant, out, plural, print_diagnostics, printable, targets
from .progress import ProgressBar
from .reports import FORMATS, checked, unchecked

EXIT_NOT_AT_RUN_TIME = 4  # diff: valid variants, but the move needs a rebuild or a restart

if TYPE_CHECKING:
    from rich.tree import Tree

    from ..binding.resolve import Variant
    from ..language.model import Configuration, FeatureModel
    from ..validate import Report



@click.command("validate")
@click.argument("target", default=".", type=click.Path(readable=False))
@click.option(
    "--config", "config", type=click.Path(readable=False), help="A configuration file to check against the model."
)
@click.option("--variant", help="A variant of the robot folder: variants/NAME.json.")
@click.option("--partial", is_flag=True, help="Accept features without an entry (left to the configurator).")
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["text", *FORMATS]),
    default="text",
    show_default=True,
    help="json: the result as data; sarif: SARIF 2.1.0 for code scanning; junit: JUnit XML, a test case per document.",
)
def validate_command(target: str, config: str | None, variant: str | None, partial: bool, fmt: str) -> None:
    """Check a feature model, or a configuration (variant) of it.

    TARGET is a model.json or a robot folder (default: the current folder). A robot folder
    without --variant checks the model and every variant in variants/. A fleet file
    (fleet.json, NAME.fleet.json) checks every robot's variant with the fleet's overrides.
    """
    from ..fleet import is_fleet_file
    from ..validate import DocumentKind, validate

    if is_fleet_file(target) and config is None and variant is None:
        _validate_fleet(target, fmt, partial)
    try:
        model_path, configs, analyse = targets(target, config, variant)
        folder = RobotFolder(Path(target)) if Path(target).is_dir() else None
        architecture = optional_document(folder.architecture_path) if folder else None
        coordination = optional_document(folder.coordination_path) if folder else None
        robot = folder if folder and optional_document(folder.settings_path) else None
        result = validate(model_path, configs, partial, analyse, architecture, coordination, robot)
    except (MotivmlError, OSError) as exc:  # nothing checked: the problem alone, in the format asked for
        problem = exc if isinstance(exc, MotivmlError) else environment_problem(exc)
        if fmt == "text":
            fail(problem)
        click.echo(unchecked(fmt, target, problem))
        sys.exit(problem.exit_code)
    if fmt != "text":
        click.echo(checked(fmt, result.reports, result.valid))
    else:
        for report in result.reports:
            print_diagnostics(report.errors + report.warnings)
            if report.kind is not DocumentKind.MODEL or report.analysed or report.diagnostics:
                _verdict(report, checked_variants=result.checked or not configs)
    sys.exit(0 if result.valid else 1)


def _validate_fleet(target: str, fmt: str, partial: bool) -> NoReturn:
    """validate FLEET.json: the fleet file, then each robot's configuration (its variant with
    the fleet's overrides), each robot's messages naming it; exit 1 if any has an error."""
    from ..fleet import validate_fleet
    from ..validate import DocumentKind, Report

    try:
        problems, robots = validate_fleet(target, partial)
    except (MotivmlError, OSError) as exc:
        problem = exc if isinstance(exc, MotivmlError) else environment_problem(exc)
        if fmt == "text":
            fail(problem)
        click.echo(unchecked(fmt, target, problem))
        sys.exit(problem.exit_code)
    reports = [Report(target, DocumentKind.FLEET, problems)]
    reports += [Report(f"{target} {r.namespace}", DocumentKind.ROBOT, r.diagnostics) for r in robots]
    valid = all(report.valid for report in reports)
    if fmt != "text":
        click.echo(checked(fmt, reports, valid))
        sys.exit(0 if valid else 1)
    print_diagnostics(problems)
    if problems:
        out.print(f"[bold red]invalid[/]: {escape(target)}: {plural(len(problems), 'error')} in the fleet file")
    for robot in robots:
        print_diagnostics(robot.errors + robot.warnings)
        counts = f"{plural(len(robot.errors), 'error')}, {plural(len(robot.warnings), 'warning')}"
        said = f"robot {robot.namespace} ({robot.folder}, variant {robot.variant}; {', '.join(robot.layers) or 'no entries'})"
        verdict = "[bold green]valid[/]" if robot.valid else "[bold red]invalid[/]"
        out.print(f"{verdict}: {escape(said)}, {counts}")
    sys.exit(0 if valid else 1)


def _verdict(report: Report, checked_variants: bool) -> None:
    from ..validate import DocumentKind

    counts = f"{plural(len(report.errors), 'error')}, {plural(len(report.warnings), 'warning')}"
    if report.valid:
        extra = ""
        if report.kind is DocumentKind.MODEL and report.model is not None and report.analysed:
            extra = f" ({len(report.model.features)} features)"
        elif report.open_bindings or report.open_features:
            left = [plural(report.open_features, "feature")] if report.open_features else []
            left += [plural(report.open_bindings, "binding")] if report.open_bindings else []
            extra = f" ({' and '.join(left)} left to the configurator)"
        out.print(f"[bold green]valid[/]: {escape(report.file)}{escape(extra)}, {counts}")
    else:
        unchecked = (
            " (its variants were not checked)" if report.kind is DocumentKind.MODEL and not checked_variants else ""
        )
        out.print(f"[bold red]invalid[/]: {escape(report.file)}: {counts} in the {report.kind}{unchecked}")


@click.command("configure")
@click.argument("target", default=".", type=click.Path(readable=False))
@click.option("--variant", help="The variant of the robot folder: variants/NAME.json.")
@click.option(
    "--config", "config", type=click.Path(readable=False), help="A configuration file, instead of --variant (named by its stem)."
)
@click.option("-o", "--output", type=click.Path(readable=False), help="Output folder (default build/<robot>/<variant>/).")
@click.option(
    "--prefer",
    type=click.Choice(PREFERENCES),
    multiple=True,
    help="Decide open bindings Late and/or Dynamic instead of the defaults Early and Static.",
)
@click.option("--prefix", default="MOTIVML_", show_default=True, help="Prefix of the C++ macros.")
@click.option(
    "--save-decisions",
    type=click.Path(dir_okay=False, readable=False),
    help="Also write the smallest decisions file from which configure derives this variant again.",
)
def configure_command(
    target: str,
    variant: str | None,
    config: str | None,
    output: str | None,
    prefer: tuple[str, ...],
    prefix: str,
    save_decisions: str | None,
) -> None:
    """Resolve a variant; write variant.lock.json, features.h, static_loader.hpp, bindings.yaml, plugins.json, ros2_params.yaml.

    TARGET is a robot folder (default: the current folder); the variant is --variant NAME
    (variants/NAME.json) or --config FILE, a configuration document anywhere, which goes by
    its file name's stem (FILE variants/NAME.json is the same as --variant NAME). ros2_params.yaml holds the ROS 2
    parameters of the motivml node (features.<id>.active at start) and of each
    ros2_lifecycle plugin's node, for --ros-args --params-file. Files are rewritten only
    when their content changes; nothing is written when the variant is invalid.
    """
    from ..binding.resolve import DecidedBy
    from ..configure import NotConfigured, configure

    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", prefix):
        raise click.UsageError(f"--prefix {prefix!r} cannot start a C++ macro name (letters, digits, _)")
    name = one_variant(config, variant)
    try:
        robot = RobotFolder.open(target)
        (config_path,) = targets(target, config, variant)[1]
        folder = Path(output) if output else Path("build") / robot.name / name
        decisions = Path(save_decisions) if save_decisions is not None else None
        with ProgressBar(1) as bar:
            bar.step(f"configuring {robot.name}'s variant {name}")
            done = configure(robot, Path(config_path), folder, prefer, prefix, decisions)
    except NotConfigured as invalid:
        print_diagnostics(invalid.diagnostics)
        out.print(f"[bold red]invalid[/]: {escape(invalid.what)}: nothing written")
        sys.exit(1)
    except MotivmlError as exc:
        fail(exc)
    print_diagnostics(done.missing)
    chosen = done.variant.selected()
    by_solver = sum(
        1
        for d in done.variant.decisions
        if d.selection_by is DecidedBy.SOLVER or (d.selected and DecidedBy.SOLVER in (d.time_by, d.mode_by))
    )
    counts = ", ".join(f"{sum(1 for d in chosen if d.binding is b)} {b.words}" for b in Binding)
    out.print(
        f"variant {escape(name)}: {len(chosen)} features selected ({counts}); {by_solver} decided by the solver"
    )
    for file, changed in done.written.items():
        out.print(f"  {'wrote' if changed else 'unchanged'} {escape(str(folder / file))}")
    if save_decisions is not None:
        out.print(f"  wrote {escape(save_decisions)} (the decisions it derives from)")


@click.command("diff")
@click.argument("target", type=click.Path(readable=False))
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
    (reference.md section 4). Exit 0 when every change can be made at run time, 4 when one
    needs a rebuild or a restart, 1 when a variant is invalid.
    """
    from ..binding import impact
    from ..binding.resolve import resolve
    from ..validate import validate

    try:
        robot = RobotFolder.open(target)
        paths = [robot.variant_path(first), robot.variant_path(second)]
        result = validate(robot.model_path, paths, partial=True, analyse=False)
        if not result.valid:
            print_diagnostics(result.errors)
            out.print("[bold red]invalid[/]: nothing to compare (fix the errors above)")
            sys.exit(1)
        model = result.model.model
        before, after = (report.config for report in result.configurations)
        assert model is not None and before is not None and after is not None
        changes = impact.diff(resolve(model, before, prefer), resolve(model, after, prefer))
    except MotivmlError as exc:
        fail(exc)
    worst = impact.verdict(changes)
    if fmt == "json":
        click.echo(
            json.dumps(
                {
                    "from": first,
                    "to": second,
                    "swappable_at_run_time": worst == impact.Impact.RUN_TIME,
                    "needs": worst,
                    "changes": [vars(c) for c in changes],
                },
                indent=2,
            )
        )
    else:
        for c in changes:
            colour = {impact.Impact.REBUILD: "red", impact.Impact.RESTART: "yellow", impact.Impact.RUN_TIME: "green"}[c.impact]
            out.print(
                f"[{colour}]{c.impact:>8}[/]  {escape(c.feature)}: {c.before} -> {c.after}  [dim]{escape(c.reason)}[/]"
            )
        summary = {
            impact.Impact.RUN_TIME: "can be swapped while the robot runs",
            impact.Impact.RESTART: "needs a restart (no rebuild)",
            impact.Impact.REBUILD: "needs a rebuild",
        }[worst]
        out.print(f"{escape(first)} -> {escape(second)}: {plural(len(changes), 'change')}; {summary}")
    sys.exit(0 if worst == impact.Impact.RUN_TIME else EXIT_NOT_AT_RUN_TIME)


@click.command("show")
@click.argument("target", default=".", type=click.Path(readable=False))
@click.option("--config", "config", type=click.Path(readable=False), help="A configuration file.")
@click.option("--variant", help="A variant of the robot folder: variants/NAME.json.")
@click.option(
    "--why", "why_feature", metavar="FEATURE", help="Why FEATURE is selected or not, and bound as it is."
)
@click.option(
    "--prefer",
    multiple=True,
    type=click.Choice(PREFERENCES),
    help="Resolve the variant as configure --prefer does (repeatable).",
)
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text", show_default=True)
def show_command(
    target: str,
    config: str | None,
    variant: str | None,
    why_feature: str | None,
    prefer: tuple[str, ...],
    fmt: str,
) -> None:
    """Print the feature tree with groups, allowed, configured and forced bindings.

    With a variant (--variant or --config), the features active at start are marked. With
    --why FEATURE, say why the feature is selected or not (configured, forced, impossible or
    left open) and why it has its time and mode, each answer with the located facts behind it.
    """
    from ..binding.check import analyse_model, binding_states
    from ..validate import validate

    try:
        model_path, configs, _ = targets(target, config, variant)
        chosen = configs[:1] if variant or config else []
        result = validate(model_path, chosen, partial=True, analyse=False)
        if not result.valid:
            print_diagnostics(result.errors)
            out.print("[bold red]invalid[/]: nothing to show (fix the errors above)")
            sys.exit(1)
        model = result.model.model
        assert model is not None
        if why_feature is not None and why_feature not in model.index:
            close = difflib.get_close_matches(why_feature, list(model.index), n=1, cutoff=0.75)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise click.BadParameter(f"no feature {why_feature!r} in the model{hint}", param_hint="'--why'")
        configuration = result.configurations[0].config if chosen else None
        states = binding_states(model, configuration)
        if not states[0]:  # not even the root: the model has no valid variant
            print_diagnostics(analyse_model(model))
            out.print("[bold red]invalid[/]: nothing to show (fix the errors above)")
            sys.exit(1)
        resolved = _resolved(model, configuration, prefer)
        reasons = None
        if why_feature is not None:
            from ..binding.why import why

            decision = resolved[0].decisions[model.index[why_feature]] if resolved else None
            reasons = why(
                model,
                configuration,
                why_feature,
                states,
                prefer,
                (decision.selected, decision.binding) if decision else None,
                why_feature in resolved[1] if resolved else None,
            )
    except MotivmlError as exc:
        fail(exc)
    if fmt == "json":
        payload = _show_json(model, configuration, states, resolved)
        if reasons is not None:
            payload["why"] = {"feature": why_feature, "reasons": [r.as_dict() for r in reasons]}
        click.echo(json.dumps(payload, indent=2))
        return
    if reasons is not None:
        for reason in reasons:
            out.print(f"[bold]{escape(reason.statement)}[/]: {escape(reason.because)}")
            for fact in reason.facts:
                out.print(f"    [dim]{escape(str(fact.location))}: {escape(fact.text)}[/]")
        return
    # A tree cannot soft-wrap: on a terminal it wraps at its width, into a pipe it stays whole
    # (written as rich would print it, without colours, at once: `_tree_text`).
    labels = _labels(model, configuration, states, resolved[1] if resolved else None)
    if out.is_terminal:
        out.print(_tree(model, labels))
    else:
        out.file.write(_tree_text(model, labels, not out.encoding.lower().startswith("utf")))
    for formula in model.formulas:  # (rule 2.4: they hold beside the tree)
        out.print(f"formula {formula.position + 1}: {escape(formula.text)}")
    out.print(_legend(model.bindings_declared, resolved is not None))


def _legend(bound: bool, resolved: bool) -> str:
    """The line under `show`'s tree that says what its marks mean."""
    start = "; start = active at start in the variant configure resolves" if resolved else ""
    if not bound:
        return (
            "[dim]marks: ! mandatory, ? optional, [OR]/[XOR] group member; set = what the configuration says; "
            "solver = whether valid variants select it (one value: forced); no feature says a binding, "
            f"so every one is Static Early{start}[/]"
        )
    return (
        "[dim]marks: ! mandatory, ? optional, [OR]/[XOR] group member; allowed = mode/time a feature allows; "
        f"set = what the configuration says; solver = what valid variants leave (one value: forced){start}[/]"
    )


def _resolved(
    model: FeatureModel, config: Configuration | None, prefer: tuple[str, ...]
) -> tuple[Variant, set[str]] | None:
    """The variant configure makes of the configuration, and its start state; None without one."""
    if config is None:
        return None
    from ..binding.resolve import resolve, start_state

    variant = resolve(model, config, prefer)
    return variant, {f.id for f in start_state(variant)}


def _show_json(
    model: FeatureModel,
    config: Configuration | None,
    states: list[set[FeatureState]],
    resolved: tuple[Variant, set[str]] | None,
) -> dict[str, object]:
    """The tree as data: per feature what the model allows, the configuration says, valid
    variants leave, and (with a variant) what configure makes of it and whether it starts active."""
    order: list[FeatureState] = [OFF, *Binding]
    features = []
    for f in model.features:
        entry = config.entries.get(f.id) if config is not None else None
        item: dict[str, object] = {
            "id": f.id,
            "name": f.name,
            "parent": None if f.parent is None else model.features[f.parent].id,
            "group": f.group,
            "mandatory": f.mandatory,
            "abstract": f.abstract,
            "allowed": {"time": token(f.time_allowed), "mode": token(f.mode_allowed)},
            "possible": [str(s) for s in order if s in states[f.index]],
        }
        if config is not None:
            item["configured"] = (
                None
                if entry is None
                else {"selected": entry.selected}
                if not entry.selected
                else {"selected": True, "time": token(entry.time), "mode": token(entry.mode)}
            )
        if resolved is not None:
            d = resolved[0].decisions[f.index]
            item["variant"] = {"selected": d.selected, "binding": str(d.binding) if d.selected else None}
            item["active_at_start"] = f.id in resolved[1]
        features.append(item)
    return {
        "model": model.source.file if model.source is not None else model.name,
        "configuration": config.source.file if config is not None and config.source is not None else None,
        "features": features,
        "formulas": [formula.text for formula in model.formulas],
    }


def _labels(
    model: FeatureModel,
    config: Configuration | None,
    states: list[set[FeatureState]],
    active: set[str] | None = None,
) -> list[tuple[str, str]]:
    """Per feature, its line of `show`'s tree: as rich markup, and as the plain text that
    the markup prints without colours."""
    order: list[FeatureState] = [OFF, *Binding]
    labels: list[tuple[str, str]] = []
    for f in model.features:
        parts: list[tuple[str, str]] = []  # (text, style)
        if f.parent is None:
            pass
        elif f.group:
            parts += [(f"[{f.group}]", "magenta"), (" ", "")]
        else:
            parts += [("!", "bold"), (" ", "")] if f.mandatory else [("? ", "")]
        bound = model.bindings_declared  # (False: every feature takes the defaults; say selection only)
        allowed = f"  allowed {_short(f.mode_allowed)}{_short(f.time_allowed)}" if bound else ""
        configured = ""
        if config is not None:
            entry = config.entries.get(f.id)
            if entry is None:
                configured = " set —" if f.parent is not None else ""
            elif not entry.selected:
                configured = " set off"
            else:
                configured = f" set {_short(entry.mode)}{_short(entry.time)}" if bound or entry.mode or entry.time else " set on"
        possible = states[f.index]
        words = [s for s in order if s in possible]
        solver = ",".join(words if bound else ["on" if s != OFF else s for s in words]) or "none"
        parts += [(f.id, "bold")]
        if f.name != f.id:
            parts += [(" ", ""), (f"({printable(f.name)})", "dim")]
        parts += [
            (f"{allowed}{configured}  solver ", ""),
            (solver, "green" if len(possible) == 1 else "cyan"),
        ]
        if active is not None and f.id in active:
            parts += [(" ", ""), ("start", "bold green")]
        markup = "".join(f"[{style}]{escape(text)}[/]" if style else escape(text) for text, style in parts)
        labels.append((markup, "".join(text for text, _ in parts)))
    return labels


def _tree(model: FeatureModel, labels: list[tuple[str, str]]) -> Tree:
    from rich.tree import Tree

    nodes: dict[int, Tree] = {}
    root_tree: Tree | None = None
    for f in model.features:
        label = labels[f.index][0]
        if f.parent is None:
            root_tree = Tree(label)
            nodes[f.index] = root_tree
        else:
            nodes[f.index] = nodes[f.parent].add(label)
    assert root_tree is not None
    return root_tree


def _tree_text(model: FeatureModel, labels: list[tuple[str, str]], ascii_only: bool) -> str:
    """The tree as rich prints it into a pipe, without rich (which takes seconds for 10,000
    features): the same guides, one whole line per feature, however deep (rich would wrap
    a line wider than its console, and drops lines when the guides alone are wider)."""
    from rich.tree import Tree

    space, keep, fork, end = Tree.ASCII_GUIDES if ascii_only else Tree.TREE_GUIDES[0]
    lines: list[str] = []
    stack: list[tuple[int, str, bool]] = [(0, "", True)]  # (feature, its guides' prefix, last child)
    features = model.features
    while stack:
        i, prefix, last = stack.pop()
        text = labels[i][1]
        if features[i].parent is None:
            lines.append(text)
            below = ""
        else:
            lines.append(prefix + (end if last else fork) + text)
            below = prefix + (space if last else keep)
        children = features[i].children
        stack.extend((c, below, k == 0) for k, c in enumerate(reversed(children)))
    return "\n".join(lines) + "\n"


def _short(value: Time | Mode | None) -> str:
    """A time or mode as the letter it has in a binding's name ("S" of "SE"); `*`: Any."""
    return "*" if value is None else value[0]

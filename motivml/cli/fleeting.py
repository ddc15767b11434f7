"""fleet: many robots of one fleet file at once (reference.md section 9)."""

from __future__ import annotations

import sys

import click
from rich.markup import escape

from ..errors import MotivmlError
from .common import fail, out, plural, print_diagnostics


@click.group("fleet")
def fleet_group() -> None:
    """Many robots of one fleet file (FLEET.json) at once.

    `fleet plan` checks a change for every robot of the fleet file without touching any.
    (Listing the running fleet and rolling a change out in stages are not there yet: each
    robot's node takes `motivml ctl` and its ROS 2 parameters one robot at a time.)
    """


@fleet_group.command("plan")
@click.argument("fleet", type=click.Path(dir_okay=False, readable=False))
@click.argument("change", nargs=-1, required=True)
@click.option(
    "--robots",
    "selector",
    metavar="SELECTOR",
    help="The robots to plan for: a glob over namespaces (/bay*; * also crosses /), or @GROUP for a group's robots (default: all).",
)
def plan_command(fleet: str, change: tuple[str, ...], selector: str | None) -> None:
    """Check CHANGE (load F..., unload F..., reload F..., swap OUT IN) for each
    robot of FLEET as `ctl` checks it on a running robot, without touching anything: per
    robot, accepted with what loads and unloads, or refused with the reason and the repairs.

    The change is checked against the active set each robot's variant starts with (with the
    fleet's overrides): no running robot is asked. Exit 0 when every robot accepts it, 1
    when one refuses it or its configuration has errors, 2 for a change that is not one.
    """
    from ..fleet import UnknownGroup, plan_fleet
    from ..runtime.requests import Event, RequestError, parse

    if change[0] not in ("load", "unload", "reload", "swap"):
        raise click.UsageError(f"{change[0]} is not planned for a fleet: load, unload, reload or swap")
    try:
        request = parse(change[0], change[1:])
    except RequestError as exc:
        raise click.UsageError(f"{' '.join(change)!r}: {exc}") from None
    assert not isinstance(request, Event)  # (no event verb gets here)
    try:
        problems, plans = plan_fleet(fleet, request, selector)
    except UnknownGroup as unknown:
        raise click.BadParameter(str(unknown), param_hint="'--robots'") from None
    except (MotivmlError, OSError) as exc:
        from .common import environment_problem

        fail(exc if isinstance(exc, MotivmlError) else environment_problem(exc))
    if problems:
        print_diagnostics(problems)
        out.print(f"[bold red]invalid[/]: {escape(fleet)}: {plural(len(problems), 'error')} in the fleet file: nothing planned")
        sys.exit(1)
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
    out.print(
        f"{escape(' '.join(change))}: accepted by {len(plans) - refused} of {plural(len(plans), 'robot')}, "
        f"refused by {refused} (checked against each robot's start state: no running robot was asked)"
    )
    sys.exit(1 if refused else 0)

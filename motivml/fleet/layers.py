"""A fleet file (reference.md section 9): robots by namespace, each a robot folder and one of
its variants, with decisions overridden in layers, checked robot by robot.

Each robot's configuration is its variant's entries, then the fleet's overrides, then its
groups' (in the order the robot lists them), then its own: an entry replaces the entry of
the same feature that an earlier layer made. The result is checked against the robot's
model as `validate MODEL --config` checks a configuration (a partial one when the variant
is a decisions file), and every message is located where the entry it speaks of was
written (the variant file, or the layer in the fleet file) and names the robot, and each
conflict names the layers of the decisions it involves.
"""

from __future__ import annotations

import fnmatch
import json
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..binding.check import check_variant
from ..documents.loader import Document, parse
from ..documents.robot_folder import RobotFolder, UnknownVariant
from ..documents.schema import FLEET, check_configuration, check_document, read_with_problems
from ..errors import Diagnostic, Judged, Location, MotivmlError, Severity, error
from ..language.model import Configuration, FeatureModel
from ..language.reader import load_model, read_configuration

if TYPE_CHECKING:
    from ..runtime.requests import Request


@dataclass(frozen=True)
class Layer:
    """Where a robot's entries come from: its variant file, or a layer of the fleet file."""

    name: str  # "variant clinic", "fleet", "group night", "robot /uv1"
    document: Document
    steps: tuple[str | int, ...]  # the path of its entry list in the document


@dataclass
class RobotReport(Judged):
    """What checking one robot of the fleet found."""

    namespace: str
    folder: str
    variant: str
    layers: list[str]
    diagnostics: list[Diagnostic] = field(default_factory=list)
    model: FeatureModel | None = None
    config: Configuration | None = None
    origins: list[tuple[Layer, int]] = field(default_factory=list)  # where each entry of `config` was written
    entry: Location | None = None  # the robot's entry in the fleet file
    variant_layer: Layer | None = None  # its variant file, where the configuration as a whole is said
    document: dict[str, Any] | None = None  # its configuration as one decisions document (run FLEET runs it)


def is_fleet_file(path: str | Path) -> bool:
    """A fleet file is named fleet.json, or NAME.fleet.json."""
    name = Path(path).name
    return name == "fleet.json" or name.endswith(".fleet.json")


def validate_fleet(path: str | Path, partial: bool = False) -> tuple[list[Diagnostic], list[RobotReport]]:
    """The fleet file's own errors (its schema, names that refer to nothing, a namespace
    twice), and, when it has none, one report per robot in the file's order (`partial`:
    every robot's configuration checked as a partial one, as validate --partial does)."""
    problems, doc = fleet_file(path)
    if doc is None:
        return problems, []
    base = Path(path).parent
    return [], [_robot(doc, k, base, partial) for k in range(len(doc.root["robots"]))]


def fleet_file(path: str | Path) -> tuple[list[Diagnostic], Document | None]:
    """The fleet file read and checked on its own (its schema, groups a robot names that it
    does not define, a namespace twice), no robot's configuration yet: its errors, or the file."""
    doc, problems = read_with_problems(path, lambda d: check_document(d, FLEET, "a fleet file"))
    if doc is None or problems:
        return problems, None
    root: dict[str, Any] = doc.root
    groups: dict[str, Any] = root.get("groups", {})
    seen: dict[str, int] = {}
    for k, robot in enumerate(root["robots"]):
        namespace = "/" + robot["namespace"].strip("/")
        if namespace in seen:
            problems.append(
                error(
                    doc.locate(("robots", k, "namespace")),
                    f"{namespace} is robot {seen[namespace] + 1}'s namespace too: one robot per namespace",
                    "fleet.namespace",
                )
            )
        seen.setdefault(namespace, k)
        for g, name in enumerate(robot.get("groups", [])):
            if name not in groups:
                known = ", ".join(groups) or "none"
                problems.append(
                    error(
                        doc.locate(("robots", k, "groups", g)),
                        f"no group {name!r} in the fleet file (groups: {known})",
                        "fleet.group",
                    )
                )
    return (problems, None) if problems else ([], doc)


def _robot(doc: Document, k: int, base: Path, partial: bool) -> RobotReport:
    robot: dict[str, Any] = doc.root["robots"][k]
    namespace = "/" + robot["namespace"].strip("/")
    where = os.path.normpath(base / robot["robot"])  # (said as "robots/uv1", not "fleets/../robots/uv1")
    report = RobotReport(namespace, where, robot["variant"], [], entry=doc.locate(("robots", k)))
    try:
        folder = RobotFolder.open(where)
        variant_path = folder.variant_path(robot["variant"])
    except MotivmlError as exc:  # (a folder or a variant that is not there: said at the robot's entry)
        key = "variant" if isinstance(exc, UnknownVariant) else "robot"
        at = doc.locate(("robots", k, key))
        report.diagnostics = [
            _about(namespace, replace(d, location=at, message=f"{d.message} ({d.location})")) for d in exc.diagnostics
        ]
        return report
    model, problems = load_model(folder.model_path)
    # the variant as validate --variant reads it: its schema, then (below) its own entries
    variant_doc, variant_problems = read_with_problems(variant_path, check_configuration)
    if model is None or variant_doc is None or variant_problems:
        report.diagnostics = [_about(namespace, d) for d in [*problems, *variant_problems] if d.severity is Severity.ERROR]
        return report
    report.model = model
    layers = [Layer(f"variant {robot['variant']}", variant_doc, ("properties",))]
    report.variant_layer = layers[0]
    layers.append(Layer("fleet", doc, ("overrides",)))
    layers += [Layer(f"group {name}", doc, ("groups", name, "overrides")) for name in robot.get("groups", [])]
    layers.append(Layer(f"robot {namespace}", doc, ("robots", k, "overrides")))
    entries, origins, twice = _merged(layers)
    report.layers = [layer.name for layer in layers if _entries(layer)]
    if twice:
        report.diagnostics = [_about(namespace, d) for d in twice]
        return report
    partial = partial or variant_doc.root.get("partial") is True
    report.document = {"partial": partial, "properties": entries}
    merged = parse(json.dumps(report.document), f"{namespace} (merged)")
    config, diagnostics = read_configuration(merged, model, partial=partial)
    report.config, report.origins = config, origins
    if not [d for d in diagnostics if d.severity is Severity.ERROR]:
        diagnostics += check_variant(model, config)
    report.diagnostics = [_about(namespace, _moved(d, origins, layers[0])) for d in diagnostics]
    return report


def fleet_robot(path: str | Path, namespace: str) -> tuple[list[Diagnostic], RobotReport | None]:
    """The robot of the fleet file in `namespace`, checked (`run FLEET --ros-namespace NS`):
    the fleet file's errors, or its report (None: no robot of the file has that namespace)."""
    problems, robots = validate_fleet(path)
    if problems:
        return problems, None
    wanted = "/" + namespace.strip("/")
    return [], next((r for r in robots if r.namespace == wanted), None)


def _entries(layer: Layer) -> list[Any]:
    node: Any = layer.document.root
    for step in layer.steps:
        if isinstance(node, dict) and isinstance(step, str):
            node = node.get(step, [])
        elif isinstance(node, list) and isinstance(step, int) and step < len(node):
            node = node[step]
        else:
            return []
    return node if isinstance(node, list) else []


def _merged(layers: list[Layer]) -> tuple[list[Any], list[tuple[Layer, int]], list[Diagnostic]]:
    """The entries of every layer, a later layer's replacing an earlier one's for the same
    feature (in the place of the first), and where each came from; and the errors of a
    layer that decides a feature twice (a layer is a decisions file: once each)."""
    at: dict[str, int] = {}
    entries: list[Any] = []
    origins: list[tuple[Layer, int]] = []
    twice: list[Diagnostic] = []
    for layer in layers:
        mine: dict[str, int] = {}
        for position, entry in enumerate(_entries(layer)):
            fid = entry.get("id") if isinstance(entry, dict) else None
            if isinstance(fid, str) and fid in mine:
                where = layer.document.locate((*layer.steps, position, "id"))
                first = layer.document.locate((*layer.steps, mine[fid]))
                said = f"a second entry for {fid!r} in {layer.name} (the first at line {first.line}): a layer decides a feature once"
                twice.append(error(where, said, "config.duplicate", fid))
                continue
            if isinstance(fid, str):
                mine[fid] = position
            if isinstance(fid, str) and fid in at:
                entries[at[fid]], origins[at[fid]] = entry, (layer, position)
                continue
            if isinstance(fid, str):
                at[fid] = len(entries)
            entries.append(entry)
            origins.append((layer, position))
    return entries, origins, twice


def _moved(d: Diagnostic, origins: list[tuple[Layer, int]], variant: Layer | None) -> Diagnostic:
    """A diagnostic of the merged configuration, located where its entries were written,
    the layers of the entries it involves named."""
    layers: list[str] = []

    def where(location: Location) -> Location:
        steps = location.steps
        if len(steps) >= 2 and steps[0] == "properties" and isinstance(steps[1], int) and steps[1] < len(origins):
            layer, position = origins[steps[1]]
            if layer.name not in layers:
                layers.append(layer.name)
            return layer.document.locate((*layer.steps, position, *steps[2:]))
        if steps in ((), ("properties",)) and variant is not None:  # (the configuration as a whole: its variant's)
            return variant.document.locate(steps)
        return location

    location = where(d.location)
    facts = tuple(replace(f, location=where(f.location)) for f in d.facts)
    said = f" (set by: {', '.join(layers)})" if layers else ""
    return replace(d, location=location, facts=facts, message=d.message + said)


def _about(namespace: str, d: Diagnostic) -> Diagnostic:
    return replace(d, message=f"robot {namespace}: {d.message}")



# ----------------------------------------------------------------------------- plan
class UnknownGroup(ValueError):
    """A selector names a group the fleet file does not define."""


@dataclass
class RobotPlan:
    """What a change would do to one robot: accepted (what loads and unloads) or not (why)."""

    namespace: str
    accepted: bool
    loads: tuple[str, ...] = ()
    unloads: tuple[str, ...] = ()
    diagnostics: list[Diagnostic] = field(default_factory=list)  # why not, with the repairs
    against: tuple[str, ...] = ()  # the active set it was planned against


def selected(robots: list[RobotReport], groups: dict[str, list[str]], selector: str | None) -> list[RobotReport]:
    """The robots a selector names: a glob over namespaces ("/bay*"), or "@GROUP" for the
    robots of a group; None: every robot."""
    chosen = set(_chosen([r.namespace for r in robots], groups, selector))
    return [r for r in robots if r.namespace in chosen]


def selected_namespaces(path: str | Path, selector: str | None) -> list[str]:
    """The namespaces of the robots of a fleet file (one with no errors of its own) that a
    selector names, in the file's order; UnknownGroup for a group it does not define."""
    doc, _ = read_with_problems(path, lambda d: [])
    assert doc is not None
    return _chosen(namespaces(doc), groups_of(doc), selector)


def namespaces(doc: Document) -> list[str]:
    """The robots' namespaces of a fleet file, in its order."""
    return ["/" + r["namespace"].strip("/") for r in doc.root["robots"]]


def _chosen(namespaces: list[str], groups: dict[str, list[str]], selector: str | None) -> list[str]:
    if selector is None:
        return namespaces
    if selector.startswith("@"):
        if selector[1:] not in groups:
            raise UnknownGroup(f"no group {selector[1:]!r} in the fleet file (groups: {', '.join(groups) or 'none'})")
        members = set(groups[selector[1:]])
        return [ns for ns in namespaces if ns in members]
    pattern = "/" + selector.strip("/")
    return [ns for ns in namespaces if fnmatch.fnmatchcase(ns, pattern)]


@dataclass(frozen=True)
class Running:
    """What a running robot's node says of itself (its latched active-set message)."""

    namespace: str
    robot: str
    variant: str
    active: tuple[str, ...]
    tick: int
    configuration: str = ""  # the digest of the variant it runs (Variant.digest; "": not said)


def groups_of(doc: Document) -> dict[str, list[str]]:
    """Each group of the fleet file and its robots' namespaces, in the file's order."""
    groups: dict[str, list[str]] = {name: [] for name in doc.root.get("groups", {})}
    for robot in doc.root["robots"]:
        for name in robot.get("groups", []):
            groups.setdefault(name, []).append("/" + robot["namespace"].strip("/"))
    return groups


def plan_fleet(
    path: str | Path,
    request: Request,
    selector: str | None = None,
    ask: Callable[[list[str]], dict[str, Running]] | None = None,
) -> tuple[list[Diagnostic], list[RobotPlan]]:
    """The change checked for each selected robot as `ctl` checks it on a running robot,
    touching nothing: the fleet file's errors (then no plan), or one plan per selected
    robot. Without `ask`, against the active set each robot's variant starts with; with it,
    against the active set each running robot reports (`ask` is given the selected robots'
    namespaces and answers for those it found): a robot not found, or running another
    variant than the fleet file gives it, is not planned for."""
    problems, robots = validate_fleet(path)
    if problems:
        return problems, []
    doc, _ = read_with_problems(path, lambda d: [])
    assert doc is not None
    chosen = selected(robots, groups_of(doc), selector)
    if ask is None:
        return [], [_plan(r, request) for r in chosen]
    running = ask([r.namespace for r in chosen])
    return [], [_plan_running(r, request, running.get(r.namespace)) for r in chosen]


def _plan_running(robot: RobotReport, request: Request, running: Running | None) -> RobotPlan:
    where = robot.entry or Location(robot.folder)
    if running is None:
        why = f"robot {robot.namespace}: not running (no node {robot.namespace.rstrip('/')}/motivml on the graph)"
        return RobotPlan(robot.namespace, False, diagnostics=[error(where, why, "fleet.absent")])
    if running.robot != Path(robot.folder).name:
        why = (
            f"robot {robot.namespace}: runs the robot {running.robot}, the fleet file gives it "
            f"{Path(robot.folder).name}: nothing planned"
        )
        return RobotPlan(robot.namespace, False, diagnostics=[error(where, why, "fleet.robot")])
    if running.variant != robot.variant:
        why = (
            f"robot {robot.namespace}: runs variant {running.variant}, the fleet file gives it {robot.variant}: "
            "nothing planned (restart it with its fleet variant, or correct the fleet file)"
        )
        return RobotPlan(robot.namespace, False, diagnostics=[error(where, why, "fleet.variant")])
    return _plan(robot, request, running.active, running.configuration)


def _plan(
    robot: RobotReport, request: Request, active: tuple[str, ...] | None = None, configuration: str = ""
) -> RobotPlan:
    from ..binding.resolve import resolve, start_state
    from ..runtime.reconfigure import Reconfigurer, Refused

    if not robot.valid or robot.model is None or robot.config is None:
        why = f"robot {robot.namespace}: its configuration has errors (validate the fleet file): nothing planned"
        where = robot.entry or Location(robot.folder)
        return RobotPlan(robot.namespace, False, diagnostics=[error(where, why, "fleet.invalid")])
    variant = resolve(robot.model, robot.config)
    if configuration and configuration != variant.digest():
        why = (
            f"robot {robot.namespace}: runs variant {robot.variant} in another configuration than the fleet file "
            f"gives it (its layers): nothing planned (run it as motivml run FLEET --ros-namespace {robot.namespace})"
        )
        return RobotPlan(robot.namespace, False, diagnostics=[error(robot.entry or Location(robot.folder), why, "fleet.layers")])
    now = list(active) if active is not None else [f.id for f in start_state(variant)]
    try:
        plan = Reconfigurer(variant, robot.config).plan(now, request)
    except Refused as refused:
        said = [_about(robot.namespace, _moved(d, robot.origins, robot.variant_layer)) for d in refused.diagnostics]
        return RobotPlan(robot.namespace, False, diagnostics=said, against=tuple(now))
    return RobotPlan(robot.namespace, True, plan.loads, plan.unloads, against=tuple(now))

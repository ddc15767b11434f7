"""The motion architecture document (architecture.json) and its validation.

Structure after "Modeling of Movement Control Architectures based on Motion Primitives
using Domain-Specific Languages": spaces (typed data), mappings between types,
transformations within a type, adaptive modules (dynamical systems plus learners) and
adaptive components (a module with its wiring, rate and criterion). Every element names
the feature that brings it, so a variant's active features decide which elements exist.

Validation, located like validate's messages: unknown or duplicate ids, elements of
features the model does not have, a transformation between types or dimensions, a
mapping within one type, a module whose dimension does not fit a port, a component's goal
and feedback meeting in incompatible spaces, a criterion or dynamical system unfit for the
component's kind, and cycles among goal connections (a component cannot wait on its own
output within one tick; feedback may close loops).

A document that passes becomes an `Architecture` of typed elements (elements.py), made
once here: the builder, the drawings and the coordination checks read those, never the
JSON. The checks themselves read the JSON, since what they look for (duplicate ids,
unknown references, parameters of another system's type) is what typed elements cannot
hold; `Architecture.locate` takes an element back to its place in the text.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, TypeVar

from ..documents.loader import Document
from ..documents.schema import check_document
from ..errors import Diagnostic, Location, error, warning
from ..language.model import FeatureModel
from .elements import (
    Component,
    Criterion,
    Demonstration,
    DMPParameters,
    Element,
    Learner,
    Linear,
    Mapping,
    MappingFunction,
    Module,
    OscillatorParameters,
    PlanarArm,
    PlanarArmIK,
    PointAttractorParameters,
    Port,
    Scale,
    Space,
    SystemParameters,
    Vector,
)

ARCHITECTURE = "architecture.schema.json"
GOAL_DIRECTED = {"pointAttractor", "dmp"}
PERIODIC = {"oscillators"}
CRITERIA = {
    "convergence": {"ReachingController", "Sequencer"},
    "tracking": {"TrackingController", "PatternGenerator"},
}
SYSTEMS = {
    "ReachingController": GOAL_DIRECTED,
    "Sequencer": GOAL_DIRECTED,
    "TrackingController": GOAL_DIRECTED | PERIODIC,
    "PatternGenerator": PERIODIC,
}
PARAMETERS = {
    "pointAttractor": {"alpha"},
    "dmp": {"alpha", "basis", "duration", "demonstration"},
    "oscillators": {"frequency", "coupling", "amplitude", "offsets", "phases"},
}
SECTIONS = ("spaces", "mappings", "modules", "components")
E = TypeVar("E", Space, Mapping, Module, Component)


@dataclass
class Architecture:
    """The document's elements by id, per section, in document order (typed, checked)."""

    spaces: dict[str, Space]
    mappings: dict[str, Mapping]
    modules: dict[str, Module]
    components: dict[str, Component]
    source: Document
    positions: dict[tuple[str, str], int]  # (section, id) -> index in the document's section

    def elements_of(self, features: set[str]) -> Architecture:
        """The elements brought by the given (active) features.

        An element kept still refers to the elements it uses, kept or not: whoever needs
        them present (the builder, a drawing) looks for their ids among the kept ones.
        """

        def keep(section: dict[str, E]) -> dict[str, E]:
            return {k: v for k, v in section.items() if v.feature in features}

        return Architecture(
            keep(self.spaces),
            keep(self.mappings),
            keep(self.modules),
            keep(self.components),
            self.source,
            self.positions,
        )

    def elements(self) -> Iterator[Element]:
        """Every element: spaces, mappings, modules, components."""
        yield from self.spaces.values()
        yield from self.mappings.values()
        yield from self.modules.values()
        yield from self.components.values()

    def locate(self, section: str, element: str, *keys: str | int) -> Location:
        """Where an element, or one of its keys, stands in the document's text."""
        return self.source.locate((section, self.positions[(section, element)], *keys))


@dataclass(frozen=True)
class Reference:
    """One element using another: where it says so, and the features that bring both."""

    section: str
    element: str
    keys: tuple[str, ...]
    kind: str  # the used element's section
    target: str
    user_feature: str
    target_feature: str


def references(architecture: Architecture) -> list[Reference]:
    """Every use of one element by another, in document order."""
    found = []
    for mapping in architecture.mappings.values():
        for key, space in (("from", mapping.source), ("to", mapping.target)):
            found.append(
                Reference("mappings", mapping.id, (key,), "spaces", space.id, mapping.feature, space.feature)
            )
    for component in architecture.components.values():
        module, user = component.module, component.feature
        found.append(
            Reference("components", component.id, ("module",), "modules", module.id, user, module.feature)
        )
        for name, port in component.ports():
            space = port.space
            found.append(
                Reference(
                    "components", component.id, (name, "space"), "spaces", space.id, user, space.feature
                )
            )
            if port.through is not None:
                mapping = port.through
                found.append(
                    Reference(
                        "components",
                        component.id,
                        (name, "through"),
                        "mappings",
                        mapping.id,
                        user,
                        mapping.feature,
                    )
                )
    return found


class _ArchitectureChecker:
    """What an architecture document must be beyond its schema, against itself and the model:
    ids, features, references, types and dimensions, kinds, goal cycles.

    Every problem is collected in `found`, located.
    """

    def __init__(self, doc: Document, model: FeatureModel) -> None:
        self.doc = doc
        self.model = model
        self.found: list[Diagnostic] = []
        root = doc.root
        self.position = {
            (section, item["id"]): i for section in SECTIONS for i, item in enumerate(root.get(section, []))
        }
        self.by_id = {section: {item["id"]: item for item in root.get(section, [])} for section in SECTIONS}

    def where(self, section: str, element: str, *keys: str) -> Location:
        return self.doc.locate((section, self.position[(section, element)], *keys))

    def report(self, section: str, element: str, keys: tuple[str, ...], message: str, rule: str) -> None:
        feature = self.by_id[section][element].get("feature")
        self.found.append(error(self.where(section, element, *keys), message, rule, feature))

    def reference(self, section: str, element: str, keys: tuple[str, ...], target: str, kind: str) -> bool:
        known = self.by_id[kind]
        if target in known:
            return True
        close = difflib.get_close_matches(target, list(known), n=1, cutoff=0.75)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        singular = kind.removesuffix("s")
        self.report(
            section,
            element,
            keys,
            f"{element} refers to unknown {singular} {target!r}{hint}",
            "architecture.unknown-id",
        )
        return False

    def run(self) -> None:
        seen: dict[str, str] = {}
        duplicated = False
        for section in SECTIONS:
            for index, item in enumerate(self.doc.root.get(section, [])):
                element = item["id"]
                if element in seen:
                    where = self.doc.locate((section, index, "id"))
                    message = f"id {element!r} is used twice (also a {seen[element]})"
                    self.found.append(error(where, message, "architecture.duplicate-id", item.get("feature")))
                    duplicated = True
                    continue
                seen[element] = section.removesuffix("s")
                if item["feature"] not in self.model.index:
                    self.report(
                        section,
                        element,
                        ("feature",),
                        f"{element} is brought by {item['feature']!r}, which is not a feature of the model",
                        "architecture.unknown-feature",
                    )
        if duplicated:
            return  # references would be ambiguous
        for element, space in self.by_id["spaces"].items():
            if "initial" in space and len(space["initial"]) != space["dimension"]:
                self.report(
                    "spaces",
                    element,
                    ("initial",),
                    f"the initial value of {_shape(space)} has {len(space['initial'])} numbers",
                    "architecture.value",
                )
        for element, mapping in self.by_id["mappings"].items():
            self.mapping(element, mapping)
        for element, module in self.by_id["modules"].items():
            for number, system in enumerate(module["systems"]):
                self.parameters(element, number, system)
            has_dmp = any(system["type"] == "dmp" for system in module["systems"])
            for number, learner in enumerate(module.get("learners", [])):
                if learner["type"] != "ridge" or not has_dmp:
                    self.report_at(
                        "modules",
                        element,
                        ("learners", str(number), "type"),
                        f"a module's learner is ridge regression of its DMPs' weights, so {learner['type']} does not fit module {element}"
                        + ("" if has_dmp else " (it has no DMP)")
                        + " (an elm learns in an adaptive mapping)",
                        "architecture.learner",
                    )
        for element, component in self.by_id["components"].items():
            self.component(element, component)
        self.writers()
        self.shared_modules()
        self.cycles()

    def mapping(self, element: str, mapping: dict[str, Any]) -> None:
        ends = [mapping["from"], mapping["to"]]
        if not all(
            self.reference("mappings", element, (key,), mapping[key], "spaces") for key in ("from", "to")
        ):
            return
        source, target = (self.by_id["spaces"][end] for end in ends)
        if mapping["kind"] == "transformation" and (source["type"], source["dimension"]) != (
            target["type"],
            target["dimension"],
        ):
            self.report(
                "mappings",
                element,
                ("kind",),
                f"transformation {element} changes {_shape(source)} into {_shape(target)}: a transformation stays within one type and dimension (use a mapping)",
                "architecture.transformation",
            )
        self.function(element, mapping, source, target)
        if mapping["kind"] != "transformation" and source["type"] == target["type"]:
            self.report(
                "mappings",
                element,
                ("kind",),
                f"{mapping['kind']} {element} stays within {source['type']}: use a transformation",
                "architecture.mapping",
            )

    def function(
        self, element: str, mapping: dict[str, Any], source: dict[str, Any], target: dict[str, Any]
    ) -> None:
        """Does the mapping say what it computes, in a way that fits its two spaces?"""
        kind, function = mapping["kind"], mapping.get("function")

        def wrong(key: str, message: str) -> None:
            self.report(
                "mappings",
                element,
                ("function", key) if function else (key,),
                message,
                "architecture.function",
            )

        if kind == "adaptiveMapping" and "learner" not in mapping:
            wrong("kind", f"adaptive mapping {element} needs a learner")
        if function is None:
            if kind == "mapping":
                wrong("kind", f"mapping {element} needs a function: linear or planarArm")
            return
        rows, columns = target["dimension"], source["dimension"]
        allowed = {"transformation": ("linear", "scale")}.get(kind, ("linear", "planarArm", "planarArmIK"))
        if function["type"] not in allowed:
            wrong("type", f"a {kind} cannot compute {function['type']} (it can: {', '.join(allowed)})")
            return
        needs = {
            "linear": ("matrix",),
            "scale": ("factor",),
            "planarArm": ("links",),
            "planarArmIK": ("links",),
        }[function["type"]]
        for key in sorted(
            set(function) - set(needs) - {"type", "offset"} - {k for k in function if k.startswith("x-")}
        ):
            wrong(key, f"{key} is not a parameter of {function['type']}")
        for key in needs:
            if key not in function:
                wrong("type", f"{function['type']} needs {key}")
                return
        if function["type"] == "linear":
            shape = (len(function["matrix"]), {len(row) for row in function["matrix"]})
            if shape != (rows, {columns}):
                wrong(
                    "matrix",
                    f"the matrix of {element} must be {rows} x {columns} ({target['id']} from {source['id']})",
                )
        if (
            function["type"] == "scale"
            and isinstance(function["factor"], list)
            and len(function["factor"]) != rows
        ):
            wrong("factor", f"{element} scales {rows} numbers but has {len(function['factor'])} factors")
        if function["type"] == "planarArmIK" and (columns, len(function["links"])) not in ((2, 2), (2, 3)):
            wrong(
                "links",
                f"the inverse kinematics of {element} maps a 2-dimensional position to 2 or 3 joint angles, not {_shape(source)} with {len(function['links'])} links",
            )
        elif function["type"] == "planarArmIK" and rows != len(function["links"]):
            wrong("links", f"{element} has {len(function['links'])} links but {_shape(target)}")
        if function["type"] == "planarArm" and (len(function["links"]), rows) != (columns, 2):
            wrong(
                "links",
                f"a planar arm of {len(function['links'])} links maps JointAngles({len(function['links'])}) to a 2-dimensional position, not {_shape(source)} to {_shape(target)}",
            )
        if "offset" in function and (function["type"] == "scale" or len(function["offset"]) != rows):
            wrong(
                "offset", f"the offset of {element} must have {rows} numbers and belongs to a linear function"
            )

    def parameters(self, element: str, number: int, system: dict[str, Any]) -> None:
        """System parameters belong to their type and have the system's dimension."""
        kind, dimension = system["type"], system["dimension"]
        for key in sorted(set(system) - {"type", "dimension"}):
            if key.startswith("x-"):
                continue
            where = ("systems", str(number), key)
            if key not in PARAMETERS[kind]:
                self.report_at(
                    "modules",
                    element,
                    (*where,),
                    f"{key} is not a parameter of {kind}",
                    "architecture.parameter",
                )
            elif key in ("offsets", "phases") and len(system[key]) != dimension:
                self.report_at(
                    "modules",
                    element,
                    (*where,),
                    f"{key} of {element} needs {dimension} numbers",
                    "architecture.parameter",
                )
            elif key == "demonstration":
                lengths = {len(sample) for sample in system[key]["samples"]}
                if lengths != {dimension}:
                    self.report_at(
                        "modules",
                        element,
                        (*where,),
                        f"the demonstration of {element} must have samples of {dimension} numbers",
                        "architecture.parameter",
                    )

    def report_at(self, section: str, element: str, keys: tuple[str, ...], message: str, rule: str) -> None:
        path = tuple(int(k) if k.isdigit() else k for k in keys)
        feature = self.by_id[section][element].get("feature")
        self.found.append(
            error(
                self.doc.locate((section, self.position[(section, element)], *path)), message, rule, feature
            )
        )

    def shared_modules(self) -> None:
        """Each component runs its own module (a module's state is one component's)."""
        user: dict[str, str] = {}
        for element, component in self.by_id["components"].items():
            module = component["module"]
            if module in user:
                self.report(
                    "components",
                    element,
                    ("module",),
                    f"module {module} already runs in component {user[module]}: each component needs a module of its own",
                    "architecture.shared-module",
                )
            user.setdefault(module, element)

    def writers(self) -> None:
        """A space is computed by component outputs (summed) or by free mappings, not both.

        Two free mappings may compute one space (alternatives of an XOR group, say); if both
        are active, the later in document order wins.
        """
        ports = {
            c.get(port, {}).get("through")
            for c in self.by_id["components"].values()
            for port in ("goal", "feedback", "output")
        }
        written = {c["output"]["space"]: element for element, c in self.by_id["components"].items()}
        for element, mapping in self.by_id["mappings"].items():
            if element in ports or mapping["to"] not in self.by_id["spaces"]:
                continue
            other = written.get(mapping["to"])
            if other is not None and other in self.by_id["components"]:
                self.report(
                    "mappings",
                    element,
                    ("to",),
                    f"{mapping['to']} is written by component {other} and computed by {element}: a space has one kind of writer",
                    "architecture.writers",
                )
            written.setdefault(mapping["to"], element)

    def module_side(self, element: str, port: str) -> dict[str, Any] | None:
        """The space a component's module sees on a port, after its mapping (if known)."""
        connection = self.by_id["components"][element].get(port)
        if connection is None:
            return None
        if not self.reference("components", element, (port, "space"), connection["space"], "spaces"):
            return None
        through = connection.get("through")
        if through is None:
            outer_space: dict[str, Any] = self.by_id["spaces"][connection["space"]]
            return outer_space
        if not self.reference("components", element, (port, "through"), through, "mappings"):
            return None
        mapping = self.by_id["mappings"][through]
        outer = "to" if port == "output" else "from"
        inner = "from" if port == "output" else "to"
        if mapping[outer] != connection["space"]:
            self.report(
                "components",
                element,
                (port, "through"),
                f"{through} connects {mapping['from']} to {mapping['to']}, not {connection['space']} on the {port} of {element}",
                "architecture.connection",
            )
            return None
        inner_space: dict[str, Any] | None = self.by_id["spaces"].get(mapping[inner])
        return inner_space

    def component(self, element: str, component: dict[str, Any]) -> None:
        kind = component["kind"]
        if not self.reference("components", element, ("module",), component["module"], "modules"):
            module = None
        else:
            module = self.by_id["modules"][component["module"]]
        sides = {port: self.module_side(element, port) for port in ("goal", "feedback", "output")}
        goal, feedback = sides["goal"], sides["feedback"]
        if goal is not None and feedback is not None and _key(goal) != _key(feedback):
            self.report(
                "components",
                element,
                ("feedback",),
                f"the goal ({_shape(goal)}) and feedback ({_shape(feedback)}) of {element} meet in incompatible spaces",
                "architecture.connection",
            )
        criterion = component.get("criterion")
        if criterion is not None and kind not in CRITERIA[criterion["type"]]:
            self.report(
                "components",
                element,
                ("criterion", "type"),
                f"a {criterion['type']} criterion does not fit a {kind} (it fits {', '.join(sorted(CRITERIA[criterion['type']]))})",
                "architecture.criterion",
            )
        if "sequence" in component and kind != "Sequencer":
            self.report(
                "components",
                element,
                ("sequence",),
                f"only a Sequencer has a sequence, not a {kind}",
                "architecture.sequence",
            )
        if kind == "Sequencer" and "sequence" not in component and "goal" not in component:
            self.report(
                "components",
                element,
                ("kind",),
                f"Sequencer {element} needs a sequence or a goal",
                "architecture.sequence",
            )
        if module is None:
            return
        for number, point in enumerate(component.get("sequence", [])):
            if len(point) != sum(system["dimension"] for system in module["systems"]):
                self.report_at(
                    "components",
                    element,
                    ("sequence", str(number)),
                    f"via point {number} of {element} does not have the dimension of module {module['id']}",
                    "architecture.sequence",
                )
        dimension = sum(system["dimension"] for system in module["systems"])
        for port, side in sides.items():
            if side is not None and side["dimension"] != dimension:
                self.report(
                    "components",
                    element,
                    (port,),
                    f"the {port} of {element} is {_shape(side)} but module {module['id']} has dimension {dimension}",
                    "architecture.dimension",
                )
        unfit = [s["type"] for s in module["systems"] if s["type"] not in SYSTEMS[kind]]
        if unfit:
            self.report(
                "components",
                element,
                ("module",),
                f"a {kind} cannot run {', '.join(unfit)} (module {module['id']})",
                "architecture.system",
            )

    def cycles(self) -> None:
        """Components connected output -> goal must be acyclic (stepped in dependency order)."""
        components = self.by_id["components"]
        readers: dict[str, list[str]] = {}
        for element, component in components.items():
            if "goal" in component:
                readers.setdefault(component["goal"]["space"], []).append(element)
        edges = {e: sorted(readers.get(c["output"]["space"], [])) for e, c in components.items()}
        state: dict[str, int] = {}
        for start in components:
            if state.get(start):
                continue
            stack: list[tuple[str, int]] = [(start, 0)]
            path: list[str] = []
            while stack:
                node, index = stack.pop()
                if index == 0:
                    state[node] = 1
                    path.append(node)
                nexts = edges[node]
                if index < len(nexts):
                    stack.append((node, index + 1))
                    child = nexts[index]
                    if state.get(child) == 1:
                        loop = path[path.index(child) :] + [child]
                        self.report(
                            "components",
                            child,
                            ("goal",),
                            f"components wait on each other's output within a tick: {' -> '.join(loop)}",
                            "architecture.cycle",
                        )
                    elif not state.get(child):
                        stack.append((child, 0))
                else:
                    state[node] = 2
                    path.pop()


def _key(space: dict[str, Any]) -> tuple[str, int]:
    return space["type"], space["dimension"]


def _shape(space: dict[str, Any]) -> str:
    unit = f" [{space['unit']}]" if space.get("unit") else ""
    return f"{space['id']}: {space['type']}({space['dimension']}){unit}"


def read_architecture(doc: Document, model: FeatureModel) -> tuple[Architecture | None, list[Diagnostic]]:
    """Validate an architecture document against the schema and the model; its typed elements."""
    problems = check_document(doc, ARCHITECTURE, "an architecture document")
    if problems:
        return None, problems
    checker = _ArchitectureChecker(doc, model)
    checker.run()
    if checker.found:
        return None, checker.found
    architecture = _elements(doc)
    return architecture, sizes(architecture)


# Sizes above which a run is too slow for its loop or too big for memory, warned about: an
# online ELM updates a hidden x hidden matrix per sample (10,000 hidden units take ~3 s a
# tick), and a space, a system or a DMP's basis is a numpy vector or matrix of its size.
MAX_HIDDEN = 500
MAX_DIMENSION = 1000
MAX_BASIS = 1000


def sizes(architecture: Architecture) -> list[Diagnostic]:
    """A located warning for each learner, system or space above the size bounds."""
    found: list[Diagnostic] = []

    def warn(
        section: str,
        element: str,
        keys: tuple[str | int, ...],
        what: str,
        size: int,
        bound: int,
        feature: str,
    ) -> None:
        found.append(
            warning(
                architecture.locate(section, element, *keys),
                f"{element} has {size:,} {what}, over the bound of {bound:,}: "
                f"a run may be too slow for its loop or run out of memory",
                "architecture.size",
                feature,
            )
        )

    for space in architecture.spaces.values():
        if space.dimension > MAX_DIMENSION:
            warn(
                "spaces",
                space.id,
                ("dimension",),
                "dimensions",
                space.dimension,
                MAX_DIMENSION,
                space.feature,
            )
    for mapping in architecture.mappings.values():
        learner = mapping.learner
        if learner is not None and learner.type == "elm" and learner.hidden > MAX_HIDDEN:
            keys: tuple[str | int, ...] = ("learner", "hidden")
            warn("mappings", mapping.id, keys, "hidden units", learner.hidden, MAX_HIDDEN, mapping.feature)
    for module in architecture.modules.values():
        for number, system in enumerate(module.systems):
            if system.dimension > MAX_DIMENSION:
                keys = ("systems", number, "dimension")
                warn(
                    "modules", module.id, keys, "dimensions", system.dimension, MAX_DIMENSION, module.feature
                )
            if isinstance(system, DMPParameters) and system.basis > MAX_BASIS:
                keys = ("systems", number, "basis")
                warn("modules", module.id, keys, "basis functions", system.basis, MAX_BASIS, module.feature)
    return found


# ------------------------------------------------------------- typed elements of the JSON
def _elements(doc: Document) -> Architecture:
    """The typed elements of a checked document (every id unique, every reference known)."""
    root = doc.root
    spaces = {item["id"]: _space(item) for item in root.get("spaces", [])}
    mappings = {item["id"]: _mapping(item, spaces) for item in root.get("mappings", [])}
    modules = {item["id"]: _module(item) for item in root.get("modules", [])}
    components = {
        item["id"]: _component(item, spaces, mappings, modules) for item in root.get("components", [])
    }
    positions = {
        (section, item["id"]): i for section in SECTIONS for i, item in enumerate(root.get(section, []))
    }
    return Architecture(spaces, mappings, modules, components, doc, positions)


def _vector(numbers: list[float]) -> Vector:
    return tuple(numbers)


def _count(number: int | float) -> int:
    """A dimension, a number of hidden units or of basis functions as an int: JSON Schema's
    "integer" admits 3.0, and numpy refuses a float for a size."""
    return int(number)


def _space(item: dict[str, Any]) -> Space:
    initial = item.get("initial")
    return Space(
        item["id"],
        item["type"],
        _count(item["dimension"]),
        item["feature"],
        item.get("unit"),
        _vector(initial) if initial is not None else None,
    )


def _function(item: dict[str, Any]) -> MappingFunction:
    kind = item["type"]
    if kind == "linear":
        offset = item.get("offset")
        return Linear(
            tuple(_vector(row) for row in item["matrix"]), _vector(offset) if offset is not None else None
        )
    if kind == "scale":
        factor = item["factor"]
        return Scale(_vector(factor) if isinstance(factor, list) else factor)
    if kind == "planarArm":
        return PlanarArm(_vector(item["links"]))
    return PlanarArmIK(_vector(item["links"]))


def _learner(item: dict[str, Any]) -> Learner:
    return Learner(item["type"], item.get("mode"), _count(item.get("hidden", 60)))


def _mapping(item: dict[str, Any], spaces: dict[str, Space]) -> Mapping:
    function, learner = item.get("function"), item.get("learner")
    return Mapping(
        item["id"],
        item["kind"],
        spaces[item["from"]],
        spaces[item["to"]],
        item["feature"],
        _function(function) if function is not None else None,
        _learner(learner) if learner is not None else None,
    )


def _system(item: dict[str, Any]) -> SystemParameters:
    kind, dimension = item["type"], _count(item["dimension"])
    if kind == "pointAttractor":
        return PointAttractorParameters(dimension, item.get("alpha", 25.0))
    if kind == "dmp":
        shown = item.get("demonstration")
        demonstration = (
            Demonstration(shown["dt"], tuple(_vector(sample) for sample in shown["samples"]))
            if shown is not None
            else None
        )
        return DMPParameters(
            dimension,
            item.get("alpha", 25.0),
            _count(item.get("basis", 30)),
            item.get("duration"),
            demonstration,
        )
    offsets, phases = item.get("offsets"), item.get("phases")
    return OscillatorParameters(
        dimension,
        item.get("frequency", 1.0),
        item.get("coupling", 4.0),
        item.get("amplitude", 1.0),
        _vector(offsets) if offsets is not None else None,
        _vector(phases) if phases is not None else None,
    )


def _module(item: dict[str, Any]) -> Module:
    return Module(
        item["id"],
        tuple(_system(system) for system in item["systems"]),
        item["feature"],
        tuple(_learner(learner) for learner in item.get("learners", [])),
        item.get("state", "executing"),
    )


def _component(
    item: dict[str, Any], spaces: dict[str, Space], mappings: dict[str, Mapping], modules: dict[str, Module]
) -> Component:
    def port(name: str) -> Port | None:
        connection = item.get(name)
        if connection is None:
            return None
        through = connection.get("through")
        return Port(spaces[connection["space"]], mappings[through] if through is not None else None)

    output, criterion = port("output"), item.get("criterion")
    assert output is not None  # required by the schema
    return Component(
        item["id"],
        item["kind"],
        modules[item["module"]],
        output,
        item["feature"],
        port("goal"),
        port("feedback"),
        item.get("rate"),
        Criterion(criterion["type"], criterion["tolerance"]) if criterion is not None else None,
        tuple(_vector(point) for point in item.get("sequence", [])),
    )

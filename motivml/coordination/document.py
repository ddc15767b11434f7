"""Coordination: a Harel statechart over the motion architecture (coordination.json).

Read and checked here (located messages like every other document's), executed by
sismic (a maintained Harel-statechart interpreter) inside `motivml run`, and exported as
W3C SCXML.

Semantics (those of sismic): entering a compound state enters its `initial` sub-state; exit
actions run innermost first, entry actions outermost first; among the transitions that
could fire, inner states' win over outer ones', and within a state the first in document
order wins. A transition fires when its `event` has arrived (if it names one), its `after`
seconds have passed since its source state was entered (if it has one), and every `when`
condition holds. Domain conditions read the architecture: a component `converged`,
`tracking` or `ongoing`; a module's learning state. Actions: `log`, `send` a value to a
space, set a module's `learning` state, `start` or `stop` a component, `load`, `unload` or
`swap` features (a reconfiguration, checked like any other).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, TypeVar

from ..architecture.document import Architecture
from ..architecture.elements import Component, Module, Space
from ..documents.loader import Document
from ..documents.robot_folder import ARCHITECTURE_FILE
from ..documents.schema import check_document
from ..errors import Diagnostic, error, warning
from ..language.model import Binding, FeatureModel

COORDINATION = "coordination.schema.json"
MAX_DEPTH = 64  # nesting of states (the schema check recurses)
CPP_KEYWORDS = frozenset(
    "alignas alignof and asm auto bitand bitor bool break case catch char class compl concept const consteval "
    "constexpr constinit continue decltype default delete do double else enum explicit export extern false float "
    "for friend goto if inline int long mutable namespace new noexcept not nullptr operator or private protected "
    "public register requires return short signed sizeof static struct switch template this throw true try "
    "typedef typeid typename union unsigned using virtual void volatile while xor".split()
)
RESERVED_EVENTS = {"motivml", "error", "done"}  # SCXML matches event names by prefix: these would catch ours
CRITERION_FOR = {
    "converged": ("convergence",),
    "tracking": ("tracking",),
    "ongoing": ("convergence", "tracking"),
}


@dataclass
class Coordination:
    """A checked statechart: states by id with their parent, in document order."""

    doc: Document
    initial: str
    states: dict[str, dict[str, Any]]
    parent: dict[str, str | None]
    paths: dict[str, tuple[str | int, ...]]  # JSON path of each state
    rate: float

    def children(self, state: str | None) -> list[str]:
        return [s for s, p in self.parent.items() if p == state]


def _walk(root: dict[str, Any]) -> Iterator[tuple[dict[str, Any], str | None, tuple[str | int, ...], int]]:
    """Every state with its parent's id, its JSON path and its depth (iterative, pre-order)."""
    stack: list[tuple[dict[str, Any], str | None, tuple[str | int, ...], int]] = [
        (state, None, ("states", i), 1) for i, state in reversed(list(enumerate(root["states"])))
    ]
    while stack:
        state, parent, path, depth = stack.pop()
        yield state, parent, path, depth
        for i, child in reversed(list(enumerate(state.get("states", [])))):
            stack.append((child, state["id"], (*path, "states", i), depth + 1))


def _depth(root: Any) -> int:
    deepest, stack = 0, [(root, 0)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        children = node.get("states") if isinstance(node, dict) else None
        if isinstance(children, list):
            stack += [(child, depth + 1) for child in children]
    return deepest


E = TypeVar("E", Space, Module, Component)


def _spaces(architecture: Architecture) -> dict[str, Space]:
    return architecture.spaces


def _modules(architecture: Architecture) -> dict[str, Module]:
    return architecture.modules


def _components(architecture: Architecture) -> dict[str, Component]:
    return architecture.components


@dataclass(frozen=True)
class VariantBindings:
    """What the checks need of a resolved variant: its name and each selected feature's binding."""

    name: str
    bindings: dict[str, Binding]  # selected feature id -> its binding


class _CoordinationChecker:
    """What a coordination document must be beyond its schema: its states, and its references
    to the model's features, the architecture's elements and the variant's bindings.

    Every problem is collected in `found`, located.
    """

    def __init__(
        self,
        doc: Document,
        model: FeatureModel,
        architecture: Architecture | None,
        variant: VariantBindings | None,
        architecture_invalid: bool = False,
    ) -> None:
        self.doc, self.model, self.architecture, self.variant = doc, model, architecture, variant
        self.architecture_invalid = architecture_invalid
        self.unchecked = 0  # element references not checked because the architecture is invalid
        self.found: list[Diagnostic] = []

    def error(self, path: tuple[str | int, ...], message: str, rule: str) -> None:
        self.found.append(error(self.doc.locate(path), message, rule))

    def warn(self, path: tuple[str | int, ...], message: str, rule: str) -> None:
        self.found.append(warning(self.doc.locate(path), message, rule))

    def run(self) -> Coordination | None:
        root = self.doc.root
        for state, _, path, _ in _walk(root):
            if state["id"] in CPP_KEYWORDS:
                self.warn(
                    (*path, "id"),
                    f"state id {state['id']!r} is a C++ keyword: Qt's SCXML compiler would generate code that does not build",
                    "coordination.keyword",
                )
        states: dict[str, dict[str, Any]] = {}
        parent: dict[str, str | None] = {}
        paths: dict[str, tuple[str | int, ...]] = {}
        for state, above, path, _ in _walk(root):
            if state["id"] in states:
                self.error((*path, "id"), f"state {state['id']!r} is defined twice", "coordination.duplicate")
                continue
            states[state["id"]], parent[state["id"]], paths[state["id"]] = state, above, path
        if self.found:
            return None
        top = [s for s, p in parent.items() if p is None]
        if root["initial"] not in top:
            self.error(
                ("initial",),
                f"the initial state {root['initial']!r} is not a top-level state ({', '.join(top)})",
                "coordination.unknown-state",
            )
        for sid, state in states.items():
            self.state(sid, state, paths[sid], parent, states)
        coordination = Coordination(
            self.doc, root["initial"], states, parent, paths, float(root.get("rate", 100.0))
        )
        if not any(d.severity.value == "error" for d in self.found):
            self.eventless_cycles(coordination)
        if not any(d.severity.value == "error" for d in self.found):
            self.reachability(coordination)
        return coordination

    def state(
        self,
        sid: str,
        state: dict[str, Any],
        path: tuple[str | int, ...],
        parent: dict[str, str | None],
        states: dict[str, dict[str, Any]],
    ) -> None:
        children = [c["id"] for c in state.get("states", [])]
        if state.get("final") and (children or state.get("transitions")):
            self.error(
                (*path, "final"), f"final state {sid} has sub-states or transitions", "coordination.final"
            )
        if children and "initial" not in state:
            self.error(
                (*path, "id"),
                f"compound state {sid} needs an initial sub-state ({', '.join(children)})",
                "coordination.initial",
            )
        if "initial" in state and state["initial"] not in children:
            self.error(
                (*path, "initial"),
                f"{state['initial']!r} is not a sub-state of {sid}",
                "coordination.unknown-state",
            )
        for key in ("entry", "exit"):
            for i, action in enumerate(state.get(key, [])):
                self.action(action, (*path, key, i))
        for i, transition in enumerate(state.get("transitions", [])):
            where = (*path, "transitions", i)
            if transition["target"] not in states:
                self.error(
                    (*where, "target"),
                    f"{sid} has a transition to unknown state {transition['target']!r}",
                    "coordination.unknown-state",
                )
            if not ({"event", "after", "when"} & set(transition)):
                self.warn(
                    where,
                    f"a transition of {sid} has no event, time or condition: it fires at once",
                    "coordination.eventless",
                )
            if transition.get("event") in RESERVED_EVENTS:
                self.error(
                    (*where, "event"),
                    f"event name {transition['event']!r} is reserved (SCXML would match its own {transition['event']}.* events)",
                    "coordination.event",
                )
            for j, condition in enumerate(transition.get("when", [])):
                self.condition(condition, (*where, "when", j))
            for j, action in enumerate(transition.get("actions", [])):
                self.action(action, (*where, "actions", j))

    def _element(
        self,
        section: Callable[[Architecture], dict[str, E]],
        name: str,
        path: tuple[str | int, ...],
        what: str,
    ) -> E | None:
        """The architecture's element of that name in that section, if it has one (else say so)."""
        if self.architecture is None:
            if self.architecture_invalid:
                self.unchecked += 1
            else:
                self.error(
                    path, f"{what} {name!r}: the robot has no {ARCHITECTURE_FILE}", "coordination.unknown"
                )
            return None
        element = section(self.architecture).get(name)
        if element is None:
            self.error(path, f"unknown {what} {name!r}", "coordination.unknown")
        elif self.variant is not None and element.feature not in self.variant.bindings:
            self.warn(
                path,
                f"{what} {name} belongs to {element.feature}, which variant {self.variant.name} does not select: "
                f"it is never active there",
                "coordination.inactive",
            )
        return element

    def condition(self, condition: dict[str, Any], path: tuple[str | int, ...]) -> None:
        if "component" in condition:
            component = self._element(_components, condition["component"], (*path, "component"), "component")
            if component is None:
                return
            criterion = component.criterion
            wanted = CRITERION_FOR[condition["is"]]
            if criterion is None or criterion.type not in wanted:
                has = f"a {criterion.type} criterion" if criterion is not None else "no criterion"
                self.error(
                    (*path, "is"),
                    f"{condition['component']} has {has}, so it is never {condition['is']} (a condition on a component needs its {' or '.join(wanted)} criterion)",
                    "coordination.criterion",
                )
        else:
            self._element(_modules, condition["module"], (*path, "module"), "module")

    def action(self, action: dict[str, Any], path: tuple[str | int, ...]) -> None:
        ((kind, value),) = action.items()
        where = (*path, kind)
        if kind == "send":
            space = self._element(_spaces, value["space"], (*where, "space"), "space")
            if space is None:
                return
            if len(value["value"]) != space.dimension:
                self.error(
                    (*where, "value"),
                    f"{value['space']} holds {space.type}({space.dimension}), not {len(value['value'])} numbers",
                    "coordination.send",
                )
            if "type" in value and value["type"] != space.type:
                self.error(
                    (*where, "type"),
                    f"{value['space']} holds {space.type}, not {value['type']}",
                    "coordination.send",
                )
            if "unit" in value and value["unit"] != space.unit:
                self.warn(
                    (*where, "unit"),
                    f"{value['space']} is in {space.unit or 'no unit'}, not {value['unit']}",
                    "coordination.unit",
                )
        elif kind == "learning":
            self._element(_modules, value["module"], (*where, "module"), "module")
        elif kind in ("start", "stop"):
            self._element(_components, value, where, "component")
        elif kind in ("load", "unload", "swap"):
            for i, feature in enumerate(value):
                self.feature(feature, (*where, i), kind)

    def feature(self, feature: str, path: tuple[str | int, ...], verb: str) -> None:
        if feature not in self.model.index:
            self.error(path, f"no feature {feature!r} in the model", "coordination.unknown")
            return
        if self.variant is not None:
            binding = self.variant.bindings.get(feature)
            if binding is None:
                self.error(
                    path,
                    f"{verb} {feature}: {feature} is not in variant {self.variant.name}",
                    "coordination.variant",
                )
            elif binding is Binding.SE:
                self.error(
                    path,
                    f"{verb} {feature}: {feature} is compiled into variant {self.variant.name} (Static Early)",
                    "coordination.variant",
                )
            elif binding is Binding.SL and (verb == "unload" or (verb == "swap" and path[-1] == 0)):
                self.error(
                    path,
                    f"{verb} {feature}: {feature} is Static Late in variant {self.variant.name}: it stays once loaded",
                    "coordination.variant",
                )

    def eventless_cycles(self, coordination: Coordination) -> None:
        """Transitions with no event, time or condition that lead back: the chart never settles."""
        edges: dict[str, list[str]] = {}
        for sid, state in coordination.states.items():
            for t in state.get("transitions", []):
                if not ({"event", "after", "when"} & set(t)) and t["target"] in coordination.states:
                    edges.setdefault(sid, []).append(t["target"])
        for start in edges:
            seen, todo = set(), list(edges[start])
            while todo:
                node = todo.pop()
                if (
                    node == start
                    or coordination.parent.get(node) == start
                    or self._inside(coordination, start, node)
                ):
                    self.error(
                        (*coordination.paths[start], "transitions"),
                        f"state {start} leads back to itself through transitions with no event, time or condition: the chart would never settle",
                        "coordination.eventless-cycle",
                    )
                    break
                if node not in seen:
                    seen.add(node)
                    todo += edges.get(node, [])

    @staticmethod
    def _inside(coordination: Coordination, outer: str, node: str) -> bool:
        above: str | None = coordination.parent.get(node)
        while above is not None:
            if above == outer:
                return True
            above = coordination.parent.get(above)
        return False

    def reachability(self, coordination: Coordination) -> None:
        reached: set[str] = set()
        todo = [coordination.initial]
        while todo:
            sid = todo.pop()
            if sid in reached:
                continue
            reached.add(sid)
            state = coordination.states[sid]
            if "initial" in state:
                todo.append(state["initial"])
            todo += [t["target"] for t in state.get("transitions", [])]
            above = coordination.parent[sid]
            if above is not None:
                todo.append(above)  # entering a state enters its ancestors, with their transitions
        for sid, path in coordination.paths.items():
            if sid not in reached:
                self.warn((*path, "id"), f"state {sid} can never be entered", "coordination.unreachable")
        for sid, state in coordination.states.items():
            if state.get("final") or state.get("states"):
                continue
            node: str | None = sid
            stuck = True
            while node is not None:
                if coordination.states[node].get("transitions"):
                    stuck = False
                node = coordination.parent[node]
            if stuck and sid in reached:
                self.warn(
                    (*coordination.paths[sid], "id"),
                    f"state {sid} has no way out and is not final",
                    "coordination.dead-end",
                )


def read_coordination(
    doc: Document,
    model: FeatureModel,
    architecture: Architecture | None,
    variant: VariantBindings | None = None,
    architecture_invalid: bool = False,
) -> tuple[Coordination | None, list[Diagnostic]]:
    """Check a coordination document: schema, references, types, reachability.

    With `architecture_invalid` (the robot has an architecture, but it did not pass its
    checks) references to its elements are left unchecked, and no coordination is returned
    when there are any.
    """
    if _depth(doc.root) > MAX_DEPTH:
        return None, [
            error(doc.locate(()), f"states nest deeper than {MAX_DEPTH} levels", "coordination.depth")
        ]
    problems = check_document(doc, COORDINATION, "a coordination document")
    if problems:
        return None, problems
    checker = _CoordinationChecker(doc, model, architecture, variant, architecture_invalid)
    coordination = checker.run()
    errors = [d for d in checker.found if d.severity.value == "error"]
    return (None if errors or checker.unchecked else coordination), checker.found

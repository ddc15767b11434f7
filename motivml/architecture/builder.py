"""The robot builder: from a variant's active features to an executable motion architecture.

`build(architecture, active)` instantiates exactly the elements of the active features:
spaces (numpy vectors, from their initial values), mappings (the functions of
architecture.json, an `AdaptiveMappingInstance` with its learner for an adaptive one), one
`ModuleInstance` per adaptive module and one `ComponentInstance` per adaptive component,
wired to its spaces through `PortInstance`s. It orders the components so that a component
whose output is another's goal steps first within a tick (the document forbids cycles
among goal connections), and the free mappings (those on no port) after them, each after
the mappings it reads from.

What a tick means for each element (the runtime calls `Assembly.tick`):

* a component steps when due (every `loop rate / component rate` ticks): it reads its goal
  and feedback through their mappings, steps its module, and writes its output through its
  mapping; several components writing one space are *superposed* (the space holds the sum
  of their latest outputs), which is how a mixture of controllers combines;
* goal-directed systems restart from the current position when the goal changes; periodic
  systems oscillate around the goal (or zero);
* a criterion compares goal and feedback (or the module's own output when there is no
  feedback): convergence -> "converged", tracking -> "tracking", else "ongoing"; without
  a criterion a component is "running". A pattern generator tracks when its oscillators are
  locked to the wanted phase differences within the tolerance;
* module lifecycle: `executing` drives the output; `offlineLearning` drives nothing and
  records learning data (the feedback, else the goal); `onlineLearning` drives the output
  and records. Leaving a learning state learns from the recording: a DMP's weights by ridge
  regression (the recording is its new demonstration).

Missing references (a component of an active feature using a space of an inactive one) are
refused with a located `BuildError`, never half built.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..errors import Diagnostic, MotivmlError, error, warning
from .document import Architecture
from .dynamics import CoupledOscillators, DiscreteDMP, PointAttractor
from .elements import (
    PORTS,
    Component,
    ComponentKind,
    Criterion,
    DMPParameters,
    Learner,
    Linear,
    Mapping,
    MappingFunction,
    Module,
    PlanarArmIK,
    PointAttractorParameters,
    PortName,
    Scale,
    Space,
)
from .learners import ExtremeLearningMachine, LinearRLS
from .stability import unstable

Vector = NDArray[np.float64]
Function = Callable[[Vector], Vector]
STATES = ("executing", "onlineLearning", "offlineLearning")


class BuildError(MotivmlError):
    """The active features' elements do not make a runnable architecture."""


# ----------------------------------------------------------------------------- mappings
def make_function(mapping: Mapping) -> Function:
    """What a mapping computes, as a function of numpy vectors."""
    inputs, outputs = mapping.source.dimension, mapping.target.dimension
    if mapping.kind == "adaptiveMapping":
        assert mapping.learner is not None  # the document's checks see to it
        teacher = mapping.teacher
        taught = _compute(teacher, outputs) if teacher is not None else None
        return AdaptiveMappingInstance(mapping.learner, inputs, outputs, taught)
    return _compute(mapping.function, outputs)


def _compute(function: MappingFunction | None, outputs: int) -> Function:
    if function is None:
        return lambda x: x.copy()
    if isinstance(function, Scale):
        factor = np.asarray(function.factor, dtype=float)
        return lambda x: factor * x
    if isinstance(function, Linear):
        matrix = np.asarray(function.matrix, dtype=float)
        offset = np.asarray(
            function.offset if function.offset is not None else np.zeros(outputs), dtype=float
        )
        return lambda x: np.asarray(matrix @ x + offset)
    links = np.asarray(function.links, dtype=float)
    if isinstance(function, PlanarArmIK):
        return lambda x: planar_arm_ik(links, x)
    return lambda x: planar_arm(links, x)


def planar_arm(links: Vector, angles: Vector) -> Vector:
    """Forward kinematics of a planar serial arm: the hand's (x, y)."""
    absolute = np.cumsum(angles)
    return np.array([links @ np.cos(absolute), links @ np.sin(absolute)])


def planar_arm_ik(links: Vector, position: Vector) -> Vector:
    """Joint angles that put a planar arm's hand at (x, y), elbow down.

    With 3 links the redundancy is resolved by pointing the tool away from the base: the
    wrist sits one tool length short of the target on the line from the base. Targets out
    of reach are clamped to the arm's reach.
    """
    x, y = float(position[0]), float(position[1])
    heading = math.atan2(y, x)
    if len(links) == 3:
        x, y = x - links[2] * math.cos(heading), y - links[2] * math.sin(heading)
    a, b = float(links[0]), float(links[1])
    cosine = max(-1.0, min(1.0, (x * x + y * y - a * a - b * b) / (2 * a * b)))
    elbow = math.acos(cosine)
    shoulder = math.atan2(y, x) - math.atan2(b * math.sin(elbow), a + b * math.cos(elbow))
    angles = [shoulder, elbow]
    if len(links) == 3:
        angles.append(heading - shoulder - elbow)
    return np.array(angles)


class AdaptiveMappingInstance:
    """A running adaptive mapping: predicts with its learner, and learns from a teacher if it has one.

    A sample is an evaluation whose input has moved since the last sample: holding still
    teaches nothing new, and would only pull the learner towards one point. online (the
    default): each sample is learned at once, by recursive least squares. offline: samples
    are collected, and the learner is fitted on all of them in one batch every `BATCH`
    samples (predictions use the latest fit).
    """

    BATCH = 100

    def __init__(self, learner: Learner, inputs: int, outputs: int, teacher: Function | None) -> None:
        self.model: ExtremeLearningMachine | LinearRLS = (
            ExtremeLearningMachine(inputs, outputs, hidden=int(learner.hidden))  # JSON may say 60.0
            if learner.type == "elm"
            else LinearRLS(inputs, outputs)
        )
        self.offline = learner.mode == "offline"
        self.teacher = teacher
        self.samples = 0
        self.error = float("nan")
        self._inputs: list[Vector] = []
        self._targets: list[Vector] = []
        self._last: Vector | None = None

    def __call__(self, x: Vector) -> Vector:
        prediction = np.asarray(self.model.predict(x)[0], dtype=float)
        if self.teacher is not None and (self._last is None or not np.array_equal(x, self._last)):
            self._last = x.copy()
            target = self.teacher(x)
            self.error = float(np.linalg.norm(target - prediction))
            self.samples += 1
            if self.offline:
                self._inputs.append(x.copy())
                self._targets.append(target)
                if self.samples % self.BATCH == 0:
                    self.model.fit(np.array(self._inputs), np.array(self._targets))
            else:
                self.model.update(x, target)
        return prediction


# ------------------------------------------------------------------------------ modules
@dataclass
class ModuleInstance:
    """A running adaptive module: its dynamical systems side by side, and its lifecycle."""

    id: str
    systems: list[PointAttractor | DiscreteDMP | CoupledOscillators]
    sizes: list[int]
    state: str = "executing"
    recording: list[Vector] = field(default_factory=list)
    learned: int = 0  # how many times it has learned from a recording
    record_dt: float = 0.001  # the step of the recording (the recording component's)

    def __post_init__(self) -> None:
        self.dimension = sum(self.sizes)
        self.periodic = all(isinstance(s, CoupledOscillators) for s in self.systems)
        self._cuts = list(np.cumsum(self.sizes)[:-1])
        self._single = self.systems[0] if len(self.systems) == 1 else None
        self._no_centre = np.zeros(self.dimension)  # what a component without a goal passes

    def _split(self, vector: Vector) -> list[Vector]:
        return [vector] if self._single is not None else np.split(vector, self._cuts)

    def position(self) -> Vector:
        parts = [s.output() if isinstance(s, CoupledOscillators) else s.position for s in self.systems]
        return np.concatenate(parts)

    def hold(self) -> Vector:
        """Where the module is, as a goal: goal-directed parts stay, periodic parts centre on 0."""
        parts = [
            np.zeros(n) if isinstance(s, CoupledOscillators) else s.position
            for s, n in zip(self.systems, self.sizes, strict=True)
        ]
        return np.concatenate(parts)

    def retarget(self, goal: Vector) -> None:
        """Move the goal without restarting: the motion so far goes on towards it."""
        single = self._single
        if single is not None:  # spaces are replaced, never changed in place: no copy needed
            if not isinstance(single, CoupledOscillators):
                single.goal = goal
            return
        for system, g in zip(self.systems, self._split(goal), strict=True):
            if isinstance(system, PointAttractor | DiscreteDMP):
                system.goal = g.copy()

    def reset(self, start: Vector, goal: Vector) -> None:
        for system, x0, g in zip(self.systems, self._split(start), self._split(goal), strict=True):
            if isinstance(system, DiscreteDMP):
                system.reset(x0, g)
            elif isinstance(system, PointAttractor):
                system.position, system.velocity, system.goal = x0.copy(), np.zeros_like(x0), g.copy()

    def step(self, dt: float, centre: Vector) -> Vector:
        single = self._single
        if single is not None:  # the common case, without splitting and joining
            if isinstance(single, CoupledOscillators):
                out = single.step(dt)
                return out if centre is self._no_centre else centre + out
            return single.step(dt)  # a new array each step: safe to share
        parts = []
        for system, c in zip(self.systems, self._split(centre), strict=True):
            if isinstance(system, CoupledOscillators):
                parts.append(c + system.step(dt))
            else:
                parts.append(system.step(dt))
        return np.concatenate(parts)

    def phase_error(self) -> float:
        """Largest distance of the oscillators' phase differences from the wanted ones."""
        return max(
            (s.locking_error() for s in self.systems if isinstance(s, CoupledOscillators)), default=0.0
        )

    def set_state(self, state: str) -> None:
        """Change the lifecycle state; leaving a learning state learns from the recording."""
        if state not in STATES:
            raise ValueError(f"unknown learning state {state!r} (states: {', '.join(STATES)})")
        if self.state != "executing" and state != self.state and len(self.recording) >= 3:
            self.learn(np.array(self.recording))
        if state != self.state:
            self.recording = []
        self.state = state

    def learn(self, demonstration: Vector, dt: float | None = None) -> None:
        """A DMP learns the recorded movement (at the rate it was recorded)."""
        step = dt if dt is not None else self.record_dt
        for system, part in zip(
            self.systems, np.split(demonstration, np.cumsum(self.sizes)[:-1], axis=1), strict=True
        ):
            if isinstance(system, DiscreteDMP):
                system.learn(part, step)
        self.learned += 1


def make_module(spec: Module) -> ModuleInstance:
    systems: list[PointAttractor | DiscreteDMP | CoupledOscillators] = []
    for system in spec.systems:
        n = system.dimension
        if isinstance(system, PointAttractorParameters):
            systems.append(PointAttractor(np.zeros(n), np.zeros(n), alpha=system.alpha))
        elif isinstance(system, DMPParameters):
            dmp = DiscreteDMP(n, basis=system.basis, alpha=system.alpha)
            dmp.tau = system.duration if system.duration is not None else 1.0
            demonstration = system.demonstration
            if demonstration is not None:
                dmp.learn(np.asarray(demonstration.samples, dtype=float), demonstration.dt)
                if system.duration is not None:
                    dmp.tau = system.duration
            systems.append(dmp)
        else:
            offsets = np.asarray(system.offsets if system.offsets is not None else np.zeros(n), dtype=float)
            phases = np.asarray(
                system.phases if system.phases is not None else 0.3 * np.arange(n), dtype=float
            )
            systems.append(
                CoupledOscillators(
                    offsets,
                    frequency=system.frequency,
                    coupling=system.coupling,
                    amplitude=system.amplitude,
                    phases=phases,
                )
            )
    module = ModuleInstance(spec.id, systems, [s.dimension for s in spec.systems])
    module.set_state(spec.state)
    return module


# --------------------------------------------------------------------------- components
@dataclass
class PortInstance:
    """A component's built port: the space it reads or writes, and the function on the way."""

    space: str
    function: Function | None

    def read(self, values: dict[str, Vector]) -> Vector:
        value = values[self.space]
        return self.function(value) if self.function is not None else value


@dataclass
class ComponentInstance:
    """A running adaptive component: its module, ports, rate divider and criterion's verdict."""

    id: str
    kind: ComponentKind
    feature: str
    module: ModuleInstance
    output: PortInstance
    goal: PortInstance | None
    feedback: PortInstance | None
    criterion: Criterion | None
    divider: int  # steps every `divider` ticks
    dt: float
    sequence: list[Vector]
    running: bool = True
    status: str = "ongoing"
    error: float = float("nan")  # the criterion's measure: distance or phase error
    contribution: Vector | None = None
    via: int = 0  # a Sequencer's current via point
    _goal: Vector | None = None  # the goal the module was last reset to
    _raw: Vector | None = None  # the goal space's value last read
    _read: Vector | None = None  # ... and what the goal port made of it

    def current_goal(self, values: dict[str, Vector]) -> Vector | None:
        """The module-side goal; read through its mapping only when the space changed."""
        if self.sequence:
            return self.sequence[self.via]
        if self.goal is None:
            return None
        raw = values[self.goal.space]
        if raw is not self._raw:  # spaces are replaced, never changed in place
            self._raw = raw
            self._read = self.goal.read(values)
        return self._read

    def step(self, values: dict[str, Vector]) -> None:
        module = self.module
        goal = self.current_goal(values)
        feedback = self.feedback.read(values) if self.feedback is not None else None
        if module.state == "offlineLearning":
            sample = feedback if feedback is not None else goal
            if sample is not None:
                module.recording.append(sample.copy())
            module.record_dt = self.dt
            self.contribution = None
            self.status = "learning"
            return
        if module.periodic:  # oscillates around the goal, if any
            out = module.step(self.dt, goal if goal is not None else module._no_centre)
        else:  # goal-directed: restarts from where it is when the goal changes
            here = feedback
            if goal is None:
                goal = self._goal if self._goal is not None else (here if here is not None else module.hold())
            if goal is not self._goal:
                if self._goal is None:
                    module.reset(here if here is not None else module.position(), goal)
                elif self.kind == "TrackingController":  # a moving reference: follow it, keep the motion
                    module.retarget(goal)
                elif not np.array_equal(goal, self._goal):  # a new goal: a new movement from here
                    module.reset(here if here is not None else module.position(), goal)
                self._goal = goal
            out = module.step(self.dt, goal)
        self.contribution = self.output.function(out) if self.output.function is not None else out
        if module.state == "onlineLearning":
            module.recording.append((feedback if feedback is not None else out).copy())
            module.record_dt = self.dt
        self.judge(goal if goal is not None else out, feedback if feedback is not None else out)

    def judge(self, goal: Vector, measured: Vector) -> None:
        """Evaluate the criterion (a periodic module's by its phase locking, not its goal)."""
        if self.criterion is None:
            self.status = "running"
            return
        tolerance = self.criterion.tolerance
        if self.module.periodic:
            self.error = self.module.phase_error()
        else:
            gap = goal - measured
            self.error = math.sqrt(float(gap @ gap))
        within = self.error <= tolerance
        if within and self.sequence and self.via < len(self.sequence) - 1:
            self.via += 1
            within = False
        if self.criterion.type == "convergence":
            self.status = "converged" if within else "ongoing"
        else:
            self.status = "tracking" if within else "ongoing"


# ---------------------------------------------------------------------------- assembly
@dataclass
class Assembly:
    """The built architecture: space values, components in stepping order, free mappings."""

    values: dict[str, Vector]
    spaces: dict[str, Space]
    components: list[ComponentInstance]
    modules: dict[str, ModuleInstance]
    mappings: list[tuple[str, str, str, Function]]  # (id, from, to, function), in order
    adaptive: dict[str, AdaptiveMappingInstance]
    writers: dict[str, list[ComponentInstance]]
    functions: dict[str, Function]  # every mapping's function by id (kept across changes)
    fresh: list[ComponentInstance]  # components built new, to prime before their first step
    features: set[str]  # the active features it was built for

    def goal_changed(self, space: str) -> None:
        """A space was set from outside: components whose goal depends on it (directly or
        through free mappings) have not yet judged the new goal, so they are `ongoing`."""
        changed, grew = {space}, True
        while grew:
            grew = False
            for _, source, target, _ in self.mappings:
                if source in changed and target not in changed:
                    changed.add(target)
                    grew = True
        for component in self.components:
            if (
                component.goal is not None
                and component.goal.space in changed
                and component.criterion is not None
            ):
                component.status = "ongoing"

    def prime(self) -> None:
        """Start the fresh goal-directed components where their feedback or output is now.

        A component with feedback starts there; the sole writer of its output space (with no
        mapping on the way) starts at the space's value; superposed writers start at zero, so
        their sum starts at the space's value only through what they add.
        """
        values = self.values
        for component in self.fresh:
            if component.module.periodic:
                continue
            start = component.feedback.read(values) if component.feedback is not None else None
            sole = len(self.writers.get(component.output.space, [])) == 1
            if start is None and component.output.function is None and sole:
                start = values[component.output.space]
            if start is not None:
                component.module.reset(start, start)
        self.fresh = []

    def tick(self, count: int) -> None:
        values = self.values
        for component in self.components:
            if not component.running or count % component.divider:
                continue
            component.step(values)
            space = component.output.space
            total = None
            for writer in self.writers[space]:  # superposition: the sum of the latest outputs
                part = writer.contribution
                if part is not None:
                    total = part if total is None else total + part
            if total is not None:
                values[space] = total
        for _, source, target, function in self.mappings:
            values[target] = function(values[source])


def _initial(space: Space) -> Vector:
    return np.asarray(space.initial if space.initial is not None else np.zeros(space.dimension), dtype=float)


def _order(items: Collection[str], depends: Callable[[str], list[str]]) -> list[str]:
    """Kahn's algorithm, document order among equals; items on a cycle keep document order last."""
    remaining = {k: set(depends(k)) & set(items) for k in items}
    ordered: list[str] = []
    while remaining:
        ready = [k for k, deps in remaining.items() if not deps]
        if not ready:
            ordered.extend(remaining)
            break
        for k in ready:
            del remaining[k]
            ordered.append(k)
        for deps in remaining.values():
            deps.difference_update(ready)
    return ordered


def build(
    architecture: Architecture, active: set[str], rate: float, previous: Assembly | None = None
) -> tuple[Assembly, list[Diagnostic]]:
    """Instantiate the active features' elements; warnings about rates come back as diagnostics.

    With `previous` (a reconfiguration), the elements that stay are the same objects, with
    their state (a module's motion, a learner's weights, a space's value); only the elements
    of features that come are new, and `Assembly.fresh` lists the new components, which the
    runtime primes with the space values of the tick the change commits on.
    """
    builder = _Builder(architecture, active, rate, previous)
    builder.make_functions()
    builder.make_components()
    if builder.problems:
        raise BuildError(builder.problems)
    return builder.assemble(), builder.warnings


class _Builder:
    """One build: what it has made so far, and what it found wrong."""

    def __init__(
        self, architecture: Architecture, active: set[str], rate: float, previous: Assembly | None
    ) -> None:
        self.whole = architecture
        self.arch = architecture.elements_of(active)
        self.active, self.rate, self.previous = active, rate, previous
        self.kept_functions = previous.functions if previous is not None else {}
        self.kept_components = {c.id: c for c in previous.components} if previous is not None else {}
        self.problems: list[Diagnostic] = []
        self.warnings: list[Diagnostic] = []
        self.functions: dict[str, Function] = {}
        self.adaptive: dict[str, AdaptiveMappingInstance] = {}
        self.modules: dict[str, ModuleInstance] = {}
        self.components: dict[str, ComponentInstance] = {}

    def need(
        self, user: Mapping | Component, keys: tuple[str, ...], kind: str, used: Space | Mapping | Module
    ) -> bool:
        """Is the element `user` uses active too? If not, a located error says which."""
        if used.feature in self.active:
            return True
        self.problems.append(
            error(
                self.whole.locate("mappings" if isinstance(user, Mapping) else "components", user.id, *keys),
                f"{user.id} of feature {user.feature} needs {kind} {used.id} of feature {used.feature}, which is not active",
                "build.inactive",
                user.feature,
            )
        )
        return False

    def make_functions(self) -> None:
        for element, mapping in self.arch.mappings.items():
            if self.need(mapping, ("from",), "space", mapping.source) and self.need(
                mapping, ("to",), "space", mapping.target
            ):
                kept = self.kept_functions.get(element)
                function = self.functions[element] = kept if kept is not None else make_function(mapping)
                if isinstance(function, AdaptiveMappingInstance):
                    self.adaptive[element] = function

    def make_components(self) -> None:
        for element, spec in self.arch.components.items():
            ok = self.need(spec, ("module",), "module", spec.module)
            ports: dict[PortName, PortInstance | None] = {}
            for name in PORTS:
                port = spec.port(name)
                if port is None:
                    ports[name] = None
                    continue
                ok = self.need(spec, (name, "space"), "space", port.space) and ok
                through = port.through
                if through is not None:
                    ok = self.need(spec, (name, "through"), "mapping", through) and ok
                ports[name] = PortInstance(
                    port.space.id, self.functions.get(through.id) if through is not None else None
                )
            if not ok:
                continue
            if element in self.kept_components:
                self.components[element] = self.kept_components[element]
                self.modules[spec.module.id] = self.kept_components[element].module
                continue
            divider = self.divider(element, spec)
            module = self.modules[spec.module.id] = make_module(spec.module)
            self.check_stability(element, spec, divider)
            output = ports["output"]
            assert output is not None  # required by the schema
            self.components[element] = ComponentInstance(
                element,
                spec.kind,
                spec.feature,
                module,
                output,
                ports["goal"],
                ports["feedback"],
                spec.criterion,
                divider,
                divider / self.rate,
                [np.asarray(p, dtype=float) for p in spec.sequence],
            )

    def divider(self, element: str, spec: Component) -> int:
        """Every how many loop ticks the component steps; a warning when its rate cannot be kept."""
        rate = self.rate
        component_rate = spec.rate if spec.rate is not None else rate
        divider = max(1, round(rate / component_rate))
        if component_rate > rate or abs(rate / divider - component_rate) > 1e-9 * rate:
            self.warnings.append(
                warning(
                    self.whole.locate("components", element, "rate"),
                    f"{element} asks for {component_rate:g} Hz; the loop runs at {rate:g} Hz, so it steps at {rate / divider:g} Hz",
                    "build.rate",
                    spec.feature,
                )
            )
        return divider

    def check_stability(self, element: str, spec: Component, divider: int) -> None:
        """Semi-implicit Euler diverges once alpha * dt / tau >= 2: refuse such a step."""
        self.problems += unstable(self.whole, spec, self.rate, divider)

    def assemble(self) -> Assembly:
        """The built elements, ordered for the tick: components by goal dependency, free mappings by data flow."""
        arch, previous, components, functions = self.arch, self.previous, self.components, self.functions
        for element, module_spec in arch.modules.items():
            if element not in self.modules:
                kept_module = previous.modules.get(element) if previous is not None else None
                self.modules[element] = kept_module if kept_module is not None else make_module(module_spec)
        old = previous.values if previous is not None else {}
        values = {k: old[k] if k in old else _initial(s) for k, s in arch.spaces.items()}
        fresh = [c for k, c in components.items() if k not in self.kept_components]
        writers: dict[str, list[ComponentInstance]] = {}
        for component in components.values():
            writers.setdefault(component.output.space, []).append(component)
        goal_of = {
            k: spec.goal.space.id
            for k, spec in arch.components.items()
            if spec.goal is not None and k in components
        }
        order = _order(components, lambda k: [w.id for w in writers.get(goal_of.get(k, ""), [])])
        on_any_port = {  # of the whole document: a port's mapping never computes on its own
            port.through.id
            for spec in self.whole.components.values()
            for _, port in spec.ports()
            if port.through is not None
        }
        free = {k: m for k, m in arch.mappings.items() if k not in on_any_port and k in functions}
        mapping_order = _order(
            free, lambda k: [j for j, m in free.items() if m.target.id == free[k].source.id]
        )
        return Assembly(
            values,
            arch.spaces,
            [components[k] for k in order],
            self.modules,
            [(k, free[k].source.id, free[k].target.id, functions[k]) for k in mapping_order],
            self.adaptive,
            writers,
            functions,
            fresh,
            set(self.active),
        )


def empty_assembly(features: set[str]) -> Assembly:
    """A robot without an architecture: nothing but its plugins runs."""
    return Assembly({}, {}, [], {}, [], {}, {}, {}, [], features)

"""The elements of a motion architecture as typed, plain data: what architecture.json says.

After "Modeling of Movement Control Architectures based on Motion Primitives using
Domain-Specific Languages": a `Space` is named, typed data; a `Mapping` goes from one space
to another (a mapping between types, a transformation within one, an adaptive mapping that
a learner trains); a `Module` is a motion primitive (dynamical systems, learners, a
lifecycle); a `Component` runs a module with its `Port`s, rate and `Criterion`. Every
element names the feature that brings it.

`read_architecture` (document.py) makes these once, from a document that passed its checks:
elements refer to each other as objects (a component's module, a port's space and mapping),
never by id, and every reference exists. Values are as the document writes them (a number
is not rounded or converted), except that sizes (dimensions, hidden units, basis functions)
are ints even where the document writes 3.0, which JSON Schema's "integer" admits. Where
the document leaves a parameter out, the field holds the default the builder has always
used, or None when leaving it out means something of its own. Nothing here runs: the builder (builder.py) makes running instances of these
(`ModuleInstance`, `ComponentInstance`, ...), and nothing here reads files.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import ClassVar, Literal

Vector = tuple[float, ...]
MappingKind = Literal["mapping", "transformation", "adaptiveMapping"]
ComponentKind = Literal["ReachingController", "TrackingController", "Sequencer", "PatternGenerator"]
LearningState = Literal["executing", "onlineLearning", "offlineLearning"]
PortName = Literal["goal", "feedback", "output"]
PORTS: tuple[PortName, ...] = ("goal", "feedback", "output")


@dataclass(frozen=True)
class Space:
    """Named, typed data shared between components."""

    id: str
    type: str  # the data type: JointAngles, JointVelocities, Pose, Position, Scalar, ...
    dimension: int
    feature: str
    unit: str | None = None  # None: the document gives none
    initial: Vector | None = None  # the value at start; None: zeros


# ------------------------------------------------------------------ what a mapping computes
@dataclass(frozen=True)
class Linear:
    """y = matrix x + offset."""

    type: ClassVar[str] = "linear"
    matrix: tuple[Vector, ...]  # rows
    offset: Vector | None = None  # None: zeros


@dataclass(frozen=True)
class Scale:
    """y = factor * x: one factor, or one per dimension."""

    type: ClassVar[str] = "scale"
    factor: float | Vector


@dataclass(frozen=True)
class PlanarArm:
    """The forward kinematics of a planar arm: joint angles -> the hand's (x, y)."""

    type: ClassVar[str] = "planarArm"
    links: Vector  # link lengths, from the base


@dataclass(frozen=True)
class PlanarArmIK:
    """The inverse kinematics of a planar arm of 2 or 3 links: (x, y) -> joint angles."""

    type: ClassVar[str] = "planarArmIK"
    links: Vector


MappingFunction = Linear | Scale | PlanarArm | PlanarArmIK


@dataclass(frozen=True)
class Learner:
    """What trains an adaptive mapping (ridge or an extreme learning machine), or a module's
    DMPs (ridge regression of their weights)."""

    type: Literal["ridge", "elm"]
    mode: Literal["online", "offline"] | None = None  # None: not said (online)
    hidden: int = 60  # hidden units of an elm


@dataclass(frozen=True)
class Mapping:
    """From one space to another: a `mapping` between types (e.g. kinematics), a
    `transformation` within one (a frame change, a scaling), or an `adaptiveMapping` that
    its learner trains."""

    id: str
    kind: MappingKind
    source: Space  # the document's "from"
    target: Space  # the document's "to"
    feature: str
    # What it computes; None: the identity (a transformation). An adaptive mapping computes
    # with its learner, and this function, if any, is the teacher that gives it samples.
    function: MappingFunction | None = None
    learner: Learner | None = None  # an adaptive mapping's

    @property
    def teacher(self) -> MappingFunction | None:
        """What an adaptive mapping learns from (None for the other kinds)."""
        return self.function if self.kind == "adaptiveMapping" else None


# --------------------------------------------------------------------- dynamical systems
@dataclass(frozen=True)
class Demonstration:
    """A recorded movement a DMP learns from: samples `dt` seconds apart."""

    dt: float
    samples: tuple[Vector, ...]


@dataclass(frozen=True)
class PointAttractorParameters:
    """A goal-directed point attractor: alpha is its stiffness."""

    type: ClassVar[str] = "pointAttractor"
    dimension: int
    alpha: float = 25.0


@dataclass(frozen=True)
class DMPParameters:
    """A dynamic movement primitive, with an optional demonstration to learn from."""

    type: ClassVar[str] = "dmp"
    dimension: int
    alpha: float = 25.0
    basis: int = 30
    duration: float | None = None  # s; None: 1 s, or the demonstration's length
    demonstration: Demonstration | None = None


@dataclass(frozen=True)
class OscillatorParameters:
    """Coupled phase oscillators (a central pattern generator)."""

    type: ClassVar[str] = "oscillators"
    dimension: int
    frequency: float = 1.0  # Hz
    coupling: float = 4.0
    amplitude: float = 1.0
    offsets: Vector | None = None  # the wanted phases (rad); None: zeros
    phases: Vector | None = None  # the start phases; None: 0.3 rad apart


SystemParameters = PointAttractorParameters | DMPParameters | OscillatorParameters


@dataclass(frozen=True)
class Module:
    """An adaptive module: a motion primitive of dynamical systems side by side, the
    learners that adapt them, and the lifecycle state it starts in."""

    id: str
    systems: tuple[SystemParameters, ...]
    feature: str
    learners: tuple[Learner, ...] = ()
    state: LearningState = "executing"


# ---------------------------------------------------------------------------- components
@dataclass(frozen=True)
class Port:
    """A component's connection to a space, optionally through a mapping or transformation."""

    space: Space
    through: Mapping | None = None


@dataclass(frozen=True)
class Criterion:
    """When a component reports `converged` (convergence) or `tracking` (tracking) rather than
    `ongoing`: its error within the tolerance."""

    type: Literal["convergence", "tracking"]
    tolerance: float


@dataclass(frozen=True)
class Component:
    """An adaptive component: a module with its wiring, control logic and rate."""

    id: str
    kind: ComponentKind
    module: Module
    output: Port
    feature: str
    goal: Port | None = None
    feedback: Port | None = None
    rate: float | None = None  # Hz; None: the loop's rate
    criterion: Criterion | None = None
    sequence: tuple[Vector, ...] = ()  # a Sequencer's via points, in order

    def ports(self) -> Iterator[tuple[PortName, Port]]:
        """The ports it has, goal, feedback, output."""
        for name in PORTS:
            port = self.port(name)
            if port is not None:
                yield name, port

    def port(self, name: PortName) -> Port | None:
        return self.goal if name == "goal" else self.feedback if name == "feedback" else self.output


Element = Space | Mapping | Module | Component

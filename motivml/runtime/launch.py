"""Launching a robot: variant -> start state -> motion architecture -> runnable assembly.

`launch(folder, variant)` reads the robot folder's model and variant, resolves the variant
(`configure.resolve`, so a partial variant is completed the way `configure` would), computes
the active set at start (reference.md section 4: every Early feature, plus the fewest Late
ones the model needs), reads `architecture.json` and builds the elements of exactly the
active features. Every failure is a typed, located error: an invalid variant is explained
as `validate` explains it (exit 1), a robot without an architecture is an environment
problem (exit 3).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..architecture.builder import Assembly, build, empty_assembly
from ..architecture.document import Architecture, read_architecture
from ..binding.resolve import Variant, resolve, start_state
from ..coordination.document import Coordination, VariantBindings, read_coordination
from ..documents.robot_folder import ARCHITECTURE_FILE, Plugin, RobotFolder, optional_document
from ..documents.schema import read_checked
from ..errors import Diagnostic, DocumentError, EnvironmentProblem, Location, Severity, error
from ..language.model import Configuration, FeatureModel
from ..language.reader import load_configuration, load_model
from ..plugins.manifests import discover
from .binder import Binder, unimplemented_feature
from .coordinator import Coordinator
from .loop import Runtime


@dataclass
class Robot:
    folder: RobotFolder
    variant: Variant
    active: list[str]  # feature ids at start, definition order
    architecture: Architecture | None
    runtime: Runtime
    binder: Binder
    warnings: list[Diagnostic]
    coordination: Coordination | None = None
    coordinator: Coordinator | None = None

    def coordinate(self, simulated: bool) -> Coordinator | None:
        """Start the coordination statechart beside the loop (None without coordination.json)."""
        if self.coordination is None:
            return None
        self.coordinator = Coordinator(self.coordination, self.runtime, self.binder, simulated)
        self.runtime.after_each_tick(self.coordinator.step)
        return self.coordinator

    @property
    def assembly(self) -> Assembly:
        """The architecture running now (a reconfiguration replaces it)."""
        return self.runtime.assembly

    def close(self) -> None:
        """Stop the plugins and the binder's thread."""
        self.binder.close()


def _errors(diagnostics: list[Diagnostic]) -> list[Diagnostic]:
    return [d for d in diagnostics if d.severity is Severity.ERROR]


@dataclass
class Loaded:
    """A robot folder read and checked: its model, and a variant with its start state."""

    folder: RobotFolder
    model: FeatureModel
    variant: Variant | None
    active: list[str] | None  # the start state's feature ids, definition order
    architecture: Architecture | None
    config: Configuration | None = None  # the variant's document


def read_robot_architecture(folder: RobotFolder, model: FeatureModel, required: bool) -> Architecture | None:
    path = folder.architecture_path
    if optional_document(path) is None:
        if not required:
            return None
        raise EnvironmentProblem(
            error(
                Location(str(path)),
                f"no {ARCHITECTURE_FILE}: this robot has no motion architecture to run",
                "io",
            )
        )
    doc, problems = read_checked(path, lambda d: [])
    if doc is None:
        raise DocumentError(problems)
    architecture, problems = read_architecture(doc, model)
    if architecture is None:
        raise DocumentError(problems)
    return architecture


def load(
    target: str | Path,
    variant_name: str | None,
    prefer: tuple[str, ...] = (),
    need_architecture: bool = False,
    config_path: str | Path | None = None,
) -> Loaded:
    """Read a robot folder: the model, the variant resolved with its start state, the architecture.

    The variant is `variants/<variant_name>.json`, or the configuration document at
    `config_path` (one of them, or neither for the model alone).
    """
    if variant_name is not None and config_path is not None:
        raise ValueError("a variant name or a configuration path, not both")
    folder = RobotFolder.open(target)
    model, diagnostics = load_model(folder.model_path)
    if model is None:
        raise DocumentError(_errors(diagnostics))
    variant, active, config = None, None, None
    path = Path(config_path) if config_path is not None else None
    if variant_name is not None:
        path = folder.variant_path(variant_name)
    if path is not None:
        config, diagnostics = load_configuration(path, model, partial=True)
        if config is None:
            raise DocumentError(_errors(diagnostics))
        variant = resolve(model, config, prefer)
        active = [f.id for f in start_state(variant)]
    architecture = read_robot_architecture(folder, model, need_architecture)
    return Loaded(folder, model, variant, active, architecture, config)


def launch(
    target: str | Path,
    variant_name: str | None,
    rate: float = 1000.0,
    prefer: tuple[str, ...] = (),
    strict: bool = False,
    ros_namespace: str = "/",
    config_path: str | Path | None = None,
) -> Robot:
    """Build a variant's start state into a runtime at `rate` Hz, its plugins started.

    The variant is `variants/<variant_name>.json` or the configuration document at
    `config_path`, one of them. The robot folder needs an architecture.json, plugins (robot.json), or both; the
    start state's architecture elements are built and its features' plugins started (all
    or none: a plugin that fails to start stops the others and raises PluginError).
    An active Dynamic feature that nothing implements (no plugin, no architecture element,
    not abstract) is warned about, or with `strict` refused (DocumentError). Relative node
    names of ros2_lifecycle plugins are resolved against `ros_namespace`.
    """
    if variant_name is None and config_path is None:
        raise ValueError("a variant name or a configuration path")
    loaded = load(target, variant_name, prefer, config_path=config_path)
    assert loaded.variant is not None and loaded.active is not None
    plugins, problems = discover(loaded.folder, loaded.model)
    if _errors(problems):
        raise DocumentError(_errors(problems))
    if loaded.architecture is None and not plugins:
        path = loaded.folder.architecture_path
        raise EnvironmentProblem(
            error(
                Location(str(path)),
                f"no {ARCHITECTURE_FILE} and no plugins: this robot has nothing to run",
                "io",
            )
        )
    missing = unimplemented(loaded.variant, plugins, loaded.architecture)
    severity = Severity.ERROR if strict else Severity.WARNING
    absent = [unimplemented_feature(loaded.model, f, "is", severity) for f in loaded.active if f in missing]
    if strict and absent:
        raise DocumentError(absent)
    if loaded.architecture is not None:
        assembly, warnings = build(loaded.architecture, set(loaded.active), rate)
    else:
        assembly, warnings = empty_assembly(set(loaded.active)), []
    warnings = absent + warnings
    runtime = Runtime(assembly, rate)
    binder = Binder(
        runtime,
        loaded.variant,
        loaded.architecture,
        plugins,
        loaded.active,
        loaded.config,
        loaded.folder.name,
        unimplemented=missing,
        strict=strict,
        ros_namespace=ros_namespace,
    )
    coordination = read_robot_coordination(loaded.folder, loaded.model, loaded.architecture, loaded.variant)
    try:
        binder.start()
    except BaseException:
        binder.close()  # its thread, and a ROS graph a lifecycle plugin opened
        raise
    return Robot(
        loaded.folder,
        loaded.variant,
        loaded.active,
        loaded.architecture,
        runtime,
        binder,
        warnings,
        coordination,
    )


def unimplemented(
    variant: Variant, plugins: dict[str, Plugin], architecture: Architecture | None
) -> frozenset[str]:
    """Selected Dynamic features, not abstract, that neither a plugin nor an architecture element implements."""
    brought = {e.feature for e in architecture.elements()} if architecture is not None else set()
    return frozenset(
        d.feature.id
        for d in variant.selected()
        if not d.binding.static
        and not d.feature.abstract
        and d.feature.id not in plugins
        and d.feature.id not in brought
    )


def read_robot_coordination(
    folder: RobotFolder, model: FeatureModel, architecture: Architecture | None, variant: Variant | None
) -> Coordination | None:
    """The robot's coordination.json, checked against the model, architecture and variant."""
    path = folder.coordination_path
    if optional_document(path) is None:
        return None
    doc, problems = read_checked(path, lambda d: [])
    if doc is None:
        raise DocumentError(problems)
    bindings = None
    if variant is not None:
        bindings = VariantBindings(variant.name, {d.feature.id: d.binding for d in variant.selected()})
    coordination, problems = read_coordination(doc, model, architecture, bindings)
    if coordination is None:
        raise DocumentError(_errors(problems))
    return coordination

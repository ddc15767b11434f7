"""Launching a robot: variant -> start state -> motion architecture -> runnable assembly.

`launch(folder, variant)` reads the robot folder's model and variant, resolves the variant
(`configure.resolve`, so a partial variant is completed the way `configure` would), computes
the active set at start (semantics.md section 4: every Early feature, plus the fewest Late
ones the model needs), reads `architecture.json` and builds the elements of exactly the
active features. Every failure is a typed, located error: an invalid variant is explained
as `validate` explains it (exit 1), a robot without an architecture is an environment
problem (exit 3).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .architecture import Architecture, read_architecture
from .builder import Assembly, build
from .check import load_configuration, load_model
from .configure import Variant, resolve, start_state
from .errors import Diagnostic, DocumentError, EnvironmentProblem, Location, Severity, error
from .robot import RobotFolder
from .runtime import Runtime
from .schema import read_checked

ARCHITECTURE_FILE = "architecture.json"


@dataclass
class Robot:
    folder: RobotFolder
    variant: Variant
    active: list[str]  # feature ids, definition order
    architecture: Architecture
    assembly: Assembly
    runtime: Runtime
    warnings: list[Diagnostic]


def _errors(diagnostics: list[Diagnostic]) -> list[Diagnostic]:
    return [d for d in diagnostics if d.severity is Severity.ERROR]


def read_robot_architecture(folder: RobotFolder, variant: Variant) -> Architecture:
    path = folder.path / ARCHITECTURE_FILE
    if not path.is_file():
        raise EnvironmentProblem(
            error(Location(str(path)), "no architecture.json: this robot has no motion architecture to run", "io")
        )
    doc, problems = read_checked(path, lambda d: [])
    if doc is None:
        raise DocumentError(problems)
    architecture, problems = read_architecture(doc, variant.model)
    if architecture is None:
        raise DocumentError(problems)
    return architecture


def launch(target: str | Path, variant_name: str, rate: float = 1000.0, prefer: tuple[str, ...] = ()) -> Robot:
    folder = RobotFolder.open(target)
    model, diagnostics = load_model(folder.model_path)
    if model is None:
        raise DocumentError(_errors(diagnostics))
    config, diagnostics = load_configuration(folder.variant_path(variant_name), model, partial=True)
    if config is None:
        raise DocumentError(_errors(diagnostics))
    variant = resolve(model, config, prefer)
    active = [f.id for f in start_state(variant)]
    architecture = read_robot_architecture(folder, variant)
    assembly, warnings = build(architecture, set(active), rate)
    return Robot(folder, variant, active, architecture, assembly, Runtime(assembly, rate), warnings)

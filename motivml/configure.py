"""Configuring a variant: the pipeline behind `motivml configure`.

The configuration is read and checked against the model (`validate`, without a solve:
resolving solves it, and explains it as `validate` would when it has no valid completion),
resolved (the solver decides what it leaves open, reference.md sections 3 and 4), the robot
folder's plugin manifests are read, and the generated files are written, all of them or
none. The CLI parses, calls `configure`, and prints what it returns.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .binding.resolve import Variant
from .documents.robot_folder import Plugin, RobotFolder
from .errors import Diagnostic

# What else motivml puts in a variant's build folder: a run's control socket folder, and
# graph's pictures. A real folder holding only these is configure's to take over.
BESIDE_OUTPUTS = frozenset(
    {"run", *(f"{name}.{fmt}" for name in ("feature-model", "architecture") for fmt in ("dot", "svg", "graphml"))}
)


@dataclass
class Configured:
    """A variant configured: what was resolved and what was written where."""

    variant: Variant
    folder: Path  # where the generated files are
    written: dict[str, bool]  # file name -> whether its content changed
    missing: list[Diagnostic]  # warnings: Late or Dynamic features without a plugin
    decisions: Path | None = None  # the decisions file written beside, if asked for


class NotConfigured(Exception):
    """Nothing was written: the configuration (or the model) or the plugin manifests have
    errors; `what` names them for the verdict line."""

    def __init__(self, diagnostics: list[Diagnostic], what: str) -> None:
        super().__init__(what)
        self.diagnostics = diagnostics
        self.what = what


def configure(
    robot: RobotFolder,
    config_path: Path,
    output: Path,
    prefer: Sequence[str] = (),
    prefix: str = "MOTIVML_",
    save_decisions: Path | None = None,
) -> Configured:
    """Resolve the configuration at `config_path` against the robot's model and write its
    generated files into `output` (and, with `save_decisions`, the smallest decisions file
    that resolves to the same variant). Raises NotConfigured, having written nothing, when
    the documents have errors; MotivmlError when the output cannot be written."""
    from .binding.codegen import late_or_dynamic, outputs
    from .binding.resolve import NoVariant, resolve
    from .documents.writing import write_generation
    from .plugins.manifests import discover, missing
    from .validate import validate

    result = validate(robot.model_path, [config_path], partial=True, analyse=False, solve=False)
    model, configuration = result.last.model, result.last.config
    if not result.valid or model is None or configuration is None:
        raise NotConfigured(result.errors, result.last.file)
    try:
        variant = resolve(model, configuration, prefer)
    except NoVariant as exc:
        raise NotConfigured(exc.diagnostics, result.last.file) from None
    plugins: dict[str, Plugin]
    plugins, problems = discover(robot, model)
    if problems:
        raise NotConfigured(problems, "plugin manifests")
    written = write_generation(output, outputs(variant, prefix, plugins, robot.path), BESIDE_OUTPUTS)
    configured = Configured(variant, output, written, missing(model, late_or_dynamic(variant), plugins))
    if save_decisions is not None:
        from .binding.configurator import decisions_text
        from .binding.resolve import decisions
        from .documents.writing import write_if_changed

        write_if_changed(save_decisions.parent, {save_decisions.name: decisions_text(decisions(variant, prefer))})
        configured.decisions = save_decisions
    return configured

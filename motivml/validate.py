"""Checking a robot's documents: the pipeline behind `motivml validate`.

document -> schema -> model objects -> SAT, for the model, each configuration, the
architecture and the coordination. Each stage reports every problem it finds; a stage runs
only when the one before left something sound to work on. Semantics are decided by the
encoding alone (`binding.check`); this module only decides what is checked against what.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING

from .binding.check import analyse_model, check_variant
from .documents.robot_folder import ARCHITECTURE_FILE, RobotFolder, optional_document
from .documents.schema import read_checked
from .errors import Diagnostic, Judged, Severity, error
from .language.model import Configuration, FeatureModel
from .language.reader import load_configuration, load_model

# The architecture, coordination and plugin checks import what they need when a robot has
# those documents: validating a model or a variant costs only the checking pipeline.
if TYPE_CHECKING:
    from .architecture.document import Architecture


class DocumentKind(StrEnum):
    """What a report is about (its verdict line says "in the model", "in the configuration" ...)."""

    MODEL = "model"
    CONFIGURATION = "configuration"
    ARCHITECTURE = "architecture"
    COORDINATION = "coordination"
    PLUGINS = "plugins"
    FLEET = "fleet file"
    ROBOT = "robot's configuration"  # (a robot of a fleet file: its variant with the fleet's overrides)


@dataclass
class Report(Judged):
    """What a check found in one document, errors first (each group best first)."""

    file: str
    kind: DocumentKind
    diagnostics: list[Diagnostic] = field(default_factory=list)
    model: FeatureModel | None = None
    config: Configuration | None = None
    analysed: bool = False  # model analyses (dead features, bindings) ran
    open_bindings: int = 0  # selected features whose binding the configuration leaves open
    open_features: int = 0  # features without an entry (a partial configuration, a decisions file)


@dataclass
class Validation:
    """What `validate` checked: the model's report, then one per document checked against the
    model (none when the model could not be read: nothing else was checked)."""

    model: Report
    configurations: list[Report] = field(default_factory=list)
    architecture: Report | None = None
    coordination: Report | None = None
    plugins: Report | None = None

    @property
    def reports(self) -> list[Report]:
        """Every report, in the order they are shown: the model's, the configurations', the
        architecture's, the coordination's, the plugins'."""
        others = [r for r in (self.architecture, self.coordination, self.plugins) if r is not None]
        return [self.model, *self.configurations, *others]

    @property
    def checked(self) -> bool:
        """Whether everything asked was checked (the model was read, so were the others)."""
        return self.model.model is not None

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for r in self.reports for d in r.errors]

    @property
    def valid(self) -> bool:
        """Everything asked was checked, and nothing has an error."""
        return self.checked and all(r.valid for r in self.reports)

    @property
    def last(self) -> Report:
        """The last report (a configuration's, or the model's if it stopped there)."""
        return self.reports[-1]


def validate_model(model_path: str | Path, analyse: bool = True) -> Report:
    """Check a model file: syntax, consistency, and (with `analyse`) its variants' space."""
    report = Report(str(model_path), DocumentKind.MODEL)
    model, diagnostics = load_model(model_path)
    report.diagnostics += diagnostics
    report.model = model
    if model is not None and analyse:
        report.diagnostics += analyse_model(model)
        report.analysed = True
    return _sorted(report)


def validate_configuration(
    model: FeatureModel, config_path: str | Path, partial: bool = False, solve: bool = True
) -> Report:
    """Check a configuration file against a (sound) model; without `solve`, only what can be
    checked without a solver (for a caller that solves it next, as `configure` does)."""
    report = Report(str(config_path), DocumentKind.CONFIGURATION, model=model)
    config, diagnostics = load_configuration(config_path, model, partial)
    report.diagnostics += diagnostics
    report.config = config
    if config is not None:
        if solve:
            report.diagnostics += check_variant(model, config)
        report.open_features = sum(1 for f in model.features[1:] if f.id not in config.entries)
        report.open_bindings = sum(
            1
            for e in config.entries.values()
            if e.selected and (e.time is None or e.mode is None) and e.id != model.root.id
        )
    return _sorted(report)


def validate_architecture(model: FeatureModel, path: str | Path) -> Report:
    """Check an architecture document against its schema and the model, and every component's
    integration at the default loop rate (what a build at `run`'s default rate would refuse)."""
    from .architecture.document import read_architecture
    from .architecture.family import architecture_bindings
    from .architecture.stability import stability

    report = Report(str(path), DocumentKind.ARCHITECTURE, model=model)
    doc, problems = read_checked(path, lambda d: [])
    report.diagnostics += problems
    if doc is not None:
        architecture, problems = read_architecture(doc, model)
        report.diagnostics += problems
        if architecture is not None:
            report.diagnostics += architecture_bindings(model, architecture)
            report.diagnostics += stability(architecture)
    return _sorted(report)


def validate(
    model_path: str | Path,
    config_paths: Sequence[str | Path] = (),
    partial: bool = False,
    analyse: bool = True,
    architecture_path: str | Path | None = None,
    coordination_path: str | Path | None = None,
    robot: RobotFolder | None = None,
    solve: bool = True,
) -> Validation:
    """The model's report, one per configuration, the architecture's, the coordination's, and
    with `robot` (a folder with robot.json) the plugin manifests'.

    The model is read once; the other documents are checked only against a sound model.
    Without `solve`, the configurations are read and checked but not solved.
    """
    result = Validation(validate_model(model_path, analyse))
    model = result.model.model
    if model is None:
        return result
    result.configurations = [validate_configuration(model, c, partial, solve) for c in config_paths]
    architecture = None
    if architecture_path is not None:
        result.architecture = validate_architecture(model, architecture_path)
        if result.architecture.valid:
            from .architecture.document import read_architecture

            doc, _ = read_checked(architecture_path, lambda d: [])
            architecture = read_architecture(doc, model)[0] if doc is not None else None
    if coordination_path is not None:
        variants = [r.config for r in result.configurations if r.valid and r.config is not None]
        result.coordination = validate_coordination(model, coordination_path, architecture, variants)
    if robot is not None and optional_document(robot.settings_path) is not None:
        result.plugins = validate_plugins(robot, model)
    return result


def validate_plugins(robot: RobotFolder, model: FeatureModel) -> Report:
    """robot.json and the manifests of the plugin directories it declares, against the model."""
    from .plugins.manifests import discover
    from .plugins.registry import KINDS

    report = Report(str(robot.settings_path), DocumentKind.PLUGINS, model=model)
    plugins, problems = discover(robot, model)
    report.diagnostics += problems
    for plugin in plugins.values():  # what a run would stop on when it loads one (issue 31)
        report.diagnostics += KINDS[plugin.kind].inspect(plugin)
    return _sorted(report)


def validate_coordination(
    model: FeatureModel, path: str | Path, architecture: Architecture | None, configs: Sequence[Configuration]
) -> Report:
    """Check coordination.json against the model and architecture, and each valid variant's features."""
    from .binding.resolve import resolve
    from .coordination.document import VariantBindings, read_coordination

    report = Report(str(path), DocumentKind.COORDINATION, model=model)
    doc, problems = read_checked(path, lambda d: [])
    report.diagnostics += problems
    if doc is None:
        return report
    architecture_invalid = architecture is None and (Path(path).parent / ARCHITECTURE_FILE).is_file()
    coordination, found = read_coordination(
        doc, model, architecture, architecture_invalid=architecture_invalid
    )
    if architecture_invalid:
        found.append(
            error(
                doc.locate(()),
                f"{ARCHITECTURE_FILE} is invalid (see its errors): the coordination's elements are not checked",
                "coordination.architecture",
            )
        )
    report.diagnostics += found
    if coordination is not None:
        seen = {(d.location.steps, d.message) for d in report.diagnostics}
        for config in configs:
            variant = resolve(model, config)
            bindings = VariantBindings(config.name, {d.feature.id: d.binding for d in variant.selected()})
            for d in read_coordination(doc, model, architecture, bindings)[1]:
                if (d.location.steps, d.message) not in seen:
                    seen.add((d.location.steps, d.message))
                    report.diagnostics.append(d)
    return _sorted(report)


def _sorted(report: Report) -> Report:
    """Errors before warnings; within each, the order of discovery (best first)."""
    report.diagnostics.sort(key=lambda d: d.severity is not Severity.ERROR)
    return report

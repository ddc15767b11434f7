"""Checking models and configurations: the pipeline behind `motivml validate` and `show`.

document -> schema -> model objects -> SAT. Each stage reports every problem it finds; a
stage runs only when the one before left something sound to work on. Semantics are
decided by the encoding alone (no second, hand-written rule checker): a configuration is
valid iff the solver finds a variant under its facts; when it does not, the minimal
conflicts are explained.

Analyses of a model alone (dead features, bindings a feature allows but can never take)
need many solves, so they run when a model is validated without a configuration; a
variant check reports only what concerns the variant (and a void model).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from .architecture.document import Architecture, read_architecture, references
from .binding import encoding as enc
from .binding.explain import Explainer
from .coordination.document import VariantBindings, read_coordination
from .documents.loader import no_gc
from .documents.schema import check_configuration, check_feature_model, read_checked
from .errors import Diagnostic, Location, Severity, error, warning
from .language.model import Configuration, Feature, FeatureModel
from .language.reader import read_configuration, read_model

EXPLAINED_WARNINGS = 20  # per kind: dead features and bindings explained one by one
LISTED_WARNINGS = 100  # per kind: located one by one; the rest are summed up in one warning


@dataclass
class Report:
    """What a check found in one document, errors first (each group best first)."""

    file: str
    kind: str  # "model" or "configuration"
    diagnostics: list[Diagnostic] = field(default_factory=list)
    model: FeatureModel | None = None
    config: Configuration | None = None
    analysed: bool = False  # model analyses (dead features, bindings) ran
    open_bindings: int = 0  # selected features whose binding the configuration leaves open

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.severity is Severity.ERROR]

    @property
    def warnings(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.severity is Severity.WARNING]

    @property
    def valid(self) -> bool:
        return not self.errors


def _usable(diagnostics: list[Diagnostic]) -> bool:
    return not any(d.severity is Severity.ERROR for d in diagnostics)


def load_model(path: str | Path) -> tuple[FeatureModel | None, list[Diagnostic]]:
    """Read a feature model file; None when it cannot be used (the diagnostics say why)."""
    doc, problems = read_checked(path, check_feature_model)
    if doc is None:
        return None, problems
    with no_gc():
        model, diagnostics = read_model(doc)
    return (model if _usable(diagnostics) else None), diagnostics


def load_configuration(
    path: str | Path, model: FeatureModel, partial: bool = False
) -> tuple[Configuration | None, list[Diagnostic]]:
    """Read a configuration of `model`; None when it cannot be used (the diagnostics say why)."""
    doc, problems = read_checked(path, check_configuration)
    if doc is None:
        return None, problems
    with no_gc():
        config, diagnostics = read_configuration(doc, model, partial)
    config.name = Path(path).stem
    return (config if _usable(diagnostics) else None), diagnostics


def validate_model(model_path: str | Path, analyse: bool = True) -> Report:
    """Check a model file: syntax, consistency, and (with `analyse`) its variants' space."""
    report = Report(str(model_path), "model")
    model, diagnostics = load_model(model_path)
    report.diagnostics += diagnostics
    report.model = model
    if model is not None and analyse:
        report.diagnostics += analyse_model(model)
        report.analysed = True
    return _sorted(report)


def validate_configuration(model: FeatureModel, config_path: str | Path, partial: bool = False) -> Report:
    """Check a configuration file against a (sound) model."""
    report = Report(str(config_path), "configuration", model=model)
    config, diagnostics = load_configuration(config_path, model, partial)
    report.diagnostics += diagnostics
    report.config = config
    if config is not None:
        report.diagnostics += check_variant(model, config)
        report.open_bindings = sum(
            1
            for e in config.entries.values()
            if e.selected and (e.time == "Any" or e.mode == "Any") and e.id != model.root.id
        )
    return _sorted(report)


def validate_architecture(model: FeatureModel, path: str | Path) -> Report:
    """Check an architecture document against its schema and the model."""
    report = Report(str(path), "architecture", model=model)
    doc, problems = read_checked(path, lambda d: [])
    report.diagnostics += problems
    if doc is not None:
        architecture, problems = read_architecture(doc, model)
        report.diagnostics += problems
        if architecture is not None:
            report.diagnostics += architecture_bindings(model, architecture)
    return _sorted(report)


def architecture_bindings(model: FeatureModel, architecture: Architecture) -> list[Diagnostic]:
    """Every element an active element uses is active too, in every variant of the model.

    A family-wide check on the one encoding: for each pair of features (user, used) that
    an architecture reference joins, is there an active set (section 2 over a(f), every
    selected Early feature active) with the user active and the used one not? Then some
    variant cannot be built, and each reference of that pair is an error.
    """
    pairs: dict[tuple[str, str], list[Diagnostic]] = {}
    for ref in references(architecture):
        if ref.user_feature == ref.target_feature:
            continue
        message = (
            f"{ref.element} (feature {ref.user_feature}) uses {ref.kind.removesuffix('s')} {ref.target} of feature "
            f"{ref.target_feature}, but the model lets {ref.target_feature} be inactive while {ref.user_feature} "
            f"is active: bring both with one feature, or make {ref.user_feature} include {ref.target_feature}"
        )
        where = architecture.locate(ref.section, ref.element, *ref.keys)
        pairs.setdefault((ref.user_feature, ref.target_feature), []).append(
            error(where, message, "architecture.binding", ref.user_feature)
        )
    found: list[Diagnostic] = []
    if not pairs:
        return found
    with no_gc(), enc.Encoding(model) as encoding:
        for (user, used), diagnostics in pairs.items():
            i, j = model.index[user], model.index[used]
            if encoding.solve(with_config=False, extra=[encoding.a(i), -encoding.a(j)]):
                found += diagnostics
    return found


def validate(
    model_path: str | Path,
    config_paths: Sequence[str | Path] = (),
    partial: bool = False,
    analyse: bool = True,
    architecture_path: str | Path | None = None,
    coordination_path: str | Path | None = None,
) -> list[Report]:
    """The model's report, one per configuration, the architecture's and the coordination's.

    The model is read once; the other documents are checked only against a sound model.
    """
    model_report = validate_model(model_path, analyse)
    reports = [model_report]
    if model_report.model is not None:
        model = model_report.model
        reports += [validate_configuration(model, c, partial) for c in config_paths]
        architecture = None
        if architecture_path is not None:
            reports.append(validate_architecture(model, architecture_path))
            if reports[-1].valid:
                doc, _ = read_checked(architecture_path, lambda d: [])
                architecture = read_architecture(doc, model)[0] if doc is not None else None
        if coordination_path is not None:
            variants = [
                r.config for r in reports[1 : 1 + len(config_paths)] if r.valid and r.config is not None
            ]
            reports.append(validate_coordination(model, coordination_path, architecture, variants))
    return reports


def validate_coordination(
    model: FeatureModel, path: str | Path, architecture: Architecture | None, configs: Sequence[Configuration]
) -> Report:
    """Check coordination.json against the model and architecture, and each valid variant's features."""
    report = Report(str(path), "coordination", model=model)
    doc, problems = read_checked(path, lambda d: [])
    report.diagnostics += problems
    if doc is None:
        return report
    coordination, found = read_coordination(doc, model, architecture)
    if architecture is None and (path_of_architecture := Path(path).parent / "architecture.json").is_file():
        found = [d for d in found if "the robot has no architecture.json" not in d.message]
        found.append(
            error(
                doc.locate(()),
                f"{path_of_architecture.name} is invalid (see its errors): the coordination's elements are not checked",
                "coordination.architecture",
            )
        )
    report.diagnostics += found
    if coordination is not None:
        from .binding.resolve import resolve  # configure builds on check: resolve only here, at need

        seen = {(d.location.path, d.message) for d in report.diagnostics}
        for config in configs:
            variant = resolve(model, config)
            bindings = VariantBindings(config.name, {d.feature.id: d.binding for d in variant.selected()})
            for d in read_coordination(doc, model, architecture, bindings)[1]:
                if (d.location.path, d.message) not in seen:
                    seen.add((d.location.path, d.message))
                    report.diagnostics.append(d)
    return _sorted(report)


def _sorted(report: Report) -> Report:
    """Errors before warnings; within each, the order of discovery (best first)."""
    report.diagnostics.sort(key=lambda d: d.severity is not Severity.ERROR)
    return report


def check_variant(model: FeatureModel, config: Configuration) -> list[Diagnostic]:
    """Errors of a configuration: every independent minimal conflict, explained."""
    with no_gc():
        with enc.Encoding(model) as hard:
            hard.set_configuration(config)
            if hard.solve():
                return []
        with enc.Encoding(model, explain=True) as encoding:
            encoding.set_configuration(config)
            explainer = Explainer(encoding, model, config)
            if not encoding.solve(with_config=False):
                return _void(encoding, explainer)
            return [explainer.diagnostic(mus) for mus in encoding.conflicts()]


def _void(encoding: enc.Encoding, explainer: Explainer) -> list[Diagnostic]:
    return [
        explainer.diagnostic(mus, prefix="the model has no valid variant: ")
        for mus in encoding.conflicts(with_config=False)
    ]


def analyse_model(model: FeatureModel) -> list[Diagnostic]:
    """A void model (error); dead features and never-possible bindings (warnings)."""
    with no_gc(), enc.Encoding(model) as hard:
        if not hard.solve(with_config=False):
            with enc.Encoding(model, explain=True) as encoding:
                return _void(encoding, Explainer(encoding, model, None))
        features = model.features
        n = len(features)
        alive = hard.cover(
            [[hard.s(i)] for i in range(n)], with_config=False, hints=[[hard.s(i) for i in range(n)]]
        )
        targets: list[list[int]] = []
        owners: list[tuple[int, str, str]] = []  # (feature, aspect, value)
        for f in features:
            if not alive[f.index]:
                continue
            i = f.index
            if f.time_allowed == "Any":
                targets += [[hard.s(i), hard.E(i)], [hard.s(i), -hard.E(i)]]
                owners += [(i, "time", "Early"), (i, "time", "Late")]
            if f.mode_allowed == "Any":
                targets += [[hard.s(i), hard.S(i)], [hard.s(i), -hard.S(i)]]
                owners += [(i, "mode", "Static"), (i, "mode", "Dynamic")]
        hints = [
            [lit for i in range(n) for lit in (hard.s(i), e * hard.E(i), m * hard.S(i))]
            for e in (1, -1)
            for m in (1, -1)
        ]
        possible = hard.cover(targets, with_config=False, hints=hints)

    dead = [f for f in features if not alive[f.index] and (f.parent is None or alive[f.parent])]
    impossible = [owners[k] for k in range(len(targets)) if not possible[k]]
    if not dead and not impossible:
        return []
    found: list[Diagnostic] = []
    with no_gc(), enc.Encoding(model, explain=True) as encoding:
        explainer = Explainer(encoding, model, None)
        for count, f in enumerate(dead):
            below = len(model.subtree(f.index)) - 1
            extra = f" (and so are its {below} sub-features)" if below else ""
            head = f"{f.id} is dead: no valid variant selects it{extra}"
            if count >= LISTED_WARNINGS:
                found.append(_more(dead[count:], model, "model.dead-feature", "dead features"))
                break
            if count >= EXPLAINED_WARNINGS:
                found.append(
                    warning(explainer.model_location(f.index, "id"), head, "model.dead-feature", f.id)
                )
                continue
            q = encoding.query("query-selected", f.index, encoding.s(f.index))
            explainer.query_words[q] = f"{f.id} would be selected"
            (mus, *_) = encoding.conflicts(with_config=False, limit=1, queries=[q])
            where = explainer.model_location(f.index, "id")
            found.append(_as_warning(explainer.diagnostic(mus), where, head, "model.dead-feature", f.id))
        for count, (i, aspect, value) in enumerate(impossible):
            f = features[i]
            if count >= LISTED_WARNINGS:
                rest = [features[j] for j, _, _ in impossible[count:]]
                found.append(
                    _more(rest, model, "model.impossible-binding", "bindings allowed but never possible")
                )
                break
            other = {"Early": "Late", "Late": "Early", "Static": "Dynamic", "Dynamic": "Static"}[value]
            head = f"{f.id} allows Any binding {aspect} but can never be {value}, only {other}"
            key = "bindingTimeAllowed" if aspect == "time" else "bindingModeAllowed"
            where = explainer.model_location(i, "constraints", key)
            if count >= EXPLAINED_WARNINGS:
                found.append(warning(where, head, "model.impossible-binding", f.id))
                continue
            literal = {
                "Early": encoding.E(i),
                "Late": -encoding.E(i),
                "Static": encoding.S(i),
                "Dynamic": -encoding.S(i),
            }
            q1 = encoding.query("query-selected", i, encoding.s(i))
            q2 = encoding.query("query-binding", i, literal[value])
            explainer.query_words[q1] = f"{f.id} would be selected"
            explainer.query_words[q2] = f"{f.id} would be {value}"
            (mus, *_) = encoding.conflicts(with_config=False, limit=1, queries=[q1, q2])
            found.append(
                _as_warning(explainer.diagnostic(mus), where, head, "model.impossible-binding", f.id)
            )
    return found


def _more(rest: list[Feature], model: FeatureModel, rule: str, what: str) -> Diagnostic:
    """One warning for what is left after LISTED_WARNINGS of a kind."""
    names = ", ".join(dict.fromkeys(f.id for f in rest[:10]))
    location = model.source.locate(model.path(rest[0].index, "id")) if model.source else Location(model.name)
    return warning(location, f"{len(rest)} more {what}, in {names}{', ...' if len(rest) > 10 else ''}", rule)


def _as_warning(explained: Diagnostic, where: Location, head: str, rule: str, feature: str) -> Diagnostic:
    return Diagnostic(
        Severity.WARNING,
        where,
        f"{head}, because {explained.message}",
        rule,
        feature,
        explained.facts,
    )


def binding_states(model: FeatureModel, config: Configuration | None) -> list[set[str]]:
    """Per feature, what valid variants (of the configuration) can make of it.

    Each set holds "off" (not selected) and/or the bindings SE, SL, DE, DL it can take; a
    one-element set is what the solver forces. This is the paper's "binding semantics
    interpreter", answered by `Encoding.cover`.
    """
    with no_gc(), enc.Encoding(model) as hard:
        if config is not None:
            hard.set_configuration(config)
        targets: list[list[int]] = []
        for f in model.features:
            i = f.index
            s, e, st = hard.s(i), hard.E(i), hard.S(i)
            targets += [[-s], [s, e, st], [s, -e, st], [s, e, -st], [s, -e, -st]]
        possible = hard.cover(targets, with_config=config is not None)
    names = ("off", "SE", "SL", "DE", "DL")
    return [{names[j] for j in range(5) if possible[5 * f.index + j]} for f in model.features]

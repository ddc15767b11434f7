"""From schema-valid documents to model objects, with the checks a schema cannot make.

Errors: duplicate feature ids, ids differing only in case (their C++ macros would clash),
includes/excludes of unknown ids or of the feature itself, configuration entries for unknown features or given twice, and (unless partial
configurations are accepted) features without an entry. Warnings: one-member groups,
`isMandatory: true` on a group member, `isSelected` away from the root, props of a
deselected feature. Everything else about meaning is the SAT encoding's job.
"""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import Any

from ..documents.loader import Document
from ..documents.schema import check_configuration, check_feature_model, read_checked_then, read_with_problems
from ..errors import Diagnostic, Severity, error, warning
from ..process import no_gc
from .formula import FormulaError, parse
from .model import ANY, Configuration, Entry, Feature, FeatureModel, Group, GroupKind, Mode, Time

# Tokens the schema admits, to values, and the model's defaults (reference.md section 1).
# Dicts and plain strings: enum calls and member lookups cost ~0.25 us each, and a model
# of 100,000 features takes 200,000 of them.
_TIMES: dict[str, Time | None] = {**{t.value: t for t in Time}, ANY: None}
_MODES: dict[str, Mode | None] = {**{m.value: m for m in Mode}, ANY: None}
_DEFAULT_TIME, _DEFAULT_MODE = Time.EARLY.value, Mode.STATIC.value


class _Suggestions:
    """`(did you mean 'x'?)` for unknown ids, for the first few only.

    difflib compares a word with every known id; over a 30,000-feature model that is a
    quarter of a second per word, so a file full of misspelt ids gets suggestions for its
    first `LIMIT` and plain messages after that.
    """

    LIMIT = 10

    def __init__(self, known: dict[str, int]) -> None:
        self.known = list(known)
        self.left = self.LIMIT

    def __call__(self, word: str) -> str:
        if self.left <= 0:
            return ""
        self.left -= 1
        close = difflib.get_close_matches(word, self.known, n=1, cutoff=0.75)
        return f" (did you mean {close[0]!r}?)" if close else ""


def read_model(doc: Document) -> tuple[FeatureModel, list[Diagnostic]]:
    """Build the feature model of a schema-valid document (iterative pre-order walk)."""
    diagnostics: list[Diagnostic] = []
    features: list[Feature] = []
    index: dict[str, int] = {}
    folded: dict[str, int] = {}  # upper-cased id -> first feature with it (C++ macro names)
    nodes: list[dict[str, Any]] = []
    stack: list[tuple[dict[str, Any], int | None, int]] = [(doc.root, None, 0)]
    model = FeatureModel(features, index, [], str(doc.root.get("name", "")), doc)

    declared = False  # (some feature says its allowed binding)
    while stack:
        node, parent, position = stack.pop()
        i = len(features)
        constraints = node.get("constraints", {})
        if constraints and not declared:
            declared = "bindingTimeAllowed" in constraints or "bindingModeAllowed" in constraints
        feature = Feature(  # (by position: keywords cost a tenth of the reading at 100,000 features)
            i,  # index
            node["id"],
            node["name"],
            parent,
            position,
            node.get("group", "") if parent is not None else "",  # declared_group
            "",  # group
            False,  # mandatory
            node.get("isMandatory"),  # declared_mandatory
            _TIMES[constraints.get("bindingTimeAllowed", _DEFAULT_TIME)],
            _MODES[constraints.get("bindingModeAllowed", _DEFAULT_MODE)],
            _listed(constraints.get("featuresIncluded")),
            _listed(constraints.get("featuresExcluded")),
            [],  # children
            node.get("abstract", False) is True,
        )
        features.append(feature)
        nodes.append(node)
        if parent is not None:
            features[parent].children.append(i)
        if feature.id in index:
            first = model.path(index[feature.id], "id")
            where = doc.locate(first)
            diagnostics.append(
                error(
                    doc.locate(model.path(i, "id")),
                    f"duplicate feature id {feature.id!r} (first defined at line {where.line}, column {where.column})",
                    "model.duplicate-id",
                    feature.id,
                )
            )
        else:
            index[feature.id] = i
            other = folded.setdefault(feature.id.upper(), i)
            if other != i:
                diagnostics.append(
                    error(
                        doc.locate(model.path(i, "id")),
                        f"{feature.id} and {features[other].id} differ only in case, "
                        f"so their C++ macros would be the same name",
                        "model.case-clash",
                        feature.id,
                    )
                )
        for position_ in range(len(node.get("sub", ())) - 1, -1, -1):
            stack.append((node["sub"][position_], i, position_))

    model.bindings_declared = declared
    root, root_node = features[0], nodes[0]
    if root_node.get("isSelected") is False:
        diagnostics.append(
            error(
                doc.locate(("isSelected",)),
                "the root cannot be deselected: it is the program itself (rule 2.1)",
                "2.1",
                root.id,
            )
        )
    if root_node.get("group"):
        diagnostics.append(
            warning(
                doc.locate(("group",)),
                "the root has no siblings: its group is ignored",
                "model.root-group",
                root.id,
            )
        )

    suggest = _Suggestions(index)
    for feature, node in zip(features, nodes, strict=True):
        if feature.parent is not None and "isSelected" in node:
            diagnostics.append(
                warning(
                    doc.locate(model.path(feature.index, "isSelected")),
                    "isSelected is only meaningful on the root; ignored here",
                    "model.is-selected",
                    feature.id,
                )
            )
        if not (feature.includes or feature.excludes):
            continue
        for key, targets in (("featuresIncluded", feature.includes), ("featuresExcluded", feature.excludes)):
            verb = "includes" if key == "featuresIncluded" else "excludes"
            named: dict[str, int] = {}  # target -> where it is first named
            for position_, target in enumerate(targets):
                if named.setdefault(target, position_) != position_:
                    diagnostics.append(
                        warning(
                            doc.locate(model.path(feature.index, "constraints", key, position_)),
                            f"{feature.id} {verb} {target} twice; the second is ignored",
                            "model.repeated-id",
                            feature.id,
                        )
                    )
                    continue
                if target in index and target != feature.id:
                    continue
                path = model.path(feature.index, "constraints", key, position_)
                if target == feature.id:
                    diagnostics.append(
                        error(
                            doc.locate(path),
                            f"{feature.id} {verb} itself",
                            "model.self-reference",
                            feature.id,
                        )
                    )
                elif target not in index:
                    diagnostics.append(
                        error(
                            doc.locate(path),
                            f"{feature.id} {verb} unknown feature {target!r}{suggest(target)}",
                            "model.unknown-id",
                            feature.id,
                        )
                    )

    _read_formulas(doc, model, diagnostics, suggest)

    # Groups (rule 2.2): the label sits on the child; a group needs two members.
    labelled = {f.parent for f in features if f.declared_group}  # parents with a labelled child
    for owner in features:
        if owner.index not in labelled:
            continue
        for kind in GroupKind:
            members = [c for c in owner.children if features[c].declared_group == kind]
            if len(members) == 1:
                only = features[members[0]]
                diagnostics.append(
                    warning(
                        doc.locate(model.path(only.index, "group")),
                        f"{only.id} is the only member of {owner.id}'s {kind} group; "
                        f"it is treated as an ungrouped child (a group needs at least two members)",
                        "model.one-member-group",
                        only.id,
                    )
                )
            elif len(members) >= 2:
                model.groups.append(Group(owner.index, kind, tuple(members)))
                for member in members:
                    features[member].group = kind
                    if features[member].declared_mandatory is True:
                        diagnostics.append(
                            warning(
                                doc.locate(model.path(member, "isMandatory")),
                                f"isMandatory of {features[member].id} is ignored: "
                                f"it is a member of {owner.id}'s {kind} group, and the group decides",
                                "model.grouped-mandatory",
                                features[member].id,
                            )
                        )
    for feature in features[1:]:
        if not feature.group:
            feature.mandatory = feature.declared_mandatory is not False
    return model, diagnostics


def _listed(value: Any) -> tuple[Any, ...]:
    """A list's members; nothing for any other value. (The schema says what the list must
    be; a big model is read while the schema is checked, and a string or an object where a
    list belongs must not be read as thousands of members meanwhile.)"""
    return tuple(value) if isinstance(value, list) else ()


def _read_formulas(doc: Document, model: FeatureModel, diagnostics: list[Diagnostic], suggest: _Suggestions) -> None:
    """The root's `formulas` (rule 2.4): each parsed, each id known, errors at the character."""
    for position, text in enumerate(_listed(doc.root.get("formulas"))):
        path = ("formulas", position)
        try:
            formula = parse(text, position)
        except FormulaError as problem:
            diagnostics.append(
                error(
                    doc.locate_in_string(path, problem.offset),
                    f"formula {position + 1}, `{text}`, does not parse: {problem.message} (rule 2.4)",
                    "2.4",
                )
            )
            continue
        unknown = [v for v in formula.variables() if v.id not in model.index]
        for var in unknown:
            diagnostics.append(
                error(
                    doc.locate_in_string(path, var.offset),
                    f"formula {position + 1}, `{text}`, names unknown feature {var.id!r}{suggest(var.id)} (rule 2.4)",
                    "2.4",
                )
            )
        if not unknown:
            model.formulas.append(formula)


def read_configuration(
    doc: Document, model: FeatureModel, partial: bool = False, skip: frozenset[int] = frozenset()
) -> tuple[Configuration, list[Diagnostic]]:
    """Build a configuration of `model`; report unknown, duplicate and missing entries.

    Entries at the positions in `skip` (those with schema errors) are not read; their id, if
    it is a string, still counts as an entry, so that it is not also reported missing.
    """
    diagnostics: list[Diagnostic] = []
    entries: dict[str, Entry] = {}
    skipped: set[str] = set()
    config = Configuration(entries, source=doc)
    suggest = _Suggestions(model.index)
    for position, raw in enumerate(doc.root.get("properties", [])):
        if position in skip:
            if isinstance(raw, dict) and isinstance(raw.get("id"), str):
                skipped.add(raw["id"])
            continue
        feature_id = raw["id"]
        props = raw.get("props", {})
        entry = Entry(  # id, selected, time, mode, position
            feature_id,
            raw.get("selected", True),
            _TIMES[props.get("time", ANY)],
            _MODES[props.get("mode", ANY)],
            position,
        )
        if feature_id not in model.index:
            diagnostics.append(
                error(
                    doc.locate(("properties", position, "id")),
                    f"unknown feature {feature_id!r}{suggest(feature_id)}",
                    "config.unknown-id",
                    feature_id,
                )
            )
            continue
        if feature_id in entries:
            first = doc.locate(("properties", entries[feature_id].position))
            diagnostics.append(
                error(
                    doc.locate(("properties", position, "id")),
                    f"second entry for {feature_id!r} (the first is at line {first.line}, column {first.column})",
                    "config.duplicate-id",
                    feature_id,
                )
            )
            continue
        if not entry.selected and (entry.time is not None or entry.mode is not None):
            diagnostics.append(
                warning(
                    doc.locate(("properties", position, "props")),
                    f"{feature_id} is not selected: its props are ignored",
                    "config.props-ignored",
                    feature_id,
                )
            )
        entries[feature_id] = entry
    missing = [f.id for f in model.features[1:] if f.id not in entries and f.id not in skipped]
    if missing and not partial and doc.root.get("partial") is not True:  # (a decisions file: section 1)
        shown = ", ".join(missing[:10]) + (f" and {len(missing) - 10} more" if len(missing) > 10 else "")
        diagnostics.append(
            error(
                doc.locate(("properties",)),
                f"the configuration is incomplete: no entry for {shown} "
                f"(add the entries, or use --partial to leave them to the configurator)",
                "config.incomplete",
                missing[0] if len(missing) == 1 else None,
            )
        )
    return config, diagnostics


def _entry_position(diagnostic: Diagnostic) -> int | None:
    """The position of the configuration entry a schema error is about, if it is about one."""
    steps = diagnostic.location.steps
    return steps[1] if len(steps) >= 2 and steps[0] == "properties" and isinstance(steps[1], int) else None


def _usable(diagnostics: list[Diagnostic]) -> bool:
    """Whether a configuration can still be checked: an incomplete one can (as a partial one),
    so that what else is wrong with it is not hidden behind the missing entries."""
    return not any(d.severity is Severity.ERROR and d.rule != "config.incomplete" for d in diagnostics)


def load_model(path: str | Path) -> tuple[FeatureModel | None, list[Diagnostic]]:
    """Read a feature model file; None when it cannot be used (the diagnostics say why)."""
    doc, problems, read = read_checked_then(path, check_feature_model, _read_model)
    if doc is None or read is None:
        return None, problems
    model, diagnostics = read
    return (model if _usable(diagnostics) else None), diagnostics


def _read_model(doc: Document) -> tuple[FeatureModel, list[Diagnostic]]:
    with no_gc():
        return read_model(doc)


def load_configuration(
    path: str | Path, model: FeatureModel, partial: bool = False
) -> tuple[Configuration | None, list[Diagnostic]]:
    """Read a configuration of `model`; None when it cannot be used (the diagnostics say why)."""
    doc, problems = read_with_problems(path, check_configuration)
    if doc is None:
        return None, problems
    if problems:
        # The entries without schema errors are still checked (unknown ids, duplicates), so
        # that one bad entry does not hide the others' errors; schema errors come first.
        # Only when every schema error is inside an entry: the document's shape is sound.
        positions = [_entry_position(p) for p in problems]
        if any(p is None for p in positions):
            return None, problems
        skip = frozenset(p for p in positions if p is not None)
        with no_gc():
            _, more = read_configuration(doc, model, partial, skip)
        return None, problems + more
    with no_gc():
        config, diagnostics = read_configuration(doc, model, partial)
    config.name = Path(path).stem
    return (config if _usable(diagnostics) else None), diagnostics

"""Run the product's semantic check on in-memory documents, and read its explanations
back as statements of the reference semantics (tests/reference_semantics.py)."""

from __future__ import annotations

import json
import re
from typing import Any

import reference_semantics as ref

from motivml.binding.check import check_variant
from motivml.documents.loader import parse
from motivml.errors import Diagnostic, LocatedFact
from motivml.language.reader import read_configuration, read_model

MODEL_FILE = "model.json"
CONFIG_FILE = "variant.json"


def variant_errors(model: dict[str, Any], config: dict[str, Any]) -> list[Diagnostic]:
    """Errors of a configuration (partial allowed), via loader, reader and SAT."""
    doc = parse(json.dumps(model, indent=1), MODEL_FILE)
    feature_model, diagnostics = read_model(doc)
    assert not [d for d in diagnostics if d.severity.value == "error"], diagnostics
    config_doc = parse(json.dumps(config, indent=1), CONFIG_FILE)
    configuration, diagnostics = read_configuration(config_doc, feature_model, partial=True)
    assert not [d for d in diagnostics if d.severity.value == "error"], diagnostics
    return check_variant(feature_model, configuration)


# ---------------------------------------------------------------------------------------
# Explanations as reference statements
# ---------------------------------------------------------------------------------------
#
# An explanation lists its facts (`Diagnostic.facts`) as a sentence and a location each.
# Both are read here from the user's side only: the sentence gives the statement of the
# reference semantics, and the location must point, in the raw JSON documents, at where
# that statement is written.  Nothing of the product's encoding is used.

_ID = r"([A-Za-z_][A-Za-z0-9_]*)"
_SENTENCES: list[tuple[str, str]] = [
    (rf"{_ID} is the root", "root"),
    (r"the robot must be able to start", "start"),
    (rf"{_ID} is a sub-feature of {_ID}", "sub"),
    (rf"{_ID} is a mandatory sub-feature of {_ID}", "mandatory"),
    (rf"{_ID} requires its mandatory sub-feature {_ID}", "mandatory-of"),
    (rf"{_ID} has the (OR|XOR) group ({_ID[1:-1]}(?:, {_ID[1:-1]})+)", "group"),
    (rf"{_ID} and {_ID} are alternatives in {_ID}'s XOR group", "alternatives"),
    (rf"{_ID} (?:includes|requires) {_ID}", "includes"),
    (rf"{_ID} excludes {_ID}", "excludes"),
    (rf"{_ID} allows only (Early|Late) binding", "time-allowed"),
    (rf"{_ID} allows only (Static|Dynamic) binding", "mode-allowed"),
    (rf"{_ID} is selected", "selected"),
    (rf"{_ID} is not selected", "deselected"),
    (rf"{_ID} is configured (Early|Late)", "time"),
    (rf"{_ID} is configured (Static|Dynamic)", "mode"),
    (rf"{_ID} would be selected", "would-be-selected"),
    (rf"{_ID} is dead(?: \(below {_ID}\))?", "dead"),
    (rf"{_ID} would be (Early|Late)", "would-be-time"),
    (rf"{_ID} would be (Static|Dynamic)", "would-be-mode"),
    (r"formula ([1-9][0-9]*), `(.+)`, must hold", "formula"),
]


def _features(
    raw: dict[str, Any], path: str = "$", parent: str | None = None
) -> dict[str, tuple[str, dict[str, Any], str | None]]:
    """Feature id -> (JSON path, raw feature object, parent id), from the model document."""
    found = {raw["id"]: (path, raw, parent)}
    for k, child in enumerate(raw.get("sub", [])):
        found |= _features(child, f"{path}.sub[{k}]", raw["id"])
    return found


def _key(base: str, key: str) -> str:
    """`base` + `.key`, the way a JSON path is written ("$" + ".id" is "$.id")."""
    return f"{base}.{key}"


def statement_of(
    fact: LocatedFact, model: dict[str, Any], config: dict[str, Any] | None
) -> tuple[tuple[str, ...], bool]:
    """The reference statement one fact of an explanation states, and whether it is a
    hypothesis of the question asked ("f would be selected") rather than something the
    model or the configuration says.  Fails the test if the sentence is not understood or
    the location is not where that statement is written."""
    understood = [(kind, m) for pattern, kind in _SENTENCES if (m := re.fullmatch(pattern, fact.text))]
    assert understood, f"explanation fact not understood: {fact.text!r}"
    ((kind, match),) = understood
    groups = match.groups()
    features = _features(model)
    for fid in (g for g in groups if g and re.fullmatch(_ID, g)):
        assert fid in features or fid in ("OR", "XOR", "Early", "Late", "Static", "Dynamic"), fact
    where = fact.location.path
    in_model = fact.location.file == MODEL_FILE

    def path_of(fid: str) -> str:
        return features[fid][0]

    def raw(fid: str) -> dict[str, Any]:
        return features[fid][1]

    def parent_of(fid: str) -> str | None:
        return features[fid][2]

    statement: tuple[str, ...]
    hypothesis = kind.startswith("would-be")
    if kind == "root":
        (fid,) = groups
        assert fid == model["id"] and in_model and where == "$.id", fact
        statement = ("root",)
    elif kind == "start":
        assert in_model and where == "$", fact
        statement = ("start",)
    elif kind in ("sub", "mandatory", "mandatory-of"):
        child, parent = groups if kind != "mandatory-of" else groups[::-1]
        assert parent_of(child) == parent, fact
        # a mandatory child is located at its isMandatory key, or at its id if the key is
        # absent (mandatory by default)
        key = "isMandatory" if kind != "sub" and "isMandatory" in raw(child) else "id"
        assert in_model and where == _key(path_of(child), key), fact
        statement = ("sub" if kind == "sub" else "mandatory", child)
    elif kind == "group":
        parent, label, members = groups[0], groups[1], groups[2].split(", ")
        assert all(parent_of(m) == parent for m in members), fact
        assert in_model and where == _key(path_of(members[0]), "group"), fact
        statement = ("group", parent, label)
    elif kind == "alternatives":
        a, b, parent = groups
        assert parent_of(a) == parent_of(b) == parent, fact
        assert in_model and where == _key(path_of(b), "group"), fact
        statement = ("alternatives", a, b)
    elif kind in ("includes", "excludes"):
        x, y = groups
        key = "featuresIncluded" if kind == "includes" else "featuresExcluded"
        listed = raw(x).get("constraints", {}).get(key, [])
        positions = [_key(path_of(x), f"constraints.{key}[{k}]") for k, v in enumerate(listed) if v == y]
        assert in_model and where in positions, fact
        statement = (kind, x, y)
    elif kind == "formula":
        number, text = groups
        position = int(number) - 1
        assert model.get("formulas", [])[position] == text, fact
        assert in_model and where == f"$.formulas[{position}]", fact
        statement = ("formula", str(position))
    elif kind in ("time-allowed", "mode-allowed"):
        fid, value = groups
        key = "bindingTimeAllowed" if kind == "time-allowed" else "bindingModeAllowed"
        default = "Early" if kind == "time-allowed" else "Static"
        assert raw(fid).get("constraints", {}).get(key, default) == value, fact
        assert in_model and where == _key(path_of(fid), f"constraints.{key}"), fact
        statement = (kind, fid)
    elif kind in ("selected", "deselected", "time", "mode"):
        fid = groups[0]
        assert config is not None and fact.location.file == CONFIG_FILE, fact
        (position,) = [k for k, e in enumerate(config["properties"]) if e["id"] == fid]
        entry = config["properties"][position]
        base = f"$.properties[{position}]"
        if kind == "selected":
            assert entry.get("selected", True) is True and where == base, fact
            statement = ("selected", fid)
        elif kind == "deselected":
            assert entry.get("selected") is False and where == _key(base, "selected"), fact
            statement = ("deselected", fid)
        else:
            assert entry.get("props", {}).get(kind) == groups[1], fact
            assert where == _key(base, f"props.{kind}"), fact
            statement = (kind, fid, groups[1])
    elif kind == "dead":  # what another warning showed: no valid variant selects fid
        fid, top = groups
        assert in_model and where == _key(path_of(fid), "id"), fact
        assert top is None or path_of(fid).startswith(path_of(top) + "."), fact
        statement = ("deselected", fid)
    else:  # the question asked: "f would be selected", "f would be Early"
        fid = groups[0]
        assert in_model and where == _key(path_of(fid), "id"), fact
        if kind == "would-be-selected":
            statement = ("selected", fid)
        else:
            statement = ("time" if kind == "would-be-time" else "mode", fid, groups[1])
    return statement, hypothesis


def explanation_statements(
    diagnostic: Diagnostic, model: dict[str, Any], config: dict[str, Any] | None
) -> list[tuple[str, ...]]:
    """The statements an explanation names, each checked to be one the documents make
    (or, for a question, the hypothesis it asks about)."""
    written = set(ref.model_statements(model)) | set(ref.config_statements(model, config))
    statements = []
    for fact in diagnostic.facts:
        statement, hypothesis = statement_of(fact, model, config)
        if fact.text.startswith(f"{statement[-1]} is dead"):  # derived: true of the model itself
            dead = not ref.consistent(model, [*ref.model_statements(model), ("selected", statement[-1])])
            assert dead, (fact, "not dead by the reference")
            hypothesis = True
        assert hypothesis or statement in written, (fact, statement)
        statements.append(statement)
    assert len(set(statements)) == len(statements), ("a statement named twice", diagnostic.facts)
    return statements


def assert_conflict(model: dict[str, Any], statements: list[tuple[str, ...]]) -> None:
    """Per the reference: the statements together have no variant."""
    assert statements, "an explanation names its facts"
    assert not ref.consistent(model, statements), ("not a conflict", statements)


class NotMinimal(AssertionError):
    """An explanation names a fact that the others do not need to conflict."""


def assert_minimal_conflict(model: dict[str, Any], statements: list[tuple[str, ...]]) -> None:
    """Per the reference: the statements together have no variant, and without any one of
    them they have one (a minimal unsatisfiable subset, reference.md section 4)."""
    assert_conflict(model, statements)
    for k, dropped in enumerate(statements):
        rest = statements[:k] + statements[k + 1 :]
        if not ref.consistent(model, rest):
            raise NotMinimal(f"still a conflict without {dropped}: {statements}")

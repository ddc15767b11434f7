"""Model and configuration reading: the checks a schema cannot make, word for word."""

from __future__ import annotations

import json
from random import Random
from typing import Any

from helpers import config, dumps, feature
from hypothesis import given, settings
from hypothesis import strategies as st
from test_property_sat import models

from motivml.documents.loader import parse
from motivml.language.model import Binding, Mode, Time, token
from motivml.language.reader import read_configuration, read_model


def read(model: dict[str, object]):  # type: ignore[no-untyped-def]
    return read_model(parse(dumps(model), "m.json"))


def lines(diagnostics) -> list[str]:  # type: ignore[no-untyped-def]
    return [f"{d.severity.value}: {d.location}: {d.location.path}: {d.message}" for d in diagnostics]


def test_features_in_preorder_with_defaults() -> None:
    model, diagnostics = read(feature("r", [feature("a", [feature("b")]), feature("c", isMandatory=False)]))
    assert diagnostics == []
    assert [f.id for f in model.features] == ["r", "a", "b", "c"]
    a, c = model["a"], model["c"]
    assert (a.mandatory, a.time_allowed, a.mode_allowed, a.group) == (True, "Early", "Static", "")
    assert c.mandatory is False
    assert model.path(model.index["b"], "id") == ("sub", 0, "sub", 0, "id")
    assert model.subtree(1) == [1, 2]


def test_duplicate_id() -> None:
    _, diagnostics = read(feature("r", [feature("a"), feature("a")]))
    assert lines(diagnostics) == [
        "error: m.json:10:13: $.sub[1].id: duplicate feature id 'a' (first defined at line 6, column 13)"
    ]


def test_unknown_and_self_references() -> None:
    _, diagnostics = read(feature("r", [feature("gridmap"), feature("slam", inc=["gridmpa"], exc=["slam"])]))
    assert lines(diagnostics) == [
        "error: m.json:14:11: $.sub[1].constraints.featuresIncluded[0]: "
        "slam includes unknown feature 'gridmpa' (did you mean 'gridmap'?)",
        "error: m.json:17:11: $.sub[1].constraints.featuresExcluded[0]: slam excludes itself",
    ]


def test_one_member_group_is_an_ungrouped_child() -> None:
    model, diagnostics = read(feature("r", [feature("a", group="XOR"), feature("b")]))
    assert lines(diagnostics) == [
        "warning: m.json:8:16: $.sub[0].group: a is the only member of r's XOR group; it is treated as an "
        "ungrouped child (a group needs at least two members)"
    ]
    assert model["a"].group == "" and model["a"].mandatory is True and model.groups == []


def test_grouped_is_mandatory_true_is_ignored_with_a_warning() -> None:
    model, diagnostics = read(
        feature(
            "r", [feature("a", group="OR", isMandatory=True), feature("b", group="OR", isMandatory=False)]
        )
    )
    assert lines(diagnostics) == [
        "warning: m.json:9:22: $.sub[0].isMandatory: isMandatory of a is ignored: it is a member of r's OR "
        "group, and the group decides"
    ]
    assert [(g.kind, g.members) for g in model.groups] == [("OR", (1, 2))]
    assert model["a"].mandatory is False


def test_root_cannot_be_deselected_and_is_selected_elsewhere_is_ignored() -> None:
    _, diagnostics = read(feature("r", [feature("a", isSelected=False)], isSelected=False))
    assert lines(diagnostics) == [
        "error: m.json:4:17: $.isSelected: the root cannot be deselected: it is the program itself (rule 2.1)",
        "warning: m.json:9:21: $.sub[0].isSelected: isSelected is only meaningful on the root; ignored here",
    ]


def read_config(entries: dict[str, object], partial: bool = False) -> list[str]:
    model, _ = read(feature("r", [feature("slam"), feature("amcl")]))
    _, diagnostics = read_configuration(parse(json.dumps(entries, indent=1), "c.json"), model, partial)
    return lines(diagnostics)


def test_configuration_unknown_duplicate_and_missing() -> None:
    assert read_config(config(("slma",), ("slam",), ("slam", False))) == [
        "error: c.json:4:10: $.properties[0].id: unknown feature 'slma' (did you mean 'slam'?)",
        "error: c.json:10:10: $.properties[2].id: second entry for 'slam' (the first is at line 6, column 3)",
        "error: c.json:2:16: $.properties: the configuration is incomplete: no entry for amcl (add the entries, "
        "or use --partial to leave them to the configurator)",
    ]


def test_partial_configuration_and_ignored_props() -> None:
    entries = {"properties": [{"id": "slam", "selected": False, "props": {"time": "Late"}}]}
    assert read_config(entries, partial=True) == [
        "warning: c.json:6:13: $.properties[0].props: slam is not selected: its props are ignored"
    ]


def test_repeated_include_is_warned_and_used_once() -> None:
    model, diagnostics = read(feature("r", [feature("a", inc=["b", "b"]), feature("b")]))
    assert lines(diagnostics) == [
        "warning: m.json:11:11: $.sub[0].constraints.featuresIncluded[1]: a includes b twice; the second is ignored"
    ]
    assert model["a"].includes == ("b", "b")


def test_any_is_read_as_an_open_value_and_a_binding_is_spelled_from_its_time_and_mode() -> None:
    model, _ = read(feature("r", [feature("a", time="Any", mode="Dynamic")]))
    assert (model["a"].time_allowed, model["a"].mode_allowed) == (None, Mode.DYNAMIC)
    entries = read_configuration(parse(json.dumps(config(("a", "Late", "Any"))), "c.json"), model)[0].entries
    assert (entries["a"].time, entries["a"].mode) == (Time.LATE, None)
    assert [(b.value, b.words, b.macro) for b in Binding] == [
        ("SE", "Static Early", "STATIC_EARLY"),
        ("SL", "Static Late", "STATIC_LATE"),
        ("DE", "Dynamic Early", "DYNAMIC_EARLY"),
        ("DL", "Dynamic Late", "DYNAMIC_LATE"),
    ]
    for b in Binding:
        assert Binding.of(b.time, b.mode) is b is Binding.from_flags(b.early, b.static)
        assert (b.early, b.static) == (b.time is Time.EARLY, b.mode is Mode.STATIC)
    assert [token(v) for v in (Time.LATE, Mode.DYNAMIC, None)] == ["Late", "Dynamic", "Any"]


def test_ids_differing_only_in_case_are_an_error_of_the_model() -> None:
    # configure would refuse them (their C++ macros clash), so validate must too
    _, diagnostics = read(feature("r", [feature("slam"), feature("SLAM"), feature("slam")]))
    assert lines(diagnostics) == [
        "error: m.json:10:13: $.sub[1].id: SLAM and slam differ only in case, "
        "so their C++ macros would be the same name",
        "error: m.json:14:13: $.sub[2].id: duplicate feature id 'slam' (first defined at line 6, column 13)",
    ]


def test_a_schema_error_in_one_entry_hides_no_other_error(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from motivml.language.reader import load_configuration

    model, _ = read(feature("r", [feature("slam"), feature("amcl")]))
    path = tmp_path / "c.json"
    path.write_text(
        '{"properties": [\n'
        '  {"id": "slam", "props": {"time": "early"}},\n'
        '  {"id": "slma"},\n'
        '  {"id": "amcl"},\n'
        '  {"id": "amcl", "selected": false}\n'
        "]}\n"
    )
    config, diagnostics = load_configuration(path, model)
    assert config is None
    assert [line.replace(str(tmp_path), "") for line in lines(diagnostics)] == [
        "error: /c.json:2:36: $.properties[0].props.time: 'early' is not one of 'Early', 'Late', 'Any' "
        "(did you mean 'Early'?)",
        "error: /c.json:3:10: $.properties[1].id: unknown feature 'slma' (did you mean 'slam'?)",
        "error: /c.json:5:10: $.properties[3].id: second entry for 'amcl' (the first is at line 4, column 3)",
    ]


def test_a_configuration_whose_shape_is_wrong_reports_only_its_schema_errors(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from motivml.language.reader import load_configuration

    model, _ = read(feature("r", [feature("slam")]))
    path = tmp_path / "c.json"
    path.write_text('{"properties": {"id": "slma"}}')
    config, diagnostics = load_configuration(path, model)
    assert config is None and [d.rule for d in diagnostics] == ["schema.type"]


def _json_paths(raw: dict[str, object]) -> dict[str, tuple[object, ...]]:
    """Each feature id's path in the model document, found by walking the document."""
    found: dict[str, tuple[object, ...]] = {}
    stack: list[tuple[dict[str, object], tuple[object, ...]]] = [(raw, ())]
    while stack:
        node, path = stack.pop()
        found[str(node["id"])] = path
        for position, child in enumerate(node.get("sub", [])):  # type: ignore[arg-type]
            stack.append((child, (*path, "sub", position)))
    return found


@settings(max_examples=100, deadline=None)
@given(models(max_features=12), st.randoms(use_true_random=False))
def test_feature_paths_are_the_documents_in_any_order_they_are_asked(raw: dict[str, Any], rng: Random) -> None:
    """FeatureModel.path keeps each path it makes and makes a new one from the nearest
    kept ancestor's: whatever the order of the questions, each is the document's path."""
    model, _ = read_model(parse(json.dumps(raw), "m.json"))
    expected = _json_paths(raw)
    asked = list(range(len(model.features))) * 2
    rng.shuffle(asked)
    for i in asked:
        assert model.path(i, "id") == (*expected[model.features[i].id], "id")

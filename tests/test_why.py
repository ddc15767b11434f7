"""`show --why FEATURE`, `show --format json` and the start marks of `show`.

Fixtures on SimpleBot with a decisions file (three entries: teleoperation, kartoslam, and
gesture_recognition Dynamic Late), so that most of the model's values are forced or left
open rather than configured; and a property test: what `why` calls forced, impossible or
open agrees with brute-force enumeration of the valid variants.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest
import reference_semantics as ref
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_property_sat import configurations, models

from motivml.binding.check import binding_states
from motivml.binding.why import why
from motivml.cli import main
from motivml.documents.loader import parse
from motivml.language.reader import read_configuration, read_model

ROBOT = "feature_models/simplebot"
DECISIONS = {
    "partial": True,
    "properties": [
        {"id": "teleoperation"},
        {"id": "kartoslam"},
        {"id": "gesture_recognition", "props": {"time": "Late", "mode": "Dynamic"}},
    ],
}


@pytest.fixture
def decisions(tmp_path: Path) -> str:
    path = tmp_path / "lab.json"
    path.write_text(json.dumps(DECISIONS, indent=2) + "\n")
    return str(path)


def answer(decisions: str, feature: str) -> list[dict[str, Any]]:
    result = CliRunner().invoke(
        main, ["show", ROBOT, "--config", decisions, "--why", feature, "--format", "json"]
    )
    assert result.exit_code == 0, result.output
    payload = json.loads(result.output)
    assert payload["why"]["feature"] == feature
    reasons: list[dict[str, Any]] = payload["why"]["reasons"]
    return reasons


def test_a_configured_feature_points_at_its_entry(decisions: str) -> None:
    (selection, time, mode, start) = answer(decisions, "gesture_recognition")
    assert (selection["statement"], selection["how"]) == ("gesture_recognition is selected", "configuration")
    assert selection["facts"][0]["file"] == decisions and selection["facts"][0]["line"] == 10
    assert (time["statement"], time["facts"][0]["path"]) == (
        "gesture_recognition is Late",
        "$.properties[2].props.time",
    )
    assert mode["statement"] == "gesture_recognition is Dynamic"
    assert start["statement"] == "gesture_recognition is not active at start"


def test_a_forced_selection_is_the_chain_of_facts_that_forces_it(decisions: str) -> None:
    selection, time, mode, start = answer(decisions, "grid_map")
    assert (selection["statement"], selection["how"]) == ("grid_map is always selected", "forced")
    texts = [f["text"] for f in selection["facts"]]
    assert texts == [
        "kartoslam is a sub-feature of slam",
        "slam includes grid_map",
        "kartoslam is selected",
        "grid_map would not be selected",
    ]
    assert [f["line"] for f in selection["facts"]][:3] == [150, 127, 7]  # model, model, decisions file
    assert (time["how"], mode["how"]) == ("open", "forced")
    assert time["because"].endswith(
        "configure makes it Early (it prefers Early, the published default, section 4)"
    )
    assert mode["statement"] == "grid_map is always Static when selected"
    assert "slam requires grid_map" in mode["because"] and "(binding rule 3.1)" in mode["because"]
    assert start["statement"] == "grid_map is active at start"


def test_a_feature_that_can_never_be_selected_says_why(decisions: str) -> None:
    (selection,) = answer(decisions, "amcl")
    assert (selection["statement"], selection["how"]) == ("amcl is never selected", "forced")
    assert "amcl excludes slam" in [f["text"] for f in selection["facts"]]


def test_a_feature_left_open_says_what_configure_makes_of_it(decisions: str) -> None:
    selection, time, mode = answer(decisions, "orbslam")
    assert (selection["statement"], selection["how"]) == ("orbslam is left open", "open")
    assert "configure leaves it out" in selection["because"]
    assert time["how"] == "open" and "configure makes it" not in time["because"]  # it is left out
    assert mode["statement"] == "orbslam is always Dynamic when selected"
    assert "kartoslam and orbslam are alternatives in slam's XOR group" in mode["because"]


def test_the_root(decisions: str) -> None:
    (selection,) = answer(decisions, "root_feature")
    assert selection["how"] == "model" and "rule 2.1" in selection["because"]


def test_text_output_lists_each_answer_with_its_facts(decisions: str) -> None:
    result = CliRunner().invoke(main, ["show", ROBOT, "--config", decisions, "--why", "slam"])
    assert result.exit_code == 0
    lines = result.output.splitlines()
    assert lines[0].startswith(
        "slam is always selected: it cannot be left out: kartoslam is a sub-feature of slam"
    )
    assert lines[1].strip().endswith("kartoslam is a sub-feature of slam")
    assert (
        lines[-1]
        == "slam is active at start: it is Static Early: every selected Early feature is active at start (section 4)"
    )


def test_an_unknown_feature_is_a_usage_error() -> None:
    result = CliRunner().invoke(main, ["show", ROBOT, "--variant", "lab", "--why", "gridmap"])
    assert result.exit_code == 2
    assert "no feature 'gridmap' in the model (did you mean 'grid_map'?)" in result.output


def test_show_json_and_the_start_marks_agree_with_the_start_state() -> None:
    result = CliRunner().invoke(main, ["show", ROBOT, "--variant", "lab", "--format", "json"])
    assert result.exit_code == 0
    features = {f["id"]: f for f in json.loads(result.output)["features"]}
    assert features["hands"]["variant"] == {"selected": True, "binding": "DL"}
    assert features["hands"]["active_at_start"] is False
    assert features["grid_map"]["active_at_start"] is True and features["grid_map"]["possible"] == ["SE"]
    assert features["amcl"]["configured"] == {"selected": False}
    text = CliRunner().invoke(main, ["show", ROBOT, "--variant", "lab"]).output
    marked = {
        re.search(r"── (?:! |\? |\[X?OR\] )?(\w+) \(", line).group(1)  # type: ignore[union-attr]
        for line in text.splitlines()
        if line.endswith(" start") and "──" in line
    }
    assert marked == {f for f, v in features.items() if v["active_at_start"] and v["parent"] is not None}


def test_without_a_variant_there_is_no_start_state() -> None:
    result = CliRunner().invoke(main, ["show", ROBOT, "--format", "json", "--why", "hands"])
    payload = json.loads(result.output)
    assert all("active_at_start" not in f for f in payload["features"])
    assert [r["aspect"] for r in payload["why"]["reasons"]] == ["selection", "time", "mode"]


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_forced_impossible_and_open_agree_with_brute_force(data: st.DataObject) -> None:
    raw = data.draw(models(max_features=7))
    # half the time a decisions file with no entry: every value is forced or open
    document = data.draw(configurations(raw)) if data.draw(st.booleans()) else {"properties": []}
    if not ref.is_valid(raw, document):
        return
    model, _ = read_model(parse(json.dumps(raw), "model.json"))
    config, _ = read_configuration(parse(json.dumps(document), "v.json"), model, partial=True)
    variants = list(ref.valid_variants(raw, document))
    states = binding_states(model, config)
    entries = {e["id"]: e for e in document["properties"]}
    for f in model.features[1:]:
        reasons = {r.aspect: r for r in why(model, config, f.id, states)}
        selection = reasons["selection"]
        chosen = [f.id in v for v in variants]
        if f.id in entries:
            assert selection.how == "configuration"
        elif all(chosen):
            assert (selection.how, selection.statement) == ("forced", f"{f.id} is always selected")
        elif not any(chosen):
            assert (selection.how, selection.statement) == ("forced", f"{f.id} is never selected")
        else:
            assert selection.how == "open"
        for aspect, position in (("time", 0), ("mode", 1)):
            values = {v[f.id][position] for v in variants if f.id in v}
            if not values:
                assert aspect not in reasons
            elif reasons[aspect].how == "forced":
                assert len(values) == 1, (aspect, f.id, values)
            elif reasons[aspect].how == "open":
                assert len(values) == 2, (aspect, f.id, values)


# ------------------------------------------------------- a model that says no bindings
IMPORTED = {  # as an import of another tool's model makes it: no feature says a binding
    "id": "gripper",
    "name": "Gripper",
    "sub": [
        {"id": "force", "name": "Force sensing", "isMandatory": False},
        {"id": "suction", "name": "suction", "isMandatory": False, "constraints": {"featuresExcluded": ["force"]}},
    ],
}


def test_a_model_without_bindings_is_shown_and_explained_by_selection_alone(tmp_path: Path) -> None:
    """Issue 33: on a model no feature of which says a binding, show and --why spoke of
    bindings nobody chose ("force is always Early ... cannot be Late") and printed a name
    equal to its id twice ("suction (suction)")."""
    (tmp_path / "model.json").write_text(json.dumps(IMPORTED))
    shown = CliRunner().invoke(main, ["show", str(tmp_path / "model.json")])
    assert shown.exit_code == 0, shown.output
    lines = shown.output.splitlines()
    assert lines[:3] == [
        "gripper (Gripper)  solver on",
        "├── ? force (Force sensing)  solver off,on",
        "└── ? suction  solver off,on",
    ]
    assert "no feature says a binding, so every one is Static Early" in " ".join(shown.output.split())
    explained = CliRunner().invoke(main, ["show", str(tmp_path / "model.json"), "--why", "force"])
    assert explained.output.splitlines() == [
        "force is left open: the model does not decide it, and valid variants exist with it and without it"
    ]
    one_says = json.loads(json.dumps(IMPORTED))
    one_says["sub"][0]["constraints"] = {"bindingTimeAllowed": "Any"}  # one says a binding: all are spoken of
    (tmp_path / "model.json").write_text(json.dumps(one_says))
    bound = CliRunner().invoke(main, ["show", str(tmp_path / "model.json"), "--why", "suction"])
    assert "suction is always Early when selected" in bound.output

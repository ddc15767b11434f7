"""The shipped robots end to end: models valid, variants as intended, messages word for word."""

from __future__ import annotations

import pytest
from paths import FEATURE_MODELS

from motivml.documents.robot_folder import RobotFolder
from motivml.validate import validate

ROBOTS = sorted(p.name for p in FEATURE_MODELS.iterdir() if (p / "model.json").is_file())

EXPECTED_ERRORS = {
    ("simplebot", "broken_gridmap_dynamic"): [
        "57:17: $.properties[7].props.mode: slam requires grid_map, but grid_map is configured Dynamic and slam is "
        "selected: a required feature must be Static (binding rule 3.1)"
    ],
    ("uv_disinfection", "broken_joystick_beside_static_lamp"): [
        "145:17: $.properties[18].props.mode: joystick_teleop excludes irradiation, but joystick_teleop is selected "
        "and irradiation is configured Static: features that exclude each other can both be selected only as Dynamic alternatives, at most one of "
        "them Early (rules 2.3 and 3.3)"
    ],
    ("tiago_service", "broken_privacy_mode_at_start"): [
        "140:17: $.properties[21].props.time: speech_recognition has the XOR group vosk_asr, google_cloud_asr; "
        "privacy_mode excludes google_cloud_asr, but vosk_asr is not selected, speech_recognition is configured "
        "Early and privacy_mode is configured Early: no start state exists: at start every selected Early "
        "feature is active, and the active set needs every active parent's mandatory sub-features, one active "
        "member of each of its groups (exactly one for XOR) and no two active features that exclude each other "
        "(section 4)"
    ],
    ("reaching_arm", "broken_both_static"): [
        "25:17: $.properties[2].props.mode: dmp_reach and attractor_reach are alternatives in reaching's XOR group, "
        "but dmp_reach is configured Static and attractor_reach is selected: two members of an XOR group can both "
        "be selected only as Dynamic alternatives, at most one of them Early (rules 2.2 and 3.3)"
    ],
    ("coordinated_arm", "broken_both_static"): [
        "25:17: $.properties[2].props.mode: dmp_reach and attractor_reach are alternatives in reaching's XOR group, "
        "but dmp_reach is configured Static and attractor_reach is selected: two members of an XOR group can both "
        "be selected only as Dynamic alternatives, at most one of them Early (rules 2.2 and 3.3)"
    ],
    ("laundry_gripping", "broken_two_calibrations"): [
        "7:89: $.properties[3].props.mode: calibration_learning and calibration_known are alternatives in "
        "calibration's XOR group, but calibration_learning is configured Static and calibration_known is selected: "
        "two members of an XOR group can both be selected only as Dynamic alternatives, at most one of them Early "
        "(rules 2.2 and 3.3)"
    ],
    ("quadruped", "broken_two_gaits"): [
        "17:17: $.properties[1].props.mode: trot and pace are alternatives in locomotion's XOR group, but trot is "
        "configured Static and pace is selected: two members of an XOR group can both be selected only as Dynamic "
        "alternatives, at most one of them Early (rules 2.2 and 3.3)"
    ],
    ("mixture_arm", "broken_no_primitive"): [
        "22:19: $.properties[2].selected: primitives has the OR group reach_left, reach_right, circle, but "
        "reach_left is not selected, reach_right is not selected, circle is not selected and primitives is "
        "selected: an OR group needs a selected member when its parent is selected (rule 2.2)"
    ],
}


def test_eight_robots_ship() -> None:
    assert ROBOTS == [
        "coordinated_arm",  # the reaching arm's files (links) with a coordination.json
        "laundry_gripping",
        "mixture_arm",
        "quadruped",
        "reaching_arm",
        "simplebot",
        "tiago_service",
        "uv_disinfection",
    ]


@pytest.mark.parametrize("robot", [r for r in ROBOTS if (FEATURE_MODELS / r / "architecture.json").is_file()])
def test_architecture_is_valid(robot: str) -> None:
    result = validate(FEATURE_MODELS / robot / "model.json", architecture_path=FEATURE_MODELS / robot / "architecture.json")
    assert result.architecture is not None and [d.message for r in result.reports for d in r.diagnostics] == []


@pytest.mark.parametrize("robot", ROBOTS)
def test_model_is_valid(robot: str) -> None:
    result = validate(FEATURE_MODELS / robot / "model.json")
    assert result.reports == [result.model] and result.model.errors == [] and result.model.analysed


@pytest.mark.parametrize("robot", ROBOTS)
def test_variants(robot: str) -> None:
    folder = RobotFolder.open(FEATURE_MODELS / robot)
    names = folder.variant_names()
    valid = [n for n in names if not n.startswith("broken")]
    invalid = [n for n in names if n.startswith("broken")]
    assert len(valid) >= 2 and len(invalid) == 1
    for name in valid:
        (report,) = validate(folder.model_path, [folder.variant_path(name)]).configurations
        assert report.diagnostics == [], (name, [d.message for d in report.diagnostics])
    (name,) = invalid
    (report,) = validate(folder.model_path, [folder.variant_path(name)]).configurations
    got = [f"{d.location.line}:{d.location.column}: {d.location.path}: {d.message}" for d in report.errors]
    assert got == EXPECTED_ERRORS[(robot, name)]

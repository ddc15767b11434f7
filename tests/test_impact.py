"""Change impact (reference.md section 4) and `motivml diff`."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from motivml.binding.impact import Impact, classify
from motivml.cli import main
from motivml.language.model import OFF, Binding, FeatureState

REBUILD, RESTART, RUN_TIME = Impact.REBUILD, Impact.RESTART, Impact.RUN_TIME

STATES: list[FeatureState] = [OFF, *Binding]

# Straight from the spec's sentences, one row per `before`.
EXPECTED = {
    ("off", "SE"): REBUILD, ("off", "SL"): RUN_TIME, ("off", "DE"): RUN_TIME, ("off", "DL"): RUN_TIME,
    ("SE", "off"): REBUILD, ("SE", "SL"): REBUILD, ("SE", "DE"): REBUILD, ("SE", "DL"): REBUILD,
    ("SL", "off"): RESTART, ("SL", "SE"): REBUILD, ("SL", "DE"): RESTART, ("SL", "DL"): RESTART,
    ("DE", "off"): RUN_TIME, ("DE", "SE"): REBUILD, ("DE", "SL"): RESTART, ("DE", "DL"): RUN_TIME,
    ("DL", "off"): RUN_TIME, ("DL", "SE"): REBUILD, ("DL", "SL"): RESTART, ("DL", "DE"): RUN_TIME,
}  # fmt: skip


@pytest.mark.parametrize(("before", "after"), [p for p in itertools.product(STATES, STATES) if p[0] != p[1]])
def test_classification(before: FeatureState, after: FeatureState) -> None:
    assert classify(before, after)[0] == EXPECTED[(before, after)]


def robot(tmp_path: Path) -> Path:
    (tmp_path / "variants").mkdir()
    (tmp_path / "model.json").write_text(
        json.dumps(
            {
                "id": "bot",
                "name": "Bot",
                "sub": [
                    {
                        "id": "slam",
                        "name": "SLAM",
                        "isMandatory": False,
                        "constraints": {"bindingTimeAllowed": "Any", "bindingModeAllowed": "Any"},
                    },
                    {"id": "amcl", "name": "AMCL", "isMandatory": False},
                ],
            }
        )
    )
    variants = {
        "a": [
            {"id": "slam", "props": {"time": "Late", "mode": "Dynamic"}},
            {"id": "amcl", "selected": False},
        ],
        "b": [{"id": "slam", "selected": False}, {"id": "amcl", "selected": False}],
        "c": [{"id": "slam", "selected": False}, {"id": "amcl"}],
    }
    for name, properties in variants.items():
        (tmp_path / "variants" / f"{name}.json").write_text(json.dumps({"properties": properties}))
    return tmp_path


def test_diff_run_time_swap_exits_0(tmp_path: Path) -> None:
    result = CliRunner().invoke(main, ["diff", str(robot(tmp_path)), "a", "b"])
    assert result.exit_code == 0
    assert result.output.splitlines() == [
        "run time  slam: DL -> off  a Dynamic feature leaves: it is unloaded while the program runs",
        "a -> b: 1 change; can be swapped while the robot runs",
    ]


def test_diff_rebuild_exits_4_with_json(tmp_path: Path) -> None:
    """Its own code, so that a script can tell "needs a rebuild" from "a variant is invalid" (1)."""
    result = CliRunner().invoke(main, ["diff", str(robot(tmp_path)), "a", "c", "--format", "json"])
    assert result.exit_code == 4
    data = json.loads(result.output)
    assert data["needs"] == "rebuild" and data["swappable_at_run_time"] is False
    assert [(c["feature"], c["before"], c["after"], c["impact"]) for c in data["changes"]] == [
        ("amcl", "off", "SE", "rebuild"),
        ("slam", "DL", "off", "run time"),
    ]


def test_diff_of_an_invalid_variant_exits_1() -> None:
    simplebot = Path(__file__).resolve().parent.parent / "feature_models" / "simplebot"
    result = CliRunner().invoke(main, ["diff", str(simplebot), "lab", "broken_gridmap_dynamic"])
    assert result.exit_code == 1 and "nothing to compare" in result.output

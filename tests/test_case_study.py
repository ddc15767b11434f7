"""The laundry-gripping case study end to end, in simulated time."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from paths import FEATURE_MODELS as ROOT

from motivml.cli import main
from motivml.runtime.launch import launch

LAUNDRY = ROOT / "laundry_gripping"
STATES = [
    "Calibration",
    "RedundancyLearning",
    "Exploring",
    "Consolidating",
    "Execution",
    "ApproachPleat",
    "Grip",
    "OpenGripper",
    "Done",
]


@pytest.mark.parametrize(("variant", "tolerance"), [("learned", 0.02), ("engineered", 0.001)])
def test_the_laundry_system_grips_the_pleat(variant: str, tolerance: float) -> None:
    robot = launch(LAUNDRY, variant)
    try:
        coordinator = robot.coordinate(simulated=True)
        assert coordinator is not None
        robot.runtime.run(60.0, until=lambda rt: coordinator.finished is not None)
        entered = [state for _, _, kind, state in coordinator.history if kind == "entered"]
        assert entered == STATES
        assert coordinator.finished is not None and 29.0 < coordinator.finished[0] < 32.0
        values = robot.assembly.values
        pleat = np.array([0.05 + 0.0015 * 410.0, 0.75 - 0.0015 * 180.0])  # the camera model, by hand
        assert np.allclose(values["PleatPosition"], pleat, atol=1e-3)  # the calibration, learned or measured
        assert np.linalg.norm(values["HandPosition"] - pleat) < tolerance  # the arm is at the pleat
        assert values["GripperCommand"][0] < 0.05  # gripped, then opened
    finally:
        robot.close()


def test_the_case_study_runs_from_the_command_line() -> None:
    result = CliRunner().invoke(
        main,
        [
            "run",
            str(LAUNDRY),
            "--variant",
            "engineered",
            "--duration",
            "60",
            "--clock",
            "simulated",
            "--no-control",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "coordination: the pleat was gripped" in result.output
    assert result.output.splitlines()[-1].startswith("coordination reached its final state Done at 30.0")

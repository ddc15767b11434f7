"""Coordination statecharts: validation, semantics in simulated time, SCXML, the CLI."""

from __future__ import annotations

import copy
import json
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from paths import ROOT

from motivml.cli import main
from motivml.runtime.launch import launch

ARM = ROOT / "feature_models" / "coordinated_arm"  # the reaching arm (links) with a coordination.json
QSCXMLC = Path("/usr/lib/qt6/libexec/qscxmlc")
COORDINATION: dict[str, Any] = json.loads((ARM / "coordination.json").read_text())


def robot_with(tmp_path: Path, coordination: dict[str, Any]) -> Path:
    """The reaching arm with another coordination.json."""
    folder = tmp_path / "arm"
    shutil.copytree(ARM, folder)
    (folder / "coordination.json").write_text(json.dumps(coordination, indent=1))
    return folder


def messages(tmp_path: Path, coordination: dict[str, Any], variant: str = "dmp") -> list[str]:
    result = CliRunner().invoke(
        main, ["validate", str(robot_with(tmp_path, coordination)), "--variant", variant]
    )
    return [
        line.split(": ", 1)[1]
        for line in result.output.splitlines()
        if "coordination.json:" in line and ": $" in line
    ]


def changed(edit: Any) -> dict[str, Any]:
    document = copy.deepcopy(COORDINATION)
    edit(document)
    return document


def working(document: dict[str, Any]) -> dict[str, Any]:
    state: dict[str, Any] = document["states"][0]
    return state


CASES = {
    "unknown state": (
        lambda d: working(d)["transitions"][0].update(target="Gone"),
        "$.states[0].transitions[0].target: error: Working has a transition to unknown state 'Gone'",
    ),
    "duplicate state": (
        lambda d: working(d)["states"][2].update(id="ComeBack"),
        "$.states[0].states[2].id: error: state 'ComeBack' is defined twice",
    ),
    "compound state without initial": (
        lambda d: working(d).pop("initial"),
        "$.states[0].id: error: compound state Working needs an initial sub-state (ReachOut, ComeBack, Rest)",
    ),
    "condition on a component without that criterion": (
        lambda d: working(d)["states"][0]["transitions"][0]["when"][0].update(**{"is": "tracking"}),
        "$.states[0].states[0].transitions[0].when[0].is: error: DMPReacher has a convergence criterion, so it is never "
        "tracking (a condition on a component needs its tracking criterion)",
    ),
    "data of the wrong dimension": (
        lambda d: working(d)["states"][1]["entry"][0]["send"].update(value=[0.0, 0.0]),
        "$.states[0].states[1].entry[0].send.value: error: ArmGoal holds JointAngles(3), not 2 numbers",
    ),
    "data of the wrong type": (
        lambda d: working(d)["states"][0]["entry"][0]["send"].update(type="Pose"),
        "$.states[0].states[0].entry[0].send.type: error: ArmGoal holds JointAngles, not Pose",
    ),
    "data in another unit": (
        lambda d: working(d)["states"][0]["entry"][0]["send"].update(unit="deg"),
        "$.states[0].states[0].entry[0].send.unit: warning: ArmGoal is in rad, not deg",
    ),
    "unknown space": (
        lambda d: working(d)["states"][1]["entry"][0]["send"].update(space="ArmGaol"),
        "$.states[0].states[1].entry[0].send.space: error: unknown space 'ArmGaol'",
    ),
    "unreachable state": (
        lambda d: d["states"].insert(1, {"id": "Limbo", "transitions": [{"target": "Done", "event": "go"}]}),
        "$.states[1].id: warning: state Limbo can never be entered",
    ),
    "no way out": (
        lambda d: working(d)["states"][2].pop("transitions") and working(d).pop("transitions"),
        "$.states[0].states[2].id: warning: state Rest has no way out and is not final",
    ),
    "feature not in the variant": (
        lambda d: working(d)["states"][2]["transitions"][0].update(actions=[{"load": ["attractor_reach"]}]),
        "$.states[0].states[2].transitions[0].actions[0].load[0]: error: load attractor_reach: attractor_reach is not "
        "in variant dmp",
    ),
    "final state with transitions": (
        lambda d: d["states"][1].update(transitions=[{"target": "Working", "event": "again"}]),
        "$.states[1].final: error: final state Done has sub-states or transitions",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_validation(tmp_path: Path, case: str) -> None:
    edit, expected = CASES[case]
    assert expected in messages(tmp_path, changed(edit))


def test_the_shipped_coordination_is_valid_for_every_variant() -> None:
    result = CliRunner().invoke(main, ["validate", str(ARM)])
    assert "valid: " + str(ARM / "coordination.json") + ", 0 errors, 4 warnings" in result.output
    # each primitive's component is named in a condition, and each variant has one of them
    assert (
        "component DMPReacher belongs to dmp_reach, which variant attractor does not select" in result.output
    )


def test_deep_nesting_is_refused_without_a_traceback(tmp_path: Path) -> None:
    state: dict[str, Any] = {"id": "S0", "final": True}
    for i in range(1, 200):
        state = {"id": f"S{i}", "initial": f"S{i - 1}", "states": [state]}
    result = CliRunner().invoke(
        main, ["validate", str(robot_with(tmp_path, {"initial": "S199", "states": [state]}))]
    )
    assert result.exit_code == 1 and "states nest deeper than 64 levels" in result.output


# ------------------------------------------------------------------------- semantics
SEMANTICS = {
    "initial": "Outer",
    "states": [
        {
            "id": "Outer",
            "initial": "Inner",
            "entry": [{"log": "enter Outer"}],
            "exit": [{"log": "exit Outer"}],
            "transitions": [{"target": "Other", "event": "go", "actions": [{"log": "outer transition"}]}],
            "states": [
                {
                    "id": "Inner",
                    "entry": [{"log": "enter Inner"}],
                    "exit": [{"log": "exit Inner"}],
                    "transitions": [
                        {"target": "Final", "event": "go", "actions": [{"log": "first inner transition"}]},
                        {"target": "Other", "event": "go", "actions": [{"log": "second inner transition"}]},
                    ],
                }
            ],
        },
        {"id": "Other", "transitions": [{"target": "Final", "after": 0.25}]},
        {"id": "Final", "final": True, "entry": [{"log": "enter Final"}]},
    ],
}


def test_entry_exit_order_priority_and_final_states(tmp_path: Path) -> None:
    robot = launch(robot_with(tmp_path, SEMANTICS), "dmp")
    try:
        coordinator = robot.coordinate(simulated=True)
        assert coordinator is not None
        robot.runtime.run(0.1)
        assert coordinator.configuration() == ["Outer", "Inner"]
        coordinator.event("go")
        robot.runtime.run(0.1)
        log = [text.removeprefix("coordination: ") for _, _, text in robot.runtime.notes]
        assert log == [
            "enter Outer",  # outermost first
            "enter Inner",
            "entered Outer",  # (the log of a step's states follows its actions)
            "entered Inner",
            "exit Inner",  # innermost first
            "exit Outer",
            "first inner transition",  # inner beats outer, and the first in document order wins
            "enter Final",
            "entered Final",
        ]
        assert coordinator.finished is not None and coordinator.finished[2] == "Final"
    finally:
        robot.close()


def test_time_conditions_use_control_time(tmp_path: Path) -> None:
    document = copy.deepcopy(SEMANTICS)
    document["states"][0]["states"][0]["transitions"] = []
    robot = launch(robot_with(tmp_path, document), "dmp")
    try:
        coordinator = robot.coordinate(simulated=True)
        assert coordinator is not None
        robot.runtime.run(0.05)
        coordinator.event("go")  # the outer transition now
        robot.runtime.run(1.0)
        entered = [(round(t, 3), s) for t, _, kind, s in coordinator.history if kind == "entered"]
        assert entered == [(0.001, "Outer"), (0.001, "Inner"), (0.051, "Other"), (0.301, "Final")]
    finally:
        robot.close()


def test_the_arm_runs_its_coordination_to_the_final_state() -> None:
    result = CliRunner().invoke(
        main,
        ["run", str(ARM), "--variant", "dmp", "--duration", "20", "--clock", "simulated", "--no-control"],
    )
    assert result.exit_code == 0, result.output
    entered = [
        line.split("entered ")[1] for line in result.output.splitlines() if "coordination: entered" in line
    ]
    assert entered == ["Working", "ReachOut", "ComeBack", "Rest", "Done"]
    assert result.output.splitlines()[-1].startswith("coordination reached its final state Done at 3.2")
    stopped = CliRunner().invoke(
        main,
        [
            "run",
            str(ARM),
            "--variant",
            "attractor",
            "--clock",
            "simulated",
            "--no-control",
            "--at",
            "0.5",
            "event stop",
        ],
    )
    assert "coordination: stopped by the operator" in stopped.output
    assert (
        stopped.output.splitlines()[-1] == "coordination reached its final state Done at 0.501 s (tick 501)"
    )


# ------------------------------------------------------------------------------ SCXML
def test_the_scxml_export_is_accepted_by_qt_and_says_what_the_document_says(tmp_path: Path) -> None:
    target = tmp_path / "arm.scxml"
    result = CliRunner().invoke(main, ["export", "scxml", str(ARM), "-o", str(target)])
    assert result.exit_code == 0, result.output
    root = ET.parse(target).getroot()
    ns = {"s": "http://www.w3.org/2005/07/scxml", "m": "urn:motivml:coordination:1"}
    assert root.get("initial") == "Working" and [f.get("id") for f in root.findall("s:final", ns)] == ["Done"]
    when = [
        t.get("{urn:motivml:coordination:1}when")
        for t in root.iterfind(".//s:state[@id='ReachOut']/s:transition", ns)
    ]
    assert when == ["component DMPReacher is converged", "component AttractorReacher is converged"]
    assert root.find(".//s:state[@id='Rest']/s:onentry/s:send", ns).get("delay") == "500ms"  # type: ignore[union-attr]
    raised = root.find(".//s:state[@id='ReachOut']/s:onentry/s:raise", ns)
    assert (
        raised is not None and raised.get("event") == "motivml.condition"
    )  # conditions true on entry are seen
    if not QSCXMLC.exists():
        pytest.fail("Qt's qscxmlc is missing: .ci/run installs libqt6scxml6-bin")
    accepted = subprocess.run(
        [str(QSCXMLC), str(target), "-o", str(tmp_path / "chart")], capture_output=True, text=True
    )
    assert accepted.returncode == 0, accepted.stderr
    assert (tmp_path / "chart.h").exists() and (tmp_path / "chart.cpp").exists()
    broken = tmp_path / "broken.scxml"
    broken.write_text(target.read_text().replace('target="Rest"', 'target="Nowhere"'))
    refused = subprocess.run(
        [str(QSCXMLC), str(broken), "-o", str(tmp_path / "no")], capture_output=True, text=True
    )
    assert refused.returncode != 0 and "Nowhere" in refused.stderr  # the engine really checks


# ------------------------------------------------------------------ review findings
MORE_CASES = {
    "unknown component": (
        lambda d: working(d)["states"][0]["transitions"][0]["when"][0].update(component="Reacher"),
        "$.states[0].states[0].transitions[0].when[0].component: error: unknown component 'Reacher'",
    ),
    "transition with nothing to wait for": (
        lambda d: working(d)["states"][2]["transitions"][0].pop("after"),
        "$.states[0].states[2].transitions[0]: warning: a transition of Rest has no event, time or condition: it fires at once",
    ),
    "reserved event name": (
        lambda d: working(d)["transitions"][0].update(event="done"),
        "$.states[0].transitions[0].event: error: event name 'done' is reserved (SCXML would match its own done.* events)",
    ),
    "a cycle that never settles": (
        lambda d: working(d)["states"][2].update(transitions=[{"target": "Rest"}]),
        "$.states[0].states[2].transitions: error: state Rest leads back to itself through transitions with no event, "
        "time or condition: the chart would never settle",
    ),
}


@pytest.mark.parametrize("case", list(MORE_CASES))
def test_more_validation(tmp_path: Path, case: str) -> None:
    edit, expected = MORE_CASES[case]
    assert expected in messages(tmp_path, changed(edit))


def test_states_reached_through_an_ancestor_are_reachable(tmp_path: Path) -> None:
    document = {
        "initial": "A",
        "states": [
            {"id": "A", "transitions": [{"target": "X", "event": "go"}]},
            {
                "id": "B",
                "initial": "Y",
                "transitions": [{"target": "C", "event": "next"}],
                "states": [{"id": "Y"}, {"id": "X"}],
            },
            {"id": "C", "transitions": [{"target": "Done", "event": "end"}]},
            {"id": "Done", "final": True},
        ],
    }
    assert not [m for m in messages(tmp_path, document) if "can never be entered" in m]


def test_odd_values_are_refused_or_exported_safely(tmp_path: Path) -> None:
    huge = changed(lambda d: working(d)["states"][1]["entry"][0]["send"].update(value=[10**400, 0, 0]))
    result = CliRunner().invoke(main, ["validate", str(robot_with(tmp_path / "huge", huge))])
    assert result.exit_code == 1 and "digits is out of range" in result.output
    control = changed(lambda d: working(d)["entry"][0].update(log="a\u0001b"))
    result = CliRunner().invoke(main, ["validate", str(robot_with(tmp_path / "control", control))])
    assert result.exit_code == 1 and "entry[0].log" in result.output
    odd = changed(lambda d: working(d)["states"][2]["transitions"][0].update(after=1234.5678))
    target = tmp_path / "odd.scxml"
    assert (
        CliRunner()
        .invoke(main, ["export", "scxml", str(robot_with(tmp_path / "odd", odd)), "-o", str(target)])
        .exit_code
        == 0
    )
    assert 'delay="1234568ms"' in target.read_text() and 'id="motivml.after.Rest.0"' in target.read_text()


def test_a_chart_that_never_settles_stops_the_run(tmp_path: Path) -> None:
    looping = {
        "initial": "A",
        "states": [
            {
                "id": "A",
                "transitions": [{"target": "B", "when": [{"module": "ReachDMP", "is": "executing"}]}],
            },
            {
                "id": "B",
                "transitions": [{"target": "A", "when": [{"module": "ReachDMP", "is": "executing"}]}],
            },
        ],
    }
    result = CliRunner().invoke(
        main,
        [
            "run",
            str(robot_with(tmp_path, looping)),
            "--variant",
            "dmp",
            "--clock",
            "simulated",
            "--no-control",
        ],
    )
    assert (
        "coordination: did not settle within 1000 steps (a cycle of transitions?): the run stops"
        in result.output
    )
    assert result.exit_code == 1


def test_keywords_and_an_invalid_architecture_are_said_so(tmp_path: Path) -> None:
    keyword = changed(
        lambda d: d["states"][1].update(id="delete") or working(d)["transitions"][0].update(target="delete")
    )
    assert (
        "$.states[1].id: warning: state id 'delete' is a C++ keyword: Qt's SCXML compiler would generate code that does not build"
        in messages(tmp_path / "k", keyword)
    )
    folder = robot_with(tmp_path / "a", COORDINATION)
    (folder / "architecture.json").unlink()
    (folder / "architecture.json").write_text('{"spaces": [{"id": "X"}]}')
    result = CliRunner().invoke(main, ["validate", str(folder), "--variant", "dmp"])
    assert (
        "architecture.json is invalid (see its errors): the coordination's elements are not checked"
        in result.output
    )
    assert "the robot has no architecture.json" not in result.output


def test_a_send_to_a_space_a_running_component_writes_is_skipped_and_said(tmp_path: Path) -> None:
    document = changed(lambda d: working(d)["states"][0]["entry"][0]["send"].update(space="ArmCommand"))
    result = CliRunner().invoke(
        main,
        [
            "run",
            str(robot_with(tmp_path, document)),
            "--variant",
            "dmp",
            "--duration",
            "0.1",
            "--clock",
            "simulated",
            "--no-control",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "coordination: send to ArmCommand skipped: ArmCommand is written by DMPReacher" in result.output


# ------------------------------------------- actions on the running robot (coverage)
def notes(robot: Any) -> list[str]:
    return [text for _, _, text in robot.runtime.notes]


def component_status(robot: Any, name: str) -> str:
    return next(c.status for c in robot.runtime.status().components if c.id == name)


RECONFIGURING = {
    "initial": "Swap",
    "states": [
        {
            "id": "Swap",
            "entry": [
                {"swap": ["dmp_reach", "attractor_reach"]},
                {"learning": {"module": "ReachDMP", "state": "offlineLearning"}},
                {"start": "DMPReacher"},
                {"stop": "DMPReacher"},
                {"learning": {"module": "ReachAttractor", "state": "offlineLearning"}},
                {"unload": ["hand_monitor"]},
                {"send": {"space": "HandPosition", "value": [0.0, 0.0]}},
                {"load": ["dmp_reach"]},
            ],
            "transitions": [{"target": "Back", "event": "back"}],
        },
        {
            "id": "Back",
            "entry": [
                {"stop": "AttractorReacher"},
                {"learning": {"module": "ReachAttractor", "state": "executing"}},
                {"load": ["hand_monitor"]},
            ],
            "transitions": [{"target": "Done", "event": "end"}],
        },
        {"id": "Done", "final": True, "entry": [{"start": "AttractorReacher"}]},
    ],
}


def test_actions_reconfigure_the_running_robot_and_skip_what_is_not_active(tmp_path: Path) -> None:
    robot = launch(robot_with(tmp_path, RECONFIGURING), "swappable")
    try:
        coordinator = robot.coordinate(simulated=True)
        assert coordinator is not None and robot.binder.active >= {"dmp_reach", "hand_monitor"}
        robot.runtime.run(0.01)
        log = notes(robot)
        assert log[:6] == [
            "coordination: swap dmp_reach attractor_reach: accepted",
            "coordination: learning of ReachDMP skipped: its feature is not active",
            "coordination: start of DMPReacher skipped: its feature is not active",
            "coordination: stop of DMPReacher skipped: its feature is not active",
            "coordination: unload hand_monitor: accepted",
            "coordination: send to HandPosition skipped: its feature is not active",
        ]
        assert log[6].startswith(
            "refused load dmp_reach: dmp_reach and attractor_reach are alternatives"
        )  # the binder's log
        assert log[7].startswith(
            "coordination: load dmp_reach: refused: dmp_reach and attractor_reach are alternatives in reaching's "
            "XOR group, but dmp_reach would be active and attractor_reach would be active"
        )
        assert [c.request for c in robot.runtime.changes] == [
            "swap dmp_reach attractor_reach",
            "unload hand_monitor",
        ]
        assert [c.id for c in robot.assembly.components] == ["AttractorReacher"]
        assert "hand_monitor" not in robot.binder.active and "HandPosition" not in robot.assembly.values
        assert robot.assembly.modules["ReachAttractor"].state == "offlineLearning"
        coordinator.event("back")
        robot.runtime.run(0.01)
        assert component_status(robot, "AttractorReacher") == "stopped"
        assert robot.assembly.modules["ReachAttractor"].state == "executing"
        assert "hand_monitor" in robot.binder.active and "HandPosition" in robot.assembly.values
        coordinator.event("end")
        robot.runtime.run(0.01)
        assert coordinator.finished is not None and component_status(robot, "AttractorReacher") != "stopped"
    finally:
        robot.close()


def test_on_the_real_clock_a_reconfiguration_is_logged_when_its_outcome_arrives(tmp_path: Path) -> None:
    from motivml.runtime.loop import RealClock

    chart = {
        "initial": "Swap",
        "states": [
            {"id": "Swap", "entry": [{"swap": ["dmp_reach", "attractor_reach"]}, {"load": ["dmp_reach"]}]}
        ],
    }
    robot = launch(robot_with(tmp_path, chart), "swappable")
    try:
        robot.coordinate(simulated=False)  # prepared on the binder's thread, committed by a later tick

        def answered(runtime: Any) -> bool:
            return sum(": accepted" in t or ": refused" in t for t in notes(robot)) == 2

        robot.runtime.run(60.0, RealClock(), until=answered)
        assert answered(robot.runtime)
        swap, load = (t for t in notes(robot) if ": accepted" in t or ": refused" in t)
        assert swap == "coordination: swap dmp_reach attractor_reach: accepted"
        assert load.startswith(
            "coordination: load dmp_reach: refused: dmp_reach and attractor_reach are alternatives"
        )
        assert [c.id for c in robot.assembly.components] == ["AttractorReacher"]
    finally:
        robot.close()


def test_a_chart_whose_action_fails_stops_the_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # a checked chart's actions do not raise; a failure inside the runtime is simulated here
    from motivml.runtime.binder import Binder

    def broken(self: Any, request: Any) -> Any:
        raise RuntimeError("the binder broke")

    monkeypatch.setattr(Binder, "request_between_ticks", broken)
    chart = {
        "initial": "Load",
        "states": [{"id": "Load", "entry": [{"log": "loading"}, {"unload": ["hand_monitor"]}]}],
    }
    result = CliRunner().invoke(
        main,
        ["run", str(robot_with(tmp_path, chart)), "--variant", "swappable", "--duration", "1"]
        + ["--clock", "simulated", "--no-control"],
    )
    assert result.exit_code == 1, result.output
    failed = [line for line in result.output.splitlines() if "coordination failed" in line]
    assert len(failed) == 1 and failed[0].startswith(
        "at 0.001 s (tick 1): coordination failed: RuntimeError: the binder broke (at test_coordination.py:"
    )  # the error itself, not sismic's wrapper around the code it ran
    assert failed[0].endswith(": the run stops")
    assert "1 ticks, 0.001 s of control time" in result.output  # it stopped at once


def test_the_scxml_export_keeps_every_domain_action_and_module_condition(tmp_path: Path) -> None:
    chart = json.loads(json.dumps(RECONFIGURING))
    chart["states"][1]["transitions"] = [
        {"target": "Done", "when": [{"module": "ReachAttractor", "is": "executing"}]}
    ]
    folder = robot_with(tmp_path, chart)
    target = tmp_path / "chart.scxml"
    result = CliRunner().invoke(main, ["export", "scxml", str(folder), "-o", str(target)])
    assert result.exit_code == 0, result.output
    text = target.read_text()
    for element in (
        '<m:swap features="dmp_reach attractor_reach" />',
        '<m:learning module="ReachDMP" state="offlineLearning" />',
        '<m:start component="DMPReacher" />',
        '<m:stop component="DMPReacher" />',
        '<m:unload features="hand_monitor" />',
        '<m:send space="HandPosition" value="0.0 0.0" />',
        '<m:load features="dmp_reach" />',
        'm:when="module ReachAttractor is executing"',
    ):
        assert element in text, element

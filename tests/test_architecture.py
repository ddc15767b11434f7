"""architecture.json: schema and validation, one fixture per error kind, word for word."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from motivml.architecture.document import read_architecture
from motivml.architecture.elements import (
    Criterion,
    DMPParameters,
    Learner,
    OscillatorParameters,
    Port,
    Scale,
    Space,
)
from motivml.cli import main
from motivml.documents.loader import parse
from motivml.language.reader import read_model

MODEL = {
    "id": "arm",
    "name": "Arm",
    "sub": [
        {"id": "reaching", "name": "Reaching", "isMandatory": False},
        {"id": "gait", "name": "Gait", "isMandatory": False},
    ],
}

VALID: dict[str, Any] = {
    "spaces": [
        {"id": "pose_goal", "type": "Pose", "dimension": 6, "unit": "m, rad", "feature": "reaching"},
        {"id": "joint_goal", "type": "JointAngles", "dimension": 7, "unit": "rad", "feature": "reaching"},
        {"id": "joints", "type": "JointAngles", "dimension": 7, "unit": "rad", "feature": "arm"},
        {"id": "command", "type": "JointAngles", "dimension": 7, "unit": "rad", "feature": "arm"},
        {"id": "legs", "type": "JointAngles", "dimension": 4, "unit": "rad", "feature": "gait"},
    ],
    "mappings": [
        {
            "id": "ik",
            "kind": "adaptiveMapping",
            "from": "pose_goal",
            "to": "joint_goal",
            "learner": {"type": "elm"},
            "feature": "reaching",
        },
        {
            "id": "scale",
            "kind": "transformation",
            "from": "joint_goal",
            "to": "command",
            "function": {"type": "scale", "factor": 0.5},
            "feature": "reaching",
        },
    ],
    "modules": [
        {
            "id": "reach_dmp",
            "systems": [{"type": "dmp", "dimension": 7}],
            "learners": [{"type": "ridge", "mode": "offline"}],
            "feature": "reaching",
        },
        {"id": "cpg", "systems": [{"type": "oscillators", "dimension": 4}], "feature": "gait"},
    ],
    "components": [
        {
            "id": "reacher",
            "kind": "ReachingController",
            "module": "reach_dmp",
            "rate": 100,
            "goal": {"space": "pose_goal", "through": "ik"},
            "feedback": {"space": "joints"},
            "output": {"space": "command", "through": "scale"},
            "criterion": {"type": "convergence", "tolerance": 0.01},
            "feature": "reaching",
        },
        {
            "id": "walker",
            "kind": "PatternGenerator",
            "module": "cpg",
            "output": {"space": "legs"},
            "criterion": {"type": "tracking", "tolerance": 0.1},
            "feature": "gait",
        },
    ],
}


def problems(document: dict[str, Any]) -> list[str]:
    model, _ = read_model(parse(json.dumps(MODEL), "model.json"))
    _, diagnostics = read_architecture(parse(json.dumps(document, indent=1), "architecture.json"), model)
    return [f"{d.location.path}: {d.message}" for d in diagnostics]


def changed(section: str, index: int, **values: Any) -> dict[str, Any]:
    document = copy.deepcopy(VALID)
    document[section][index].update(values)
    return document


def test_the_valid_document_is_valid() -> None:
    assert problems(VALID) == []


CASES = {
    "schema": (
        changed("components", 0, kind="Reacher"),
        "$.components[0].kind: 'Reacher' is not one of 'ReachingController', 'TrackingController', 'Sequencer', 'PatternGenerator'",
    ),
    "unknown reference": (
        changed("components", 0, module="reach_dpm"),
        "$.components[0].module: reacher refers to unknown module 'reach_dpm' (did you mean 'reach_dmp'?)",
    ),
    "unknown feature": (
        changed("spaces", 4, feature="legs"),
        "$.spaces[4].feature: legs is brought by 'legs', which is not a feature of the model",
    ),
    "duplicate id": (
        changed("modules", 1, id="reach_dmp"),
        "$.modules[1].id: id 'reach_dmp' is used twice (also a module)",
    ),
    "transformation between types": (
        changed("mappings", 1, **{"from": "pose_goal"}),
        "$.mappings[1].kind: transformation scale changes pose_goal: Pose(6) [m, rad] into command: "
        "JointAngles(7) [rad]: a transformation stays within one type and dimension (use a mapping)",
    ),
    "mapping within a type": (
        changed("mappings", 0, to="pose_goal"),
        "$.mappings[0].kind: adaptiveMapping ik stays within Pose: use a transformation",
    ),
    "incompatible goal and feedback": (
        changed("components", 0, feedback={"space": "pose_goal"}),
        "$.components[0].feedback: the goal (joint_goal: JointAngles(7) [rad]) and feedback (pose_goal: Pose(6) "
        "[m, rad]) of reacher meet in incompatible spaces",
    ),
    "dimension of a port": (
        changed("components", 1, output={"space": "command"}),
        "$.components[1].output: the output of walker is command: JointAngles(7) [rad] but module cpg has dimension 4",
    ),
    "mapping on the wrong port": (
        changed("components", 0, feedback={"space": "joints", "through": "ik"}),
        "$.components[0].feedback.through: ik connects pose_goal to joint_goal, not joints on the feedback of reacher",
    ),
    "criterion unfit for the kind": (
        changed("components", 1, criterion={"type": "convergence", "tolerance": 0.1}),
        "$.components[1].criterion.type: a convergence criterion does not fit a PatternGenerator (it fits "
        "ReachingController, Sequencer)",
    ),
    "system unfit for the kind": (
        changed(
            "components", 1, kind="ReachingController", criterion={"type": "convergence", "tolerance": 0.1}
        ),
        "$.components[1].module: a ReachingController cannot run oscillators (module cpg)",
    ),
    "initial value of the wrong length": (
        changed("spaces", 4, initial=[0.0, 1.0]),
        "$.spaces[4].initial: the initial value of legs: JointAngles(4) [rad] has 2 numbers",
    ),
    "mapping without a function": (
        changed("mappings", 0, kind="mapping"),
        "$.mappings[0].kind: mapping ik needs a function: linear or planarArm",
    ),
    "function unfit for the kind": (
        changed("mappings", 1, function={"type": "planarArm", "links": [1.0]}),
        "$.mappings[1].function.type: a transformation cannot compute planarArm (it can: linear, scale)",
    ),
    "inverse kinematics of the wrong shape": (
        changed("mappings", 0, kind="mapping", function={"type": "planarArmIK", "links": [0.4, 0.3, 0.2]}),
        "$.mappings[0].function.links: the inverse kinematics of ik maps a 2-dimensional position to 2 or 3 joint "
        "angles, not pose_goal: Pose(6) [m, rad] with 3 links",
    ),
    "matrix of the wrong shape": (
        changed("mappings", 1, function={"type": "linear", "matrix": [[1.0, 0.0]]}),
        "$.mappings[1].function.matrix: the matrix of scale must be 7 x 7 (command from joint_goal)",
    ),
    "adaptive mapping without a learner": (
        changed("mappings", 0, learner=None)
        | {
            "mappings": [
                {k: v for k, v in VALID["mappings"][0].items() if k != "learner"},
                VALID["mappings"][1],
            ]
        },
        "$.mappings[0].kind: adaptive mapping ik needs a learner",
    ),
    "parameter of another system": (
        changed("modules", 1, systems=[{"type": "oscillators", "dimension": 4, "basis": 10}]),
        "$.modules[1].systems[0].basis: basis is not a parameter of oscillators",
    ),
    "offsets of the wrong length": (
        changed("modules", 1, systems=[{"type": "oscillators", "dimension": 4, "offsets": [0.0, 3.1]}]),
        "$.modules[1].systems[0].offsets: offsets of cpg needs 4 numbers",
    ),
    "sequence on another kind": (
        changed("components", 0, sequence=[[0.0] * 7]),
        "$.components[0].sequence: only a Sequencer has a sequence, not a ReachingController",
    ),
    "learner that does not fit a module": (
        changed("modules", 1, learners=[{"type": "elm"}]),
        "$.modules[1].learners[0].type: a module's learner is ridge regression of its DMPs' weights, so elm does "
        "not fit module cpg (it has no DMP) (an elm learns in an adaptive mapping)",
    ),
    "module shared by two components": (
        changed(
            "components",
            1,
            module="reach_dmp",
            kind="ReachingController",
            criterion={"type": "convergence", "tolerance": 0.1},
            output={"space": "joints"},
        ),
        "$.components[1].module: module reach_dmp already runs in component reacher: each component needs a module of its own",
    ),
    "two writers of one space": (
        {
            **VALID,
            "mappings": VALID["mappings"]
            + [{"id": "copy", "kind": "transformation", "from": "joints", "to": "command", "feature": "arm"}],
        },
        "$.mappings[2].to: command is written by component reacher and computed by copy: a space has one kind of writer",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_error_kind(case: str) -> None:
    """The first message is the one of this kind (a wrong wire may also misfit what follows it)."""
    document, expected = CASES[case]
    assert problems(document)[0] == expected


def test_goal_cycles_are_refused_with_the_chain() -> None:
    document = copy.deepcopy(VALID)
    document["components"][0]["output"] = {"space": "joint_goal"}
    document["components"][0]["goal"] = {"space": "joint_goal"}
    document["mappings"].pop(0)  # ik would compute joint_goal, a second writer
    assert problems(document) == [
        "$.components[0].goal: components wait on each other's output within a tick: reacher -> reacher"
    ]


def test_a_checked_document_becomes_typed_elements() -> None:
    """Elements hold each other, not ids; what the document leaves out is a default or None."""
    model, _ = read_model(parse(json.dumps(MODEL), "model.json"))
    architecture, _ = read_architecture(parse(json.dumps(VALID), "architecture.json"), model)
    assert architecture is not None
    spaces, mappings, modules = architecture.spaces, architecture.mappings, architecture.modules
    reacher, walker = architecture.components["reacher"], architecture.components["walker"]
    assert reacher.module is modules["reach_dmp"] and reacher.output.space is spaces["command"]
    assert reacher.goal == Port(spaces["pose_goal"], mappings["ik"])
    assert reacher.feedback == Port(spaces["joints"])
    assert (reacher.rate, reacher.criterion, reacher.sequence) == (100, Criterion("convergence", 0.01), ())
    assert [name for name, _ in walker.ports()] == ["output"] and walker.rate is None
    ik = mappings["ik"]
    assert (ik.kind, ik.source, ik.target) == ("adaptiveMapping", spaces["pose_goal"], spaces["joint_goal"])
    assert ik.learner == Learner("elm") and ik.function is None and ik.teacher is None
    assert mappings["scale"].function == Scale(0.5)
    assert modules["reach_dmp"].systems == (DMPParameters(7),)
    assert modules["reach_dmp"].learners == (Learner("ridge", "offline"),)
    assert modules["cpg"].systems == (OscillatorParameters(4),) and modules["cpg"].state == "executing"
    assert spaces["pose_goal"] == Space("pose_goal", "Pose", 6, "reaching", "m, rad")
    assert [e.id for e in architecture.elements()][-4:] == ["reach_dmp", "cpg", "reacher", "walker"]


def test_elements_of_active_features() -> None:
    model, _ = read_model(parse(json.dumps(MODEL), "model.json"))
    architecture, _ = read_architecture(parse(json.dumps(VALID), "architecture.json"), model)
    assert architecture is not None
    active = architecture.elements_of({"arm", "gait"})
    assert sorted(active.spaces) == ["command", "joints", "legs"] and list(active.components) == ["walker"]


def test_validate_checks_the_robot_folders_architecture(tmp_path: Path) -> None:
    (tmp_path / "model.json").write_text(json.dumps(MODEL))
    (tmp_path / "architecture.json").write_text(json.dumps(changed("components", 0, module="nope"), indent=1))
    result = CliRunner().invoke(main, ["validate", str(tmp_path)])
    assert result.exit_code == 1
    assert "architecture.json" in result.output and "reacher refers to unknown module 'nope'" in result.output
    assert result.output.splitlines()[-1].endswith("1 error, 0 warnings in the architecture")


from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis_jsonschema import from_schema  # noqa: E402

from motivml.documents.schema import load_schema  # noqa: E402


def _small(schema: dict[str, Any]) -> dict[str, Any]:
    """The architecture schema with ids from a small set, so references sometimes resolve."""
    schema = copy.deepcopy(schema)
    schema["$defs"]["id"] = {"enum": ["a", "b", "arm", "reaching", "gait"]}
    for section in ("spaces", "mappings", "modules", "components"):
        schema["properties"][section]["maxItems"] = 3
    defs = schema.pop("$defs")

    def inline(node: Any) -> Any:  # the schema is not recursive: replace every $ref by its target
        if isinstance(node, list):
            return [inline(n) for n in node]
        if not isinstance(node, dict):
            return node
        if "$ref" in node:
            return inline(defs[node["$ref"].removeprefix("#/$defs/")])
        return {k: inline(v) for k, v in node.items()}

    schema = inline(schema)
    schema.pop("$id", None)
    return schema


@pytest.mark.slow
@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
@given(document=from_schema(_small(load_schema("architecture.schema.json"))))
def test_schema_valid_documents_never_crash(document: dict[str, Any]) -> None:
    for line in problems(document):
        assert line.startswith("$.")


def test_an_element_using_one_of_a_feature_that_can_be_inactive_is_an_error(tmp_path: Path) -> None:
    """Family-wide: some variant activates gait without reaching, so walker could not be built."""
    from motivml.validate import validate_architecture

    document = copy.deepcopy(VALID)
    document["spaces"].append(
        {"id": "gait_out", "type": "JointAngles", "dimension": 4, "feature": "reaching"}
    )
    document["components"][1]["output"] = {"space": "gait_out"}
    path = tmp_path / "architecture.json"
    path.write_text(json.dumps(document, indent=1))
    model, _ = read_model(parse(json.dumps(MODEL), "model.json"))
    report = validate_architecture(model, path)
    assert [f"{d.location.path}: {d.message}" for d in report.diagnostics] == [
        "$.components[1].output.space: walker (feature gait) uses space gait_out of feature reaching, but the model "
        "lets reaching be inactive while gait is active: bring both with one feature, or make gait include reaching"
    ]
    included = copy.deepcopy(MODEL)
    included["sub"][1]["constraints"] = {"featuresIncluded": ["reaching"]}
    model, _ = read_model(parse(json.dumps(included), "model.json"))
    assert validate_architecture(model, path).diagnostics == []

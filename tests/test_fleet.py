"""A fleet file (reference.md section 9): each robot's variant with the fleet's overrides in
layers, checked robot by robot, every message located where its entry was written and
naming the robot and the layers involved (issue 35)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from paths import ROOT, SIMPLEBOT

from motivml.cli import main
from motivml.fleet import validate_fleet


def fleet(tmp_path: Path, **document: Any) -> Path:
    path = tmp_path / "fleet.json"
    path.write_text(json.dumps(document, indent=2))
    return path


def robot(namespace: str, variant: str = "field", **more: Any) -> dict[str, Any]:
    return {"namespace": namespace, "robot": str(SIMPLEBOT), "variant": variant, **more}


def test_a_valid_fleet_checks_every_robot_with_its_layers(tmp_path: Path) -> None:
    path = fleet(
        tmp_path,
        overrides=[{"id": "orbslam", "selected": False}],
        groups={"indoor": {"overrides": [{"id": "kartoslam", "props": {"time": "Late", "mode": "Dynamic"}}]}},
        robots=[robot("bot1"), robot("/bot2", groups=["indoor"]), robot("bot3", "lab")],
    )
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 0, result.output
    lines = [" ".join(line.split()) for line in result.output.splitlines()]
    assert lines == [
        f"valid: robot /bot1 ({SIMPLEBOT}, variant field; variant field, fleet), 0 errors, 0 warnings",
        f"valid: robot /bot2 ({SIMPLEBOT}, variant field; variant field, fleet, group indoor), 0 errors, 0 warnings",
        f"valid: robot /bot3 ({SIMPLEBOT}, variant lab; variant lab, fleet), 0 errors, 0 warnings",
    ]


def test_a_later_layer_replaces_an_earlier_ones_entry(tmp_path: Path) -> None:
    path = fleet(
        tmp_path,
        overrides=[{"id": "orbslam", "selected": False}],
        groups={"g": {"overrides": [{"id": "orbslam", "props": {"time": "Late", "mode": "Dynamic"}}]}},
        robots=[robot("one", groups=["g"]), robot("two", groups=["g"], overrides=[{"id": "orbslam", "selected": False}])],
    )
    problems, robots = validate_fleet(path)
    assert problems == []
    one, two = (r.config.entries["orbslam"] for r in robots if r.config is not None)
    assert (one.selected, str(one.time), str(one.mode)) == (True, "Late", "Dynamic")  # the group's, over the fleet's
    assert two.selected is False  # the robot's own, over the group's


def test_a_conflicting_override_is_located_in_its_layer_and_names_robot_and_layers(tmp_path: Path) -> None:
    path = fleet(
        tmp_path,
        robots=[robot("ok"), robot("bad", "lab", overrides=[{"id": "grid_map", "props": {"mode": "Dynamic"}}])],
    )
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 1, result.output
    text = " ".join(result.output.split())
    assert f"valid: robot /ok ({SIMPLEBOT}, variant field; variant field), 0 errors" in text
    (problem,) = [r for r in validate_fleet(path)[1] if r.namespace == "/bad"][0].errors
    where = problem.location
    assert (Path(where.file), where.path) == (path, "$.robots[1].overrides[0].props.mode")
    assert problem.message.startswith("robot /bad: slam requires grid_map, but grid_map is configured Dynamic")
    assert problem.message.endswith("(set by: robot /bad, variant lab)")
    facts = {Path(f.location.file).name: f.text for f in problem.facts}
    assert facts["fleet.json"] == "grid_map is configured Dynamic" and facts["lab.json"] == "slam is selected"
    assert problem.repairs  # (the configuration's repairs, as validate --config gives them)
    assert f"invalid: robot /bad ({SIMPLEBOT}, variant lab; variant lab, robot /bad), 1 error, 0 warnings" in text


@pytest.mark.parametrize(
    ("document", "path", "message"),
    [
        ({"robots": [robot("a", groups=["night"])]}, "$.robots[0].groups[0]", "no group 'night' in the fleet file (groups: none)"),
        ({"robots": [robot("a"), robot("/a")]}, "$.robots[1].namespace", "/a is robot 1's namespace too"),
        ({"robots": [robot("a")], "colour": "red"}, "$.colour", "unknown key 'colour'"),
        ({"robots": []}, "$.robots", ""),
        ({"robots": [robot("a b")]}, "$.robots[0].namespace", ""),
    ],
    ids=["unknown group", "namespace twice", "unknown key", "no robot", "bad namespace"],
)
def test_the_fleet_files_own_errors_are_located_and_no_robot_is_checked(
    tmp_path: Path, document: dict[str, Any], path: str, message: str
) -> None:
    file = fleet(tmp_path, **document)
    problems, robots = validate_fleet(file)
    assert robots == [] and problems
    assert problems[0].location.path == path and message in problems[0].message
    result = CliRunner().invoke(main, ["validate", str(file)])
    assert result.exit_code == 1 and "in the fleet file" in result.output


def test_a_robot_folder_or_variant_that_is_not_there_is_said_at_the_robots_entry(tmp_path: Path) -> None:
    path = fleet(tmp_path, robots=[robot("a", "nosuch"), {"namespace": "b", "robot": "nowhere", "variant": "v"}])
    _, robots = validate_fleet(path)
    (variant,), (folder,) = (r.errors for r in robots)
    assert variant.location.path == "$.robots[0].variant" and variant.message.startswith("robot /a: ")
    assert folder.location.path == "$.robots[1].robot" and "no such robot folder" in folder.message


def test_validate_fleet_in_json(tmp_path: Path) -> None:
    path = fleet(tmp_path, robots=[robot("a"), robot("b", overrides=[{"id": "slam", "selected": False}])])
    result = CliRunner().invoke(main, ["validate", str(path), "--format", "json"])
    payload = json.loads(result.output)
    assert result.exit_code == 1 and payload["valid"] is False
    assert [(d["file"], d["kind"], d["valid"]) for d in payload["documents"]] == [
        (str(path), "fleet file", True),
        (f"{path} /a", "robot's configuration", True),
        (f"{path} /b", "robot's configuration", False),
    ]


def test_the_fleet_schemas_entry_is_the_configurations() -> None:
    schemas = ROOT / "schemas"
    fleet_schema = json.loads((schemas / "fleet.schema.json").read_text())
    configuration = json.loads((schemas / "configuration.schema.json").read_text())
    assert fleet_schema["$defs"]["entry"] == configuration["$defs"]["entry"]


# ------------------------------------------------------------------ fleet plan
def test_a_plan_says_per_robot_what_moves_or_why_not_touching_nothing(tmp_path: Path) -> None:
    path = fleet(
        tmp_path,
        groups={"bays": {"overrides": [{"id": "kartoslam", "selected": False}]}},
        robots=[robot("bay1"), robot("bay2", groups=["bays"]), robot("yard")],
    )
    before = path.read_bytes()
    result = CliRunner().invoke(main, ["fleet", "plan", "--offline", str(path), "swap", "hectorslam", "kartoslam"])
    assert result.exit_code == 1, result.output
    lines = [" ".join(line.split()) for line in result.output.splitlines()]
    assert lines[0] == "/bay1: accepted: loads kartoslam; unloads hectorslam"
    assert lines[1].startswith(f"{path}:") and "$.groups.bays.overrides[0]" in lines[1]
    assert "robot /bay2: kartoslam is not selected in the variant" in lines[1] and lines[1].endswith("(set by: group bays)")
    assert "/bay2: refused" in lines and "/yard: accepted: loads kartoslam; unloads hectorslam" in lines
    assert lines[-1].startswith("swap hectorslam kartoslam: accepted by 2 of 3 robots, refused by 1 (checked against each robot's start state")
    assert path.read_bytes() == before


@pytest.mark.parametrize(("selector", "chosen"), [("bay*", ["/bay1", "/bay2"]), ("@bays", ["/bay2"]), ("/yard", ["/yard"])])
def test_robots_are_selected_by_a_namespace_glob_or_a_group(tmp_path: Path, selector: str, chosen: list[str]) -> None:
    from motivml.fleet import plan_fleet
    from motivml.runtime.requests import Swap

    path = fleet(tmp_path, groups={"bays": {}}, robots=[robot("bay1"), robot("bay2", groups=["bays"]), robot("yard")])
    problems, plans = plan_fleet(path, Swap("hectorslam", "kartoslam"), selector)
    assert problems == [] and [p.namespace for p in plans] == chosen and all(p.accepted for p in plans)


def test_a_plan_refuses_a_robot_whose_configuration_has_errors_and_a_change_that_is_not_one(tmp_path: Path) -> None:
    path = fleet(tmp_path, robots=[robot("a"), robot("b", overrides=[{"id": "slam", "selected": False}])])
    result = CliRunner().invoke(main, ["fleet", "plan", "--offline", str(path), "unload", "navigation"])
    assert result.exit_code == 1
    text = " ".join(result.output.split())
    assert "/a: accepted: unloads navigation" in text
    assert "$.robots[1]: error: robot /b: its configuration has errors (validate the fleet file): nothing planned" in text
    usage = CliRunner().invoke(main, ["fleet", "plan", "--offline", str(path), "swap", "hectorslam"])
    assert usage.exit_code == 2 and "swap needs two features" in usage.output
    nobody = CliRunner().invoke(main, ["fleet", "plan", "--offline", str(path), "unload", "navigation", "--robots", "/nobody*"])
    assert nobody.exit_code == 1 and "no robot" in nobody.output


# ------------------------------------------------------------------ from a review
def copy_of_simplebot(tmp_path: Path, **variants: Any) -> Path:
    import shutil

    folder = tmp_path / "rb"
    shutil.copytree(SIMPLEBOT, folder)
    for name, document in variants.items():
        (folder / "variants" / f"{name}.json").write_text(json.dumps(document))
    return folder


def test_a_variant_is_read_as_validate_reads_it_and_a_layer_decides_a_feature_once(tmp_path: Path) -> None:
    folder = copy_of_simplebot(
        tmp_path,
        noid={"partial": True, "properties": [{"selected": True}]},
        soon={"partial": True, "properties": [{"id": "slam", "props": {"time": "Soon"}}]},
        dup={"partial": True, "properties": [{"id": "slam"}, {"id": "slam"}]},
    )
    path = fleet(
        tmp_path,
        overrides=[{"id": "orbslam", "selected": False}, {"id": "orbslam"}],
        robots=[{"namespace": n, "robot": str(folder), "variant": n} for n in ("noid", "soon", "dup")],
    )
    problems, robots = validate_fleet(path)
    assert problems == []
    noid, soon, dup = (r.errors[0] for r in robots)
    assert Path(noid.location.file).name == "noid.json" and "missing required key 'id'" in noid.message
    assert Path(soon.location.file).name == "soon.json" and noid.message.startswith("robot /noid: ")
    assert Path(dup.location.file).name == "dup.json" and dup.location.path == "$.properties[1].id"
    assert "a second entry for 'slam' in variant dup" in dup.message
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 1 and "Traceback" not in result.output
    in_fleet = [d for d in robots[2].errors if Path(d.location.file).name == "fleet.json"]
    assert [d.location.path for d in in_fleet] == ["$.overrides[1].id"]  # (the fleet layer's own twice, too)
    assert "a second entry for 'orbslam' in fleet" in in_fleet[0].message


def test_an_incomplete_full_variant_is_said_in_its_file_and_partial_is_heard(tmp_path: Path) -> None:
    folder = copy_of_simplebot(tmp_path)
    full = json.loads((folder / "variants" / "field.json").read_text())
    full["properties"] = [e for e in full["properties"] if e["id"] != "amcl"]
    (folder / "variants" / "short.json").write_text(json.dumps(full))
    path = fleet(tmp_path, robots=[{"namespace": "a", "robot": str(folder), "variant": "short"}])
    (robot_report,) = validate_fleet(path)[1]
    (incomplete,) = robot_report.errors
    assert Path(incomplete.location.file).name == "short.json" and "amcl" in incomplete.message
    assert validate_fleet(path, partial=True)[1][0].valid
    assert CliRunner().invoke(main, ["validate", str(path), "--partial"]).exit_code == 0


def test_a_folder_without_a_model_is_said_at_the_robot_key(tmp_path: Path) -> None:
    (tmp_path / "empty").mkdir()
    path = fleet(tmp_path, robots=[{"namespace": "a", "robot": str(tmp_path / "empty"), "variant": "v"}])
    (report,) = validate_fleet(path)[1]
    (problem,) = report.errors
    assert problem.location.path == "$.robots[0].robot" and str(tmp_path / "empty") in problem.message


def test_an_unknown_group_selector_or_a_set_is_a_usage_error_and_a_group_is_listed_once(tmp_path: Path) -> None:
    path = fleet(tmp_path, groups={"bays": {}}, robots=[robot("a")])
    unknown = CliRunner().invoke(main, ["fleet", "plan", "--offline", str(path), "unload", "navigation", "--robots", "@nosuch"])
    assert unknown.exit_code == 2 and "no group 'nosuch' in the fleet file (groups: bays)" in unknown.output
    empty = CliRunner().invoke(main, ["fleet", "plan", "--offline", str(path), "unload", "navigation", "--robots", "@bays"])
    assert empty.exit_code == 1 and "no robot" in empty.output
    settled = CliRunner().invoke(main, ["fleet", "plan", "--offline", str(path), "set", "navigation"])
    assert settled.exit_code == 2 and "set takes +FEATURE and -FEATURE words" in settled.output
    event = CliRunner().invoke(main, ["fleet", "plan", "--offline", str(path), "event", "go"])
    assert event.exit_code == 2 and "event is not a change for a fleet" in event.output
    twice = fleet(tmp_path, groups={"g": {}}, robots=[robot("a", groups=["g", "g"])])
    problems, _ = validate_fleet(twice)
    assert problems and problems[0].location.path == "$.robots[0].groups"


def test_plan_on_a_fleet_file_with_errors_or_none_plans_nothing(tmp_path: Path) -> None:
    broken = fleet(tmp_path, robots=[robot("a", groups=["night"])])
    result = CliRunner().invoke(main, ["fleet", "plan", "--offline", str(broken), "unload", "navigation"])
    assert result.exit_code == 1 and "error in the fleet file: nothing planned" in " ".join(result.output.split())
    missing = CliRunner().invoke(main, ["fleet", "plan", "--offline", str(tmp_path / "nowhere.json"), "unload", "navigation"])
    assert missing.exit_code == 3 and "nowhere.json" in missing.output


# ------------------------------------------------------------------ run FLEET --ros-namespace NS
def test_a_fleet_robot_runs_its_variant_with_the_fleets_layers(tmp_path: Path) -> None:
    path = fleet(
        tmp_path,
        overrides=[{"id": "orbslam", "selected": False}],
        robots=[robot("a", overrides=[{"id": "hectorslam", "selected": False}]), robot("b", overrides=[{"id": "slam", "selected": False}])],
    )
    run = ["run", str(path), "--duration", "0.1", "--rate", "50", "--no-live", "--no-control"]
    a = CliRunner().invoke(main, [*run, "--ros-namespace", "/a"])
    assert a.exit_code == 0, a.output
    (said,) = [line for line in a.output.splitlines() if line.startswith("running simplebot variant field:")]
    assert "kartoslam" in said and "hectorslam" not in said  # (the robot's own layer, over its variant)
    b = CliRunner().invoke(main, [*run, "--ros-namespace", "b"])
    assert b.exit_code == 1 and f"cannot run: robot /b of {path}: its configuration has errors" in b.output
    assert f"{path}:" in b.output and "(set by: robot /b" in b.output
    nobody = CliRunner().invoke(main, [*run, "--ros-namespace", "/c"])
    assert nobody.exit_code == 2 and f"no robot of {path} has the namespace /c" in nobody.output
    both = CliRunner().invoke(main, [*run, "--ros-namespace", "/a", "--variant", "lab"])
    assert both.exit_code == 2 and "no --variant or --config with it" in both.output
    bare = CliRunner().invoke(main, run)
    assert bare.exit_code == 2 and "a fleet file needs --ros-namespace NS" in bare.output

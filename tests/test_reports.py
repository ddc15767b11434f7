"""validate --format sarif and --format junit (motivml/cli/reports.py), through click's CliRunner.

SARIF is checked against the official SARIF 2.1.0 schema (tests/data/, see its README), and
both formats against what --format json says of the same call: the same diagnostics, the
same documents.
"""

from __future__ import annotations

import ast
import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from jsonschema import Draft4Validator
from paths import ROOT

from motivml import __version__
from motivml.cli import main
from motivml.cli.reports import FAMILIES, REFERENCE_RULES, describe

SARIF_SCHEMA = json.loads((Path(__file__).parent / "data" / "sarif-schema-2.1.0.json").read_text())
SIMPLEBOT = "feature_models/simplebot"
EXAMPLES = "guidelines/examples"


@pytest.fixture(autouse=True)
def at_the_root(monkeypatch: pytest.MonkeyPatch) -> None:
    """Paths relative to the repository, as a CI job gives them."""
    monkeypatch.chdir(ROOT)


def validate(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, ["validate", *args])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    assert result.stderr == "", result.stderr  # the document alone goes out, on stdout
    return result.exit_code, result.stdout


def sarif(*args: str) -> tuple[int, dict[str, Any]]:
    """validate's SARIF for these arguments, checked against the SARIF 2.1.0 schema."""
    code, output = validate(*args, "--format", "sarif")
    log = json.loads(output)
    problems = sorted(Draft4Validator(SARIF_SCHEMA).iter_errors(log), key=str)
    assert not problems, [f"{list(p.absolute_path)}: {p.message}" for p in problems]
    return code, log


def as_json(*args: str) -> tuple[int, dict[str, Any]]:
    code, output = validate(*args, "--format", "json")
    data: dict[str, Any] = json.loads(output)
    return code, data


def region(item: dict[str, Any]) -> tuple[str, int | None, int | None]:
    physical = item["physicalLocation"]
    place = physical.get("region", {})
    return physical["artifactLocation"]["uri"], place.get("startLine"), place.get("startColumn")


CALLS = {
    "valid model": [f"{SIMPLEBOT}/model.json"],
    "valid variant": [SIMPLEBOT, "--variant", "lab"],
    "model with warnings": [f"{EXAMPLES}/dead.json"],
    "invalid model, located errors": [f"{EXAMPLES}/typo.json"],
    "configuration conflict with facts": [SIMPLEBOT, "--variant", "broken_gridmap_dynamic"],
    "robot folder, every variant": [SIMPLEBOT],
    "partial configuration": [SIMPLEBOT, "--config", f"{EXAMPLES}/gestures.json", "--partial"],
    "usage: an unknown variant": [SIMPLEBOT, "--variant", "nope"],
    "environment: no such file": [f"{EXAMPLES}/none.json"],
}


@pytest.mark.parametrize("args", CALLS.values(), ids=CALLS.keys())
def test_sarif_is_valid_sarif_and_says_what_json_says(args: list[str]) -> None:
    code, log = sarif(*args)
    json_code, data = as_json(*args)
    assert code == json_code
    (run,) = log["runs"]
    assert log["version"] == "2.1.0"
    assert run["tool"]["driver"]["name"] == "motivml" and run["tool"]["driver"]["version"] == __version__
    assert run["invocations"] == [{"executionSuccessful": code in (0, 1), "exitCode": code}]
    diagnostics = [(d, "error") for d in data["errors"]] + [(d, "warning") for d in data["warnings"]]
    assert len(run["results"]) == len(diagnostics)
    rules = [rule["id"] for rule in run["tool"]["driver"]["rules"]]
    assert rules == list(dict.fromkeys(d["rule"] for d, _ in diagnostics))  # each rule used, once
    by_place = {(d["file"], d["line"], d["column"], d["message"]): (d, level) for d, level in diagnostics}
    for result in run["results"]:
        (location,) = result["locations"]
        uri, line, column = region(location)
        d, level = by_place[(uri, line, column, result["message"]["text"])]
        assert result["level"] == level and result["ruleId"] == d["rule"]
        assert rules[result["ruleIndex"]] == d["rule"]
        assert result["properties"]["jsonPath"] == d["path"]
        assert result["properties"].get("feature") == d["feature"]
        related = result.get("relatedLocations", [])
        assert [(*region(r), r["message"]["text"]) for r in related] == [
            (f["file"], f["line"], f["column"], f["text"]) for f in d["facts"]
        ]
        assert [r["id"] for r in related] == list(range(1, len(related) + 1))


def test_the_sarif_schema_refuses_what_sarif_does_not_allow() -> None:
    """The vendored schema is the real one: it catches a wrong level and a line 0."""
    _, log = sarif(SIMPLEBOT, "--variant", "broken_gridmap_dynamic")
    result = log["runs"][0]["results"][0]
    result["level"] = "fatal"
    result["locations"][0]["physicalLocation"]["region"]["startLine"] = 0
    found = {p.validator for p in Draft4Validator(SARIF_SCHEMA).iter_errors(log)}
    assert found == {"enum", "minimum"}


def test_sarif_of_a_conflict_locates_the_fact_to_change_and_lists_the_others() -> None:
    code, log = sarif(SIMPLEBOT, "--variant", "broken_gridmap_dynamic")
    assert code == 1
    (run,) = log["runs"]
    (result,) = run["results"]
    variant = f"{SIMPLEBOT}/variants/broken_gridmap_dynamic.json"
    assert result["ruleId"] == "3.1" and result["level"] == "error"
    assert result["message"]["text"].startswith("slam requires grid_map, but grid_map is configured Dynamic")
    assert region(result["locations"][0]) == (variant, 57, 17)
    assert result["properties"] == {
        "jsonPath": "$.properties[7].props.mode",
        "feature": "grid_map",
        "repairs": ["make grid_map Static", "deselect slam and kartoslam"],  # (section 6)
    }
    assert [(*region(r), r["message"]["text"]) for r in result["relatedLocations"]] == [
        (f"{SIMPLEBOT}/model.json", 127, 15, "slam requires grid_map"),
        (variant, 52, 5, "grid_map is selected"),
        (variant, 57, 17, "grid_map is configured Dynamic"),
        (variant, 60, 5, "slam is selected"),
    ]
    assert run["tool"]["driver"]["rules"] == [
        {
            "id": "3.1",
            "shortDescription": {
                "text": "What a feature requires is there whenever it is (reference binding rule 3.1)"
            },
        }
    ]


def test_sarif_of_a_valid_model_has_no_results() -> None:
    code, log = sarif(f"{SIMPLEBOT}/model.json")
    assert code == 0 and log["runs"][0]["results"] == [] and log["runs"][0]["tool"]["driver"]["rules"] == []


def test_sarif_warnings_are_results_of_level_warning() -> None:
    code, log = sarif(f"{EXAMPLES}/dead.json")
    (result,) = log["runs"][0]["results"]
    assert code == 0 and result["level"] == "warning" and result["ruleId"] == "model.dead-feature"
    assert len(result["relatedLocations"]) == 3


def test_sarif_of_an_unknown_variant_holds_the_usage_error() -> None:
    code, log = sarif(SIMPLEBOT, "--variant", "nope")
    (run,) = log["runs"]
    (result,) = run["results"]
    assert code == 2 and run["invocations"][0]["executionSuccessful"] is False
    assert result["ruleId"] == "usage" and "no variant 'nope'" in result["message"]["text"]
    assert region(result["locations"][0]) == (f"{SIMPLEBOT}/variants/nope.json", None, None)  # no region


def test_sarif_of_an_unreadable_path_is_exit_3_with_the_path(tmp_path: Path) -> None:
    """An OSError no stage turned into a located error still comes as the format asked for."""
    long = tmp_path / ("a" * 300)
    code, log = sarif(str(long))
    (result,) = log["runs"][0]["results"]
    assert code == 3 and result["message"]["text"] == "cannot read: File name too long"
    assert result["locations"][0]["physicalLocation"] == {"artifactLocation": {"uri": long.as_uri()}}
    code, data = as_json(str(long))  # (so does JSON, which printed click's text before)
    assert code == 3 and [e["message"] for e in data["errors"]] == ["cannot read: File name too long"]


def test_sarif_uris_are_uri_references(tmp_path: Path) -> None:
    """A space or a byte that is no UTF-8 in a file name is percent-encoded; an absolute path is a file: URI."""
    folder = tmp_path / "my bot\udce9"  # (a file name byte 0xE9, as os.fsdecode gives it)
    folder.mkdir()
    shutil.copy(ROOT / EXAMPLES / "typo.json", folder / "model.json")
    code, log = sarif(str(folder / "model.json"))
    uris = {region(r["locations"][0])[0] for r in log["runs"][0]["results"]}
    assert code == 1 and uris == {f"file://{tmp_path}/my%20bot%E9/model.json"}


def test_every_rule_motivml_names_has_a_description() -> None:
    """Each rule of a diagnostic in motivml's source belongs to a family described in reports.py."""
    rules = set()
    for source in (ROOT / "motivml").rglob("*.py"):
        for node in ast.walk(ast.parse(source.read_text())):
            if not isinstance(node, ast.Call):
                continue
            name = getattr(node.func, "id", None) or getattr(node.func, "attr", None)
            place = {"error": 2, "warning": 2, "Diagnostic": 3, "LocatedFact": 2}.get(str(name))
            if place is None:
                continue
            args = node.args[place : place + 1] + [k.value for k in node.keywords if k.arg == "rule"]
            rules |= {a.value for a in args if isinstance(a, ast.Constant) and isinstance(a.value, str)}
    assert {"2.1", "model.dead-feature", "io", "usage", "config.incomplete"} <= rules  # (the scan reads them)
    for rule in rules:
        family = rule.partition(".")[0]
        assert rule in REFERENCE_RULES or family in FAMILIES, rule
    assert describe("model.dead-feature") == "The feature model: dead feature"
    assert describe("schema.enum") == "The document follows its JSON Schema: enum"


def junit(*args: str) -> tuple[int, ET.Element]:
    code, output = validate(*args, "--format", "junit")
    assert output.startswith('<?xml version="1.0" encoding="UTF-8"?>\n')
    return code, ET.fromstring(output)


@pytest.mark.parametrize("args", [a for a in CALLS.values() if len(a) > 1 or "none" not in a[0]])
def test_junit_has_a_test_case_per_document_failed_exactly_by_its_errors(args: list[str]) -> None:
    code, suites = junit(*args)
    json_code, data = as_json(*args)
    assert code == json_code
    (suite,) = suites.findall("testsuite")
    cases = suite.findall("testcase")
    if not data["documents"]:  # nothing checked: one case in error, the problem
        (case,) = cases
        (problem,) = case.findall("error")
        (first,) = data["errors"]
        assert problem.get("message") == f"{first['file']}: {first['message']}"
        assert suite.get("errors") == "1" and suite.get("failures") == "0"
        return
    assert [(c.get("name"), c.get("classname")) for c in cases] == [
        (d["file"], d["kind"]) for d in data["documents"]
    ]
    for case, document in zip(cases, data["documents"], strict=True):
        errors = [d for d in data["errors"] if d["file"] == document["file"]]
        failures = case.findall("failure")
        assert len(failures) == (0 if document["valid"] else 1)
        if failures:
            (failure,) = failures
            place = f"{errors[0]['file']}:{errors[0]['line']}:{errors[0]['column']}"
            assert failure.get("message") == f"{place}: {errors[0]['message']}"
            assert failure.get("type") == errors[0]["rule"]
            assert failure.text is not None
            lines = [line for line in failure.text.splitlines() if not line.startswith("    ")]
            assert lines == [
                f"{d['file']}:{d['line']}:{d['column']}: {d['path']}: error: {d['message']}" for d in errors
            ]
        out = case.find("system-out")
        assert (out is not None) == (document["warnings"] > 0)
    counts = {k: suite.get(k) for k in ("tests", "failures", "errors", "skipped")}
    invalid = sum(not d["valid"] for d in data["documents"])
    assert counts == {"tests": str(len(cases)), "failures": str(invalid), "errors": "0", "skipped": "0"}
    assert {k: suites.get(k) for k in counts} == counts


def test_junit_of_a_robot_folder_fails_only_the_broken_variant() -> None:
    code, suites = junit(SIMPLEBOT)
    cases = suites.findall("testsuite/testcase")
    failed = [c.get("name") for c in cases if c.find("failure") is not None]
    assert code == 1 and len(cases) == 7
    assert failed == [f"{SIMPLEBOT}/variants/broken_gridmap_dynamic.json"]
    failure = cases[1].find("failure")
    assert failure is not None and failure.text is not None
    assert f"    {SIMPLEBOT}/model.json:127:15: slam requires grid_map\n" in failure.text  # the facts


def test_junit_puts_warnings_in_system_out() -> None:
    code, suites = junit(f"{EXAMPLES}/dead.json")
    (case,) = suites.findall("testsuite/testcase")
    out = case.find("system-out")
    assert code == 0 and case.find("failure") is None and out is not None and out.text is not None
    assert out.text.startswith(f"{EXAMPLES}/dead.json:7:13: $.sub[1].id: warning: slam is dead")


def test_junit_stays_well_formed_whatever_the_names(tmp_path: Path) -> None:
    """A control character or an undecodable byte in a file name is spelled out, not written raw."""
    folder = tmp_path / "bot\x01\udce9"
    folder.mkdir()
    shutil.copy(ROOT / EXAMPLES / "typo.json", folder / "model.json")
    code, suites = junit(str(folder / "model.json"))
    (case,) = suites.findall("testsuite/testcase")
    assert code == 1 and case.get("name") == f"{tmp_path}/bot\\x01\\udce9/model.json"
    failure = case.find("failure")
    assert failure is not None and failure.get("message", "").startswith(
        f"{tmp_path}/bot\\x01\\udce9/model.json:8:7: "
    )


def test_a_model_whose_variants_went_unchecked_has_one_case(tmp_path: Path) -> None:
    """An invalid model stops validate before its variants: the cases are the documents checked."""
    folder = tmp_path / "bot"
    shutil.copytree(ROOT / SIMPLEBOT, folder)
    shutil.copy(ROOT / EXAMPLES / "typo.json", folder / "model.json")
    code, suites = junit(str(folder))
    (case,) = suites.findall("testsuite/testcase")
    assert code == 1 and case.get("name") == f"{folder}/model.json" and case.find("failure") is not None

"""Abstract features, and Dynamic features that nothing implements: said at start and on request; --strict refuses."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner
from test_transactions import make_robot

from motivml.cli import main
from motivml.language.reader import load_model
from motivml.plugins.manifests import missing
from motivml.runtime.launch import launch
from motivml.runtime.requests import Load


def hollow_robot(tmp_path: Path, abstract_alt: bool = True) -> Path:
    """alt (Dynamic Early, groups a and b) and d (Dynamic Late): a has a plugin, d has none."""
    folder = make_robot(tmp_path / "bot", {"a": {}, "b": {}})
    model = json.loads((folder / "model.json").read_text())
    if abstract_alt:
        model["sub"][0]["abstract"] = True
    (folder / "model.json").write_text(json.dumps(model, indent=1))
    return folder


def run(folder: Path, *extra: str) -> tuple[int, str]:
    args = ["run", str(folder), "--variant", "v", "--duration", "1", "--clock", "simulated", "--no-control"]
    result = CliRunner().invoke(main, [*args, "--no-live", *extra])
    return result.exit_code, result.output


def test_abstract_is_read_and_expects_no_plugin(tmp_path: Path) -> None:
    folder = hollow_robot(tmp_path)
    model, problems = load_model(folder / "model.json")
    assert model is not None and not problems
    assert model["alt"].abstract and not model["d"].abstract
    assert [d.feature for d in missing(model, ["alt", "d"], {})] == ["d"]


def test_a_non_boolean_abstract_is_a_schema_error(tmp_path: Path) -> None:
    folder = hollow_robot(tmp_path)
    model = json.loads((folder / "model.json").read_text())
    model["sub"][0]["abstract"] = "yes"
    (folder / "model.json").write_text(json.dumps(model))
    result = CliRunner().invoke(main, ["validate", str(folder / "model.json")])
    assert result.exit_code == 1 and "$.sub[0].abstract" in result.output


def test_an_active_dynamic_feature_nothing_implements_is_said_at_start_and_refused_with_strict(
    tmp_path: Path,
) -> None:
    folder = hollow_robot(tmp_path, abstract_alt=False)
    code, output = run(folder)
    assert code == 0, output
    assert "warning: alt is active and Dynamic, but nothing implements it" in output
    code, output = run(folder, "--strict")
    assert code == 1 and "error: alt is active and Dynamic, but nothing implements it" in output
    assert "cannot run" in output
    code, output = run(hollow_robot(tmp_path / "abstract"), "--strict")  # abstract: nothing expected
    assert code == 0 and "nothing implements" not in output, output


def test_a_load_of_such_a_feature_is_accepted_with_a_warning_or_refused_with_strict(tmp_path: Path) -> None:
    folder = hollow_robot(tmp_path)
    robot = launch(folder, "v")
    try:
        outcome = robot.binder.request_between_ticks(Load(("d",)))
        assert outcome.accepted and [d.rule for d in outcome.diagnostics] == ["run.unimplemented"]
        assert "d is now active and Dynamic, but nothing implements it" in outcome.diagnostics[0].message
        assert robot.runtime.notes[-1][2] == "load d: nothing implements d: active as a feature only"
    finally:
        robot.close()
    strict = launch(folder, "v", strict=True)
    try:
        outcome = strict.binder.request_between_ticks(Load(("d",)))
        assert not outcome.accepted and "d would be active and Dynamic" in outcome.reason
        assert "d" not in strict.binder.active
    finally:
        strict.close()

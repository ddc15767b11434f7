""".pre-commit-hooks.yaml: pre-commit reads it, and its hook runs a real command.

The file is read with ruamel.yaml, which sismic (a dependency of motivml) brings; pre-commit
itself is not needed to check what it would read.
"""

from __future__ import annotations

import re
import shlex
import tomllib
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from paths import ROOT
from ruamel.yaml import YAML

from motivml.cli import main

# The keys of a hook in pre-commit's manifest (pre_commit/clientlib.py, MANIFEST_HOOK_DICT).
HOOK_KEYS = {
    "id", "name", "entry", "language", "alias", "files", "exclude", "types", "types_or",
    "exclude_types", "additional_dependencies", "args", "always_run", "fail_fast", "pass_filenames",
    "description", "language_version", "log_file", "minimum_pre_commit_version", "require_serial",
    "stages", "verbose",
}  # fmt: skip


def hooks() -> list[dict[str, Any]]:
    loaded = YAML(typ="safe", pure=True).load((ROOT / ".pre-commit-hooks.yaml").read_text())
    assert isinstance(loaded, list)
    return loaded


def hook() -> dict[str, Any]:
    (found,) = (h for h in hooks() if h["id"] == "motivml-validate")
    return found


def test_the_hooks_file_is_what_pre_commit_reads() -> None:
    for item in hooks():
        assert {"id", "name", "entry", "language"} <= set(item) <= HOOK_KEYS, item
    assert hook()["language"] == "python" and hook()["pass_filenames"] is False


def test_the_entry_is_the_console_script() -> None:
    """pre-commit installs the repository with pip and runs `entry`: its first word is our script."""
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert (
        shlex.split(hook()["entry"]) == ["motivml", "validate"] and scripts["motivml"] == "motivml.__main__:run"
    )


@pytest.mark.parametrize(
    ("path", "runs"),
    [
        ("model.json", True),
        ("feature_models/simplebot/model.json", True),
        ("feature_models/simplebot/variants/lab.json", True),
        ("feature_models/simplebot/architecture.json", True),
        ("feature_models/reaching_arm/coordination.json", True),
        ("feature_models/simplebot/robot.json", True),
        ("plugins/python/hectorslam/plugin.json", True),
        ("feature_models/simplebot/mymodel.json", False),
        ("package.json", False),
        ("feature_models/simplebot/variants/old/lab.json", False),
        ("feature_models/simplebot/variants/lab.json.orig", False),
        ("README.md", False),
    ],
)
def test_the_hook_runs_when_a_robot_document_changes(path: str, runs: bool) -> None:
    assert bool(re.search(hook()["files"], path)) is runs  # (pre-commit matches with re.search)


def run_hook(monkeypatch: pytest.MonkeyPatch, where: Path, args: list[str]) -> tuple[int, str]:
    """What pre-commit runs in `where` (the repository): entry, then the hook's args."""
    monkeypatch.chdir(where)
    command = shlex.split(hook()["entry"])[1:] + hook().get("args", []) + args
    result = CliRunner().invoke(main, command)
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


def test_the_hook_with_its_default_args_checks_the_current_folder(monkeypatch: pytest.MonkeyPatch) -> None:
    code, output = run_hook(monkeypatch, ROOT / "guidelines" / "examples" / "mybot", [])
    assert code == 0 and output == "valid: model.json (3 features), 0 errors, 0 warnings\n"


def test_the_hook_on_a_robot_folder_fails_a_commit_with_an_invalid_variant(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """args: [feature_models/simplebot], as guidelines/validating.md sets it: its broken variant fails."""
    code, output = run_hook(monkeypatch, ROOT, ["feature_models/simplebot"])
    assert code == 1
    assert "invalid: feature_models/simplebot/variants/broken_gridmap_dynamic.json: 1 error" in output

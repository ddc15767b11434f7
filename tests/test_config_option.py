"""--variant NAME and --config FILE (issue 16): every command that takes one takes the other.

NAME is variants/NAME.json of the robot folder, FILE a configuration document anywhere, which
goes by its file name's stem; the same document gives the same output either way. Both
given, or neither where a command needs a variant, is a usage error (exit 2).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import click
import pytest
from click.testing import CliRunner
from paths import SIMPLEBOT

from motivml.cli import COMMANDS, main

FIELD = SIMPLEBOT / "variants" / "field.json"
BOTH = "give --config FILE or --variant NAME, not both"
NEITHER = "give --variant NAME (variants/NAME.json of the robot folder) or --config FILE"
# ctl's --variant names a run that is listening, not a document: a run of --config FILE goes
# by FILE's stem, and `ctl --variant STEM` reaches it.
NAMES_A_RUN = {"ctl"}


def run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, list(args))
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


@pytest.fixture
def elsewhere(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A working folder of its own (default output folders go to build/ below it)."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


def options(name: str) -> set[str]:
    command = main.get_command(click.Context(main), name)
    assert command is not None
    return {flag for p in command.params for flag in p.opts}


@pytest.mark.parametrize("name", sorted(set(COMMANDS) - NAMES_A_RUN))
def test_a_command_takes_both_or_neither(name: str) -> None:
    found = options(name)
    assert ("--variant" in found) == ("--config" in found), name


def test_the_commands_about_a_variant_are_those_expected() -> None:
    about = {name for name in COMMANDS if "--variant" in options(name)}
    assert about == {"validate", "show", "configure", "menuconfig", "graph", "run", "ctl"}


def files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_configure_config_of_a_variants_file_writes_what_variant_writes(elsewhere: Path) -> None:
    code, _ = run("configure", str(SIMPLEBOT), "--variant", "field", "-o", "by-name")
    assert code == 0
    code, output = run("configure", str(SIMPLEBOT), "--config", str(FIELD))
    assert code == 0 and "variant field: 18 features selected" in output
    written = files(elsewhere / "build" / "simplebot" / "field")  # the default folder, as for --variant
    assert written == files(elsewhere / "by-name") and len(written) == 6


def test_configure_config_elsewhere_goes_by_its_stem(elsewhere: Path) -> None:
    shutil.copy(FIELD, elsewhere / "trial.json")
    code, output = run("configure", str(SIMPLEBOT), "--config", "trial.json")
    assert code == 0 and "variant trial: 18 features selected" in output
    lock = (elsewhere / "build" / "simplebot" / "trial" / "variant.lock.json").read_text()
    assert '"x-variant": "trial"' in lock


def test_configure_an_invalid_config_writes_nothing(elsewhere: Path) -> None:
    code, output = run(
        "configure", str(SIMPLEBOT), "--config", str(SIMPLEBOT / "variants" / "broken_gridmap_dynamic.json")
    )
    assert code == 1 and "broken_gridmap_dynamic.json: nothing written" in output
    assert not (elsewhere / "build").exists()


def test_configure_a_missing_config_is_an_environment_problem(elsewhere: Path) -> None:
    code, output = run("configure", str(SIMPLEBOT), "--config", "none.json")
    assert code == 3 and "none.json: no such file or folder" in output


@pytest.mark.parametrize(
    "command",
    [
        ["configure", str(SIMPLEBOT)],
        ["graph", str(SIMPLEBOT)],
        ["run", str(SIMPLEBOT), "--clock", "simulated", "--duration", "0.1", "--no-control"],
        ["show", str(SIMPLEBOT)],
        ["validate", str(SIMPLEBOT)],
    ],
    ids=lambda c: c[0],
)
def test_variant_and_config_together_are_a_usage_error(elsewhere: Path, command: list[str]) -> None:
    code, output = run(*command, "--variant", "field", "--config", str(FIELD))
    assert code == 2 and BOTH in output
    assert not (elsewhere / "build").exists()


@pytest.mark.parametrize(
    "command",
    [
        ["configure", str(SIMPLEBOT)],
        ["run", str(SIMPLEBOT), "--clock", "simulated", "--duration", "0.1", "--no-control"],
    ],
    ids=lambda c: c[0],
)
def test_a_command_about_one_variant_needs_one(elsewhere: Path, command: list[str]) -> None:
    code, output = run(*command)
    assert code == 2 and NEITHER in output
    assert not (elsewhere / "build").exists()


def test_graph_config_draws_what_variant_draws(elsewhere: Path) -> None:
    code, _ = run("graph", str(SIMPLEBOT), "--variant", "field", "--format", "graphml", "-o", "by-name")
    assert code == 0
    shutil.copy(FIELD, elsewhere / "trial.json")
    code, output = run("graph", str(SIMPLEBOT), "--config", "trial.json", "--format", "graphml")
    drawn = elsewhere / "build" / "simplebot" / "trial"  # build/<robot>/<stem>/
    assert code == 0 and f"wrote {Path('build/simplebot/trial/feature-model.graphml')}" in output
    assert files(drawn) == files(elsewhere / "by-name") and len(files(drawn)) == 2


def test_graph_without_either_draws_the_model(elsewhere: Path) -> None:
    code, output = run("graph", str(SIMPLEBOT), "--format", "graphml")
    assert code == 0 and "wrote build/simplebot/model/feature-model.graphml" in output


def test_run_config_runs_the_document_under_its_stem(
    elsewhere: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(elsewhere))
    shutil.copy(FIELD, elsewhere / "trial.json")
    code, output = run(
        "run",
        str(SIMPLEBOT),
        "--config",
        "trial.json",
        "--clock",
        "simulated",
        "--duration",
        "0.2",
        "--no-live",
    )
    assert code == 0, output
    assert "running simplebot variant trial: 2 components of 12 active features" in output
    assert "control: build/simplebot/trial/run/" in output  # the run folder ctl --variant trial finds


def test_run_of_an_invalid_config_cannot_run(elsewhere: Path) -> None:
    code, output = run(
        "run", str(SIMPLEBOT), "--config", str(SIMPLEBOT / "variants" / "broken_gridmap_dynamic.json"),
        "--clock", "simulated", "--duration", "0.1", "--no-control",
    )  # fmt: skip
    assert code == 1 and "cannot run: " in output and "variant broken_gridmap_dynamic" in output
    assert "slam requires grid_map" in output

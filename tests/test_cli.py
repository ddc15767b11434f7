"""The command line through click's CliRunner: exit codes, text and JSON output."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from click.testing import CliRunner
from paths import ROOT, SIMPLEBOT

from motivml import process
from motivml.binding import encoding as enc
from motivml.cli import main
from motivml.language import reader


def run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, list(args))
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


def test_valid_variant_exit_0() -> None:
    code, output = run("validate", str(SIMPLEBOT), "--variant", "lab")
    assert code == 0
    variant, architecture, plugins = output.strip().splitlines()
    assert variant.startswith("valid: ") and variant.endswith("lab.json, 0 errors, 0 warnings")
    assert architecture.startswith("valid: ") and architecture.endswith(
        "architecture.json, 0 errors, 0 warnings"
    )
    assert plugins.startswith("valid: ") and plugins.endswith("robot.json, 0 errors, 0 warnings")


def test_invalid_variant_exit_1_with_located_message() -> None:
    code, output = run("validate", str(SIMPLEBOT), "--variant", "broken_gridmap_dynamic")
    assert code == 1
    first = output.splitlines()[0]
    assert first.endswith(
        "broken_gridmap_dynamic.json:57:17: $.properties[7].props.mode: error: slam requires grid_map, but "
        "grid_map is configured Dynamic and slam is selected: a required feature must be Static (binding rule 3.1)"
    )
    assert output.splitlines()[-3].startswith("invalid: ")  # then the architecture and plugins, valid


def test_model_file_with_config_and_json_format() -> None:
    code, output = run(
        "validate",
        str(SIMPLEBOT / "model.json"),
        "--config",
        str(SIMPLEBOT / "variants" / "broken_gridmap_dynamic.json"),
        "--format",
        "json",
    )
    assert code == 1
    data = json.loads(output)
    assert data["valid"] is False and data["warnings"] == []
    (error,) = data["errors"]
    assert {k: error[k] for k in ("line", "column", "path", "feature", "rule")} == {
        "line": 57,
        "column": 17,
        "path": "$.properties[7].props.mode",
        "feature": "grid_map",
        "rule": "3.1",
    }
    assert error["file"].endswith("broken_gridmap_dynamic.json")
    assert error["message"].startswith("slam requires grid_map, but grid_map is configured Dynamic")
    assert [f["text"] for f in error["facts"]][0] == "slam requires grid_map"


def test_robot_folder_checks_model_and_every_variant() -> None:
    code, output = run("validate", str(SIMPLEBOT))
    verdicts = [line for line in output.splitlines() if line.startswith(("valid: ", "invalid: "))]
    assert code == 1
    assert len(verdicts) == 7 and verdicts[0].startswith("valid: ") and "(19 features)" in verdicts[0]
    assert verdicts[-2].endswith("architecture.json, 0 errors, 0 warnings")
    assert verdicts[-1].endswith("robot.json, 0 errors, 0 warnings")  # the plugin manifests


def test_current_folder_is_the_default(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(SIMPLEBOT)
    code, output = run("validate", "--variant", "field")
    assert code == 0 and "variants/field.json" in output


def test_partial_configuration(tmp_path: Path) -> None:
    config = tmp_path / "partial.json"
    config.write_text('{"properties": [{"id": "slam", "props": {"time": "Early"}}]}')
    code, output = run("validate", str(SIMPLEBOT / "model.json"), "--config", str(config))
    assert code == 1 and "the configuration is incomplete" in output
    code, output = run("validate", str(SIMPLEBOT / "model.json"), "--config", str(config), "--partial")
    assert code == 0, output
    assert "(17 features and 1 binding left to the configurator)" in output


def test_unknown_variant_is_a_usage_error() -> None:
    code, output = run("validate", str(SIMPLEBOT), "--variant", "nope")
    assert code == 2
    assert (
        "no variant 'nope'" in output and "variants: broken_gridmap_dynamic, field, lab, warehouse" in output
    )


def test_variant_with_a_model_file_is_a_usage_error() -> None:
    code, output = run("validate", str(SIMPLEBOT / "model.json"), "--variant", "lab")
    assert code == 2 and "--variant needs a robot folder" in output


def test_bad_option_is_a_usage_error() -> None:
    code, _ = run("validate", "--format", "xml")
    assert code == 2


def test_missing_file_is_an_environment_problem(tmp_path: Path) -> None:
    code, output = run("validate", str(tmp_path / "none.json"))
    assert code == 3 and "no such file or folder" in output


def test_folder_without_model_is_an_environment_problem(tmp_path: Path) -> None:
    code, output = run("validate", str(tmp_path))
    assert code == 3 and "no model.json here" in output


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            '{"id": "r", "name": "R", "id": "s"}',
            "m.json:1:26: $: error: duplicate key 'id' (first at line 1, column 2)",
        ),
        ("{\xff}", "m.json:1:2: $: error: not valid UTF-8"),
        (
            '{"id": "r", "name": "R", "sub": [{"id": "a", "name": "A", "group": "xor"}]}',
            "m.json:1:68: $.sub[0].group",
        ),
    ],
)
def test_bad_model_files_exit_1_located(tmp_path: Path, text: str, expected: str) -> None:
    path = tmp_path / "m.json"
    path.write_bytes(text.encode("utf-8", "surrogateescape") if "\xff" not in text else b"{\xff}")
    code, output = run("validate", str(path))
    assert code == 1
    assert output.splitlines()[0].split("/")[-1].startswith(expected)


def test_show_prints_the_tree_with_forced_bindings() -> None:
    code, output = run("show", str(SIMPLEBOT), "--variant", "lab")
    assert code == 0
    lines = output.splitlines()
    assert lines[0].startswith("root_feature (SimpleBot)  allowed SE  solver SE")
    assert any("[XOR] hectorslam" in line for line in lines)
    assert lines[-1].startswith("marks: ")


def test_show_lists_the_formulas_under_the_tree() -> None:
    code, output = run("show", str(ROOT / "guidelines" / "examples" / "sensorbot"))
    assert code == 0
    assert output.splitlines()[-3:-1] == ["formula 1: slam => lidar | camera", "formula 2: !(lidar & sonar)"]


def test_show_invalid_variant_exit_1() -> None:
    code, output = run("show", str(SIMPLEBOT), "--variant", "broken_gridmap_dynamic")
    assert code == 1 and "binding rule 3.1" in output


def test_broken_model_in_a_robot_folder_is_reported_once(tmp_path: Path) -> None:
    (tmp_path / "variants").mkdir()
    (tmp_path / "model.json").write_text(
        '{"id": "r", "name": "R", "sub": [{"id": "a", "name": "A", "group": "xor"}]}'
    )
    for name in ("a", "b"):
        (tmp_path / "variants" / f"{name}.json").write_text('{"properties": []}')
    code, output = run("validate", str(tmp_path))
    assert code == 1
    assert output.count("'xor' is not one of") == 1
    assert output.splitlines()[-1].endswith(
        "1 error, 0 warnings in the model (its variants were not checked)"
    )


def test_config_and_variant_together_is_a_usage_error() -> None:
    code, output = run("validate", str(SIMPLEBOT), "--variant", "lab", "--config", "x.json")
    assert code == 2 and "give --config FILE or --variant NAME, not both" in output


def test_json_format_for_environment_problems(tmp_path: Path) -> None:
    code, output = run("validate", str(tmp_path / "none.json"), "--format", "json")
    assert code == 3
    data = json.loads(output)
    assert data["valid"] is False and data["errors"][0]["message"] == "no such file or folder"


def test_locations_are_printed_verbatim(tmp_path: Path) -> None:
    """rich must not turn ':100:' into an emoji or '[...]' into markup."""
    path = tmp_path / "m.json"
    path.write_text("\n" * 99 + '{"id": "r", "name": "R", "[bold]": 1}')
    code, output = run("validate", str(path))
    assert code == 1
    assert "m.json:100:26: $[\"[bold]\"]: error: unknown key '[bold]'" in output


def test_hidden_and_non_file_entries_of_variants_are_not_variants(tmp_path: Path) -> None:
    (tmp_path / "variants" / "dir.json").mkdir(parents=True)
    (tmp_path / "model.json").write_text('{"id": "r", "name": "R"}')
    (tmp_path / "variants" / ".hidden.json").write_text("{}")
    (tmp_path / "variants" / "v.json").write_text('{"properties": []}')
    (tmp_path / "variants" / "gone.json").symlink_to(tmp_path / "nowhere.json")
    code, output = run("validate", str(tmp_path))
    assert code == 0, output
    assert [line.split("/")[-1] for line in output.splitlines()] == [
        "model.json (1 features), 0 errors, 0 warnings",
        "v.json, 0 errors, 0 warnings",
    ]
    code, output = run("validate", str(tmp_path), "--variant", "../model")
    assert code == 2 and "(variants: v)" in output


def test_show_a_model_without_variants_exit_1(tmp_path: Path) -> None:
    path = tmp_path / "m.json"
    path.write_text('{"id": "r", "name": "R", "constraints": {"bindingTimeAllowed": "Late"}}')
    code, output = run("show", str(path))
    assert code == 1 and "the model has no valid variant" in output


def test_show_spells_out_control_characters_in_names(tmp_path: Path) -> None:
    path = tmp_path / "m.json"
    path.write_text('{"id": "r", "name": "R\\u001b[31m"}')
    code, output = run("show", str(path))
    assert code == 0 and "(R\\x1b[31m)" in output


ESCAPES = "x\x1b]0;owned\x07\x1b[31m\r\x9b2J"  # retitle the terminal, recolour, return, clear (C1 CSI)


@pytest.mark.parametrize("broken", [False, True], ids=["valid", "broken"])
def test_file_names_with_escape_sequences_are_spelt_out(tmp_path: Path, broken: bool) -> None:
    """Issue 31: file names with escape sequences reached the terminal raw. Every line goes
    through a console that spells out control characters, escaped by its caller or not."""
    path = tmp_path / f"{ESCAPES}.json"
    path.write_text("{bad" if broken else (SIMPLEBOT / "model.json").read_text())
    code, output = run("validate", str(path))
    assert code == (1 if broken else 0), output
    assert "x\\x1b]0;owned\\x07\\x1b[31m\\r\\x9b2J.json" in output
    assert not any(ch in output for ch in "\x1b\x07\r\x9b")


# ------------------------------------------------------- run and ctl: refusals, live view
ARM = ROOT / "feature_models" / "coordinated_arm"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["status", "slam"], "status takes no features"),
        (["load"], "load needs at least one feature"),
        (["event", "stop", "now"], "event needs one name"),
    ],
)
def test_ctl_usage_errors_exit_2_before_any_connection(tmp_path: Path, args: list[str], message: str) -> None:
    code, output = run(
        "ctl", str(SIMPLEBOT), "--variant", "field", "--run-dir", str(tmp_path / "none"), *args
    )
    assert code == 2 and message in output


def test_configure_refuses_output_folders_it_did_not_make_and_names_that_are_not_plain(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 31: `--config DIR/..json` (stem `.`) wrote into build/ROBOT/ and made it a link;
    `-o .` left `..generations` and `..lock` here; `-o proj` made a checkout a link."""
    import shutil

    monkeypatch.chdir(tmp_path)
    shutil.copy(SIMPLEBOT / "variants" / "field.json", tmp_path / "..json")
    code, output = run("configure", str(SIMPLEBOT), "--config", str(tmp_path / "..json"))
    assert code == 2 and "a variant's name ('.') must be a plain file name" in output
    code, output = run("configure", str(SIMPLEBOT), "--variant", "field", "-o", ".")
    assert code == 3 and "is not a plain folder name" in output
    (tmp_path / "proj" / ".git").mkdir(parents=True)
    code, output = run("configure", str(SIMPLEBOT), "--variant", "field", "-o", "proj")
    assert code == 3 and "is a folder motivml did not make" in output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["..json", "proj"]  # nothing beside
    assert [p.name for p in (tmp_path / "proj").iterdir()] == [".git"]


def test_a_simulated_run_prints_the_same_bytes_however_late_its_output_is_read(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Issue 31: a change stamped with the wall clock ("15:28:53.222 tick 2000: swap ...")
    was printed when the command looked at the run before it ended, which it does or not as
    the machine is busy. Here it looks once after the whole run (the worst case) and once
    never during it: the same output."""
    from motivml.runtime.session import Session

    args = ["run", str(SIMPLEBOT), "--variant", "field", "--duration", "0.5", "--clock", "simulated"]
    args += ["--no-live", "--no-control", "--at", "0.2", "swap hectorslam kartoslam"]
    real_wait = Session.wait
    looked: list[bool] = []

    def late(self: Session, timeout: float) -> bool:
        if not looked:  # the first look comes after the run has ended, as on a busy machine
            looked.append(real_wait(self, 60))
            return False
        return real_wait(self, timeout)

    monkeypatch.setattr(Session, "wait", late)
    code, looked_late = run(*args)
    assert code == 0 and looked == [True], looked_late
    monkeypatch.setattr(Session, "wait", lambda self, timeout: real_wait(self, 60))
    code, at_the_end = run(*args)
    assert code == 0 and looked_late == at_the_end
    assert "changed at 0.200 s (tick 200): swap hectorslam kartoslam" in at_the_end


def test_run_with_an_event_for_a_robot_without_coordination_is_a_usage_error(tmp_path: Path) -> None:
    code, output = run(
        "run",
        str(SIMPLEBOT),
        "--variant",
        "field",
        "--clock",
        "simulated",
        "--run-dir",
        str(tmp_path / "run"),
        "--at",
        "0.5",
        "event stop",
    )
    assert code == 2 and "events go to a coordination statechart, and this robot has none" in output
    assert not (tmp_path / "run" / "control.sock").exists()  # the socket it had opened is closed


def test_run_whose_socket_cannot_open_exits_3(tmp_path: Path) -> None:
    blocker = tmp_path / "build"
    blocker.write_text("a file where a folder of the run directory goes")
    run_dir = blocker / "run"
    code, output = run(
        "run", str(SIMPLEBOT), "--variant", "field", "--clock", "simulated", "--run-dir", str(run_dir)
    )
    assert code == 3, output
    assert (
        output.splitlines()[-1]
        == f"{run_dir / 'control.sock'}: cannot open the control socket: Not a directory"
    )


def test_run_on_the_real_clock_reports_changes_as_they_happen() -> None:
    code, output = run(
        "run",
        str(SIMPLEBOT),
        "--variant",
        "field",
        "--duration",
        "0.3",
        "--no-control",
        "--at",
        "0.05",
        "swap hectorslam kartoslam",
    )
    assert code == 0, output
    reported = [line for line in output.splitlines() if line.endswith(": swap hectorslam kartoslam")]
    stamp, tick = reported[0].split(" tick ")  # HH:MM:SS.mmm tick N: the request
    assert len(stamp) == 12 and stamp[2] == stamp[5] == ":" and stamp[8] == "."
    assert int(tick.split(":")[0]) >= 50
    assert "request at 0.050 s (tick 50): swap hectorslam kartoslam: accepted" in output


def test_the_live_view_shows_the_coordination() -> None:
    code, output = run(
        "run",
        str(ARM),
        "--variant",
        "dmp",
        "--duration",
        "5",
        "--clock",
        "simulated",
        "--no-control",
        "--live",
    )
    assert code == 0, output
    assert output.splitlines()[-1].startswith("coordination reached its final state Done")


def test_ids_differing_only_in_case_fail_validate_as_configure_would(tmp_path: Path) -> None:
    model = tmp_path / "model.json"
    model.write_text(
        '{"id": "r", "name": "R", "sub": [{"id": "slam", "name": "a"}, {"id": "SLAM", "name": "b"}]}'
    )
    code, output = run("validate", str(model))
    assert code == 1
    assert "$.sub[1].id: error: SLAM and slam differ only in case" in output


def _floats(node: object) -> object:
    """Every dimension, hidden and basis count written as a float (3 -> 3.0)."""
    if isinstance(node, dict):
        return {
            k: float(v) if k in ("dimension", "hidden", "basis") and isinstance(v, int) else _floats(v)
            for k, v in node.items()
        }
    if isinstance(node, list):
        return [_floats(v) for v in node]
    return node


@pytest.mark.parametrize(("robot", "variant"), [("laundry_gripping", "learned"), ("reaching_arm", "dmp")])
def test_integral_floats_for_counts_are_accepted_by_run(tmp_path: Path, robot: str, variant: str) -> None:
    # JSON Schema's "integer" admits 3.0: what validate passes, run must accept (numpy refused a float size)
    import shutil

    folder = tmp_path / robot
    shutil.copytree(ROOT / "feature_models" / robot, folder)
    architecture = folder / "architecture.json"
    document = json.loads(architecture.read_text())
    architecture.write_text(json.dumps(_floats(document), indent=2))
    assert "3.0" in architecture.read_text()
    assert run("validate", str(folder), "--variant", variant)[0] == 0
    code, output = run(
        "run", str(folder), "--variant", variant, "--duration", "0.2", "--clock", "simulated", "--no-control"
    )
    assert code == 0, output


def test_a_rate_that_makes_run_diverge_fails_validate_with_the_builders_message(tmp_path: Path) -> None:
    import shutil

    folder = tmp_path / "arm"
    shutil.copytree(ROOT / "feature_models" / "reaching_arm", folder)
    architecture = folder / "architecture.json"
    document = json.loads(architecture.read_text())
    [component] = [c for c in document["components"] if c["id"] == "AttractorReacher"]
    component["rate"] = 5
    architecture.write_text(json.dumps(document, indent=2))
    message = (
        "AttractorReacher steps every 0.2 s, too coarse for module ReachAttractor (alpha 20): "
        "the integration diverges unless alpha * step / duration < 2"
    )
    code, output = run("validate", str(folder), "--variant", "dmp")  # not even the variant that uses it
    assert code == 1 and message in output, output
    code, output = run(
        "run",
        str(folder),
        "--variant",
        "attractor",
        "--duration",
        "0.1",
        "--clock",
        "simulated",
        "--no-control",
    )
    assert code != 0 and message in output, output


@pytest.mark.parametrize("command", ["validate", "show"])
def test_ctrl_c_ends_any_command_with_one_line_and_130(monkeypatch: pytest.MonkeyPatch, command: str) -> None:
    import motivml.validate

    def interrupted(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(motivml.validate, "validate", interrupted)
    monkeypatch.setattr(motivml.validate, "validate_model", interrupted)
    result = CliRunner().invoke(main, [command, str(SIMPLEBOT)])
    assert result.exit_code == 130 and result.output == "interrupted\n", result.output


@pytest.mark.parametrize("text", ["Caught keyboard interrupt", "something else went wrong"])
def test_ctrl_c_inside_a_solve_is_an_interruption_too(monkeypatch: pytest.MonkeyPatch, text: str) -> None:
    """pysat's solvers catch SIGINT themselves while they search, and raise their own error."""
    import pysolvers  # type: ignore[import-not-found]

    import motivml.validate

    def solving(*args: object, **kwargs: object) -> None:
        raise pysolvers.error(text)

    monkeypatch.setattr(motivml.validate, "validate_model", solving)
    result = CliRunner().invoke(main, ["validate", str(SIMPLEBOT / "model.json")])
    if "keyboard" in text:
        assert result.exit_code == 130 and result.output == "interrupted\n", result.output
    else:
        assert isinstance(result.exception, pysolvers.error)  # (not ours to hide)


@pytest.mark.parametrize(
    "args",
    [
        ["validate"],
        ["show"],
        ["graph"],
        ["configure", "--variant", "lab"],
        ["run", "--variant", "lab", "--clock", "simulated", "--duration", "0.1", "--no-control"],
    ],
)
def test_a_path_component_over_255_characters_exits_3_with_the_path(tmp_path: Path, args: list[str]) -> None:
    long = tmp_path / ("a" * 300)
    code, output = run(args[0], str(long), *args[1:])
    assert code == 3, output
    assert f"{long}: " in output and "cannot read: File name too long" in output


def _refuse(monkeypatch: pytest.MonkeyPatch, method: str, where: Path) -> None:
    """What a folder at mode 000 does for a user other than root: pathlib raises PermissionError."""
    original = getattr(Path, method)

    def refused(self: Path, *args: object) -> object:
        if self == where or where in self.parents:
            raise PermissionError(13, "Permission denied", str(self))
        return original(self, *args)

    monkeypatch.setattr(Path, method, refused)


@pytest.mark.parametrize("command", ["validate", "show", "graph", "configure", "run"])
def test_an_unreadable_robot_folder_exits_3_with_the_path(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, command: str
) -> None:
    import shutil

    folder = tmp_path / "bot"
    shutil.copytree(SIMPLEBOT, folder)
    _refuse(monkeypatch, "is_dir", folder)
    extra = ["--variant", "lab"] if command in ("configure", "run") else []
    code, output = run(command, str(folder), *extra)
    assert code == 3, output
    assert f"{folder}: " in output and "cannot read: Permission denied" in output


def test_robot_folder_open_makes_a_permission_error_an_environment_problem(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from motivml.documents.robot_folder import RobotFolder
    from motivml.errors import EnvironmentProblem

    _refuse(monkeypatch, "is_dir", tmp_path)
    with pytest.raises(EnvironmentProblem) as caught:
        RobotFolder.open(tmp_path)
    assert str(caught.value) == f"{tmp_path}: cannot read: Permission denied"


def test_an_unreadable_plugin_folder_exits_3_with_the_path(monkeypatch: pytest.MonkeyPatch) -> None:
    plugins = (SIMPLEBOT / "../../plugins/python").resolve()
    original = Path.iterdir

    def refused(self: Path):  # type: ignore[no-untyped-def]
        if self.resolve() == plugins:
            raise PermissionError(13, "Permission denied", str(self))
        return original(self)

    monkeypatch.setattr(Path, "iterdir", refused)
    code, output = run("validate", str(SIMPLEBOT))
    assert code == 3 and "plugins/python: cannot read: Permission denied" in output, output


UNREADABLE_COMMANDS = [
    ["validate", "{bot}"],
    ["configure", "{bot}", "--variant", "field", "-o", "{out}"],
    ["analyse", "{bot}"],
    ["show", "{bot}"],
    ["run", "{bot}", "--variant", "field", "--duration", "0.1", "--clock", "simulated", "--no-live", "--no-control"],
    ["export", "uvl", "{bot}", "-o", "{out}.uvl"],
    ["sample", "{bot}", "-o", "{out}"],
    ["graph", "{bot}", "-o", "{out}"],
    ["diff", "{bot}", "field", "lab"],
]


def test_a_robot_folder_at_mode_000_exits_3_for_every_command() -> None:
    """Issue 31: click refused an unreadable TARGET itself ("is not readable", exit 2); the
    documented code for the environment is 3, with the path. Root reads anything, so as root
    the commands run in a child that has become `nobody` (after running each command once
    on a readable copy: the child cannot read Python's own modules under /root either)."""
    import json
    import shutil
    import tempfile

    top = Path(tempfile.mkdtemp())
    try:
        top.chmod(0o755)
        shutil.copytree(SIMPLEBOT, top / "warm")
        shutil.copytree(SIMPLEBOT, top / "bot")
        (top / "bot").chmod(0)

        def commands(bot: str, out: str) -> list[list[str]]:
            return [[word.format(bot=top / bot, out=top / out) for word in c] for c in UNREADABLE_COMMANDS]

        if os.geteuid() != 0:
            results = [(run(*c)) for c in commands("bot", "out")]
        else:
            for c in commands("warm", "warm-out"):
                run(*c)
            read, write = os.pipe()
            pid = os.fork()
            if pid == 0:  # pragma: no cover (the child)
                try:
                    os.close(read)
                    os.setgid(65534)
                    os.setuid(65534)
                    os.write(write, json.dumps([run(*c) for c in commands("bot", "out")]).encode())
                finally:
                    os._exit(0)
            os.close(write)
            with os.fdopen(read, "rb") as answers:
                results = json.loads(answers.read() or b"[]")
            os.waitpid(pid, 0)
        assert len(results) == len(UNREADABLE_COMMANDS)
        for c, (code, output) in zip(UNREADABLE_COMMANDS, results, strict=True):
            assert code == 3, (c, output)
            assert "Permission denied" in output and "Traceback" not in output, (c, output)
    finally:
        (top / "bot").chmod(0o755)
        shutil.rmtree(top)


def test_a_learner_above_the_size_bound_is_warned_about_located(tmp_path: Path) -> None:
    import shutil

    folder = tmp_path / "laundry"
    shutil.copytree(ROOT / "feature_models" / "laundry_gripping", folder)
    architecture = folder / "architecture.json"
    architecture.write_text(architecture.read_text().replace('"hidden": 120', '"hidden": 10000'))
    code, output = run("validate", str(folder), "--variant", "learned")
    assert code == 0, output
    [line] = [line for line in output.splitlines() if "hidden units" in line]
    assert line.startswith(f"{architecture}:37:62: ")
    assert line.endswith(
        "$.mappings[2].learner.hidden: warning: RedundancyLearner has 10,000 hidden units, over the bound of 500: "
        "a run may be too slow for its loop or run out of memory"
    ), line


def test_a_large_xor_group_is_explained_as_one_statement(tmp_path: Path) -> None:
    # above encoding.PAIRWISE_EXPLAINED members the explain build has one fact for the group's pairs
    model, config = tmp_path / "model.json", tmp_path / "c.json"
    model.write_text(
        json.dumps(
            {"id": "r", "name": "R", "sub": [{"id": f"m{i}", "name": "M", "group": "XOR"} for i in range(70)]}
        )
    )
    config.write_text(json.dumps({"properties": [{"id": f"m{i}", "selected": i < 2} for i in range(70)]}))
    code, output = run("validate", str(model), "--config", str(config))
    assert code == 1
    assert (
        "error: the 70 members of r's XOR group are alternatives, but m0 allows only Early binding, m0 is "
        "selected, m1 allows only Early binding and m1 is selected: members of an XOR group can be selected "
        "together only as Dynamic alternatives, at most one of them Early, and only one of them is active at "
        "a time (rules 2.2 and 3.3)" in output
    ), output
    assert f"    {model}:1:69: the 70 members of r's XOR group are alternatives" in output


class _Ended(Exception):
    """os._exit, in a test: the code the process would have ended with."""


@pytest.fixture
def ending(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """console() without ending this process: os._exit raises _Ended, and what ran at exit
    is listed."""
    import atexit


    done: list[str] = []

    def end(code: int) -> None:
        done.append(f"ended {code}")
        raise _Ended(code)

    monkeypatch.setattr(os, "_exit", end)
    monkeypatch.setattr(atexit, "_run_exitfuncs", lambda: done.append("atexit"))
    monkeypatch.setattr(process, "_process_ends", False)  # (console says it: not for the tests after)
    monkeypatch.setattr(enc, "_LEFT_TILL_EXIT", [])  # (and what it keeps is not theirs either)
    return done


def test_a_command_that_does_one_job_ends_the_process_once_done(
    ending: list[str], monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """...and leaves its solvers to the end of the process, which frees them at no cost."""
    import motivml.cli as cli

    for argv, code in ((["validate", str(SIMPLEBOT / "model.json")], 0), (["validate", "no/such/model.json"], 3)):
        monkeypatch.setattr("sys.argv", ["motivml", *argv])
        with pytest.raises(_Ended):
            cli.console()
        assert ending[-2:] == ["atexit", f"ended {code}"]
    assert "valid: " in capsys.readouterr().out
    assert enc._LEFT_TILL_EXIT and process._process_ends


def test_a_command_of_many_encodings_keeps_the_last_solver_only(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(process, "_process_ends", True)
    monkeypatch.setattr(enc, "_LEFT_TILL_EXIT", [])
    model = reader.load_model(SIMPLEBOT / "model.json")[0]
    assert model is not None
    with process.one_command():
        with enc.Encoding(model) as first:
            pass
        with enc.Encoding(model) as second:
            pass
        assert enc._LEFT_TILL_EXIT == [second.solver] and first.solver.solver is None  # (deleted)


def test_a_process_that_ends_at_once_deletes_no_solver(monkeypatch: pytest.MonkeyPatch) -> None:
    """A forked child (`forked._child`) ends with os._exit: its encodings, in a command or
    not, free nothing before its answer."""
    monkeypatch.setattr(process, "_at_once", True)
    monkeypatch.setattr(enc, "_LEFT_TILL_EXIT", [])
    model = reader.load_model(SIMPLEBOT / "model.json")[0]
    assert model is not None
    with enc.Encoding(model) as first:
        pass
    with enc.Encoding(model) as second:
        pass
    assert enc._LEFT_TILL_EXIT == [first.solver, second.solver] and first.solver.solver is not None


def test_solvers_are_deleted_when_the_process_goes_on_after_the_command() -> None:
    result = CliRunner().invoke(main, ["validate", str(SIMPLEBOT / "model.json")])
    assert result.exit_code == 0 and not process._process_ends and not enc._LEFT_TILL_EXIT
    model = reader.load_model(SIMPLEBOT / "model.json")[0]
    assert model is not None
    with process.one_command():
        with enc.Encoding(model) as encoding:
            pass
    assert encoding.solver.solver is None  # (deleted)


def test_help_a_long_running_command_or_another_thread_end_the_process_as_python_does(
    ending: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import threading

    import motivml.cli as cli

    monkeypatch.setattr("sys.argv", ["motivml", "--help"])  # (no command is resolved)
    with pytest.raises(SystemExit):
        cli.console()
    monkeypatch.setattr("sys.argv", ["motivml", "run", "no/such/robot", "--variant", "v"])
    with pytest.raises(SystemExit):
        cli.console()
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        monkeypatch.setattr("sys.argv", ["motivml", "validate", str(SIMPLEBOT / "model.json")])
        with pytest.raises(SystemExit):
            cli.console()
    finally:
        stop.set()
        other.join()
    assert ending == []


def test_output_that_cannot_be_flushed_leaves_the_end_to_python(
    ending: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import motivml.cli as cli

    class Closed:
        def flush(self) -> None:
            raise BrokenPipeError(32, "Broken pipe")

    def one_job_done(prog_name: str) -> None:
        cli._one_job = True
        raise SystemExit(0)

    monkeypatch.setattr(cli, "main", one_job_done)
    monkeypatch.setattr("sys.stdout", Closed())
    with pytest.raises(SystemExit):
        cli.console()
    assert ending == []


@pytest.mark.parametrize("encoding", ["utf-8", "ascii"])
def test_shows_tree_text_is_what_rich_prints_into_a_pipe(encoding: str) -> None:
    """`show` writes its tree into a pipe without rich (seconds at 10,000 features): the
    same text as rich's Tree, for the shipped robots and wide and grouped generated shapes,
    with rich's guides or its ASCII ones, where rich's lines fit (deeper, rich wraps them;
    into a pipe they stay whole)."""
    import io
    import sys as system

    from helpers import model_of
    from rich.console import Console

    from motivml.binding.check import binding_states
    from motivml.cli.checking import _labels, _tree, _tree_text

    system.path.insert(0, str(ROOT / "bench"))
    from families import family

    class Pipe(io.StringIO):
        @property
        def encoding(self) -> str:  # type: ignore[override]
            return encoding

    models = [reader.load_model(str(path))[0] for path in sorted((ROOT / "feature_models").glob("*/model.json"))]
    models += [model_of(family(name, 120, seed=2)) for name in ("deep", "wide", "groups")]
    for model in models:
        assert model is not None
        labels = _labels(model, None, binding_states(model, None))
        text = _tree_text(model, labels, encoding == "ascii")
        width = max(map(len, text.splitlines()))
        pipe = Pipe()
        Console(file=pipe, width=width, highlight=False, emoji=False, color_system=None).print(_tree(model, labels))
        assert text == pipe.getvalue(), model.name


def test_a_change_is_reported_on_the_real_clock_even_when_the_run_ends_first() -> None:
    """The live report polls every 0.25 s; a run shorter than that (or a busy machine) ended
    before the first poll, and its change was never reported as it happened (a test of
    this file failed so under load). Whatever the timing, each change is reported once."""
    code, output = run(
        "run", str(SIMPLEBOT), "--variant", "field", "--duration", "0.1", "--no-control", "--at", "0.05",
        "swap hectorslam kartoslam",
    )
    assert code == 0, output
    live = [line for line in output.splitlines() if " tick " in line and line.endswith(": swap hectorslam kartoslam")]
    assert len(live) == 1 and live[0][2] == live[0][5] == ":"

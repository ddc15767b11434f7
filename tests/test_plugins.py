"""Plugin manifests and plugins.json: declared directories, validated manifests, located errors."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from motivml.cli import main
from motivml.documents.robot_folder import RobotFolder
from motivml.language.reader import load_model
from motivml.plugins.manifests import discover

MODEL = {
    "id": "bot",
    "name": "Bot",
    "sub": [
        {
            "id": "slam",
            "name": "SLAM",
            "isMandatory": False,
            "constraints": {"bindingTimeAllowed": "Late", "bindingModeAllowed": "Dynamic"},
        },
        {
            "id": "hands",
            "name": "Hands",
            "isMandatory": False,
            "constraints": {"bindingTimeAllowed": "Late", "bindingModeAllowed": "Dynamic"},
        },
    ],
}


def robot(tmp_path: Path, manifests: dict[str, Any], directories: list[str] | None = None) -> Path:
    (tmp_path / "variants").mkdir()
    (tmp_path / "model.json").write_text(json.dumps(MODEL))
    (tmp_path / "variants" / "v.json").write_text(
        json.dumps({"properties": [{"id": "slam"}, {"id": "hands"}]})
    )
    (tmp_path / "robot.json").write_text(
        json.dumps({"pluginDirectories": directories or ["plugins"]}, indent=1)
    )
    for name, manifest in manifests.items():
        (tmp_path / "plugins" / name).mkdir(parents=True)
        (tmp_path / "plugins" / name / "plugin.json").write_text(json.dumps(manifest, indent=1))
    return tmp_path


def found(folder: Path) -> tuple[dict[str, Any], list[str]]:
    model, _ = load_model(folder / "model.json")
    assert model is not None
    plugins, diagnostics = discover(RobotFolder.open(folder), model)
    return plugins, [
        f"{Path(d.location.file).parent.name}:{d.location.line}: {d.message}" for d in diagnostics
    ]


SLAM = {"feature": "slam", "kind": "python", "entry": {"module": "hector.slam", "class": "HectorSlam"}}


def test_a_valid_manifest_is_found(tmp_path: Path) -> None:
    plugins, problems = found(robot(tmp_path, {"hector": SLAM}))
    assert problems == []
    assert plugins["slam"].kind == "python" and plugins["slam"].entry == {
        "module": "hector.slam",
        "class": "HectorSlam",
    }


def test_manifest_errors_are_located(tmp_path: Path) -> None:
    manifests = {
        "a_rust": {"feature": "slam", "kind": "rust", "entry": {"class": "X"}},
        "b_escape": {"feature": "hands", "kind": "cpp", "entry": {"library": "../evil.so", "class": "Hands"}},
        "c_unknown": {"feature": "legs", "kind": "python", "entry": {"module": "legs", "class": "Legs"}},
        "d_nomodule": {"feature": "slam", "kind": "python", "entry": {"class": "X"}},
        "e_ok": SLAM,
        "f_twice": SLAM,
    }
    plugins, problems = found(robot(tmp_path, manifests))
    assert problems == [
        "a_rust:3: 'rust' is not one of 'python', 'cpp', 'ros2_lifecycle'",
        "b_escape:5: library '../evil.so' leaves the plugin folder",
        "c_unknown:2: the plugin implements 'legs', which is not a feature of the model",
        "d_nomodule:4: a python plugin's entry needs 'module'",
        f"f_twice:2: a second plugin for slam (the first is {tmp_path / 'plugins' / 'e_ok' / 'plugin.json'})",
    ]
    assert list(plugins) == ["slam"]


def test_each_kind_takes_its_own_entry_keys(tmp_path: Path) -> None:
    """A ros2_lifecycle entry names a node (and may carry its parameters); a python or cpp
    entry needs its class; a key of another kind is refused at that key; one node, one feature."""
    manifests = {
        "a_lamp": {
            "feature": "slam",
            "kind": "ros2_lifecycle",
            "entry": {
                "node": "/uv/lamp",
                "parameters": {"power.max": 0.8, "names": ["a", "b"]},
                "timeout": 2,
            },
        },
        "b_noclass": {"feature": "hands", "kind": "cpp", "entry": {"library": "libh.so"}},
        "c_class": {"feature": "hands", "kind": "ros2_lifecycle", "entry": {"node": "lamp", "class": "Lamp"}},
        "d_same_node": {"feature": "hands", "kind": "ros2_lifecycle", "entry": {"node": "/uv/lamp"}},
    }
    plugins, problems = found(robot(tmp_path, manifests))
    assert problems == [
        "b_noclass:4: a cpp plugin's entry needs 'class'",
        "c_class:6: a ros2_lifecycle plugin's entry has no 'class' (it has node, parameters, timeout)",
        f"d_same_node:5: node '/uv/lamp' is also the entry of {tmp_path / 'plugins' / 'a_lamp' / 'plugin.json'}: "
        "entry nodes need distinct names",
    ]
    assert plugins["slam"].entry["parameters"] == {"power.max": 0.8, "names": ["a", "b"]}


def test_parameters_ros_2_cannot_take_are_refused_at_the_item(tmp_path: Path) -> None:
    manifests = {
        "a_lamp": {
            "feature": "slam",
            "kind": "ros2_lifecycle",
            "entry": {"node": "lamp", "parameters": {"power": 0.8, "gains": [1.0, 2, 3.5]}},
        },
    }
    plugins, problems = found(robot(tmp_path, manifests))
    assert problems == [
        "a_lamp:10: parameter 'gains': a ROS 2 array holds one type, but item 1 is an integer after a double "
        "(write 1.0 for a double)"
    ]
    assert plugins == {}
    result = CliRunner().invoke(main, ["validate", str(tmp_path), "--format", "json"])
    (problem,) = json.loads(result.output)["errors"]
    assert result.exit_code == 1 and problem["path"] == "$.entry.parameters.gains[1]"
    assert problem["rule"] == "plugins.parameter"


def test_an_undeclared_directory_is_not_searched(tmp_path: Path) -> None:
    folder = robot(tmp_path, {"hector": SLAM}, directories=["elsewhere"])
    plugins, problems = found(folder)
    assert plugins == {}
    assert problems == [
        f"{tmp_path.name}:3: plugin directory 'elsewhere' does not exist (relative to {tmp_path})"
    ]


def test_configure_writes_plugins_json_and_warns_about_missing_plugins(tmp_path: Path) -> None:
    folder = robot(tmp_path, {"hector": SLAM})
    result = CliRunner().invoke(
        main, ["configure", str(folder), "--variant", "v", "-o", str(tmp_path / "out")]
    )
    assert result.exit_code == 0, result.output
    assert "warning: no plugin implements hands, which the variant binds Dynamic or Late" in result.output
    data = json.loads((tmp_path / "out" / "plugins.json").read_text())
    assert data["plugins"] == [
        {
            "feature": "slam",
            "binding": "DL",
            "plugin": {
                "folder": "plugins/hector",
                "kind": "python",
                "entry": {"module": "hector.slam", "class": "HectorSlam"},
            },
        },
        {"feature": "hands", "binding": "DL", "plugin": None},
    ]


def test_a_bad_manifest_stops_configure_before_writing(tmp_path: Path) -> None:
    folder = robot(
        tmp_path, {"bad": {"feature": "slam", "kind": "cpp", "entry": {"library": "../x.so", "class": "X"}}}
    )
    result = CliRunner().invoke(
        main, ["configure", str(folder), "--variant", "v", "-o", str(tmp_path / "out")]
    )
    assert result.exit_code == 1 and "leaves the plugin folder" in result.output
    assert not (tmp_path / "out").exists()


def test_validate_checks_robot_json_and_manifests_with_a_suggestion(tmp_path: Path) -> None:
    """What validate passes, configure and run accept: a manifest naming no feature fails here first."""
    folder = robot(tmp_path, {"hector": dict(SLAM, feature="slm")})
    result = CliRunner().invoke(main, ["validate", str(folder)])
    assert result.exit_code == 1
    assert (
        "the plugin implements 'slm', which is not a feature of the model (did you mean 'slam'?)"
        in result.output
    )
    assert f"invalid: {folder / 'robot.json'}: 1 error, 0 warnings in the plugins" in result.output


def not_a_file(path: Path, kind: str) -> None:
    """Put at `path` what a document is not: a directory, a link to nothing or a FIFO."""
    import os

    if kind == "directory":
        path.mkdir()
    elif kind == "broken link":
        path.symlink_to(path.parent / "nowhere.json")
    else:
        os.mkfifo(path)


@pytest.mark.parametrize("kind", ["directory", "broken link", "fifo"])
def test_an_optional_document_that_is_not_a_file_is_an_environment_error(tmp_path: Path, kind: str) -> None:

    folder = robot(tmp_path, {"hector": SLAM})
    path = folder / "architecture.json"
    not_a_file(path, kind)
    result = CliRunner().invoke(main, ["validate", str(folder)])
    assert result.exit_code == 3 and "architecture.json" in result.output and "Traceback" not in result.output


# ------------------------------------------------ Python plugins that fail to load (coverage)
SLAM_PLUGIN = {"feature": "slam", "kind": "python", "entry": {"module": "slammod", "class": "Plugin"}}
SLAM_CODE = """
from motivml.plugins.api import FeaturePlugin
GREETING = "v1"

class Plugin(FeaturePlugin):
    def status(self):
        return GREETING
"""


def slam_robot(tmp_path: Path, code: str = SLAM_CODE) -> Path:
    folder = robot(tmp_path, {"slam": SLAM_PLUGIN})
    (folder / "plugins" / "slam" / "slammod.py").write_text(code)
    return folder


def load(robot: Any, action: str, *features: str) -> Any:
    """A request made between two ticks, as the control thread makes it."""
    from motivml.runtime.requests import change

    return robot.binder.request_between_ticks(change(action, features))


def test_a_failed_reload_leaves_the_running_plugin_and_its_module_as_they_were(tmp_path: Path) -> None:
    from motivml.runtime.launch import launch

    folder = slam_robot(tmp_path)
    running = launch(folder, "v")
    try:
        assert load(running, "load", "slam").accepted
        module = folder / "plugins" / "slam" / "slammod.py"
        module.write_text('GREETING = "half-written"\nraise RuntimeError("saved mid-edit")\n')
        outcome = load(running, "reload", "slam")
        assert not outcome.accepted
        [problem] = outcome.diagnostics
        assert problem.message == (
            "cannot import 'slammod' of plugin slam: RuntimeError: saved mid-edit (at slammod.py:2)"
        )
        assert problem.location.path == "$.entry.module"
        assert running.runtime.status().plugins == (("slam", "v1"),)  # not "half-written"
        module.write_text(SLAM_CODE.replace('"v1"', '"v2"'))
        assert load(running, "reload", "slam").accepted
        assert running.runtime.status().plugins == (("slam", "v2"),)
    finally:
        running.close()


def test_a_class_that_cannot_be_constructed_refuses_the_load(tmp_path: Path) -> None:
    from motivml.runtime.launch import launch

    code = SLAM_CODE + "    def __init__(self, context):\n        raise ValueError('no map server')\n"
    running = launch(slam_robot(tmp_path, code), "v")
    try:
        outcome = load(running, "load", "slam")
        assert not outcome.accepted and outcome.reason == (
            "constructing Plugin of plugin slam failed: ValueError: no map server (at slammod.py:9)"
        )
        assert outcome.diagnostics[0].location.path == "$.entry.class"
        assert running.runtime.plugins == {} and "slam" not in running.binder.active
    finally:
        running.close()


def test_a_plugin_folder_removed_during_the_run_is_named_by_its_manifest(tmp_path: Path) -> None:
    import shutil

    from motivml.runtime.launch import launch

    folder = slam_robot(tmp_path)
    running = launch(folder, "v")
    try:
        shutil.rmtree(folder / "plugins" / "slam")
        outcome = load(running, "load", "slam")
        assert not outcome.accepted
        [problem] = outcome.diagnostics
        assert problem.message.startswith("cannot import 'slammod' of plugin slam: ModuleNotFoundError: ")
        assert str(problem.location) == str(
            folder / "plugins" / "slam" / "plugin.json"
        )  # no line: it is gone
    finally:
        running.close()


ROOT_FOLDER = Path(__file__).resolve().parent.parent / "feature_models"
COMMANDS = {
    "validate": ["validate", "{folder}"],
    "configure": ["configure", "{folder}", "--variant", "{variant}", "-o", "{out}"],
    "run": ["run", "{folder}", "--variant", "{variant}", "--clock", "simulated", "--duration", "0.01", "--no-control"],
}


@pytest.mark.parametrize("kind", ["directory", "broken link", "fifo"])
@pytest.mark.parametrize(
    ("document", "robot_name", "variant"),
    [("robot.json", "simplebot", "field"), ("coordination.json", "coordinated_arm", "swappable")],
)
@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_command_refuses_a_robot_document_that_is_not_a_file(
    tmp_path: Path, kind: str, document: str, robot_name: str, variant: str, command: str
) -> None:
    """Issue 31: robot.json or coordination.json that was a directory, a FIFO or a broken
    link made validate exit 3, while configure and run took it for absent and exited 0
    (SimpleBot ran with no plugins, the arm with no statechart). Every command now says the
    same of it, located, exit 3, and writes nothing."""
    import shutil

    folder = tmp_path / "a" / robot_name  # (SimpleBot's plugin directories are ../../plugins/...)
    shutil.copytree(ROOT_FOLDER / robot_name, folder)
    (tmp_path / "plugins").symlink_to(ROOT_FOLDER.parent / "plugins")
    path = folder / document
    path.unlink()
    not_a_file(path, kind)
    out = tmp_path / "out"
    args = [a.format(folder=folder, variant=variant, out=out) for a in COMMANDS[command]]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 3, result.output
    assert str(path) in result.output and f"{document} is a file, or absent" in result.output
    assert not out.exists()


@pytest.mark.parametrize("kind", ["directory", "broken link", "fifo"])
@pytest.mark.parametrize("command", ["validate", "run"])
def test_a_plugin_manifest_that_is_not_a_file_is_refused_not_skipped(tmp_path: Path, kind: str, command: str) -> None:
    """Issue 31: a plugin.json that was a directory, FIFO or broken link was skipped
    silently by validate and run, as if the folder were no plugin."""

    folder = robot(tmp_path, {"hector": SLAM})
    path = folder / "plugins" / "hector" / "plugin.json"
    path.unlink()
    not_a_file(path, kind)
    args = ["validate", str(folder)] if command == "validate" else ["run", str(folder), "--variant", "v", "--clock", "simulated", "--duration", "0.01", "--no-control"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 3, result.output
    assert str(path) in result.output and "plugin.json is a file, or absent" in result.output


# ------------------------------------------- what validate passes, run starts (issue 31)
def _broken_robot(tmp_path: Path, case: str) -> Path:
    """SimpleBot with its Python plugins copied beside it, hectorslam's broken as `case` says."""
    import shutil

    shutil.copytree(ROOT_FOLDER / "simplebot", tmp_path / "bot")
    shutil.copytree(ROOT_FOLDER.parent / "plugins" / "python", tmp_path / "plugins")
    settings = tmp_path / "bot" / "robot.json"
    settings.write_text(json.dumps({"pluginDirectories": ["../plugins"]}))
    module = tmp_path / "plugins" / "hectorslam" / "hector.py"
    if case == "missing":
        module.unlink()
    elif case == "class":
        module.write_text(module.read_text().replace("class HectorSLAM", "class Other"))
    elif case == "syntax":
        module.write_text(module.read_text() + "\ndef (\n")
    elif case == "link":
        outside = tmp_path / "hector.py"
        module.rename(outside)
        module.symlink_to(outside)
    return tmp_path / "bot"


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("missing", "$.entry.module: error: module 'hector' is not in the plugin folder"),
        ("class", "$.entry.class: error: module 'hector' has no class 'HectorSLAM' (its classes: Other)"),
        ("syntax", "$.entry.module: error: module 'hector' does not compile (line "),
        ("link", "$.entry.module: error: module 'hector' leaves the plugin folder (a link)"),
        ("none", ""),
    ],
)
def test_validate_refuses_the_python_plugins_a_run_would_stop_on(tmp_path: Path, case: str, message: str) -> None:
    """validate exited 0 for these, and run then exited 3: validate reads the module
    (compiles it, running nothing) and fails where the run would."""
    robot = _broken_robot(tmp_path, case)
    checked = CliRunner().invoke(main, ["validate", str(robot), "--variant", "field"])
    ran = CliRunner().invoke(
        main, ["run", str(robot), "--variant", "field", "--duration", "0.01", "--clock", "simulated", "--no-control"]
    )
    if case == "none":
        assert checked.exit_code == 0 and ran.exit_code == 0, checked.output + ran.output
    else:
        assert checked.exit_code == 1 and message in checked.output, checked.output
        assert ran.exit_code == 3, ran.output


def test_a_cpp_library_not_built_is_a_warning_and_one_that_links_out_an_error(tmp_path: Path) -> None:
    import shutil

    from motivml.plugins.files import cpp_files as inspect

    folder = tmp_path / "hands"
    shutil.copytree(ROOT_FOLDER.parent / "plugins" / "cpp" / "gestures" / "hands", folder, ignore=shutil.ignore_patterns("build"))
    plugin = next(iter(discover_folder(folder).values()))
    (unbuilt,) = inspect(plugin)
    assert unbuilt.severity.value == "warning" and "does not exist (build it: make cpp-plugins)" in unbuilt.message
    (folder / "build").mkdir()
    (tmp_path / "libhands.so").write_bytes(b"")
    (folder / "build" / "libhands.so").symlink_to(tmp_path / "libhands.so")
    (outside,) = inspect(plugin)
    assert outside.severity.value == "error" and "leaves the plugin folder (a link)" in outside.message
    (folder / "build" / "libhands.so").unlink()
    (folder / "build" / "libhands.so").write_bytes(b"")
    assert inspect(plugin) == []


def discover_folder(folder: Path) -> dict[str, Any]:
    """The plugin of one plugin folder, as a robot of its own declares it."""
    from motivml.documents.robot_folder import Plugin

    manifest = json.loads((folder / "plugin.json").read_text())
    return {manifest["feature"]: Plugin(manifest["feature"], manifest["kind"], manifest["entry"], folder, folder / "plugin.json")}


@pytest.mark.parametrize(
    ("source", "verdict"),
    [
        ("import sys\nfor HectorSLAM in (dict,):\n    pass\n", None),  # bound by a for
        ("def __getattr__(name):\n    return dict\n", None),  # PEP 562: anything may be there
        ("globals()['HectorSLAM'] = dict\n", None),  # bound by a call nobody can read
        ("match 1:\n    case 1:\n        class HectorSLAM:\n            pass\n", None),
        ("if (HectorSLAM := dict):\n    pass\n", None),
        ("x = " + "(" * 300_000 + ")" * 300_000 + "\n", "does not compile"),
        ("class Other:\n    pass\n", "has no class 'HectorSLAM'"),
    ],
    ids=["for", "module getattr", "globals", "match", "walrus", "too deep", "no class"],
)
def test_the_python_inspector_reads_what_modules_bind_and_never_raises(
    tmp_path: Path, source: str, verdict: str | None
) -> None:
    """Review of issue 31: names bound by for, match, walrus or at run time made validate
    refuse plugins that load; a module too deep for the parser raised out of validate."""
    from motivml.plugins.files import python_files as inspect

    robot = _broken_robot(tmp_path, "none")
    (tmp_path / "plugins" / "hectorslam" / "hector.py").write_text(source)
    plugins, _ = discover(RobotFolder.open(robot), load_model(str(robot / "model.json"))[0])
    found = inspect(plugins["hectorslam"])
    assert (found[0].message if found else None) is None if verdict is None else verdict in found[0].message


def test_a_loop_of_links_is_a_link_out_of_the_folder(tmp_path: Path) -> None:
    from motivml.plugins.files import python_files as inspect

    robot = _broken_robot(tmp_path, "none")
    module = tmp_path / "plugins" / "hectorslam" / "hector.py"
    module.unlink()
    module.symlink_to(tmp_path / "plugins" / "hectorslam" / "loop.py")
    (tmp_path / "plugins" / "hectorslam" / "loop.py").symlink_to(module)
    plugins, _ = discover(RobotFolder.open(robot), load_model(str(robot / "model.json"))[0])
    (found,) = inspect(plugins["hectorslam"])
    assert "leaves the plugin folder (a link)" in found.message

"""C++ feature plugins through ROS class_loader: loads, live instances, real unloading, errors."""

from __future__ import annotations

import importlib
import json
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import binder_sync
import pytest

from motivml.documents.robot_folder import Plugin
from motivml.plugins.api import PluginContext
from motivml.plugins.python import PluginError
from motivml.runtime.launch import Robot, launch

ROOT = Path(__file__).resolve().parent.parent
GESTURES = ROOT / "plugins" / "cpp" / "gestures"
BROKEN = ROOT / "plugins" / "cpp" / "broken" / "missing_symbol"


@pytest.fixture(scope="module")
def extension() -> ModuleType:
    """motivml._cpp_plugins and the example libraries, built as `make cpp-plugins` builds them."""
    try:
        return importlib.import_module("motivml._cpp_plugins")
    except ImportError:
        pass
    missing = [tool for tool in ("cmake", "g++") if shutil.which(tool) is None]
    if missing or not Path("/usr/include/class_loader/class_loader/class_loader.hpp").exists():
        pytest.fail("C++ plugins need cmake, g++ and libclass-loader-dev: .ci/run installs them")
    build = ROOT / "build" / "cpp_plugins"
    subprocess.run(
        ["cmake", "-S", str(ROOT / "cpp_plugins"), "-B", str(build), f"-DPython_EXECUTABLE={sys.executable}"],
        check=True,
        capture_output=True,
    )
    subprocess.run(["cmake", "--build", str(build), "-j", "2"], check=True, capture_output=True)
    return importlib.import_module("motivml._cpp_plugins")


def mapped(name: str) -> bool:
    return any(name in line for line in Path("/proc/self/maps").read_text().splitlines())


def test_a_library_never_unloads_under_a_live_instance_and_really_unloads_after(
    extension: ModuleType,
) -> None:
    library = extension.Library(str(GESTURES / "hands" / "build" / "libhands.so"))
    assert library.classes() == ["gestures::Hands"] and library.loaded and library.loads == 1
    instance = library.create("gestures::Hands")
    assert library.live == 1 and mapped("libhands.so")
    with pytest.raises(RuntimeError, match=r"1 instance\(s\) of .*libhands.so still live: not unloading"):
        library.unload()
    assert library.loaded and mapped("libhands.so")
    instance.release()
    assert library.live == 0
    assert library.unload() is False and not library.loaded and library.loads == 0  # nobody else holds it
    assert not mapped("libhands.so")  # dlclose really unmapped it


def test_errors_say_what_the_library_declares(extension: ModuleType) -> None:
    library = extension.Library(str(GESTURES / "pointscloud" / "build" / "libpointscloud.so"))
    with pytest.raises(
        RuntimeError, match=r"declares no class gestures::Hands \(it declares: gestures::PointsCloud\)"
    ):
        library.create("gestures::Hands")
    library.unload()
    with pytest.raises(
        extension.LoadError, match="undefined symbol: motivml_calibration_table_that_nobody_defines"
    ):
        extension.Library(str(BROKEN / "build" / "libmissing_symbol.so"))


def context() -> PluginContext:
    return PluginContext("x", Path("."), 1000.0, lambda s: [0.0], lambda s, v: None, lambda t: None)  # type: ignore[arg-type, return-value]


def manifest(folder: Path) -> Plugin:
    document = json.loads((folder / "plugin.json").read_text())
    return Plugin(document["feature"], "cpp", document["entry"], folder, folder / "plugin.json")


def test_the_broken_plugin_is_reported_with_its_manifest(extension: ModuleType) -> None:
    from motivml.plugins import cpp as cppplugins

    with pytest.raises(PluginError) as caught:
        cppplugins.create(manifest(BROKEN), context())
    [problem] = caught.value.diagnostics
    assert problem.location.path == "$.entry.library"
    assert str(problem.location).startswith(str(BROKEN / "plugin.json"))
    assert "cannot load libmissing_symbol.so: Could not load library dlopen error:" in problem.message
    assert "undefined symbol: motivml_calibration_table_that_nobody_defines" in problem.message


@pytest.fixture
def field(extension: ModuleType) -> Iterator[Robot]:
    robot = launch(ROOT / "feature_models" / "simplebot", "field")
    yield robot
    robot.close()


def ask(robot: Robot, text: str) -> bool:
    return binder_sync.ask(robot, text).accepted


def test_gesture_plugins_load_step_and_unload_in_the_running_robot(field: Robot) -> None:
    assert not mapped("libhands.so")
    assert ask(field, "load gesture_recognition hands")
    assert set(field.runtime.plugins) == {"hectorslam", "hands"} and mapped("libhands.so")
    field.runtime.run(1.6)
    assert field.runtime.plugins["hands"].instance.status().startswith("3 hand gestures, last: ")
    assert ask(field, "load pointscloud")
    field.runtime.run(1.0)
    assert "depth frames" in field.runtime.plugins["pointscloud"].instance.status()
    assert ask(field, "unload gesture_recognition")
    assert set(field.runtime.plugins) == {"hectorslam"}
    assert not mapped("libhands.so") and not mapped("libpointscloud.so")  # stopped, released, unloaded


def test_a_library_link_that_leaves_the_plugin_folder_is_refused(
    extension: ModuleType, tmp_path: Path
) -> None:
    from motivml.plugins import cpp as cppplugins

    folder = tmp_path / "sneaky"
    folder.mkdir()
    (folder / "libhands.so").symlink_to(GESTURES / "hands" / "build" / "libhands.so")
    plugin = Plugin(
        "hands", "cpp", {"library": "libhands.so", "class": "gestures::Hands"}, folder, folder / "plugin.json"
    )
    (folder / "plugin.json").write_text(
        json.dumps({"feature": "hands", "kind": "cpp", "entry": plugin.entry})
    )
    with pytest.raises(PluginError, match="library libhands.so leaves the plugin folder"):
        cppplugins.create(plugin, context())

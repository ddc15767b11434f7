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
from paths import ROOT

from motivml.documents.robot_folder import Plugin
from motivml.plugins.api import PluginContext
from motivml.plugins.python import PluginError
from motivml.runtime.launch import Robot, launch
from motivml.runtime.requests import Load

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


# --------------------------------------- the spaces bridge, throwing plugins, set-up errors
TESTING_CPP = r"""
#include <stdexcept>
#include <string>
#include <vector>

#include <motivml/feature.hpp>

namespace testing_plugins {

class Echo : public motivml::Feature {  // Out = 2 In, every tick
 public:
  void step(double, motivml::Spaces& spaces) override {
    std::vector<double> value = spaces.read("In");
    for (double& v : value) v *= 2.0;
    spaces.write("Out", value);
    ++steps_;
  }
  std::string status() const override { return std::to_string(steps_) + " echoes"; }

 private:
  long steps_ = 0;
};

class Broken : public motivml::Feature {
 public:
  void start() override { throw std::runtime_error("no sensor"); }
  void step(double, motivml::Spaces&) override {}
  void stop() override { throw std::runtime_error("stuck"); }
};

class Stumbling : public motivml::Feature {  // throws in its second step
 public:
  void step(double, motivml::Spaces&) override {
    if (++steps_ == 2) throw std::out_of_range("lost track");
  }

 private:
  long steps_ = 0;
};

}  // namespace testing_plugins

MOTIVML_FEATURE(echo, testing_plugins::Echo)
MOTIVML_FEATURE(broken, testing_plugins::Broken)
MOTIVML_FEATURE(stumbling, testing_plugins::Stumbling)
"""


@pytest.fixture(scope="module")
def testing_library(extension: ModuleType, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two small C++ plugins, compiled as cpp_plugins/CMakeLists.txt compiles a plugin."""
    folder = tmp_path_factory.mktemp("cpp")
    (folder / "testing.cpp").write_text(TESTING_CPP)
    build_plugin(folder / "testing.cpp", folder / "libtesting.so")
    return folder / "libtesting.so"


def build_plugin(source: Path, library: Path) -> None:
    """Compile a plugin with the flags motivml_add_plugin gives (cpp_static/cmake)."""
    includes = [ROOT / "cpp_static" / "include"] + [
        Path("/usr/include") / name for name in ("class_loader", "rcpputils", "rcutils")
    ]
    command = ["g++", "-std=c++17", "-shared", "-fPIC", "-fno-gnu-unique", "-fvisibility=hidden"]
    command += ["-DMOTIVML_PLUGIN_BUILD", *(f"-I{path}" for path in includes)]
    command += [str(source), "-o", str(library), "-Wl,-z,defs"]
    command += ["-lclass_loader", "-lconsole_bridge", "-lrcpputils", "-lrcutils"]
    subprocess.run(command, check=True, capture_output=True)


def cpp_robot(folder: Path, library: Path, classes: dict[str, str]) -> Path:
    """Features x and y (Dynamic Late), spaces In and Out, a C++ plugin per entry of `classes`."""
    model = {
        "id": "bot",
        "name": "Bot",
        "sub": [
            {
                "id": f,
                "name": f,
                "isMandatory": False,
                "constraints": {"bindingTimeAllowed": "Late", "bindingModeAllowed": "Dynamic"},
            }
            for f in ("x", "y")
        ],
    }
    (folder / "variants").mkdir(parents=True)
    (folder / "model.json").write_text(json.dumps(model))
    variant = {"properties": [{"id": f, "props": {"time": "Late", "mode": "Dynamic"}} for f in ("x", "y")]}
    (folder / "variants" / "v.json").write_text(json.dumps(variant))
    (folder / "robot.json").write_text(json.dumps({"pluginDirectories": ["plugins"]}))
    spaces = [{"id": s, "type": "Vector", "dimension": 2, "feature": "bot"} for s in ("In", "Out")]
    (folder / "architecture.json").write_text(json.dumps({"spaces": spaces}))
    for feature, cls in classes.items():
        plugin = folder / "plugins" / feature
        plugin.mkdir(parents=True)
        shutil.copy(library, plugin / "libtesting.so")
        entry = {"library": "libtesting.so", "class": cls}
        (plugin / "plugin.json").write_text(json.dumps({"feature": feature, "kind": "cpp", "entry": entry}))
    return folder


def test_a_cpp_plugin_reads_and_writes_spaces(testing_library: Path, tmp_path: Path) -> None:
    robot = launch(cpp_robot(tmp_path, testing_library, {"x": "testing_plugins::Echo"}), "v")
    try:
        robot.runtime.send("In", [0.25, -1.5])
        assert robot.binder.request_between_ticks(Load(("x",))).accepted
        robot.runtime.run(0.003)
        assert robot.runtime.assembly.values["Out"].tolist() == [0.5, -3.0]
        assert robot.runtime.status().plugins == (("x", "3 echoes"),)
    finally:
        robot.close()
    assert not mapped(str(tmp_path / "plugins" / "x" / "libtesting.so"))  # released and unloaded


def test_a_cpp_start_that_throws_refuses_the_load_and_a_throwing_stop_is_noted(
    testing_library: Path, tmp_path: Path
) -> None:
    robot = launch(cpp_robot(tmp_path, testing_library, {"y": "testing_plugins::Broken"}), "v")
    try:
        outcome = robot.binder.request_between_ticks(Load(("y",)))
        assert (
            not outcome.accepted and outcome.reason == "start() of plugin y failed: RuntimeError: no sensor"
        )
        assert [text for _, _, text in robot.runtime.notes] == [
            "stop() of plugin y raised RuntimeError: stuck",
            "refused load y: start() of plugin y failed: RuntimeError: no sensor",
        ]
        assert robot.runtime.plugins == {} and "y" not in robot.binder.active
        assert not mapped(str(tmp_path / "plugins" / "y" / "libtesting.so"))  # released all the same
    finally:
        robot.close()


def test_a_cpp_step_that_throws_is_a_fault_that_unloads_its_feature(
    testing_library: Path, tmp_path: Path
) -> None:
    folder = cpp_robot(tmp_path, testing_library, {"x": "testing_plugins::Stumbling"})
    robot = launch(folder, "v")
    try:
        robot.binder.make_changes_between_ticks()  # as a simulated run does
        assert robot.binder.request_between_ticks(Load(("x",))).accepted
        robot.runtime.run(0.005)
        assert robot.runtime.ticks == 5 and robot.runtime.failure is None  # the loop went on
        assert [(f.feature, f.error) for f in robot.runtime.faults] == [("x", "IndexError: lost track")]
        assert "unloaded x after the fault of x" in [text for _, _, text in robot.runtime.notes]
        assert robot.runtime.plugins == {} and "x" not in robot.binder.active
        assert not mapped(str(folder / "plugins" / "x" / "libtesting.so"))  # stopped, released
    finally:
        robot.close()


def test_set_up_errors_name_the_manifest_entry(
    testing_library: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from motivml.plugins import cpp as cppplugins

    folder = cpp_robot(tmp_path, testing_library, {"x": "testing_plugins::Feet"})
    plugin = manifest(folder / "plugins" / "x")
    with pytest.raises(PluginError) as caught:
        cppplugins.create(plugin, context())
    [problem] = caught.value.diagnostics
    assert problem.location.path == "$.entry.class"
    assert "declares no class testing_plugins::Feet" in problem.message
    assert "testing_plugins::Broken" in problem.message and "testing_plugins::Echo" in problem.message
    assert not mapped(str(folder / "plugins" / "x" / "libtesting.so"))
    (folder / "plugins" / "x" / "libtesting.so").unlink()
    with pytest.raises(PluginError, match=r"libtesting.so does not exist \(build it: make cpp-plugins\)"):
        cppplugins.create(plugin, context())
    import motivml

    monkeypatch.delattr(motivml, "_cpp_plugins")  # as if it was never built
    monkeypatch.setitem(sys.modules, "motivml._cpp_plugins", None)
    with pytest.raises(PluginError) as missing:
        cppplugins.create(plugin, context())
    assert missing.value.diagnostics[0].message == (
        "C++ plugin support is not built into this installation: in a checkout, run make cpp-plugins; "
        "else reinstall motivml (pip install) where cmake, g++, python3-dev and libclass-loader-dev are installed"
    )
    assert missing.value.diagnostics[0].location.path == "$.entry.library"


# ------------------------------------------------ a library that cannot load poisons nothing
def test_a_library_whose_static_initialiser_throws_leaves_the_running_process_able_to_load(
    extension: ModuleType, tmp_path: Path
) -> None:
    # loaded in the running process, the exception would leave the dynamic loader's lock
    # held: the next load (from another thread) and the exit would hang; probed in a child
    # process first, it is only refused
    source = ROOT / "plugins" / "cpp" / "broken" / "throwing_initialiser"
    broken = tmp_path / "plugins" / "broken_initialiser"
    broken.mkdir(parents=True)
    build_plugin(source / "broken.cpp", broken / "libthrowing_initialiser.so")
    entry = {"library": "libthrowing_initialiser.so", "class": "broken::ThrowingInitialiser"}
    (broken / "plugin.json").write_text(
        json.dumps({"feature": "broken_initialiser", "kind": "cpp", "entry": entry})
    )
    hands = tmp_path / "plugins" / "hands"
    hands.mkdir()
    shutil.copy(GESTURES / "hands" / "build" / "libhands.so", hands / "libhands.so")
    entry = {"library": "libhands.so", "class": "gestures::Hands"}
    (hands / "plugin.json").write_text(json.dumps({"feature": "hands", "kind": "cpp", "entry": entry}))
    late = {"bindingTimeAllowed": "Late", "bindingModeAllowed": "Dynamic"}
    features = ("broken_initialiser", "hands")
    sub = [{"id": f, "name": f, "isMandatory": False, "constraints": late} for f in features]
    (tmp_path / "model.json").write_text(json.dumps({"id": "bot", "name": "Bot", "sub": sub}))
    (tmp_path / "variants").mkdir()
    variant = {"properties": [{"id": f, "props": {"time": "Late", "mode": "Dynamic"}} for f in features]}
    (tmp_path / "variants" / "v.json").write_text(json.dumps(variant))
    (tmp_path / "robot.json").write_text(json.dumps({"pluginDirectories": ["plugins"]}))
    run = [sys.executable, "-m", "motivml.cli", "run", str(tmp_path), "--variant", "v", "--no-control"]
    run += ["--duration", "1", "--clock", "real"]  # requests are prepared on the binder's thread
    run += ["--at", "0.2", "load broken_initialiser", "--at", "0.5", "load hands"]
    done = subprocess.run(run, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr
    assert (
        "$.entry.library: error: cannot load libthrowing_initialiser.so: Could not load library no calibration file"
        in done.stdout
    )
    assert "request at 0.500 s (tick 500): load hands: accepted" in done.stdout

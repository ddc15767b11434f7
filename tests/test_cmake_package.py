"""The motivml CMake package, used as a project outside this repository would use it.

The test writes a small C++ project in a temporary folder: `find_package(motivml)` with
`motivml cmake-dir` on CMAKE_PREFIX_PATH, one `motivml_configure` and one
`motivml_add_plugin`. Its robot has two features, `logger` (always Static Early) and `hands`,
whose one source (the gesture feature of plugins/cpp) is compiled in by the variant that
binds it Static Early and built as a plugin for the variant that binds it Dynamic Late. The
static program holds exactly its Static Early features; the plugin loads in `motivml run`;
and the feature behaves the same both ways.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from helpers import simulated_run
from paths import ROOT

from motivml.cli import main

pytestmark = pytest.mark.slow  # builds C++ projects with CMake

HANDS = ROOT / "plugins" / "cpp" / "gestures" / "include" / "motivml_features" / "hands.hpp"

CMAKELISTS = """\
cmake_minimum_required(VERSION 3.18)
project(outside LANGUAGES CXX)
find_package(motivml 0.1 CONFIG REQUIRED)

add_executable(robot main.cpp)
target_include_directories(robot PRIVATE features)
motivml_configure(TARGET robot ROBOT ${CMAKE_SOURCE_DIR}/robot VARIANT compiled_in)

motivml_add_plugin(hands SOURCES hands.cpp OUTPUT_DIRECTORY ${CMAKE_SOURCE_DIR}/robot/plugins/hands)
target_include_directories(hands PRIVATE features)
motivml_add_plugin(calibrated SOURCES calibrated.cpp OUTPUT_DIRECTORY ${CMAKE_SOURCE_DIR}/robot/plugins/calibrated)
"""

CALIBRATED = """\
#include <cstdlib>
#include <fstream>
#include <stdexcept>

#include <motivml/feature.hpp>

namespace calibrated {

// Loaded, it reads its calibration; stopped, it uses it up (the file is gone after).
struct Calibration {
  Calibration() {
    if (std::ifstream(std::getenv("CALIBRATION_USED")).good()) throw std::runtime_error("no calibration file");
  }
};
const Calibration calibration;

class Calibrated : public motivml::Feature {
 public:
  void step(double, motivml::Spaces&) override {}
  void stop() override { std::ofstream(std::getenv("CALIBRATION_USED")) << "used\\n"; }
};

}  // namespace calibrated

MOTIVML_FEATURE(calibrated, calibrated::Calibrated)
"""

MAIN = """\
// robot --list: the compiled-in features; robot SECONDS: step them at 1 kHz, print statuses.
#include <cstdlib>
#include <cstring>
#include <iostream>

#include <motivml/static_loader.hpp>

int main(int argc, char** argv) {
  motivml::FeatureRegistry registry;
  motivml::register_static_features(registry);
  if (argc > 1 && std::strcmp(argv[1], "--list") == 0) {
    for (const auto& id : registry.ids()) std::cout << id << "\\n";
    return 0;
  }
  const int ticks = static_cast<int>(std::atof(argv[1]) * 1000);
  motivml::MapSpaces spaces;
  registry.start_all();
  for (int tick = 0; tick < ticks; ++tick) registry.step_all(tick * 0.001, spaces);
  for (const auto& id : registry.ids()) std::cout << id << ": " << registry.at(id).status() << "\\n";
  registry.stop_all();
  return 0;
}
"""

LOGGER = """\
#pragma once
#include <string>
#include <motivml/feature.hpp>
namespace outside {
class Logger : public motivml::Feature {
 public:
  void step(double, motivml::Spaces&) override { ++lines_; }
  std::string status() const override { return std::to_string(lines_) + " lines"; }
 private:
  long lines_ = 0;
};
}  // namespace outside
MOTIVML_FEATURE(logger, outside::Logger)
"""


def robot(folder: Path) -> None:
    features = [
        {"id": "logger", "name": "Logger"},
        {
            "id": "hands",
            "name": "Hands",
            "isMandatory": False,
            "constraints": {"bindingTimeAllowed": "Any", "bindingModeAllowed": "Any"},
        },
        {
            "id": "calibrated",
            "name": "Calibrated",
            "isMandatory": False,
            "constraints": {"bindingTimeAllowed": "Late", "bindingModeAllowed": "Dynamic"},
        },
    ]
    (folder / "variants").mkdir(parents=True)
    (folder / "model.json").write_text(json.dumps({"id": "bot", "name": "Bot", "sub": features}, indent=2))
    for name, time, mode in (("compiled_in", "Early", "Static"), ("plugin", "Late", "Dynamic")):
        entries = [{"id": "logger"}, {"id": "hands", "props": {"time": time, "mode": mode}}]
        entries.append({"id": "calibrated", "selected": name == "plugin"})
        (folder / "variants" / f"{name}.json").write_text(json.dumps({"properties": entries}, indent=2))
    (folder / "robot.json").write_text(json.dumps({"pluginDirectories": ["plugins"]}))
    spaces = [{"id": "Gesture", "type": "Vector", "dimension": 1, "feature": "bot"}]
    (folder / "architecture.json").write_text(json.dumps({"spaces": spaces}))
    plugin = folder / "plugins" / "hands"
    plugin.mkdir(parents=True)
    entry = {"library": "libhands.so", "class": "gestures::Hands"}
    (plugin / "plugin.json").write_text(json.dumps({"feature": "hands", "kind": "cpp", "entry": entry}))
    plugin = folder / "plugins" / "calibrated"
    plugin.mkdir(parents=True)
    entry = {"library": "libcalibrated.so", "class": "calibrated::Calibrated"}
    (plugin / "plugin.json").write_text(json.dumps({"feature": "calibrated", "kind": "cpp", "entry": entry}))


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if shutil.which("cmake") is None or shutil.which("g++") is None:
        pytest.fail("cmake and g++ are needed: .ci/run installs them")
    folder = tmp_path_factory.mktemp("outside")
    (folder / "CMakeLists.txt").write_text(CMAKELISTS)
    (folder / "main.cpp").write_text(MAIN)
    (folder / "hands.cpp").write_text("#include <motivml_features/hands.hpp>\n")
    (folder / "calibrated.cpp").write_text(CALIBRATED)
    features = folder / "features" / "motivml_features"
    features.mkdir(parents=True)
    shutil.copy(HANDS, features / "hands.hpp")  # the one source of the feature, both ways
    (features / "logger.hpp").write_text(LOGGER)
    robot(folder / "robot")
    cmake_dir = CliRunner().invoke(main, ["cmake-dir"]).output.strip()
    motivml = Path(sys.executable).with_name("motivml")
    configure = ["cmake", "-S", str(folder), "-B", str(folder / "build"), f"-DCMAKE_PREFIX_PATH={cmake_dir}"]
    configure.append(f"-DMOTIVML_EXECUTABLE={motivml}")
    subprocess.run(configure, check=True, capture_output=True, text=True)
    subprocess.run(["cmake", "--build", str(folder / "build"), "-j", "2"], check=True, capture_output=True)
    return folder


def test_cmake_dir_names_the_package() -> None:
    result = CliRunner().invoke(main, ["cmake-dir"])
    assert result.exit_code == 0
    folder = Path(result.output.strip())
    assert (folder / "motivmlConfig.cmake").is_file() and (
        folder.parent / "include" / "motivml" / "feature.hpp"
    ).is_file()
    version = (folder / "motivmlConfigVersion.cmake").read_text()
    project = (ROOT / "pyproject.toml").read_text()
    assert re.search(r'PACKAGE_VERSION "([^"]+)"', version).group(1) == re.search(  # type: ignore[union-attr]
        r'^version = "([^"]+)"', project, re.M
    ).group(1)


def test_the_static_program_holds_exactly_its_static_early_features(project: Path) -> None:
    listed = subprocess.run([str(project / "build" / "robot"), "--list"], capture_output=True, text=True)
    assert listed.stdout.split() == ["logger", "hands"]
    assert (project / "robot" / "plugins" / "hands" / "libhands.so").is_file()


def test_one_source_behaves_the_same_compiled_in_and_as_a_plugin(project: Path) -> None:
    static = subprocess.run(
        [str(project / "build" / "robot"), "2"], capture_output=True, text=True, check=True
    )
    compiled_in = dict(line.split(": ", 1) for line in static.stdout.splitlines())
    result = CliRunner().invoke(main, simulated_run(project / "robot", "plugin", 3, (1, "load hands")))
    assert result.exit_code == 0, result.output
    assert "request at 1.000 s (tick 1000): load hands: accepted" in result.output
    (status,) = re.findall(r"plugin hands: (.*)", result.output)
    # two seconds of steps each: compiled in from 0 s, as a plugin from 1 s to 3 s
    assert status == compiled_in["hands"] == "3 hand gestures, last: wave"


def test_a_missing_motivml_says_how_to_point_cmake_at_it(project: Path, tmp_path: Path) -> None:
    cmake_dir = CliRunner().invoke(main, ["cmake-dir"]).output.strip()
    result = subprocess.run(
        [
            "cmake",
            "-S",
            str(project),
            "-B",
            str(tmp_path / "build"),
            f"-DCMAKE_PREFIX_PATH={cmake_dir}",
            "-DMOTIVML_EXECUTABLE=MOTIVML_EXECUTABLE-NOTFOUND",
        ],
        capture_output=True,
        text=True,
        env={"PATH": "/usr/bin:/bin"},
    )
    assert result.returncode != 0
    message = " ".join(result.stderr.split())
    assert (
        "the motivml command was not found" in message and "-DMOTIVML_EXECUTABLE=/path/to/motivml" in message
    )


def test_an_installation_without_the_package_says_so(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A motivml whose files lost the CMake package (neither a wheel's nor a checkout's): exit 3."""
    from motivml.cli import building

    monkeypatch.setattr(building, "__file__", str(tmp_path / "motivml" / "cli" / "building.py"))
    result = CliRunner().invoke(main, ["cmake-dir"])
    assert result.exit_code == 3
    assert "no motivmlConfig.cmake in this installation of motivml" in result.output


def test_a_library_that_loaded_once_is_probed_again_before_it_is_mapped_again(project: Path) -> None:
    """Issue 31: a library probed and loaded cleanly was not probed again while its file was
    unchanged, but its initialiser may throw the next time: then it threw inside the robot,
    and every later load (and the exit) hung. Every load that maps it again is one a child
    made just before: built by motivml_add_plugin, `calibrated` uses up its calibration when
    it stops, so its second load is refused, and `hands` still loads after it."""
    import os

    run = [sys.executable, "-m", "motivml.cli", "run", str(project / "robot"), "--variant", "plugin"]
    run += ["--no-control", "--duration", "1", "--clock", "real"]  # requests prepared on the binder's thread
    run += ["--at", "0.1", "load calibrated", "--at", "0.3", "unload calibrated"]
    run += ["--at", "0.5", "load calibrated", "--at", "0.7", "load hands"]
    used = project / "calibration-used"
    used.unlink(missing_ok=True)
    done = subprocess.run(run, capture_output=True, text=True, timeout=60, env={**os.environ, "CALIBRATION_USED": str(used)})
    said = done.stdout + done.stderr
    assert done.returncode == 0, said
    assert "request at 0.100 s (tick 100): load calibrated: accepted" in said, said
    assert "request at 0.500 s (tick 500): load calibrated: refused, nothing changed" in said, said
    assert "cannot load libcalibrated.so: Could not load library no calibration file" in said, said
    assert "request at 0.700 s (tick 700): load hands: accepted" in said, said

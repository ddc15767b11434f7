"""Real wheels and an sdist: an installed motivml works without a checkout.

The wheel carries the schemas, the CMake package and, when this machine can build it (CMake,
a compiler, Python's and class_loader's headers: what .ci/run installs), the C++ plugin
extension (hatch_build.py). A fresh virtual environment installs the built wheel, not an
editable install, and runs validate, configure and a C++ plugin swap from it. (Its other
dependencies are borrowed from this environment through a path file, so that the test does
not download them again; motivml itself comes from the wheel, as the test checks.)
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import venv
import zipfile
from pathlib import Path

import pytest
from helpers import simulated_run
from paths import ROOT

pytestmark = pytest.mark.slow  # builds the sdist and the wheel, installs them in fresh environments

CPP_READY = (
    shutil.which("cmake") is not None
    and Path("/usr/include/class_loader/class_loader/class_loader.hpp").is_file()
)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(folder), str(ROOT)],
        check=True,
        env={**os.environ, "MOTIVML_CPP_PLUGINS": "1" if CPP_READY else ""},
    )
    (built,) = folder.glob("motivml-*.whl")
    return built


def test_wheel_contains_schemas_cmake_package_extension_and_console_script(wheel: Path) -> None:
    names = zipfile.ZipFile(wheel).namelist()
    assert "motivml/schemas/feature-model.schema.json" in names
    assert "motivml/schemas/configuration.schema.json" in names
    assert "motivml/cmake/motivmlConfig.cmake" in names and "motivml/include/motivml/feature.hpp" in names
    assert any(n.endswith("dist-info/licenses/LICENSE") or n.endswith("dist-info/LICENSE") for n in names)
    entry_points = next(n for n in names if n.endswith("entry_points.txt"))
    assert "motivml = motivml.__main__:run" in zipfile.ZipFile(wheel).read(entry_points).decode()
    extension = [n for n in names if re.fullmatch(r"motivml/_cpp_plugins\..*\.so", n)]
    assert len(extension) == (1 if CPP_READY else 0)
    if CPP_READY:
        assert "-linux_" in wheel.name  # a platform wheel, since it holds compiled code


def test_a_pure_wheel_says_why_it_has_no_cpp_plugins(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-v", "-w", str(tmp_path), str(ROOT)],
        capture_output=True,
        text=True,
        env={**os.environ, "MOTIVML_CPP_PLUGINS": "0"},
        check=True,
    )
    assert (
        "building the wheel without C++ plugin support (MOTIVML_CPP_PLUGINS=0)"
        in result.stdout + result.stderr
    )
    (built,) = tmp_path.glob("motivml-*.whl")
    assert built.name.endswith("-py3-none-any.whl")
    assert not [n for n in zipfile.ZipFile(built).namelist() if "_cpp_plugins" in n]


def test_sdist_holds_what_a_build_from_it_needs(tmp_path: Path) -> None:
    subprocess.run(
        [sys.executable, "-m", "build", "--sdist", "-o", str(tmp_path), str(ROOT)],
        check=True,
        capture_output=True,
    )
    (sdist,) = tmp_path.glob("motivml-*.tar.gz")
    names = {name.split("/", 1)[1] for name in tarfile.open(sdist).getnames() if "/" in name}
    for needed in (
        "LICENSE",
        "pyproject.toml",
        "hatch_build.py",
        "schemas/feature-model.schema.json",
        "cpp_plugins/CMakeLists.txt",
        "cpp_plugins/loader/module.cpp",
        "cpp_static/cmake/motivmlConfig.cmake",
        "cpp_static/include/motivml/feature.hpp",
    ):
        assert needed in names, needed


def test_a_fresh_environment_runs_the_installed_wheel(wheel: Path, tmp_path: Path) -> None:
    env_dir = tmp_path / "env"
    venv.create(env_dir, with_pip=True)
    python = env_dir / "bin" / "python"
    subprocess.run([str(python), "-m", "pip", "install", "--quiet", "--no-deps", str(wheel)], check=True)
    site = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    (Path(site) / "borrowed-dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    motivml = str(env_dir / "bin" / "motivml")
    work = tmp_path / "work"
    shutil.copytree(ROOT / "feature_models", work / "feature_models")
    shutil.copytree(ROOT / "plugins", work / "plugins")

    def run(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [motivml, *args], cwd=work, capture_output=True, text=True, env={"PATH": os.environ["PATH"]}
        )

    where = subprocess.run(
        [str(python), "-c", "import motivml; print(motivml.__file__)"],
        capture_output=True,
        text=True,
        cwd=work,
    )
    assert where.stdout.startswith(site), where.stdout  # the wheel's motivml, not this checkout's
    assert run("--version").stdout.strip() == "motivml, version 0.1.0"
    assert run("cmake-dir").stdout.strip() == str(Path(site) / "motivml" / "cmake")
    assert run("validate", "feature_models/simplebot", "--variant", "field").returncode == 0
    configured = run(
        "configure", "feature_models/simplebot", "--variant", "field", "-o", str(tmp_path / "out")
    )
    assert configured.returncode == 0 and (tmp_path / "out" / "static_loader.hpp").is_file()
    if not CPP_READY:
        return
    if not (ROOT / "plugins" / "cpp" / "gestures" / "hands" / "build" / "libhands.so").is_file():
        pytest.fail("the example C++ plugins are not built: make cpp-plugins")
    swapped = run(
        *simulated_run(
            "feature_models/simplebot",
            "field",
            3,
            (1, "load gesture_recognition hands"),
            (2, "swap hands pointscloud"),
        )
    )
    assert swapped.returncode == 0, swapped.stdout + swapped.stderr
    assert "swap hands pointscloud: accepted" in swapped.stdout
    assert "plugin pointscloud: 16 depth frames, 2 clusters" in swapped.stdout  # 1 s at 15 Hz, both ends


INTERRUPTED_IMPORT = """
import sys
class Interrupting:  # Ctrl-C arriving while click is imported, as at a command's first tenth of a second
    def find_spec(self, name, path=None, target=None):
        if name == "click":
            raise KeyboardInterrupt
sys.meta_path.insert(0, Interrupting())
sys.argv = ["motivml", "validate", "nothing.json"]
from motivml.__main__ import run
run()
"""


def test_ctrl_c_during_the_imports_ends_with_one_line_and_130() -> None:
    """Issue 31: Ctrl-C in the first second printed a KeyboardInterrupt traceback from the
    imports. The script's entry imports the command line inside the same guard as the
    command: one line, exit code 130."""
    ended = subprocess.run([sys.executable, "-c", INTERRUPTED_IMPORT], capture_output=True, text=True, timeout=60)
    assert ended.returncode == 130, ended.stderr
    assert ended.stderr == "interrupted\n" and ended.stdout == ""


def test_ctrl_c_before_the_command_runs_is_caught_by_the_entry(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The same guard, in this process: whatever of the start-up is interrupted."""
    import motivml.cli
    from motivml.__main__ import run

    def interrupted() -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(motivml.cli, "console", interrupted)
    try:
        with pytest.raises(SystemExit) as ended:
            run()
    finally:
        sys.modules.pop("motivml.__main__", None)  # (as -m finds it: not imported yet)
    assert ended.value.code == 130 and capsys.readouterr().err == "interrupted\n"


def test_python_dash_m_motivml_is_the_command(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`python -m motivml` runs the command (run here in-process, as -m runs it)."""
    import runpy

    monkeypatch.setattr(sys, "argv", ["motivml", "--version"])
    with pytest.raises(SystemExit) as ended:
        runpy.run_module("motivml", run_name="__main__")
    assert ended.value.code == 0
    assert capsys.readouterr().out == "motivml, version 0.1.0\n"

"""The C++ side: two SimpleBot variants built through CMake contain exactly their Static
Early features (listed by the program and proven by marker strings in the binaries), and
ctest passes (GoogleTest unit tests and a run of each demo)."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from paths import ROOT

VARIANTS = ["lab", "field"]


@pytest.fixture(scope="module")
def build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    missing = [tool for tool in ("cmake", "g++") if shutil.which(tool) is None]
    if missing:
        pytest.fail(
            f"{', '.join(missing)} not installed: .ci/run installs them (apt-get install cmake g++ libgtest-dev)"
        )
    folder = tmp_path_factory.mktemp("cpp")
    motivml = Path(sys.executable).with_name("motivml")
    generator = ["-G", "Ninja"] if shutil.which("ninja") else []
    subprocess.run(
        [
            "cmake",
            "-S",
            str(ROOT / "cpp_static"),
            "-B",
            str(folder),
            *generator,
            f"-DMOTIVML_EXECUTABLE={motivml}",
        ],
        check=True,
        capture_output=True,
    )
    subprocess.run(["cmake", "--build", str(folder), "-j", "2"], check=True, capture_output=True)
    return folder


def static_early(build: Path, variant: str) -> list[str]:
    text = (build / "motivml" / f"simplebot_{variant}" / "motivml" / "bindings.yaml").read_text()
    (line,) = [line for line in text.splitlines() if line.strip().startswith("static_early:")]
    ids = [i.strip().strip('"') for i in line.split("[", 1)[1].rstrip("]").split(",") if i.strip()]
    return [i for i in ids if i != "root_feature"]  # the root is the program itself


@pytest.mark.parametrize("variant", VARIANTS)
def test_binary_lists_exactly_its_static_features(build: Path, variant: str) -> None:
    listed = subprocess.run(
        [str(build / f"simplebot_{variant}"), "--list"], check=True, capture_output=True, text=True
    )
    assert listed.stdout.split() == static_early(build, variant)


@pytest.mark.parametrize("variant", VARIANTS)
def test_binary_contains_no_other_feature_code(build: Path, variant: str) -> None:
    binary = (build / f"simplebot_{variant}").read_bytes()
    markers = set(re.findall(rb"motivml-feature:([a-z0-9_]+)", binary))
    assert {m.decode() for m in markers} == set(static_early(build, variant))


def test_variants_differ(build: Path) -> None:
    assert static_early(build, "lab") != static_early(build, "field")


def test_ctest_passes(build: Path) -> None:
    result = subprocess.run(["ctest", "--output-on-failure"], cwd=build, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "100% tests passed" in result.stdout


def test_a_static_early_feature_without_its_header_fails_the_build(tmp_path: Path) -> None:
    """Strict static binding: grid_map is Static Early in lab, so compiled in; with its header
    misnamed, the build stops with an error naming the feature and the header it expected."""
    if shutil.which("g++") is None:
        pytest.fail("g++ not installed: .ci/run installs it")
    features = tmp_path / "features" / "motivml_features"
    shutil.copytree(ROOT / "cpp_static" / "features" / "motivml_features", features)
    (features / "grid_map.hpp").rename(features / "gridmap.hpp")  # the typo a new user makes
    motivml = Path(sys.executable).with_name("motivml")
    out = tmp_path / "lab"
    subprocess.run(
        [str(motivml), "configure", str(ROOT / "feature_models" / "simplebot"), "--variant", "lab", "-o", str(out)],
        check=True,
        capture_output=True,
    )
    (tmp_path / "main.cpp").write_text('#include "static_loader.hpp"\nint main() { return 0; }\n')
    # (-iquote: a folder holding features.h must not shadow the C library's <features.h>)
    command = ["g++", "-std=c++17", "-fsyntax-only", "-iquote", str(out), f"-I{ROOT / 'cpp_static' / 'include'}"]
    command += [f"-I{tmp_path / 'features'}", str(tmp_path / "main.cpp")]
    broken = subprocess.run(command, capture_output=True, text=True)
    assert broken.returncode != 0
    errors = [line for line in broken.stderr.splitlines() if ": error: " in line]
    assert len(errors) == 1, broken.stderr  # grid_map, and nothing else
    assert "grid_map is Static Early in lab, so it is compiled in" in errors[0]
    assert "<motivml_features/grid_map.hpp> was not found" in errors[0]
    (features / "gridmap.hpp").rename(features / "grid_map.hpp")
    assert subprocess.run(command, capture_output=True, text=True).returncode == 0

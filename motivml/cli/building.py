"""cmake-dir: where the motivml CMake package is, for C++ projects outside this repository."""

from __future__ import annotations

from pathlib import Path

import click

from ..errors import EnvironmentProblem, Location, error
from .common import fail

CONFIG = "motivmlConfig.cmake"


def cmake_dir() -> Path:
    """The folder holding motivmlConfig.cmake: inside the installed package (a wheel carries
    it as motivml/cmake), or in the source tree of an editable install (cpp_static/cmake)."""
    package = Path(__file__).resolve().parent.parent
    for folder in (package / "cmake", package.parent / "cpp_static" / "cmake"):
        if (folder / CONFIG).is_file():
            return folder
    raise EnvironmentProblem(
        error(
            Location(str(package)),
            f"no {CONFIG} in this installation of motivml (looked in {package / 'cmake'} and "
            f"{package.parent / 'cpp_static' / 'cmake'}): reinstall it from a wheel or the source tree",
            "io",
        )
    )


@click.command("cmake-dir")
def cmake_dir_command() -> None:
    """Print the folder of the motivml CMake package.

    Put it on CMAKE_PREFIX_PATH (or set motivml_DIR to it), and find_package(motivml CONFIG
    REQUIRED) gives motivml::feature, motivml_configure and motivml_add_plugin:

        cmake -S . -B build -DCMAKE_PREFIX_PATH="$(motivml cmake-dir)"
    """
    try:
        click.echo(str(cmake_dir()))
    except EnvironmentProblem as exc:
        fail(exc)

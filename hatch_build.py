"""Wheel build hook: C++ plugin support built into the wheel when this machine can build it.

`pip install .` and `pip wheel .` run this before the wheel is packed. It builds the Python
extension motivml._cpp_plugins (cpp_plugins/, CMake, pybind11, ROS class_loader) in a
temporary folder and puts it into the wheel, which then is a platform wheel. When CMake, a
C++ compiler or the class_loader headers are missing, the wheel is built without it (pure
Python) and says so once: motivml works, and `motivml run` refuses C++ plugins, saying how
to get them. An editable install (`pip install -e .`, `make setup`) builds nothing here:
`make cpp-plugins` builds the extension into the source tree instead.

Set MOTIVML_CPP_PLUGINS=0 to build a pure wheel on purpose, =1 to fail when the extension
cannot be built.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path
from typing import Any

from hatchling.builders.hooks.plugin.interface import BuildHookInterface

CLASS_LOADER_HEADER = "class_loader/class_loader/class_loader.hpp"


class CppPluginsHook(BuildHookInterface):  # type: ignore[misc]
    def initialize(self, version: str, build_data: dict[str, Any]) -> None:
        if version == "editable":
            return
        wanted = os.environ.get("MOTIVML_CPP_PLUGINS", "")
        if wanted == "0":
            self._without("MOTIVML_CPP_PLUGINS=0")
            return
        why = self._missing()
        if why:
            if wanted == "1":
                raise RuntimeError(f"motivml: cannot build C++ plugin support: {why}")
            self._without(why)
            return
        self._folder = tempfile.mkdtemp(prefix="motivml-cpp-")
        build = Path(self._folder)
        configure = ["cmake", "-S", str(Path(self.root) / "cpp_plugins"), "-B", str(build / "build")]
        configure += [f"-DPython_EXECUTABLE={sys.executable}", f"-DMOTIVML_EXTENSION_DIR={build / 'out'}"]
        configure += ["-DMOTIVML_EXAMPLE_PLUGINS=OFF", "-DCMAKE_BUILD_TYPE=Release"]
        try:
            subprocess.run(configure, check=True, capture_output=True, text=True)
            subprocess.run(
                ["cmake", "--build", str(build / "build"), "-j", str(os.cpu_count() or 1)],
                check=True,
                capture_output=True,
                text=True,
            )
        except subprocess.CalledProcessError as exc:
            why = f"CMake failed: {(exc.stderr or exc.stdout or '').strip().splitlines()[-1:]}"
            if wanted == "1":
                raise RuntimeError(f"motivml: cannot build C++ plugin support: {why}") from None
            self._without(why)
            return
        (extension,) = (build / "out").glob("_cpp_plugins*.so")
        build_data["force_include"][str(extension)] = f"motivml/{extension.name}"
        build_data["pure_python"] = False
        build_data["infer_tag"] = True
        self.app.display_info(f"motivml: C++ plugin support built into the wheel ({extension.name})")

    def finalize(self, version: str, build_data: dict[str, Any], artifact_path: str) -> None:
        folder = getattr(self, "_folder", None)
        if folder:
            shutil.rmtree(folder, ignore_errors=True)

    def _missing(self) -> str:
        """Why the extension cannot be built here; '' when it can."""
        for tool in ("cmake", "c++"):
            if shutil.which(tool) is None and not (tool == "c++" and shutil.which("g++")):
                return f"no {tool} on PATH"
        include = Path(sysconfig.get_paths()["include"])
        if not (include / "Python.h").is_file():
            return f"no Python headers ({include / 'Python.h'}; Debian: python3-dev)"
        if not any(
            (Path(prefix) / "include" / CLASS_LOADER_HEADER).is_file() for prefix in ("/usr", "/usr/local")
        ):
            return "no ROS class_loader headers (Debian, Ubuntu: apt-get install libclass-loader-dev)"
        return ""

    def _without(self, why: str) -> None:
        self.app.display_warning(
            f"motivml: building the wheel without C++ plugin support ({why}); Python plugins and "
            "everything else work, and motivml run says so if a variant needs a C++ plugin"
        )

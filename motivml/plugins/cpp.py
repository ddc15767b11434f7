"""C++ feature plugins: shared libraries loaded through ROS class_loader.

The extension `motivml._cpp_plugins` (cpp_plugins/, built by `make cpp-plugins`) wraps
class_loader. Each `Library` counts its loads and its live instances, refuses to unload
while an instance lives, and really unmaps the library (dlclose) once the last one is
released. `CppPlugin` adapts a C++ instance to the runtime's plugin interface (start, step,
stop, status): its stop() also releases the C++ object and unloads the library.
Every failure is a `PluginError` at the manifest's `entry.library` or `entry.class`:
- the extension is not built;
- the library file is missing;
- dlopen fails (an undefined symbol, say, or a static initialiser that throws);
- the library does not declare the class (the message lists the classes it does).

A library is loaded in a child process first, and only when that succeeded in the running
process: a library that cannot load must never poison it (a static initialiser that throws
unwinds through dlopen and leaves the dynamic loader's lock held, so every later load from
another thread, and the exit, would hang). The child loads it every time the running
process is about to map it (no instance of it lives here): a library that loaded cleanly
once may throw the next time (its calibration file has gone since), so no verdict is kept.
While an instance lives, a further load maps nothing and runs no initialiser: no probe.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
from pathlib import Path
from types import ModuleType
from typing import Any

from ..documents.robot_folder import Plugin
from ..errors import Diagnostic
from .api import PluginContext
from .files import inside, plugin_error


def _extension() -> ModuleType | None:
    try:
        from .. import _cpp_plugins  # type: ignore[attr-defined]
    except ImportError:
        return None
    module: ModuleType = _cpp_plugins
    return module


PROBE_TIMEOUT = 30.0  # s for a child process to load a library
_PROBE = """
import importlib.util, sys
spec = importlib.util.spec_from_file_location("_cpp_plugins", sys.argv[1])
extension = importlib.util.module_from_spec(spec)
spec.loader.exec_module(extension)
try:
    extension.Library(sys.argv[2])
except RuntimeError as exc:
    lines = str(exc).strip().splitlines()
    print(lines[0] if lines else type(exc).__name__)
    sys.exit(1)
"""
_mapped: dict[str, int] = {}  # resolved library path -> live Library objects of it in this process
_probing = threading.RLock()  # (a probe and the load after it, one library at a time)


def probe(extension: ModuleType, path: Path) -> str | None:
    """Why the library cannot load, found by loading it in a child process now; None if it can."""
    with _probing:
        command = [sys.executable, "-c", _PROBE, str(extension.__file__), str(path)]
        try:
            done = subprocess.run(command, capture_output=True, text=True, timeout=PROBE_TIMEOUT)
        except subprocess.TimeoutExpired:
            verdict: str | None = f"loading it did not finish within {PROBE_TIMEOUT:g} s"
        else:
            said = done.stdout.strip().splitlines()
            if done.returncode == 0:
                verdict = None
            elif done.returncode == 1 and said:
                verdict = said[-1]
            elif done.returncode < 0:
                verdict = f"loading it killed the process ({signal.Signals(-done.returncode).name})"
            else:
                verdict = f"loading it ended the process with exit code {done.returncode}"
        return verdict


class CppPlugin:
    """A C++ plugin instance, seen by the runtime as a Python plugin."""

    def __init__(
        self, library: Any, instance: Any, context: PluginContext, spaces_type: type, key: str = ""
    ) -> None:
        self.library = library
        self.key = key  # its entry in `_mapped`
        self.instance = instance
        self.context = context
        outer = context

        class Spaces(spaces_type):  # type: ignore[misc]
            def read(self, space: str) -> list[float]:
                return [float(v) for v in outer.read(space)]

            def write(self, space: str, value: list[float]) -> None:
                outer.write(space, value)

        self.spaces = Spaces()

    def start(self) -> None:
        self.instance.start()

    def step(self, time: float) -> None:
        self.instance.step(time, self.spaces)

    def stop(self) -> None:
        try:
            self.instance.stop()
        finally:
            self.instance.release()
            if self.library.live == 0 and self.library.loaded:
                self.library.unload()  # closed for real unless another loader holds it
                _unmapped(self.key)

    def status(self) -> str:
        return str(self.instance.status())


def create(plugin: Plugin, context: PluginContext) -> CppPlugin:
    """Load the plugin's library and construct its class (not started)."""
    extension = _extension()
    if extension is None:
        raise plugin_error(
            plugin,
            "library",
            "C++ plugin support is not built into this installation: in a checkout, run make cpp-plugins; "
            "else reinstall motivml (pip install) where cmake, g++, python3-dev and libclass-loader-dev are installed",
        )
    path = Path(plugin.folder) / plugin.entry["library"]
    if not inside(path, Path(plugin.folder).resolve()):
        raise plugin_error(
            plugin, "library", f"library {plugin.entry['library']} leaves the plugin folder (a link)"
        )
    if not path.is_file():
        raise plugin_error(plugin, "library", f"library {path} does not exist (build it: make cpp-plugins)")
    key = str(path.resolve())
    with _probing:  # (held from the check to the count: no last instance unmaps it between)
        mapped = _mapped.get(key, 0) > 0
        verdict = None if mapped else probe(extension, path)  # (mapped here: loading it again runs nothing)
        if verdict is not None:
            raise plugin_error(plugin, "library", f"cannot load {path.name}: {verdict}")
        try:
            library = extension.Library(str(path))
        except RuntimeError as exc:  # LoadError: dlopen failed
            raise plugin_error(plugin, "library", f"cannot load {path.name}: {_first_line(exc)}") from None
        _mapped[key] = _mapped.get(key, 0) + 1
    try:
        instance = library.create(plugin.entry["class"])
    except RuntimeError as exc:
        library.unload()
        _unmapped(key)
        raise plugin_error(plugin, "class", _first_line(exc)) from None
    return CppPlugin(library, instance, context, extension.Spaces, key)


def _unmapped(key: str) -> None:
    with _probing:
        left = _mapped.get(key, 0) - 1
        if left > 0:
            _mapped[key] = left
        else:
            _mapped.pop(key, None)


class CppPlugins:
    """The C++ plugins of one robot: each instance holds its library until it is stopped."""

    def __init__(self, robot: str, plugins: dict[str, Plugin]) -> None:
        self.plugins = plugins

    def problems(self) -> list[Diagnostic]:
        return []

    def absent(self, features: list[str]) -> dict[str, str]:
        """None: a library that cannot load says so when its feature starts."""
        return {}

    def create(self, plugin: Plugin, context: PluginContext, fresh: bool = False) -> CppPlugin:
        return create(plugin, context)

    def discard(self, instance: Any) -> None:
        """Release the object and, with its last instance, the library (stop() releases too)."""
        instance.stop()

    def activation(self, instance: Any) -> None:
        """None: a C++ plugin runs from its start() on."""
        return None

    def close(self) -> None:
        """Libraries are released by their last instance's stop()."""


def _first_line(exc: BaseException) -> str:
    lines = str(exc).strip().splitlines()
    return lines[0] if lines else type(exc).__name__

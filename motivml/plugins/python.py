"""Python feature plugins, loaded through pluginbase: one plugin source per robot.

Every Python plugin folder a robot declares is on its robot's plugin source's search path,
so plugin modules import under a namespace of their own (never `sys.modules`' top level,
never another robot's). Entry modules must have distinct names across a robot's plugins.
`create` imports the entry module (once), finds the class and constructs it; `reload`
re-executes the entry module from disk, so a Dynamic feature picks up edited code without
a restart (submodules it imports are not reloaded). Every failure is a `PluginError` that
names the plugin's manifest and what went wrong, with the classes the module does have.
"""

from __future__ import annotations

import importlib
import itertools
from pathlib import Path
from types import ModuleType
from typing import Any

from pluginbase import PluginBase, PluginSource

from ..documents.loader import load_file
from ..documents.robot_folder import Plugin
from ..errors import Diagnostic, EnvironmentProblem, Location, describe_exception, error
from .api import PluginContext

_LAUNCHES = itertools.count()


class PluginError(EnvironmentProblem):
    """A plugin could not be imported, constructed or started (exit 3)."""


def plugin_error(plugin: Plugin, key: str, message: str) -> PluginError:
    """A located error at the manifest's `entry.<key>` (or the manifest itself)."""
    try:
        where = load_file(plugin.manifest).locate(("entry", key) if key else ())
    except EnvironmentProblem:  # the manifest went away since it was read: name the file
        where = Location(str(plugin.manifest))
    return PluginError(error(where, message, "plugins.load", plugin.feature))


def _refuse_links_out(plugin: Plugin, name: str) -> None:
    """The entry module (its file, or its package's folders) must not be a link that leaves the
    plugin folder: what is imported is what the folder holds, as for a C++ library."""
    folder = Path(plugin.folder).resolve()
    here = Path(plugin.folder)
    for part in name.split("."):
        for candidate in (here / part, here / f"{part}.py"):
            if (candidate.exists() or candidate.is_symlink()) and not _inside(candidate, folder):
                raise plugin_error(plugin, "module", f"module {name!r} leaves the plugin folder (a link)")
        here = here / part


def _inside(path: Path, folder: Path) -> bool:
    """Whether `path`, its links followed, is in `folder` (a loop of links is not)."""
    try:
        return path.resolve().is_relative_to(folder)
    except (RuntimeError, OSError):  # (a symlink loop: Python 3.11's resolve raises RuntimeError)
        return False


def inspect(plugin: Plugin) -> list[Diagnostic]:
    """What `validate` can tell of a Python plugin without running any of it: its entry
    module is a file of the plugin folder (not a link out of it), compiles, and binds the
    entry class at its top level (a class, an assignment or an import of that name; a
    `from ... import *` leaves it open). A run that loads the plugin would stop on each."""
    import ast

    name, wanted = plugin.entry["module"], plugin.entry["class"]
    try:
        _refuse_links_out(plugin, name)
    except PluginError as exc:
        return exc.diagnostics
    base = Path(plugin.folder).joinpath(*name.split("."))
    path = next((p for p in (base.with_name(base.name + ".py"), base / "__init__.py") if p.is_file()), None)
    if path is None:
        message = f"module {name!r} is not in the plugin folder ({base.name}.py, or {base.name}/__init__.py)"
        return plugin_error(plugin, "module", message).diagnostics
    try:
        tree = ast.parse(path.read_bytes(), filename=str(path))  # (compiled, not run)
    except (SyntaxError, ValueError, RecursionError, MemoryError) as exc:
        line = f" (line {exc.lineno})" if isinstance(exc, SyntaxError) and exc.lineno else ""
        reason = (
            exc.msg
            if isinstance(exc, SyntaxError)
            else "it nests too deep for Python's parser"
            if isinstance(exc, (RecursionError, MemoryError))
            else str(exc)
        )
        return plugin_error(plugin, "module", f"module {name!r} does not compile{line}: {reason}").diagnostics
    except OSError as exc:
        return plugin_error(plugin, "module", f"cannot read module {name!r}: {exc.strerror or exc}").diagnostics
    bound, classes, starred = _top_level_names(tree)
    if wanted in bound or starred:
        return []
    has = ", ".join(sorted(classes)) or "none"
    return plugin_error(plugin, "class", f"module {name!r} has no class {wanted!r} (its classes: {has})").diagnostics


_DYNAMIC = frozenset({"globals", "exec", "setattr", "vars", "locals", "__import__", "eval"})


def _top_level_names(tree: Any) -> tuple[set[str], set[str], bool]:
    """(names the module binds at its top level, its classes, whether that is left open),
    looking into top-level compound statements (iteratively). Open: `from ... import *`, a
    module `__getattr__` (PEP 562), or a call that may bind anything (`globals()`, `exec`)."""
    import ast

    bound: set[str] = set()
    classes: set[str] = set()
    starred = False
    work = list(tree.body)
    while work:
        node = work.pop()
        if isinstance(node, ast.ClassDef):
            bound.add(node.name)
            classes.add(node.name)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            bound.add(node.name)
            starred = starred or node.name == "__getattr__"
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            for alias in node.names:
                if alias.name == "*":
                    starred = True
                bound.add(alias.asname or alias.name.split(".")[0])
        else:
            # names any other statement binds (assignments, for targets, walruses, with
            # ... as, except ... as), then the statements in its blocks
            for part in ast.walk(node) if not isinstance(node, ast.stmt) or not _blocks(node) else _heads(node):
                if isinstance(part, ast.Name) and isinstance(part.ctx, ast.Store):
                    bound.add(part.id)
                elif isinstance(part, (ast.ExceptHandler, ast.MatchAs, ast.MatchStar)) and part.name:
                    bound.add(part.name)
                elif isinstance(part, ast.Call) and isinstance(part.func, ast.Name) and part.func.id in _DYNAMIC:
                    starred = True
            work += _blocks(node)
    return bound, classes, starred


def _blocks(node: Any) -> list[Any]:
    """The statements in a compound statement's blocks (if, for, while, with, try, match)."""
    import ast

    found: list[Any] = []
    for key in ("body", "orelse", "finalbody"):
        value = getattr(node, key, None)
        if isinstance(value, list) and all(isinstance(s, ast.stmt) for s in value):
            found += value
    for handler in getattr(node, "handlers", []):
        found += handler.body
    for case in getattr(node, "cases", []):
        found += case.body
    return found


def _heads(node: Any) -> Any:
    """Every part of a compound statement but the statements of its blocks."""
    import ast

    inner = {id(s) for s in _blocks(node)}
    stack = [node]
    while stack:
        part = stack.pop()
        yield part
        stack += [child for child in ast.iter_child_nodes(part) if id(child) not in inner]


class PythonPlugins:
    """The Python plugins of one robot: import, construct, reload."""

    def __init__(self, robot: str, plugins: dict[str, Plugin]) -> None:
        self.plugins = plugins
        self.base = PluginBase(package="motivml.robot_plugins")
        self.source: PluginSource = self.base.make_plugin_source(
            searchpath=[str(p.folder) for p in self.plugins.values()],
            identifier=f"motivml-{robot}-{next(_LAUNCHES)}",  # one namespace per launched robot
        )
        self.modules: dict[str, ModuleType] = {}

    def problems(self) -> list[Diagnostic]:
        """None left at launch: `discover` refuses entry modules whose names clash."""
        return []

    def absent(self, features: list[str]) -> dict[str, str]:
        """None: a module that cannot be imported says so when its feature starts."""
        return {}

    def _module(self, plugin: Plugin, fresh: bool) -> ModuleType:
        name = plugin.entry["module"]
        module = self.modules.get(plugin.feature)
        if module is None or fresh:
            _refuse_links_out(plugin, name)
        try:
            with self.source:
                if module is None:
                    module = __import__(f"{self.base.package}.{name}", fromlist=["__name__"])
                elif fresh:  # a failed reload leaves the module as it was
                    saved = dict(module.__dict__)
                    try:
                        module = importlib.reload(module)
                    except BaseException:
                        module.__dict__.clear()
                        module.__dict__.update(saved)
                        raise
        except BaseException as exc:  # a plugin's import may raise anything, SystemExit too
            raise plugin_error(
                plugin,
                "module",
                f"cannot import {name!r} of plugin {plugin.feature}: {describe_exception(exc, plugin.folder)}",
            ) from None
        assert module is not None
        self.modules[plugin.feature] = module
        return module

    def create(self, plugin: Plugin, context: PluginContext, fresh: bool = False) -> Any:
        """An instance of the feature's plugin class (`fresh`: re-read its module first)."""
        feature = plugin.feature
        module = self._module(plugin, fresh)
        name = plugin.entry["class"]
        cls = getattr(module, name, None)
        if not isinstance(cls, type):
            classes = sorted(
                k for k, v in vars(module).items() if isinstance(v, type) and v.__module__ == module.__name__
            )
            has = ", ".join(classes) or "none"
            raise plugin_error(
                plugin,
                "class",
                f"module {plugin.entry['module']!r} has no class {name!r} (its classes: {has})",
            )
        try:
            return cls(context)
        except BaseException as exc:  # SystemExit, KeyboardInterrupt too: the plugin's fault
            raise plugin_error(
                plugin,
                "class",
                f"constructing {name} of plugin {feature} failed: {describe_exception(exc, plugin.folder)}",
            ) from None

    def discard(self, instance: Any) -> None:
        """Nothing to release: the instance is garbage once dropped."""

    def close(self) -> None:
        self.modules.clear()
        self.source.cleanup()

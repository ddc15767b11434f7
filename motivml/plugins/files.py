"""What a plugin's files say before anything of them runs (`validate`'s inspectors, one per
kind of plugin with files), and the located error every kind reports a plugin with.

Light on purpose: `validate` imports this and nothing that loads plugins (pluginbase,
numpy, the C++ extension stay out of a checking command, tests/test_layout.py)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from ..documents.loader import load_file
from ..documents.robot_folder import Plugin
from ..errors import Diagnostic, EnvironmentProblem, Location, Severity, error


class PluginError(EnvironmentProblem):
    """A plugin could not be imported, constructed or started (exit 3)."""


def plugin_error(plugin: Plugin, key: str, message: str) -> PluginError:
    """A located error at the manifest's `entry.<key>` (or the manifest itself)."""
    try:
        where = load_file(plugin.manifest).locate(("entry", key) if key else ())
    except EnvironmentProblem:  # the manifest went away since it was read: name the file
        where = Location(str(plugin.manifest))
    return PluginError(error(where, message, "plugins.load", plugin.feature))


def refuse_links_out(plugin: Plugin, name: str) -> None:
    """The entry module (its file, or its package's folders) must not be a link that leaves the
    plugin folder: what is imported is what the folder holds, as for a C++ library."""
    folder = Path(plugin.folder).resolve()
    here = Path(plugin.folder)
    for part in name.split("."):
        for candidate in (here / part, here / f"{part}.py"):
            if (candidate.exists() or candidate.is_symlink()) and not inside(candidate, folder):
                raise plugin_error(plugin, "module", f"module {name!r} leaves the plugin folder (a link)")
        here = here / part


def inside(path: Path, folder: Path) -> bool:
    """Whether `path`, its links followed, is in `folder` (a loop of links is not)."""
    try:
        return path.resolve().is_relative_to(folder)
    except (RuntimeError, OSError):  # (a symlink loop: Python 3.11's resolve raises RuntimeError)
        return False


def python_files(plugin: Plugin) -> list[Diagnostic]:
    """What `validate` can tell of a Python plugin without running any of it: its entry
    module is a file of the plugin folder (not a link out of it), compiles, and binds the
    entry class at its top level (a class, an assignment or an import of that name; a
    `from ... import *` leaves it open). A run that loads the plugin would stop on each."""
    import ast

    name, wanted = plugin.entry["module"], plugin.entry["class"]
    try:
        refuse_links_out(plugin, name)
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


def cpp_files(plugin: Plugin) -> list[Diagnostic]:
    """What `validate` can tell of a C++ plugin without loading it: its library is a file of
    the plugin folder (not a link out of it: an error), and it is built (else a warning, as
    for a checkout where `make cpp-plugins` has not run: a run that loads it stops)."""
    path = Path(plugin.folder) / plugin.entry["library"]
    if not inside(path, Path(plugin.folder).resolve()):
        message = f"library {plugin.entry['library']} leaves the plugin folder (a link)"
        return plugin_error(plugin, "library", message).diagnostics
    if not path.is_file():
        (problem,) = plugin_error(
            plugin,
            "library",
            f"library {path} does not exist (build it: make cpp-plugins); a run that loads {plugin.feature} stops",
        ).diagnostics
        return [replace(problem, severity=Severity.WARNING)]
    return []

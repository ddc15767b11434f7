"""The kinds of plugin: each kind is one module with a loader, registered here once.

A manifest's `kind` picks an entry of `KINDS`, which says what the manifest's `entry` must
name and where the kind's loader is. The loader module is imported only when a launched
robot has a plugin of that kind, so reading manifests (`configure`, `validate`) never pays
for pluginbase or the C++ extension. Adding a kind (ROS 2 lifecycle nodes, say) is one
module with a `Loader` and one line below, plus the kind in `schemas/plugin.schema.json`.
`ros2_lifecycle` is such a kind: its instances drive lifecycle nodes of other processes.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import PurePosixPath
from typing import TYPE_CHECKING, Any, Protocol

from ..documents.robot_folder import Plugin
from ..errors import Diagnostic

if TYPE_CHECKING:
    from .api import PluginContext


class FeatureInstance(Protocol):
    """What a run asks of a feature's plugin instance, whatever its kind (a Python object, a
    C++ class behind the extension, a stand-in for a ROS 2 lifecycle node)."""

    def start(self) -> None: ...

    def step(self, time: float) -> None: ...

    def stop(self) -> None: ...


class Activation(Protocol):
    """The optional step of instances that live outside the run's process (ROS 2 lifecycle
    nodes): activated at the commit that brings them in, deactivated at the one that takes
    them out (and back, when the commit does not happen)."""

    def activate(self) -> None: ...

    def deactivate(self) -> None: ...


class Loader(Protocol):
    """Makes the instances of one kind's plugins, for one launched robot."""

    def problems(self) -> list[Diagnostic]:
        """What stops these plugins from loading together (before anything starts)."""
        ...

    def absent(self, features: list[str]) -> dict[str, str]:
        """Of these features, about to start together, those whose implementation is not
        there (a node not on the ROS graph): feature -> why, all found at once."""
        ...

    def create(self, plugin: Plugin, context: PluginContext, fresh: bool) -> Any:
        """An instance of the plugin's class, not yet started (`fresh`: re-read its code)."""
        ...

    def discard(self, instance: Any) -> None:
        """Release an instance whose start() failed (stop() is not called on it)."""
        ...

    def activation(self, instance: Any) -> Activation | None:
        """The instance's activation step, if its kind has one (None: it runs at once)."""
        ...

    def close(self) -> None:
        """Forget what this robot loaded."""
        ...


EntryPath = tuple[str | int, ...]  # a place inside a manifest's entry
INT64 = range(-(2**63), 2**63)  # a ROS 2 integer parameter
RESERVED = "motivml."  # parameter names configure writes itself (motivml.feature, motivml.binding)


def ros2_parameters(entry: dict[str, Any]) -> tuple[EntryPath, str] | None:
    """What ROS 2 cannot take among a ros2_lifecycle entry's (schema-valid) parameters.

    A ROS parameter has one type: an array's items are all booleans, all integers, all
    doubles or all strings (the node would refuse `[1, 2.5]` when it reads
    ros2_params.yaml), and an array is not empty (`[]` has no type); integers fit 64 bits.
    """
    for name, value in entry.get("parameters", {}).items():
        here: EntryPath = ("parameters", name)
        if name.startswith(RESERVED):
            return here, f"parameter {name!r}: names starting {RESERVED!r} are written by configure"
        items = value if isinstance(value, list) else [value]
        first = _ros_type(items[0]) if items else ""
        for position, item in enumerate(items):
            where = (*here, position) if isinstance(value, list) else here
            found = _ros_type(item)
            if found == "integer" and item not in INT64:
                return where, f"parameter {name!r}: {item} does not fit a ROS 2 integer (64 bits)"
            if found != first:
                hint = " (write 1.0 for a double)" if {first, found} == {"integer", "double"} else ""
                return where, (
                    f"parameter {name!r}: a ROS 2 array holds one type, "
                    f"but item {position} is {_a(found)} after {_a(first)}{hint}"
                )
        if not items:
            return here, f"parameter {name!r}: an empty array has no ROS 2 type (leave the parameter out)"
    return None


def _ros_type(value: object) -> str:
    if isinstance(value, bool):
        return "boolean"
    return {int: "integer", float: "double", str: "string"}[type(value)]


def _a(word: str) -> str:
    return f"an {word}" if word[0] in "aeiou" else f"a {word}"


@dataclass(frozen=True)
class Kind:
    name: str
    path_key: str  # the entry key naming what to load (inside the plugin folder, or a node)
    path_is_file: bool  # a file path (no '..'), or a dotted module name
    loader: str  # "package.module:Class", imported at first use
    required: tuple[str, ...] = ("class",)  # entry keys this kind needs besides path_key
    optional: tuple[str, ...] = ()  # entry keys this kind may have
    on_ros: bool = False  # its loader takes the run's ROS namespace
    check_values: Callable[[dict[str, Any]], tuple[EntryPath, str] | None] | None = None  # the kind's own
    inspector: str | None = None  # "package.module:function": what validate can tell of its files, running nothing

    def inspect(self, plugin: Plugin) -> list[Diagnostic]:
        """What the plugin's files say before a run loads them (none for a kind without files)."""
        if self.inspector is None:
            return []
        module, name = self.inspector.split(":")
        found: list[Diagnostic] = getattr(importlib.import_module(module), name)(plugin)
        return found

    def check_entry(self, entry: dict[str, Any]) -> tuple[EntryPath, str] | None:
        """(place in the entry, problem) when a schema-valid entry cannot be used, else None."""
        for key in (self.path_key, *self.required):
            if key not in entry:
                return (), f"a {self.name} plugin's entry needs {key!r}"
        allowed = {self.path_key, *self.required, *self.optional}
        for key in entry:
            if key not in allowed and not key.startswith("x-"):
                problem = f"a {self.name} plugin's entry has no {key!r} (it has {', '.join(sorted(allowed))})"
                return (key,), problem
        if self.path_is_file and ".." in PurePosixPath(entry[self.path_key]).parts:
            return (self.path_key,), f"library {entry[self.path_key]!r} leaves the plugin folder"
        return self.check_values(entry) if self.check_values is not None else None

    def make_loader(self, robot: str, plugins: dict[str, Plugin], ros_namespace: str = "/") -> Loader:
        module, name = self.loader.split(":")
        factory = getattr(importlib.import_module(module), name)
        loader: Loader = factory(robot, plugins, ros_namespace) if self.on_ros else factory(robot, plugins)
        return loader


KINDS = {
    kind.name: kind
    for kind in (
        Kind(
            "python",
            "module",
            path_is_file=False,
            loader="motivml.plugins.python:PythonPlugins",
            inspector="motivml.plugins.files:python_files",
        ),
        Kind(
            "cpp",
            "library",
            path_is_file=True,
            loader="motivml.plugins.cpp:CppPlugins",
            inspector="motivml.plugins.files:cpp_files",
        ),
        Kind(
            "ros2_lifecycle",
            "node",
            path_is_file=False,
            loader="motivml.plugins.ros2:LifecyclePlugins",
            required=(),
            optional=("parameters", "timeout"),
            on_ros=True,
            check_values=ros2_parameters,
        ),
    )
}


def loaders(robot: str, plugins: dict[str, Plugin], ros_namespace: str = "/") -> dict[str, Loader]:
    """One loader per kind the robot's plugins use, each given the plugins of its kind."""
    used = sorted({p.kind for p in plugins.values()}, key=list(KINDS).index)
    return {
        kind: KINDS[kind].make_loader(
            robot, {f: p for f, p in plugins.items() if p.kind == kind}, ros_namespace
        )
        for kind in used
    }

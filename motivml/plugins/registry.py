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
from dataclasses import dataclass
from pathlib import PurePosixPath
from typing import TYPE_CHECKING, Any, Protocol

from ..documents.robot_folder import Plugin
from ..errors import Diagnostic

if TYPE_CHECKING:
    from .api import PluginContext


class Loader(Protocol):
    """Makes the instances of one kind's plugins, for one launched robot."""

    def problems(self) -> list[Diagnostic]:
        """What stops these plugins from loading together (before anything starts)."""
        ...

    def create(self, plugin: Plugin, context: PluginContext, fresh: bool) -> Any:
        """An instance of the plugin's class, not yet started (`fresh`: re-read its code)."""
        ...

    def discard(self, instance: Any) -> None:
        """Release an instance whose start() failed (stop() is not called on it)."""
        ...

    def close(self) -> None:
        """Forget what this robot loaded."""
        ...


@dataclass(frozen=True)
class Kind:
    name: str
    path_key: str  # the entry key naming what to load (inside the plugin folder, or a node)
    path_is_file: bool  # a file path (no '..'), or a dotted module name
    loader: str  # "package.module:Class", imported at first use
    required: tuple[str, ...] = ("class",)  # entry keys this kind needs besides path_key
    optional: tuple[str, ...] = ()  # entry keys this kind may have
    on_ros: bool = False  # its loader takes the run's ROS namespace

    def check_entry(self, entry: dict[str, Any]) -> tuple[str, str] | None:
        """(entry key, problem) when a schema-valid entry cannot be used, else None."""
        for key in (self.path_key, *self.required):
            if key not in entry:
                return "", f"a {self.name} plugin's entry needs {key!r}"
        allowed = {self.path_key, *self.required, *self.optional}
        for key in entry:
            if key not in allowed and not key.startswith("x-"):
                return key, f"a {self.name} plugin's entry has no {key!r} (it has {', '.join(sorted(allowed))})"
        if self.path_is_file and ".." in PurePosixPath(entry[self.path_key]).parts:
            return self.path_key, f"library {entry[self.path_key]!r} leaves the plugin folder"
        return None

    def make_loader(self, robot: str, plugins: dict[str, Plugin], ros_namespace: str = "/") -> Loader:
        module, name = self.loader.split(":")
        factory = getattr(importlib.import_module(module), name)
        loader: Loader = factory(robot, plugins, ros_namespace) if self.on_ros else factory(robot, plugins)
        return loader


KINDS = {
    kind.name: kind
    for kind in (
        Kind("python", "module", path_is_file=False, loader="motivml.plugins.python:PythonPlugins"),
        Kind("cpp", "library", path_is_file=True, loader="motivml.plugins.cpp:CppPlugins"),
        Kind(
            "ros2_lifecycle",
            "node",
            path_is_file=False,
            loader="motivml.plugins.ros2:LifecycleNodes",
            required=(),
            optional=("parameters", "timeout"),
            on_ros=True,
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

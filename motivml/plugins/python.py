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
from types import ModuleType
from typing import Any

from pluginbase import PluginBase, PluginSource

from ..documents.robot_folder import Plugin
from ..errors import Diagnostic, describe_exception
from .api import PluginContext
from .files import PluginError, plugin_error, refuse_links_out

__all__ = ["PluginError", "PythonPlugins", "plugin_error"]  # (PluginError and plugin_error: files.py's)

_LAUNCHES = itertools.count()


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
            refuse_links_out(plugin, name)
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

    def activation(self, instance: Any) -> None:
        """None: a Python plugin runs from its start() on (a method of its own named
        activate is not called)."""
        return None

    def close(self) -> None:
        self.modules.clear()
        self.source.cleanup()

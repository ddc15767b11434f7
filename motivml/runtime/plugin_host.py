"""The plugins of a running robot: each feature's instance made, started, switched and stopped.

`PluginHost` holds the variant's plugins and one loader per kind (`plugins/registry.py`).
It knows nothing of requests: the binder (`binder.py`) decides what loads and leaves, and
asks the host to

- start the instances of the start state, all or none (`start_state`);
- make and start an instance while a change is prepared (`start_instance`), with a view of
  the spaces that holds its writes back until the commit (`Preparing`);
- move the instances that live outside the process (ROS 2 lifecycle nodes) just before a
  commit: the leaving ones deactivated, the arriving ones activated, and back again if one
  fails (`switch`, `unswitch`);
- stop an instance (`stop`), and every instance when the run ends (`stop_all`, `close`).

Plugin code is untrusted: whatever it raises, the host says so in the run's notes or in a
located `PluginError`, and never lets it through.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..architecture.builder import Assembly
from ..binding.resolve import Variant
from ..documents.robot_folder import Plugin
from ..errors import describe_exception
from ..plugins.api import FeatureUnavailable, PluginContext
from ..plugins.python import PluginError, plugin_error
from ..plugins.registry import loaders
from .loop import Running, Runtime


@dataclass
class Preparing:
    """What plugins being prepared see: the staged architecture, and their held-back writes."""

    assembly: Assembly | None
    writes: list[tuple[str, Any]] = field(default_factory=list)
    active: bool = True


class PluginHost:
    """The instances of one run's plugins, from start to stop (see the module's text)."""

    def __init__(
        self, runtime: Runtime, variant: Variant, plugins: dict[str, Plugin], robot: str, ros_namespace: str
    ) -> None:
        self.runtime = runtime
        self.model = variant.model
        # Only the variant's plugins are loaded: a robot folder may declare plugins (of kinds
        # this Python cannot load, say) for features other variants select.
        selected = {d.feature.id for d in variant.decisions if d.selected}
        self.plugins = {f: p for f, p in plugins.items() if f in selected}
        self.loaders = loaders(robot, self.plugins, ros_namespace)
        self.static = {d.feature.id: d.binding.static for d in variant.decisions}

    def context(self, feature: str, preparing: Preparing) -> PluginContext:
        """A plugin instance's view of the spaces: while it is being prepared, the new
        architecture's, with its writes held back until the commit; afterwards, the running
        one's (every instance has its own view, so a running plugin never sees a staging)."""
        runtime = self.runtime

        def read(space: str) -> Any:
            if preparing.active:
                staged = preparing.assembly if preparing.assembly is not None else runtime.assembly
                return staged.values[space]
            return runtime.assembly.values[space]

        def write(space: str, value: Any) -> None:
            if not preparing.active:
                runtime.send(space, value)
                return
            staged = preparing.assembly if preparing.assembly is not None else runtime.assembly
            if space not in staged.values or staged.writers.get(space):
                raise ValueError(f"{space} is not a space this plugin may write")
            preparing.writes.append(
                (space, np.asarray(value, dtype=float).reshape(staged.values[space].shape))
            )

        return PluginContext(
            feature,
            self.plugins[feature].folder,
            runtime.rate,
            read,
            write,
            lambda text: runtime.note(f"{feature}: {text}"),
        )

    def start_instance(self, feature: str, preparing: Preparing, fresh: bool = False) -> Running:
        """A new, started instance of the feature's plugin (`fresh`: its code read again)."""
        plugin = self.plugins[feature]
        loader = self.loaders[plugin.kind]
        instance = loader.create(plugin, self.context(feature, preparing), fresh)
        try:
            instance.start()
        except BaseException as exc:  # plugin code may raise anything
            try:
                loader.discard(instance)
            except BaseException as problem:
                self.runtime.note(
                    f"stop() of plugin {feature} raised {describe_exception(problem, plugin.folder)}"
                )
            if isinstance(exc, FeatureUnavailable):  # the kind's own words (a node not there, say)
                raise plugin_error(plugin, entry_key(plugin), f"cannot start {feature}: {exc}") from None
            raise plugin_error(
                plugin,
                "class",
                f"start() of plugin {feature} failed: {describe_exception(exc, plugin.folder)}",
            ) from None
        return Running(feature, instance, self.static[feature], plugin.folder, activation=loader.activation(instance))

    def start_instances(
        self, features: Sequence[str], preparing: Preparing, fresh: bool, staging: bool = False
    ) -> dict[str, Running]:
        """Started instances of the plugins of `features` (those that have one), all or none:
        if one fails, those already started are stopped. Their writes wait in `preparing` for
        the commit; unless `staging` (the caller ends it), they are its last."""
        started: dict[str, Running] = {}
        try:
            for feature in features:
                if feature in self.plugins:
                    started[feature] = self.start_instance(feature, preparing, fresh)
        except BaseException:
            for running in started.values():  # (what they write in stop() stays staged: dropped)
                self.stop(running)
            raise
        finally:
            if not staging:
                preparing.active = False
        return started

    def stop(self, running: Running) -> bool:
        """Stop a plugin; False (and a note) if its stop() raised."""
        try:
            running.instance.stop()
        except BaseException as exc:  # plugin code may raise anything, SystemExit too
            folder = self.plugins[running.feature].folder
            self.runtime.note(f"stop() of plugin {running.feature} raised {describe_exception(exc, folder)}")
            return False
        return True

    def start_state(self, active: frozenset[str]) -> None:
        """Start the plugins of the start state (before the loop runs); all or none."""
        problems = [d for loader in self.loaders.values() for d in loader.problems()]
        if problems:
            raise PluginError(problems)
        starting = sorted(active & set(self.plugins), key=self.model.index.__getitem__)
        absent: dict[str, str] = {}
        for kind, loader in self.loaders.items():  # (all of them named, before any starts)
            absent |= loader.absent([f for f in starting if self.plugins[f].kind == kind])
        if absent:
            raise PluginError(
                [
                    d
                    for f in starting
                    if f in absent
                    for d in plugin_error(self.plugins[f], entry_key(self.plugins[f]), f"cannot start {f}: {absent[f]}").diagnostics
                ]
            )
        preparing = Preparing(None)
        try:  # (writes are held back while the ROS 2 nodes activate too)
            started = list(self.start_instances(starting, preparing, fresh=False, staging=True).values())
            try:
                self.switch([], started)
            except BaseException:
                for running in started:
                    self.stop(running)
                raise
        finally:
            preparing.active = False
        for space, value in preparing.writes:
            self.runtime.send(space, value)
        self.runtime.adopt(started)

    def switch(self, leaving: list[Running], arriving: list[Running]) -> None:
        """Just before a commit: the plugins that live outside the process (ROS 2 lifecycle
        nodes) leave, then arrive: deactivated, then activated. If one fails, those already
        moved are moved back, and PluginError names the one that failed."""
        moved_out: list[Running] = []
        moved_in: list[Running] = []
        moves = [(r, "deactivate", moved_out) for r in leaving] + [(r, "activate", moved_in) for r in arriving]
        for running, move, moved in moves:
            activation = running.activation
            if activation is None:
                continue
            try:
                (activation.deactivate if move == "deactivate" else activation.activate)()
            except BaseException as exc:  # a node's failure, or plugin code
                plugin = self.plugins[running.feature]
                problem = str(exc) if isinstance(exc, FeatureUnavailable) else describe_exception(exc, plugin.folder)
                undone = self.unswitch(moved_out, moved_in)
                verb = "stop" if move == "deactivate" else "start"
                back = f"; moved back: {', '.join(undone)}" if undone else ""
                raise plugin_error(
                    plugin, entry_key(plugin), f"cannot {verb} {running.feature}: {problem}{back}"
                ) from None
            moved.append(running)

    def unswitch(self, moved_out: list[Running], moved_in: list[Running]) -> list[str]:
        """Move back what `switch` moved (a failure, or a commit that did not happen)."""
        undone = []
        for running, undo in [(r, "deactivate") for r in reversed(moved_in)] + [
            (r, "activate") for r in reversed(moved_out)
        ]:
            activation = running.activation
            if activation is None:
                continue
            try:
                (activation.deactivate if undo == "deactivate" else activation.activate)()
                undone.append(f"{running.feature} {undo}d")
            except BaseException as exc:
                self.runtime.note(
                    f"{running.feature}: could not {undo} it again: "
                    f"{describe_exception(exc, self.plugins[running.feature].folder)}"
                )
        return undone

    def stop_all(self) -> list[str]:
        """Stop every plugin in the loop (the run has ended): those whose stop() raised."""
        return [running.feature for running in self.runtime.release_plugins() if not self.stop(running)]

    def close(self) -> None:
        """Forget what this robot loaded."""
        for loader in self.loaders.values():
            loader.close()


def entry_key(plugin: Plugin) -> str:
    """Where a manifest names what failed: its class, or (a ROS 2 node) the node."""
    return "class" if "class" in plugin.entry else "node" if "node" in plugin.entry else ""

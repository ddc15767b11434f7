"""What a Python feature plugin implements, and what the runtime gives it.

A plugin is a folder with `plugin.json` (`schemas/plugin.schema.json`) naming the feature it
implements and its entry: a module in the folder and a class in that module. The runtime
constructs the class with a `PluginContext` and calls, in this order:

* `start()` once, off the control thread, before the plugin joins the loop: open devices,
  load data, warm caches; raising here refuses the whole reconfiguration;
* `step(time)` every tick on the control thread, after the architecture's components: read
  and write spaces through the context; keep it short (the loop runs at up to 1 kHz);
  raising here unloads a Dynamic feature (with its subtree) and stops the run for a Static
  one;
* `stop()` once, when the feature unloads or the run ends (errors here are reported, never
  raised into the loop; at the end of a run they make `motivml run` exit 1).

"Raising" is anything, `SystemExit`, `KeyboardInterrupt` and `GeneratorExit` included: each is
the plugin's fault, never the end of the loop or of the process.

Subclass `FeaturePlugin` (its methods do nothing) and override what you need.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

Vector = NDArray[np.float64]


@dataclass
class PluginContext:
    """The runtime as a plugin sees it."""

    feature: str
    folder: Path
    rate: float  # the loop's rate, Hz
    _read: Callable[[str], Vector]
    _write: Callable[[str, Vector], None]
    _log: Callable[[str], None]

    def read(self, space: str) -> Vector:
        """The current value of an active space (a copy)."""
        return self._read(space).copy()

    def write(self, space: str, value: list[float] | Vector) -> None:
        """Set a space that no component writes (ValueError otherwise, or on a wrong shape)."""
        self._write(space, np.asarray(value, dtype=float))

    def log(self, message: str) -> None:
        """A line in the run's log, with the time and tick."""
        self._log(message)


class FeatureUnavailable(Exception):  # noqa: N818 (what it says, not how it failed)
    """Raised by a plugin kind's own code (never a plugin's) when what implements a feature
    cannot be had or moved: a ROS 2 node that is not there, or refuses a transition. Its
    message is shown as it is, without the Python type a plugin's exception is shown with."""


class FeaturePlugin:
    """Base class of Python feature plugins: every method is optional."""

    def __init__(self, context: PluginContext) -> None:
        self.context = context

    def start(self) -> None:
        """Prepare, off the control thread."""

    def step(self, time: float) -> None:
        """One tick, on the control thread."""

    def stop(self) -> None:
        """Release what start() took."""

    def status(self) -> str:
        """One short line for the live view and the summary."""
        return ""

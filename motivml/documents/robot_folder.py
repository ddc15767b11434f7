"""A robot folder and the names of its files: the only place they are written down.

`model.json`, `variants/<name>.json`, and optionally `architecture.json`,
`coordination.json` and `robot.json` (which names the plugin directories, whose
sub-folders hold a `plugin.json` manifest each).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import EnvironmentProblem, Location, error

MODEL_FILE = "model.json"
VARIANTS_FOLDER = "variants"
ARCHITECTURE_FILE = "architecture.json"
COORDINATION_FILE = "coordination.json"
SETTINGS_FILE = "robot.json"
MANIFEST_FILE = "plugin.json"


@dataclass(frozen=True)
class Plugin:
    """One plugin manifest: the implementation of a feature, and where it is."""

    feature: str
    kind: str  # a kind of the plugin registry: "python", "cpp", "ros2_lifecycle"
    entry: dict[str, Any]  # as the manifest has it (strings, and a ros2 node's parameters)
    folder: Path
    manifest: Path


class UnknownVariant(EnvironmentProblem):
    """A variant name with no file; exit code 2 (usage) in the CLI."""

    exit_code = 2


def _is(test: Callable[[Path], bool], path: Path) -> bool:
    """`path.is_dir()` or `is_file()`, with a permission or a name too long an environment problem
    of that path (pathlib raises those instead of answering False)."""
    try:
        return test(path)
    except OSError as exc:
        raise EnvironmentProblem(error(Location(str(path)), f"cannot read: {exc.strerror}", "io")) from None


def optional_document(path: Path) -> Path | None:
    """A robot folder's optional document (robot.json, architecture.json,
    coordination.json, a plugin's plugin.json): None when there is nothing at its place;
    refused (exit 3, located) when what is there is not a regular file (a folder, a FIFO, a
    link to nothing), never taken for absent: every command that reads the folder says the
    same of it."""
    if not os.path.lexists(path):
        return None
    if not _is(Path.is_file, path):
        what = "a link to nothing" if not path.exists() else "not a regular file"
        raise EnvironmentProblem(error(Location(str(path)), f"is {what}: {path.name} is a file, or absent", "io"))
    return path


@dataclass(frozen=True)
class RobotFolder:
    path: Path

    @classmethod
    def open(cls, path: str | Path) -> RobotFolder:
        folder = cls(Path(path))
        if not _is(Path.is_dir, folder.path):
            raise EnvironmentProblem(error(Location(str(folder.path)), "no such robot folder", "io"))
        if not _is(Path.is_file, folder.model_path):
            raise EnvironmentProblem(
                error(
                    Location(str(folder.model_path)),
                    f"no {MODEL_FILE} here: a robot folder holds {MODEL_FILE} and {VARIANTS_FOLDER}/<name>.json",
                    "io",
                )
            )
        for optional in (folder.architecture_path, folder.coordination_path, folder.settings_path):
            optional_document(optional)  # (whichever command opens the folder: the same answer)
        return folder

    @property
    def name(self) -> str:
        return self.path.resolve().name

    @property
    def model_path(self) -> Path:
        return self.path / MODEL_FILE

    @property
    def architecture_path(self) -> Path:
        return self.path / ARCHITECTURE_FILE

    @property
    def coordination_path(self) -> Path:
        return self.path / COORDINATION_FILE

    @property
    def settings_path(self) -> Path:
        return self.path / SETTINGS_FILE

    def variant_names(self) -> list[str]:
        """Names of the regular, non-hidden `variants/*.json` files."""
        folder = self.path / VARIANTS_FOLDER
        if not _is(Path.exists, folder):
            return []
        try:
            entries = list(os.scandir(folder))
        except OSError as exc:
            raise EnvironmentProblem(
                error(Location(str(folder)), f"cannot read: {exc.strerror}", "io")
            ) from None
        return sorted(
            e.name.removesuffix(".json")
            for e in entries
            if e.name.endswith(".json") and not e.name.startswith(".") and e.is_file()
        )

    def variant_path(self, name: str) -> Path:
        candidate = self.path / VARIANTS_FOLDER / f"{name}.json"
        if name not in self.variant_names():
            known = ", ".join(self.variant_names()) or "none"
            raise UnknownVariant(
                error(
                    Location(str(candidate)),
                    f"no variant {name!r} in {self.path} (variants: {known})",
                    "usage",
                )
            )
        return candidate

"""A robot folder: `model.json` and `variants/<name>.json` (plus, later, architecture and plugins)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import EnvironmentProblem, Location, error


class UnknownVariant(EnvironmentProblem):
    """A variant name with no file; exit code 2 (usage) in the CLI."""

    exit_code = 2


@dataclass(frozen=True)
class RobotFolder:
    path: Path

    @classmethod
    def open(cls, path: str | Path) -> RobotFolder:
        folder = cls(Path(path))
        if not folder.path.is_dir():
            raise EnvironmentProblem(error(Location(str(folder.path)), "no such robot folder", "io"))
        if not folder.model_path.is_file():
            raise EnvironmentProblem(
                error(
                    Location(str(folder.model_path)),
                    "no model.json here: a robot folder holds model.json and variants/<name>.json",
                    "io",
                )
            )
        return folder

    @property
    def name(self) -> str:
        return self.path.resolve().name

    @property
    def model_path(self) -> Path:
        return self.path / "model.json"

    def variant_names(self) -> list[str]:
        """Names of the regular, non-hidden `variants/*.json` files."""
        folder = self.path / "variants"
        if not folder.exists():
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
        candidate = self.path / "variants" / f"{name}.json"
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

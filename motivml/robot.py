"""A robot folder: `model.json` and `variants/<name>.json` (plus, later, architecture and plugins)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .errors import EnvironmentProblem, Location, error


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
        folder = self.path / "variants"
        return sorted(p.stem for p in folder.glob("*.json")) if folder.is_dir() else []

    def variant_path(self, name: str) -> Path:
        candidate = self.path / "variants" / f"{name}.json"
        if "/" in name or "\\" in name or name.startswith(".") or not candidate.is_file():
            known = ", ".join(self.variant_names()) or "none"
            raise UnknownVariant(
                error(
                    Location(str(candidate)),
                    f"no variant {name!r} in {self.path} (variants: {known})",
                    "usage",
                )
            )
        return candidate

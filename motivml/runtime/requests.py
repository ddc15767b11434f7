"""What a client may ask of a running robot: plain data, cheap to import (the CLI parses with it)."""

from __future__ import annotations

from dataclasses import dataclass

ACTIONS = ("load", "unload", "reload", "swap")


@dataclass(frozen=True)
class Request:
    action: str  # load | unload | reload | swap
    features: tuple[str, ...]  # swap: (the one to unload, the one to load)

    def __str__(self) -> str:
        return f"{self.action} {' '.join(self.features)}"

"""What a client may ask of a running robot: plain data, cheap to import (the CLI parses with it)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

ACTIONS = ("load", "unload", "reload", "swap")  # the verbs of `run --at` and `motivml ctl`


@dataclass(frozen=True)
class Request:
    action: str  # load | unload | reload | swap | set
    features: tuple[str, ...]  # swap: (the one to unload, the one to load); set: the ones to load
    unloading: tuple[str, ...] = ()  # set: the ones to unload
    cause: str = ""  # why the run asked it itself (a fault), shown after the request

    @staticmethod
    def set(loads: Iterable[str], unloads: Iterable[str]) -> Request:
        """Load some features and unload others in one reconfiguration (the ROS 2 node's
        parameters: one call setting `features.<id>.active`, true or false, is one of these)."""
        return Request("set", tuple(loads), tuple(unloads))

    def __str__(self) -> str:
        if self.action == "set":
            text = " ".join(["set", *(f"+{f}" for f in self.features), *(f"-{f}" for f in self.unloading)])
        else:
            text = f"{self.action} {' '.join(self.features)}"
        return f"{text} ({self.cause})" if self.cause else text

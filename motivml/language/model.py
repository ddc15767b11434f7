"""Model objects: features, groups, configurations. Plain data, no I/O.

A `FeatureModel` holds its features in pre-order (definition order): index 0 is the root,
a parent comes before its children. That order is the one generated files and reports
use, and the tie-break of the start state (semantics.md section 4).

Where a feature came from is kept as its JSON path, computed on demand from the parent
links (paths of deep features are long, and most are never shown).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

PathItem = str | int


@dataclass(slots=True)
class Feature:
    index: int
    id: str
    name: str
    parent: int | None
    position: int  # index in the parent's `sub`
    declared_group: str  # the label as written: "", "OR", "XOR"
    group: str  # the group it really belongs to ("" for one-member groups)
    mandatory: bool  # ungrouped and mandatory (rule 2.2); False for group members
    declared_mandatory: bool | None  # as written, None when absent
    time_allowed: str
    mode_allowed: str
    includes: tuple[str, ...]  # as written (a repeated id is warned about and used once)
    excludes: tuple[str, ...]
    children: list[int] = field(default_factory=list)


@dataclass(frozen=True, slots=True)
class Group:
    parent: int
    kind: str  # "OR" or "XOR"
    members: tuple[int, ...]


@dataclass
class FeatureModel:
    features: list[Feature]
    index: dict[str, int]
    groups: list[Group]
    name: str = ""
    source: Any = None  # the loader's Document, to locate messages

    @property
    def root(self) -> Feature:
        return self.features[0]

    def __getitem__(self, feature_id: str) -> Feature:
        return self.features[self.index[feature_id]]

    def path(self, index: int, *keys: PathItem) -> tuple[PathItem, ...]:
        """JSON path of a feature (and of keys below it) in the model document."""
        parts: list[PathItem] = []
        node: int | None = index
        while node is not None and node != 0:
            feature = self.features[node]
            parts.append(feature.position)
            parts.append("sub")
            node = feature.parent
        return tuple(reversed(parts)) + keys

    def subtree(self, index: int) -> list[int]:
        """The feature and all its descendants, pre-order (iterative)."""
        result, stack = [], [index]
        while stack:
            node = stack.pop()
            result.append(node)
            stack.extend(reversed(self.features[node].children))
        return result


@dataclass(frozen=True, slots=True)
class Entry:
    """One configuration entry: a feature's selection and, if selected, its binding."""

    id: str
    selected: bool
    time: str  # Early | Late | Any (Any: absent or left to the configurator)
    mode: str  # Static | Dynamic | Any
    position: int  # index in `properties`


@dataclass
class Configuration:
    entries: dict[str, Entry]
    name: str = ""
    source: Any = None

    def path(self, feature_id: str, *keys: PathItem) -> tuple[PathItem, ...]:
        return ("properties", self.entries[feature_id].position) + keys

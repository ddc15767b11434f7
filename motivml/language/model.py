"""Model objects: features, groups, configurations, bindings. Plain data, no I/O.

A `FeatureModel` holds its features in pre-order (definition order): index 0 is the root,
a parent comes before its children. That order is the one generated files and reports
use, and the tie-break of the start state (reference.md section 4).

Where a feature came from is kept as its JSON path, computed on demand from the parent
links (paths of deep features are long, and most are never shown).

A binding (reference.md section 3) is one `Binding` everywhere: the variant, the generated
files, the change impact, the run time and the coordination checks all speak it, and its
spellings (the document's words, the two letters, the C macro) come from it alone. What
the model allows and what a configuration entry asks for may leave time or mode open
(`Any`): that is a `Time` or a `Mode`, or None for `Any`, never a `Binding`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Final, Literal, NamedTuple

from .formula import Formula

PathItem = str | int


class GroupKind(StrEnum):
    """A group of sub-features (rule 2.2): at least one of them (OR), or exactly one (XOR,
    unless they are Dynamic alternatives, rule 3.3)."""

    OR = "OR"
    XOR = "XOR"


class Time(StrEnum):
    """When a feature is bound: while the program is built or started, or while it runs."""

    EARLY = "Early"
    LATE = "Late"


class Mode(StrEnum):
    """Whether a bound feature stays (Static) or can be unloaded and loaded again (Dynamic)."""

    STATIC = "Static"
    DYNAMIC = "Dynamic"


ANY: Final = "Any"  # the documents' token for a time or mode left open (None in the objects)


class Binding(StrEnum):
    """The binding of a selected feature: a mode and a time, named by their initials.

    The value is what reports and generated files have always written ("SE" ...); the
    other spellings are derived from it: `words` "Static Early" (messages, pictures),
    `macro` "STATIC_EARLY" (the generated C++ header). The parts are plain attributes,
    not properties: the run time and code generation read them per feature. The order
    of the members is the order of reports and the header's numbering (1 to 4).
    """

    mode: Mode
    time: Time
    static: bool
    early: bool
    words: str
    macro: str

    SE = "SE"
    SL = "SL"
    DE = "DE"
    DL = "DL"

    def __init__(self, letters: str) -> None:
        self.static = letters[0] == "S"
        self.early = letters[1] == "E"
        self.mode = Mode.STATIC if self.static else Mode.DYNAMIC
        self.time = Time.EARLY if self.early else Time.LATE
        self.words = f"{self.mode} {self.time}"
        self.macro = f"{self.mode}_{self.time}".upper()

    @staticmethod
    def of(time: Time, mode: Mode) -> Binding:
        return _BINDINGS[mode is Mode.STATIC, time is Time.EARLY]

    @staticmethod
    def from_flags(early: bool, static: bool) -> Binding:
        """From the truth of E(f) (Early) and S(f) (Static), as the encoding has them."""
        return _BINDINGS[static, early]


_BINDINGS: Final = {
    (True, True): Binding.SE,
    (True, False): Binding.SL,
    (False, True): Binding.DE,
    (False, False): Binding.DL,
}  # (static, early) -> Binding

OFF: Final = "off"  # what a variant makes of a feature it does not select
FeatureState = Binding | Literal["off"]  # what a variant makes of a feature: off, or its binding


def token(value: Time | Mode | None) -> str:
    """A time or mode as the documents write it: `Any` when it is left open."""
    return ANY if value is None else value.value


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
    time_allowed: Time | None  # None: Any
    mode_allowed: Mode | None
    includes: tuple[str, ...]  # as written (a repeated id is warned about and used once)
    excludes: tuple[str, ...]
    children: list[int] = field(default_factory=list)
    abstract: bool = False  # only groups others: no implementation is expected for it


@dataclass(frozen=True, slots=True)
class Group:
    parent: int
    kind: GroupKind
    members: tuple[int, ...]


@dataclass
class FeatureModel:
    features: list[Feature]
    index: dict[str, int]
    groups: list[Group]
    name: str = ""
    source: Any = None  # the loader's Document, to locate messages
    formulas: list[Formula] = field(default_factory=list)  # the root's cross-tree formulas (2.4)
    # some feature says its allowed binding time or mode (False: an imported model, whose
    # features all take the defaults: its bindings are not worth speaking of)
    bindings_declared: bool = True
    _paths: dict[int, tuple[PathItem, ...]] = field(default_factory=dict, init=False, repr=False, compare=False)
    _named: frozenset[str] | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def root(self) -> Feature:
        return self.features[0]

    def __getitem__(self, feature_id: str) -> Feature:
        return self.features[self.index[feature_id]]

    def path(self, index: int, *keys: PathItem) -> tuple[PathItem, ...]:
        """JSON path of a feature (and of keys below it) in the model document.

        Each feature's path is kept once made, and made from its nearest ancestor's that
        was kept: paths in a deep model are thousands of steps long, and the messages
        about one part of it share most of them."""
        paths = self._paths
        missing: list[int] = []
        node: int | None = index
        while node is not None and node not in paths:
            missing.append(node)
            node = self.features[node].parent
        path: tuple[PathItem, ...] = paths[node] if node is not None else ()
        for node in reversed(missing):
            feature = self.features[node]
            path = path + ("sub", feature.position) if feature.parent is not None else ()
            paths[node] = path
        return path + keys

    def named(self) -> frozenset[str]:
        """The ids that some include, exclude or formula names (an including or excluding
        feature's own id too), made once: menuconfig asks after every decision (2,800
        formulas of Automotive01 read again each time: 7.5 ms a key press)."""
        if self._named is None:
            found: set[str] = set()
            for f in self.features:
                found.update(f.includes)
                found.update(f.excludes)
                if f.includes or f.excludes:
                    found.add(f.id)
            for formula in self.formulas:
                found.update(formula.ids())
            self._named = frozenset(found)
        return self._named

    def subtree(self, index: int) -> list[int]:
        """The feature and all its descendants, pre-order (iterative)."""
        result, stack = [], [index]
        while stack:
            node = stack.pop()
            result.append(node)
            stack.extend(reversed(self.features[node].children))
        return result


class Entry(NamedTuple):
    """One configuration entry: a feature's selection and, if selected, its binding. (A
    named tuple: a configuration of 100,000 features makes as many.)"""

    id: str
    selected: bool
    time: Time | None  # None: Any, absent or left to the configurator
    mode: Mode | None
    position: int  # index in `properties`


@dataclass
class Configuration:
    entries: dict[str, Entry]
    name: str = ""
    source: Any = None

    def path(self, feature_id: str, *keys: PathItem) -> tuple[PathItem, ...]:
        return ("properties", self.entries[feature_id].position) + keys

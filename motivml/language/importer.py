"""What every importer of another tool's model shares (UVL, FeatureIDE XML).

An importer walks its own syntax tree; this base gives what it builds from it:

* `Ids`: the tool's feature names made ids, deterministically;
* constraints built as formula trees (`reference`, `negate`, `combine`: the nodes of
  formula.py, over ids), written as text once, by `formula.write`, in time linear in their
  size (text joined level by level was quadratic in a formula's depth);
* the allowed binding read from the attributes `bindingTime` and `bindingMode`;
* includes and excludes named by the tool's names, resolved once every feature is read;
* `Refusal`: what cannot be kept, at its line and column (anything that has them: a parse
  tree's node, an XML element), turned into the located error of the command.
"""

from __future__ import annotations

import re
from functools import reduce
from typing import Any

from ..errors import Diagnostic, DocumentError, Location, error, warning
from .formula import AND, IMPLIES, Binary, Node, Not, Var, at_most_one, write
from .model import FeatureModel

_ID = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_ALLOWED = {"bindingTime": ("Early", "Late", "Any"), "bindingMode": ("Static", "Dynamic", "Any")}
_CONSTRAINT = {"bindingTime": "bindingTimeAllowed", "bindingMode": "bindingModeAllowed"}
_RELATION = {"includes": "featuresIncluded", "excludes": "featuresExcluded"}


class Refusal(Exception):
    """What an importer cannot keep, where the source says it (`where`: anything with a
    `line` and a `column`, or None for the whole file)."""

    def __init__(self, where: Any, message: str) -> None:
        super().__init__(message)
        self.line: int | None = getattr(where, "line", None)
        self.column: int | None = getattr(where, "column", None)
        self.message = message

    def located(self, file: str, rule: str) -> DocumentError:
        return DocumentError(error(Location(file, self.line, self.column), self.message + " (section 8)", rule))


class Ids(dict[str, str]):
    """Names of another tool's features -> ids, made deterministically (in the order asked):
    a name that is an id and free is kept; otherwise its other characters become `_` (a
    leading digit gets one before it) and a clash, also one of case only, gets `_2`, ..."""

    def __init__(self) -> None:
        super().__init__()
        self.folded: set[str] = set()

    def of(self, name: str) -> str:
        """The id of `name` (made the first time it is asked)."""
        if name not in self:
            self[name] = self.fresh(name)
        return self[name]

    def fresh(self, name: str) -> str:
        """A new id made from `name`, not kept for it (a feature another tool names twice)."""
        base = name if _ID.match(name) else re.sub(r"[^A-Za-z0-9_]", "_", name) or "_"
        if base[0].isdigit():
            base = "_" + base
        candidate, k = base, 1
        while candidate.casefold() in self.folded:
            k += 1
            candidate = f"{base}_{k}"
        self.folded.add(candidate.casefold())
        return candidate


class ImportReader:
    """The shared part of an importer's reader (one per file read)."""

    def __init__(self) -> None:
        self.ids = Ids()  # the tool's name -> id
        # includes and excludes as the tool names them: (document, "includes" or "excludes", names, where)
        self.relations: list[tuple[dict[str, Any], str, list[str], Any]] = []
        self._tolerated: dict[str, list[Any]] = {}  # what is read though not as specified: where

    def tolerate(self, where: Any, what: str) -> None:
        """Read something a published dialect writes otherwise than the format's own
        definition; said once per kind, at its first place, with how often (`said`)."""
        self._tolerated.setdefault(what, []).append(where)

    def said(self, file: str, rule: str) -> list[Diagnostic]:
        """The warnings of what was tolerated."""
        found = []
        for what, places in self._tolerated.items():
            first = places[0]
            times = f" ({len(places)} places, the first here)" if len(places) > 1 else ""
            at = Location(file, getattr(first, "line", None), getattr(first, "column", None))
            found.append(warning(at, f"{what}{times}", rule))
        return found

    # -- constraints, as trees over ids
    def reference(self, name: str, where: Any) -> Var:
        """The id of a feature a constraint names (refused if no feature has that name)."""
        if name not in self.ids:
            raise Refusal(where, f"the constraint names {name!r}, which is not a feature of the model")
        return Var(self.ids[name], 0)

    @staticmethod
    def negate(operand: Node) -> Node:
        return Not(operand)

    @staticmethod
    def combine(op: str, operands: list[Node]) -> Node:
        """`op` over one or more operands, grouped to the left (one operand: itself)."""
        return reduce(lambda left, right: Binary(op, left, right), operands)

    @staticmethod
    def text(tree: Node) -> str:
        return write(tree)

    @staticmethod
    def group_as_formulas(parent: str, members: list[str], some: bool, one: bool) -> list[str]:
        """A group MoTiVML cannot hold as a group (a parent's second OR or XOR group, a group
        of "at most one"), its members made optional: `parent` needs some of them (`some`),
        no two together (`one`, in n log n names: formula.at_most_one)."""
        formulas = [f"{parent} => {' | '.join(members)}"] if some else []
        if one:
            formulas += [f"!({_some(a)} & {_some(b)})" for a, b in at_most_one(members)]
        return formulas

    # -- attributes every importer reads
    @staticmethod
    def binding(key: str, value: object, document: dict[str, Any], where: Any) -> bool:
        """The allowed binding time or mode, if `key` names one (True: it was one of them)."""
        if key not in _ALLOWED:
            return False
        if value not in _ALLOWED[key]:
            raise Refusal(where, f"{key} is one of {', '.join(_ALLOWED[key])}, not {value!r}")
        document.setdefault("constraints", {})[_CONSTRAINT[key]] = value
        return True

    def relation(self, document: dict[str, Any], key: str, names: list[str], where: Any) -> None:
        """An `includes` or `excludes` attribute, resolved by `resolve_relations` at the end."""
        self.relations.append((document, key, names, where))

    def resolve_relations(self) -> list[str]:
        """The relations as constraints of their documents, once every feature is read; the
        texts of the formulas that say them again (not to be read again as formulas)."""
        said: list[str] = []
        for document, key, names, where in self.relations:
            unknown = [name for name in names if name not in self.ids]
            if unknown:
                raise Refusal(where, f"{document['id']} {key} {unknown[0]!r}, which is not a feature of the model")
            ids = [self.ids[name] for name in names]
            document.setdefault("constraints", {})[_RELATION[key]] = ids
            me = Var(document["id"], 0)
            for other in ids:
                if key == "includes":
                    said.append(write(Binary(IMPLIES, me, Var(other, 0))))
                else:
                    said.append(write(Not(Binary(AND, me, Var(other, 0)))))
        return said



def _some(ids: list[str]) -> str:
    """"Some of `ids`", as a formula's operand."""
    return ids[0] if len(ids) == 1 else f"({' | '.join(ids)})"


def attributes(model: FeatureModel, index: int, key: str) -> dict[str, Any]:
    """A feature's `x-` key as its document holds it (the attributes an importer kept,
    for the exporter to write back): {} if it has none or the model has no document."""
    node: Any = getattr(model.source, "root", None)
    for step in model.path(index) if node is not None else ():
        if isinstance(node, dict) and isinstance(step, str):
            node = node.get(step)
        elif isinstance(node, list) and isinstance(step, int) and step < len(node):
            node = node[step]
        else:
            return {}
    value = node.get(key) if isinstance(node, dict) else None
    return value if isinstance(value, dict) else {}


FORMATS = {"uvl": "UVL", "featureide": "FeatureIDE XML", "sxfm": "S.P.L.O.T.'s SXFM"}
_ROOTS = {"featureModel": "featureide", "extendedFeatureModel": "featureide", "feature_model": "sxfm"}
_PROLOGUE = re.compile(rb"\s*(?:<\?.*?\?>|<!--.*?-->|<!DOCTYPE[^\[>]*(?:\[.*?\])?\s*>|\s)*<([A-Za-z_][\w:.-]*)", re.S)


def guess(data: bytes) -> tuple[str | None, str]:
    """The format a model file's text is in (a key of FORMATS, or None: none motivml
    imports), and why, in words: "its root element is <feature_model>"."""
    head = data[:65536].removeprefix(b"\xef\xbb\xbf")
    if head.lstrip().startswith(b"<"):
        found = _PROLOGUE.match(head)
        tag = found.group(1).decode("ascii", "replace") if found else "?"
        return _ROOTS.get(tag), f"its root element is <{tag}>"
    text = head.decode("utf-8", "replace")
    if re.search(r"^\s*p\s+cnf\b", text, re.M):
        return None, "it is DIMACS CNF (`p cnf`): a formula without a feature tree"
    if re.search(r"^(features|namespace|include|imports)\b", text, re.M):
        return "uvl", "it has UVL's `features` section"
    return None, "it is neither XML nor UVL"

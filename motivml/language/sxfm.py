"""S.P.L.O.T.'s Simple XML Feature Model (SXFM, reference.md section 8): read into a feature
model document, and a model written as one.

An SXFM file is XML around two texts. `<feature_tree>` holds one feature per line, its
depth given by its indentation:

    :r Robot (robot)               the root
        :m Base (base)             a mandatory child
        :o Slam (slam)             an optional child
            :g (slam_g) [1,1]      a group of Slam's (its id is optional)
                : Hector (hector)  a member of the group
                : Karto (karto)

and `<constraints>` holds clauses over the features' ids, one per line: `c1: ~slam or base`.
A feature's id is the one in parentheses (a line without one gets its id from its name);
its name is the text before. Group cardinalities `[1,1]` and `[1,*]` (or `[1,n]` for n
members) are MoTiVML's XOR and OR groups; `[0,1]` and `[0,*]` make the members optional
(at most one of them, for `[0,1]`, as formulas); any other is refused, located. A second
group of a kind under one feature becomes formulas, as in UVL. SXFM has no attributes:
the model's name and its `<meta>` data are kept under the root's `x-sxfm`, and written back.

Writing: the tree, each OR group as `[1,*]` and each XOR group as `[1,1]`; includes,
excludes and formulas as clauses (a formula in conjunctive normal form, refused if that
form would be larger than MAX_CLAUSES clauses: SXFM has no auxiliary variables). Binding
times and modes are not written (there is nowhere to write them); `export` says so.
"""

from __future__ import annotations

import re
from typing import Any

from ..errors import Diagnostic, DocumentError, Location, error
from .formula import OR, Node, Var, clauses_of
from .importer import ImportReader, Refusal, attributes
from .model import Feature, FeatureModel, GroupKind
from .xmltree import Element, parse_xml

MAX_CLAUSES = 10_000  # of one formula written as clauses
MAX_LITERALS = 200_000  # in them (a few clauses of many literals each are as large as many clauses)

_LINE = re.compile(r"(?P<indent>[ \t]*):(?P<kind>[rmog]?)(?:[ \t]+|(?=\())?(?P<rest>.*?)\s*\Z")
_NAMED = re.compile(r"(?P<name>.*?)\s*\((?P<id>[^()]*)\)\Z")
_CARDINALITY = re.compile(r"(?:\((?P<id>[^()]*)\)\s*)?\[\s*(?P<low>\d+)\s*,\s*(?P<high>\d+|\*)\s*\]\Z")
_CLAUSE = re.compile(r"(?P<label>[^:]*):(?P<literals>.*)\Z")


def read_sxfm(data: bytes, file: str, warnings: list[Diagnostic] | None = None) -> dict[str, Any]:
    """The feature model document of an SXFM text; DocumentError (located) if it cannot be
    kept. What published files write otherwise than SPLOT's documentation, and is read
    anyway, is said in `warnings` (when given)."""
    top = parse_xml(data, file, "sxfm", "an SXFM model")
    reader = _SxfmReader()
    try:
        document = reader.document(top)
    except Refusal as refusal:
        raise refusal.located(file, "sxfm") from None
    if warnings is not None:
        warnings += reader.said(file, "sxfm")
    return document


class _Line:
    """One line of the feature tree: where it is, its depth, kind (r, m, o, g, or "" for a
    group's member), and what follows the kind."""

    def __init__(self, line: int, column: int, depth: int, kind: str, rest: str) -> None:
        self.line, self.column, self.depth, self.kind, self.rest = line, column, depth, kind, rest
        self.document: dict[str, Any] | None = None  # a feature's document (None: a group)
        self.members: list[dict[str, Any]] = []  # a group's members
        self.cardinality: tuple[int, int | None] = (0, None)  # a group's (None: *)
        self.owner: dict[str, Any] | None = None  # a group's feature


class _SxfmReader(ImportReader):
    def __init__(self) -> None:
        super().__init__()
        self.named: dict[str, str] = {}  # the name of a feature written without an id -> its id
        self.twice: set[str] = set()  # such names that two features have (a clause cannot name them)

    def document(self, top: Element) -> dict[str, Any]:
        if top.tag != "feature_model":
            raise Refusal(top, f"<{top.tag}> is not an SXFM model (<feature_model>)")
        trees = [c for c in top.children if c.tag == "feature_tree"]
        if len(trees) != 1:
            raise Refusal(top, "an SXFM model has one <feature_tree>")
        root, formulas = self._tree(trees[0])
        sxfm: dict[str, Any] = {}
        if top.attributes.get("name"):
            sxfm["name"] = top.attributes["name"]
        meta = next((c for c in top.children if c.tag == "meta"), None)
        if meta is not None:
            data = {c.attributes.get("name", ""): c.text.strip() for c in meta.children if c.tag == "data"}
            if any(data.values()):
                sxfm["meta"] = {key: value for key, value in data.items() if key and value}
        if sxfm:
            root["x-sxfm"] = sxfm
        for constraints in (c for c in top.children if c.tag == "constraints"):  # (every one: a file may have two)
            formulas += self._clauses(constraints)
        if formulas:
            root["formulas"] = formulas
        return root

    # -- the tree: a stack of the lines above the one read, by depth
    def _tree(self, tree: Element) -> tuple[dict[str, Any], list[str]]:
        lines = self._lines(tree)
        if not lines or lines[0].kind != "r":
            raise Refusal(lines[0] if lines else tree, "the feature tree begins with its root, `:r name (id)`")
        formulas: list[str] = []
        groups: list[_Line] = []
        above: list[_Line] = []
        for line in lines:
            while above and above[-1].depth >= line.depth:
                above.pop()
            parent = above[-1] if above else None
            if line.kind == "r":
                if parent is not None or line is not lines[0]:
                    raise Refusal(line, "a second root (`:r`): the tree has one")
                line.document = self._feature(line)
            elif line.kind == "g":
                if parent is None or parent.document is None:
                    raise Refusal(line, "a group (`:g`) belongs to a feature, indented under it")
                line.cardinality = self._cardinality(line)
                line.owner = parent.document
                groups.append(line)
            elif parent is None:
                raise Refusal(line, "a feature outside the root: indent it under its parent")
            elif parent.document is None:  # under a group: one of its members
                if line.kind:
                    self.tolerate(line, "`:m` and `:o` lines under a group `:g` are read as the group's members")
                line.document = self._feature(line)
                parent.members.append(line.document)
            else:  # under a feature: a child
                if not line.kind:
                    self.tolerate(line, "`: name` lines under a feature, not a group `:g`, are read as optional children")
                line.document = self._feature(line)
                if line.kind != "m":
                    line.document["isMandatory"] = False
                parent.document.setdefault("sub", []).append(line.document)
            above.append(line)
        formulas += self._groups(groups)
        assert lines[0].document is not None
        return lines[0].document, formulas

    def _lines(self, tree: Element) -> list[_Line]:
        lines: list[_Line] = []
        kinds: set[str] = set()  # of the indentation's characters so far
        mixed = False
        for k, text in enumerate(tree.text.split("\n")):
            if not text.strip():
                continue
            line = tree.line + k
            column = (tree.column + len("<feature_tree>") if k == 0 else 1) + len(text) - len(text.lstrip())
            match = _LINE.match(text)
            if match is None:
                raise Refusal(_At(line, column), f"not a line of an SXFM feature tree: {text.strip()[:60]!r}")
            depth = len(match["indent"].expandtabs(4)) if k else 0
            kinds.update(set(match["indent"]) & {"\t", " "})
            if len(kinds) == 2 and not mixed:
                mixed = True  # (said once: where tabs and spaces first meet)
                self.tolerate(_At(line, column), "the indentation mixes tabs and spaces: a tab counts as 4 spaces")
            lines.append(_Line(line, column, depth, match["kind"], match["rest"]))
        return lines

    def _feature(self, line: _Line) -> dict[str, Any]:
        """A feature's document: its id from the one in parentheses; a line without one gets
        an id of its own from its name, and a constraint may name it by its name if no other
        feature has that name or id."""
        named = _NAMED.match(line.rest)
        name, key = (named["name"], named["id"].strip()) if named else (line.rest, "")
        if not key and not name:
            raise Refusal(line, "a feature without a name or an id")
        if not key:
            self.tolerate(line, "lines without an id `(id)` get one made from their name (a name used twice: _2, _3, ...)")
            made = self.ids.fresh(name)
            if name in self.named:
                self.twice.add(name)
            self.named.setdefault(name, made)
            return {"id": made, "name": name}
        if key in self.ids:
            raise Refusal(line, f"a second feature with the id {key!r}: ids are unique in SXFM")
        return {"id": self.ids.of(key), "name": name or key}

    @staticmethod
    def _cardinality(line: _Line) -> tuple[int, int | None]:
        match = _CARDINALITY.match(line.rest)
        if match is None:
            raise Refusal(line, f"a group's cardinality is written [low,high] (high a number or *), not {line.rest!r}")
        return int(match["low"]), None if match["high"] == "*" else int(match["high"])

    def _groups(self, groups: list[_Line]) -> list[str]:
        """Each group's members under their feature: an OR or XOR group, or optional
        members with formulas (a second group of a kind, or one of at most one)."""
        seen: dict[tuple[int, str], int] = {}
        formulas: list[str] = []
        for group in groups:
            parent = group.owner
            assert parent is not None  # (set when the group's line was read)
            members = group.members
            if not members:
                raise Refusal(group, "a group without members")
            low, high = group.cardinality
            top = len(members) if high is None else min(high, len(members))
            if low > top or top == 0 or low > 1 or top not in (1, len(members)):  # ([0,k], [1,k]: 1 < k < n)
                shown = "*" if high is None else high
                raise Refusal(
                    group,
                    f"the group cardinality [{low},{shown}] over {len(members)} members cannot be kept: "
                    "only [1,1], [1,*], [0,1] and [0,*]",
                )
            kind = "XOR" if low == 1 and top == 1 and len(members) > 1 else "OR" if low == 1 and len(members) > 1 else ""
            seen[(id(parent), kind)] = seen.get((id(parent), kind), 0) + 1
            ids = [m["id"] for m in members]
            if kind and seen[(id(parent), kind)] == 1:
                for member in members:
                    member["group"] = kind
            else:
                for member in members:
                    if not (low == 1 and len(members) == 1):  # (one member, one needed: mandatory)
                        member["isMandatory"] = False
                if kind or (low == 0 and top == 1 and len(members) > 1):
                    formulas += self.group_as_formulas(parent["id"], ids, some=low == 1, one=top == 1)
            parent.setdefault("sub", []).extend(members)
        return formulas

    # -- the constraints: one clause per line
    def _clauses(self, constraints: Element) -> list[str]:
        formulas: list[str] = []
        for k, text in enumerate(constraints.text.split("\n")):
            if not text.strip():
                continue
            where = _At(constraints.line + k, 1 + len(text) - len(text.lstrip()))
            match = _CLAUSE.match(text.strip())
            if match is None:
                raise Refusal(where, f"a constraint is written `label: a or ~b`, not {text.strip()[:60]!r}")
            literals: list[Node] = []
            for literal in re.split(r"\s+or\s+", match["literals"].strip()):
                negated = literal.startswith("~")
                name = literal.removeprefix("~").strip()
                if not name or not re.fullmatch(r"[^\s~()]+", name):
                    raise Refusal(where, f"a literal is an id or ~id, not {literal!r}")
                if name not in self.ids and name in self.twice:
                    raise Refusal(where, f"the constraint names {name!r}, the name of two features without ids: give them ids")
                var = Var(self.named[name], 0) if name not in self.ids and name in self.named else self.reference(name, where)
                literals.append(self.negate(var) if negated else var)
            formulas.append(self.text(self.combine(OR, literals)))
        return formulas


class _At:
    """A place in the file that no element stands for (a line of a text)."""

    def __init__(self, line: int, column: int) -> None:
        self.line, self.column = line, column


# ----------------------------------------------------------------------------- export
def write_sxfm(model: FeatureModel) -> str:
    """The model as SXFM (the tree, its groups, every cross-tree rule as clauses);
    DocumentError (located at the formula) if a formula's clauses would be too many."""
    root = model.features[0]
    sxfm = attributes(model, root.index, "x-sxfm")
    name = sxfm["name"] if isinstance(sxfm.get("name"), str) else root.name
    meta: dict[str, Any] = sxfm["meta"] if isinstance(sxfm.get("meta"), dict) else {}
    lines = [f'<feature_model name="{_escape(name)}">', "<meta>"]
    lines += [f'<data name="{_escape(str(k))}">{_escape(str(v))}</data>' for k, v in meta.items()]
    lines += ["</meta>", "<feature_tree>"]
    taken = {f.id for f in model.features}
    work: list[tuple[Feature, int, str] | str] = [(root, 0, ":r ")]  # a feature, or a line as it is
    while work:
        item = work.pop()
        if isinstance(item, str):
            lines.append(item)
            continue
        feature, depth, mark = item
        lines.append("\t" * depth + f"{mark}{_escape(_name(feature))}({feature.id})")
        children = [model.features[c] for c in feature.children]
        pending: list[tuple[Feature, int, str] | str] = []
        pending += [(c, depth + 1, ":m " if c.mandatory else ":o ") for c in children if not c.group]
        for group, cardinality in ((GroupKind.OR, "[1,*]"), (GroupKind.XOR, "[1,1]")):
            members = [c for c in children if c.group == group]
            if members:
                gid = _free(f"{feature.id}_{group.value.lower()}", taken)
                pending.append("\t" * (depth + 1) + f":g ({gid}) {cardinality}")
                pending += [(m, depth + 2, ": ") for m in members]
        work.extend(reversed(pending))
    lines += ["</feature_tree>", "<constraints>"]
    clauses: list[str] = []
    for feature in model.features:
        clauses += [f"~{feature.id} or {other}" for other in dict.fromkeys(feature.includes)]
        clauses += [f"~{feature.id} or ~{other}" for other in dict.fromkeys(feature.excludes)]
    for formula in model.formulas:
        found = _cnf(formula.tree)
        if found is None:
            where = model.source.locate(("formulas", formula.position)) if model.source else Location(model.name)
            raise DocumentError(
                error(
                    where,
                    f"formula {formula.text[:60]!r} is more than {MAX_CLAUSES:,} clauses (or {MAX_LITERALS:,} "
                    "literals) in conjunctive normal form, and SXFM writes a formula so, without new variables: "
                    "simplify it, or export another format",
                    "sxfm",
                )
            )
        clauses += [" or ".join(clause) for clause in found]
    lines += [f"C{k}:{clause}" for k, clause in enumerate(clauses, 1)]
    lines += ["</constraints>", "</feature_model>"]
    return "\n".join(lines) + "\n"


def _free(base: str, taken: set[str]) -> str:
    candidate, k = base, 1
    while candidate in taken:
        k += 1
        candidate = f"{base}_{k}"
    taken.add(candidate)
    return candidate


def _name(feature: Feature) -> str:
    """A feature's name as a line of the tree can hold it (no parentheses, one line)."""
    return " ".join(feature.name.replace("(", "[").replace(")", "]").split()) or feature.id


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def _cnf(tree: Node) -> list[list[str]] | None:
    """The clauses of a formula as SXFM writes them (`id`, `~id`); None past the limits."""
    found = clauses_of(tree, MAX_CLAUSES, MAX_LITERALS)
    return None if found is None else [[("" if positive else "~") + fid for fid, positive in clause] for clause in found]

"""FeatureIDE XML (reference.md section 8): `<featureModel>` read into a feature model
document, and a model written as one.

In FeatureIDE the element of a feature says how its *children* are grouped: `<and>` (each
child mandatory or not by its `mandatory` attribute), `<or>`, `<alt>`; `<feature>` is a leaf.
`abstract="true"` is kept, `<constraints>` rules (`var`, `not`, `conj`, `disj`, `imp`, `eq`)
become formulas (rule 2.4), and the attributes `bindingTime` and `bindingMode` (FeatureIDE's
`<attribute name=... value=...>`) the allowed binding. Anything else of the model's meaning
(other constraint elements, feature cardinalities) is refused, located at its line and
column; a description or a property that means nothing for selection is dropped (a
description is kept under `x-featureide`).

A MoTiVML parent may mix ungrouped children with an OR and an XOR group; FeatureIDE gives a
parent one kind of children. Such a parent is written as `<and>` with its group members
optional, and each group as rules (the parent implies one of them; for an XOR group, no two
together), which keeps its selections, over the same features. Includes and excludes are
rules too. A rule carries no binding rule (2.4), so each of these is also written as an
attribute (`includes`, `excludes` on the feature, `group` on a member), and reading one back
brings the relation back in place of its rule: a round trip keeps the variants.

XML is read with expat (Python's own), declaring no entity (refused, as defusedxml does) and
fetching nothing, building the element tree by hand to keep each element's place.
"""

from __future__ import annotations

import collections
from typing import Any

from ..errors import DocumentError, Location, error
from .formula import AND, IFF, IMPLIES, OR, Node, at_most_one, fold
from .importer import ImportReader, Refusal
from .importer import attributes as kept_attributes
from .model import Feature, FeatureModel, GroupKind, token
from .xmltree import Element, parse_xml

_GROUPS = {"and": "", "or": "OR", "alt": "XOR", "feature": ""}
_OPERATORS = {"conj": AND, "disj": OR, "imp": IMPLIES, "eq": IFF}
_OWN = frozenset({"description", "bindingTime", "bindingMode", "includes", "excludes", "group"})  # written by export itself


def read_featureide(data: bytes, file: str) -> dict[str, Any]:
    """The feature model document of a FeatureIDE XML text; DocumentError (located) if it
    cannot be kept."""
    top = parse_xml(data, file, "featureide", "a FeatureIDE model")
    try:
        return _FeatureIdeReader().document(top)
    except Refusal as refusal:
        raise refusal.located(file, "featureide") from None


class _FeatureIdeReader(ImportReader):
    def __init__(self) -> None:
        super().__init__()
        self.grouped = False  # a `group` attribute was read (export's mark on a group written as rules)

    def document(self, top: Element) -> dict[str, Any]:
        if top.tag not in ("featureModel", "extendedFeatureModel"):
            raise Refusal(top, f"<{top.tag}> is not a FeatureIDE model (<featureModel>)")
        struct = next((c for c in top.children if c.tag == "struct"), None)
        if struct is None or len(struct.children) != 1:
            raise Refusal(struct or top, "a FeatureIDE model has one root feature in <struct>")
        root = self._features(struct.children[0])
        self.resolve_relations()  # (the rules that say them again are found below, as export wrote them)
        constraints = next((c for c in top.children if c.tag == "constraints"), None)
        formulas = [self._formula(rule) for rule in constraints.children] if constraints else []
        if self.relations or self.grouped:
            # the rules that say the relations above again, as export wrote them: each once
            said = collections.Counter(self._formula(parse_xml(f"<rule>{rule}</rule>".encode(), "", "featureide", "")) for rule in _relation_rules(root))
            kept = []
            for formula in formulas:
                if said[formula] > 0:
                    said[formula] -= 1
                else:
                    kept.append(formula)
            formulas = kept
        if formulas:
            root["formulas"] = formulas
        return root

    def _features(self, top: Element) -> dict[str, Any]:
        root: dict[str, Any] | None = None
        work: list[tuple[Element, dict[str, Any] | None, str]] = [(top, None, "")]
        while work:
            element, parent, group = work.pop()
            if element.tag not in _GROUPS:
                raise Refusal(element, f"<{element.tag}> is not a feature (and, or, alt, feature)")
            name = element.attributes.get("name", "")
            if not name:
                raise Refusal(element, "a feature without a name")
            if name in self.ids:
                raise Refusal(element, f"a second feature named {name!r}: names are unique in FeatureIDE")
            document: dict[str, Any] = {"id": self.ids.of(name), "name": name}
            if group:
                document["group"] = group
            elif parent is not None and element.attributes.get("mandatory") != "true":
                document["isMandatory"] = False
            if element.attributes.get("abstract") == "true":
                document["abstract"] = True
            children: list[Element] = []
            for child in element.children:
                if child.tag in _GROUPS:
                    children.append(child)
                elif child.tag == "attribute":
                    self._attribute(child, document)
                elif child.tag == "description":
                    document.setdefault("x-featureide", {})["description"] = child.text.strip()
                elif child.tag not in ("graphics", "property"):
                    raise Refusal(child, f"<{child.tag}> in a feature cannot be kept")
            if parent is not None:
                parent.setdefault("sub", []).append(document)
            root = root or document
            kind = _GROUPS[element.tag]
            if kind and len(children) == 1:
                kind = ""  # one member: selected with its parent, as the group would have it
                children[0].attributes["mandatory"] = "true"
            work.extend((child, document, kind) for child in reversed(children))
        assert root is not None  # (the work list began with the root)
        return root

    def _attribute(self, element: Element, document: dict[str, Any]) -> None:
        key, value = element.attributes.get("name", ""), element.attributes.get("value", "")
        if key in ("includes", "excludes"):  # (motivml's own, written by export; resolved at the end)
            self.relation(document, key, value.split(), element)
        elif key == "group" and value in ("OR", "XOR"):
            document["group"] = value
            document.pop("isMandatory", None)
            self.grouped = True
        elif not self.binding(key, value, document, element):
            document.setdefault("x-featureide", {})[key] = value

    def _formula(self, rule: Element) -> str:
        """A rule as rule 2.4 writes it (ids renamed): its tree, built bottom-up."""
        if rule.tag != "rule" or len(rule.children) != 1:
            raise Refusal(rule, "a constraint is one <rule> holding one expression")
        results: list[Node] = []
        work: list[tuple[Element, bool]] = [(rule.children[0], False)]
        while work:
            element, done = work.pop()
            if element.tag == "var":
                results.append(self.reference(element.text.strip(), element))
                continue
            arity = {"not": 1, "imp": 2, "eq": 2}.get(element.tag)
            if element.tag not in ("not", *_OPERATORS):
                raise Refusal(element, f"<{element.tag}> in a constraint cannot be kept: only var, not, conj, disj, imp, eq")
            if (arity and len(element.children) != arity) or not element.children:
                raise Refusal(element, f"<{element.tag}> with {len(element.children)} operands")
            if not done:
                work.append((element, True))
                work.extend((child, False) for child in reversed(element.children))
                continue
            count = len(element.children)
            parts = results[len(results) - count :]
            del results[len(results) - count :]
            results.append(self.negate(parts[0]) if element.tag == "not" else self.combine(_OPERATORS[element.tag], parts))
        return self.text(results[0])


# ----------------------------------------------------------------------------- export
def write_featureide(model: FeatureModel) -> str:
    """The model as FeatureIDE XML: features by id (the name as a description when it
    differs), groups as FeatureIDE can hold them, the rest as rules; bindings as attributes."""
    from xml.sax.saxutils import quoteattr

    features = model.features
    for feature in features:  # XML 1.0 holds no control character but tab and newlines, not even escaped
        bad = next((c for c in feature.name if not _xml_char(c)), None)
        if bad is not None:
            where = model.source.locate(model.path(feature.index, "name")) if model.source else Location(model.name)
            raise DocumentError(
                error(
                    where,
                    f"the name of {feature.id} cannot be written in FeatureIDE XML (U+{ord(bad):04X}: XML 1.0"
                    " holds no such character)",
                    "featureide",
                )
            )
    rules: list[str] = []
    lines = ['<?xml version="1.0" encoding="UTF-8" standalone="no"?>', "<featureModel>", "    <struct>"]
    work: list[tuple[int | str, int]] = [(0, 2)]
    while work:
        item, depth = work.pop()
        pad = "    " * depth
        if isinstance(item, str):
            lines.append(pad + item)
            continue
        feature = features[item]
        tag = _tag(model, feature)
        mixed = tag == "and"
        if mixed:  # groups of a parent with other children: as rules
            for kind in GroupKind:
                members = [features[c].id for c in feature.children if features[c].group == kind]
                if members:
                    rules.append(_rule_disj(feature.id, members))
                    if kind is GroupKind.XOR:  # (n log n names, not the n^2 / 2 pairs: 348 MB for 3,000 members)
                        rules += [_rule_none_of_both(a, b) for a, b in at_most_one(members)]
        parent = features[feature.parent] if feature.parent is not None else None
        mandatory = parent is None or (feature.mandatory and not feature.group)
        attributes = f"name={quoteattr(feature.id)}"
        if feature.abstract:
            attributes += ' abstract="true"'
        if mandatory and parent is not None:
            attributes += ' mandatory="true"'
        inner = [  # (a model that says no binding takes the defaults, and reads back the same without them)
            f'<attribute name="bindingTime" type="string" value="{token(feature.time_allowed)}"/>',
            f'<attribute name="bindingMode" type="string" value="{token(feature.mode_allowed)}"/>',
        ] if model.bindings_declared else []
        # What rules cannot say, beside the rules other tools count by: an include's binding
        # rule (3.1), and that excluding features and members of a group written as rules
        # may be Dynamic alternatives (3.3). Read back, they replace their rules.
        for key, targets in (("includes", feature.includes), ("excludes", feature.excludes)):
            if targets:
                value = quoteattr(" ".join(dict.fromkeys(targets)))
                inner.append(f'<attribute name="{key}" type="string" value={value}/>')
        if feature.group and parent is not None and _tag(model, parent) == "and":
            inner.append(f'<attribute name="group" type="string" value="{feature.group}"/>')
        kept = kept_attributes(model, feature.index, "x-featureide")  # (what an import kept)
        for key, value in kept.items():
            if key not in _OWN and isinstance(value, str):
                inner.append(f'<attribute name={quoteattr(key)} type="string" value={quoteattr(value)}/>')
        if feature.name != feature.id:
            inner.insert(0, f"<description>{_escape(feature.name)}</description>")
        elif isinstance(kept.get("description"), str):
            inner.insert(0, f"<description>{_escape(kept['description'])}</description>")
        lines.append(f"{pad}<{tag} {attributes}>")
        lines += [pad + "    " + line for line in inner]
        work.append((f"</{tag}>", depth))
        work.extend((c, depth + 1) for c in reversed(feature.children))
    for feature in features:
        rules += [_rule_imp(feature.id, y) for y in dict.fromkeys(feature.includes)]
        rules += [_rule_not_both(feature.id, y) for y in dict.fromkeys(feature.excludes)]
    for formula in model.formulas:
        rules.append(
            fold(
                formula.tree,
                lambda var: f"<var>{var.id}</var>",
                lambda x: f"<not>{x}</not>",
                {op: _element(op) for op in (AND, OR, IMPLIES, IFF)},
            )
        )
    lines += ["    </struct>", "    <constraints>"]
    lines += [f"        <rule>{rule}</rule>" for rule in rules]
    lines += ["    </constraints>", "</featureModel>"]
    return "\n".join(lines) + "\n"


def _tag(model: FeatureModel, feature: Feature) -> str:
    """The FeatureIDE element of a feature: a leaf, a group of one kind, or `and`."""
    if not feature.children:
        return "feature"
    kinds = {model.features[c].group for c in feature.children}
    return "or" if kinds == {"OR"} else "alt" if kinds == {"XOR"} else "and"


def _relation_rules(document: dict[str, Any]) -> list[str]:
    """The rules `write_featureide` writes for a document's includes, excludes and groups
    beside other children (so that the reader can tell them from a model's own), over the
    FeatureIDE names the document's features were read from (an id may differ: a second
    `lidar` beside `Lidar` is `lidar_2`), as the file's own rules are."""
    names: dict[str, str] = {}  # id -> its name, as XML text (a name may hold & or <)
    work = [document]
    while work:
        node = work.pop()
        names[node["id"]] = _escape(node["name"])
        work += node.get("sub", [])
    rules: list[str] = []
    work = [document]
    while work:
        node = work.pop()
        sub = node.get("sub", [])
        kinds = {child.get("group", "") for child in sub}
        if sub and len(kinds) > 1:  # (a parent whose groups are written as rules)
            for kind in ("OR", "XOR"):
                members = [names[child["id"]] for child in sub if child.get("group") == kind]
                if members:
                    rules.append(_rule_disj(names[node["id"]], members))
                    if kind == "XOR":
                        rules += [_rule_none_of_both(a, b) for a, b in at_most_one(members)]
        constraints = node.get("constraints", {})
        rules += [_rule_imp(names[node["id"]], names[y]) for y in constraints.get("featuresIncluded", [])]
        rules += [_rule_not_both(names[node["id"]], names[y]) for y in constraints.get("featuresExcluded", [])]
        work += sub
    return rules


def _element(op: str) -> Any:
    tag = {AND: "conj", OR: "disj", IMPLIES: "imp", IFF: "eq"}[op]
    return lambda x, y: f"<{tag}>{x}{y}</{tag}>"


def _rule_disj(parent: str, members: list[str]) -> str:
    return f"<imp><var>{parent}</var><disj>{''.join(f'<var>{m}</var>' for m in members)}</disj></imp>"


def _rule_none_of_both(a: list[str], b: list[str]) -> str:
    """Not some of `a` and some of `b`."""

    def some(names: list[str]) -> str:
        if len(names) == 1:
            return f"<var>{names[0]}</var>"
        return f"<disj>{''.join(f'<var>{n}</var>' for n in names)}</disj>"

    return f"<not><conj>{some(a)}{some(b)}</conj></not>"


def _rule_not_both(a: str, b: str) -> str:
    return f"<not><conj><var>{a}</var><var>{b}</var></conj></not>"


def _rule_imp(a: str, b: str) -> str:
    return f"<imp><var>{a}</var><var>{b}</var></imp>"


def _xml_char(c: str) -> bool:
    """Whether XML 1.0 holds the character (its production Char)."""
    n = ord(c)
    return n in (0x9, 0xA, 0xD) or 0x20 <= n <= 0xD7FF or 0xE000 <= n <= 0xFFFD or 0x10000 <= n <= 0x10FFFF


def _escape(text: str) -> str:
    from xml.sax.saxutils import escape

    return escape(text)

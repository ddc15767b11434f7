"""UVL (reference.md section 8): read a UVL model into a feature model document, write one back.

UVL is the product-line community's exchange language (FeatureIDE, flamapy, UVLHub). Its
Boolean level maps onto MoTiVML one to one: `mandatory` and `optional` children, `or` and
`alternative` groups (a parent's second group of a kind becomes formulas, since a parent
has one OR and one XOR group here), the `abstract` attribute, and constraints as formulas
(rule 2.4). Binding time and mode travel as the attributes `bindingTime` and `bindingMode`
with section 1's tokens, includes and excludes as `includes` and `excludes` (each also
written as a constraint, so that other tools count the same selections), the feature's
name as `name`; other attributes are kept under the document's `x-uvl` key.

What cannot be kept is refused, located at its line and column: group cardinalities,
feature cardinalities, typed features, arithmetic constraints, imports, and language levels
beyond Boolean. Feature names become ids deterministically: a name that is an id and free
is kept; otherwise its other characters become `_` (a leading digit gets one before it)
and a clash, also one of case only, gets `_2`, `_3`, ...

The text is parsed by lark (MIT) with a grammar of our own and lark's indentation
post-lexer; the parse tree is turned into a document iteratively, so a deep model does not
exhaust Python's stack.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import Any

from ..errors import Diagnostic, DocumentError, Location, error
from .formula import AND, IFF, IMPLIES, OR, Node, fold, without_outer_parentheses
from .importer import ImportReader, Refusal, attributes
from .model import Feature, FeatureModel, token

_GRAMMAR = r"""
start: _NL? _header* features? constraints?

_header: namespace | include | imports
namespace: "namespace" name _NL
include: "include" _NL _INDENT (level _NL)+ _DEDENT
level: NAME ("." (NAME | STAR))*
imports: "imports" _NL _INDENT (name ("as" name)? _NL)+ _DEDENT

features: "features" _NL _INDENT feature _DEDENT
feature: TYPE? name feature_cardinality? attributes? _NL (_INDENT group+ _DEDENT)?
       | TYPE feature_cardinality? attributes? _NL (_INDENT group+ _DEDENT)? -> type_named
feature_cardinality: "cardinality" cardinality
group: GROUP _NL _INDENT feature+ _DEDENT
     | cardinality _NL _INDENT feature+ _DEDENT -> cardinality_group
cardinality: "[" INT (".." (INT | STAR))? "]"

attributes: "{" [attribute ("," attribute)*] "}"
attribute: name value?
value: STRING -> string
     | QUOTED -> quoted_string
     | SIGNED_NUMBER -> number
     | "true" -> true
     | "false" -> false
     | attributes
     | "[" [value ("," value)*] "]" -> vector
     | "constraint" expression -> attribute_constraint
     | "constraints" "[" [expression ("," expression)*] "]" -> attribute_constraint

constraints: "constraints" _NL (_INDENT (expression _NL)+ _DEDENT)?

?expression: iff
?iff: implies | implies IFF_OP implies (IFF_OP implies)*
?implies: disjunction | disjunction IMPLIES_OP disjunction (IMPLIES_OP disjunction)*
?disjunction: conjunction ("|" conjunction)*
?conjunction: negation ("&" negation)*
?negation: "!" negation -> negation
         | atom
?atom: name -> reference
     | TYPE -> type_reference
     | "(" expression ")"
     | SIGNED_NUMBER -> arithmetic
     | STRING -> arithmetic
     | atom ARITHMETIC_OP atom -> arithmetic
     | NAME "(" [expression ("," expression)*] ")" -> arithmetic

name: NAME ("." NAME)* | QUOTED
GROUP: "mandatory" | "optional" | "or" | "alternative"
TYPE: "Boolean" | "Integer" | "Real" | "String"
IFF_OP: "<=>"
IMPLIES_OP: "=>"
ARITHMETIC_OP: "==" | "!=" | "<=" | ">=" | "<" | ">" | "+" | "-" | "*" | "/"
STAR: "*"
NAME: /(?!(mandatory|optional|or|alternative|features|constraints|constraint|cardinality|namespace|include|imports|as|true|false|Boolean|Integer|Real|String)\b)[^\s"'.,(){}\[\]!&|=<>+\-*\/]+/
QUOTED: /"[^"\n]*"/
STRING: /'[^'\n]*'/
%import common.INT
%import common.SIGNED_NUMBER
_NL: /(\r?\n[\t ]*((\/\/[^\n]*)|(\/\*([^*]|\*(?!\/))*\*\/))?)+/
COMMENT: /\/\/[^\n]*/ | /\/\*([^*]|\*(?!\/))*\*\//
%ignore COMMENT
%ignore /[\t \f]+/
%declare _INDENT _DEDENT
"""

_UVL_KEYWORDS = frozenset(
    "mandatory optional or alternative features constraints constraint cardinality namespace include "
    "imports as true false Boolean Integer Real String".split()
)
_PARSER: Any = None
_POSITION = "\0position"  # a child's position attribute while the tree is read


def _parser() -> Any:
    global _PARSER
    if _PARSER is None:
        from lark import Lark
        from lark.indenter import Indenter

        class UVLIndenter(Indenter):
            NL_type = "_NL"
            OPEN_PAREN_types = ["LPAR", "LSQB", "LBRACE"]
            CLOSE_PAREN_types = ["RPAR", "RSQB", "RBRACE"]
            INDENT_type = "_INDENT"
            DEDENT_type = "_DEDENT"
            tab_len = 4

        _PARSER = Lark(_GRAMMAR, parser="lalr", postlex=UVLIndenter(), propagate_positions=True, maybe_placeholders=False)
    return _PARSER


def read_uvl(text: str, file: str, warnings: list[Diagnostic] | None = None) -> dict[str, Any]:
    """The feature model document of a UVL text; DocumentError (located) if it cannot be
    kept. What published files write otherwise than UVL's grammar, and is read anyway (the
    dialects of FeatureIDE's and other tools' exports), is said in `warnings` (when given)."""
    from lark.exceptions import LarkError, UnexpectedInput

    reader = _UvlReader()
    try:
        tree = _parser().parse(text if text.endswith("\n") else text + "\n")
        document = reader.document(tree)
        if warnings is not None:
            warnings += reader.said(file, "uvl")
        return document
    except Refusal as refusal:
        raise refusal.located(file, "uvl") from None
    except UnexpectedInput as problem:
        where = Location(file, getattr(problem, "line", None), getattr(problem, "column", None))
        found = getattr(problem, "token", None) or getattr(problem, "char", None)
        what = f"unexpected {str(found)!r}" if found not in (None, "") else "unexpected end of the text"
        raise DocumentError(error(where, f"not UVL: {what}", "uvl")) from None
    except LarkError as problem:  # (the indenter: a dedent to a level never opened)
        raise DocumentError(error(Location(file), f"not UVL: {problem}", "uvl")) from None


class _UvlReader(ImportReader):
    def __init__(self) -> None:
        super().__init__()
        self.declared: set[str] = set()  # names of the features read so far

    def _id(self, name: str) -> str:
        return self.ids.of(name)

    def document(self, tree: Any) -> dict[str, Any]:
        sections = {child.data: child for child in tree.children if hasattr(child, "data")}
        if "imports" in sections:
            raise Refusal(sections["imports"].meta, "imports of other UVL models cannot be kept: merge them first")
        if "include" in sections:
            for level in sections["include"].children:
                words = [str(t) for t in level.children]
                if words[0] != "Boolean":
                    raise Refusal(level.meta, f"the language level {'.'.join(words)} cannot be kept: only Boolean")
        if "features" not in sections:
            raise Refusal(tree.meta, "the model has no features")
        root, formulas, kept = self._features(sections["features"].children[0])
        if "constraints" in sections:
            for expression in sections["constraints"].children:
                text = self._formula(expression)
                if text not in kept:
                    formulas.append(text)
        if formulas:
            root["formulas"] = formulas
        return root

    # -- the feature tree, iteratively (a work list of (tree node, parent document))
    def _features(self, top: Any) -> tuple[dict[str, Any], list[str], set[str]]:
        """The root's document, the formulas its second groups need, and the constraints
        that its includes and excludes already say (not to be read again as formulas)."""
        documents: list[dict[str, Any]] = []
        extra_formulas: list[str] = []
        work: list[tuple[Any, dict[str, Any] | None, str]] = [(top, None, "")]
        while work:
            node, parent, kind = work.pop()
            document = self._feature(node, kind)
            documents.append(document)
            if parent is not None:
                parent.setdefault("sub", []).append(document)
            groups_seen: dict[str, int] = {}
            pending: list[tuple[Any, dict[str, Any], str]] = []
            for group in (child for child in node.children if getattr(child, "data", None) in ("group", "cardinality_group")):
                if group.data == "cardinality_group":
                    raise Refusal(group.meta, "group cardinalities cannot be kept: only mandatory, optional, or, alternative")
                label = str(group.children[0])
                members = group.children[1:]
                if label in ("or", "alternative"):
                    groups_seen[label] = groups_seen.get(label, 0) + 1
                    if len(members) == 1:
                        label = "mandatory"  # one member: selected with its parent, as a group would
                    elif groups_seen[label] > 1:  # a second group of a kind: its meaning as formulas
                        names = [self._id(self._name(m)) for m in members]
                        extra_formulas += self.group_as_formulas(document["id"], names, True, label == "alternative")
                        label = "optional"
                pending += [(member, document, label) for member in members]
            work.extend(reversed(pending))
        for document in documents:  # children back in the order positions give (export's own)
            sub = document.get("sub", [])
            if any(_POSITION in child for child in sub):
                sub.sort(key=lambda child: child.get(_POSITION, len(sub)))
        for document in documents:  # (the root's too: it has no siblings to be sorted among)
            document.pop(_POSITION, None)
        kept = set(self.resolve_relations())
        return documents[0], extra_formulas, kept

    def _name(self, node: Any) -> str:
        if node.data == "type_named":  # (a feature named as a type: `Integer` alone on its line)
            return str(node.children[0])
        name = next(child for child in node.children if getattr(child, "data", None) == "name")
        return _name_text(name)

    def _feature(self, node: Any, kind: str) -> dict[str, Any]:
        children = node.children
        if node.data == "type_named":
            self.tolerate(
                children[0],
                f"a feature named {children[0]}, a word of UVL's types, is read as a name "
                f"(UVL quotes it: \"{children[0]}\"; FeatureIDE's exports do not)",
            )
        elif children and not hasattr(children[0], "data") and children[0].type == "TYPE" and str(children[0]) != "Boolean":
            raise Refusal(children[0], f"a feature of type {children[0]} cannot be kept: only Boolean features")
        name = self._name(node)
        if not name:
            raise Refusal(node.meta, "a feature named \"\": every feature needs a name")
        if name in self.declared:
            raise Refusal(node.meta, f"a second feature named {name!r}: names are unique in UVL")
        self.declared.add(name)
        document: dict[str, Any] = {"id": self._id(name), "name": name}
        if kind == "or":
            document["group"] = "OR"
        elif kind == "alternative":
            document["group"] = "XOR"
        elif kind == "optional":
            document["isMandatory"] = False
        for child in children:
            data = getattr(child, "data", None)
            if data == "feature_cardinality":
                raise Refusal(child.meta, f"the feature cardinality of {name} cannot be kept")
            if data == "attributes":
                self._attributes(child, document)
        return document

    def _attributes(self, node: Any, document: dict[str, Any]) -> None:
        others: dict[str, Any] = {}
        for attribute in node.children:
            key = _name_text(attribute.children[0])
            value = self._value(attribute.children[1]) if len(attribute.children) > 1 else True
            if key == "abstract":
                if not isinstance(value, bool):
                    raise Refusal(attribute.meta, "abstract is true or false")
                if value:
                    document["abstract"] = True
            elif self.binding(key, value, document, attribute.meta):
                pass
            elif key == "name" and isinstance(value, str) and value:
                document["name"] = value
            elif key == "position" and isinstance(value, int):
                document[_POSITION] = value
            elif key in ("includes", "excludes") and isinstance(value, list) and all(isinstance(v, str) for v in value):
                self.relation(document, key, value, attribute.meta)
            elif key == "isMandatory" or key == "group":
                raise Refusal(attribute.meta, f"the attribute {key} is motivml's own word: write the group instead")
            else:
                others[key] = value
        if others:
            document["x-uvl"] = others

    def _value(self, node: Any) -> Any:
        while node.data == "value":  # (an attribute list as a value)
            node = node.children[0]
        data = node.data
        if data == "string":
            return str(node.children[0])[1:-1]
        if data == "quoted_string":
            self.tolerate(
                node.children[0],
                "attribute values in double quotes are read as strings "
                "(UVL quotes a string with single quotes; FeatureIDE's exports use double quotes)",
            )
            return str(node.children[0])[1:-1]
        if data == "number":
            text = str(node.children[0])
            number = int(text) if re.fullmatch(r"[+-]?\d+", text) else float(text)
            if isinstance(number, float) and not math.isfinite(number):
                raise Refusal(node.children[0], f"the number {text} is out of range: it cannot be kept")
            return number
        if data in ("true", "false"):
            return data == "true"
        if data == "vector":
            return [self._value(child) for child in node.children]
        if data == "attributes":
            return {
                _name_text(a.children[0]): self._value(a.children[1]) if len(a.children) > 1 else True
                for a in node.children
            }
        raise Refusal(node.meta, "attribute constraints cannot be kept")

    def _formula(self, expression: Any) -> str:
        """A constraint as rule 2.4 writes it (ids renamed): its tree, built bottom-up."""
        results: list[Node] = []
        work: list[tuple[Any, bool]] = [(expression, False)]
        while work:
            node, done = work.pop()
            data = getattr(node, "data", None)
            if data == "reference":
                results.append(self.reference(_name_text(node.children[0]), node.meta))
            elif data == "type_reference":  # (a feature named as a type, unquoted)
                self.tolerate(
                    node.children[0],
                    f"{node.children[0]}, a word of UVL's types, is read as a feature's name in a constraint",
                )
                results.append(self.reference(str(node.children[0]), node.children[0]))
            elif data == "arithmetic":
                raise Refusal(node.meta, "arithmetic and type-level constraints cannot be kept: only Boolean ones")
            elif data in _OPERATORS:
                operands = [c for c in node.children if hasattr(c, "data")]
                if not done:
                    if data in ("iff", "implies") and len(operands) > 2:
                        raise Refusal(node.meta, "a chain of => or <=> without parentheses is read differently by different tools: add them")
                    work.append((node, True))
                    work.extend((c, False) for c in reversed(operands))
                    continue
                parts = results[len(results) - len(operands) :]
                del results[len(results) - len(operands) :]
                op = _OPERATORS[data]
                results.append(self.negate(parts[0]) if op is None else self.combine(op, parts))
            else:
                raise Refusal(getattr(node, "meta", None), f"cannot read this constraint ({data})")
        return self.text(results[0])


_OPERATORS = {"negation": None, "disjunction": OR, "conjunction": AND, "iff": IFF, "implies": IMPLIES}


def _name_text(node: Any) -> str:
    parts = [str(t) for t in node.children]
    if len(parts) == 1 and parts[0].startswith('"'):
        return parts[0][1:-1]
    return ".".join(parts)


# ----------------------------------------------------------------------------- export
def write_uvl(model: FeatureModel) -> str:
    """The model in UVL: features by id, bindings, names, includes and excludes as attributes,
    includes, excludes and formulas as constraints (so other tools count the same selections)."""
    features = model.features
    for feature in features:  # UVL's strings have no escapes: a name it cannot hold is refused
        if "'" in feature.name or not feature.name.isprintable():
            where = model.source.locate(model.path(feature.index, "name")) if model.source else Location(model.name)
            raise DocumentError(
                error(where, f"the name of {feature.id} cannot be written in UVL (a quote or a control character)", "uvl")
            )
    lines = ["features"]
    positions: dict[int, int] = {}  # a child's position among its siblings, where UVL moves it
    work: list[tuple[str | int, int]] = [(0, 1)]  # a feature's index or a group keyword, and its indent
    while work:
        item, level = work.pop()
        if isinstance(item, str):
            lines.append("    " * level + item)
            continue
        feature = features[item]
        kept = attributes(model, feature.index, "x-uvl")  # (the attributes an import kept)
        said = _uvl_attributes(feature, positions.get(item), kept, model.bindings_declared)
        lines.append("    " * level + _uvl_name(feature.id) + said)
        # children in their order, one keyword per run of a kind; a group's members together
        # where its first one stands (UVL has one place per group): if that moves a child,
        # each child says its position, so that the order comes back on import
        runs: list[tuple[str, list[int]]] = []
        placed: dict[str, list[int]] = {}
        for c in feature.children:
            kind = _KIND[features[c].group] if features[c].group else ("mandatory" if features[c].mandatory else "optional")
            if kind in ("or", "alternative") and kind in placed:
                placed[kind].append(c)
            elif runs and runs[-1][0] == kind and kind not in ("or", "alternative"):
                runs[-1][1].append(c)
            else:
                runs.append((kind, [c]))
                placed.setdefault(kind, runs[-1][1])
        order = [c for _, members in runs for c in members]
        if order != feature.children:
            positions.update({c: k for k, c in enumerate(feature.children)})
        pending: list[tuple[str | int, int]] = []
        for keyword, members in runs:
            pending.append((keyword, level + 1))
            pending += [(m, level + 2) for m in members]
        work.extend(reversed(pending))
    constraints: list[str] = []
    for feature in features:
        name = _uvl_name(feature.id)
        constraints += [f"{name} => {_uvl_name(y)}" for y in dict.fromkeys(feature.includes)]
        constraints += [f"!({name} & {_uvl_name(y)})" for y in dict.fromkeys(feature.excludes)]
    for formula in model.formulas:
        text = fold(
            formula.tree,
            lambda var: _uvl_name(var.id),
            lambda x: f"!{x}",
            {op: _joiner(op) for op in (AND, OR, IMPLIES, IFF)},
        )
        constraints.append(without_outer_parentheses(text))
    if constraints:
        lines += ["constraints", *("    " + c for c in constraints)]
    return "\n".join(lines) + "\n"


def _joiner(op: str) -> Callable[[str, str], str]:
    return lambda x, y: f"({x} {op} {y})"


def _uvl_name(feature_id: str) -> str:
    return f'"{feature_id}"' if feature_id in _UVL_KEYWORDS else feature_id


_KIND = {"OR": "or", "XOR": "alternative"}


def _uvl_attributes(
    feature: Feature, position: int | None = None, kept: dict[str, Any] | None = None, bound: bool = True
) -> str:
    """A feature's attributes; its binding only where the model says bindings (`bound`: a
    model that says none takes the defaults, and reads back the same without them)."""
    parts: list[str] = []
    if position is not None:
        parts.append(f"position {position}")
    if feature.abstract:
        parts.append("abstract")
    if feature.name != feature.id:
        parts.append(f"name {_uvl_string(feature.name)}")
    if bound:
        parts.append(f"bindingTime '{token(feature.time_allowed)}'")
        parts.append(f"bindingMode '{token(feature.mode_allowed)}'")
    if feature.includes:
        parts.append("includes [" + ", ".join(f"'{i}'" for i in dict.fromkeys(feature.includes)) + "]")
    if feature.excludes:
        parts.append("excludes [" + ", ".join(f"'{i}'" for i in dict.fromkeys(feature.excludes)) + "]")
    for key, value in (kept or {}).items():
        written = _uvl_value(value)
        if written is not None and key not in _OWN_ATTRIBUTES:
            parts.append(_uvl_attribute_name(key) + ("" if written == "true" else f" {written}"))
    return " {" + ", ".join(parts) + "}"


_OWN_ATTRIBUTES = frozenset({"abstract", "name", "position", "bindingTime", "bindingMode", "includes", "excludes"})


def _uvl_attribute_name(key: str) -> str:
    return key if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", key) and key not in _UVL_KEYWORDS else f'"{key}"'


def _uvl_value(value: Any, depth: int = 0) -> str | None:
    """An attribute's value as UVL writes it; None for one it cannot hold (a string with a
    quote or a line break, a value nested deeper than 20 levels, or holding either), which
    is left out."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return f"'{value}'" if "'" not in value and "\n" not in value else None
    if depth >= 20 or not isinstance(value, (list, dict)):
        return None
    pairs = list(value.items()) if isinstance(value, dict) else [("", v) for v in value]
    written = [(k, _uvl_value(v, depth + 1)) for k, v in pairs]
    if any(v is None for _, v in written):
        return None
    if isinstance(value, list):
        return "[" + ", ".join(str(v) for _, v in written) + "]"
    return "{" + ", ".join(_uvl_attribute_name(k) + ("" if v == "true" else f" {v}") for k, v in written) + "}"


def _uvl_string(text: str) -> str:
    return "'" + text + "'"



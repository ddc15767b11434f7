"""XML read safely into a tree of elements that keep their line and column (the XML importers':
FeatureIDE's, S.P.L.O.T.'s SXFM)."""

from __future__ import annotations

from dataclasses import dataclass, field
from xml.parsers import expat

from ..errors import DocumentError, Location, error


@dataclass
class Element:
    tag: str
    attributes: dict[str, str]
    line: int
    column: int
    children: list[Element] = field(default_factory=list)
    text: str = ""
    pieces: list[str] = field(default_factory=list)  # the text as expat gives it, joined at the end tag


def parse_xml(data: bytes, file: str, rule: str, kind: str) -> Element:
    """The element tree of an XML text, in time linear in its size (`kind`: what the file
    should be, for the messages; `rule`: their rule).

    As defusedxml does, no entity is declared or expanded: a model has no DTD of its own, and ten nested entities of ten references each (a 1 KB "billion laughs")
    expand to a billion. Text is kept in pieces and joined once per element (a description
    of 200,000 lines, appended piece by piece, took 14 s)."""
    parser = expat.ParserCreate()
    parser.buffer_text = True  # (adjacent text in one call, not one per line or reference)
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    root: list[Element] = []
    stack: list[Element] = []

    def start(tag: str, attributes: dict[str, str]) -> None:
        element = Element(tag, attributes, parser.CurrentLineNumber, parser.CurrentColumnNumber + 1)
        (stack[-1].children if stack else root).append(element)
        stack.append(element)

    def end(tag: str) -> None:
        element = stack.pop()
        element.text, element.pieces = "".join(element.pieces), []

    def text(content: str) -> None:
        if stack:
            stack[-1].pieces.append(content)

    def entity(name: str, *_: object) -> None:
        raise _Entity(parser.CurrentLineNumber, parser.CurrentColumnNumber + 1, name)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = text
    parser.EntityDeclHandler = entity

    def external(context: str, base: str | None, system: str | None, public: str | None) -> int:
        raise _Entity(parser.CurrentLineNumber, parser.CurrentColumnNumber + 1, system or context)

    parser.ExternalEntityRefHandler = external
    try:
        parser.Parse(data, True)
    except expat.ExpatError as problem:
        where = Location(file, problem.lineno, problem.offset + 1)
        raise DocumentError(error(where, f"not XML: {expat.ErrorString(problem.code)}", rule)) from None
    except _Entity as declared:
        where = Location(file, declared.line, declared.column)
        message = f"the entity {declared.name!r} is declared: {kind} declares no entities (refused, as defusedxml does)"
        raise DocumentError(error(where, message, rule)) from None
    return root[0]


class _Entity(Exception):
    def __init__(self, line: int, column: int, name: str) -> None:
        super().__init__(name)
        self.line, self.column, self.name = line, column, name

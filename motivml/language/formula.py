"""Cross-tree formulas (reference.md 2.4): the syntax of UVL's Boolean level over feature ids.

    slam => lidar | camera          !(gps & indoor)          a <=> (b & !c)

Precedence from tightest: `!`, `&`, `|`, `=>`, `<=>`; `=>` and `<=>` group to the right,
`&` and `|` to the left (it does not change the meaning). Parsing is an operator-precedence
(shunting-yard) pass with explicit stacks, so a formula nested ten thousand levels deep or
a conjunction of ten thousand ids is read like any other; the trees are walked iteratively
too. A formula that does not parse raises `FormulaError` with the offset (into the text) of
the character where it goes wrong; ids are checked against the model by the reader.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Final, TypeVar

# Operators: their precedence (higher binds tighter) and whether they group to the right.
NOT: Final = "!"
AND: Final = "&"
OR: Final = "|"
IMPLIES: Final = "=>"
IFF: Final = "<=>"
_BINARY: Final = {AND: (3, False), OR: (2, False), IMPLIES: (1, True), IFF: (0, True)}

_TOKEN = re.compile(r"\s*(?:([A-Za-z_][A-Za-z0-9_]*)|(<=>|=>|[!&|()]))")
_TRAILING_SPACE = re.compile(r"\s*\Z")


class FormulaError(ValueError):
    """A formula that does not parse: what is wrong, at which offset of its text."""

    def __init__(self, offset: int, message: str) -> None:
        super().__init__(message)
        self.offset = offset
        self.message = message


@dataclass(frozen=True, slots=True)
class Var:
    """A feature id, where it stands in the text."""

    id: str
    offset: int


# Nodes compare by identity (eq=False): a generated equality would recurse down a deep tree.
@dataclass(frozen=True, slots=True, eq=False)
class Not:
    operand: Node


@dataclass(frozen=True, slots=True, eq=False)
class Binary:
    op: str  # AND, OR, IMPLIES or IFF
    left: Node
    right: Node


Node = Var | Not | Binary


@dataclass(frozen=True, slots=True)
class Formula:
    """One formula of the model: its text as written, its tree, its position in `formulas`."""

    text: str
    tree: Node
    position: int

    def variables(self) -> Iterator[Var]:
        """Every occurrence of an id, left to right (iterative)."""
        stack: list[Node] = [self.tree]
        while stack:
            node = stack.pop()
            if isinstance(node, Var):
                yield node
            elif isinstance(node, Not):
                stack.append(node.operand)
            else:
                stack.append(node.right)
                stack.append(node.left)

    def ids(self) -> list[str]:
        """The ids it names, each once, in the order of their first occurrence."""
        return list(dict.fromkeys(v.id for v in self.variables()))

    def holds(self, value: Callable[[str], bool]) -> bool:
        """Its truth under `value` (an id's truth), evaluated bottom-up without recursion."""
        return fold(self.tree, lambda v: value(v.id), lambda x: not x, _EVALUATE)


_EVALUATE: Final[dict[str, Callable[[bool, bool], bool]]] = {
    AND: lambda x, y: x and y,
    OR: lambda x, y: x or y,
    IMPLIES: lambda x, y: (not x) or y,
    IFF: lambda x, y: x == y,
}


T = TypeVar("T")


def fold(
    tree: Node,
    leaf: Callable[[Var], T],
    negate: Callable[[T], T],
    combine: dict[str, Callable[[T, T], T]],
) -> T:
    """A value computed bottom-up over a tree (post-order with an explicit stack)."""
    results: list[T] = []
    stack: list[tuple[Node, bool]] = [(tree, False)]
    while stack:
        node, children_done = stack.pop()
        if isinstance(node, Var):
            results.append(leaf(node))
        elif children_done:
            if isinstance(node, Not):
                results.append(negate(results.pop()))
            else:
                right = results.pop()
                results.append(combine[node.op](results.pop(), right))
        else:
            stack.append((node, True))
            if isinstance(node, Not):
                stack.append((node.operand, False))
            else:
                stack.append((node.right, False))
                stack.append((node.left, False))
    return results[0]


def write(tree: Node) -> str:
    """The text of a tree, every operator under another in parentheses but for a left
    operand of the same `&` or `|` ("a & b & c"), the whole without: "!(a => b) <=> (c | d)".
    Iterative, and linear in the size of the text."""
    pieces: list[str] = []
    work: list[Node | str] = [tree]  # a node to write, or a piece of text to put down as it is
    wrapped: list[bool] = [False]  # (beside work: whether that node is written in parentheses)
    while work:
        item, wrap = work.pop(), wrapped.pop()
        if isinstance(item, str):
            pieces.append(item)
        elif isinstance(item, Var):
            pieces.append(item.id)
        elif isinstance(item, Not):
            pieces.append(NOT)
            work.append(item.operand)
            wrapped.append(True)
        else:
            chained = isinstance(item.left, Binary) and item.left.op == item.op and item.op in (AND, OR)
            if wrap:
                pieces.append("(")
                work.append(")")
                wrapped.append(False)
            work += [item.right, f" {item.op} ", item.left]
            wrapped += [True, False, not chained]
    return "".join(pieces)


def without_outer_parentheses(text: str) -> str:
    """A formula's text without the parentheses around all of it, if a pair encloses all of
    it ("(a | b)" -> "a | b"; "(a) | (b)" stays): how the importers and the UVL writer give a
    formula whose operators they parenthesised one by one."""
    if not text.startswith("("):
        return text
    depth = 0
    for k, ch in enumerate(text):
        depth += (ch == "(") - (ch == ")")
        if depth == 0 and k < len(text) - 1:
            return text
    return text[1:-1]


def at_most_one(items: Sequence[str]) -> list[tuple[list[str], list[str]]]:
    """"At most one of `items`" as pairs (A, B), each meaning "not (some of A and some of
    B)": the items halved, then each half halved again, so every two items are apart in
    exactly one pair. n log n names in all, where the pairs of items are n^2 / 2 (a group of
    6,000 alternatives written pairwise took 3 GB to import). Iterative."""
    found: list[tuple[list[str], list[str]]] = []
    work = [list(items)]
    while work:
        part = work.pop()
        if len(part) < 2:
            continue
        half = len(part) // 2
        found.append((part[:half], part[half:]))
        work += [part[half:], part[:half]]
    return found


def parse(text: str, position: int = 0) -> Formula:
    """The formula of `text` (its `position` in the model's `formulas`); FormulaError if it
    does not parse."""
    operands: list[Node] = []
    # pending operators: (operator, offset), "(" for an open parenthesis
    operators: list[tuple[str, int]] = []
    expect_operand = True
    offset = 0
    end = _TRAILING_SPACE.search(text)
    stop = end.start() if end else len(text)

    def reduce_one() -> None:
        op, _ = operators.pop()
        if op == NOT:
            operands.append(Not(operands.pop()))
        else:
            right = operands.pop()
            operands.append(Binary(op, operands.pop(), right))

    while offset < stop:
        match = _TOKEN.match(text, offset)
        if match is None:
            where = offset + len(text[offset:]) - len(text[offset:].lstrip())
            raise FormulaError(where, f"unexpected character {text[where]!r}")
        name, symbol = match.group(1), match.group(2)
        at = match.start(1) if name else match.start(2)
        offset = match.end()
        if expect_operand:
            if name:
                operands.append(Var(name, at))
                expect_operand = False
            elif symbol in (NOT, "("):
                operators.append((symbol, at))
            else:
                raise FormulaError(at, f"expected a feature id, '!' or '(' before {symbol!r}")
            continue
        if name:
            raise FormulaError(at, f"expected an operator (&, |, =>, <=>) or ')' before {name!r}")
        if symbol in (NOT, "("):
            raise FormulaError(at, f"expected an operator (&, |, =>, <=>) or ')' before {symbol!r}")
        if symbol == ")":
            while operators and operators[-1][0] != "(":
                reduce_one()
            if not operators:
                raise FormulaError(at, "')' without a matching '('")
            operators.pop()
            continue
        precedence, right = _BINARY[symbol]
        while operators and operators[-1][0] != "(":
            top = operators[-1][0]
            if top != NOT and (_BINARY[top][0] < precedence or (_BINARY[top][0] == precedence and right)):
                break
            reduce_one()
        operators.append((symbol, at))
        expect_operand = True
    if expect_operand:
        if not operands and not operators:
            raise FormulaError(stop, "the formula is empty")
        raise FormulaError(stop, "the formula ends where a feature id is expected")
    while operators:
        if operators[-1][0] == "(":
            raise FormulaError(operators[-1][1], "'(' is never closed")
        reduce_one()
    return Formula(text, operands[0], position)


def clauses_of(tree: Node, max_clauses: int, max_literals: int) -> list[list[tuple[str, bool]]] | None:
    """The clauses of a formula, each a list of (feature id, positive), by negation normal
    form and distribution, without new variables, iteratively; None if they would be more
    than `max_clauses` clauses or `max_literals` literals (distribution can grow them
    exponentially: a formula of n two-literal disjunctions is 2^n clauses)."""
    results: list[list[list[tuple[str, bool]]]] = []
    work: list[tuple[Node, bool, bool]] = [(tree, False, False)]  # (node, negated, its parts done)
    while work:
        node, negated, done = work.pop()
        if isinstance(node, Var):
            results.append([[(node.id, not negated)]])
            continue
        if isinstance(node, Not):
            work.append((node.operand, not negated, False))
            continue
        op = node.op
        if op in (IMPLIES, IFF) and not done:
            if op == IMPLIES:  # a => b: !a | b
                work.append((Binary(OR, Not(node.left), node.right), negated, False))
            else:  # a <=> b: (!a | b) & (a | !b)
                both = Binary(AND, Binary(OR, Not(node.left), node.right), Binary(OR, node.left, Not(node.right)))
                work.append((both, negated, False))
            continue
        if not done:
            work.append((node, negated, True))
            work.append((node.right, negated, False))
            work.append((node.left, negated, False))
            continue
        right, left = results.pop(), results.pop()
        if (op == AND) != negated:  # a conjunction: the clauses of both
            clauses = left + right
        else:  # a disjunction: each clause of one with each of the other
            if len(left) * len(right) > max_clauses:
                return None
            if len(left) * sum(map(len, right)) + len(right) * sum(map(len, left)) > max_literals:
                return None
            clauses = [a + b for a in left for b in right]
        if len(clauses) > max_clauses or sum(len(clause) for clause in clauses) > max_literals:
            return None
        results.append(clauses)
    return [list(dict.fromkeys(clause)) for clause in results[0]]

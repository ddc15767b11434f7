"""Cross-tree formulas (reference.md 2.4): syntax, located errors, words, run time.

Their meaning against brute force is in test_property_sat.py (random models with random
formulas, judged by reference_semantics.py's own parser) and test_reconfigure.py (the
active set at run time).
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from helpers import config, feature
from hypothesis import given
from hypothesis import strategies as st

from motivml.binding.check import check_variant
from motivml.binding.resolve import resolve, start_state
from motivml.cli import main
from motivml.documents.loader import parse as parse_json
from motivml.language.formula import Binary, FormulaError, Node, Not, Var, parse, without_outer_parentheses
from motivml.language.formula import write as write_tree
from motivml.language.reader import read_configuration, read_model
from motivml.runtime.reconfigure import Reconfigurer, Refused
from motivml.runtime.requests import Load


def shape(node: Any) -> str:
    """A tree fully parenthesised, to compare precedence and grouping."""
    if isinstance(node, Var):
        return node.id
    if isinstance(node, Not):
        return f"!{shape(node.operand)}"
    assert isinstance(node, Binary)
    return f"({shape(node.left)} {node.op} {shape(node.right)})"


@pytest.mark.parametrize(
    ("text", "tree"),
    [
        ("a", "a"),
        ("slam => lidar | camera", "(slam => (lidar | camera))"),
        ("a & b | c", "((a & b) | c)"),
        ("a | b & c", "(a | (b & c))"),
        ("!a & b", "(!a & b)"),
        ("!(a & b)", "!(a & b)"),
        ("a => b => c", "(a => (b => c))"),  # => groups to the right
        ("a <=> b <=> c", "(a <=> (b <=> c))"),  # so does <=>
        ("a <=> b => c", "(a <=> (b => c))"),  # <=> binds loosest
        ("a => b <=> c | d", "((a => b) <=> (c | d))"),
        ("a & b & c", "((a & b) & c)"),
        ("  ( ( a ) )\t", "a"),
        ("!!a", "!!a"),
        ("a&!b|c", "((a & !b) | c)"),
    ],
)
def test_precedence_and_grouping(text: str, tree: str) -> None:
    assert shape(parse(text).tree) == tree


@pytest.mark.parametrize(
    ("text", "offset", "message"),
    [
        ("", 0, "the formula is empty"),
        ("   ", 0, "the formula is empty"),
        ("a &", 3, "the formula ends where a feature id is expected"),
        ("a & ", 3, "the formula ends where a feature id is expected"),
        ("a b", 2, "expected an operator (&, |, =>, <=>) or ')' before 'b'"),
        ("a !b", 2, "expected an operator (&, |, =>, <=>) or ')' before '!'"),
        ("(a", 0, "'(' is never closed"),
        ("a)", 1, "')' without a matching '('"),
        ("& a", 0, "expected a feature id, '!' or '(' before '&'"),
        ("a # b", 2, "unexpected character '#'"),
        ("a = b", 2, "unexpected character '='"),
        ("a & ()", 5, "expected a feature id, '!' or '(' before ')'"),
        ("1a", 0, "unexpected character '1'"),
    ],
)
def test_errors_say_where(text: str, offset: int, message: str) -> None:
    with pytest.raises(FormulaError) as raised:
        parse(text)
    assert (raised.value.offset, raised.value.message) == (offset, message)


def test_deep_and_long_formulas_parse_without_recursion() -> None:
    deep = parse("(" * 50_000 + "!a" + ")" * 50_000)
    assert deep.ids() == ["a"] and deep.holds(lambda _: False)
    long = parse(" & ".join(f"x{i}" for i in range(50_000)))
    assert len(long.ids()) == 50_000
    assert long.holds(lambda _: True) and not long.holds(lambda name: name != "x49999")


def test_holds_is_the_truth_table() -> None:
    formula = parse("a => b <=> !c | a & b")
    for a, b, c in itertools.product((False, True), repeat=3):
        truth = {"a": a, "b": b, "c": c}
        expected = ((not a) or b) == ((not c) or (a and b))
        assert formula.holds(truth.__getitem__) == expected


# ------------------------------------------------------------------------ in a model
MODEL = feature(
    "bot",
    [
        feature("slam", isMandatory=False, time="Any", mode="Any"),
        feature("lidar", isMandatory=False, time="Any", mode="Any"),
        feature("camera", isMandatory=False, time="Any", mode="Any"),
    ],
    formulas=["slam => lidar | camera", "!(lidar & camera)"],
)


def write(tmp_path: Path, model: dict[str, Any], **variants: dict[str, Any]) -> Path:
    (tmp_path / "variants").mkdir(exist_ok=True)
    (tmp_path / "model.json").write_text(json.dumps(model, indent=2))
    for name, document in variants.items():
        (tmp_path / "variants" / f"{name}.json").write_text(json.dumps(document, indent=2))
    return tmp_path / "model.json"


def test_errors_are_located_at_the_character(tmp_path: Path) -> None:
    path = tmp_path / "model.json"
    # written by hand, so that columns are known: the first formula holds an escape (\n,
    # two characters of the text, one of the value) before the unknown id
    path.write_text(
        '{"id": "bot", "name": "Bot", "sub": ' + json.dumps(MODEL["sub"]) + ",\n"
        ' "formulas": ["slam =>\\n lidar | camara",\n  "lidar & (camera"]}'
    )
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 1
    # `"slam =>\n lidar | camara"` opens in column 15: camara is character 17 of the value,
    # 18 of the text, so column 15 + 1 + 18
    assert result.output.startswith(
        f"{path}:2:34: $.formulas[0]: error: formula 1, `slam =>\n lidar | camara`, names unknown "
        "feature 'camara' (did you mean 'camera'?) (rule 2.4)\n"
    )
    # `"lidar & (camera"` opens in column 3; its '(' is character 8
    assert (
        f"{path}:3:12: $.formulas[1]: error: formula 2, `lidar & (camera`, does not parse: "
        "'(' is never closed (rule 2.4)\n" in result.output
    )


def test_formulas_only_on_the_root(tmp_path: Path) -> None:
    model = feature("bot", [feature("slam", isMandatory=False, formulas=["slam"])])
    result = CliRunner().invoke(main, ["validate", str(write(tmp_path, model))])
    assert result.exit_code == 1
    assert "$.sub[0]" in result.output and "formulas" in result.output


def read(model: dict[str, Any], document: dict[str, Any]) -> Any:
    feature_model, problems = read_model(parse_json(json.dumps(model, indent=1), "model.json"))
    assert not problems
    configuration, problems = read_configuration(
        parse_json(json.dumps(document, indent=1), "v.json"), feature_model
    )
    assert not problems
    return feature_model, configuration


def test_a_broken_formula_is_explained_in_the_users_words() -> None:
    model, configuration = read(MODEL, config(("slam",), ("lidar", False), ("camera", False)))
    (error,) = check_variant(model, configuration)
    assert error.rule == "2.4"
    assert error.message == (
        "formula 1, `slam => lidar | camera`, must hold, but slam is selected, lidar is not selected "
        "and camera is not selected: every formula of the model holds over the selection (rule 2.4)"
    )
    where = {fact.text: (fact.location.file, fact.location.path) for fact in error.facts}
    assert where["formula 1, `slam => lidar | camera`, must hold"] == ("model.json", "$.formulas[0]")
    assert where["lidar is not selected"] == ("v.json", "$.properties[1].selected")


def test_a_formula_is_not_an_exclusion_even_for_dynamic_features() -> None:
    """2.4: `!(a & b)` forbids both even as Dynamic alternatives; `featuresExcluded` allows it."""
    both = config(("slam", False), ("lidar", "Late", "Dynamic"), ("camera", "Late", "Dynamic"))
    model, configuration = read(MODEL, both)
    (error,) = check_variant(model, configuration)
    assert error.message.startswith("formula 2, `!(lidar & camera)`, must hold, but lidar is selected")
    excluded = feature(
        "bot",
        [
            feature("slam", isMandatory=False, time="Any", mode="Any"),
            feature("lidar", isMandatory=False, time="Any", mode="Any", exc=["camera"]),
            feature("camera", isMandatory=False, time="Any", mode="Any"),
        ],
    )
    assert check_variant(*read(excluded, both)) == []


def test_the_run_time_holds_formulas_over_the_active_set() -> None:
    """Both selected as Dynamic Late features, `lidar <=> camera` makes them come and go together."""
    model_document = {**MODEL, "formulas": ["lidar <=> camera"]}
    model, configuration = read(
        model_document, config(("slam", False), ("lidar", "Late", "Dynamic"), ("camera", "Late", "Dynamic"))
    )
    variant = resolve(model, configuration)
    active = {f.id for f in start_state(variant)}
    assert active == {"bot"}
    with Reconfigurer(variant, configuration) as reconfigurer:
        with pytest.raises(Refused) as refused:
            reconfigurer.plan(active, Load(("lidar",)))
        (diagnostic,) = refused.value.diagnostics
        assert diagnostic.rule == "2.4"
        assert diagnostic.message == (
            "formula 1, `lidar <=> camera`, must hold, but lidar would be active and camera would be "
            "inactive: at every moment the active set satisfies every formula of the model (rule 2.4, "
            "section 4)"
        )
        plan = reconfigurer.plan(active, Load(("lidar", "camera")))
        assert set(plan.after) == {"bot", "lidar", "camera"}


def test_no_start_state_because_of_a_formula() -> None:
    """x and y are XOR alternatives, so exactly one is active; x is Early, so it is active at
    start, and `x => y` would need y active too: the selection satisfies the formula, the
    start state cannot."""
    dynamic = {"time": "Any", "mode": "Dynamic"}
    model_document = feature(
        "bot",
        [
            feature(
                "m", [feature("x", group="XOR", **dynamic), feature("y", group="XOR", **dynamic)], mode="Any"
            )
        ],
        formulas=["x => y"],
    )
    model, configuration = read(
        model_document, config(("m", "Early", "Static"), ("x", "Early", "Dynamic"), ("y", "Late", "Dynamic"))
    )
    (error,) = check_variant(model, configuration)
    assert error.rule == "2.4"
    assert error.message == (
        "x and y are alternatives in m's XOR group; formula 1, `x => y`, must hold, but x is configured "
        "Early: no start state exists: at start every selected Early feature is active, and the active "
        "set satisfies section 2 and every formula of the model (rule 2.4, section 4)"
    )


@pytest.mark.parametrize("n", range(10))
def test_at_most_one_sets_every_two_items_apart_exactly_once(n: int) -> None:
    from motivml.language.formula import at_most_one

    items = [f"x{k}" for k in range(n)]
    apart = [(a, b) for left, right in at_most_one(items) for a in left for b in right]
    assert sorted(apart) == sorted((a, b) for k, a in enumerate(items) for b in items[k + 1 :])


def test_only_parentheses_around_all_of_a_formula_are_taken_off() -> None:
    """The importers and the UVL writer parenthesise every operator, then take off the pair
    around the whole formula, and only that pair."""
    cases = {
        "(a | b)": "a | b",
        "((a & b) | c)": "(a & b) | c",
        "(a) | (b)": "(a) | (b)",
        "!(a & b)": "!(a & b)",
        "a": "a",
        "((a))": "(a)",
    }
    for text, shown in cases.items():
        assert without_outer_parentheses(text) == shown
        assert parse(shown).holds(lambda _: True) == parse(text).holds(lambda _: True)


TREES = st.recursive(
    st.sampled_from(["a", "b", "c", "d"]).map(lambda name: Var(name, 0)),
    lambda inner: st.one_of(
        inner.map(Not),
        st.builds(Binary, st.sampled_from(["&", "|", "=>", "<=>"]), inner, inner),
    ),
    max_leaves=12,
)


@given(TREES)
def test_a_written_tree_reads_back_as_the_same_tree(tree: Node) -> None:
    """`write` (the importers' one writer) puts in every pair of parentheses the reading
    needs, and no more than it takes off for a left chain of one `&` or `|`."""
    text = write_tree(tree)
    assert shape(parse(text).tree) == shape(tree)
    assert not text.startswith("(") or without_outer_parentheses(text) == text  # no pair around all of it


@pytest.mark.parametrize(
    ("text", "written"),
    [
        ("a & b & c", "a & b & c"),
        ("a | (b | c)", "a | (b | c)"),
        ("!(a => b) <=> c | d & a", "!(a => b) <=> (c | (d & a))"),
        ("a => b => c", "a => (b => c)"),
        ("(a => b) => c", "(a => b) => c"),
        ("!!a", "!!a"),
    ],
)
def test_write_parenthesises_every_operator_under_another(text: str, written: str) -> None:
    assert write_tree(parse(text).tree) == written


def test_deep_and_long_trees_are_written_without_recursion() -> None:
    deep = parse("!" * 50_000 + "a").tree
    assert write_tree(deep) == "!" * 50_000 + "a"
    chain = parse(" => ".join(f"x{i}" for i in range(20_000))).tree  # (grouped to the right)
    text = write_tree(chain)
    assert text.startswith("x0 => (x1 => (x2 => ") and text.endswith("(x19998 => x19999" + ")" * 19_998)
    assert len(text) == sum(len(f"x{i}") for i in range(20_000)) + 4 * 19_999 + 2 * 19_998

"""S.P.L.O.T.'s SXFM (reference.md section 8): import against brute force, public files,
round trips, located refusals, the commands.

The brute force below reads nothing of motivml: it counts the selections of the structure
a test made, by SXFM's own rules (a child needs its parent; a mandatory child comes with
it; a group of [low,high] holds that many of its members when its feature is selected;
every clause holds), and motivml must count the same from the text it was written as.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from paths import ROOT

from motivml.binding.analysis import count_selections
from motivml.cli import main
from motivml.documents.loader import load_bytes
from motivml.errors import Diagnostic, DocumentError
from motivml.language.model import FeatureModel
from motivml.language.reader import read_model
from motivml.language.sxfm import read_sxfm, write_sxfm

DATA = ROOT / "tests" / "data" / "sxfm"


def model_of(document: dict[str, Any]) -> FeatureModel:
    model, problems = read_model(load_bytes(json.dumps(document).encode(), "model.json"))
    assert model is not None and not [d for d in problems if d.severity.value == "error"], problems
    return model


def count(text: str) -> int | None:
    return count_selections(model_of(read_sxfm(text.encode(), "m.xml")), 60)


# ------------------------------------------------------------------ against brute force
@st.composite
def structures(draw: st.DrawFn) -> tuple[str, list[tuple[str, str | None, str]], list[Any], list[list[str]]]:
    """A small SXFM model: its text, its features (id, parent, how attached), its groups
    (feature, low, high or None, members) and its clauses (literals id or ~id)."""
    features: list[tuple[str, str | None, str]] = [("f0", None, "root")]
    groups: list[tuple[str, int, int | None, list[str]]] = []

    def grow(parent: str, depth: int) -> list[str]:
        lines: list[str] = []
        for _ in range(draw(st.integers(0, 3 if depth < 3 else 0))):
            if len(features) >= 9:
                break
            if draw(st.booleans()):
                kind = draw(st.sampled_from(["m", "o"]))
                fid = f"f{len(features)}"
                features.append((fid, parent, kind))
                lines.append("\t" * (depth + 1) + f":{kind} Feature {fid}({fid})")
                lines += grow(fid, depth + 1)
            else:
                size = draw(st.integers(1, 3))
                low, high = draw(st.sampled_from([(1, 1), (1, None), (0, 1), (0, None), (1, size), (0, size)]))
                lines.append("\t" * (depth + 1) + f":g [{low},{'*' if high is None else high}]")
                members = []
                for _ in range(size):
                    fid = f"f{len(features)}"
                    features.append((fid, parent, "member"))
                    members.append(fid)
                    lines.append("\t" * (depth + 2) + f": Member {fid}({fid})")
                    lines += grow(fid, depth + 2)
                groups.append((parent, low, high, members))
        return lines

    lines = [":r Root(f0)", *grow("f0", 0)]
    ids = [f for f, _, _ in features]
    clauses = draw(
        st.lists(st.lists(st.tuples(st.sampled_from(ids), st.booleans()), min_size=1, max_size=3), max_size=3)
    )
    written = [[("~" if negated else "") + fid for fid, negated in clause] for clause in clauses]
    text = "<feature_model name='m'>\n<feature_tree>\n" + "\n".join(lines) + "\n</feature_tree>\n<constraints>\n"
    text += "".join(f"c{k}: {' or '.join(c)}\n" for k, c in enumerate(written)) + "</constraints>\n</feature_model>\n"
    return text, features, groups, written


def brute_force(features: list[tuple[str, str | None, str]], groups: list[Any], clauses: list[list[str]]) -> int:
    ids = [f for f, _, _ in features]
    found = 0
    for values in itertools.product((False, True), repeat=len(ids)):
        on = dict(zip(ids, values, strict=True))
        if not on["f0"]:
            continue
        if any(parent is not None and on[f] and not on[parent] for f, parent, _ in features):
            continue
        if any(kind == "m" and on[parent] and not on[f] for f, parent, kind in features if parent is not None):
            continue
        if any(
            on[parent] and not (low <= sum(on[m] for m in members) <= (len(members) if high is None else high))
            for parent, low, high, members in groups
        ):
            continue
        if any(not any(on[lit.removeprefix("~")] != lit.startswith("~") for lit in clause) for clause in clauses):
            continue
        found += 1
    return found


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(structures())
def test_sxfm_counts_equal_brute_force_and_survive_a_round_trip(made: tuple[str, Any, Any, Any]) -> None:
    text, features, groups, clauses = made
    expected = brute_force(features, groups, clauses)
    model = model_of(read_sxfm(text.encode(), "m.xml"))
    assert count_selections(model, 60) == expected
    assert count(write_sxfm(model)) == expected


# ------------------------------------------------------------------ public files
COUNTS = {  # as motivml counts them, and as the benchmark's DIMACS of the same model counts
    "routefinding.xml": 1_777_705_574_400,
    "xtext.xml": 130_793_182_007_669_276_479_488,
    "berkeleydb.xml": 32,
}


@pytest.mark.parametrize("name", sorted(p.name for p in DATA.glob("*.xml")))
def test_public_sxfm_files_import_and_round_trip_keeping_their_count(name: str) -> None:
    warnings: list[Diagnostic] = []
    model = model_of(read_sxfm((DATA / name).read_bytes(), name, warnings))
    counted = count_selections(model, 60)
    assert counted is not None and counted > 0
    if name in COUNTS:
        assert counted == COUNTS[name]
    assert count(write_sxfm(model)) == counted
    if name == "berkeleydb.xml":  # members written `:m` under a group: read, and said once
        (said,) = warnings
        assert said.message.startswith("`:m` and `:o` lines under a group `:g` are read as the group's members (")
        assert said.location.line == 34
    elif name == "e_shop.xml":  # lines without ids: said once, with how many
        (said,) = warnings
        assert said.message.startswith("lines without an id `(id)` get one made from their name (a name used twice: ")
        assert "(225 places, the first here)" in said.message and said.location.line == 7
    else:
        assert warnings == []


def test_a_one_member_group_of_one_needed_is_mandatory() -> None:
    """printer.xml: `:g [1,1]` with the one member Duplex. S.P.L.O.T.'s cardinality needs
    it whenever its parent is selected (the benchmark's DIMACS, made by FeatureIDE, makes it
    optional and counts twice as many)."""
    model = model_of(read_sxfm((DATA / "printer.xml").read_bytes(), "printer.xml"))
    duplex = model["_r_1_26_28_29"]
    assert (duplex.name, duplex.mandatory, model.features[duplex.parent].name) == ("Duplex", True, "Printed Sides")


def test_lines_without_ids_get_ids_and_clauses_may_name_them() -> None:
    """e_shop.xml: most lines have no id, two features are named CyberSource, clauses name
    features by the ids in parentheses where there are some."""
    document = read_sxfm((DATA / "e_shop.xml").read_bytes(), "e_shop.xml")
    model = model_of(document)
    cyber = [f.id for f in model.features if f.name == "CyberSource"]
    assert cyber == ["CyberSource", "CyberSource_2"]
    assert model["special_offers"].name == "Special offers" and "~special_offers or discounts" not in document
    assert model.formulas[0].text == "!special_offers | discounts"


def test_meta_data_and_the_model_name_are_kept_and_written_back() -> None:
    document = read_sxfm((DATA / "routefinding.xml").read_bytes(), "routefinding.xml")
    assert document["x-sxfm"]["name"] == "RouteConcatenateFeatureModel"
    assert document["x-sxfm"]["meta"]["organization"] == "MEKELLE UNIVERSITY"
    written = write_sxfm(model_of(document))
    assert '<feature_model name="RouteConcatenateFeatureModel">' in written
    assert '<data name="organization">MEKELLE UNIVERSITY</data>' in written
    assert read_sxfm(written.encode(), "back.xml")["x-sxfm"] == document["x-sxfm"]


# ------------------------------------------------------------------ refusals
TREE = "<feature_model name='m'><feature_tree>\n{}\n</feature_tree><constraints>\n{}\n</constraints></feature_model>"


@pytest.mark.parametrize(
    ("tree", "constraints", "where", "message"),
    [
        (":r R(r)\n\t:g [2,3]\n\t\t: A(a)\n\t\t: B(b)\n\t\t: C(c)", "", (3, 2), "the group cardinality [2,3] over 3 members cannot be kept"),
        (":r R(r)\n\t:g [1,2]\n\t\t: A(a)\n\t\t: B(b)\n\t\t: C(c)", "", (3, 2), "the group cardinality [1,2] over 3 members"),
        (":r R(r)\n\t:g [0,2]\n\t\t: A(a)\n\t\t: B(b)\n\t\t: C(c)", "", (3, 2), "the group cardinality [0,2] over 3 members"),
        (":r R(r)\n\t: Pay\n\t: Pay", "c1: ~Pay", (6, 1), "the constraint names 'Pay', the name of two features without ids"),
        (":r R(r)\n:r S(s)", "", (3, 1), "a second root"),
        (":m R(r)", "", (2, 1), "the feature tree begins with its root"),
        (":r R(r)\n\t:o A(a)\n\t:o B(a)", "", (4, 2), "a second feature with the id 'a'"),
        (":r R(r)\n\t:g [one,1]\n\t\t: A(a)", "", (3, 2), "a group's cardinality is written [low,high]"),
        (":r R(r)\n\tA(a)", "", (3, 2), "not a line of an SXFM feature tree"),
        (":r R(r)\n\t:o A(a)", "c1: ~a or z", (5, 1), "the constraint names 'z', which is not a feature of the model"),
        (":r R(r)\n\t:o A(a)", "c1 ~a or r", (5, 1), "a constraint is written `label: a or ~b`"),
    ],
    ids=["cardinality", "cardinality of some", "cardinality of at most some", "a name twice", "two roots", "no root", "id twice", "bad cardinality", "bad line", "unknown id", "bad clause"],
)
def test_refusals_are_located(tree: str, constraints: str, where: tuple[int, int], message: str) -> None:
    with pytest.raises(DocumentError) as refused:
        read_sxfm(TREE.format(tree, constraints).encode(), "m.xml")
    (diagnostic,) = refused.value.diagnostics
    assert (diagnostic.location.line, diagnostic.location.column) == where, diagnostic.message
    assert message in diagnostic.message and diagnostic.message.endswith("(section 8)")


def test_a_formula_too_large_for_clauses_is_refused_at_the_formula() -> None:
    ids = [f"x{k}" for k in range(28)]
    pairs = " | ".join(f"({a} & {b})" for a, b in zip(ids[::2], ids[1::2], strict=True))  # 2^14 clauses
    document = {"id": "r", "name": "R", "sub": [{"id": i, "name": i, "isMandatory": False} for i in ids], "formulas": [pairs]}
    with pytest.raises(DocumentError) as refused:
        write_sxfm(model_of(document))
    (diagnostic,) = refused.value.diagnostics
    assert "is more than 10,000 clauses (or 200,000 literals) in conjunctive normal form" in diagnostic.message


def test_every_operator_is_written_as_clauses_of_the_same_meaning() -> None:
    document = {
        "id": "r",
        "name": "R",
        "sub": [{"id": i, "name": i, "isMandatory": False} for i in "abcd"],
        "formulas": ["a <=> (b | !c)", "!(a & d) => c", "!(b <=> d)"],
    }
    model = model_of(document)
    assert count(write_sxfm(model)) == count_selections(model, 60)


# ------------------------------------------------------------------ the commands
def test_import_tells_the_format_says_it_and_writes_to_build_by_default(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    source = str(DATA / "berkeleydb.xml")
    result = CliRunner().invoke(main, ["import", source])
    assert result.exit_code == 0, result.output
    assert f"reading {source} as S.P.L.O.T.'s SXFM (its root element is <feature_model>)" in result.output
    assert "warning: `:m` and `:o` lines under a group `:g` are read as the group's members (4 places" in result.output
    assert "wrote build/berkeleydb/model.json (117 features)" in result.output
    assert (tmp_path / "build" / "berkeleydb" / "variants").is_dir()
    again = CliRunner().invoke(main, ["import", "sxfm", source])  # (the same folder: refused, nothing written)
    assert again.exit_code == 3 and "exists already" in again.output


@pytest.mark.parametrize(
    ("words", "said"),
    [
        (["featureide", "xtext.xml"], "this is S.P.L.O.T.'s SXFM, not FeatureIDE XML (its root element is <feature_model>): motivml import sxfm"),
        (["uvl", "xtext.xml"], "this is S.P.L.O.T.'s SXFM, not UVL"),
        (["README.md"], "cannot tell which model format this is: it is neither XML nor UVL"),
    ],
)
def test_a_refusal_names_the_format_it_saw_and_the_command_that_reads_it(
    words: list[str], said: str, tmp_path: Path
) -> None:
    words = [*words[:-1], str(DATA / words[-1])]
    result = CliRunner().invoke(main, ["import", *words, "-o", str(tmp_path / "m")])
    assert result.exit_code == 1 and said in " ".join(result.output.split()), result.output
    assert not (tmp_path / "m").exists()


def test_import_refuses_dimacs_and_an_unknown_format_word(tmp_path: Path) -> None:
    cnf = tmp_path / "m.dimacs"
    cnf.write_text("c 1 a\np cnf 1 1\n1 0\n")
    result = CliRunner().invoke(main, ["import", str(cnf), "-o", str(tmp_path / "m")])
    assert result.exit_code == 1 and "it is DIMACS CNF (`p cnf`): a formula without a feature tree" in result.output
    usage = CliRunner().invoke(main, ["import", "kconfig", str(cnf)])
    assert usage.exit_code == 2 and "import takes [uvl|featureide|sxfm] SOURCE" in usage.output


def test_export_sxfm_says_what_it_cannot_write_and_reads_back(tmp_path: Path) -> None:
    out = tmp_path / "simplebot.xml"
    result = CliRunner().invoke(main, ["export", "sxfm", str(ROOT / "feature_models" / "simplebot"), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "not written: the allowed binding times and modes of 18 features" in " ".join(result.output.split())
    back = CliRunner().invoke(main, ["import", str(out), "-o", str(tmp_path / "back")])
    assert back.exit_code == 0, back.output
    original = model_of(json.loads((ROOT / "feature_models" / "simplebot" / "model.json").read_text()))
    again = model_of(json.loads((tmp_path / "back" / "model.json").read_text()))
    assert count_selections(again, 60) == count_selections(original, 60)
    assert [f.id for f in again.features] == [f.id for f in original.features]


def test_names_with_xml_characters_are_written_escaped() -> None:
    document = {"id": "r", "name": "R & <co>", "sub": [{"id": "a", "name": "Pick & Place (fast)", "isMandatory": False}]}
    back = read_sxfm(write_sxfm(model_of(document)).encode(), "back.xml")
    assert (back["name"], back["sub"][0]["name"]) == ("R & <co>", "Pick & Place [fast]")  # (a line's id is in parentheses)


def test_the_format_is_told_past_a_doctype_and_every_constraints_element_is_read() -> None:
    from motivml.language.importer import guess

    assert guess(b'<?xml version="1.0"?>\n<!DOCTYPE m [<!ENTITY a "b">]>\n<feature_model name="m">')[0] == "sxfm"
    text = TREE.format(":r R(r)\n\t:o A(a)\n\t:o B(b)", "c1: ~a or b") + ""
    text = text.replace("</feature_model>", "<constraints>\nc2: ~b or a\n</constraints></feature_model>")
    assert read_sxfm(text.encode(), "m.xml")["formulas"] == ["!a | b", "!b | a"]


def test_indentation_that_mixes_tabs_and_spaces_is_said() -> None:
    warnings: list[Diagnostic] = []
    text = TREE.format(":r R(r)\n\t:o A(a)\n    :o B(b)", "")
    document = read_sxfm(text.encode(), "m.xml", warnings)
    assert [c["id"] for c in document["sub"]] == ["a", "b"]  # (a tab is 4 spaces: siblings)
    (said,) = warnings
    assert (said.location.line, said.message) == (4, "the indentation mixes tabs and spaces: a tab counts as 4 spaces")

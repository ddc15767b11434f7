"""UVL import and export (reference.md section 8): round trips, counts, refusals, the CLI.

Random UVL models are built here as plain data, written as UVL text and counted by brute
force from that data alone (no code of the product's); the product imports the text, and
its selections are counted by the reference semantics and by the product's counter.
"""

from __future__ import annotations

import itertools
import json
import re
from pathlib import Path
from typing import Any

import pytest
import reference_semantics as ref
from click.testing import CliRunner
from helpers import model_of as read
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from paths import ROOT
from test_property_sat import models

from motivml.binding.analysis import count_selections
from motivml.cli import main
from motivml.errors import Diagnostic, DocumentError
from motivml.language.uvl import read_uvl, write_uvl


# ------------------------------------------------------------- UVL -> motivml -> UVL
# A random UVL model as data: (name, [(group kind, [child, ...]), ...]); constraints over names.
@st.composite
def uvl_models(draw: st.DrawFn, max_features: int = 15) -> tuple[Any, list[tuple[str, str, str, bool]]]:
    n = draw(st.integers(2, max_features))
    names = [
        "Root",
        *(draw(st.sampled_from(["f", "Feature ", "x-", "9lives", "or_"])) + str(i) for i in range(1, n)),
    ]
    nodes: list[tuple[str, list[tuple[str, list[Any]]]]] = [(names[0], [])]
    for i in range(1, n):
        parent = nodes[draw(st.integers(0, i - 1))]
        kind = draw(st.sampled_from(["mandatory", "optional", "optional", "or", "alternative"]))
        node: tuple[str, list[tuple[str, list[Any]]]] = (names[i], [])
        # a new group of that kind, or the last one of that kind (so parents get two or groups)
        same = [g for g in parent[1] if g[0] == kind]
        if same and draw(st.booleans()):
            same[-1][1].append(node)
        else:
            parent[1].append((kind, [node]))
        nodes.append(node)
    constraints = [
        (
            draw(st.sampled_from(names)),
            draw(st.sampled_from(["=>", "|", "&", "<=>"])),
            draw(st.sampled_from(names)),
            draw(st.booleans()),
        )
        for _ in range(draw(st.integers(0, 2)))
    ]
    return nodes[0], constraints


def uvl_text(root: Any, constraints: list[tuple[str, str, str, bool]]) -> str:
    lines = ["features"]
    stack: list[tuple[Any, int]] = [(root, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, str):
            lines.append("    " * depth + item)
            continue
        name, groups = item
        lines.append("    " * depth + (name if name.isidentifier() and name != "or_" else f'"{name}"'))
        pending: list[tuple[Any, int]] = []
        for kind, children in groups:
            pending.append((kind, depth + 1))
            pending += [(child, depth + 2) for child in children]
        stack.extend(reversed(pending))
    if constraints:
        lines.append("constraints")
        for a, op, b, negate in constraints:
            q = lambda x: x if x.isidentifier() and x != "or_" else f'"{x}"'  # noqa: E731
            lines.append(f"    {'!' if negate else ''}({q(a)} {op} {q(b)})")
    return "\n".join(lines) + "\n"


def uvl_count(root: Any, constraints: list[tuple[str, str, str, bool]]) -> int:
    """UVL's Boolean semantics by enumeration: root selected, children need parents,
    mandatory children, or groups at least one, alternative groups exactly one, constraints."""
    parent: dict[str, str] = {}
    rules: list[tuple[str, str, list[str]]] = []  # (parent, kind, members)
    stack = [root]
    names = []
    while stack:
        name, groups = stack.pop()
        names.append(name)
        for kind, children in groups:
            rules.append((name, kind, [c[0] for c in children]))
            for child in children:
                parent[child[0]] = name
                stack.append(child)
    total = 0
    for bits in itertools.product((False, True), repeat=len(names) - 1):
        on = {root[0]} | {n for n, b in zip(names[1:], bits, strict=True) if b}
        if any(n in on and parent[n] not in on for n in names[1:]):
            continue
        ok = True
        for p, kind, members in rules:
            picked = sum(m in on for m in members)
            if p in on and (
                (kind == "mandatory" and picked < len(members))
                or (kind == "or" and picked == 0)
                or (kind == "alternative" and picked != 1)
            ):
                ok = False
        for a, op, b, negate in constraints:
            x, y = a in on, b in on
            value = {"=>": (not x) or y, "|": x or y, "&": x and y, "<=>": x == y}[op]
            ok &= value != negate
        total += ok
    return total


@pytest.mark.slow
@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(uvl_models())
def test_uvl_to_motivml_to_uvl_keeps_the_selection_count(data: tuple[Any, Any]) -> None:
    root, constraints = data
    expected = uvl_count(root, constraints)
    document = read_uvl(uvl_text(root, constraints), "m.uvl")
    assert sum(1 for _ in ref.section_2_selections(document)) == expected  # the reference
    model = read(document)
    assert count_selections(model) == expected  # the product's counter
    again = read_uvl(write_uvl(model), "again.uvl")
    assert sum(1 for _ in ref.section_2_selections(again)) == expected
    assert read_uvl(write_uvl(read(again)), "third.uvl") == again  # a fixed point from there on


# ------------------------------------------------------------- motivml -> UVL -> motivml
def normal(model: Any) -> list[tuple[Any, ...]]:
    return [
        (
            f.id,
            f.name,
            f.parent,
            f.group,
            f.mandatory,
            f.time_allowed,
            f.mode_allowed,
            tuple(dict.fromkeys(f.includes)),
            tuple(dict.fromkeys(f.excludes)),
            f.abstract,
        )
        for f in model.features
    ]


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=8), st.booleans())
def test_motivml_to_uvl_reads_back_to_the_same_model(raw: dict[str, Any], abstract: bool) -> None:
    if abstract and raw.get("sub"):
        raw["sub"][0]["abstract"] = True
    model = read(raw)
    back = read_uvl(write_uvl(model), "m.uvl")
    assert normal(read(back)) == normal(model)
    assert sorted(map(sorted, ref.valid_variants(back, None))) == sorted(
        map(sorted, ref.valid_variants(raw, None))
    )
    assert sorted(map(str, ref.valid_variants(back, None))) == sorted(map(str, ref.valid_variants(raw, None)))


@pytest.mark.parametrize(
    "robot", sorted(p.parent.name for p in (ROOT / "feature_models").glob("*/model.json"))
)
def test_shipped_models_read_back_the_same(robot: str) -> None:
    path = ROOT / "feature_models" / robot / "model.json"
    model = read(json.loads(path.read_text()))
    back = read_uvl(write_uvl(model), f"{robot}.uvl")
    assert normal(read(back)) == normal(model)
    assert count_selections(read(back)) == count_selections(model)


# ------------------------------------------------------------------------- refusals
@pytest.mark.parametrize(
    ("text", "where", "message"),
    [
        (
            "features\n    R\n        [1..2]\n            A\n            B\n",
            (3, 9),
            "group cardinalities cannot be kept",
        ),
        (
            "features\n    R\n        optional\n            A cardinality [1..3]\n",
            (4, 15),
            "the feature cardinality of A cannot be kept",
        ),
        (
            "features\n    R\n        optional\n            Integer A\n",
            (4, 13),
            "a feature of type Integer cannot be kept",
        ),
        (
            "features\n    R\n        optional\n            A\nconstraints\n    A > 3\n",
            (6, 5),
            "arithmetic and type-level constraints cannot be kept",
        ),
        ("imports\n    other as o\nfeatures\n    R\n", (1, 1), "imports of other UVL models cannot be kept"),
        (
            "include\n    Arithmetic.*\nfeatures\n    R\n",
            (2, 5),
            "the language level Arithmetic.* cannot be kept",
        ),
        (
            "features\n    R\n        optional\n            A\nconstraints\n    A => B\n",
            (6, 10),
            "the constraint names 'B', which is not a feature of the model",
        ),
        (
            "features\n    R\n        optional\n            A\n            B\n            C\nconstraints\n    A => B => C\n",
            (8, 5),
            "a chain of => or <=> without parentheses",
        ),
        (
            "features\n    R {bindingTime 'early'}\n",
            (2, 8),
            "bindingTime is one of Early, Late, Any, not 'early'",
        ),
        ("features\n    R\n        optional\n            A\n            A\n", (5, 13), "a second feature named 'A'"),
        ('features\n    R\n        optional\n            ""\n', (4, 13), 'a feature named "": every feature needs a name'),
        (
            "features\n    R\n        optional\n            A {excludes ['B', 'Z']}\n            B\n",
            (4, 16),
            "A excludes 'Z', which is not a feature of the model",
        ),
    ],
    ids=[
        "group cardinality",
        "feature cardinality",
        "type",
        "arithmetic",
        "imports",
        "language level",
        "unknown name",
        "chain",
        "binding token",
        "name twice",
        "empty name",
        "unknown relation",  # (at the attribute that names it)
    ],
)
def test_refusals_are_located(text: str, where: tuple[int, int], message: str) -> None:
    with pytest.raises(DocumentError) as refused:
        read_uvl(text, "m.uvl")
    (diagnostic,) = refused.value.diagnostics
    assert (diagnostic.location.line, diagnostic.location.column) == where
    assert message in diagnostic.message and diagnostic.message.endswith("(section 8)")


def test_not_uvl_is_located() -> None:
    with pytest.raises(DocumentError) as refused:
        read_uvl("features\n    R\n        optional\n            A &\n", "m.uvl")
    (diagnostic,) = refused.value.diagnostics
    assert (diagnostic.location.line, diagnostic.location.column) == (4, 15)
    assert diagnostic.message == "not UVL: unexpected '&'"


def test_names_become_ids_deterministically() -> None:
    """Kept when an id; else other characters become _, a leading digit gets one before it,
    and a clash (of case too: C++ macros) gets _2, _3 ...; a name given twice is refused."""
    text = 'features\n    "My Robot"\n        optional\n            "2D lidar"\n            lidar\n            Lidar\n            "lidar 2"\n'
    document = read_uvl(text, "m.uvl")
    ids = [document["id"], *(child["id"] for child in document["sub"])]
    names = [document["name"], *(child["name"] for child in document["sub"])]
    assert ids == ["My_Robot", "_2D_lidar", "lidar", "Lidar_2", "lidar_2_2"]
    assert names == ["My Robot", "2D lidar", "lidar", "Lidar", "lidar 2"]
    with pytest.raises(DocumentError, match="a second feature named 'lidar'"):
        read_uvl(text.replace('"lidar 2"', '"lidar"'), "m.uvl")


def test_a_second_group_of_a_kind_becomes_formulas() -> None:
    text = "features\n    R\n        alternative\n            A\n            B\n        alternative\n            C\n            D\n"
    document = read_uvl(text, "m.uvl")
    assert [c.get("group", "") for c in document["sub"]] == ["XOR", "XOR", "", ""]
    assert document["formulas"] == ["R => C | D", "!(C & D)"]
    assert sum(1 for _ in ref.section_2_selections(document)) == 4


def test_a_second_alternative_group_is_at_most_one_in_n_log_n_names() -> None:
    """Issue 31: a second alternative group of 6,000 members was written pairwise (18
    million formulas, 3 GB). Halved and halved again, every two members are apart once:
    the selections are the same (brute force), the names n log n."""
    members = [f"M{k}" for k in range(7)]
    text = "features\n    R\n        alternative\n            A\n            B\n        alternative\n"
    document = read_uvl(text + "".join(f"            {m}\n" for m in members), "m.uvl")
    assert document["formulas"][0] == "R => " + " | ".join(members)
    assert sum(1 for _ in ref.section_2_selections(document)) == 2 * 7
    wide = read_uvl(text + "".join(f"            M{k}\n" for k in range(6000)), "m.uvl")
    named = sum(len(re.findall(r"M\d+", formula)) for formula in wide["formulas"][1:])
    assert named <= 6000 * 13  # (6,000 log2 6,000: 75,000; pairwise, 36 million)


def test_attributes_kept_and_a_name_uvl_cannot_hold() -> None:
    text = "features\n    R {color 'red', weight 3, tags ['a', 'b'], x {y true}}\n"
    assert read_uvl(text, "m.uvl")["x-uvl"] == {
        "color": "red",
        "weight": 3,
        "tags": ["a", "b"],
        "x": {"y": True},
    }
    model = read({"id": "r", "name": "Rob's bot"})
    with pytest.raises(DocumentError, match="cannot be written in UVL"):
        write_uvl(model)


# ------------------------------------------------------------------------------ CLI
def test_import_and_export_commands(tmp_path: Path) -> None:
    source = tmp_path / "sandwich.uvl"
    source.write_text(
        "features\n    Sandwich {abstract}\n        mandatory\n            Bread\n        optional\n"
        "            Cheese\n            Sauce\n                alternative\n                    Ketchup\n"
        "                    Mustard\nconstraints\n    Ketchup => Cheese\n"
    )
    runner = CliRunner()
    result = runner.invoke(main, ["import", "uvl", str(source), "-o", str(tmp_path / "sandwich")])
    assert result.exit_code == 0, result.output
    assert result.output == f"  wrote {tmp_path / 'sandwich' / 'model.json'} (6 features)\n"
    assert (tmp_path / "sandwich" / "variants").is_dir()
    analysed = runner.invoke(main, ["analyse", str(tmp_path / "sandwich"), "--format", "json"])
    assert json.loads(analysed.output)["selection_count"] == 5
    again = runner.invoke(main, ["import", "uvl", str(source), "-o", str(tmp_path / "sandwich")])
    assert again.exit_code == 3 and "exists already" in again.output
    exported = runner.invoke(
        main, ["export", "uvl", str(tmp_path / "sandwich"), "-o", str(tmp_path / "back.uvl")]
    )
    assert exported.exit_code == 0
    assert (tmp_path / "back.uvl").read_text().splitlines()[:3] == [
        "features",
        "    Sandwich {abstract}",  # (no feature of it says a binding: none is written)
        "        mandatory",
    ]
    bad = tmp_path / "bad.uvl"
    bad.write_text("features\n    R\n        [2..3]\n            A\n            B\n")
    refused = runner.invoke(main, ["import", "uvl", str(bad), "-o", str(tmp_path / "bad")])
    assert refused.exit_code == 1
    assert refused.output.splitlines() == [
        f"{bad}:3:9: $: error: group cardinalities cannot be kept: only mandatory, optional, or, alternative (section 8)",
        f"nothing imported: {bad}",
    ]
    assert not (tmp_path / "bad").exists()


@pytest.mark.parametrize("kind", ["uvl", "featureide"])
@pytest.mark.parametrize("special", ["fifo", "/dev/zero"])
def test_import_reads_only_a_regular_file(kind: str, special: str, tmp_path: Path) -> None:
    """Issue 31: importing a FIFO blocked for ever and /dev/zero ran out of memory. An import
    reads its file as every document is read (documents/loader.read_bytes): a FIFO or a
    device is refused, exit 3, and nothing is written."""
    import os

    source = str(tmp_path / "model.fifo") if special == "fifo" else special
    if special == "fifo":
        os.mkfifo(source)
    out = tmp_path / "robot"
    result = CliRunner().invoke(main, ["import", kind, source, "-o", str(out)])
    assert result.exit_code == 3, result.output
    assert "is not a regular file" in result.output and "Traceback" not in result.output
    assert not out.exists()


@pytest.mark.parametrize("kind", ["uvl", "featureide"])
def test_import_of_a_model_nested_600_deep(kind: str, tmp_path: Path) -> None:
    """Issue 31: a model nested 600 deep made a RecursionError traceback (json.dumps of the
    imported document); motivml accepts models thousands deep, and so does import."""
    depth = 600
    if kind == "uvl":
        lines = ["features", "    f0"]
        for d in range(1, depth):
            lines += ["    " * (2 * d) + "optional", "    " * (2 * d + 1) + f"f{d}"]
        text = "\n".join(lines) + "\n"
        source = tmp_path / "deep.uvl"
    else:
        opening = "".join(f'<and name="f{d}">' for d in range(depth - 1))
        text = (
            '<?xml version="1.0"?><featureModel><struct>'
            + opening
            + '<feature name="leaf"/>'
            + "</and>" * (depth - 1)
            + "</struct></featureModel>"
        )
        source = tmp_path / "deep.xml"
    source.write_text(text)
    out = tmp_path / "robot"
    result = CliRunner().invoke(main, ["import", kind, str(source), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert f"({depth} features)" in result.output
    validated = CliRunner().invoke(main, ["validate", str(out / "model.json")])
    assert validated.exit_code == 0, validated.output


def test_import_writes_only_what_validate_accepts(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 31: `import uvl` said "wrote" and wrote a model.json that `validate` refused (the
    root's `position` attribute stayed as a key "\\u0000position"). The root's position is
    read as the children's are; and whatever an importer makes is checked as `validate`
    checks it (the schema, then the model) before anything is written."""
    source = tmp_path / "m.uvl"
    source.write_text("features\n    R {position 3}\n        optional\n            B {position 0}\n")
    result = CliRunner().invoke(main, ["import", "uvl", str(source), "-o", str(tmp_path / "ok")])
    assert result.exit_code == 0, result.output
    assert CliRunner().invoke(main, ["validate", str(tmp_path / "ok" / "model.json")]).exit_code == 0

    import motivml.language.uvl as uvl

    monkeypatch.setattr(uvl, "read_uvl", lambda text, file, warnings=None: {"id": "R", "name": "R", "colour": "red"})
    refused = CliRunner().invoke(main, ["import", "uvl", str(source), "-o", str(tmp_path / "bad")])
    assert refused.exit_code == 1, refused.output
    assert "unknown key 'colour'" in refused.output and "nothing imported" in refused.output
    assert not (tmp_path / "bad" / "model.json").exists()


def test_constraints_are_written_once_from_their_trees() -> None:
    """The importers build a constraint's tree and write it once (formula.write): a deep one
    reads back as written, and the only parentheses dropped are those around a left operand
    of the same `&` or `|`. (That the writing is linear in the text is formula.write's own
    test's business: test_formula.py writes 50,000 levels.)"""
    names = [f"F{k}" for k in range(3000)]
    deep = " => (".join(names[:-1]) + f" => {names[-1]}" + ")" * (len(names) - 2)  # F0 => (F1 => (... => F2999))
    children = "".join(f"            {name}\n" for name in names)
    text = f"features\n    R\n        optional\n{children}constraints\n    {deep}\n    (F0 & F1) & F2\n    F0 | (F1 | F2)\n"
    formulas = read_uvl(text, "m.uvl")["formulas"]
    assert formulas[0] == deep
    assert formulas[1:] == ["F0 & F1 & F2", "F0 | (F1 | F2)"]


# ------------------------------------------------------------------ published dialects
UVL_DATA = ROOT / "tests" / "data" / "uvl"


def test_a_type_word_as_a_feature_name_is_read_with_a_warning() -> None:
    """frscs.uvl names a feature `Integer`, unquoted, in the tree and in a constraint; it
    counts as the benchmark's DIMACS and SXFM of the same model count."""
    warnings: list[Diagnostic] = []
    document = read_uvl((UVL_DATA / "frscs.uvl").read_text(), "frscs.uvl", warnings)
    assert [(d.severity.value, d.location.line, d.message.split(",")[0]) for d in warnings] == [
        ("warning", 60, "a feature named Integer"),
        ("warning", 321, "Integer"),
    ]
    assert count_selections(read(document), 60) == 117_228_783_306_240


def test_double_quoted_attribute_values_are_read_kept_and_written_back() -> None:
    """FeatureIDE's UVL: `{featureDescription__ "..."}`. The values are kept under x-uvl,
    written back by export (in UVL's own single quotes), and the count is the benchmark's."""
    import lzma

    warnings: list[Diagnostic] = []
    text = lzma.open(UVL_DATA / "financial-services-2017-05-22.uvl.xz").read().decode()
    document = read_uvl(text, "fs.uvl", warnings)
    (said,) = warnings
    assert said.location.line == 4 and said.message.startswith(
        "attribute values in double quotes are read as strings (UVL quotes a string with single quotes; "
        "FeatureIDE's exports use double quotes) ("
    )
    assert document["x-uvl"] == {"featureDescription__": "D_XXEYWH5510S43DAAPCE5VG55OXTKAKAA"}
    model = read(document)
    assert count_selections(model, 60) == 430
    written = write_uvl(model)
    assert "featureDescription__ 'D_XXEYWH5510S43DAAPCE5VG55OXTKAKAA'" in written
    again: list[Diagnostic] = []
    assert read_uvl(written, "back.uvl", again)["x-uvl"] == document["x-uvl"] and again == []


def test_kept_attributes_of_every_kind_are_written_back() -> None:
    text = (
        "features\n    R {color 'red', weight 3, ratio 0.5, flag, off false, tags ['a', 'b'], nested {x 'y'}}\n"
        "        optional\n            A {note \"quoted\"}\n"
    )
    document = read_uvl(text, "m.uvl")
    back = read_uvl(write_uvl(read(document)), "back.uvl")
    assert back["x-uvl"] == document["x-uvl"] == {
        "color": "red", "weight": 3, "ratio": 0.5, "flag": True, "off": False, "tags": ["a", "b"], "nested": {"x": "y"},
    }
    assert back["sub"][0]["x-uvl"] == {"note": "quoted"}


def test_a_model_without_bindings_is_exported_without_them_and_reads_back_the_same(tmp_path: Path) -> None:
    """A review found that export wrote the default binding of every feature, so that a model
    imported without bindings came back saying them (show then spoke of bindings)."""
    from motivml.language.featureide import read_featureide, write_featureide

    document = read_uvl("features\n    R\n        optional\n            A\n", "m.uvl")
    model = read(document)
    assert not model.bindings_declared
    assert "bindingTime" not in write_uvl(model) and "bindingTime" not in write_featureide(model)
    assert not read(read_uvl(write_uvl(model), "back.uvl")).bindings_declared
    assert not read(read_featureide(write_featureide(model).encode(), "back.xml")).bindings_declared


def test_a_byte_order_mark_and_a_number_out_of_range(tmp_path: Path) -> None:
    source = tmp_path / "bom.uvl"
    source.write_bytes("\ufefffeatures\n    R\n".encode())
    result = CliRunner().invoke(main, ["import", str(source), "-o", str(tmp_path / "bom")])
    assert result.exit_code == 0, result.output
    with pytest.raises(DocumentError) as refused:
        read_uvl("features\n    R {weight 1e400}\n", "m.uvl")
    (diagnostic,) = refused.value.diagnostics
    assert (diagnostic.location.line, "the number 1e400 is out of range") == (2, diagnostic.message.split(":")[0])

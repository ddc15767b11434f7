"""Repairs (reference.md section 6): minimal changes to a configuration that make it valid.

Each repair is applied to the configuration's JSON here, by hand, and the result judged by
the brute-force reference alone (`reference_semantics`): the applied repair is valid, no
proper subset of it is, the first one has the fewest changes of any repair, and there is
one whenever the model has a valid variant at all.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Iterable, Sequence
from itertools import combinations
from math import comb
from typing import Any, TypeVar

import pytest
import reference_semantics as ref
from click.testing import CliRunner
from helpers import config, feature
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from semantic_helpers import variant_errors
from test_property_sat import configurations, models

from motivml.cli import main
from motivml.errors import Change, ChangeKind, repair_text

Fact = tuple[str, str, Any]  # (feature, "select" | "time" | "mode", value the configuration says)


def facts_of(configuration: dict[str, Any]) -> list[Fact]:
    """What a configuration says, one fact each: a (de)selection, a time, a mode."""
    found: list[Fact] = []
    for entry in configuration["properties"]:
        selected = entry.get("selected", True)
        found.append((entry["id"], "select", selected))
        props = entry.get("props", {})  # (a deselected entry's too: they hold once it is selected)
        for key in ("time", "mode"):
            if props.get(key, "Any") != "Any":
                found.append((entry["id"], key, props[key]))
    return found


def applied(configuration: dict[str, Any], changes: list[tuple[str, str, Any]]) -> dict[str, Any]:
    """The configuration with each (feature, change, new value) made, the way a person would:
    a (de)selection turns `selected` over and leaves the entry's props as they are (issue 31:
    a repair that selected an entry whose props could not hold did not work)."""
    result = copy.deepcopy(configuration)
    entries = {entry["id"]: entry for entry in result["properties"]}
    for fid, change, value in changes:
        entry = entries[fid]
        if change == "select":
            if value:
                entry.pop("selected", None)
            else:
                entry["selected"] = False
        else:
            entry.setdefault("props", {})[change] = value
    return result


def flipped(fact: Fact) -> tuple[str, str, Any]:
    fid, change, value = fact
    other = {"select": {True: False, False: True}, "time": {"Early": "Late", "Late": "Early"}}
    other["mode"] = {"Static": "Dynamic", "Dynamic": "Static"}
    return fid, change, other[change][value]


def as_changes(repair: tuple[Change, ...]) -> list[tuple[str, str, Any]]:
    return [(c.feature, c.change, c.value) for c in repair]


@pytest.mark.slow
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_each_repair_makes_the_configuration_valid_and_no_part_of_it_does(data: st.DataObject) -> None:
    model = data.draw(models(max_features=9))
    configuration = data.draw(configurations(model))
    errors = variant_errors(model, configuration)
    if not errors:
        return
    repairs = errors[0].repairs
    where = (json.dumps(model), json.dumps(configuration), [repair_text(r) for r in repairs])
    assert all(e.repairs == repairs for e in errors), where  # one list: each fixes everything
    assert bool(repairs) == ref.is_valid(model, None), where  # one whenever one exists
    assert len(repairs) <= 5, where
    assert [len(r) for r in repairs] == sorted(len(r) for r in repairs), where  # fewest first
    said = facts_of(configuration)
    for repair in repairs:
        changes = as_changes(repair)
        # each change turns over something the configuration says
        assert all(flipped(fact) in changes for fact in said if fact[:2] in {c[:2] for c in changes}), where
        assert len({c[:2] for c in changes}) == len(changes), where
        assert ref.is_valid(model, applied(configuration, changes)), where
        for part in smaller_sets(changes, len(changes), data):
            assert not ref.is_valid(model, applied(configuration, list(part))), (where, part)
    if repairs:  # the first has the fewest changes of any repair
        for part in smaller_sets(said, len(repairs[0]), data):
            fixed = applied(configuration, [flipped(fact) for fact in part])
            assert not ref.is_valid(model, fixed), (where, part)


T = TypeVar("T")
EXHAUSTIVE = 1000  # sets checked one by one (each by brute force, about 1 ms), at most
SAMPLED = 200  # sets drawn instead, where there are more


def smaller_sets(items: Sequence[T], below: int, data: st.DataObject) -> Iterable[tuple[T, ...]]:
    """Every subset of `items` with fewer than `below` members, or SAMPLED of them drawn,
    sizes evenly, where there are more than EXHAUSTIVE (a first repair of 6 of 27 facts
    leaves 100,000 smaller sets: checking them all took minutes)."""
    if sum(comb(len(items), size) for size in range(below)) <= EXHAUSTIVE:
        return (part for size in range(below) for part in combinations(items, size))
    parts = []
    for _ in range(SAMPLED):  # (each size as likely as any other: most sets are of the largest)
        size = data.draw(st.integers(0, below - 1))
        chosen = data.draw(st.lists(st.integers(0, len(items) - 1), min_size=size, max_size=size, unique=True))
        parts.append(tuple(items[k] for k in chosen))
    return parts


def test_a_repair_that_selects_an_entry_turns_over_its_props_where_they_cannot_hold() -> None:
    """Issue 31: under a root whose mandatory `a` allows Any, an entry deselecting `a` with
    props Early and Dynamic got "select a"; applied (props kept), the product refused it,
    for a required feature must be Static. The repair is both changes."""
    model = feature("r", [feature("a", time="Any", mode="Any")])
    configuration = {"properties": [{"id": "a", "selected": False, "props": {"time": "Early", "mode": "Dynamic"}}]}
    (error, *_) = variant_errors(model, configuration)
    assert [repair_text(r) for r in error.repairs] == ["select a and make a Static"]
    (repair,) = error.repairs
    assert ref.is_valid(model, applied(configuration, as_changes(repair)))
    assert not ref.is_valid(model, applied(configuration, [("a", "select", True)]))


def test_a_feature_deselected_by_a_repair_takes_its_selected_sub_features_with_it() -> None:
    """The shipped SimpleBot's broken variant: grid_map Dynamic, required by slam."""
    result = CliRunner().invoke(
        main,
        ["validate", "feature_models/simplebot", "--variant", "broken_gridmap_dynamic", "--format", "json"],
    )
    assert result.exit_code == 1, result.output
    (conflict,) = json.loads(result.output)["errors"]
    assert [r["text"] for r in conflict["repairs"]] == ["make grid_map Static", "deselect slam and kartoslam"]
    assert conflict["repairs"][0]["changes"] == [
        {"feature": "grid_map", "change": "mode", "value": "Static", "text": "make grid_map Static"}
    ]
    assert [c["value"] for c in conflict["repairs"][1]["changes"]] == [False, False]


def test_repairs_are_printed_under_the_conflict() -> None:
    result = CliRunner().invoke(
        main, ["validate", "feature_models/simplebot", "--variant", "broken_gridmap_dynamic"]
    )
    lines = result.output.splitlines()
    at = lines.index("    to repair, one of:")
    assert lines[at + 1 : at + 3] == ["      - make grid_map Static", "      - deselect slam and kartoslam"]
    assert "slam requires grid_map" in lines[at - 4]


def test_two_independent_conflicts_share_one_list_printed_once(tmp_path: Any) -> None:
    """Each repair fixes the whole configuration: both conflicts carry the same list, and the
    text shows it once, under the last."""
    model = feature(
        "root",
        [
            feature("a", inc=["b"], isMandatory=False),
            feature("b", mode="Any", isMandatory=False),
            feature("c", inc=["d"], isMandatory=False),
            feature("d", mode="Any", isMandatory=False),
        ],
    )
    (tmp_path / "model.json").write_text(json.dumps(model))
    variant = config(("a",), ("b", "Early", "Dynamic"), ("c",), ("d", "Early", "Dynamic"))
    (tmp_path / "variant.json").write_text(json.dumps(variant))
    result = CliRunner().invoke(
        main, ["validate", str(tmp_path / "model.json"), "--config", str(tmp_path / "variant.json")]
    )
    assert result.exit_code == 1, result.output
    assert result.output.count("to repair, one of:") == 1
    texts = [line.strip()[2:] for line in result.output.splitlines() if line.startswith("      - ")]
    # two changes each, one per conflict, in every combination
    assert set(texts) == {
        "make b Static and d Static",
        "deselect a and c",
        "deselect a and make d Static",
        "make b Static and deselect c",
    }


def test_an_incomplete_configuration_shows_its_conflicts_too(tmp_path: Any) -> None:
    """A missing entry no longer hides what else is wrong: both errors, and the repairs."""
    model = feature(
        "root",
        [
            feature("a", inc=["b"], isMandatory=False),
            feature("b", mode="Any", isMandatory=False),
            feature("c", isMandatory=False),
        ],
    )
    (tmp_path / "model.json").write_text(json.dumps(model))
    (tmp_path / "v.json").write_text(json.dumps(config(("a",), ("b", "Early", "Dynamic"))))
    result = CliRunner().invoke(
        main, ["validate", str(tmp_path / "model.json"), "--config", str(tmp_path / "v.json")]
    )
    assert result.exit_code == 1
    assert "the configuration is incomplete: no entry for c" in result.output
    assert "a requires b, but b is configured Dynamic" in result.output
    assert "- make b Static" in result.output


def test_no_repair_when_the_model_itself_has_no_variant(tmp_path: Any) -> None:
    model = feature("root", [feature("a"), feature("b", exc=["a"])])
    (tmp_path / "model.json").write_text(json.dumps(model))
    (tmp_path / "v.json").write_text(json.dumps(config(("a",), ("b",))))
    result = CliRunner().invoke(
        main,
        ["validate", str(tmp_path / "model.json"), "--config", str(tmp_path / "v.json"), "--format", "json"],
    )
    errors = json.loads(result.output)["errors"]
    assert errors and errors[0]["message"].startswith("the model has no valid variant")
    assert all(e["repairs"] == [] for e in errors)


def test_repair_text_groups_changes_by_verb() -> None:
    def change(fid: str, kind: str, value: Any) -> Change:
        verb = {True: "select", False: "deselect"}.get(value) if kind == "select" else "make"
        return Change(fid, ChangeKind(kind), value, f"{verb} {fid}" if kind == "select" else f"make {fid} {value}")

    repair = (
        change("a", "mode", "Dynamic"),
        change("a", "time", "Late"),
        change("b", "mode", "Dynamic"),
        change("c", "select", False),
    )
    assert repair_text(repair) == "make a Dynamic Late and b Dynamic; deselect c"
    assert (
        repair_text((change("c", "select", False), change("d", "select", True))) == "deselect c and select d"
    )

"""The analyses on every family of model shapes the benchmarks run (bench/families.py),
against brute force; interchangeable features (symmetry.py); and the work of `cover`
growing linearly with its targets (issue 32).

The families are made small enough for the reference (reference_semantics.py, which shares
no code with the product) to list every valid variant: chains, flat trees, many small
groups, wide groups (of up to nine members: the XOR rule is encoded by counters from nine
on), dense cross-tree constraints, formulas, bindings mostly `Any` and mostly fixed.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pytest
import reference_semantics as ref
from helpers import model_of as read
from test_analysis import (
    assert_analyses_equal_brute_force,
    assert_live_features_and_impossible_bindings_equal_brute_force,
)

from motivml.binding import encoding as enc
from motivml.binding.analysis import analyse
from motivml.binding.check import binding_states
from motivml.binding.symmetry import Classes, interchangeable
from motivml.documents.loader import parse
from motivml.language.model import OFF, Binding
from motivml.language.reader import read_configuration

pytestmark = pytest.mark.slow  # every analysis on every family of shapes against brute force

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))
from families import FAMILIES, family, tiny  # noqa: E402

# (eight features allowing Any bindings are 10 s of brute force: seven for that family)
CASES = [(name, n, seed) for name in FAMILIES for n in (5, 7, 8) for seed in range(2) if n < 8 or name != "any"]


def _id(case: tuple[str, int, int]) -> str:
    return "-".join(map(str, case))


@pytest.mark.parametrize("case", CASES, ids=_id)
def test_every_analysis_of_every_family_equals_brute_force(case: tuple[str, int, int]) -> None:
    assert_analyses_equal_brute_force(tiny(*case), counts=False)


@pytest.mark.parametrize("case", CASES, ids=_id)
def test_validates_search_on_every_family_equals_brute_force(case: tuple[str, int, int]) -> None:
    assert_live_features_and_impossible_bindings_equal_brute_force(tiny(*case))


def _states_by_brute_force(raw: dict[str, Any], document: dict[str, Any] | None) -> dict[str, set[object]]:
    found: dict[str, set[object]] = {}
    variants = list(ref.valid_variants(raw, document))
    stack = [raw]
    while stack:
        node = stack.pop()
        stack.extend(node.get("sub", []))
        f = node["id"]
        found[f] = {OFF} if any(f not in v for v in variants) else set()
        found[f] |= {Binding.from_flags(*v[f]) for v in variants if f in v}
    return found


@pytest.mark.parametrize("case", CASES, ids=_id)
def test_shows_states_on_every_family_equal_brute_force(case: tuple[str, int, int]) -> None:
    """`show`'s states (binding_states), of the model and of a decisions file that decides
    the second half of the features as the first valid variant does."""
    raw = tiny(*case)
    variants = list(ref.valid_variants(raw, None))
    if not variants:
        return
    model = read(raw)
    decided = [f.id for f in model.features[len(model.features) // 2 :]]
    entries = [
        {"id": f, "props": {"time": "Early" if variants[0][f][0] else "Late", "mode": "Static" if variants[0][f][1] else "Dynamic"}}
        if f in variants[0]
        else {"id": f, "selected": False}
        for f in decided
    ]
    for document in (None, {"partial": True, "properties": entries}):
        config = None
        if document is not None:
            config, _ = read_configuration(parse(json.dumps(document), "v.json"), model, partial=True)
        expected = _states_by_brute_force(raw, document)
        assert {f.id: states for f, states in zip(model.features, binding_states(model, config), strict=True)} == expected


@pytest.mark.parametrize("case", [c for c in CASES if c[1] < 8], ids=_id)
def test_states_asked_again_of_one_kept_encoding_equal_brute_force(case: tuple[str, int, int]) -> None:
    """As menuconfig asks them: one kept encoding, the configuration changed decision by
    decision (some as the last valid variant has it, some against it, some taken back),
    so that the variants kept from the last question hold or not (`Encoding.recent`)."""
    raw = tiny(*case)
    variants = list(ref.valid_variants(raw, None))
    if not variants:
        return
    model = read(raw)
    ids = [f.id for f in model.features]
    entries: dict[str, dict[str, Any]] = {}
    with enc.Encoding(model) as kept:
        for step, f in enumerate(ids[1:] + ids[1:3]):
            last = variants[-1 - step % len(variants)]
            if step % 3 == 2:
                entries.pop(f, None)  # (taken back)
            elif f in last and step % 2:
                entries[f] = {"id": f, "props": {"time": "Early" if last[f][0] else "Late"}}
            else:
                entries[f] = {"id": f, "selected": f not in last}
            document = {"partial": True, "properties": list(entries.values())}
            expected = _states_by_brute_force(raw, document)
            if not any(len(states) for states in expected.values()) or not list(ref.valid_variants(raw, document)):
                entries.pop(f, None)
                continue
            config, _ = read_configuration(parse(json.dumps(document), "v.json"), model, partial=True)
            assert config is not None
            kept.set_configuration(config)
            found = binding_states(model, config, kept)
            assert {g: states for g, states in zip(ids, found, strict=True)} == expected, document


@pytest.mark.parametrize("name", ["dense", "any", "groups"])
def test_a_decision_more_asks_nothing_again_that_the_last_answer_settled(name: str) -> None:
    """menuconfig's next decision holds the last one's literals and more: what no variant
    had then is settled at once (no propagation, no solve), and what some variant had is
    not first propagated on its own. The states are the same as when the encoding has
    forgotten the last answers (its kept variants are kept either way), with fewer unit
    propagations. (Solves may be a few more or fewer: a target that the decision made
    impossible is then refuted by a batch's solve, not its own propagation.)"""
    model = read(family(name, 300, 1))
    states: list[Any] = []
    work: list[int] = []
    for forget in (False, True):
        with enc.Encoding(model) as kept:
            entries: list[dict[str, Any]] = []
            last = None
            for step in range(6):  # (decisions one after another, each leaving variants)
                open_ = [f.id for f, can in zip(model.features, last or [], strict=False) if len(can) > 1][1:]
                if last is not None and not open_:
                    break
                if last is not None:
                    entries.append({"id": open_[(7 * step) % len(open_)], "selected": step % 2 == 0})
                document = {"partial": True, "properties": entries}
                config, _ = read_configuration(parse(json.dumps(document), "v.json"), model, partial=True)
                assert config is not None
                kept.set_configuration(config)
                if not kept.solve():
                    entries.pop()
                    continue
                if forget:
                    kept.recent_answers = (frozenset(), set(), set())
                last = binding_states(model, config, kept)
            states.append(last)
            work.append(kept.work.propagations)
    assert states[0] == states[1]
    assert work[0] < work[1]


def test_the_model_alone_asked_of_a_kept_encoding_set_to_a_configuration() -> None:
    """`binding_states(model, None, kept)` asks of the model alone, whatever configuration
    the kept encoding was last set to: what that configuration ruled out is not carried
    over (a review found a and b both "off" here)."""
    raw = {"id": "r", "name": "r", "sub": [{"id": "a", "name": "a"}, {"id": "b", "name": "b"}]}
    model = read(raw)
    document = {"partial": True, "properties": [{"id": "a", "selected": False}]}
    config, _ = read_configuration(parse(json.dumps(document), "v.json"), model, partial=True)
    with enc.Encoding(model) as kept:
        kept.set_configuration(config)
        binding_states(model, config, kept)
        assert binding_states(model, None, kept) == binding_states(model, None) == [
            set(states) for states in _states_by_brute_force(raw, None).values()
        ]


def _wide_group(members: int, time: str = "Any", mode: str = "Any", others: int = 0) -> dict[str, Any]:
    """A root with one XOR group of `members` leaves allowing `time` and `mode`, and `others`
    members of their own kind: one with a sub-feature, one included by the root's first
    child, one Early Static."""
    sub: list[dict[str, Any]] = [
        {"id": f"m{i}", "name": f"M{i}", "group": "XOR", "constraints": {"bindingTimeAllowed": time, "bindingModeAllowed": mode}}
        for i in range(members)
    ]
    extra: list[dict[str, Any]] = [
        {"id": "parent", "name": "Parent", "group": "XOR", "sub": [{"id": "leaf", "name": "Leaf", "isMandatory": True}]},
        {"id": "named", "name": "Named", "group": "XOR"},
        {"id": "fixed", "name": "Fixed", "group": "XOR", "constraints": {"bindingTimeAllowed": "Early", "bindingModeAllowed": "Static"}},
    ][:others]
    root: dict[str, Any] = {"id": "root", "name": "Root", "sub": [*sub, *extra]}
    if others >= 2:
        root["sub"].append(
            {"id": "user", "name": "User", "isMandatory": False, "constraints": {"featuresIncluded": ["named"]}}
        )
    return root


def test_interchangeable_features_are_leaves_alike_that_no_statement_names() -> None:
    model = read(_wide_group(4, others=3))
    representative = interchangeable(model)
    index = model.index
    assert [representative[index[f"m{i}"]] for i in range(4)] == [index["m0"]] * 4
    for single in ("root", "parent", "leaf", "named", "fixed", "user"):
        assert representative[index[single]] == index[single]
    same = Classes(model)
    assert same.members() == {index["m0"]: [index[f"m{i}"] for i in range(4)]}
    assert same.spread([f"answer {i}" for i in same.asked])[index["m3"]] == f"answer {index['m0']}"


def test_a_configuration_entry_tells_interchangeable_features_apart() -> None:
    model = read(_wide_group(4))
    document = {"partial": True, "properties": [{"id": "m2", "selected": False}]}
    config, _ = read_configuration(parse(json.dumps(document), "v.json"), model, partial=True)
    representative = interchangeable(model, config)
    index = model.index
    assert representative[index["m2"]] == index["m2"]
    assert {representative[index[f"m{i}"]] for i in (0, 1, 3)} == {index["m0"]}


@pytest.mark.parametrize(
    "raw",
    [
        _wide_group(9, others=3),
        _wide_group(10, "Any", "Static", others=1),
        _wide_group(9, "Late", "Dynamic", others=3),
        _wide_group(12, "Early", "Static"),
    ],
    ids=["any", "static", "late-dynamic", "early-static"],
)
def test_wide_groups_of_interchangeable_members_equal_brute_force(raw: dict[str, Any]) -> None:
    """Groups of nine members and more (the counter encoding), a class of interchangeable
    members beside members of their own kind."""
    assert_analyses_equal_brute_force(raw, counts=False)
    assert_live_features_and_impossible_bindings_equal_brute_force(raw)


ROUNDS_CASES = [(name, n, seed) for name in FAMILIES for n in (7, 9) for seed in range(2) if n < 8 or name != "any"]


@pytest.mark.parametrize("case", ROUNDS_CASES, ids=_id)
@pytest.mark.parametrize("pays", [0, 10**6])
def test_atomic_rounds_of_one_pair_split_by_cuts_equal_brute_force(case: tuple[str, int, int], pays: int) -> None:
    """`_atomic_sets` from no variant known (so that its later rounds have work), with
    rounds of one pair (ROUND_PAIRS) and the cuts of their variants always, sometimes or
    never paying (CUT_PAYS): its classes are brute force's atomic sets."""
    from motivml.binding import analysis
    from motivml.binding.cuts import Cuts

    raw = tiny(*case)
    variants = [set(v) for v in ref.valid_variants(raw, None)]
    if not variants:
        return
    model = read(raw)
    ids = [f.id for f in model.features]
    alive = [i for i, f in enumerate(ids) if any(f in v for v in variants)]
    core = [i for i in alive if all(ids[i] in v for v in variants)]
    expected: dict[tuple[bool, ...], list[int]] = {}
    for i in alive:
        expected.setdefault(tuple(ids[i] in v for v in variants), []).append(i)
    with pytest.MonkeyPatch.context() as patch, enc.Encoding(model, record=True) as hard:
        patch.setattr(analysis, "ROUND_PAIRS", 1)
        patch.setattr(analysis, "CUT_PAYS", pays)
        assert hard.recorded is not None
        cuts = Cuts(model, hard.recorded)
        selections: list[bytes] = []
        found = analysis._atomic_sets(
            hard,
            alive,
            core,
            selections,
            lambda values: selections.append(hard.selection_of(values)),
            cut_key=lambda values: analysis._deepest_cuts(cuts, values),
        )
    assert sorted(found) == sorted(expected.values())


def test_a_10000_member_group_is_a_handful_of_solves() -> None:
    """The members of a wide group that allow the same bindings are asked about once: the
    whole analysis of a 10,000-member group is a few dozen solves, not one per member."""
    model = read(_wide_group(10_000, others=3))
    solves: list[int] = []
    original = enc.Encoding.close

    def counted(self: enc.Encoding) -> None:
        solves.append(self.work.solves)
        original(self)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(enc.Encoding, "close", counted)
        result = analyse(model, counts=False)
    assert sum(solves) < 100, solves
    assert not result.dead and result.core == ["root"]
    assert sorted(map(len, result.atomic_sets)) == [1] * (len(model.features) - 2) + [2]  # (parent, leaf)
    # (the members allow every binding, and take each: the rest is the model's of nine members)
    assert result.impossible == analyse(read(_wide_group(9, others=3)), counts=False).impossible


def test_show_settles_a_dead_subtree_without_a_solve_per_feature() -> None:
    """`show`'s states below a dead feature follow from it: a chain of 300 features under a
    feature that only a search shows dead is a handful of solves (it was one per feature),
    and the states are right (brute force on a smaller one)."""

    def dead_chain(length: int) -> dict[str, Any]:
        chain: dict[str, Any] = {"id": f"c{length}", "name": "C", "isMandatory": False, "constraints": ANY}
        for k in range(length - 1, 0, -1):
            chain = {"id": f"c{k}", "name": "C", "isMandatory": False, "constraints": ANY, "sub": [chain]}
        ghost = {"id": "ghost", "name": "Ghost", "isMandatory": False, "sub": [chain]}
        # y and z are dead by unit propagation, ghost only by a search (y or z, both dead)
        impossible = {"bindingModeAllowed": "Static", "featuresIncluded": ["lamp"], "featuresExcluded": ["lamp"]}
        y = {"id": "y", "name": "Y", "isMandatory": False, "constraints": impossible}
        z = {"id": "z", "name": "Z", "isMandatory": False, "constraints": impossible}
        lamp = {"id": "lamp", "name": "Lamp", "isMandatory": False, "constraints": ANY}
        return {"id": "root", "name": "Root", "sub": [ghost, y, z, lamp], "formulas": ["ghost => (y | z)"]}

    small = dead_chain(3)
    expected = _states_by_brute_force(small, None)
    model = read(small)
    assert {f.id: states for f, states in zip(model.features, binding_states(model, None), strict=True)} == expected
    solves: list[int] = []
    original = enc.Encoding.close

    def counted(self: enc.Encoding) -> None:
        solves.append(self.work.solves)
        original(self)

    model = read(dead_chain(300))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(enc.Encoding, "close", counted)
        states = binding_states(model, None)
    assert all(states[i] == {OFF} for i in model.subtree(model.index["ghost"]))
    assert sum(solves) < 30, solves


ANY = {"bindingTimeAllowed": "Any", "bindingModeAllowed": "Any"}


def _cover_work(members: int) -> tuple[int, int, int]:
    """(solver calls, literals hinted, targets checked) of a cover of the four bindings of
    every member of an XOR group whose members each have a sub-feature (so none is
    interchangeable with another: each member selected Early, or Static, needs a witness
    of its own)."""
    raw = {
        "id": "root",
        "name": "Root",
        "sub": [
            {
                "id": f"m{i}",
                "name": f"M{i}",
                "group": "XOR",
                "constraints": ANY,
                "sub": [{"id": f"c{i}", "name": f"C{i}", "constraints": ANY}],
            }
            for i in range(members)
        ],
    }
    model = read(raw)
    hinted = [0]
    with enc.Encoding(model) as hard:
        set_phases = hard.solver.set_phases

        def counting(literals: list[int]) -> None:
            if literals is not hard._unhinted:  # (`unhint`: one list per model, set before a solve)
                hinted[0] += len(literals)
            set_phases(literals)

        hard.solver.set_phases = counting  # type: ignore[method-assign]
        targets = []
        for m in range(members):
            i = model.index[f"m{m}"]
            targets += [[hard.s(i), sign * hard.E(i)] for sign in (1, -1)]
            targets += [[hard.s(i), sign * hard.S(i)] for sign in (1, -1)]
        possible = hard.cover(targets, with_config=False, batch=True, start_empty=True)  # (as for bindings)
        assert all(possible)
        assert 0 < hard.work.resets <= hard.work.solves  # (one reset per solve of step 3, not counted as hints)
        return hard.work.solves, hinted[0], hard.work.checks


def test_the_work_of_cover_grows_linearly_with_its_targets() -> None:
    """1,000 and 4,000 targets that each need a witness of their own: four times the
    targets is at most about four times the solver calls, the hints and the checks, not
    sixteen (the hints were rebuilt over every open target before each solve: 188,752
    literals hinted for 1,000 targets, 3,005,002 for 4,000; now 89,358 and 399,108). A hint covers the next 256
    open targets, fewer near the end, which the smaller cover reaches sooner: hence 6."""
    small, large = _cover_work(250), _cover_work(1000)
    for name, a, b in zip(("solves", "hinted literals", "checks"), small, large, strict=True):
        assert b <= 6 * a, (name, a, b)


def test_families_have_the_size_asked_and_stay_alive() -> None:
    """The benchmark's families: exactly n features, and most of them alive (a family of
    dead models would benchmark nothing)."""
    for name in FAMILIES:
        raw = family(name, 600, seed=1)
        limit = sys.getrecursionlimit()
        sys.setrecursionlimit(max(limit, 5000))  # (json.dumps of a chain of 600; others count on the limit)
        try:
            model = read(raw)
        finally:
            sys.setrecursionlimit(limit)
        assert len(model.features) == 600, name
        result = analyse(model, counts=False)
        assert not result.void, name
        assert len(result.dead) < 60, (name, len(result.dead))

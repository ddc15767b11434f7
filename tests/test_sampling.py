"""t-wise samples against brute force: every valid combination shown, every variant valid.

The valid combinations are read off the reference's list of every valid variant; whether a
sampled variant shows one is read from the decisions files `motivml sample` writes.
"""

from __future__ import annotations

import json
from itertools import combinations
from pathlib import Path
from typing import Any

import pytest
import reference_semantics as ref
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from paths import ROOT
from test_property_sat import models

from motivml.binding.sampling import sample
from motivml.cli import main
from motivml.documents.loader import parse
from motivml.language.reader import read_model


def values_of(variant: dict[str, Any], ids: list[str], bindings: bool) -> set[tuple[str, str]]:
    """A variant's values: (feature, "on"/"off"), and with bindings (feature, Early...)."""
    found = set()
    for f in ids:
        if f not in variant:
            found.add((f, "off"))
            continue
        found.add((f, "on"))
        if bindings:
            early, static = variant[f]
            found |= {(f, "Early" if early else "Late"), (f, "Static" if static else "Dynamic")}
    return found


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=7), st.integers(1, 3), st.booleans(), st.none() | st.integers(0, 1000))
def test_every_valid_combination_is_shown_by_a_valid_variant(
    raw: dict[str, Any], t: int, bindings: bool, shuffle: int | None
) -> None:
    check_against_brute_force(raw, t, bindings, shuffle)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=12), st.booleans(), st.sampled_from([(0, 3), (1000, 1), (1000, 3)]))
def test_pairs_solved_for_together_or_alone_show_every_valid_pair(
    raw: dict[str, Any], bindings: bool, lookahead: tuple[int, int]
) -> None:
    """The 2-wise greedy with no pair solved for together with the next, and with every
    pair of a row that the same partial variant takes first (and a failed solve giving up
    at once, or after 3 cores): the sample still shows every valid pair."""
    from motivml.binding import sampling

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sampling, "LOOKAHEAD", lookahead[0])
        patch.setattr(sampling, "LOOKAHEAD_FAILURES", lookahead[1])
        check_against_brute_force(raw, 2, bindings)


@pytest.mark.parametrize("lookahead", [(0, 3), (1000, 1), (1000, 3), (16, 3)])
def test_pairs_of_exclusive_members_solved_for_together(lookahead: tuple[int, int]) -> None:
    """Two optional XOR groups of 5: a row's pairs with the members of the other group each
    fit a partial variant alone, not together, so solves of pairs together fail and their
    cores take pairs out (the random models above rarely get there)."""
    from motivml.binding import sampling

    def group(name: str) -> dict[str, Any]:
        members = [{"id": f"{name}{k}", "name": f"{name}{k}", "group": "XOR"} for k in range(5)]
        return {"id": name, "name": name, "sub": members}

    raw = {"id": "root", "name": "root", "sub": [group("a"), group("b"), {"id": "c", "name": "c"}]}
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sampling, "LOOKAHEAD", lookahead[0])
        patch.setattr(sampling, "LOOKAHEAD_FAILURES", lookahead[1])
        check_against_brute_force(raw, 2, False)


@pytest.mark.parametrize("bindings", [False, True])
def test_witnesses_moved_without_a_solve_stay_valid(bindings: bool) -> None:
    """Optional features with OR groups under them: a witness that does not select p, with
    p selected (propagation does not pick one of p's members), breaks the group's clause;
    the sampler must see that and solve instead (a check that passed every moved witness
    gave invalid variants here without bindings; with them, these pairs happen to be placed
    by solves)."""

    def group(name: str) -> dict[str, Any]:
        members = [{"id": f"{name}{k}", "name": f"{name}{k}", "group": "OR"} for k in range(3)]
        return {"id": name, "name": name, "sub": members}

    raw = {"id": "root", "name": "root", "sub": [group(name) for name in "pqrs"]}
    check_against_brute_force(raw, 2, bindings)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=9), st.integers(0, 1000))
def test_the_aetg_greedy_shows_every_valid_pair(raw: dict[str, Any], seed: int) -> None:
    check_against_brute_force(raw, 2, False, aetg_seed=seed)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_aetg_greedy_on_groups_of_alternatives(seed: int) -> None:
    """Two optional XOR groups of 5 and four optional features with OR groups: shapes where
    many values of a candidate clash with those taken before it."""

    def group(name: str, kind: str, members: int) -> dict[str, Any]:
        subs = [{"id": f"{name}{k}", "name": f"{name}{k}", "group": kind} for k in range(members)]
        return {"id": name, "name": name, "sub": subs}

    xor = {"id": "root", "name": "root", "sub": [group("a", "XOR", 5), group("b", "XOR", 5), {"id": "c", "name": "c"}]}
    check_against_brute_force(xor, 2, False, aetg_seed=seed)
    ors = {"id": "root", "name": "root", "sub": [group(name, "OR", 3) for name in "pqrs"]}
    check_against_brute_force(ors, 2, False, aetg_seed=seed)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_aetg_greedy_where_only_a_search_refutes(seed: int) -> None:
    """x with y has no variant, but propagating them, alone or together, derives nothing
    (x's two clauses need p, y's need not p, which takes a search): the greedy stalls on
    that pair and a solve refutes it. d is dead the same way (the solver learns that in
    its first solve, on a model this small)."""
    leaves = [{"id": f, "name": f, "isMandatory": False} for f in ("a", "b", "d", "x", "y", "p", "q")]
    raw = {
        "id": "root",
        "name": "root",
        "sub": leaves,
        "formulas": ["!d | a | b", "!d | a | !b", "!d | !a | b", "!d | !a | !b", "!x | p | q", "!x | p | !q", "!y | !p | q", "!y | !p | !q"],
    }
    check_against_brute_force(raw, 2, False, aetg_seed=seed)


def check_against_brute_force(
    raw: dict[str, Any], t: int, bindings: bool, shuffle: int | None = None, aetg_seed: int | None = None
) -> None:
    """sample(t, bindings, shuffle) of `raw` (or, with `aetg_seed`, the AETG-style greedy's
    sample) gives valid variants (brute force says which) that together show every valid
    combination, and counts them right."""
    from motivml.binding.sampling import aetg

    model, _ = read_model(parse(json.dumps(raw), "model.json"))
    ids = [f.id for f in model.features[1:]]
    variants = list(ref.valid_variants(raw, None))
    found = sample(model, t, bindings, shuffle=shuffle) if aetg_seed is None else aetg(model, aetg_seed)
    if not variants:
        assert found.void
        return
    valid: set[tuple[tuple[str, str], ...]] = set()
    for variant in variants:
        mine = sorted(values_of(variant, ids, bindings))
        valid |= {c for c in combinations(mine, t) if len({f for f, _ in c}) == t}
    shown: set[tuple[tuple[str, str], ...]] = set()
    for chosen in found.variants:
        as_reference = {
            model.features[i].id: (b.early, b.static) for i, b in chosen.items() if b is not None and i != 0
        }
        assert any(as_reference == {k: v for k, v in w.items() if k != raw["id"]} for w in variants), (
            "not a valid variant"
        )
        mine = sorted(values_of(as_reference, ids, bindings))
        shown |= {c for c in combinations(mine, t) if len({f for f, _ in c}) == t}
    assert valid <= shown
    assert found.valid == len(valid) == found.shown


def test_sample_command_writes_valid_decisions_files(tmp_path: Path) -> None:
    runner = CliRunner()
    robot = ROOT / "feature_models" / "simplebot"
    out = tmp_path / "sample"
    (out).mkdir()
    (out / "sample-099.json").write_text("{}")  # an earlier sample's: removed
    result = runner.invoke(main, ["sample", str(robot), "--t", "2", "--bindings", "-o", str(out)])
    assert result.exit_code == 0, result.output
    first = result.output.splitlines()[0]
    assert "cover 100.0% of" in first and "valid 2-wise combinations" in first
    files = sorted(out.iterdir())
    assert files and not (out / "sample-099.json").exists()
    assert first.startswith(f"{len(files)} variants")
    for path in files:
        document = json.loads(path.read_text())
        assert document["partial"] is True
        checked = runner.invoke(main, ["validate", str(robot / "model.json"), "--config", str(path)])
        assert checked.exit_code == 0, checked.output


def test_sample_refusals(tmp_path: Path) -> None:
    runner = CliRunner()
    (tmp_path / "void").mkdir()
    (tmp_path / "void" / "model.json").write_text(
        json.dumps(
            {
                "id": "r",
                "name": "R",
                "sub": [
                    {"id": "a", "name": "A", "constraints": {"featuresExcluded": ["b"]}},
                    {"id": "b", "name": "B"},
                ],
            }
        )
    )
    void = runner.invoke(main, ["sample", str(tmp_path / "void"), "-o", str(tmp_path / "out")])
    assert void.exit_code == 1 and "nothing analysed: the model has no valid variant" in void.output
    assert not (tmp_path / "out").exists()
    big = {
        "id": "r",
        "name": "R",
        "sub": [{"id": f"f{i}", "name": "F", "isMandatory": False} for i in range(600)],
    }
    (tmp_path / "big.json").write_text(json.dumps(big))
    too_many = runner.invoke(
        main, ["sample", str(tmp_path / "big.json"), "--t", "3", "--bindings", "-o", str(tmp_path / "out")]
    )
    assert too_many.exit_code == 2 and "3-wise combinations over 600 features: more than" in too_many.output


def test_a_model_with_only_its_root_has_an_empty_sample(tmp_path: Path) -> None:
    """No feature to vary: no combination, no variant (the sampler once raised ValueError
    here, from comb(-1, t - 1))."""
    raw = {"id": "root", "name": "Root"}
    model, _ = read_model(parse(json.dumps(raw), "model.json"))
    for t in (1, 2, 3):
        for bindings in (False, True):
            found = sample(model, t, bindings)
            assert (found.variants, found.combinations, found.valid, found.shown) == ([], 0, 0, 0)
    (tmp_path / "model.json").write_text(json.dumps(raw))
    result = CliRunner().invoke(main, ["sample", str(tmp_path / "model.json"), "-o", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[-1] == "  wrote no file: no 2-wise combination, the model has 0 features besides its root"
    assert not list((tmp_path / "out").glob("sample-*.json"))


def test_sample_writes_under_build_by_default(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 33: sample needed -o where export and configure default to build/<robot>/."""
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["sample", str(ROOT / "feature_models" / "simplebot")])
    assert result.exit_code == 0, result.output
    assert "wrote build/simplebot/sample/sample-001.json" in result.output
    assert (tmp_path / "build" / "simplebot" / "sample" / "sample-001.json").is_file()


def test_more_partial_variants_than_a_word_of_bits_holds(monkeypatch: pytest.MonkeyPatch) -> None:
    """Two XOR groups of 9: each of the 81 pairs of members needs a variant of its own, so the
    2-wise greedy's bit sets (one word of 64 at first, here) grow while it runs."""
    import numpy as np

    from motivml.binding import sampling

    def one_word(self: object, rows: int) -> None:
        self.words = np.zeros((rows, 1), dtype=np.uint64)  # type: ignore[attr-defined]

    monkeypatch.setattr(sampling._Bits, "__init__", one_word)

    def group(name: str) -> dict[str, Any]:
        members = [{"id": f"{name}{k}", "name": f"{name}{k}", "group": "XOR"} for k in range(9)]
        return {"id": name, "name": name, "isMandatory": True, "sub": members}

    raw = {"id": "root", "name": "root", "sub": [group("a"), group("b")]}
    model, _ = read_model(parse(json.dumps(raw), "model.json"))
    found = sample(model, 2)
    chosen = [
        tuple(sorted(model.features[i].id for i, b in variant.items() if b is not None and model.features[i].id[1:].isdigit()))
        for variant in found.variants
    ]
    assert all(len(pair) == 2 and pair[0][0] == "a" and pair[1][0] == "b" for pair in chosen)  # (one of each group)
    assert len(set(chosen)) == 81 == len(found.variants)  # (every pair of members, each once)
    again = sampling.coverage(model, found.variants, 2)
    assert found.valid == found.shown == again.valid == again.shown


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.lists(st.integers(1, 8).flatmap(lambda v: st.sampled_from([v, -v])), min_size=1, max_size=4), min_size=1, max_size=12),
    st.lists(st.booleans(), min_size=8, max_size=8),
    st.sets(st.integers(0, 9), max_size=5),
)
def test_clauses_over_changed_variables_are_checked_as_by_hand(
    clauses: list[list[int]], truth: list[bool], changed: set[int]
) -> None:
    """`_Clauses.holds` (the 2-wise sampler's check of a witness moved without a solve):
    whether every clause with a variable in `changed` has a true literal, each clause
    evaluated by hand; variables past the clauses' highest have no clause."""
    import numpy as np

    from motivml.binding import encoding as enc
    from motivml.binding.sampling import _Clauses

    kept = enc.Clauses()
    kept.extend(clauses)
    by_hand = all(
        any(truth[abs(literal) - 1] == (literal > 0) for literal in clause)
        for clause in clauses
        if any(abs(literal) - 1 in changed for literal in clause)
    )
    truths = np.array(truth + [False, False], dtype=bool)  # (variables 9 and 10: in no clause)
    assert _Clauses(kept).holds(truths, np.array(sorted(changed), dtype=np.int64)) == by_hand


def _generated(n: int, seed: int) -> Any:
    """bench/generate.py's model of n features."""
    import sys

    if str(ROOT / "bench") not in sys.path:
        sys.path.insert(0, str(ROOT / "bench"))
    from generate import generate

    document, _ = generate(n, seed)
    model, _ = read_model(parse(json.dumps(document), "model.json"))
    return model


def test_the_smallest_sample_of_several_orders() -> None:
    """`smallest` keeps the smallest of its tries (the model's own order, then each `sample`
    in its own shuffled order), the first of equal ones, and gives the same sample again for
    the same seed and tries."""
    from motivml.binding import sampling
    from motivml.binding.sampling import TRIES_APART, smallest

    model = _generated(60, 3)
    orders = [None, *(7 * TRIES_APART + k for k in range(1, 4))]
    sizes = [len(sample(model, 2, shuffle=order).variants) for order in orders]
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sampling, "AETG_AT_MOST", 0)  # (the orders alone)
        found = smallest(model, 2, tries=4, seed=7)
        assert (len(found.variants), found.tries, found.aetg) == (min(sizes), 4, False)
        assert found.variants == sample(model, 2, shuffle=orders[sizes.index(min(sizes))]).variants
        assert smallest(model, 2, tries=4, seed=7).variants == found.variants
        assert found.valid == found.shown
    # with the AETG-style greedy too (a model this small), as many runs as orders: the smallest
    runs = [len(sampling.aetg(model, 7 * TRIES_APART + k).variants) for k in range(4)]
    both = smallest(model, 2, tries=4, seed=7)
    assert len(both.variants) == min(*sizes, *runs)
    assert both.aetg == (min(runs) < min(sizes))
    assert (both.valid, both.shown, both.tries) == (found.valid, found.shown, 4)
    assert smallest(model, 2, tries=4, seed=7).variants == both.variants


def test_no_order_is_tried_after_the_time_given() -> None:
    """With `until` already past, the first order is tried and no other (a deadline in the
    past, not a measured time: the test does not depend on the machine's speed)."""
    import time

    from motivml.binding.sampling import TRIES_APART, aetg, smallest

    model = _generated(40, 1)
    found = smallest(model, 2, tries=5, seed=2, until=time.monotonic() - 1)
    assert found.tries == 1
    # the model's own order, and one AETG run (whatever the time: as many as orders)
    own, run = sample(model, 2), aetg(model, 2 * TRIES_APART)
    assert found.variants == (run.variants if len(run.variants) < len(own.variants) else own.variants)
    alone, _ = read_model(parse(json.dumps({"id": "r", "name": "r"}), "model.json"))
    nothing = smallest(alone, 2, tries=5)  # (no combination: no other order does better)
    assert (nothing.variants, nothing.tries) == ([], 1)
    one = {"id": "r", "name": "r", "sub": [{"id": "a", "name": "a", "isMandatory": True}]}
    only, _ = read_model(parse(json.dumps(one), "model.json"))
    assert smallest(only, 1, tries=5).tries == 1  # (one variant: none is smaller)


def test_sample_tries_orders_and_says_how_to_get_the_same_sample_again(tmp_path: Path) -> None:
    """The line under the count says which greedy gave the sample (as `smallest` says, asked
    in-process with the same tries and seeds: one seed where the orders' sample is kept and
    one where the AETG-style greedy's is), and the same --tries and --seed give the same
    files again."""
    from motivml.binding.sampling import smallest

    robot = ROOT / "feature_models" / "simplebot"
    model, _ = read_model(parse((robot / "model.json").read_text(), "model.json"))
    kept = {seed: smallest(model, 2, tries=3, seed=seed).aetg for seed in range(8)}
    seeds = {False: min(s for s, aetg in kept.items() if not aetg)}
    seeds[True] = min(s for s, aetg in kept.items() if aetg)
    lines = {
        False: "  the smallest of 3 orders of the features (--tries 3 --seed {})",
        True: "  the AETG-style greedy's, smaller than the smallest of 3 orders of the features (--tries 3 --seed {})",
    }
    for aetg, seed in seeds.items():
        runs = []
        for name in ("a", "b"):
            out = tmp_path / f"{seed}{name}"
            result = CliRunner().invoke(main, ["sample", str(robot), "--tries", "3", "--seed", str(seed), "-o", str(out)])
            assert result.exit_code == 0, result.output
            assert lines[aetg].format(seed) in result.output.splitlines()
            runs.append({f.name: f.read_text() for f in sorted(out.iterdir())})
        assert runs[0] == runs[1] and runs[0]
    result = CliRunner().invoke(main, ["sample", str(robot), "--tries", "0", "-o", str(tmp_path / "c")])
    assert result.exit_code == 2 and "--tries" in result.output


def test_the_benchs_aetg_baseline_covers_every_valid_pair(tmp_path: Path) -> None:
    """bench/greedy.py, the baseline `bench/sample_bench.py` holds `sample` to: on the
    exported CNF of a small model, every variant of its sample is valid and every pair of
    two features' values that a valid variant has (a solve per pair, here) is covered."""
    import sys

    from pysat.solvers import Glucose4

    if str(ROOT / "bench") not in sys.path:
        sys.path.insert(0, str(ROOT / "bench"))
    from greedy import all_valid, baseline, covered_pairs, read_dimacs

    result = CliRunner().invoke(
        main, ["export", "dimacs", str(ROOT / "guidelines" / "examples" / "sensorbot"), "-o", str(tmp_path / "m.dimacs")]
    )
    assert result.exit_code == 0, result.output
    found = baseline(tmp_path / "m.dimacs", seed=3, candidates=5, timeout=60)
    _, clauses, features = read_dimacs(tmp_path / "m.dimacs")
    assert found["sample"] and all_valid(clauses, found["sample"])
    with Glucose4(bootstrap_with=clauses) as solver:
        valid = {
            (x, y)
            for a, b in combinations(features, 2)
            for x in (a, -a)
            for y in (b, -b)
            if solver.solve(assumptions=[x, y])
        }
    assert valid and valid <= covered_pairs(found["sample"])


def test_each_aetg_run_reports_the_pairs_it_has_covered() -> None:
    """`smallest` reports the orders' progress as (k, settled, combinations) and each AETG
    run's as (k, covered, pairs, runs): covered never falls and ends at all the pairs (a
    bar that sat at 100% during the runs is what users saw before)."""
    from motivml.binding.sampling import smallest

    model = _generated(60, 3)
    calls: list[tuple[int, ...]] = []
    found = smallest(model, 2, tries=2, seed=7, progress=lambda *args: calls.append(args))
    orders = [c for c in calls if len(c) == 3]
    runs = [c for c in calls if len(c) == 4]
    assert orders and {c[0] for c in orders} == {0, 1} and found.tries == 2
    assert runs and {c[0] for c in runs} == {0, 1} and {c[3] for c in runs} == {2}
    for k in (0, 1):
        covered = [c[1] for c in runs if c[0] == k]
        assert covered == sorted(covered) and covered[-1] == runs[-1][2] > 0

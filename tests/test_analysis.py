"""Section 7's analyses and counts against brute force, and `motivml analyse` itself.

The reference (reference_semantics.py) enumerates every valid variant of a small random
model, and every selection satisfying section 2 alone; core, dead and false-optional
features, atomic sets, impossible bindings and both counts are read off those lists here,
with no code of the product's.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import reference_semantics as ref
from click.testing import CliRunner
from helpers import feature
from helpers import model_of as read
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from paths import ROOT
from test_property_sat import models

from motivml.binding import analysis as analysis_module
from motivml.binding.analysis import Compiling, CountFailed, analyse, count_selections, count_variants
from motivml.cli import main


def ids_in_order(raw: dict[str, Any]) -> list[str]:
    found, stack = [], [raw]
    while stack:
        node = stack.pop()
        found.append(node["id"])
        stack.extend(reversed(node.get("sub", [])))
    return found


def parents(raw: dict[str, Any]) -> dict[str, str | None]:
    found: dict[str, str | None] = {raw["id"]: None}
    stack = [raw]
    while stack:
        node = stack.pop()
        for child in node.get("sub", []):
            found[child["id"]] = node["id"]
            stack.append(child)
    return found


def optional(raw: dict[str, Any]) -> set[str]:
    """Features that are not ungrouped mandatory children (section 7: "not mandatory (or a
    group member)"), read from the document: a group member is one of at least two children
    of its parent with the same group label."""
    found, stack = set(), [raw]
    while stack:
        node = stack.pop()
        children = node.get("sub", [])
        for child in children:
            label = child.get("group", "")
            grouped = label and sum(1 for c in children if c.get("group", "") == label) >= 2
            if grouped or child.get("isMandatory", True) is False:
                found.add(child["id"])
            stack.append(child)
    return found


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=8))
def test_analyses_equal_brute_force(raw: dict[str, Any]) -> None:
    assert_analyses_equal_brute_force(raw)
    assert_analyses_equal_brute_force(raw, compiled=True)


def assert_analyses_equal_brute_force(raw: dict[str, Any], counts: bool = True, compiled: bool = False) -> None:
    """Every analysis of `raw` (the counts with `counts`) is what the reference's list of
    every valid variant says: from the solver and Ganak, or with `compiled` from the
    compiled forms (made in memory)."""
    variants = list(ref.valid_variants(raw, None))
    result = analyse(read(raw), counts=counts, count_timeout=60, compiling=Compiling(use=compiled))
    if not variants:
        assert result.void and result.selection_count == (0 if counts else None)
        assert result.variant_count == (0 if counts else None)
        return
    order = ids_in_order(raw)
    selections = [set(v) for v in variants]
    alive = [f for f in order if any(f in chosen for chosen in selections)]
    assert not result.void
    assert result.dead == [f for f in order if f not in alive]
    assert result.core == [f for f in order if all(f in chosen for chosen in selections)]
    up = parents(raw)
    assert result.false_optional == [
        f
        for f in alive
        if f in optional(raw) and all(f in chosen for chosen in selections if up[f] in chosen)
    ]
    by_pattern: dict[tuple[bool, ...], list[str]] = {}
    for f in alive:
        by_pattern.setdefault(tuple(f in chosen for chosen in selections), []).append(f)
    assert sorted(result.atomic_sets) == sorted(by_pattern.values())
    assert all(members == sorted(members, key=order.index) for members in result.atomic_sets)
    taken = {
        (f, aspect, value)
        for v in variants
        for f, (early, static) in v.items()
        for aspect, value in (
            ("time", "Early" if early else "Late"),
            ("mode", "Static" if static else "Dynamic"),
        )
    }
    allowed = _allowed(raw)
    expected_impossible = {
        (f, aspect, value)
        for f in alive
        for aspect, values in (("time", ("Early", "Late")), ("mode", ("Static", "Dynamic")))
        if allowed[f][aspect] == "Any"
        for value in values
        if (f, aspect, value) not in taken
    }
    assert set(result.impossible) == expected_impossible
    if counts:
        assert result.variant_count == len(variants)
        assert result.selection_count == sum(1 for _ in ref.section_2_selections(raw))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=8))
def test_analyses_with_cover_checks_in_numpy_equal_them_in_python(raw: dict[str, Any]) -> None:
    """From VECTOR_FROM open targets on, cover checks variants against them with numpy
    arrays: forced from the first target, every answer is the same."""
    from motivml.binding import encoding as enc

    model = read(raw)
    expected = analyse(model, counts=False)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(enc, "VECTOR_FROM", 0)
        assert analyse(model, counts=False) == expected


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=8))
def test_cover_answers_the_same_with_targets_solved_for_in_batches(raw: dict[str, Any]) -> None:
    """cover(batch=True) solves for several open targets at once in its last step; without
    hints nearly every target gets there. Every answer is the one of cover alone, and the
    same without the propagation step (refute=False: impossible targets are then solved
    for)."""
    from motivml.binding import encoding as enc

    model = read(raw)
    with enc.Encoding(model) as hard:
        if not hard.solve(with_config=False):
            return
        n = len(model.features)
        targets = [
            [hard.s(i), sign_e * hard.E(i), sign_s * hard.S(i)]
            for i in range(n)
            for sign_e in (1, -1)
            for sign_s in (1, -1)
        ] + [[hard.s(i), -hard.s(j)] for i in range(n) for j in range(n) if i != j]
        alone = hard.cover(targets, with_config=False)
        together = hard.cover(targets, with_config=False, batch=True)
        unrefuted = hard.cover(targets, with_config=False, batch=True, refute=False)
    assert together == alone and unrefuted == alone


def _atomic_sets_from_rounds_alone(raw: dict[str, Any]) -> list[list[str]] | None:
    """analysis._atomic_sets with no variant known beforehand and no first split, so that
    its rounds (the first member against the others, then neighbours) settle every class;
    None for a void model."""
    from motivml.binding import encoding as enc

    model = read(raw)
    with enc.Encoding(model) as hard:
        if not hard.solve(with_config=False):
            return None
        n = len(model.features)
        alive = [i for i in range(n) if hard.solve(with_config=False, extra=[hard.s(i)])]
        core = [i for i in alive if not hard.solve(with_config=False, extra=[-hard.s(i)])]
        selections: list[bytes] = []
        sets = analysis_module._atomic_sets(
            hard, alive, core, selections, lambda values: selections.append(hard.selection_of(values))
        )
    return [[model.features[i].id for i in members] for members in sets]


def _atomic_sets_by_brute_force(raw: dict[str, Any]) -> list[list[str]] | None:
    variants = [set(v) for v in ref.valid_variants(raw, None)]
    if not variants:
        return None
    by_pattern: dict[tuple[bool, ...], list[str]] = {}
    for f in ids_in_order(raw):
        if any(f in chosen for chosen in variants):
            by_pattern.setdefault(tuple(f in chosen for chosen in variants), []).append(f)
    return sorted(by_pattern.values(), key=lambda members: ids_in_order(raw).index(members[0]))


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=9))
def test_atomic_set_rounds_alone_equal_brute_force(raw: dict[str, Any]) -> None:
    assert _atomic_sets_from_rounds_alone(raw) == _atomic_sets_by_brute_force(raw)


@given(st.lists(st.tuples(st.integers(0, 11), st.integers(0, 11)), max_size=40))
def test_strongly_connected_components_equal_mutual_reachability(edges: list[tuple[int, int]]) -> None:
    """analysis._components (iterative Tarjan) against reachability computed the plain way:
    two nodes share a component iff each reaches the other."""
    after: dict[int, list[int]] = {}
    for u, v in edges:
        after.setdefault(u, []).append(v)
    component = analysis_module._components(after)
    assert set(component) >= set(after)

    def reached(u: int) -> set[int]:
        seen, todo = {u}, [u]
        while todo:
            for v in after.get(todo.pop(), []):
                if v not in seen:
                    seen.add(v)
                    todo.append(v)
        return seen

    reach = {u: reached(u) for u in component}
    for u in component:
        for v in component:
            assert (component[u] == component[v]) == (v in reach[u] and u in reach[v]), (u, v)


def test_atomic_sets_start_from_features_that_imply_each_other() -> None:
    """A mandatory sub-feature and its parent, and a feature and the sub-feature it
    includes, imply each other by two-literal clauses: one group before any solve."""
    from motivml.binding import encoding as enc

    raw = feature(
        "r",
        [
            feature("a", [feature("m", isMandatory=True), feature("i", isMandatory=False)], isMandatory=False,
                    constraints={"featuresIncluded": ["i"]}),
            feature("b", isMandatory=False),
        ],
    )  # fmt: skip
    model = read(raw)
    index = model.index
    with enc.Encoding(model, record=True) as hard:
        assert hard.recorded is not None
        import numpy as np

        groups = analysis_module._implied_both_ways(hard.recorded, [[index["a"], index["m"], index["i"], index["b"]]], hard.n, np)
    assert groups == [[[index["a"], index["m"], index["i"]], [index["b"]]]]
    assert _atomic_sets_by_brute_force(raw) == [["r"], ["a", "m", "i"], ["b"]]
    assert sorted(analyse(model, counts=False).atomic_sets) == [["a", "m", "i"], ["b"], ["r"]]


def test_atomic_set_rounds_halve_a_class_of_alternatives_and_keep_equal_neighbours() -> None:
    """Alternatives a..e of an XOR group, each with a mandatory child: the first round
    parts a from the others, which differ from each other too (neighbour rounds); each
    alternative and its child are one class."""
    alternatives = [
        feature(name, [feature(f"{name}1", isMandatory=True)], group="XOR") for name in "abcde"
    ]
    raw = feature("r", [feature("g", alternatives, isMandatory=False)])
    expected = [["r"], ["g"], *([name, f"{name}1"] for name in "abcde")]
    assert _atomic_sets_by_brute_force(raw) == expected
    assert _atomic_sets_from_rounds_alone(raw) == expected


def test_atomic_set_rounds_find_equal_members_that_are_not_neighbours() -> None:
    """b is selected exactly when q is (q is the only live member of b's OR group), with x
    between them in pre-order: neighbour rounds see b and x differ, then x and q, and must
    not take b's class to be final before q is compared with it."""
    raw = feature(
        "r",
        [
            feature("a", isMandatory=False),
            feature(
                "b",
                [
                    feature("x", isMandatory=False),
                    feature("p", [feature("d", isMandatory=True)], group="OR"),
                    feature("q", group="OR"),
                ],
                isMandatory=False,
            ),
            feature("c", isMandatory=False),
            feature("e", isMandatory=False),
        ],
        formulas=["!d"],
    )
    expected = [["r"], ["a"], ["b", "q"], ["x"], ["c"], ["e"]]
    assert _atomic_sets_by_brute_force(raw) == expected
    assert _atomic_sets_from_rounds_alone(raw) == expected


# a is dead (its XOR group wants exactly one of x and y, the formula both or neither), yet
# unit propagation does not refute it; p's alternatives u and v are both possible
_DEAD_UNREFUTED = feature(
    "r",
    [
        feature("a", [feature("x", group="XOR"), feature("y", group="XOR")], isMandatory=False),
        feature("p", [feature("u", group="XOR"), feature("v", group="XOR")], isMandatory=False),
    ],
    formulas=["x <=> y"],
)


def test_a_batch_that_fails_leaves_its_first_target_to_a_solve_of_its_own() -> None:
    """a is dead (its XOR group wants exactly one of x and y, the formula both or neither),
    yet unit propagation does not refute it; v is possible but not in the first variant,
    which has u. In cover's last step a and v are solved for in one batch, which fails on
    a alone: a is then asked alone (impossible), and v after it (possible)."""
    from motivml.binding import encoding as enc

    model = read(_DEAD_UNREFUTED)
    with enc.Encoding(model) as hard:
        s = {f.id: hard.s(f.index) for f in model.features}
        targets = [[s["a"]], [s["u"]], [s["v"]]]
        assert hard.solver.propagate(assumptions=[s["a"], s["v"]])[0]  # (a is not refuted so)
        assert hard.cover(targets, with_config=False, batch=True) == [False, True, True]


def test_a_failed_batch_drops_the_targets_its_core_blames_and_is_solved_again() -> None:
    """x and y exclude each other (an XOR group of Static members); z is free. A batch that
    begins with x and holds y and z fails; its core blames y, which leaves, and x with z
    is solved for. A batch that begins with the dead d fails on d alone: d cannot hold.
    A batch of one target leaves it to its own solve."""
    from motivml.binding import encoding as enc

    raw = feature(
        "r",
        [
            feature("g", [feature("x", group="XOR"), feature("y", group="XOR")]),
            feature("z", isMandatory=False),
            feature("d", isMandatory=False, constraints={"featuresExcluded": ["g"]}),
        ],
    )
    model = read(raw)
    with enc.Encoding(model) as hard:
        s = {f.id: hard.s(f.index) for f in model.features}
        targets = [[s["x"]], [s["y"]], [s["z"]], [s["d"]]]
        assert hard._solve_batch(targets, [], [0, 1, 2])
        shown = set(hard.assignment())
        assert {s["x"], s["z"]} <= shown and s["y"] not in shown
        assert hard._solve_batch(targets, [], [3, 0, 2]) is False
        assert hard._solve_batch(targets, [], [2]) is None
        assert hard.cover(targets, with_config=False, batch=True) == [True, True, True, False]


def test_a_batch_of_alternatives_gives_up_after_a_few_failed_solves() -> None:
    """Members of one XOR group of Static features exclude each other: each failed solve's
    core blames one more of them. After BATCH_FAILURES failed solves the batch gives up
    and leaves its first target to its own solve (a group of 2,000 members made 31 failed
    solves a target before), and cover still answers every target."""
    from motivml.binding import encoding as enc

    raw = feature("r", [feature("g", [feature(f"x{k}", group="XOR") for k in range(12)])])
    model = read(raw)
    with enc.Encoding(model) as hard:
        targets = [[hard.s(model.index[f"x{k}"])] for k in range(12)]
        solves = 0
        solve = hard.solver.solve

        def counted(*args: Any, **kwargs: Any) -> Any:
            nonlocal solves
            solves += 1
            return solve(*args, **kwargs)

        hard.solver.solve = counted  # type: ignore[method-assign]
        assert hard._solve_batch(targets, [], list(range(12))) is None
        assert solves == enc.BATCH_FAILURES
        assert hard.cover(targets, with_config=False, batch=True, refute=False) == [True] * 12


def _allowed(raw: dict[str, Any]) -> dict[str, dict[str, str]]:
    found, stack = {}, [raw]
    while stack:
        node = stack.pop()
        constraints = node.get("constraints", {})
        found[node["id"]] = {
            "time": constraints.get("bindingTimeAllowed", "Early"),
            "mode": constraints.get("bindingModeAllowed", "Static"),
        }
        stack.extend(node.get("sub", []))
    return found


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=12))
def test_selection_count_equals_brute_force_up_to_12_features(raw: dict[str, Any]) -> None:
    assert count_selections(read(raw)) == sum(1 for _ in ref.section_2_selections(raw))


# ---------------------------------------------------------------------------- fixtures
SENSORBOT = ROOT / "guidelines" / "examples" / "sensorbot" / "model.json"


def test_sensorbot_by_hand() -> None:
    """Three OR-grouped sensors, not lidar and sonar together, SLAM only with lidar or camera:
    5 sensor sets without SLAM ({l}, {c}, {s}, {l,c}, {c,s}), 4 with it (all but {s})."""
    runner = CliRunner()
    result = runner.invoke(main, ["analyse", str(SENSORBOT), "--format", "json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.output)
    assert payload["selection_count"] == 9
    assert payload["core"] == ["sensorbot", "sensors"]
    assert payload["dead"] == [] and payload["false_optional"] == []
    assert payload["atomic_sets"][0] == ["sensorbot", "sensors"]
    assert isinstance(payload["variant_count"], int) and payload["uncounted"] == []


def test_counts_are_exact_integers_beyond_64_bits() -> None:
    """200 optional features: 2^200 selections, exactly (no float, no modulo 2^64)."""
    raw = feature("r", [feature(f"f{i}", isMandatory=False) for i in range(200)])
    model = read(raw)
    assert count_selections(model) == 2**200
    assert count_variants(model) == 2**200  # each allows Static Early only


def test_text_output(tmp_path: Path) -> None:
    result = CliRunner().invoke(main, ["analyse", str(SENSORBOT)])
    assert result.exit_code == 0
    assert result.output.splitlines() == [
        f"{SENSORBOT}: 6 features",
        "core (2): sensorbot, sensors",
        "dead (0): none",
        "false-optional (0): none",
        "atomic sets (1): {sensorbot, sensors} (and 4 live features each in a set of its own)",
        "impossible bindings (0): none",
        "selections: 9",
        "variants: 84",
    ]


def test_dead_false_optional_and_impossible(tmp_path: Path) -> None:
    raw = feature(
        "r",
        [
            feature("a", isMandatory=False, inc=["b"]),
            feature("b", isMandatory=False, exc=["a"]),
            feature("c", isMandatory=False, time="Any", mode="Any", inc=["d"]),
            feature("d", isMandatory=False, time="Any", mode="Any"),
        ],
        formulas=["d"],
    )
    (tmp_path / "model.json").write_text(json.dumps(raw))
    result = CliRunner().invoke(main, ["analyse", str(tmp_path), "--format", "json"])
    payload = json.loads(result.output)
    assert payload["dead"] == ["a"]  # a needs b, which excludes it
    assert payload["core"] == ["r", "d"]  # the formula
    assert payload["false_optional"] == ["d"]  # optional, yet always there
    # c requires d: d is Static Early whenever c is selected (3.1), but without c it may be
    # anything, and c itself any binding: no value is impossible
    assert payload["impossible_bindings"] == []
    assert payload["selection_count"] == 4  # b on/off x c on/off, d always, a never


def test_void_model(tmp_path: Path) -> None:
    raw = feature("r", [feature("a", exc=["b"]), feature("b")])
    (tmp_path / "model.json").write_text(json.dumps(raw))
    result = CliRunner().invoke(main, ["analyse", str(tmp_path)])
    assert result.exit_code == 1
    assert "the model has no valid variant: " in result.output
    assert result.output.splitlines()[-1] == "nothing analysed: the model has no valid variant"
    as_json = CliRunner().invoke(main, ["analyse", str(tmp_path), "--format", "json"])
    assert as_json.exit_code == 1 and json.loads(as_json.output)["void"] is True


def test_a_model_with_errors(tmp_path: Path) -> None:
    (tmp_path / "model.json").write_text('{"id": "r", "name": "R", "formulas": ["a &"]}')
    result = CliRunner().invoke(main, ["analyse", str(tmp_path / "model.json")])
    assert result.exit_code == 1
    assert "does not parse" in result.output and "nothing analysed: the model has errors" in result.output


def test_a_count_that_runs_out_of_time_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    """The counter runs in a child process that is killed when the time is up."""
    monkeypatch.setattr(analysis_module, "_count_here", _never_answers)
    result = CliRunner().invoke(main, ["analyse", str(SENSORBOT), "--count-timeout", "0.2", "--no-compiled"])
    assert result.exit_code == 0
    assert result.output.splitlines()[-2:] == [
        "selections: not counted within 0.2 s (see --count-timeout)",
        "variants: not counted within 0.2 s (see --count-timeout)",
    ]
    as_json = CliRunner().invoke(
        main, ["analyse", str(SENSORBOT), "--count-timeout", "0.2", "--format", "json", "--no-compiled"]
    )
    payload = json.loads(as_json.output)
    assert payload["selection_count"] is None and payload["uncounted"] == ["selection", "variant"]


def _never_answers(*_: object) -> None:
    import threading

    threading.Event().wait()  # until killed


def test_a_counter_that_fails_is_an_environment_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(analysis_module, "_count_here", _dies)
    with pytest.raises(CountFailed, match="stopped without an answer"):
        count_selections(read(feature("r")), timeout=30)
    result = CliRunner().invoke(main, ["analyse", str(SENSORBOT), "--no-compiled"])
    assert result.exit_code == 3 and "the model counter stopped without an answer" in result.output


def _dies(*_: object) -> None:
    import os

    os._exit(9)


def test_no_counts() -> None:
    result = CliRunner().invoke(main, ["analyse", str(SENSORBOT), "--no-counts"])
    assert result.exit_code == 0 and "selections" not in result.output


# ------------------------------------------------------------------------------ DIMACS
def read_dimacs(text: str) -> tuple[dict[int, str], int, list[list[int]], list[int] | None]:
    """Names, variable count, clauses and projection (`c p show`) of a DIMACS text."""
    names: dict[int, str] = {}
    shown: list[int] | None = None
    clauses: list[list[int]] = []
    variables = 0
    for line in text.splitlines():
        if line.startswith("c p show "):
            shown = [int(x) for x in line.split()[3:-1]]
        elif line.startswith("c "):
            number, _, name = line[2:].partition(" ")
            if number.isdigit():
                names[int(number)] = name
        elif line.startswith("p cnf "):
            variables, count = map(int, line.split()[2:])
        else:
            clause = [int(x) for x in line.split()]
            assert clause[-1] == 0
            clauses.append(clause[:-1])
    assert len(clauses) == count
    return names, variables, clauses, shown


COUNT = """
import json, sys
from pyganak import Counter
variables, clauses, shown = json.load(sys.stdin)
counter = Counter(verbose=0, seed=0)
counter.new_vars(variables)
counter.add_clauses(clauses)
if shown is not None:
    counter.set_sampling_set(shown)
print(counter.count())
sys.stdout.flush()
import os
os._exit(0)  # (as the product's counting child does: no C++ teardown at exit)
"""


def count_directly(variables: int, clauses: list[list[int]], shown: list[int] | None) -> int:
    """The count by Ganak itself, in a process of its own (never in pytest's: its C++ state
    is then not torn down with the interpreter's, which crashed one CI run at exit)."""
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-c", COUNT],
        input=json.dumps([variables, clauses, shown]),
        capture_output=True,
        text=True,
        check=True,
    )
    return int(done.stdout.split()[-1])  # (the counter may print lines of its own before)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=7))
def test_exported_dimacs_counts_as_the_analysis_and_brute_force(raw: dict[str, Any]) -> None:
    from motivml.binding.dimacs import selection_dimacs, variant_dimacs

    model = read(raw)
    names, variables, clauses, shown = read_dimacs(selection_dimacs(model))
    assert names == {k + 1: f for k, f in enumerate(ids_in_order(raw))}  # one per feature, pre-order
    assert shown is None
    expected = sum(1 for _ in ref.section_2_selections(raw))
    assert count_directly(variables, clauses, None) == expected  # plain: the extra variables are defined
    names, variables, clauses, shown = read_dimacs(variant_dimacs(model))
    assert shown is not None and len(shown) == 3 * len(ids_in_order(raw))
    assert count_directly(variables, clauses, shown) == sum(1 for _ in ref.valid_variants(raw, None))


def test_export_dimacs_command(tmp_path: Path) -> None:
    runner = CliRunner()
    target = tmp_path / "out" / "sensorbot.dimacs"
    result = runner.invoke(main, ["export", "dimacs", str(SENSORBOT.parent), "-o", str(target)])
    assert result.exit_code == 0 and result.output == f"  wrote {target}\n"
    names, variables, clauses, _ = read_dimacs(target.read_text())
    assert list(names.values()) == ["sensorbot", "slam", "sensors", "lidar", "camera", "sonar"]
    assert count_directly(variables, clauses, None) == 9
    again = runner.invoke(main, ["export", "dimacs", str(SENSORBOT), "-o", str(target)])
    assert again.output == f"  unchanged {target}\n"
    usage = runner.invoke(main, ["export", "scxml", str(SENSORBOT.parent), "--bindings"])
    assert usage.exit_code == 2 and "--bindings is for dimacs" in usage.output
    (tmp_path / "bad.json").write_text('{"id": "r", "name": "R", "formulas": ["nope"]}')
    bad = runner.invoke(
        main, ["export", "dimacs", str(tmp_path / "bad.json"), "-o", str(tmp_path / "bad.dimacs")]
    )
    assert bad.exit_code == 1 and "names unknown feature 'nope'" in bad.output
    assert not (tmp_path / "bad.dimacs").exists()


def test_the_progress_bar_shows_on_a_terminal_only_once_started(monkeypatch: pytest.MonkeyPatch) -> None:
    """The bar appears when its timer fires (after PROGRESS_AFTER seconds, here called at
    once), follows the steps, and is gone when the analysis ends; a timer that fires after
    the end draws nothing."""
    import io

    from rich.console import Console

    from motivml.cli import progress as analysing

    screen = io.StringIO()
    monkeypatch.setattr(analysing, "err", Console(file=screen, force_terminal=True, width=80))
    with analysing.ProgressBar(3) as bar:
        bar.step("first")
        bar._show()
        bar.step("second")
        assert bar.progress is not None
        (task,) = bar.progress.tasks
        assert (task.completed, task.description, task.total) == (1, "second", 3)
    assert bar.closed and bar.progress.finished is False  # stopped, not completed
    counted = analysing.ProgressBar(1)
    counted._show()
    counted.reached(40, 400)
    (task,) = counted.progress.tasks  # type: ignore[union-attr]
    assert (task.completed, task.total, task.description) == (40, 400, "combinations settled")
    counted.__exit__(None, None, None)
    late = analysing.ProgressBar(3)
    late.__exit__(None, None, None)
    late._show()
    assert late.progress is None
    assert "second" in screen.getvalue()


def test_bindings_inherited_from_a_parent_are_impossible_and_no_others() -> None:
    """impossible_bindings finds most without the solver: a feature is never Early below a
    feature that never is (Late only, or below one), never Static below one that never is.
    Only those: a Dynamic parent leaves its sub-feature's time free, a Late one its mode,
    and beside an inherited impossibility the other value stays possible."""

    def below(top: str, first: str, second: str, **allowed: str) -> dict[str, Any]:
        free = {"isMandatory": False, "time": "Any", "mode": "Any"}
        return feature(top, [feature(first, [feature(second, **free)], **free)], **{**free, **allowed})

    raw = feature("r", [below("late", "l1", "l2", time="Late"), below("dynamic", "d1", "d2", mode="Dynamic")])
    result = analyse(read(raw), counts=False)
    expected = [
        ("l1", "time", "Early"),
        ("l2", "time", "Early"),
        ("d1", "mode", "Static"),
        ("d2", "mode", "Static"),
    ]
    assert _brute_force_impossible(raw) == expected
    assert result.impossible == expected


def _brute_force_impossible(raw: dict[str, Any]) -> list[tuple[str, str, str]]:
    """The impossible bindings of `raw` in feature order, by enumeration (the reference)."""
    variants = list(ref.valid_variants(raw, None))
    allowed = _allowed(raw)
    found = []
    for f in ids_in_order(raw):
        if not any(f in v for v in variants):
            continue
        for aspect, values in (("time", ("Early", "Late")), ("mode", ("Static", "Dynamic"))):
            if allowed[f][aspect] != "Any":
                continue
            for value in values:
                flag = value in ("Early", "Static")
                index = 0 if aspect == "time" else 1
                if not any(f in v and v[f][index] == flag for v in variants):
                    found.append((f, aspect, value))
    return found


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=8))
def test_live_features_and_impossible_bindings_in_one_cover_equal_brute_force(raw: dict[str, Any]) -> None:
    assert_live_features_and_impossible_bindings_equal_brute_force(raw)


def assert_live_features_and_impossible_bindings_equal_brute_force(raw: dict[str, Any]) -> None:
    """validate's one search: the features some variant selects, and the bindings a live
    feature allows (Any) but no variant gives it; the first answer told once, as soon as
    it is known, and the same as returned."""
    from motivml.binding import encoding as enc

    variants = list(ref.valid_variants(raw, None))
    if not variants:
        return
    model = read(raw)
    told: list[list[bool]] = []
    with enc.Encoding(model) as hard:
        assert hard.solve(with_config=False)
        alive, impossible = analysis_module.live_features_and_impossible_bindings(hard, model, told.append)
    order = ids_in_order(raw)
    assert told == [alive]
    assert [f for f in order if alive[order.index(f)]] == [f for f in order if any(f in v for v in variants)]
    taken = {
        (f, aspect, value)
        for v in variants
        for f, (early, static) in v.items()
        for aspect, value in (("time", "Early" if early else "Late"), ("mode", "Static" if static else "Dynamic"))
    }
    allowed = _allowed(raw)
    assert {(model.features[i].id, aspect, str(value)) for i, aspect, value in impossible} == {
        (f, aspect, value)
        for f in order
        if any(f in v for v in variants)
        for aspect, values in (("time", ("Early", "Late")), ("mode", ("Static", "Dynamic")))
        if allowed[f][aspect] == "Any"
        for value in values
        if (f, aspect, value) not in taken
    }


def _selections_then_bindings(
    hard: Any, parents: list[int | None], apart: bool = False
) -> tuple[list[list[int]], list[int | None]]:
    """Each feature selected (requiring its `parents` entry's target), then each selected
    with each time and mode (and, with `apart`, without the next feature), each of those
    requiring its feature's selection."""
    n = len(parents)
    targets: list[list[int]] = [[hard.s(i)] for i in range(n)]
    requires: list[int | None] = list(parents)
    for i in range(n):
        others = (-hard.s((i + 1) % n),) if apart else ()
        for literal in (hard.E(i), -hard.E(i), hard.S(i), -hard.S(i), *others):
            targets.append([hard.s(i), literal])
            requires.append(i)
    return targets, requires


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=8))
def test_cover_with_requirements_answers_as_without(raw: dict[str, Any]) -> None:
    """Targets that require an earlier one (a binding its feature's selection), propagated
    only where `refute` says: every answer is the one of cover without them, and the first
    answers are told once, as they are."""
    from motivml.binding import encoding as enc

    model = read(raw)
    with enc.Encoding(model) as hard:
        if not hard.solve(with_config=False):
            return
        n = len(model.features)
        targets, requires = _selections_then_bindings(hard, [None] * n)
        plain = hard.cover(targets, with_config=False)
        told: list[list[bool]] = []
        for refute in (True, False, [k >= n for k in range(len(targets))]):
            answers = hard.cover(
                targets, with_config=False, batch=True, refute=refute, requires=requires, settled=(n, told.append)
            )
            assert answers == plain
    assert told == [plain[:n]] * 3


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(max_features=8), st.randoms(use_true_random=False))
def test_cover_in_another_order_answers_as_in_the_targets_own(raw: dict[str, Any], rnd: Any) -> None:
    """`order` changes which target is taken when, never an answer: any order of plain
    targets, and the analyses' own (alternatives apart, each selection after its parent's,
    the selections first) with requirements, implications and the first answers told."""
    from motivml.binding import encoding as enc

    model = read(raw)
    with enc.Encoding(model) as hard:
        if not hard.solve(with_config=False):
            return
        n = len(model.features)
        targets, requires = _selections_then_bindings(hard, [f.parent for f in model.features], apart=True)
        plain = hard.cover(targets, with_config=False)
        shuffled = list(range(len(targets)))
        rnd.shuffle(shuffled)
        assert hard.cover(targets, with_config=False, batch=True, order=shuffled) == plain
        later = list(range(n, len(targets)))
        rnd.shuffle(later)
        told: list[list[bool]] = []
        ordered = hard.cover(
            targets,
            with_config=False,
            batch=True,
            requires=requires,
            implied=requires,
            settled=(n, told.append),
            order=analysis_module.alternatives_apart(model, range(n)) + later,
        )
        assert ordered == plain
        assert told == [plain[:n]]


def test_the_first_answers_are_told_before_a_later_target_is_solved_for() -> None:
    """a is dead, but neither the first variant nor unit propagation says so (see the test
    of batches above); u is possible. With refute=False the answer for u is told, then a is
    solved for."""
    from motivml.binding import encoding as enc

    model = read(_DEAD_UNREFUTED)
    with enc.Encoding(model) as hard:
        s = {f.id: hard.s(f.index) for f in model.features}
        solves: list[bool] = []
        solve = hard.solver.solve

        def counted(assumptions: list[int]) -> bool:
            solves.append(bool(solve(assumptions=assumptions)))
            return solves[-1]

        hard.solver.solve = counted  # type: ignore[method-assign]
        told: list[tuple[list[bool], int]] = []
        answers = hard.cover(
            [[s["u"]], [s["a"]]], with_config=False, refute=False, settled=(1, lambda a: told.append((a, len(solves))))
        )
    assert answers == [True, False]
    [(shown, solved)] = told
    assert shown == [True] and solves[solved:] == [False]  # (a's solve came after)


def test_a_target_is_not_propagated_before_the_one_it_requires_is_shown() -> None:
    """a is dead but not refuted by propagation (above): its binding, which requires it,
    is impossible without being propagated or solved for."""
    from motivml.binding import encoding as enc

    raw = feature(
        "r",
        [feature("a", [feature("x", group="XOR"), feature("y", group="XOR")], isMandatory=False, time="Any")],
        formulas=["x <=> y"],
    )
    model = read(raw)
    with enc.Encoding(model) as hard:
        a = model.index["a"]
        asked: list[list[int]] = []
        propagate, solve = hard.solver.propagate, hard.solver.solve
        hard.solver.propagate = lambda assumptions: (asked.append(assumptions), propagate(assumptions=assumptions))[1]  # type: ignore[method-assign]
        hard.solver.solve = lambda assumptions: (asked.append(assumptions), solve(assumptions=assumptions))[1]  # type: ignore[method-assign]
        answers = hard.cover(
            [[hard.s(a)], [hard.s(a), hard.E(a)]], with_config=False, refute=[False, True], requires=[None, 0]
        )
    assert answers == [False, False]
    assert not any(hard.E(a) in assumptions for assumptions in asked)


@pytest.mark.parametrize("value", ["nan", "1e308", "2e6", "0", "-1", "-inf", "ten"])
def test_a_count_timeout_that_is_no_time_limit_is_a_usage_error(value: str) -> None:
    """Issue 31: nan, inf-like and huge limits made tracebacks (the system's poll takes at
    most 24 days); each is now refused as a usage error, exit 2, naming the option."""
    result = CliRunner().invoke(
        main, ["analyse", str(ROOT / "feature_models" / "simplebot"), "--count-timeout", value]
    )
    assert result.exit_code == 2, result.output
    assert "--count-timeout" in result.output and "Traceback" not in result.output


def test_a_count_timeout_of_inf_counts_without_a_limit() -> None:
    result = CliRunner().invoke(
        main, ["analyse", str(ROOT / "feature_models" / "simplebot"), "--count-timeout", "inf", "--format", "json"]
    )
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["variant_count"] == analyse(read_simplebot(), counts=True).variant_count


def read_simplebot() -> Any:
    from motivml.language.reader import load_model

    model, _ = load_model(str(ROOT / "feature_models" / "simplebot" / "model.json"))
    return model


@pytest.mark.parametrize(("terminal", "shown", "started"), [(True, True, True), (False, True, False), (True, False, False)])
def test_the_progress_bar_waits_on_a_terminal_only_and_never_for_json(
    monkeypatch: pytest.MonkeyPatch, terminal: bool, shown: bool, started: bool
) -> None:
    """Issue 33: a bar on a terminal's stderr, nothing on a pipe or with --format json (analyse
    passes shown=False then); import, export, configure and sample use the same bar."""
    import io

    from rich.console import Console

    from motivml.cli import progress

    monkeypatch.setattr(progress, "err", Console(file=io.StringIO(), force_terminal=terminal, width=80))
    with progress.ProgressBar(2, shown=shown) as bar:
        assert bar.timer.is_alive() == started or (started and bar.timer.finished.is_set())
    assert not bar.timer.is_alive() or bar.timer.finished.is_set()

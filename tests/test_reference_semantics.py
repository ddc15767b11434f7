"""Checks tests/reference_semantics.py against the specification (guidelines/reference.md).

Section 5 test vectors: every one of the 16 binding combinations of each row, valid ones and
invalid ones, as its own case.  Then a few single-sentence checks, and a cross-check of the
reference's pruning solver against plain exhaustive enumeration on small random models.
"""

from __future__ import annotations

import itertools
import os
import random
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))

import reference_semantics as ref  # noqa: E402

BINDINGS = {
    "SE": ("Early", "Static"),
    "SL": ("Late", "Static"),
    "DE": ("Early", "Dynamic"),
    "DL": ("Late", "Dynamic"),
}
NAMES = list(BINDINGS)  # SE, SL, DE, DL


# ---------------------------------------------------------------------------------------
# Section 5: "each a two-feature model under an always-selected root, both features
# selected, both optional (`isMandatory: false` unless the row says mandatory), both
# allowing `Any`"
# ---------------------------------------------------------------------------------------


def feature(fid, sub=(), group="", mandatory=False, includes=(), excludes=()):
    return {
        "id": fid,
        "name": fid.upper(),
        "group": group,
        "isMandatory": mandatory,
        "constraints": {
            "featuresIncluded": list(includes),
            "featuresExcluded": list(excludes),
            "bindingTimeAllowed": "Any",
            "bindingModeAllowed": "Any",
        },
        "sub": list(sub),
    }


def root(*sub):
    # The root keeps the defaults: selected, Early, Static.
    return {"id": "root", "name": "Root", "isSelected": True, "sub": list(sub)}


def complete_config(first, second, a="a", b="b"):
    """Selects both features with the given bindings (a complete configuration)."""
    return {
        "properties": [
            {"id": a, "props": {"time": BINDINGS[first][0], "mode": BINDINGS[first][1]}},
            {"id": b, "props": {"time": BINDINGS[second][0], "mode": BINDINGS[second][1]}},
        ]
    }


RELATIONS = {
    # 3.1 table: "X requires Y", here as X includes Y
    "X includes Y": root(feature("a", includes=["b"]), feature("b")),
    "parent -> optional ungrouped child": root(feature("a", sub=[feature("b")])),
    "parent -> mandatory child": root(feature("a", sub=[feature("b", mandatory=True)])),
    "A excludes B": root(feature("a", excludes=["b"]), feature("b")),
    "A, B in one XOR group": root(feature("a", group="XOR"), feature("b", group="XOR")),
}

# The valid (first, second) pairs, copied from section 5.
VALID = {
    # | X \ Y | SE | SL | DE | DL |
    # | SE    | ok | no | no | no |
    # | SL    | ok | ok | no | no |
    # | DE    | ok | no | no | no |
    # | DL    | ok | ok | no | no |
    "X includes Y": {("SE", "SE"), ("SL", "SE"), ("SL", "SL"), ("DE", "SE"), ("DL", "SE"), ("DL", "SL")},
    # SE→any; SL→SL, SL→DL; DE→DE, DE→DL; DL→DL
    "parent -> optional ungrouped child": {("SE", y) for y in NAMES}
    | {("SL", "SL"), ("SL", "DL"), ("DE", "DE"), ("DE", "DL"), ("DL", "DL")},
    # SE→SE, SL→SL, DE→DE, DL→DL
    "parent -> mandatory child": {(x, x) for x in NAMES},
    # DE/DL, DL/DE, DL/DL
    "A excludes B": {("DE", "DL"), ("DL", "DE"), ("DL", "DL")},
    "A, B in one XOR group": {("DE", "DL"), ("DL", "DE"), ("DL", "DL")},
}

CASES = [
    pytest.param(
        relation,
        first,
        second,
        (first, second) in VALID[relation],
        id=f"{relation}: {first}->{second} {'ok' if (first, second) in VALID[relation] else 'no'}",
    )
    for relation in RELATIONS
    for first in NAMES
    for second in NAMES
]


def test_sixteen_cases_per_row():
    assert len(CASES) == 5 * 16


@pytest.mark.parametrize("relation, first, second, expected", CASES)
def test_section_5_vector(relation, first, second, expected):
    model = RELATIONS[relation]
    config = complete_config(first, second)
    assert ref.is_valid(model, config) is expected
    # A complete configuration has exactly one variant, or none.
    variants = list(ref.valid_variants(model, config))
    assert len(variants) == (1 if expected else 0)
    if expected:
        e1, s1 = BINDINGS[first]
        e2, s2 = BINDINGS[second]
        assert variants[0] == {
            "root": ref.SE,
            "a": (e1 == "Early", s1 == "Static"),
            "b": (e2 == "Early", s2 == "Static"),
        }


# ---------------------------------------------------------------------------------------
# Single sentences of the spec
# ---------------------------------------------------------------------------------------


def test_defaults_mandatory_early_static():
    # "isMandatory ... default true"; bindingTimeAllowed default Early, Mode default Static.
    model = {"id": "r", "name": "R", "sub": [{"id": "f", "name": "F"}]}
    assert list(ref.valid_variants(model, None)) == [{"r": ref.SE, "f": ref.SE}]
    late = {"properties": [{"id": "f", "props": {"time": "Late"}}]}
    assert not ref.is_valid(model, late)
    assert not ref.is_valid(model, {"properties": [{"id": "f", "selected": False}]})


def test_undecided_features_are_free():
    model = root(feature("a"))
    # a unselected, or selected with any of 4 bindings (optional child of an SE root).
    assert ref.count_valid_variants(model, None) == 5
    assert ref.count_valid_variants(model, {"properties": []}) == 5
    assert ref.count_valid_variants(model, {"properties": [{"id": "a"}]}) == 4
    only_time = {"properties": [{"id": "a", "props": {"time": "Late", "mode": "Any"}}]}
    assert ref.count_valid_variants(model, only_time) == 2


def test_props_of_deselected_feature_are_irrelevant():
    model = root(feature("a"))
    config = {"properties": [{"id": "a", "selected": False, "props": {"time": "Late", "mode": "Dynamic"}}]}
    assert list(ref.valid_variants(model, config)) == [{"root": ref.SE}]


def test_root_entry_can_only_say_static_early():
    model = root()
    assert ref.is_valid(model, {"properties": [{"id": "root", "props": {"time": "Early"}}]})
    assert not ref.is_valid(model, {"properties": [{"id": "root", "props": {"time": "Late"}}]})
    assert not ref.is_valid(model, {"properties": [{"id": "root", "selected": False}]})


def test_one_member_group_is_an_ungrouped_child_with_its_own_is_mandatory():
    lone = root(feature("a", group="XOR", mandatory=True))
    assert list(ref.valid_variants(lone, {"properties": [{"id": "a", "selected": False}]})) == []
    # ... and 3.1 applies to it: a Static Early parent requires it Static Early.
    assert [v["a"] for v in ref.valid_variants(lone, None)] == [ref.SE]
    optional = root(feature("a", group="OR", mandatory=False))
    assert ref.count_valid_variants(optional, None) == 5


def test_is_mandatory_of_grouped_member_is_ignored():
    model = root(feature("a", group="OR", mandatory=True), feature("b", group="OR", mandatory=True))
    config = {
        "properties": [
            {"id": "a", "props": {"time": "Late", "mode": "Static"}},
            {"id": "b", "selected": False},
        ]
    }
    assert ref.is_valid(model, config)


def test_or_group_needs_a_selected_member():
    model = root(feature("a", group="OR"), feature("b", group="OR"))
    none = {"properties": [{"id": "a", "selected": False}, {"id": "b", "selected": False}]}
    assert not ref.is_valid(model, none)
    both = complete_config("SE", "SL")
    assert ref.is_valid(model, both)


def test_start_state_must_exist():
    # XOR {a, b} both DL under the root: the root is active, so exactly one of them must
    # be active at start.  e and f are Early (hence active) and exclude a and b: no start
    # state, although every rule of sections 2 and 3 holds.
    model = root(
        feature("a", group="XOR"),
        feature("b", group="XOR"),
        feature("e", excludes=["a"]),
        feature("f", excludes=["b"]),
    )
    selection = {"root": ref.SE, "a": ref.DL, "b": ref.DL, "e": ref.DE, "f": ref.DE}
    assert not ref.start_state_exists(model, selection)
    config = {
        "properties": [
            {"id": k, "props": {"time": "Early" if v[0] else "Late", "mode": "Static" if v[1] else "Dynamic"}}
            for k, v in selection.items()
            if k != "root"
        ]
    }
    assert not ref.is_valid(model, config)
    # With f Late instead, b can be the active one.
    assert ref.start_state_exists(model, {**selection, "f": ref.DL})


def test_start_state_is_section_2_strictly_over_active_features():
    # An active feature pulls in what it includes; Late features may stay inactive.
    model = root(feature("a", includes=["b"]), feature("b"))
    assert ref.start_state_exists(model, {"root": ref.SE, "a": ref.SL, "b": ref.SL})
    assert not ref.start_state_exists(model, {"root": ref.SE, "a": ref.SE})
    # The root is active, so its mandatory child must be active, hence selected.
    mandatory = root(feature("a", mandatory=True))
    assert ref.start_state_exists(mandatory, {"root": ref.SE, "a": ref.SL})
    assert not ref.start_state_exists(mandatory, {"root": ref.SE})
    # Excluded features never both active, even Dynamic ones with at most one Early.
    excl = root(feature("a", excludes=["b"]), feature("b"))
    assert ref.start_state_exists(excl, {"root": ref.SE, "a": ref.DE, "b": ref.DL})
    assert not ref.start_state_exists(excl, {"root": ref.SE, "a": ref.DE, "b": ref.DE})


@pytest.mark.parametrize(
    "bad",
    [
        {"id": "r", "name": "R", "group": "xor"},  # wrong case
        {"id": "r", "name": "R", "isMandatroy": True},  # unknown key
        {"id": "r", "name": "R", "constraints": {"bindingTimeAllowed": "early"}},
        {"id": "r", "name": "R", "sub": [{"id": "r", "name": "Again"}]},  # duplicate id
        {"id": "r", "name": "R", "constraints": {"featuresIncluded": ["nope"]}},
    ],
)
def test_meaningless_models_raise(bad):
    with pytest.raises(ValueError):
        ref.is_valid(bad, None)


def test_x_keys_are_ignored():
    assert ref.is_valid({"id": "r", "name": "R", "x-layout": [1, 2]}, None)


@pytest.mark.parametrize(
    "bad",
    [
        {"properties": [{"id": "nope"}]},
        {"properties": [{"id": "a"}, {"id": "a"}]},
        {"properties": [{"id": "a", "props": {"time": "late"}}]},
    ],
)
def test_meaningless_configs_raise(bad):
    with pytest.raises(ValueError):
        ref.is_valid(root(feature("a")), bad)


# ---------------------------------------------------------------------------------------
# The pruning solver against exhaustive enumeration (same rules, no pruning)
# ---------------------------------------------------------------------------------------


def random_model(rng: random.Random, n: int, any_bindings: bool) -> dict:
    features = [{"id": "f0", "name": "F0", "sub": []}]
    for i in range(1, n):
        f = {"id": f"f{i}", "name": f"F{i}", "sub": []}
        if rng.random() < 0.8:
            f["group"] = rng.choice(["", "", "OR", "XOR"])
        if rng.random() < 0.8:
            f["isMandatory"] = rng.random() < 0.4
        constraints = {}
        if any_bindings:
            constraints["bindingTimeAllowed"] = "Any"
            constraints["bindingModeAllowed"] = "Any"
        else:
            if rng.random() < 0.8:
                constraints["bindingTimeAllowed"] = rng.choice(["Early", "Late", "Any", "Any"])
            if rng.random() < 0.8:
                constraints["bindingModeAllowed"] = rng.choice(["Static", "Dynamic", "Any", "Any"])
        f["constraints"] = constraints
        rng.choice(features)["sub"].append(f)
        features.append(f)
    for f in features:
        others = [g["id"] for g in features if g is not f]
        if others and rng.random() < 0.25:
            f.setdefault("constraints", {})["featuresIncluded"] = [rng.choice(others)]
        if others and rng.random() < 0.25:
            f.setdefault("constraints", {})["featuresExcluded"] = [rng.choice(others)]
    return features[0]


def brute_force_variants(model: dict, config: dict | None) -> list[dict]:
    """The same rules, checked on every assignment, and the start state checked per
    selection by trying every subset of its Late features (no pruning, no joint search)."""
    parsed = ref._Model(model)
    rules = ref._variant_rules(parsed, ref._parse_config(config, parsed))
    start_rules = ref._start_state_rules(parsed)
    ids = list(parsed.features)
    found = []
    for values in itertools.product(ref._VARIANT_VALUES, repeat=len(ids)):
        v = dict(zip(ids, values, strict=True))
        if not all(r.holds({x: v[x] for x in r.scope}) for r in rules):
            continue
        selection = {f: x for f, x in v.items() if x is not None}
        late = [f for f, x in selection.items() if not x[0]]
        for active_late in itertools.product([False, True], repeat=len(late)):
            active = {f for f, x in selection.items() if x[0]}
            active |= {f for f, on in zip(late, active_late, strict=True) if on}
            full = v | {ref._a(f): f in active for f in ids}
            if all(r.holds({x: full[x] for x in r.scope}) for r in start_rules):
                assert ref.start_state_exists(model, selection)
                found.append(selection)
                break
        else:
            assert not ref.start_state_exists(model, selection)
    return found


def random_config(rng: random.Random, model: dict) -> dict | None:
    if rng.random() < 0.4:
        return None
    ids = list(ref._Model(model).features)
    entries = []
    for fid in rng.sample(ids, rng.randint(0, len(ids))):
        entry = {"id": fid}
        if rng.random() < 0.3:
            entry["selected"] = rng.random() < 0.6
        if rng.random() < 0.7:
            entry["props"] = {
                "time": rng.choice(["Early", "Late", "Any"]),
                "mode": rng.choice(["Static", "Dynamic", "Any"]),
            }
        entries.append(entry)
    return {"properties": entries}


@pytest.mark.parametrize("seed", range(80))
def test_solver_matches_exhaustive_enumeration(seed):
    rng = random.Random(seed)
    model = random_model(rng, rng.randint(2, 5), any_bindings=rng.random() < 0.5)
    config = random_config(rng, model)
    key = lambda s: sorted(s.items())  # noqa: E731
    expected = sorted(brute_force_variants(model, config), key=key)
    assert sorted(ref.valid_variants(model, config), key=key) == expected
    assert ref.count_valid_variants(model, config) == len(expected)
    assert ref.is_valid(model, config) is bool(expected)


# ---------------------------------------------------------------------------------------
# Statements, start states, completion costs
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(80))
def test_all_statements_together_mean_validity(seed):
    rng = random.Random(seed)
    model = random_model(rng, rng.randint(2, 5), any_bindings=rng.random() < 0.5)
    config = random_config(rng, model)
    statements = ref.model_statements(model) + ref.config_statements(model, config)
    assert ref.consistent(model, statements) is ref.is_valid(model, config)


def test_statements_left_out_are_not_in_force():
    model = root(feature("a", includes=["b"]), feature("b"))
    config = {"properties": [{"id": "a"}, {"id": "b", "props": {"mode": "Dynamic"}}]}
    statements = ref.model_statements(model) + ref.config_statements(model, config)
    assert ("includes", "a", "b") in statements and ("mode", "b", "Dynamic") in statements
    assert not ref.consistent(model, statements)
    assert ref.consistent(model, [s for s in statements if s != ("includes", "a", "b")])
    # 3.1 alone: a selected a requires a Static b; b Dynamic only if not selected.
    conflict = [("includes", "a", "b"), ("selected", "a"), ("mode", "b", "Dynamic")]
    assert not ref.consistent(model, conflict)
    assert ref.consistent(model, conflict[:2]) and ref.consistent(model, conflict[1:])


def test_xor_exactly_one_active_is_the_group_and_its_pairs():
    # Both Dynamic Late under the root: selectable together, one active at start.
    model = root(feature("a", group="XOR"), feature("b", group="XOR"))
    config = complete_config("DL", "DL")
    facts = ref.config_statements(model, config) + [("root",), ("start",), ("sub", "a"), ("sub", "b")]
    assert ref.consistent(model, facts + [("group", "root", "XOR"), ("alternatives", "a", "b")])
    early = ref.config_statements(model, complete_config("DE", "DE"))
    assert not ref.consistent(model, early + [("start",), ("alternatives", "a", "b")])
    assert ref.consistent(model, early + [("start",)])
    # The group statement makes one of them active: with a third, Early, alternative that
    # excludes both, no start state is left.
    three = root(feature("a", group="XOR"), feature("b", group="XOR"), feature("c", excludes=["a", "b"]))
    facts = ref.config_statements(three, complete_config("DL", "DL")) + [
        ("selected", "c"),
        ("time", "c", "Early"),
    ]
    facts += [("root",), ("start",), ("excludes", "c", "a"), ("excludes", "c", "b")]
    assert ref.consistent(three, facts)
    assert not ref.consistent(three, facts + [("group", "root", "XOR")])


def test_unknown_statements_raise():
    model = root(feature("a"))
    for bad in [("nope",), ("selected", "zz"), ("time", "a", "Soon"), ("group", "root", "OR")]:
        with pytest.raises(ValueError):
            ref.consistent(model, [bad])


def test_start_state_fewest_late_then_first_in_definition_order():
    # XOR {a, b, c} of Late Dynamic features under the root: one of them must be active,
    # the first one is.  d (Late, optional) stays inactive.
    model = root(
        feature("a", group="XOR"), feature("b", group="XOR"), feature("c", group="XOR"), feature("d")
    )
    selection = {"root": ref.SE, "a": ref.DL, "b": ref.DL, "c": ref.DL, "d": ref.SL}
    assert sorted(map(sorted, ref.start_states(model, selection))) == [
        ["a", "d", "root"],
        ["a", "root"],
        ["b", "d", "root"],
        ["b", "root"],
        ["c", "d", "root"],
        ["c", "root"],
    ]
    assert ref.preferred_start_state(model, selection) == ["root", "a"]
    # b Early: it must be active, and then neither a nor c can be.
    assert ref.preferred_start_state(model, {**selection, "b": ref.DE}) == ["root", "b"]
    # An OR group of Late features: one member (the first) rather than two.
    either = root(feature("a", group="OR"), feature("b", group="OR"))
    assert ref.preferred_start_state(either, {"root": ref.SE, "a": ref.SL, "b": ref.SL}) == ["root", "a"]
    # Fewest Late activations beat definition order: a needs b and c, d alone is enough.
    heavy = root(
        feature("a", group="OR", includes=["b"]),
        feature("d", group="OR"),
        feature("b", includes=["c"]),
        feature("c"),
    )
    late = {"root": ref.SE, "a": ref.SL, "b": ref.SL, "c": ref.SL, "d": ref.SL}
    assert ref.preferred_start_state(heavy, late) == ["root", "d"]
    assert ref.preferred_start_state(heavy, {**late, "d": ref.DL, "c": ref.SE}) == ["root", "d", "c"]
    # No start state: two excluded Early features.
    excl = root(feature("a", excludes=["b"]), feature("b"))
    assert ref.preferred_start_state(excl, {"root": ref.SE, "a": ref.DE, "b": ref.DE}) is None


def test_completion_cost_counts_the_wishes_in_order():
    model = root(feature("a"), feature("b"))
    config = {"properties": [{"id": "a", "props": {"time": "Late", "mode": "Any"}}]}
    variant = {"root": ref.SE, "a": ref.DL, "b": ref.SL}
    # b undecided and selected; b's time Late (open) and a's fixed; a's mode Dynamic (open).
    assert ref.completion_cost(model, config, variant) == (1, 1, 1)
    assert ref.completion_cost(model, config, variant, ("late",)) == (1, 0, 1)
    assert ref.completion_cost(model, config, variant, ("late", "dynamic")) == (1, 0, 1)
    assert ref.completion_cost(model, config, {"root": ref.SE, "a": ref.SL}) == (0, 0, 0)
    with pytest.raises(ValueError):
        ref.completion_cost(model, config, variant, ("fast",))


def test_active_set_is_section_2_strictly():
    model = root(
        feature("a", group="XOR"),
        feature("b", group="XOR"),
        feature("c", mandatory=True, includes=["d"]),
        feature("d", excludes=["e"]),
        feature("e"),
    )
    ok = {"root", "a", "c", "d"}
    assert ref.active_set_satisfies_section_2(model, ok)
    assert not ref.active_set_satisfies_section_2(model, ok - {"root"})  # the root is always active
    assert not ref.active_set_satisfies_section_2(model, ok | {"b"})  # exactly one XOR member
    assert not ref.active_set_satisfies_section_2(model, ok - {"a"})
    assert not ref.active_set_satisfies_section_2(model, ok - {"c"})  # a mandatory child
    assert not ref.active_set_satisfies_section_2(model, ok - {"d"})  # what c includes
    assert not ref.active_set_satisfies_section_2(model, ok | {"e"})  # d excludes e
    with pytest.raises(ValueError):
        ref.active_set_satisfies_section_2(model, {"root", "zz"})

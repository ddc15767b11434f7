"""Run-time reconfiguration (reference.md section 4): every refusal reason, and brute force."""

from __future__ import annotations

import json
from itertools import combinations
from typing import Any

import pytest
import reference_semantics as ref
from helpers import config, feature
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motivml.binding.resolve import NoVariant, resolve, start_state
from motivml.documents.loader import parse
from motivml.errors import repair_text
from motivml.language.model import FeatureModel
from motivml.language.reader import read_configuration, read_model
from motivml.runtime.reconfigure import Plan, Reconfigurer, Refused
from motivml.runtime.requests import Load, Reload, Set, Swap, Unload, change
from tests.test_property_sat import configurations, formula_texts, models

ANY = {"time": "Any", "mode": "Any"}
MODEL = feature(
    "bot",
    [
        feature("base", isMandatory=True, time="Early", mode="Static"),
        feature(
            "slam",
            [feature("hector", group="XOR", **ANY), feature("karto", group="XOR", **ANY)],
            isMandatory=False,
            **ANY,
        ),
        feature("logger", isMandatory=False, **ANY),
        feature("camera", isMandatory=False, **ANY),
        feature("lidar", isMandatory=False, exc=["sonar"], **ANY),
        feature("sonar", isMandatory=False, **ANY),
        feature(
            "gestures", [feature("hands", isMandatory=True, **ANY)], isMandatory=False, inc=["camera"], **ANY
        ),
        feature("unused", isMandatory=False, **ANY),
    ],
)
VARIANT = config(
    ("base", "Early", "Static"),
    ("slam", "Late", "Dynamic"),
    ("hector", "Late", "Dynamic"),
    ("karto", "Late", "Dynamic"),
    ("logger", "Late", "Static"),
    ("camera", "Late", "Static"),
    ("lidar", "Early", "Dynamic"),
    ("sonar", "Late", "Dynamic"),
    ("gestures", "Late", "Dynamic"),
    ("hands", "Late", "Dynamic"),
    ("unused", False),
)


@pytest.fixture
def robot() -> tuple[Reconfigurer, set[str]]:
    model, _ = read_model(parse(json.dumps(MODEL, indent=1), "model.json"))
    configuration, problems = read_configuration(parse(json.dumps(VARIANT, indent=1), "v.json"), model)
    assert not problems
    variant = resolve(model, configuration)
    return Reconfigurer(variant, configuration), {f.id for f in start_state(variant)}


def refused(robot: tuple[Reconfigurer, set[str]], *requests: str) -> Refused:
    """Apply requests in turn; the last must be refused: its refusal."""
    reconfigurer, active = robot
    for text in requests[:-1]:
        action, *features = text.split()
        active = set(reconfigurer.plan(active, change(action, features)).after)
    action, *features = requests[-1].split()
    with pytest.raises(Refused) as refusal:
        reconfigurer.plan(active, change(action, features))
    return refusal.value


def refusal(robot: tuple[Reconfigurer, set[str]], *requests: str) -> str:
    """Apply requests in turn; the last must be refused: its first message."""
    d = refused(robot, *requests).diagnostics[0]
    return f"{d.location.path}: {d.message}"


def test_the_start_state_and_accepted_requests(robot: tuple[Reconfigurer, set[str]]) -> None:
    reconfigurer, active = robot
    assert active == {"bot", "base", "lidar"}
    plan = reconfigurer.plan(active, Load(("slam", "hector")))
    assert plan.loads == ("slam", "hector") and plan.unloads == ()
    swap = reconfigurer.plan(plan.after, Swap("hector", "karto"))
    assert swap.after == {"bot", "base", "lidar", "slam", "karto"}
    camera = reconfigurer.plan(swap.after, Load(("camera",)))
    unit = reconfigurer.plan(camera.after, Load(("gestures",)))
    assert unit.loads == ("gestures", "hands")  # a Dynamic feature and its mandatory children
    subtree = reconfigurer.plan(unit.after, Unload(("slam",)))
    assert subtree.unloads == ("karto", "slam")  # children first
    reload = reconfigurer.plan(subtree.after, Reload(("lidar",)))
    assert reload.after == subtree.after and reload.loads == reload.unloads == ("lidar",)



def test_a_set_request_loads_and_unloads_in_one_reconfiguration(robot: tuple[Reconfigurer, set[str]]) -> None:
    """What one ROS parameter call asks: features on and off together, checked as one."""
    reconfigurer, active = robot
    slam = reconfigurer.plan(active, Set(("slam", "hector"), ()))
    both = reconfigurer.plan(slam.after, Set(("karto", "sonar"), ("hector", "lidar")))
    assert both.loads == ("karto", "sonar") and both.unloads == ("lidar", "hector")  # reverse definition order
    assert both.after == {"bot", "base", "slam", "karto", "sonar"}
    assert str(both.request) == "set +karto +sonar -hector -lidar"
    with pytest.raises(Refused) as xor:  # karto alone would leave slam's XOR group with two members
        reconfigurer.plan(slam.after, Set(("karto",), ()))
    assert xor.value.breaks_relations
    with pytest.raises(Refused) as twice:
        reconfigurer.plan(slam.after, Set(("karto",), ("karto",)))
    assert twice.value.diagnostics[0].message == "karto cannot be loaded and unloaded in one request"
    with pytest.raises(Refused) as nothing:
        reconfigurer.plan(slam.after, Set((), ()))
    assert nothing.value.diagnostics[0].rule == "reconfigure.usage"


REFUSALS = {
    "unknown feature": (["load hectr"], "$: no feature 'hectr' in the model (did you mean 'hector'?)"),
    "not selected": (
        ["load unused"],
        "$.properties[10]: unused is not selected in the variant: only selected features load (section 4)",
    ),
    "Static Early never unloads": (
        ["unload base"],
        "$.properties[0].props.mode: base is bound Static Early: a Static feature never unloads or reloads; it is compiled in (section 4)",
    ),
    "Static Late stays once loaded": (
        ["load logger", "unload logger"],
        "$.properties[4].props.mode: logger is bound Static Late: a Static feature never unloads or reloads; a Static Late feature stays once it is loaded (section 4)",
    ),
    "only an active feature unloads": (
        ["unload sonar"],
        "$.properties[7]: sonar is not active: there is nothing to unload",
    ),
    "already active": (["load lidar"], "$.properties[6]: lidar is already active"),
    "parent inactive": (
        ["load hector"],
        "$.properties[2]: hector is a sub-feature of slam, which is not active: load slam in the same request (section 4)",
    ),
    "XOR: exactly one": (
        ["load slam hector", "load karto"],
        "$.sub[1].sub[1].group: hector and karto are alternatives in slam's XOR group, but hector would be active and karto would be active: at every moment the active set has every active parent's mandatory sub-features, one active member of each of its groups (exactly one for XOR), every feature an active feature includes, and no two active features that exclude each other (section 4)",
    ),
    "XOR: at least one": (
        ["load slam"],
        "$.sub[1].sub[0].group: slam has the XOR group hector, karto, but slam would be active, hector would be inactive and karto would be inactive: at every moment the active set has every active parent's mandatory sub-features, one active member of each of its groups (exactly one for XOR), every feature an active feature includes, and no two active features that exclude each other (section 4)",
    ),
    "excludes": (
        ["load sonar"],
        "$.sub[4].constraints.featuresExcluded[0]: lidar excludes sonar, but lidar would be active and sonar would be active: at every moment the active set has every active parent's mandatory sub-features, one active member of each of its groups (exactly one for XOR), every feature an active feature includes, and no two active features that exclude each other (section 4)",
    ),
    "includes": (
        ["load gestures"],
        "$.sub[6].constraints.featuresIncluded[0]: gestures includes camera, but gestures would be active and camera would be inactive: at every moment the active set has every active parent's mandatory sub-features, one active member of each of its groups (exactly one for XOR), every feature an active feature includes, and no two active features that exclude each other (section 4)",
    ),
    "mandatory": (
        ["load camera", "load gestures", "unload hands"],
        "$.sub[6].sub[0].isMandatory: hands is a mandatory sub-feature of gestures, but gestures would be active and hands would be inactive: at every moment the active set has every active parent's mandatory sub-features, one active member of each of its groups (exactly one for XOR), every feature an active feature includes, and no two active features that exclude each other (section 4)",
    ),
}


@pytest.mark.parametrize("case", list(REFUSALS))
def test_refusal(robot: tuple[Reconfigurer, set[str]], case: str) -> None:
    requests, expected = REFUSALS[case]
    assert refusal(robot, *requests) == expected


def test_a_refusal_changes_nothing(robot: tuple[Reconfigurer, set[str]]) -> None:
    reconfigurer, active = robot
    before = set(active)
    with pytest.raises(Refused):
        reconfigurer.plan(active, Swap("lidar", "unused"))
    assert active == before


# --------------------------------------------------------------------------- brute force
class Reference:
    """Section 4's reconfiguration rules read directly; section 2 over the active set is the
    brute-force reference's (reference_semantics.active_set_satisfies_section_2)."""

    def __init__(
        self, raw: dict[str, Any], model: FeatureModel, selected: dict[str, tuple[bool, bool]]
    ) -> None:
        self.raw = raw
        self.model = model
        self.selected = selected  # id -> (early, static) for selected features

    def subtree(self, f: str) -> set[str]:
        return {self.model.features[i].id for i in self.model.subtree(self.model.index[f])}

    def unit(self, f: str) -> set[str]:
        out, todo = set(), [f]
        while todo:
            g = todo.pop()
            out.add(g)
            for c in self.model[g].children:
                child = self.model.features[c]
                if child.mandatory and child.id in self.selected:
                    todo.append(child.id)
        return out

    def apply(self, active: set[str], action: str, features: tuple[str, ...]) -> set[str] | None:
        unloads = features[:1] if action == "swap" else features if action in ("unload", "reload") else ()
        loads = features[1:] if action == "swap" else features if action == "load" else ()
        return self.apply_set(active, loads, unloads, reload=action == "reload")

    def apply_set(
        self, active: set[str], loads: tuple[str, ...], unloads: tuple[str, ...], reload: bool = False
    ) -> set[str] | None:
        """The active set after unloading `unloads` and loading `loads` in one request."""
        for f in unloads:
            if f not in active or self.selected[f][1]:
                return None
        if reload:
            return set(active)
        gone = set().union(*(self.subtree(f) for f in unloads)) & active if unloads else set()
        rest = active - gone
        for f in loads:
            if f not in self.selected or f in rest:
                return None
        new = set().union(*(self.unit(f) for f in loads)) if loads else set()
        after = rest | new
        for f in new:
            parent = self.model[f].parent
            if parent is not None and self.model.features[parent].id not in after:
                return None
        return after if ref.active_set_satisfies_section_2(self.raw, after) else None


@st.composite
def run_time_models(draw: st.DrawFn, n_max: int = 9) -> dict[str, Any]:
    """Models with room for the run time: optional features with open bindings, OR/XOR
    groups, a few mandatory sub-features, excludes, sometimes a formula; includes rarely (they
    force Static)."""
    n = draw(st.integers(3, n_max))
    ids = [f"f{i}" for i in range(n)]
    nodes: list[dict[str, Any]] = [{"id": "f0", "name": "F0"}]
    for i in range(1, n):
        others = [x for x in ids[1:] if x != ids[i]]
        node: dict[str, Any] = {
            "id": ids[i],
            "name": ids[i].upper(),
            "group": draw(st.sampled_from(["", "", "OR", "XOR", "XOR"])),
            "isMandatory": draw(st.sampled_from([False, False, False, True])),
            "constraints": {
                "bindingTimeAllowed": draw(st.sampled_from(["Any", "Any", "Any", "Late", "Early"])),
                "bindingModeAllowed": draw(st.sampled_from(["Any", "Any", "Any", "Dynamic", "Static"])),
                "featuresExcluded": draw(st.lists(st.sampled_from(others), max_size=1))
                if draw(st.integers(0, 3)) == 0
                else [],
                "featuresIncluded": draw(st.lists(st.sampled_from(others), max_size=1))
                if draw(st.integers(0, 5)) == 0
                else [],
            },
        }
        nodes[draw(st.integers(0, i - 1))].setdefault("sub", []).append(node)
        nodes.append(node)
    if draw(st.integers(0, 3)) == 0:  # a formula (rule 2.4) holds over the active set too
        nodes[0]["formulas"] = [draw(formula_texts(ids[1:]))]
    return nodes[0]


def started(
    raw: dict[str, Any], document: dict[str, Any] | None
) -> tuple[FeatureModel, Any, Reference, set[str]] | None:
    """The model, its variant resolved as late and dynamic as it may be (from `document`, or
    selecting every feature with open bindings), the brute-force reference of its run time
    and its start state; None when there is no such variant."""
    model, _ = read_model(parse(json.dumps(raw), "model.json"))
    if document is None:
        document = {
            "properties": [{"id": f.id, "props": {"time": "Any", "mode": "Any"}} for f in model.features[1:]]
        }
    configuration, _ = read_configuration(parse(json.dumps(document), "v.json"), model, partial=True)
    try:
        variant = resolve(model, configuration, ("late", "dynamic"))
    except NoVariant:
        return None
    selected = {d.feature.id: (d.binding.early, d.binding.static) for d in variant.selected()}
    return model, variant, Reference(raw, model, selected), {f.id for f in start_state(variant)}


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_any_request_sequence_matches_brute_force_and_stays_valid(data: st.DataObject) -> None:
    raw: dict[str, Any] = data.draw(
        models(max_features=8) if data.draw(st.integers(0, 3)) == 0 else run_time_models()
    )
    # Half the time every feature selected with open bindings: the solver then binds all it
    # may Late and Dynamic, which gives the run time the most to do.
    document = None if data.draw(st.booleans()) else data.draw(configurations(raw))
    running = started(raw, document)
    if running is None:
        return
    model, variant, reference, active = running
    selected = reference.selected
    if len(selected) == 1:
        return  # only the root: nothing can change
    ids = [f.id for f in model.features]
    with Reconfigurer(variant) as reconfigurer:
        for _ in range(8):
            action = data.draw(st.sampled_from(["load", "unload", "reload", "swap"]))
            # Mostly moves that can succeed (an inactive selected feature to load, an active
            # Dynamic one to unload), sometimes any feature, so refusals are tried too.
            loadable = [f for f in ids if f in selected and f not in active] or ids
            unloadable = [f for f in ids if f in active and not selected[f][1]] or ids
            pools = {
                "load": [loadable],
                "unload": [unloadable],
                "reload": [unloadable],
                "swap": [unloadable, loadable],
            }
            picks = []
            for pool in pools[action]:
                picks.append(
                    data.draw(st.sampled_from(pool) if data.draw(st.integers(0, 4)) else st.sampled_from(ids))
                )
            if action in ("load", "unload") and data.draw(st.booleans()):
                picks.append(data.draw(st.sampled_from(pools[action][0])))
            features = tuple(dict.fromkeys(picks))
            if action == "swap" and len(features) != 2:
                continue
            expected = reference.apply(active, action, features)
            try:
                plan: Plan | None = reconfigurer.plan(active, change(action, features))
            except Refused as refused:
                plan = None
                assert_repairs_mend(reference, active, action, features, refused)
            assert (None if plan is None else set(plan.after)) == expected, (action, features, active)
            if plan is not None:
                assert set(plan.unloads) == plan.before - plan.after | (set(plan.unloads) & plan.after)
                assert set(plan.loads) == plan.after - (plan.before - set(plan.unloads))
                active = set(plan.after)
                assert ref.active_set_satisfies_section_2(raw, active)


def assert_repairs_mend(
    reference: Reference, active: set[str], action: str, features: tuple[str, ...], refused: Refused
) -> None:
    """A refused request's repairs (reference.md section 6), judged by brute force: each,
    made to the request, gives a request the reference accepts, and no part of it does;
    every conflict carries the same list, fewest changes first."""
    repairs = refused.diagnostics[0].repairs
    assert all(d.repairs == repairs for d in refused.diagnostics)
    assert [len(r) for r in repairs] == sorted(len(r) for r in repairs)
    unloads = features[:1] if action == "swap" else features if action in ("unload", "reload") else ()
    loads = features[1:] if action == "swap" else features if action == "load" else ()
    for repair in repairs:
        assert all(c.change in ("load", "unload") and c.value is True for c in repair)  # only additions
        assert not {c.feature for c in repair} & set(features)  # what the request names stays

        def made(changes: tuple[Any, ...]) -> set[str] | None:
            more_loads = tuple(c.feature for c in changes if c.change == "load")
            more_unloads = tuple(c.feature for c in changes if c.change == "unload")
            return reference.apply_set(active, loads + more_loads, unloads + more_unloads)

        after = made(repair)
        assert after is not None, (action, features, active, repair)
        for size in range(len(repair)):
            for part in combinations(repair, size):
                assert made(part) is None, (action, features, active, repair, part)


def test_a_refused_request_gets_the_changes_that_would_be_accepted(
    robot: tuple[Reconfigurer, set[str]],
) -> None:
    cases = {
        ("load slam hector", "load karto"): ["also unload hector"],
        ("load slam",): ["also load hector", "also load karto"],
        ("load sonar",): ["also unload lidar"],
        ("load gestures",): ["also load camera"],
        ("load hector",): ["also load slam"],
    }
    for requests, expected in cases.items():
        repairs = refused(robot, *requests).diagnostics[0].repairs
        assert [repair_text(r) for r in repairs] == expected, requests


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(run_time_models())
def test_every_refused_load_and_unload_gets_repairs_that_brute_force_accepts(raw: dict[str, Any]) -> None:
    """From the start state of a variant selecting everything it may, bound as late and as
    dynamic as it may: every load and unload of one feature; each refused one's repairs."""
    running = started(raw, None)
    if running is None:
        return
    model, variant, reference, active = running
    with Reconfigurer(variant) as reconfigurer:
        for f in model.features[1:]:
            action = "unload" if f.id in active else "load"
            try:
                reconfigurer.plan(active, change(action, (f.id,)))
            except Refused as refused:
                assert_repairs_mend(reference, active, action, (f.id,), refused)
                mendable = refused.breaks_relations or refused.diagnostics[0].rule == "reconfigure.parent"
                if mendable:  # repairs exist iff brute force finds other moves that are accepted
                    assert bool(refused.diagnostics[0].repairs) == any_mend(reference, active, action, f.id)


def any_mend(reference: Reference, active: set[str], action: str, named: str) -> bool:
    """Whether loading and unloading other features besides makes the request accepted."""
    others = [g for g in reference.selected if g != named and g != reference.model.features[0].id]
    moves = [(g, g not in active) for g in others if g not in active or not reference.selected[g][1]]
    for size in range(1, len(moves) + 1):
        for part in combinations(moves, size):
            loads = tuple(g for g, load in part if load)
            unloads = tuple(g for g, load in part if not load)
            own = (named,) if action == "load" else ()
            gone = (named,) if action == "unload" else ()
            if reference.apply_set(active, own + loads, gone + unloads) is not None:
                return True
    return False

"""Reference semantics of MoTiVML feature models and configurations.

An independent cross-check for the product (which decides validity with a SAT solver):
written only from the project's specification ("the spec" below: first the team's shared
semantics document, now guidelines/reference.md, whose sections have the same numbers),
with the Python 3.11 standard library and no import from the package.  Section numbers in
comments are the spec's.  Everything works on the raw parsed JSON documents of spec section 1.

Public functions:
    valid_variants(model, config)        every valid variant, as {selected id: (early, static)}
    is_valid(model, config)              does a valid variant exist?
    count_valid_variants(model, config)  how many valid variants exist
    start_state_exists(model, selection) does the start state of section 4 exist?
    active_set_satisfies_section_2(model, active)  may A be the active set at run time?
    start_states(model, selection)       every active set the start state may be
    preferred_start_state(model, selection)  the start state section 4 picks among them
    completion_cost(model, config, variant, prefer)  how far a variant is from the wishes
                                         `configure` completes a configuration with
    model_statements(model), config_statements(model, config), consistent(model, statements)
                                         the model and the configuration as separate facts
                                         (the ones explanations name), and whether a chosen
                                         set of them has a variant

How it works.  Every sentence of sections 2, 3 and 4 becomes one `Rule`: a readable
predicate over the few variables it mentions (its scope), built by one small function below
that quotes the sentence it implements.  There are two variables per feature f:
    f        None (not selected) or (early, static): selected, with binding time
             E(f) = early (true = Early) and binding mode S(f) = static (true = Static)
    a(f)     bool: f is in the start state's active set A (section 4)
As section 4 says ("encode the start state as a second set of variables a(f) in the same
SAT instance"), both sets are solved together, so a start state that cannot exist prunes the
search for the selection instead of being discovered variant after variant.

A tiny generic solver (`_solve`) enumerates the assignments satisfying all rules:
backtracking over the variables in the order given (features in pre-order, then the a(f)),
removing after each decision the values that can no longer satisfy some single rule whatever
the other variables of that rule take (generalised arc consistency).  Pruning only ever
removes values that cannot be part of any solution, and every complete assignment is
re-checked against every rule before it is yielded, so correctness does not depend on the
pruning: it is only there so that unsatisfiable models are refuted in milliseconds instead of
by exhaustion.  A variant is yielded once, with one witness start state, however many start
states it has.

Documents whose meaning the spec leaves undefined (bad tokens, unknown or duplicate ids,
unknown keys, ...) raise ValueError.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass
from typing import Any

Binding = tuple[bool, bool]  # (early, static)

SE: Binding = (True, True)
DE: Binding = (True, False)
SL: Binding = (False, True)
DL: Binding = (False, False)

# Values tried for a feature: "decide selected, then E, then S".
_VARIANT_VALUES: tuple[Binding | None, ...] = (None, SE, DE, SL, DL)
_ACTIVE_VALUES: tuple[bool, ...] = (False, True)


# ---------------------------------------------------------------------------------------
# Section 1: documents, with the defaults of the table
# ---------------------------------------------------------------------------------------

_FEATURE_KEYS = {"id", "name", "group", "isMandatory", "isSelected", "constraints", "sub", "abstract"}
_ROOT_KEYS = _FEATURE_KEYS | {"formulas", "$schema"}  # "`formulas`: only on the root"
_CONSTRAINT_KEYS = {"featuresIncluded", "featuresExcluded", "bindingTimeAllowed", "bindingModeAllowed"}
_GROUPS = ("", "OR", "XOR")
_TIMES_ALLOWED = ("Early", "Late", "Any")
_MODES_ALLOWED = ("Static", "Dynamic", "Any")


@dataclass
class _Feature:
    id: str
    parent: str | None
    children: list[str]
    group: str  # "group": "" | "OR" | "XOR", default ""
    is_mandatory: bool  # "isMandatory", default true
    includes: list[str]  # "constraints.featuresIncluded", default []
    excludes: list[str]  # "constraints.featuresExcluded", default []
    time_allowed: str  # "constraints.bindingTimeAllowed", default "Early"
    mode_allowed: str  # "constraints.bindingModeAllowed", default "Static"


class _Model:
    """A parsed feature model: features in pre-order, plus the groups of section 2.2."""

    def __init__(self, raw: dict) -> None:
        self.features: dict[str, _Feature] = {}  # insertion order = pre-order
        if not isinstance(raw, dict):
            raise ValueError("the feature model must be a JSON object (the root feature)")
        self.root = self._add(raw, parent=None)
        for f in self.features.values():
            for other in f.includes + f.excludes:
                if other not in self.features:
                    raise ValueError(f"feature {f.id!r} refers to unknown feature {other!r}")
        formulas = raw.get("formulas", [])
        if not isinstance(formulas, list) or not all(isinstance(t, str) for t in formulas):
            raise ValueError("'formulas' must be an array of strings")
        # 2.4: "An unknown id in a formula, or a formula that does not parse, is an error"
        self.formulas: list[_Formula] = [_parse_formula(t, set(self.features)) for t in formulas]

    def _add(self, raw: Any, parent: str | None) -> str:
        if not isinstance(raw, dict):
            raise ValueError("a feature must be a JSON object")
        _check_keys(raw, _ROOT_KEYS if parent is None else _FEATURE_KEYS, "feature")
        fid = raw.get("id")
        if not isinstance(fid, str) or not fid.isidentifier() or not fid.isascii():
            raise ValueError(f"bad or missing feature id {fid!r}")
        if fid in self.features:
            raise ValueError(f"duplicate feature id {fid!r}")
        name = raw.get("name")
        if not isinstance(name, str) or not name:
            raise ValueError(f"feature {fid!r}: 'name' must be a non-empty string")
        constraints = raw.get("constraints", {})  # "`constraints` itself may be absent"
        if not isinstance(constraints, dict):
            raise ValueError(f"feature {fid!r}: 'constraints' must be an object")
        _check_keys(constraints, _CONSTRAINT_KEYS, f"constraints of {fid!r}")
        feature = _Feature(
            id=fid,
            parent=parent,
            children=[],
            group=_token(raw.get("group", ""), _GROUPS, f"{fid}.group"),
            is_mandatory=_boolean(raw.get("isMandatory", True), f"{fid}.isMandatory"),
            includes=_id_list(constraints.get("featuresIncluded", []), f"{fid}.featuresIncluded"),
            excludes=_id_list(constraints.get("featuresExcluded", []), f"{fid}.featuresExcluded"),
            time_allowed=_token(
                constraints.get("bindingTimeAllowed", "Early"), _TIMES_ALLOWED, f"{fid}.bindingTimeAllowed"
            ),
            mode_allowed=_token(
                constraints.get("bindingModeAllowed", "Static"), _MODES_ALLOWED, f"{fid}.bindingModeAllowed"
            ),
        )
        # "isSelected: boolean; only meaningful on the root" -- and 2.1 says the root is
        # always selected, so its value never changes the meaning; only its type is checked.
        _boolean(raw.get("isSelected", True), f"{fid}.isSelected")
        self.features[fid] = feature
        sub = raw.get("sub", [])
        if not isinstance(sub, list):
            raise ValueError(f"feature {fid!r}: 'sub' must be an array")
        for child in sub:
            feature.children.append(self._add(child, parent=fid))
        return fid

    # -- Section 2.2: "A parent may thus have one OR group and one XOR group. A group needs
    # at least two members; a one-member group is [...] treated as an ungrouped child with
    # its own `isMandatory`".

    def group_members(self, parent: str, label: str) -> list[str]:
        """Members of `parent`'s OR or XOR group, or [] if it has no real (>= 2) group."""
        members = [c for c in self.features[parent].children if self.features[c].group == label]
        return members if len(members) >= 2 else []

    def is_ungrouped(self, child: str) -> bool:
        f = self.features[child]
        if f.parent is None:
            return False
        return f.group == "" or child not in self.group_members(f.parent, f.group)

    def ungrouped_mandatory_children(self, parent: str) -> list[str]:
        # "`isMandatory` of a grouped member is ignored" -- only ungrouped children count.
        return [
            c
            for c in self.features[parent].children
            if self.is_ungrouped(c) and self.features[c].is_mandatory
        ]


# -- Section 2.4: formulas.  "ids, `!`, `&`, `|`, `=>`, `<=>`, parentheses; precedence from
# tightest: `!`, `&`, `|`, `=>`, `<=>`; `=>` and `<=>` group to the right."  A recursive
# descent, one function per precedence level; a formula is kept as a function of the truth
# of its ids (`truth(id) -> bool`) and the ids it names.


@dataclass
class _Formula:
    text: str
    ids: tuple[str, ...]
    holds: Callable[[Callable[[str], bool]], bool]


_FORMULA_TOKEN = r"\s*(<=>|=>|[!&|()]|[A-Za-z_][A-Za-z0-9_]*)"


def _parse_formula(text: str, known: set[str]) -> _Formula:
    tokens: list[str] = []
    rest = text
    while rest.strip():
        m = re.match(_FORMULA_TOKEN, rest)
        if m is None:
            raise ValueError(f"formula {text!r}: cannot read {rest!r}")
        tokens.append(m.group(1))
        rest = rest[m.end() :]
    position = 0

    def peek() -> str | None:
        return tokens[position] if position < len(tokens) else None

    def take() -> str:
        nonlocal position
        if position >= len(tokens):
            raise ValueError(f"formula {text!r} ends too early")
        position += 1
        return tokens[position - 1]

    def iff() -> Callable:  # a <=> (b <=> c)
        left = implies()
        if peek() == "<=>":
            take()
            right = iff()
            return lambda t: left(t) == right(t)
        return left

    def implies() -> Callable:  # a => (b => c)
        left = disjunction()
        if peek() == "=>":
            take()
            right = implies()
            return lambda t: (not left(t)) or right(t)
        return left

    def disjunction() -> Callable:
        parts = [conjunction()]
        while peek() == "|":
            take()
            parts.append(conjunction())
        return lambda t: any(p(t) for p in parts)

    def conjunction() -> Callable:
        parts = [unary()]
        while peek() == "&":
            take()
            parts.append(unary())
        return lambda t: all(p(t) for p in parts)

    def unary() -> Callable:
        token = take()
        if token == "!":
            inner = unary()
            return lambda t: not inner(t)
        if token == "(":
            inner = iff()
            if take() != ")":
                raise ValueError(f"formula {text!r}: ')' expected")
            return inner
        if token not in known:
            raise ValueError(f"formula {text!r} names {token!r}, which is not a feature")
        return lambda t: t(token)

    whole = iff()
    if position != len(tokens):
        raise ValueError(f"formula {text!r}: unexpected {tokens[position]!r}")
    ids = tuple(dict.fromkeys(t for t in tokens if t in known))
    return _Formula(text, ids, whole)


def _check_keys(raw: dict, allowed: set[str], where: str) -> None:
    # "Unknown keys are errors [...], except keys starting with `x-`, [...] ignored."
    for key in raw:
        if key not in allowed and not (isinstance(key, str) and key.startswith("x-")):
            raise ValueError(f"unknown key {key!r} in {where}")


def _token(value: Any, allowed: tuple[str, ...], where: str) -> str:
    # "Tokens are case-sensitive (`Early`, not `early`)"; 3.4: "anything else is a schema error".
    if value not in allowed:
        raise ValueError(f"{where}: {value!r} is not one of {allowed}")
    return value


def _boolean(value: Any, where: str) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"{where}: {value!r} is not a boolean")
    return value


def _id_list(value: Any, where: str) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ValueError(f"{where}: must be an array of feature ids")
    return list(value)


@dataclass
class _Entry:
    """One configuration entry: `selected` (default true) and the fixed props, if any."""

    selected: bool
    time: str  # "Early" | "Late" | "Any" ("Any" or absent: to be decided)
    mode: str  # "Static" | "Dynamic" | "Any"


def _parse_config(raw: dict | None, model: _Model) -> dict[str, _Entry]:
    """Feature id -> entry.  A feature with no entry is undecided (free)."""
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise ValueError("a configuration must be a JSON object")
    properties = raw.get("properties", [])
    if not isinstance(properties, list):
        raise ValueError("'properties' must be an array")
    entries: dict[str, _Entry] = {}
    for item in properties:
        if not isinstance(item, dict):
            raise ValueError("a configuration entry must be an object")
        fid = item.get("id")
        # "One entry per feature id (duplicates are errors, unknown ids are errors)."
        if fid not in model.features:
            raise ValueError(f"configuration entry for unknown feature {fid!r}")
        if fid in entries:
            raise ValueError(f"duplicate configuration entry for {fid!r}")
        props = item.get("props", {})
        if not isinstance(props, dict):
            raise ValueError(f"{fid}: 'props' must be an object")
        entries[fid] = _Entry(
            # "`selected` (default `true`) is this project's extension"
            selected=_boolean(item.get("selected", True), f"{fid}.selected"),
            # "`Any` or an absent prop means 'to be decided by the configurator'"
            time=_token(props.get("time", "Any"), _TIMES_ALLOWED, f"{fid}.props.time"),
            mode=_token(props.get("mode", "Any"), _MODES_ALLOWED, f"{fid}.props.mode"),
        )
    return entries


# ---------------------------------------------------------------------------------------
# Rules and the generic solver
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Rule:
    spec: str  # where in the spec it comes from
    scope: tuple[str, ...]  # the distinct variables it mentions
    holds: Callable[[dict[str, Any]], bool]  # given a value for every variable of the scope


def _rule(spec: str, variables: tuple[str, ...], holds: Callable[[dict], bool]) -> Rule:
    # dict.fromkeys: a feature that includes or excludes itself is mentioned once.
    return Rule(spec, tuple(dict.fromkeys(variables)), holds)


def _implies(p: bool, q: bool) -> bool:
    """p → q.  Both are evaluated: guard anything that needs a selected feature."""
    return (not p) or q


def _s(v: Binding | None) -> bool:
    """s(f): selected."""
    return v is not None


def _E(v: Binding) -> bool:
    """E(f): true = Early, false = Late."""
    return v[0]


def _S(v: Binding) -> bool:
    """S(f): true = Static, false = Dynamic."""
    return v[1]


def _solve(
    order: list[str], domains: dict[str, tuple], rules: list[Rule], decisive: list[str] | None = None
) -> Iterator[dict[str, Any]]:
    """Yield every assignment {variable: value}, value taken from domains[variable], that
    satisfies every rule.  Variables are decided in `order`.  With `decisive` (a prefix of
    `order`), only the first solution is yielded for each assignment of the decisive
    variables: the others are then merely a witness."""
    rules_of: dict[str, list[Rule]] = {x: [] for x in order}
    for rule in rules:
        for x in rule.scope:
            rules_of[x].append(rule)
    start = _prune(dict(domains), rules, rules_of)
    if start is not None:
        yield from _search(order, start, rules, rules_of, decisive)


def _search(order, domains, rules, rules_of, decisive) -> Iterator[dict[str, Any]]:
    if decisive is not None and all(len(domains[x]) == 1 for x in decisive):
        witness = next(_search(order, domains, rules, rules_of, None), None)
        if witness is not None:
            yield witness
        return
    undecided = next((x for x in order if len(domains[x]) > 1), None)
    if undecided is None:
        assignment = {x: domains[x][0] for x in order}
        # Safety net: the pruning is only an optimisation; check every rule directly.
        if all(rule.holds({x: assignment[x] for x in rule.scope}) for rule in rules):
            yield assignment
        return
    for value in domains[undecided]:
        trial = dict(domains)
        trial[undecided] = (value,)
        trial = _prune(trial, rules_of[undecided], rules_of)
        if trial is not None:
            yield from _search(order, trial, rules, rules_of, decisive)


def _prune(domains, dirty_rules, rules_of):
    """Remove every value that cannot satisfy some rule whatever values the rule's other
    variables take from their domains; repeat until nothing changes.  Returns the reduced
    domains, or None if some variable has no value left (no solution below this point)."""
    queue = list(dirty_rules)
    queued = set(map(id, queue))
    while queue:
        rule = queue.pop()
        queued.discard(id(rule))
        for x in rule.scope:
            kept = tuple(v for v in domains[x] if _has_support(rule, x, v, domains))
            if not kept:
                return None
            if len(kept) < len(domains[x]):
                domains[x] = kept
                for other in rules_of[x]:
                    if id(other) not in queued:
                        queue.append(other)
                        queued.add(id(other))
    return domains


def _has_support(rule: Rule, x: str, value: Any, domains) -> bool:
    """Can `rule` hold with x = value and the other variables taken from their domains?"""
    others = [y for y in rule.scope if y != x]
    for values in itertools.product(*(domains[y] for y in others)):
        assignment = dict(zip(others, values, strict=True))
        assignment[x] = value
        if rule.holds(assignment):
            return True
    return False


# ---------------------------------------------------------------------------------------
# Sections 2 and 3 over a variant: value None (not selected) or (E, S)
# ---------------------------------------------------------------------------------------


def _root_selected_static_early(root: str) -> Rule:
    # 2.1 "Root: s(root); the root is the program itself: always selected, Static and Early"
    return _rule("2.1 root", (root,), lambda v: v[root] == SE)


def _child_needs_parent(child: str, parent: str) -> Rule:
    # 2.1 "Hierarchy: s(child) → s(parent)."
    return _rule("2.1 hierarchy", (child, parent), lambda v: _implies(_s(v[child]), _s(v[parent])))


def _mandatory_child_selected(parent: str, child: str) -> Rule:
    # 2.2 "ungrouped mandatory child: s(parent) → s(child)"
    return _rule("2.2 mandatory child", (parent, child), lambda v: _implies(_s(v[parent]), _s(v[child])))


def _group_has_selected_member(parent: str, members: list[str], label: str) -> Rule:
    # 2.2 "OR group: s(parent) → s(m1) ∨ … ∨ s(mk)"
    # 2.2 "XOR group: OR plus at most one selected member, relaxed [...] by 3.3"
    #     (the "at most one" part is _runtime_alternatives, applied to each pair)
    return _rule(
        f"2.2 {label} group",
        (parent, *members),
        lambda v: _implies(_s(v[parent]), any(_s(v[m]) for m in members)),
    )


def _includes_selects(a: str, b: str) -> Rule:
    # 2.3 "`featuresIncluded` of A containing B: s(A) → s(B)"
    return _rule("2.3 includes", (a, b), lambda v: _implies(_s(v[a]), _s(v[b])))


def _runtime_alternatives(a: str, b: str, why: str) -> Rule:
    # 2.3 "`featuresExcluded`: ¬(s(A) ∧ s(B)) (see 3.3 for dynamic features)" and
    # 2.2 XOR "at most one selected member, relaxed for Dynamic members by 3.3";
    # 3.3 "A variant may select several members of one XOR group, or two features that
    # exclude each other, only if all of them are Dynamic and at most one of them is Early
    # [...] Per pair: ¬(s(a) ∧ s(b) ∧ (S(a) ∨ S(b) ∨ (E(a) ∧ E(b))))"
    def holds(v):
        va, vb = v[a], v[b]
        return not (_s(va) and _s(vb) and (_S(va) or _S(vb) or (_E(va) and _E(vb))))

    return _rule(f"3.3 runtime alternatives ({why})", (a, b), holds)


def _time_allowed(f: _Feature) -> Rule:
    # 3 "`bindingTimeAllowed`/`bindingModeAllowed` restrict the values (`Any` = no restriction)"
    def holds(v):
        x = v[f.id]
        return not _s(x) or f.time_allowed == "Any" or _E(x) == (f.time_allowed == "Early")

    return _rule("3 binding time restriction", (f.id,), holds)


def _mode_allowed(f: _Feature) -> Rule:
    # 3 "`bindingTimeAllowed`/`bindingModeAllowed` restrict the values (`Any` = no restriction)"
    def holds(v):
        x = v[f.id]
        return not _s(x) or f.mode_allowed == "Any" or _S(x) == (f.mode_allowed == "Static")

    return _rule("3 binding mode restriction", (f.id,), holds)


def _requirement_holds(vx: Binding, vy: Binding) -> bool:
    # 3.1 "Y is Static, and Y is bound no later than X (S(Y) ∧ (E(X) → E(Y)))"
    return _S(vy) and _implies(_E(vx), _E(vy))


def _includes_requires(x: str, y: str) -> Rule:
    # 3.1 "When a selected feature X requires a selected feature Y [...]
    #      'Requires' is: X includes Y"
    def holds(v):
        if not (_s(v[x]) and _s(v[y])):
            return True
        return _requirement_holds(v[x], v[y])

    return _rule("3.1 X includes Y", (x, y), holds)


def _static_parent_requires_mandatory_child(parent: str, child: str) -> Rule:
    # 3.1 "and a Static parent requires each ungrouped mandatory child"
    def holds(v):
        vp, vc = v[parent], v[child]
        if not (_s(vp) and _s(vc) and _S(vp)):
            return True
        return _requirement_holds(vp, vc)

    return _rule("3.1 Static parent requires mandatory child", (parent, child), holds)


def _sub_feature(parent: str, child: str) -> Rule:
    # 3.2 "a Dynamic parent cannot have a Static child (¬S(p) → ¬S(c)), and a child is
    #      not bound before its parent (E(c) → E(p))"
    def holds(v):
        vp, vc = v[parent], v[child]
        if not (_s(vp) and _s(vc)):
            return True
        return _implies(not _S(vp), not _S(vc)) and _implies(_E(vc), _E(vp))

    return _rule("3.2 sub-feature", (parent, child), holds)


def _dynamic_binding_unit(parent: str, child: str) -> Rule:
    # 3.2 "A mandatory child of a Dynamic parent forms one binding unit with it: same time
    #      and mode, loaded and unloaded together"
    def holds(v):
        vp, vc = v[parent], v[child]
        if not (_s(vp) and _s(vc) and not _S(vp)):
            return True
        return vp == vc

    return _rule("3.2 Dynamic binding unit", (parent, child), holds)


def _configured(fid: str, entry: _Entry) -> Rule:
    # 1 "`selected` (default `true`)"; "`Any` or an absent prop means 'to be decided'";
    # 3 "... restrict the values [...], and so do the configuration's `props`."
    # Props of a deselected feature are irrelevant.
    def holds(v):
        x = v[fid]
        if not entry.selected:
            return not _s(x)
        if not _s(x):
            return False
        time_ok = entry.time == "Any" or _E(x) == (entry.time == "Early")
        mode_ok = entry.mode == "Any" or _S(x) == (entry.mode == "Static")
        return time_ok and mode_ok

    return _rule("1 configuration entry", (fid,), holds)


def _formula_holds(formula: _Formula) -> Rule:
    # 2.4 "Each formula must hold over the selection `s`"
    return _rule(f"2.4 {formula.text}", formula.ids, lambda v: formula.holds(lambda f: _s(v[f])))


def _formula_holds_active(formula: _Formula) -> Rule:
    # 2.4 "... and (section 4) over the active set at every moment"
    return _rule(
        f"2.4 {formula.text} (active)", tuple(map(_a, formula.ids)), lambda v: formula.holds(lambda f: v[_a(f)])
    )


def _variant_rules(model: _Model, config: dict[str, _Entry]) -> list[Rule]:
    rules = [_root_selected_static_early(model.root)]
    rules += [_formula_holds(formula) for formula in model.formulas]
    for f in model.features.values():
        rules.append(_time_allowed(f))
        rules.append(_mode_allowed(f))
        if f.parent is not None:
            rules.append(_child_needs_parent(f.id, f.parent))
            rules.append(_sub_feature(f.parent, f.id))
        for c in model.ungrouped_mandatory_children(f.id):
            rules.append(_mandatory_child_selected(f.id, c))
            rules.append(_static_parent_requires_mandatory_child(f.id, c))
            rules.append(_dynamic_binding_unit(f.id, c))
        for label in ("OR", "XOR"):
            members = model.group_members(f.id, label)
            if members:
                rules.append(_group_has_selected_member(f.id, members, label))
        for a, b in itertools.combinations(model.group_members(f.id, "XOR"), 2):
            rules.append(_runtime_alternatives(a, b, "XOR group"))
        for y in f.includes:
            rules.append(_includes_selects(f.id, y))
            rules.append(_includes_requires(f.id, y))
        for y in f.excludes:
            rules.append(_runtime_alternatives(f.id, y, "excludes"))
    for fid, entry in config.items():
        rules.append(_configured(fid, entry))
    return rules


# ---------------------------------------------------------------------------------------
# Section 4: the start state, over a(f) = "f is active" (bool)
# ---------------------------------------------------------------------------------------


def _a(f: str) -> str:
    """The name of the variable a(f): "f is active".  (Ids cannot contain parentheses.)"""
    return f"a({f})"


def _active_only_if_selected(f: str) -> Rule:
    # 4 "The runtime's active set A ⊆ selected features" -- "a(f) → s(f)"
    return _rule("4 A ⊆ selected", (_a(f), f), lambda v: _implies(v[_a(f)], _s(v[f])))


def _early_starts_active(f: str) -> Rule:
    # 4 "At start, A holds every Early feature" -- "s(f) ∧ E(f) → a(f)"
    return _rule(
        "4 Early features start active", (f, _a(f)), lambda v: _implies(_s(v[f]) and _E(v[f]), v[_a(f)])
    )


def _root_active(root: str) -> Rule:
    # 2.1 "the root [...] always active"
    return _rule("2.1 root active", (_a(root),), lambda v: v[_a(root)])


def _active_child_needs_active_parent(child: str, parent: str) -> Rule:
    # 2.1 over a: "Hierarchy: s(child) → s(parent)"
    return _rule(
        "2.1 hierarchy (active)", (_a(child), _a(parent)), lambda v: _implies(v[_a(child)], v[_a(parent)])
    )


def _active_mandatory_child(parent: str, child: str) -> Rule:
    # 2.2 over a: "ungrouped mandatory child: s(parent) → s(child)"
    return _rule(
        "2.2 mandatory child (active)",
        (_a(parent), _a(child)),
        lambda v: _implies(v[_a(parent)], v[_a(child)]),
    )


def _active_or_group(parent: str, members: list[str]) -> Rule:
    # 2.2 over a: "OR group: s(parent) → s(m1) ∨ … ∨ s(mk)"
    return _rule(
        "2.2 OR group (active)",
        (_a(parent), *map(_a, members)),
        lambda v: _implies(v[_a(parent)], any(v[_a(m)] for m in members)),
    )


def _active_xor_group(parent: str, members: list[str]) -> Rule:
    # 4 "At every moment A satisfies section 2 in full (exactly one active XOR member, ...)"
    return _rule(
        "2.2 XOR group (active)",
        (_a(parent), *map(_a, members)),
        lambda v: _implies(v[_a(parent)], sum(v[_a(m)] for m in members) == 1),
    )


def _active_includes(x: str, y: str) -> Rule:
    # 2.3 over a: "`featuresIncluded` of A containing B: s(A) → s(B)"
    return _rule("2.3 includes (active)", (_a(x), _a(y)), lambda v: _implies(v[_a(x)], v[_a(y)]))


def _active_excludes(x: str, y: str) -> Rule:
    # 4 "... no two active excluded features" -- 2.3 "¬(s(A) ∧ s(B))" over a, strictly:
    # the relaxation of 3.3 is about selection ("at most one is *active* at any moment").
    return _rule("2.3 excludes (active)", (_a(x), _a(y)), lambda v: not (v[_a(x)] and v[_a(y)]))


def _start_state_rules(model: _Model) -> list[Rule]:
    """Section 4: "encode the start state as a second set of variables a(f) in the same SAT
    instance (a(f) → s(f), s(f) ∧ E(f) → a(f), and section 2 in full over a)"."""
    rules = _active_set_rules(model)
    for f in model.features.values():
        rules.append(_active_only_if_selected(f.id))
        rules.append(_early_starts_active(f.id))
    return rules


def _active_set_rules(model: _Model) -> list[Rule]:
    """Section 4: "At every moment A satisfies section 2 in full (exactly one active XOR
    member, no two active excluded features, and so on)", over the variables a(f)."""
    rules = [_root_active(model.root)]
    rules += [_formula_holds_active(formula) for formula in model.formulas]
    for f in model.features.values():
        if f.parent is not None:
            rules.append(_active_child_needs_active_parent(f.id, f.parent))
        for c in model.ungrouped_mandatory_children(f.id):
            rules.append(_active_mandatory_child(f.id, c))
        or_members = model.group_members(f.id, "OR")
        if or_members:
            rules.append(_active_or_group(f.id, or_members))
        xor_members = model.group_members(f.id, "XOR")
        if xor_members:
            rules.append(_active_xor_group(f.id, xor_members))
        for y in f.includes:
            rules.append(_active_includes(f.id, y))
        for y in f.excludes:
            rules.append(_active_excludes(f.id, y))
    return rules


# ---------------------------------------------------------------------------------------
# Public API
# ---------------------------------------------------------------------------------------


def start_state_exists(model: dict, selection: dict[str, Binding]) -> bool:
    """Section 4: is there an active set A with A ⊆ selected, every selected Early feature
    in A, and A satisfying section 2 in full and strictly?  `selection` maps each selected
    feature id (the root included) to its (early, static) binding.  Only the start state is
    checked, not whether the selection satisfies sections 2 and 3.

    The selection is fixed, so the rules a(f) → s(f) and s(f) ∧ E(f) → a(f) fix a(f) for
    every unselected and every Early feature at once: the search enumerates subsets of the
    selected Late features only."""
    parsed = _Model(model)
    unknown = set(selection) - set(parsed.features)
    if unknown:
        raise ValueError(f"selection names unknown features {sorted(unknown)}")
    features = list(parsed.features)
    order = features + [_a(f) for f in features]
    domains = {f: (selection.get(f),) for f in features}
    domains |= {_a(f): _ACTIVE_VALUES for f in features}
    return next(_solve(order, domains, _start_state_rules(parsed)), None) is not None


def valid_variants(model: dict, config: dict | None) -> Iterator[dict[str, Binding]]:
    """Every valid variant: {id of each selected feature: (early, static)} satisfying
    sections 2 and 3, agreeing with `config` (None = no configuration: every feature
    undecided), and -- 4 "A variant whose start state does not exist is invalid" -- having
    a start state.  Each variant is yielded once."""
    parsed = _Model(model)
    entries = _parse_config(config, parsed)
    features = list(parsed.features)
    order = features + [_a(f) for f in features]
    domains = {f: _VARIANT_VALUES for f in features}
    domains |= {_a(f): _ACTIVE_VALUES for f in features}
    rules = _variant_rules(parsed, entries) + _start_state_rules(parsed)
    for assignment in _solve(order, domains, rules, decisive=features):
        yield {f: assignment[f] for f in features if assignment[f] is not None}


def section_2_selections(model: dict) -> Iterator[frozenset[str]]:
    """Every selection satisfying section 2 read on its own, without bindings (what section 7's
    selection count counts and section 8's DIMACS holds): 2.1 root and hierarchy, 2.2
    mandatory children and groups (an XOR group "at most one selected member": its relaxation
    by 3.3 needs bindings), 2.3 includes and excludes, 2.4 formulas.  By enumeration of
    every subset of the non-root features."""
    parsed = _Model(model)
    others = [f for f in parsed.features if f != parsed.root]
    for bits in itertools.product((False, True), repeat=len(others)):
        chosen = {parsed.root} | {f for f, on in zip(others, bits, strict=True) if on}
        if _section_2_holds(parsed, chosen):
            yield frozenset(chosen)


def _section_2_holds(model: _Model, chosen: set[str]) -> bool:
    for f in model.features.values():
        if f.id in chosen and f.parent is not None and f.parent not in chosen:  # 2.1
            return False
        if f.id not in chosen:
            continue
        if any(c not in chosen for c in model.ungrouped_mandatory_children(f.id)):  # 2.2
            return False
        for label in ("OR", "XOR"):
            members = model.group_members(f.id, label)
            picked = sum(m in chosen for m in members)
            if members and (picked == 0 or (label == "XOR" and picked > 1)):  # 2.2
                return False
        if any(y not in chosen for y in f.includes) or any(y in chosen for y in f.excludes):  # 2.3
            return False
    return all(formula.holds(lambda g: g in chosen) for formula in model.formulas)  # 2.4


def is_valid(model: dict, config: dict | None) -> bool:
    return next(valid_variants(model, config), None) is not None


def count_valid_variants(model: dict, config: dict | None) -> int:
    return sum(1 for _ in valid_variants(model, config))


def active_set_satisfies_section_2(model: dict, active: set[str] | frozenset[str]) -> bool:
    """4 "At every moment A satisfies section 2 in full": is `active` (feature ids) such a
    set?  Only section 2 over A is checked, not that A is part of some selection."""
    parsed = _Model(model)
    unknown = set(active) - set(parsed.features)
    if unknown:
        raise ValueError(f"active set names unknown features {sorted(unknown)}")
    values = {_a(f): f in active for f in parsed.features}
    return all(rule.holds({x: values[x] for x in rule.scope}) for rule in _active_set_rules(parsed))


def start_states(model: dict, selection: dict[str, Binding]) -> Iterator[frozenset[str]]:
    """Every active set A the start state of section 4 may be for `selection` (as in
    `start_state_exists`): A ⊆ selected, every selected Early feature in A, A satisfying
    section 2 in full and strictly.  Each set is yielded once."""
    parsed = _Model(model)
    unknown = set(selection) - set(parsed.features)
    if unknown:
        raise ValueError(f"selection names unknown features {sorted(unknown)}")
    features = list(parsed.features)
    order = features + [_a(f) for f in features]
    domains = {f: (selection.get(f),) for f in features}
    domains |= {_a(f): _ACTIVE_VALUES for f in features}
    for assignment in _solve(order, domains, _start_state_rules(parsed)):
        yield frozenset(f for f in features if assignment[_a(f)])


def preferred_start_state(model: dict, selection: dict[str, Binding]) -> list[str] | None:
    """The start state section 4 picks, as ids in definition (pre-)order; None if none exists.

    4 "At start, A holds every Early feature and is completed to a valid configuration of
    section 2 (fewest Late activations; ties broken by definition order: the feature that
    comes first in a pre-order walk of the model is activated first)."  Among the sets with
    the fewest Late features, the first Late feature (in pre-order) on which two sets differ
    is active in the one preferred."""
    order = list(_Model(model).features)
    late = [f for f in order if f in selection and not _E(selection[f])]

    def key(active: frozenset[str]) -> tuple[int, list[bool]]:
        return sum(f in active for f in late), [f not in active for f in late]

    best = min(start_states(model, selection), key=key, default=None)
    return None if best is None else [f for f in order if f in best]


PREFERENCES = ("late", "dynamic")


def completion_cost(
    model: dict, config: dict | None, variant: dict[str, Binding], prefer: tuple[str, ...] = ()
) -> tuple[int, int, int]:
    """How far `variant` (a completion of `config`) is from what `configure` wishes for;
    the variant `configure` writes has the smallest cost, compared as a tuple.

    4 "`configure` finds it: it completes undecided selections and `Any` bindings [...],
    preferring the published defaults (Early, Static) unless told otherwise".  The wishes and
    their order are those of guidelines/configuring-a-variant.md section 3, "each one before
    the next": (1) "select as few of the undecided features as the model allows"; (2) "bind
    open times Early" (Late with `--prefer late`); (3) "bind open modes Static" (Dynamic
    with `--prefer dynamic`).  A feature with no entry is undecided; a time or mode is open
    when the configuration leaves it to the configurator (no entry, or `Any`/absent).  The
    root is the program itself (2.1), never counted."""
    unknown = set(prefer) - set(PREFERENCES)
    if unknown:
        raise ValueError(f"unknown preferences {sorted(unknown)}")
    parsed = _Model(model)
    entries = _parse_config(config, parsed)
    wanted_early = "late" not in prefer
    wanted_static = "dynamic" not in prefer
    undecided = times = modes = 0
    for f, binding in variant.items():
        if f == parsed.root:
            continue
        entry = entries.get(f)
        undecided += entry is None
        times += (entry is None or entry.time == "Any") and _E(binding) != wanted_early
        modes += (entry is None or entry.mode == "Any") and _S(binding) != wanted_static
    return undecided, times, modes


# ---------------------------------------------------------------------------------------
# Statements: the model and the configuration as separate facts
# ---------------------------------------------------------------------------------------
#
# Section 4: `configure` "reports why no variant exists: each minimal set of conflicting
# model/configuration facts (a minimal unsatisfiable subset)".  To check such a set, the
# model and the configuration are cut into statements, each one sentence of the documents
# with every rule of sections 2-4 that applies it:
#
#   ("root",)               the root feature: 2.1 selected, Static and Early, and active
#   ("start",)              4: a start state exists (A ⊆ selected, every selected Early
#                           feature in A, and each chosen statement below also over A)
#   ("sub", c)              c is a sub-feature of its parent: 2.1 hierarchy, 3.2
#   ("mandatory", c)        c is an ungrouped mandatory child: 2.2, 3.1 (Static parent), 3.2 unit
#   ("group", p, label)     p's OR / XOR group: 2.2 some member is selected (active) with p
#   ("alternatives", a, b)  a and b in one XOR group: 3.3, and never both active (4)
#   ("includes", x, y)      2.3 and 3.1
#   ("excludes", x, y)      2.3 and 3.3, and never both active (4)
#   ("time-allowed", f), ("mode-allowed", f)    3: bindingTimeAllowed / bindingModeAllowed
#   ("selected", f), ("deselected", f), ("time", f, "Early"|"Late"),
#   ("mode", f, "Static"|"Dynamic")             1 and 3: what a configuration says
#
# An XOR group's "exactly one active member" (4) is its group statement (at least one)
# together with its pairs of alternatives (at most one): all statements of a model and a
# configuration together mean exactly what `is_valid` decides.  Statements left out of a
# set are simply not in force: the features they mention are then unconstrained by them.


def model_statements(model: dict) -> list[tuple[str, ...]]:
    """Every statement of the model (see above), in definition order."""
    parsed = _Model(model)
    found: list[tuple[str, ...]] = [("root",), ("start",)]
    found += [("formula", str(k)) for k in range(len(parsed.formulas))]
    for f in parsed.features.values():
        if f.time_allowed != "Any":
            found.append(("time-allowed", f.id))
        if f.mode_allowed != "Any":
            found.append(("mode-allowed", f.id))
        if f.parent is not None:
            found.append(("sub", f.id))
        found += [("mandatory", c) for c in parsed.ungrouped_mandatory_children(f.id)]
        for label in ("OR", "XOR"):
            if parsed.group_members(f.id, label):
                found.append(("group", f.id, label))
        found += [
            ("alternatives", a, b) for a, b in itertools.combinations(parsed.group_members(f.id, "XOR"), 2)
        ]
        found += [("includes", f.id, y) for y in dict.fromkeys(f.includes)]
        found += [("excludes", f.id, y) for y in dict.fromkeys(f.excludes)]
    return found


def config_statements(model: dict, config: dict | None) -> list[tuple[str, ...]]:
    """Every statement of the configuration: its entries' selections and fixed props."""
    found: list[tuple[str, ...]] = []
    for fid, entry in _parse_config(config, _Model(model)).items():
        if not entry.selected:  # "Props of a deselected feature are irrelevant"
            found.append(("deselected", fid))
            continue
        found.append(("selected", fid))
        if entry.time != "Any":
            found.append(("time", fid, entry.time))
        if entry.mode != "Any":
            found.append(("mode", fid, entry.mode))
    return found


def consistent(model: dict, statements: Collection[tuple[str, ...]]) -> bool:
    """Is there an assignment (a selection with bindings, and with ("start",) an active
    set) satisfying every rule of the given statements and nothing else?"""
    parsed = _Model(model)
    chosen = set(statements)
    start = ("start",) in chosen
    rules: list[Rule] = []
    for statement in chosen:
        rules += _statement_rules(parsed, statement, start)
    if start and ("root",) in chosen:
        rules.append(_root_active(parsed.root))
    features = list(parsed.features)
    order = features + ([_a(f) for f in features] if start else [])
    domains: dict[str, tuple] = {f: _VARIANT_VALUES for f in features}
    domains |= {_a(f): _ACTIVE_VALUES for f in features} if start else {}
    return next(_solve(order, domains, rules), None) is not None


def _statement_rules(model: _Model, statement: tuple[str, ...], start: bool) -> list[Rule]:
    """The rules of one statement; with `start`, its rules over the active set too."""
    kind, *args = statement
    known = set(model.features)
    if kind == "formula":
        if not args[0].isdigit() or int(args[0]) >= len(model.formulas):
            raise ValueError(f"statement {statement!r} names no formula of the model")
    elif not set(args[:1]) <= known or (
        kind in ("includes", "excludes", "alternatives") and args[1] not in known
    ):
        raise ValueError(f"statement {statement!r} names an unknown feature")
    f = args[0] if args and kind != "formula" else None
    parent = model.features[f].parent if f is not None else None
    if kind == "root":
        return [_root_selected_static_early(model.root)]
    if kind == "start":
        return [r for x in model.features for r in (_active_only_if_selected(x), _early_starts_active(x))]
    if kind == "formula":
        formula = model.formulas[int(args[0])]  # (the statement names it by its position)
        return [_formula_holds(formula)] + ([_formula_holds_active(formula)] if start else [])
    if kind == "time-allowed":
        return [_time_allowed(model.features[f])]
    if kind == "mode-allowed":
        return [_mode_allowed(model.features[f])]
    if kind == "sub" and parent is not None:
        rules = [_child_needs_parent(f, parent), _sub_feature(parent, f)]
        return rules + ([_active_child_needs_active_parent(f, parent)] if start else [])
    if kind == "mandatory" and parent is not None:
        rules = [
            _mandatory_child_selected(parent, f),
            _static_parent_requires_mandatory_child(parent, f),
            _dynamic_binding_unit(parent, f),
        ]
        return rules + ([_active_mandatory_child(parent, f)] if start else [])
    if kind == "group":
        label = args[1]
        members = model.group_members(f, label)
        if not members:
            raise ValueError(f"{f!r} has no {label} group")
        rules = [_group_has_selected_member(f, members, label)]
        return rules + ([_active_group_has_member(f, members, label)] if start else [])
    if kind == "alternatives":
        rules = [_runtime_alternatives(f, args[1], "XOR group")]
        return rules + ([_never_both_active(f, args[1], "XOR group")] if start else [])
    if kind == "includes":
        rules = [_includes_selects(f, args[1]), _includes_requires(f, args[1])]
        return rules + ([_active_includes(f, args[1])] if start else [])
    if kind == "excludes":
        rules = [_runtime_alternatives(f, args[1], "excludes")]
        return rules + ([_active_excludes(f, args[1])] if start else [])
    if kind in ("selected", "deselected"):
        return [_rule(f"1 {kind}", (f,), lambda v: _s(v[f]) == (kind == "selected"))]
    if kind == "time" and args[1] in ("Early", "Late"):
        early = args[1] == "Early"
        return [_rule("1 props.time", (f,), lambda v: not _s(v[f]) or _E(v[f]) == early)]
    if kind == "mode" and args[1] in ("Static", "Dynamic"):
        static = args[1] == "Static"
        return [_rule("1 props.mode", (f,), lambda v: not _s(v[f]) or _S(v[f]) == static)]
    raise ValueError(f"not a statement: {statement!r}")


def _active_group_has_member(parent: str, members: list[str], label: str) -> Rule:
    # 2.2 over a: "OR group: s(parent) → s(m1) ∨ … ∨ s(mk)"; for an XOR group this is the
    # "at least one" half of "exactly one active XOR member" (4), the pairs are the other.
    return _rule(
        f"2.2 {label} group has an active member",
        (_a(parent), *map(_a, members)),
        lambda v: _implies(v[_a(parent)], any(v[_a(m)] for m in members)),
    )


def _never_both_active(a: str, b: str, why: str) -> Rule:
    # 4 "at most one of them is *active* at any moment"; "exactly one active XOR member"
    return _rule(f"4 never both active ({why})", (_a(a), _a(b)), lambda v: not (v[_a(a)] and v[_a(b)]))

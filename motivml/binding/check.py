"""Questions asked of the one encoding about a model or a configuration.

A configuration is valid iff the solver finds a variant under its facts; when it does
not, every independent minimal conflict is explained. Analyses of a model alone (a void
model, dead features, bindings a feature allows but can never take) need many solves, so
the CLI runs them when a model is validated without a configuration.
"""

from __future__ import annotations

import contextlib
import functools
import os
import pickle
from array import array
from collections.abc import Callable, Sequence
from dataclasses import replace
from itertools import compress
from typing import Any, BinaryIO, TypeVar, cast

from ..errors import Diagnostic, Location, Severity, warning
from ..language.model import (
    OFF,
    Binding,
    Configuration,
    Entry,
    Feature,
    FeatureModel,
    FeatureState,
    Mode,
    Time,
)
from ..process import no_gc
from ..process.forked import InChild, can_fork
from . import encoding as enc
from .analysis import alternatives_apart, binding_hints, live_features_and_impossible_bindings
from .explain import Explainer
from .repair import configuration_repairs
from .symmetry import Classes

HINTED_FROM = 64  # binding targets from which binding_states hints towards every binding first
# the variants binding_states keeps on a kept encoding for its next configuration, at most
# (`_Known`; 512 of them at 100,000 features would be 153 MB)
RECENT_VARIANTS, RECENT_BYTES = 512, 16 << 20
EXPLAINED_WARNINGS = 20  # per kind: dead features and bindings explained one by one
LISTED_WARNINGS = 100  # per kind: located one by one; the rest are summed up in one warning


def check_variant(model: FeatureModel, config: Configuration, repairs: bool = True) -> list[Diagnostic]:
    """Errors of a configuration: every independent minimal conflict, explained, and (with
    `repairs`) the configuration's minimal repairs (section 6) beside each. A repair fixes
    the whole configuration, so with several conflicts each carries the same list."""
    with no_gc():
        with enc.Encoding(model) as hard:
            hard.set_configuration(config)
            if hard.solve():
                return []
        with enc.Encoding(model, explain=True) as encoding:
            encoding.set_configuration(config)
            explainer = Explainer(encoding, model, config)
            if not encoding.solve(with_config=False):
                return _void(encoding, explainer)
            found = [explainer.diagnostic(mus) for mus in encoding.conflicts()]
        if not repairs:
            return found
        mended = tuple(configuration_repairs(model, config))
    return [replace(d, repairs=mended) for d in found]


def _void(encoding: enc.Encoding, explainer: Explainer) -> list[Diagnostic]:
    return [
        explainer.diagnostic(mus, prefix="the model has no valid variant: ")
        for mus in encoding.conflicts(with_config=False)
    ]


def analyse_model(model: FeatureModel, parallel: bool | None = None) -> list[Diagnostic]:
    """A void model (error); dead features and never-possible bindings (warnings).

    The warnings are explained on a second encoding (the explain build). With `parallel`
    (by default where `os.fork` is there, for models of PARALLEL_FROM features or more), a
    child process builds it, and gets ready to locate messages, while this one searches;
    it explains the dead features as soon as they are known, while the bindings are still
    searched, then the impossible bindings. The child asks the same questions of the same
    encoding in the same order, so the warnings are the same; if it fails in any way, they
    are explained here instead.
    """
    helper: InChild[list[Diagnostic]] | None = None
    try:
        if _parallel(model, parallel):
            helper = InChild.start(functools.partial(_explain_as_told, model))
        with no_gc(), enc.Encoding(model) as hard:
            if not hard.solve(with_config=False):
                if helper is not None:
                    helper.close()  # (it builds for warnings; a void model has none)
                    helper = None
                with enc.Encoding(model, explain=True) as encoding:
                    return _void(encoding, Explainer(encoding, model, None))
            dead: list[int] = []

            def tell_dead(alive: list[bool]) -> None:  # (known before the bindings: the child explains them meanwhile)
                dead.extend(_dead(model, alive))
                if helper is not None:
                    helper.ask(dead)

            _, impossible = live_features_and_impossible_bindings(hard, model, tell_dead)
            if helper is not None:
                helper.ask(impossible)  # (before this solver is deleted: that takes a while)
        if not dead and not impossible:
            return []
        if helper is not None:
            found = helper.result()
            if isinstance(found, list) and all(isinstance(d, Diagnostic) for d in found):
                return found
        with no_gc(), enc.Encoding(model, explain=True) as encoding:
            explainer = Explainer(encoding, model, None)
            return _dead_warnings(encoding, explainer, dead) + _binding_warnings(encoding, explainer, impossible)
    finally:
        if helper is not None:
            helper.close()


def _dead(model: FeatureModel, alive: list[bool]) -> list[int]:
    """The dead features (no valid variant selects them) each highest of its dead subtree."""
    return [f.index for f in model.features if not alive[f.index] and (f.parent is None or alive[f.parent])]


PARALLEL_FROM = 2000  # features: from here `analyse_model` explains in a child process


def _parallel(model: FeatureModel, asked: bool | None) -> bool:
    if asked is not None:
        return asked and hasattr(os, "fork")
    # (a fork copies only the calling thread: with others running, one of them may hold a lock)
    return len(model.features) >= PARALLEL_FROM and can_fork()


def _explain_as_told(model: FeatureModel, requests: BinaryIO) -> list[Diagnostic]:
    """The explaining child's job: the warnings of the dead features (indices) and then of
    the impossible bindings it is sent, explained on an explain build.

    The build is made once there is something to explain: as soon as the dead features are
    known, while the parent still searches the bindings. A model with neither (most) never
    pays for it: at 100,000 features the explain build is 330 MB, and made up front it was
    the peak memory of `validate` (600 MB where the search needs 400)."""
    if model.source is not None:
        model.source.ready_to_locate()  # (while the parent still searches)
    dead: list[int] = pickle.load(requests)
    with no_gc():
        built: list[tuple[enc.Encoding, Explainer]] = []

        def explain_build() -> tuple[enc.Encoding, Explainer]:
            if not built:
                encoding = enc.Encoding(model, explain=True)
                built.append((encoding, Explainer(encoding, model, None)))
            return built[0]

        try:
            found = _dead_warnings(*explain_build(), dead) if dead else []
            impossible: list[tuple[int, str, Time | Mode]] = pickle.load(requests)
            if impossible:
                found += _binding_warnings(*explain_build(), impossible)
            return found
        finally:
            for encoding, _ in built:
                encoding.close()


def _dead_warnings(encoding: enc.Encoding, explainer: Explainer, dead: list[int]) -> list[Diagnostic]:
    """Dead features (indices, each the highest of a dead subtree), the first ones explained.

    Those explained are the EXPLAINED_WARNINGS of largest dead subtree (in model order among
    equals), and each in that order knows the ones before it dead: its conflict says "y is
    dead" where it would spell out y's own conflict again. (Dead features of a 10,000-feature
    model with root formulas were explained by 250-460 facts each, most of them the reasons
    of a few other dead features: 20 such explanations took 5 s of `validate`.) Each
    explanation stands on ones explained before it, never on itself or a later one.
    """
    model = explainer.model
    features = model.features
    listed = dead[:LISTED_WARNINGS]
    size = {i: len(model.subtree(i)) for i in listed}
    reasons: dict[int, Diagnostic] = {}
    known_dead = explainer.known_dead  # queries "y is dead", of the subtrees explained so far
    for i in sorted(listed, key=lambda i: -size[i])[:EXPLAINED_WARNINGS]:
        f = features[i]
        q = encoding.query(enc.FactKind.QUERY_SELECTED, i, encoding.s(i))
        explainer.query_words[q] = f"{f.id} would be selected"
        (mus, *_) = encoding.conflicts(with_config=False, limit=1, queries=[q, *known_dead])
        reasons[i] = explainer.diagnostic(mus)
        for j in model.subtree(i):  # (a conflict may reach a dead subtree anywhere in it)
            known = encoding.query(enc.FactKind.DEAD, j, -encoding.s(j))
            explainer.query_words[known] = f"{features[j].id} is dead" + (f" (below {f.id})" if j != i else "")
            known_dead.append(known)
    found: list[Diagnostic] = []
    for i in listed:
        f = features[i]
        extra = f" (and so are its {size[i] - 1} sub-features)" if size[i] > 1 else ""
        head = f"{f.id} is dead: no valid variant selects it{extra}"
        where = explainer.model_location(f.index, "id")
        if i in reasons:
            found.append(_as_warning(reasons[i], where, head, "model.dead-feature", f.id))
        else:
            found.append(warning(where, head, "model.dead-feature", f.id))
    if len(dead) > LISTED_WARNINGS:
        rest = [features[j] for j in dead[LISTED_WARNINGS:]]
        found.append(_more(rest, model, "model.dead-feature", "dead features"))
    return found


def _binding_warnings(
    encoding: enc.Encoding, explainer: Explainer, impossible: list[tuple[int, str, Time | Mode]]
) -> list[Diagnostic]:
    """Bindings allowed but never possible, the first ones explained."""
    model = explainer.model
    features = model.features
    found: list[Diagnostic] = []
    for count, (i, aspect, value) in enumerate(impossible):
        f = features[i]
        if count >= LISTED_WARNINGS:
            rest = [features[j] for j, _, _ in impossible[count:]]
            found.append(_more(rest, model, "model.impossible-binding", "bindings allowed but never possible"))
            break
        other = {
            Time.EARLY: Time.LATE,
            Time.LATE: Time.EARLY,
            Mode.STATIC: Mode.DYNAMIC,
            Mode.DYNAMIC: Mode.STATIC,
        }[value]
        head = f"{f.id} allows Any binding {aspect} but can never be {value}, only {other}"
        key = "bindingTimeAllowed" if aspect == "time" else "bindingModeAllowed"
        where = explainer.model_location(i, "constraints", key)
        if count >= EXPLAINED_WARNINGS:
            found.append(warning(where, head, "model.impossible-binding", f.id))
            continue
        literal = {
            Time.EARLY: encoding.E(i),
            Time.LATE: -encoding.E(i),
            Mode.STATIC: encoding.S(i),
            Mode.DYNAMIC: -encoding.S(i),
        }
        q1 = encoding.query(enc.FactKind.QUERY_SELECTED, i, encoding.s(i))
        q2 = encoding.query(enc.FactKind.QUERY_BINDING, i, literal[value])
        explainer.query_words[q1] = f"{f.id} would be selected"
        explainer.query_words[q2] = f"{f.id} would be {value}"
        (mus, *_) = encoding.conflicts(with_config=False, limit=1, queries=[q1, q2, *explainer.known_dead])
        found.append(_as_warning(explainer.diagnostic(mus), where, head, "model.impossible-binding", f.id))
    return found


def _more(rest: list[Feature], model: FeatureModel, rule: str, what: str) -> Diagnostic:
    """One warning for what is left after LISTED_WARNINGS of a kind."""
    names = ", ".join(dict.fromkeys(f.id for f in rest[:10]))
    location = model.source.locate(model.path(rest[0].index, "id")) if model.source else Location(model.name)
    return warning(location, f"{len(rest)} more {what}, in {names}{', ...' if len(rest) > 10 else ''}", rule)


def _as_warning(explained: Diagnostic, where: Location, head: str, rule: str, feature: str) -> Diagnostic:
    return Diagnostic(
        Severity.WARNING,
        where,
        f"{head}, because {explained.message}",
        rule,
        feature,
        explained.facts,
    )


def _allowed(model: FeatureModel, entries: dict[str, Entry]) -> list[frozenset[tuple[int, int]]]:
    """Per feature, the (time, mode) signs (1: Early, Static) it may take when selected: what
    the model allows it and the configuration's entry fixes, less Early below a feature
    that is never Early and Static below one never Static (rule 3.2: a selected Early
    feature's parent is Early, a Static one's Static; the parent is selected with it). An
    empty set: no valid variant selects it.

    Times and modes go down the tree as two-bit masks (1: Early or Static, 2: Late or
    Dynamic), each feature's set taken from a table of the 16 (menuconfig asks after every
    decision: sets of pairs made per feature were 8.6 ms of a key press at 2,513 features)."""
    times: list[int] = []
    modes: list[int] = []
    found: list[frozenset[tuple[int, int]]] = []
    for f in model.features:  # (pre-order: a parent before its sub-features)
        t = 3 if f.time_allowed is None else 1 if f.time_allowed is Time.EARLY else 2
        m = 3 if f.mode_allowed is None else 1 if f.mode_allowed is Mode.STATIC else 2
        entry = entries.get(f.id) if entries else None
        if entry is not None and entry.time is not None:
            t &= 1 if entry.time is Time.EARLY else 2
        if entry is not None and entry.mode is not None:
            m &= 1 if entry.mode is Mode.STATIC else 2
        if f.parent is not None:
            above_t, above_m = times[f.parent], modes[f.parent]
            if not (above_t & 1 and above_m):  # (the parent is never Early)
                t &= 2
            if not (above_m & 1 and above_t):  # (never Static)
                m &= 2
        times.append(t)
        modes.append(m)
        found.append(_SIGNS[t][m])
    return found


# the (time, mode) signs of each pair of masks: _SIGNS[times][modes]
_SIGNS = [
    [frozenset((te, ts) for te in (1, -1) if t & (1 if te == 1 else 2) for ts in (1, -1) if m & (1 if ts == 1 else 2)) for m in range(4)]
    for t in range(4)
]


class _Known:
    """The valid variants that `binding_states` found for the last configuration asked of a
    kept encoding (`Encoding.recent`), those of them that hold under the one now set, and
    which of this configuration's targets they show: menuconfig asks again after each
    decision, and many variants found for the last one still hold (Automotive01: some 48
    satisfiable solves a decision without them)."""

    def __init__(self, hard: enc.Encoding, with_config: bool) -> None:
        import numpy as np

        self.hard, self.np = hard, np
        earlier, hard.recent = hard.recent, []
        n = hard.n
        self.rows: Any = np.zeros((0, 3 * n), dtype=np.uint8)
        # the configuration's literals, as the questions assume them (the model's own facts
        # hold in each variant): none when they are asked of the model alone
        config = hard.assumptions(with_config)[hard.model_facts :]
        if earlier:
            rows = np.frombuffer(b"".join(earlier), dtype=np.uint8).reshape(len(earlier), 3 * n)
            at = np.asarray([3 * ((abs(lit) - 1) // 4) + (abs(lit) - 1) % 4 for lit in config], dtype=np.int64)
            wanted = np.asarray([lit > 0 for lit in config], dtype=np.uint8)
            self.rows = rows[(rows[:, at] == wanted).all(axis=1)] if len(at) else rows
            # (those that hold are kept for the next configuration too, the newest last: a
            # decision on Automotive01 then asked 46 solves where it asked 63)
            hard.recent = [row.tobytes() for row in self.rows]
        self._columns: dict[tuple[int, ...], list[bool]] | None = None  # (`shown`'s tables, made once)
        # What the last configuration asked answered (`answered`), if this one holds its
        # literals and more (menuconfig's next decision): a target no variant had then has
        # none now, and one some variant had mostly still has one, which a batch solve
        # shows, so it is not first refuted by a propagation of its own. (A random decision
        # on Automotive01 asked some 400 propagations and 150 failed solves again.)
        then, refuted, had = hard.recent_answers
        now = frozenset(config)
        self._before: set[int | tuple[int, ...]] = refuted if then <= now else set()
        self._had = had if then <= now else set()
        self._found: set[int | tuple[int, ...]] = set(self._before)
        self._shown_now: set[int | tuple[int, ...]] = set()
        hard.recent_answers = (now, self._found, self._shown_now)

    def remember(self, values: list[int]) -> None:
        """Keep a variant found now (a `cover` witness) for the next configuration: up to
        RECENT_VARIANTS, and RECENT_BYTES in all."""
        recent = self.hard.recent
        if len(recent) >= min(RECENT_VARIANTS, max(16, RECENT_BYTES // (3 * self.hard.n + 1))):
            del recent[0]  # (the oldest)
        n, np = self.hard.n, self.np
        # (through C ints: numpy's own conversion of the Python list took 1.3 ms at 10,000 features)
        recent.append((np.frombuffer(array("i", values[: 4 * n]), dtype=np.int32).reshape(n, 4)[:, :3] > 0).tobytes())

    def refuted(self, keys: list[int | tuple[int, ...]]) -> list[bool] | None:
        """Per target (by its `keys`), whether no variant had it under the last
        configuration asked, of which this one holds every literal (and more)."""
        before = self._before
        return [key in before for key in keys] if before else None

    def answered(self, keys: list[int | tuple[int, ...]], possible: list[bool]) -> None:
        """Keep what `cover` answered for the targets (by their `keys`) under this
        configuration, for the next."""
        self._shown_now.update(compress(keys, possible))
        self._found.update(key for key, can in zip(keys, possible, strict=True) if not can)

    def to_refute(self, keys: list[int | tuple[int, ...]]) -> list[bool] | bool:
        """Per target (by its `keys`), whether `cover` should try to refute it by
        propagation: not when it held under the last configuration (most still do, and a
        batch solve shows them)."""
        had = self._had
        return [key not in had for key in keys] if had else True

    def shown(self, targets: list[list[int]]) -> list[bool] | None:
        """Per target (literals of one feature's s, E and S variables: its selection, or
        its selection with a time and a mode), whether a kept variant that holds shows it:
        from per-feature tables of what those variants do (one pass over them)."""
        if not len(self.rows) or not targets:
            return None
        if self._columns is None:
            rows = self.rows.reshape(len(self.rows), self.hard.n, 3).astype(bool)
            on = rows[:, :, 0]
            table: dict[tuple[int, ...], Any] = {  # (the target's signs: s, then E and S) -> per feature: shown
                (1,): on.any(axis=0),
                (-1,): (~on).any(axis=0),
                **{
                    (1, te, ts): (on & (rows[:, :, 1] == (te > 0)) & (rows[:, :, 2] == (ts > 0))).any(axis=0)
                    for te in (1, -1)
                    for ts in (1, -1)
                },
            }
            self._columns = {key: value.tolist() for key, value in table.items()}
        columns = self._columns
        if all(len(t) == 1 for t in targets):  # (selections: a feature's s variable, 4i + 1)
            on, off = columns[(1,)], columns[(-1,)]
            return [(on if t[0] > 0 else off)[(abs(t[0]) - 1) >> 2] for t in targets]
        return [columns[tuple(1 if lit > 0 else -1 for lit in t)][(abs(t[0]) - 1) >> 2] for t in targets]


T = TypeVar("T")


def _selection_hints(hard: enc.Encoding, n: int) -> list[Sequence[int]]:
    """Two polarity hints: every feature selected, and none."""
    selected = [hard.s(i) for i in range(n)]
    return [selected, [-literal for literal in selected]]


def _memo(hard: enc.Encoding, name: str, make: Callable[[], T]) -> T:
    """What `make` gives for this encoding, made once (menuconfig asks its kept encoding
    after every decision: the hints were 11 ms of each at 10,000 features)."""
    if name not in hard.memo:
        hard.memo[name] = make()
    return cast(T, hard.memo[name])


def _keys(targets: list[list[int]]) -> list[int | tuple[int, ...]]:
    """Targets as a set's keys: each one's one literal, or its literals."""
    return [t[0] if len(t) == 1 else tuple(t) for t in targets]


def binding_states(
    model: FeatureModel, config: Configuration | None, kept: enc.Encoding | None = None
) -> list[set[FeatureState]]:
    """Per feature, what valid variants (of the configuration) can make of it.

    Each set holds OFF (not selected) and/or the bindings it can take; a one-element set is
    what the solver forces. This is the paper's "binding semantics interpreter", answered
    by `Encoding.cover`. `kept`: an encoding of the model to ask, kept by the caller for
    the next configuration too (the configurator's, one per session: the configuration is
    assumed, not put in its solver for good); without it, one is made for this question.
    """
    signs = [(1 if b.early else -1, 1 if b.static else -1) for b in Binding]
    # asked of the first of each class of interchangeable features only (symmetry.py)
    same = Classes(model, config)
    m, position = len(same.asked), same.position  # (a parent is never in a class: it has sub-features)
    parents = [model.features[i].parent for i in same.asked]
    with no_gc(), contextlib.nullcontext(kept) if kept is not None else enc.Encoding(model) as hard:
        if config is not None:
            hard.set_configuration(config)
            if kept is None:
                hard.fix_configuration()  # (every question is asked under it)
        # Each feature not selected, then selected (the last target that has a variable
        # gives its hint: selected), a feature's selection only with its parent's: below a
        # dead feature all is settled without a solve, as `analyse` does. Then the bindings
        # of the live features. (A model of 10,000 features, 9,600 of them dead, took 9,600
        # solves and 7 s when each feature's five targets were asked alike.)
        up = [None if p is None else m + position[p] for p in parents]
        apart = alternatives_apart(model, same.asked)
        known = _Known(hard, config is not None) if kept is not None else None
        first = [*([-hard.s(i)] for i in same.asked), *([hard.s(i)] for i in same.asked)]
        keys = _keys(first) if known is not None else []
        selected = hard.cover(
            first,
            with_config=config is not None,
            implied=[*[None] * m, *up],
            requires=[*[None] * m, *up],
            batch=True,
            # (under many decisions most that no variant shows, their propagation refutes)
            refute=known.to_refute(keys) if known is not None else True,
            order=apart + [m + k for k in apart],  # (each selection after its parent's still)
            hints=_memo(hard, "selections", lambda: _selection_hints(hard, len(model.features))),
            witness=known.remember if known is not None else None,
            shown=known.shown(first) if known is not None else None,
            refuted=known.refuted(keys) if known is not None else None,
        )
        if known is not None:
            known.answered(keys, selected)
        alive = [at for at in range(m) if selected[m + at]]
        # Only the bindings a live feature allows are asked about (`_allowed`: its own, its
        # entry's, and what its parent can be), and none when it allows one: a variant that
        # selects it binds it so. A model imported without bindings (each feature Early and
        # Static) asked four targets per feature, three of them refuted one propagation
        # each: at Automotive01's 2,513 features, 0.35 s of a decision's propagation in
        # menuconfig; at 10,000 generated ones, 12,000 propagations and 0.5 s.
        entries = config.entries if config is not None else {}
        every = _allowed(model, entries)
        allowed = {at: every[same.asked[at]] for at in alive}
        targets: list[list[int]] = []
        for at in alive:
            if len(allowed[at]) > 1:
                i = same.asked[at]
                s, e, st = hard.s(i), hard.E(i), hard.S(i)
                targets += [[s, te * e, ts * st] for te, ts in signs if (te, ts) in allowed[at]]
        keys = _keys(targets) if known is not None else []
        answers = hard.cover(
            targets,
            with_config=config is not None,
            batch=True,
            hints=_memo(hard, "bindings", lambda: binding_hints(hard, len(model.features))) if len(targets) > HINTED_FROM else (),
            witness=known.remember if known is not None else None,
            shown=known.shown(targets) if known is not None else None,
            refuted=known.refuted(keys) if known is not None else None,
        )
        if known is not None:
            known.answered(keys, answers)
        bound = iter(answers)
        # per feature asked about: OFF if it can be deselected, then each binding it can
        # take (in Binding's order, as the targets were made: one answer per allowed binding
        # of a feature that allows several, none for one that allows one)
        asked: list[tuple[FeatureState, ...]] = [(OFF,) if can else () for can in selected[:m]]
        bindings = tuple(zip(Binding, signs, strict=True))
        only: dict[frozenset[tuple[int, int]], tuple[FeatureState, ...]] = {}  # (an allowed set of one: its binding)
        for at in alive:
            allow = allowed[at]
            if len(allow) == 1:
                if allow not in only:
                    only[allow] = tuple(b for b, sign in bindings if sign in allow)
                asked[at] += only[allow]
            else:
                asked[at] += tuple([b for b, sign in bindings if sign in allow and next(bound)])
        return [set(found) for found in same.spread(asked)]  # (a set of its own per feature)

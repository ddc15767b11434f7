"""Reconfiguration at run time: loads and unloads as checked transactions (reference.md section 4).

A `Request` asks to load, unload, reload or swap features of a running variant. `plan`
turns it into the new active set, or refuses it with the reason and changes nothing:

* only features of the model, and only selected ones, load; a Static Early feature is
  compiled in, so it is always active and never loads or unloads at run time;
* a Static feature never unloads (a Static Late one stays once loaded), nor reloads;
* unloading a feature unloads its active subtree; loading a feature loads its selected
  mandatory sub-features with it (a Dynamic feature and its mandatory children move as one
  unit); a feature whose parent is inactive loads only with its parent in the same request;
* the resulting active set must satisfy section 2 in full, checked on the one SAT encoding
  (explain build, the variant's literals fixed, the start-state rule that every Early
  feature is active left out): a refusal says which statements of the model the new set
  would break, in the words `validate` uses.

`Reconfigurer` keeps one incremental solver per running variant, so a check costs one solve
(a few hundred microseconds on the example robots); the explanation is computed only for a
refusal.
"""

from __future__ import annotations

import difflib
from collections.abc import Collection
from dataclasses import dataclass, replace
from types import TracebackType

from ..binding import encoding as enc
from ..binding.explain import Explainer
from ..binding.repair import request_corrections
from ..binding.resolve import Variant
from ..errors import Change, ChangeKind, Diagnostic, Location, MotivmlError, Repair, error
from ..language.model import Configuration
from . import requests
from .requests import Request


class Refused(MotivmlError):
    """The request would break a rule of section 4; nothing changed.

    `breaks_relations`: the new active set would break the model's relations (a group, an
    include, a mandatory child), as opposed to a rule about the request itself (a Static
    feature, an inactive parent). Only the first can be mended by moving more features.
    """

    def __init__(self, diagnostics: list[Diagnostic] | Diagnostic, breaks_relations: bool = False) -> None:
        super().__init__(diagnostics)
        self.breaks_relations = breaks_relations


@dataclass(frozen=True)
class Plan:
    """An accepted request: the active set before and after, what loads and unloads."""

    request: Request
    before: frozenset[str]
    after: frozenset[str]
    loads: tuple[str, ...]  # definition order (parents first)
    unloads: tuple[str, ...]  # reverse definition order (children first)


class Reconfigurer:
    def __init__(self, variant: Variant, config: Configuration | None = None) -> None:
        """`config`: the variant's document, to point messages at its entries."""
        self.variant = variant
        self.model = variant.model
        self.config = config
        self.decisions = {d.feature.id: d for d in variant.decisions}
        self.encoding = enc.Encoding(self.model, explain=True)
        self.fixed: list[int] = []
        for d in variant.decisions:
            i = d.feature.index
            e = self.encoding
            b = d.binding
            self.fixed += [e.s(i) if d.selected else -e.s(i), e.E(i) if b.early else -e.E(i)]
            self.fixed.append(e.S(i) if b.static else -e.S(i))
        self.explainer = Explainer(self.encoding, self.model, None, run_time=True)

    # ------------------------------------------------------------------ messages
    def _where(self, feature: str, *keys: str) -> Location:
        if self.config is not None and feature in self.config.entries and self.config.source is not None:
            location: Location = self.config.source.locate(self.config.path(feature, *keys))
            return location
        return self.explainer.model_location(self.model.index[feature], "id")

    def _refuse(self, feature: str, message: str, rule: str, *keys: str) -> Refused:
        return Refused(error(self._where(feature, *keys), message, rule, feature))

    # --------------------------------------------------------------------- plan
    def plan(self, active: Collection[str], request: Request, repairs: bool = True) -> Plan:
        """The new active set of an accepted request; `Refused` says why not, and (with
        `repairs`) how the request could change to be accepted, where moving other features
        would help (reference.md section 6)."""
        request = self._usage(request)
        named = requests.named(request)
        before = frozenset(active)
        if isinstance(request, requests.Reload):
            for feature in request.features:
                self._check_unload(feature, before, "reload")
            return Plan(
                request,
                before,
                before,
                self._ordered(request.features),
                self._ordered(request.features, True),
            )
        to_unload: set[str] = set()
        to_load: set[str] = set()
        outs, ins = _moves(request)
        for feature in outs:
            self._check_unload(feature, before, "unload")
            subtree = {self.model.features[i].id for i in self.model.subtree(self.model.index[feature])}
            to_unload |= subtree & before
        for feature in ins:
            self._check_load(feature, before - to_unload)
            to_load |= self._unit(feature)
        after = (before - to_unload) | to_load
        for feature in sorted(to_load, key=self.model.index.__getitem__):
            parent = self.model[feature].parent
            if parent is not None and self.model.features[parent].id not in after:
                parent_id = self.model.features[parent].id
                refused = self._refuse(
                    feature,
                    f"{feature} is a sub-feature of {parent_id}, which is not active: load {parent_id} in the same "
                    f"request (section 4)",
                    "reconfigure.parent",
                )
                if repairs:
                    refused = Refused(self._with_repairs(refused.diagnostics, before, after, named))
                raise refused
        conflicts = self.encoding.active_set_conflicts(
            self.fixed, [self.model.index[f] for f in after], limit=5
        )
        if conflicts:
            diagnostics = [self.explainer.diagnostic(mus) for mus in conflicts]
            if repairs:
                diagnostics = self._with_repairs(diagnostics, before, after, named)
            raise Refused(diagnostics, breaks_relations=True)
        return Plan(
            request,
            before,
            frozenset(after),
            self._ordered(to_load - (before - to_unload)),
            self._ordered(to_unload, reverse=True),
        )

    def _usage(self, request: Request) -> Request:
        """The request as checked: every feature it names known, swap's two different, none
        loaded and unloaded at once; a feature named twice counts once. Refused otherwise."""
        root = self.explainer.model_location(0)
        named = requests.named(request)
        if not named:
            raise Refused(
                error(
                    root,
                    "swap takes two features (out, then in); the others one or more",
                    "reconfigure.usage",
                )
            )
        for feature in named:
            if feature not in self.model.index:
                close = difflib.get_close_matches(feature, list(self.model.index), n=1, cutoff=0.75)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise Refused(
                    error(
                        self.explainer.model_location(0),
                        f"no feature {feature!r} in the model{hint}",
                        "reconfigure.unknown",
                    )
                )
        if isinstance(request, requests.Swap) and request.out == request.into:
            raise Refused(
                error(root, "swap takes two different features (out, then in)", "reconfigure.usage")
            )
        # (a feature named twice counts once)
        if isinstance(request, requests.Set):
            request = replace(request, loads=tuple(dict.fromkeys(request.loads)), unloads=tuple(dict.fromkeys(request.unloads)))
            both = [f for f in request.loads if f in request.unloads]
            if both:
                raise self._refuse(
                    both[0], f"{both[0]} cannot be loaded and unloaded in one request", "reconfigure.usage"
                )
        elif not isinstance(request, requests.Swap):
            request = replace(request, features=tuple(dict.fromkeys(request.features)))
        return request

    def _with_repairs(
        self,
        diagnostics: list[Diagnostic],
        before: frozenset[str],
        after: Collection[str],
        named: Collection[str],
    ) -> list[Diagnostic]:
        """The diagnostics, each with the smallest changes to the request that section 2
        accepts. What the request names stays as asked (dropping it would "repair" any
        request): the changes load or unload other features besides."""
        model = self.model
        movable = []
        for d in self.variant.decisions[1:]:
            f = d.feature.id
            if not d.selected or f in named:
                continue
            if f in after:  # can it be left inactive? not once a Static feature is active
                if not d.binding.static or f not in before:
                    movable.append(d.feature.index)
            elif not (d.binding.static and d.binding.early):  # (a Static Early one is always active)
                movable.append(d.feature.index)
        found = request_corrections(
            self.encoding, self.fixed, [model.index[f] for f in after], frozenset(movable)
        )
        mended = sorted((self._changes(moves, before) for moves in found), key=len)
        return [replace(d, repairs=tuple(mended)) for d in diagnostics]

    def _changes(self, moves: list[tuple[int, bool]], before: frozenset[str]) -> Repair:
        """Moves of features' activity as changes to the request, in definition order. A move
        that another implies is left out: a feature unloaded (or not loaded) with its parent,
        a mandatory sub-feature loaded with its parent, one kept with its parent when the
        parent's unload is taken back."""
        model = self.model
        direction = dict(moves)
        changes = []
        for i, active in sorted(moves):
            f = model.features[i]
            if f.parent is not None and direction.get(f.parent) is active:
                if not active or f.mandatory or f.id in before:
                    continue
            if active:
                change = (
                    Change(f.id, ChangeKind.UNLOAD, False, f"do not unload {f.id}")
                    if f.id in before
                    else Change(f.id, ChangeKind.LOAD, True, f"also load {f.id}")
                )
            else:
                change = (
                    Change(f.id, ChangeKind.UNLOAD, True, f"also unload {f.id}")
                    if f.id in before
                    else Change(f.id, ChangeKind.LOAD, False, f"do not load {f.id}")
                )
            changes.append(change)
        return tuple(changes)

    def _check_unload(self, feature: str, active: frozenset[str], verb: str) -> None:
        if feature not in active:
            raise self._refuse(
                feature, f"{feature} is not active: there is nothing to {verb}", "reconfigure.inactive"
            )
        binding = self.decisions[feature].binding
        if binding.static:
            why = "it is compiled in" if binding.early else "a Static Late feature stays once it is loaded"
            raise self._refuse(
                feature,
                f"{feature} is bound {binding.words}: a Static feature never unloads or reloads; {why} (section 4)",
                "reconfigure.static",
                "props",
                "mode",
            )

    def _check_load(self, feature: str, active: Collection[str]) -> None:
        d = self.decisions[feature]
        if not d.selected:
            name = self.variant.name or "the variant"
            raise self._refuse(
                feature,
                f"{feature} is not selected in {name}: only selected features load (section 4)",
                "reconfigure.not-selected",
            )
        if feature in active:  # a selected Static Early feature always is: it is compiled in
            raise self._refuse(feature, f"{feature} is already active", "reconfigure.active")

    def _unit(self, feature: str) -> set[str]:
        """The feature and its selected mandatory sub-features, recursively: they load as one."""
        unit, stack = set(), [self.model.index[feature]]
        while stack:
            f = self.model.features[stack.pop()]
            unit.add(f.id)
            stack += [
                c
                for c in f.children
                if self.model.features[c].mandatory and self.decisions[self.model.features[c].id].selected
            ]
        return unit

    def _ordered(self, features: Collection[str], reverse: bool = False) -> tuple[str, ...]:
        return tuple(sorted(features, key=self.model.index.__getitem__, reverse=reverse))

    # --------------------------------------------------------------- lifecycle
    def close(self) -> None:
        self.encoding.close()

    def __enter__(self) -> Reconfigurer:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, value: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def _moves(request: Request) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(the features a request unloads, those it loads), as it names them."""
    if isinstance(request, requests.Swap):
        return (request.out,), (request.into,)
    if isinstance(request, requests.Set):
        return request.unloads, request.loads
    if isinstance(request, requests.Unload):
        return request.features, ()
    if isinstance(request, requests.Load):
        return (), request.features
    return (), ()  # (Reload: planned above)

""" "Why?": why a feature is selected or not, and why it has its time and mode.

Each answer is a statement about the feature and the chain of located facts behind it:

* what the configuration says is its own reason (the entry, located);
* a value the configuration leaves open but every valid variant gives (forced: a feature
  always selected, never selected, always Static...) is explained as a conflict is: the
  opposite is assumed ("grid_map would be Dynamic") and the minimal set of model and
  configuration facts it contradicts is the reason, in the words `validate` uses;
* a value left open is said to be, with what `configure` makes of it and why.

With a variant, the start state is answered too (reference.md section 4): an Early feature
is active at start because every selected Early feature is; a Late one when the start
state needs it.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

from ..errors import LocatedFact
from ..language.model import OFF, Binding, Configuration, FeatureModel, FeatureState, Mode, Time
from ..process import no_gc
from . import encoding as enc
from .explain import Explainer


@dataclass(frozen=True)
class Reason:
    """One answer: `aspect` is "selection", "time", "mode" or "start"; `how` says where the
    value comes from: "configuration", "forced", "open" or "model" (the root, the start
    state's rule)."""

    aspect: str
    statement: str
    how: str
    because: str
    facts: tuple[LocatedFact, ...] = ()

    def as_dict(self) -> dict[str, object]:
        return {
            "aspect": self.aspect,
            "statement": self.statement,
            "how": self.how,
            "because": self.because,
            "facts": [f.as_dict() for f in self.facts],
        }


def why(
    model: FeatureModel,
    config: Configuration | None,
    feature_id: str,
    states: list[set[FeatureState]],
    prefer: Collection[str] = (),
    chosen: tuple[bool, Binding] | None = None,
    active_at_start: bool | None = None,
) -> list[Reason]:
    """Why `feature_id` is what it is under `config` (or in the model alone).

    `states` are `check.binding_states(model, config)`; `chosen` is what `configure`
    makes of the feature (selected, binding), `active_at_start` whether the resolved
    variant starts with it active (None without a configuration).
    """
    f = model[feature_id]
    i = f.index
    possible = states[i]
    entry = config.entries.get(feature_id) if config is not None else None
    reasons: list[Reason] = []
    with no_gc(), enc.Encoding(model, explain=True) as encoding:
        if config is not None:
            encoding.set_configuration(config)
        explainer = Explainer(encoding, model, config)

        def forced(aspect: str, statement: str, opposite: str, *literals: tuple[enc.FactKind, int, str]) -> Reason:
            queries = []
            for kind, literal, words in literals:
                q = encoding.query(kind, i, literal)
                explainer.query_words[q] = words
                queries.append(q)
            (mus, *_) = encoding.conflicts(with_config=config is not None, limit=1, queries=queries)
            explained = explainer.diagnostic(mus)
            return Reason(aspect, statement, "forced", f"{opposite}: {explained.message}", explained.facts)

        def configured(aspect: str, statement: str, *keys: str) -> Reason:
            assert config is not None
            location = config.source.locate(config.path(feature_id, *keys))
            fact = LocatedFact(statement, location, "config")
            return Reason(aspect, statement, "configuration", "the configuration says so", (fact,))

        # --- selection
        selectable = any(state != OFF for state in possible)
        if f.parent is None:
            fact = LocatedFact(f"{f.id} is the root", explainer.model_location(0, "id"), "2.1")
            reasons.append(
                Reason(
                    "selection",
                    f"{f.id} is selected",
                    "model",
                    "the root is always selected, Static and Early (rule 2.1)",
                    (fact,),
                )
            )
            return reasons
        if entry is not None and entry.selected:
            reasons.append(configured("selection", f"{f.id} is selected"))
        elif entry is not None:
            reasons.append(configured("selection", f"{f.id} is not selected", "selected"))
        elif OFF not in possible:
            reasons.append(
                forced(
                    "selection",
                    f"{f.id} is always selected",
                    "it cannot be left out",
                    (enc.FactKind.QUERY_SELECTED, -encoding.s(i), f"{f.id} would not be selected"),
                )
            )
        elif not selectable:
            reasons.append(
                forced(
                    "selection",
                    f"{f.id} is never selected",
                    "it cannot be selected",
                    (enc.FactKind.QUERY_SELECTED, encoding.s(i), f"{f.id} would be selected"),
                )
            )
        else:
            reasons.append(
                Reason(
                    "selection",
                    f"{f.id} is left open",
                    "open",
                    _open_selection(config, chosen),
                )
            )
        if not selectable:
            return reasons

        # --- time and mode, of a selected feature
        selected_query = (enc.FactKind.QUERY_SELECTED, encoding.s(i), f"{f.id} would be selected")
        aspects: list[tuple[str, Time | Mode | None, set[Time | Mode], dict[Time | Mode, int]]] = [
            (
                "time",
                entry.time if entry is not None and entry.selected else None,
                {b.time for b in possible if b != OFF and isinstance(b, Binding)},
                {Time.EARLY: encoding.E(i), Time.LATE: -encoding.E(i)},
            ),
            (
                "mode",
                entry.mode if entry is not None and entry.selected else None,
                {b.mode for b in possible if b != OFF and isinstance(b, Binding)},
                {Mode.STATIC: encoding.S(i), Mode.DYNAMIC: -encoding.S(i)},
            ),
        ]
        for aspect, said, values, literal in aspects:
            if said is None and not model.bindings_declared:
                continue  # (no feature says a binding: every one is the default, nothing to explain)
            if said is not None:
                reasons.append(configured(aspect, f"{f.id} is {said}", "props", aspect))
            elif len(values) == 1:
                (value,) = values
                other = next(v for v in literal if v != value)
                reasons.append(
                    forced(
                        aspect,
                        f"{f.id} is always {value} when selected",
                        f"it cannot be {other}",
                        selected_query,
                        (enc.FactKind.QUERY_BINDING, literal[other], f"{f.id} would be {other}"),
                    )
                )
            else:
                reasons.append(
                    Reason(
                        aspect,
                        f"{f.id}'s {aspect} is left open",
                        "open",
                        _open_binding(aspect, prefer, chosen),
                    )
                )

    # --- the start state of the resolved variant
    if chosen is not None and active_at_start is not None and chosen[0] and model.bindings_declared:
        binding = chosen[1]
        if binding.early:
            reasons.append(
                Reason(
                    "start",
                    f"{f.id} is active at start",
                    "model",
                    f"it is {binding.words}: every selected Early feature is active at start (section 4)",
                )
            )
        elif active_at_start:
            reasons.append(
                Reason(
                    "start",
                    f"{f.id} is active at start",
                    "model",
                    f"it is {binding.words}, and the start state needs it: the active set at start satisfies "
                    "section 2 with the fewest Late features (section 4)",
                )
            )
        else:
            reasons.append(
                Reason(
                    "start",
                    f"{f.id} is not active at start",
                    "model",
                    f"it is {binding.words}: a Late feature is loaded while the robot runs, and the start "
                    "state does not need it (section 4)",
                )
            )
    return reasons


def _open_selection(config: Configuration | None, chosen: tuple[bool, Binding] | None) -> str:
    decided = "the configuration does not decide it" if config is not None else "the model does not decide it"
    text = f"{decided}, and valid variants exist with it and without it"
    if chosen is None:
        return text
    made = "selects it" if chosen[0] else "leaves it out"
    return f"{text}; configure {made} (it selects as few undecided features as the model allows, section 4)"


def _open_binding(aspect: str, prefer: Collection[str], chosen: tuple[bool, Binding] | None) -> str:
    text = "valid variants exist with either value"
    if chosen is None or not chosen[0]:
        return text
    value = chosen[1].time if aspect == "time" else chosen[1].mode
    preferred = ("late" if aspect == "time" else "dynamic") in prefer
    default = (
        "Late, as preferred"
        if preferred and aspect == "time"
        else "Dynamic, as preferred"
        if preferred
        else ("Early, the published default" if aspect == "time" else "Static, the published default")
    )
    return f"{text}; configure makes it {value} (it prefers {default}, section 4)"

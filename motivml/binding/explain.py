"""Sentences for minimal conflicts: from sets of SAT facts to located diagnostics.

A conflict found by the encoding is a minimal set of facts: some *statements* of the model
(a sub-feature, an include, an XOR group...) under the rule that uses them, and some
*values* (what the configuration says, what a feature allows, the root). The sentence
reads "<statements>, but <values>: <why> (rule N)", e.g.

    slam requires gridmap, but gridmap is configured Dynamic: a required feature must be
    Static (binding rule 3.1)

and every fact is attached with its own location, so `--format json` and the text output
can show where each one is written.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..errors import Diagnostic, LocatedFact, Location, Severity
from ..language.model import Configuration, FeatureModel, Mode, Time
from . import encoding as enc

# kind -> (rule, why); the first matching kind in PRIORITY gives the sentence its "why".
WHY: dict[str, tuple[str, str]] = {
    enc.FactKind.START: (
        "section 4",
        "no start state exists: at start every selected Early feature is active, and the active "
        "set needs every active parent's mandatory sub-features, one active member of each of its "
        "groups (exactly one for XOR) and no two active features that exclude each other (section 4)",
    ),
    enc.FactKind.INCLUDE_STATIC: ("3.1", "a required feature must be Static (binding rule 3.1)"),
    enc.FactKind.MANDATORY_STATIC: ("3.1", "a required feature must be Static (binding rule 3.1)"),
    enc.FactKind.INCLUDE_TIME: (
        "3.1",
        "a required feature must be bound no later than the feature that requires it (binding rule 3.1)",
    ),
    enc.FactKind.MANDATORY_TIME: (
        "3.1",
        "a required feature must be bound no later than the feature that requires it (binding rule 3.1)",
    ),
    enc.FactKind.SUB_MODE: ("3.2", "a Dynamic parent cannot have a Static sub-feature (binding rule 3.2)"),
    enc.FactKind.SUB_TIME: ("3.2", "a sub-feature cannot be bound before its parent (binding rule 3.2)"),
    enc.FactKind.UNIT_TIME: (
        "3.2",
        "a mandatory sub-feature of a Dynamic parent is bound with it, at the same time (binding rule 3.2)",
    ),
    enc.FactKind.UNIT_MODE: (
        "3.2",
        "a mandatory sub-feature of a Dynamic parent is bound with it, in the same mode (binding rule 3.2)",
    ),
    enc.FactKind.XOR_PAIR: (
        "3.3",
        "two members of an XOR group can both be selected only as Dynamic alternatives, at most one "
        "of them Early (rules 2.2 and 3.3)",
    ),
    enc.FactKind.XOR_ALTERNATIVES: (
        "3.3",
        "members of an XOR group can be selected together only as Dynamic alternatives, at most one "
        "of them Early, and only one of them is active at a time (rules 2.2 and 3.3)",
    ),
    enc.FactKind.EXCLUDE: (
        "3.3",
        "features that exclude each other can both be selected only as Dynamic alternatives, at most "
        "one of them Early (rules 2.3 and 3.3)",
    ),
    enc.FactKind.FORMULA: ("2.4", "every formula of the model holds over the selection (rule 2.4)"),
    enc.FactKind.GROUP_XOR: ("2.2", "an XOR group needs a selected member when its parent is selected (rule 2.2)"),
    enc.FactKind.GROUP_OR: ("2.2", "an OR group needs a selected member when its parent is selected (rule 2.2)"),
    enc.FactKind.MANDATORY: ("2.2", "a mandatory sub-feature is selected whenever its parent is (rule 2.2)"),
    enc.FactKind.INCLUDE: (
        "2.3",
        "an included feature is selected whenever the feature that includes it is (rule 2.3)",
    ),
    enc.FactKind.PARENT: ("2.1", "a selected feature needs its parent selected (rule 2.1)"),
    enc.FactKind.ROOT: ("2.1", "the root is always selected, Static and Early (rule 2.1)"),
    enc.FactKind.ALLOWED_TIME: ("3", "a feature is bound only as its constraints allow (section 3)"),
    enc.FactKind.ALLOWED_MODE: ("3", "a feature is bound only as its constraints allow (section 3)"),
}
PRIORITY = list(WHY)
_INCLUDES = frozenset({enc.FactKind.INCLUDE, enc.FactKind.INCLUDE_STATIC, enc.FactKind.INCLUDE_TIME})
# Facts about one model relation, said once (by the first of the family in PRIORITY).
_FAMILY = {
    **dict.fromkeys(_INCLUDES, "include"),
    **dict.fromkeys(
        (enc.FactKind.MANDATORY, enc.FactKind.MANDATORY_STATIC, enc.FactKind.MANDATORY_TIME, enc.FactKind.UNIT_TIME, enc.FactKind.UNIT_MODE), "mandatory"
    ),
    **dict.fromkeys((enc.FactKind.PARENT, enc.FactKind.SUB_MODE, enc.FactKind.SUB_TIME), "parent"),
}
VALUE_KINDS = frozenset(
    {
        enc.FactKind.ROOT,
        enc.FactKind.ALLOWED_TIME,
        enc.FactKind.ALLOWED_MODE,
        *enc.CONFIG_KINDS,
        enc.FactKind.QUERY_SELECTED,
        enc.FactKind.QUERY_BINDING,
        enc.FactKind.DEAD,
        enc.FactKind.ACTIVE,
        enc.FactKind.INACTIVE,
    }
)
STATE_KINDS = frozenset({enc.FactKind.START, enc.FactKind.START_EARLY})
# A formula in a conflict about the active set (a start state, a reconfiguration).
START_FORMULA_WHY = (
    "no start state exists: at start every selected Early feature is active, and the active set "
    "satisfies section 2 and every formula of the model (rule 2.4, section 4)"
)
RUN_TIME_FORMULA_WHY = "at every moment the active set satisfies every formula of the model (rule 2.4, section 4)"
RUN_TIME_WHY = (
    "section 4",
    "at every moment the active set has every active parent's mandatory sub-features, one active "
    "member of each of its groups (exactly one for XOR), every feature an active feature includes, "
    "and no two active features that exclude each other (section 4)",
)


class Explainer:
    """Turns facts of one encoding into words and locations."""

    def __init__(
        self,
        encoding: enc.Encoding,
        model: FeatureModel,
        config: Configuration | None,
        run_time: bool = False,
    ) -> None:
        """`run_time`: explain a reconfiguration's active set, not a variant's start state."""
        self.run_time = run_time
        self.encoding = encoding
        self.model = model
        self.config = config
        self.query_words: dict[int, str] = {}
        # Queries (kind DEAD) of features whose death is explained already: a later conflict
        # may stand on them (`check._dead_warnings`).
        self.known_dead: list[int] = []

    def _id(self, i: int) -> str:
        return self.model.features[i].id

    def model_location(self, i: int, *keys: str | int) -> Location:
        doc = self.model.source
        path = self.model.path(i, *keys)
        if doc is None:
            return Location(self.model.name or "model")
        location: Location = doc.locate(path, key=False)
        return location

    def _config_loc(self, i: int, *keys: str) -> Location:
        assert self.config is not None
        doc = self.config.source
        location: Location = doc.locate(self.config.path(self._id(i), *keys))
        return location

    def statement(self, k: int) -> LocatedFact:
        """One fact in words, with its rule and location."""
        fact = self.encoding.facts[k]
        kind, a, b = fact.kind, fact.a, fact.b
        model = self.model
        rule = WHY.get(kind, ("", ""))[0]
        if kind in (enc.FactKind.GROUP_OR, enc.FactKind.GROUP_XOR):
            group = model.groups[a]
            members = ", ".join(self._id(m) for m in group.members)
            return LocatedFact(
                f"{self._id(group.parent)} has the {group.kind} group {members}",
                self.model_location(group.members[0], "group"),
                rule,
            )
        if kind == enc.FactKind.ROOT:
            return LocatedFact(f"{self._id(0)} is the root", self.model_location(0, "id"), rule)
        if kind in STATE_KINDS:
            text = (
                "the active set satisfies section 2 at every moment"
                if self.run_time
                else "the robot must be able to start"
            )
            return LocatedFact(text, self.model_location(0), "section 4")
        if kind in (enc.FactKind.ACTIVE, enc.FactKind.INACTIVE):
            state = "active" if kind == enc.FactKind.ACTIVE else "inactive"
            return LocatedFact(f"{self._id(a)} would be {state}", self.model_location(a, "id"), "request")
        if kind in (enc.FactKind.PARENT, enc.FactKind.SUB_MODE, enc.FactKind.SUB_TIME):
            parent = model.features[a].parent
            assert parent is not None
            return LocatedFact(
                f"{self._id(a)} is a sub-feature of {self._id(parent)}", self.model_location(a, "id"), rule
            )
        if kind in (enc.FactKind.MANDATORY, enc.FactKind.UNIT_TIME, enc.FactKind.UNIT_MODE):
            parent = model.features[a].parent
            assert parent is not None
            where = "isMandatory" if model.features[a].declared_mandatory is not None else "id"
            return LocatedFact(
                f"{self._id(a)} is a mandatory sub-feature of {self._id(parent)}",
                self.model_location(a, where),
                rule,
            )
        if kind in (enc.FactKind.MANDATORY_STATIC, enc.FactKind.MANDATORY_TIME):
            parent = model.features[a].parent
            assert parent is not None
            where = "isMandatory" if model.features[a].declared_mandatory is not None else "id"
            return LocatedFact(
                f"{self._id(parent)} requires its mandatory sub-feature {self._id(a)}",
                self.model_location(a, where),
                rule,
            )
        if kind == enc.FactKind.XOR_ALTERNATIVES:
            group = model.groups[a]
            return LocatedFact(
                f"the {len(group.members)} members of {self._id(group.parent)}'s XOR group are alternatives",
                self.model_location(group.members[0], "group"),
                rule,
            )
        if kind == enc.FactKind.XOR_PAIR:
            parent = model.features[a].parent
            assert parent is not None
            return LocatedFact(
                f"{self._id(a)} and {self._id(b)} are alternatives in {self._id(parent)}'s XOR group",
                self.model_location(b, "group"),
                rule,
            )
        if kind in (enc.FactKind.INCLUDE, enc.FactKind.INCLUDE_STATIC, enc.FactKind.INCLUDE_TIME):
            target = self._id(b)
            position = list(model.features[a].includes).index(target)
            verb = "includes" if kind == enc.FactKind.INCLUDE else "requires"
            return LocatedFact(
                f"{self._id(a)} {verb} {target}",
                self.model_location(a, "constraints", "featuresIncluded", position),
                rule,
            )
        if kind == enc.FactKind.EXCLUDE:
            target = self._id(b)
            position = list(model.features[a].excludes).index(target)
            return LocatedFact(
                f"{self._id(a)} excludes {target}",
                self.model_location(a, "constraints", "featuresExcluded", position),
                rule,
            )
        if kind == enc.FactKind.FORMULA:
            formula = model.formulas[a]
            return LocatedFact(
                f"formula {formula.position + 1}, `{formula.text}`, must hold",
                self.model_location(0, "formulas", formula.position),
                rule,
            )
        if kind == enc.FactKind.ALLOWED_TIME:
            feature = model.features[a]
            return LocatedFact(
                f"{feature.id} allows only {feature.time_allowed} binding",
                self.model_location(a, "constraints", "bindingTimeAllowed"),
                "3",
            )
        if kind == enc.FactKind.ALLOWED_MODE:
            feature = model.features[a]
            return LocatedFact(
                f"{feature.id} allows only {feature.mode_allowed} binding",
                self.model_location(a, "constraints", "bindingModeAllowed"),
                "3",
            )
        if kind in enc.CONFIG_KINDS:
            literal = self.encoding.literals[k]
            if kind == enc.FactKind.CONFIG_SELECTED:
                return LocatedFact(f"{self._id(a)} is selected", self._config_loc(a), "config")
            if kind == enc.FactKind.CONFIG_DESELECTED:
                return LocatedFact(
                    f"{self._id(a)} is not selected", self._config_loc(a, "selected"), "config"
                )
            if kind == enc.FactKind.CONFIG_TIME:
                time = Time.EARLY if literal > 0 else Time.LATE
                return LocatedFact(
                    f"{self._id(a)} is configured {time}", self._config_loc(a, "props", "time"), "config"
                )
            mode = Mode.STATIC if literal > 0 else Mode.DYNAMIC
            return LocatedFact(
                f"{self._id(a)} is configured {mode}", self._config_loc(a, "props", "mode"), "config"
            )
        # queries ("what if f were selected / bound so")
        return LocatedFact(
            self.query_words.get(k, f"{self._id(a)} is assumed"), self.model_location(a, "id"), "query"
        )

    def mentions(self, k: int) -> tuple[int, ...]:
        """Features a fact's sentence names, the one a change most likely concerns first."""
        fact = self.encoding.facts[k]
        if fact.kind in (enc.FactKind.GROUP_OR, enc.FactKind.GROUP_XOR, enc.FactKind.XOR_ALTERNATIVES):
            group = self.model.groups[fact.a]
            return (*group.members, group.parent)
        if fact.kind in _INCLUDES:
            return (fact.b, fact.a)
        if fact.kind in (enc.FactKind.EXCLUDE, enc.FactKind.XOR_PAIR):
            return (fact.a, fact.b)
        if fact.kind == enc.FactKind.FORMULA:
            return tuple(self.model.index[name] for name in self.model.formulas[fact.a].ids())
        parent = self.model.features[fact.a].parent
        return (fact.a,) if parent is None else (fact.a, parent)

    def sentence(
        self, mus: Sequence[int]
    ) -> tuple[str, str, int, dict[int, LocatedFact], tuple[LocatedFact, ...]]:
        """(message, rule, primary fact's index, each fact in words, all facts shown)."""
        facts = self.encoding.facts
        kinds = {facts[k].kind for k in mus}
        main = next((kind for kind in PRIORITY if kind in kinds), None)
        rule, why = WHY[main] if main is not None else ("", "these facts contradict each other")
        if self.run_time:
            main, (rule, why) = enc.FactKind.START, RUN_TIME_WHY
            if enc.FactKind.FORMULA in kinds:
                rule, why = "2.4", RUN_TIME_FORMULA_WHY
        elif main == enc.FactKind.START and enc.FactKind.FORMULA in kinds:
            rule, why = "2.4", START_FORMULA_WHY
        main_k = next((k for k in mus if facts[k].kind == main), mus[0])
        focus = self.mentions(main_k)[0] if main not in VALUE_KINDS else facts[main_k].a

        # One statement per model relation: "slam requires gridmap" says "includes" too.
        statements: dict[tuple[str, int, int], int] = {}
        for k in sorted(
            (k for k in mus if facts[k].kind not in VALUE_KINDS and facts[k].kind not in STATE_KINDS),
            key=lambda k: PRIORITY.index(facts[k].kind),
        ):
            key = (_FAMILY.get(facts[k].kind, facts[k].kind), facts[k].a, facts[k].b)
            statements.setdefault(key, k)
        order = list(mus)
        shown_statements = sorted(statements.values(), key=order.index)
        configured = {
            facts[k].a for k in mus if facts[k].kind in (enc.FactKind.CONFIG_TIME, enc.FactKind.CONFIG_MODE, enc.FactKind.QUERY_BINDING)
        }
        values = [k for k in mus if facts[k].kind in VALUE_KINDS]
        # "x is selected" adds nothing beside "x is configured Late" (only a selected
        # feature has a binding); beside "x excludes y" it is the point, so it stays.
        shown = [
            k
            for k in values
            if not (facts[k].kind in (enc.FactKind.CONFIG_SELECTED, enc.FactKind.QUERY_SELECTED) and facts[k].a in configured)
        ] or values
        # The focus feature first; for each: what the model says, then what is missing,
        # what is set, what is there.
        order_of = {
            enc.FactKind.ROOT: 0,
            enc.FactKind.ALLOWED_TIME: 0,
            enc.FactKind.ALLOWED_MODE: 0,
            enc.FactKind.CONFIG_DESELECTED: 1,
            enc.FactKind.CONFIG_TIME: 2,
            enc.FactKind.CONFIG_MODE: 2,
            enc.FactKind.CONFIG_SELECTED: 3,
        }
        shown.sort(key=lambda k: (facts[k].a != focus, order_of.get(facts[k].kind, 4)))

        words = {k: self.statement(k) for k in mus}
        head = "; ".join(dict.fromkeys(words[k].text for k in shown_statements))
        tail = _join([words[k].text for k in shown])
        message = f"{head}, but {tail}: {why}" if head and tail else f"{head or tail}: {why}"
        # The place to change first: a configured binding (the focus feature's first), then
        # a (de)selection, then the model.
        rank = {enc.FactKind.CONFIG_TIME: 0, enc.FactKind.CONFIG_MODE: 0, enc.FactKind.CONFIG_DESELECTED: 1, enc.FactKind.CONFIG_SELECTED: 2}
        config_facts = sorted(
            (k for k in mus if facts[k].kind in rank),
            key=lambda k: (rank[facts[k].kind], facts[k].a != focus),
        )
        primary_k = next(iter(config_facts or shown_statements or values))
        ordered = tuple(dict.fromkeys(words[k] for k in [*shown_statements, *values]))
        if kinds & STATE_KINDS:
            ordered += (words[next(k for k in mus if facts[k].kind in STATE_KINDS)],)
        return message, rule, primary_k, words, ordered

    def diagnostic(
        self, mus: Sequence[int], severity: Severity = Severity.ERROR, prefix: str = ""
    ) -> Diagnostic:
        message, rule, primary, words, facts = self.sentence(mus)
        fact = self.encoding.facts[primary]
        group = fact.kind in (enc.FactKind.GROUP_OR, enc.FactKind.GROUP_XOR, enc.FactKind.XOR_ALTERNATIVES)
        formula = fact.kind == enc.FactKind.FORMULA
        feature = self._id(self.mentions(primary)[0] if formula else self.model.groups[fact.a].parent if group else fact.a)
        return Diagnostic(severity, words[primary].location, prefix + message, rule, feature, facts)


def _join(parts: list[str]) -> str:
    if len(parts) <= 1:
        return "".join(parts)
    return ", ".join(parts[:-1]) + " and " + parts[-1]

"""The family-wide check of an architecture: no variant activates an element without what it uses."""

from __future__ import annotations

from ..binding import encoding as enc
from ..errors import Diagnostic, error
from ..language.model import FeatureModel
from ..process import no_gc
from .document import Architecture, references


def architecture_bindings(model: FeatureModel, architecture: Architecture) -> list[Diagnostic]:
    """Every element an active element uses is active too, in every variant of the model.

    A family-wide check on the one encoding: for each pair of features (user, used) that
    an architecture reference joins, is there an active set (section 2 over a(f), every
    selected Early feature active) with the user active and the used one not? Then some
    variant cannot be built, and each reference of that pair is an error.
    """
    pairs: dict[tuple[str, str], list[Diagnostic]] = {}
    for ref in references(architecture):
        if ref.user_feature == ref.target_feature:
            continue
        message = (
            f"{ref.element} (feature {ref.user_feature}) uses {ref.kind.removesuffix('s')} {ref.target} of feature "
            f"{ref.target_feature}, but the model lets {ref.target_feature} be inactive while {ref.user_feature} "
            f"is active: bring both with one feature, or make {ref.user_feature} include {ref.target_feature}"
        )
        where = architecture.locate(ref.section, ref.element, *ref.keys)
        pairs.setdefault((ref.user_feature, ref.target_feature), []).append(
            error(where, message, "architecture.binding", ref.user_feature)
        )
    found: list[Diagnostic] = []
    if not pairs:
        return found
    with no_gc(), enc.Encoding(model) as encoding:
        for (user, used), diagnostics in pairs.items():
            i, j = model.index[user], model.index[used]
            if encoding.solve(with_config=False, extra=[encoding.a(i), -encoding.a(j)]):
                found += diagnostics
    return found

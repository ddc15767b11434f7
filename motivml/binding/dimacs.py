"""DIMACS export (reference.md section 8): a model's CNF as FeatureIDE and model counters read it.

    c 1 root_feature          one line per feature: its variable, its id (pre-order)
    c 2 slam
    p cnf 2 2
    1 0
    -2 1 0

The plain export is section 2 (formulas included) over one variable per feature: its count
is the selection count. Variables after the features' are defined by them (XOR counters,
formula operators), so counting them changes nothing; the header names only the features,
since FeatureIDE reads every comment as a variable's name. With bindings it
is sections 2-4 (the encoding's hard build), each feature's time and mode named too, and the
projection onto the variant's variables given as a `c p show ... 0` line (the model counting
competition's format): counted projected onto those, it is the variant count.
"""

from __future__ import annotations

from collections.abc import Iterable

from ..language.model import FeatureModel
from .analysis import variant_cnf
from .encoding import selection_cnf


def selection_dimacs(model: FeatureModel) -> str:
    """Section 2 as FeatureIDE writes a model: only `c <var> <id>` comments, then the CNF."""
    cnf = selection_cnf(model)
    header = [f"c {f.index + 1} {f.id}" for f in model.features]
    return _dimacs(header, cnf.variables, cnf.clauses)


def variant_dimacs(model: FeatureModel) -> str:
    cnf = variant_cnf(model)
    header: list[str] = []
    for f in model.features:
        s, e, st = cnf.projection[3 * f.index : 3 * f.index + 3]
        header += [f"c {s} {f.id}", f"c {e} {f.id}.early", f"c {st} {f.id}.static"]
    header += [
        f"c motivml: sections 2-4 of model {model.root.id} (variants): per feature, selected, Early, "
        "Static (both false when not selected); the other variables (start state, counters) are "
        "existential: count projected onto the `c p show` variables",
        "c p show " + " ".join(map(str, cnf.projection)) + " 0",
    ]
    return _dimacs(header, cnf.variables, cnf.clauses)


def _dimacs(header: list[str], variables: int, clauses: list[list[int]]) -> str:
    lines: Iterable[str] = (" ".join(map(str, clause)) + " 0" for clause in clauses)
    return "\n".join([*header, f"p cnf {variables} {len(clauses)}", *lines]) + "\n"

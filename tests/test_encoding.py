"""Unit tests of binding/encoding.py's own helpers (the encoding's meaning is checked
against brute force in test_property_sat.py)."""

from __future__ import annotations

import pytest
from pysat.solvers import Solver

from motivml.binding import encoding as enc


def test_clauses_reach_glucose_without_pysat_adding_them_one_by_one(monkeypatch: pytest.MonkeyPatch) -> None:
    with Solver(name="glucose4") as solver:
        monkeypatch.setattr(solver, "append_formula", _refuse)  # the fast path must not use it
        enc.add_clauses(solver, iter([[1, 2], [-1], [-2, 3]]))
        assert solver.solve() and solver.get_model() == [-1, 2, 3]
        enc.add_clauses(solver, [[-3]])
        assert not solver.solve()


def test_other_solvers_and_a_pysat_without_its_glucose_function_get_pysat_own_method(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    with Solver(name="minisat22") as other:
        enc.add_clauses(other, [[1], [-1, 2]])
        assert other.solve() and other.get_model() == [1, 2]
    monkeypatch.setattr(enc, "_glucose_functions", lambda: None)
    with Solver(name="glucose4") as solver:
        enc.add_clauses(solver, [[1], [-1]])
        assert not solver.solve()


def _refuse(*args: object, **kwargs: object) -> None:
    raise AssertionError("append_formula was called")


def test_a_conflict_is_shrunk_in_a_solver_of_its_own_variables_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """Glucose decides every variable up to the highest it knows in each solve: the solver
    that shrinks a conflict numbers the conflict's variables anew (7 ms a solve at 100,000
    features otherwise). A dead feature at the end of a long model is explained in a solver
    of a few variables, with the same facts as before."""
    from motivml.documents.loader import parse
    from motivml.language.reader import read_model

    chain = [{"id": f"f{k}", "name": f"F{k}", "isMandatory": False} for k in range(300)]
    chain[-1]["constraints"] = {"featuresIncluded": ["f0"], "featuresExcluded": ["f0"]}
    text = '{"id": "r", "name": "R", "sub": ' + str(chain).replace("'", '"').replace("False", "false") + "}"
    model, _ = read_model(parse(text, "m.json"))
    sizes: list[int] = []

    class Recording(Solver):
        def __init__(self, *args: object, **kwargs: object) -> None:
            super().__init__(*args, **kwargs)  # type: ignore[arg-type]
            sizes.append(self.nof_vars())

    with enc.Encoding(model, explain=True) as encoding:
        query = encoding.query("query-selected", 300, encoding.s(300))
        monkeypatch.setattr(enc, "Solver", Recording)
        (conflict,) = encoding.conflicts(with_config=False, limit=1, queries=[query])
        kinds = sorted(encoding.facts[k].kind for k in conflict)
        assert encoding.top > 1000
    assert kinds == ["allowed-mode", "exclude", "include", "query-selected"]  # (Static: no alternatives)
    assert sizes and max(sizes) < 20


def test_a_run_time_conflict_is_shrunk_with_the_variants_literals_assumed() -> None:
    """active_set_conflicts assumes the variant's literals (`fixed`) in the solver that
    shrinks a conflict, numbered as the conflict's own variables are: amcl, not selected
    in the field variant, cannot be active; the conflict is its being active and the
    start-state statement (an active feature is selected), with the variant assumed."""
    from pathlib import Path

    from motivml.binding.resolve import resolve, start_state
    from motivml.language.reader import load_configuration, load_model

    robot = Path(__file__).resolve().parent.parent / "feature_models" / "simplebot"
    model, _ = load_model(robot / "model.json")
    assert model is not None
    config, _ = load_configuration(robot / "variants" / "field.json", model, partial=True)
    assert config is not None
    variant = resolve(model, config)
    active = [f.index for f in start_state(variant)] + [model.index["amcl"]]
    with enc.Encoding(model, explain=True) as encoding:
        fixed = []
        for d in variant.decisions:
            i = d.feature.index
            fixed.append(encoding.s(i) if d.selected else -encoding.s(i))
            if d.selected:
                fixed += [encoding.E(i) * (1 if d.binding.early else -1), encoding.S(i) * (1 if d.binding.static else -1)]
        conflicts = encoding.active_set_conflicts(fixed, active)
        assert conflicts, "amcl is not selected: it cannot be active"
        facts = {(encoding.facts[k].kind, encoding.model.features[encoding.facts[k].a].id) for k in conflicts[0]}
    assert facts == {("active", "amcl"), ("start", "root_feature")}


@pytest.mark.parametrize("explain", [False, True], ids=["hard build", "explain build"])
def test_clauses_handed_over_while_they_are_made_are_the_same_clauses(
    monkeypatch: pytest.MonkeyPatch, explain: bool
) -> None:
    """Handed to the solver FLUSH_EVERY at a time (to keep memory down), the clauses, the
    kept ones of the explain build and the answers are those of one hand-over at the end."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))
    from families import family
    from helpers import model_of

    model = model_of(family("dense", 300, seed=3))

    def built(every: int) -> tuple[list[list[int]], list[list[int]], bool, list[int]]:
        monkeypatch.setattr(enc, "FLUSH_EVERY", every)
        with enc.Encoding(model, explain=explain, record=True) as encoding:
            assert encoding.recorded is not None
            kept = list(encoding.kept_clauses()) if explain else []
            solved = encoding.solve(with_config=False)
            return list(encoding.recorded), kept, solved, encoding.assignment()

    assert built(7) == built(1 << 30)


def test_recorded_clauses_read_back_as_they_were_made() -> None:
    made = [[1, -2], [3], [], [-4, 5, 6]]
    clauses = enc.Clauses()
    clauses.extend(made[:2])
    clauses.extend([])
    clauses.extend(made[2:])
    assert list(clauses) == made and len(clauses) == 4
    assert clauses[3] == [-4, 5, 6] and clauses[-1] == [-4, 5, 6] and clauses[1:3] == [[3], []]
    with pytest.raises(IndexError):
        clauses[4]
    literals, lengths = clauses.arrays()
    assert literals.tolist() == [1, -2, 3, -4, 5, 6] and lengths.tolist() == [2, 1, 0, 3]


@pytest.mark.parametrize("members", [40, 4000])  # (the second: hinted in numpy, over VECTOR_FROM // 8 literals)
def test_a_hint_selects_one_member_of_each_large_xor_group_at_most(
    monkeypatch: pytest.MonkeyPatch, members: int
) -> None:
    from helpers import model_of

    leaves = [{"id": f"{g}m{k}", "name": "M", "group": "XOR", "isMandatory": False} for g in "ab" for k in range(members)]
    a = {"id": "a", "name": "A", "isMandatory": False, "sub": leaves[:members]}
    b = {"id": "b", "name": "B", "isMandatory": False, "sub": leaves[members:]}
    small = [{"id": f"c{k}", "name": "C", "group": "XOR", "isMandatory": False} for k in range(3)]
    model = model_of({"id": "r", "name": "R", "sub": [a, b, {"id": "c", "name": "C", "isMandatory": False, "sub": small}]})
    with enc.Encoding(model) as encoding:
        told: list[list[int]] = []
        monkeypatch.setattr(encoding.solver, "set_phases", lambda literals: told.append(list(literals)))
        everything = [encoding.s(i) for i in range(len(model.features))]
        encoding.hint([-everything[0], *everything[1:]])
        (hinted,) = told
        selected = {model.features[abs(literal) // 4].id for literal in hinted if literal > 0}
    # the first member of each large group, every feature that is not one, the small group whole
    assert selected == {"a", "b", "am0", "bm0", "c", "c0", "c1", "c2"}
    assert len(hinted) == len(model.features) and hinted[0] < 0

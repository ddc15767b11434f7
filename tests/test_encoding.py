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

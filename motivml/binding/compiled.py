"""A model's compiled forms: its selections and its variants as d-DNNFs, made once and kept
beside the model, then asked for counts, commonalities and uniform samples at once.

Three forms per model (reference.md section 7), each made when first asked for:

* **selections**: the CNF of section 2 (`encoding.selection_cnf`), projected onto all its
  variables: the helper variables it adds (XOR counters, formula operators) are each
  defined by the features', so the count over all of them is the selection count, and
  feature i is variable i + 1;
* **variants**: the CNF of sections 2-4 (`analysis.variant_cnf`), projected onto each
  feature's selection, time and mode (feature i is variables 3i + 1, 3i + 2, 3i + 3: selected,
  Early, Static), so that a variant is counted once whatever start states it has;
* **valid-selections**: the same CNF projected onto the selections alone (feature i is
  variable i + 1): the selections some valid variant makes, which `sample --uniform` draws
  from (a section-2 selection need not have a valid variant: a feature that only Dynamic
  bindings allow cannot be included, rule 3.1; and a valid variant may select two
  alternatives, rule 3.3).

`compiler.py` makes each; ddnnife (LGPL-3.0-or-later, a library this module imports, not
code of ours) answers from it. A form is kept in `.motivml/compiled/` beside the model,
named by its kind and a hash of what was compiled (the compiler's format, the clauses and
the projection): a changed model has another name, so a kept form is never stale, and
`.motivml/compiled/` may be deleted at any time (MOTIVML_COMPILED_DIR, when set, names one
folder to keep every model's forms in instead: a read-only checkout, a cache CI keeps). A
compile that passes its time limit is given up and remembered (a `.gaveup` file), so that
the next command does not wait for it again unless given a longer limit; the caller then
counts with Ganak as before.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
import time
from array import array
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from itertools import chain
from pathlib import Path
from typing import Any

from ..language.model import Binding, FeatureModel
from . import encoding as enc
from .compiler import CompileTimeout, Dnnf, compile_cnf

FORMAT = 2  # what compiler.py writes; a change of meaning takes a new number (and new files)
COMPILE_LIMIT = 60.0  # seconds a compile may take by default before the commands fall back
FOLDER = Path(".motivml") / "compiled"  # beside the model
ELSEWHERE = "MOTIVML_COMPILED_DIR"  # the environment variable that names one folder for all forms instead


class Kind(StrEnum):
    SELECTIONS = "selections"  # section 2's selections (what the selection count counts)
    VARIANTS = "variants"  # sections 2-4's variants, each feature's selection, time and mode
    VALID_SELECTIONS = "valid-selections"  # the selections of valid variants (`sample --uniform`)

    @property
    def words(self) -> str:
        return "selections valid variants make" if self is Kind.VALID_SELECTIONS else str(self)


@dataclass
class CompiledForm:
    """One compiled form, loaded. Literals are over the form's own variables (`literal`)."""

    kind: Kind
    features: int
    variables: int
    path: Path | None  # where it is kept (None: it could not be kept, `not_kept` says why)
    seconds: float  # what the compile took
    made_now: bool
    nodes: int
    _answers: Any = field(default=None, repr=False)  # ddnnife's DdnnfMut
    _text: str | None = field(default=None, repr=False)  # the c2d text, when it is not kept in `path`
    not_kept: str = ""
    _circuit: Circuit | None = field(default=None, repr=False)
    _shares: Shares | None = field(default=None, repr=False)

    def literal(self, feature: int, aspect: str = "selected") -> int:
        """The variable of a feature's selection (or, in the variants form, "early" or
        "static": its time is Early, its mode Static)."""
        if self.kind is not Kind.VARIANTS:
            if aspect != "selected":
                raise ValueError(f"the {self.kind} form has no bindings")
            return feature + 1
        return 3 * feature + {"selected": 1, "early": 2, "static": 3}[aspect]

    def count(self, assumptions: Sequence[int] = ()) -> int:
        """How many selections (or variants) have every literal of `assumptions`."""
        return int(self._answers.count(list(assumptions)))

    def counts(self, variables: Sequence[int], assumptions: Sequence[int] = ()) -> list[int]:
        """For each of `variables`, how many of those with `assumptions` set it true."""
        return [int(c) for c in self._answers.count_multiple(list(assumptions), list(variables))]

    def every_literal(self, assumptions: Sequence[int] = ()) -> tuple[int, dict[int, int]]:
        """How many selections (or variants) have `assumptions`, and for each literal how
        many of those have it too: all at once, in two passes over the nodes
        (`Circuit.every_literal`, in exact integers: for `analyse` from the form; ddnnife's
        `count_multiple` asks once per variable: 212 ms for Automotive01's selections form,
        where this takes 25; it grows with the edges and the digits: 509 ms for
        Automotive01's variants form of 1.85 million edges; `shares` is what menuconfig
        asks after every decision)."""
        return self.circuit().every_literal(assumptions)

    def shares(self, assumptions: Sequence[int], literals: Sequence[int]) -> list[float] | None:
        """Per literal of `literals`, the share of the selections (or variants) with
        `assumptions` that have it too, in floating point (`Shares`: 0.0 and 1.0 exact);
        None when none has the assumptions. What menuconfig shows beside each feature."""
        if self._shares is None:
            self._shares = Shares(self.circuit())
        return self._shares.of(assumptions, literals)

    def circuit(self) -> Circuit:
        """The form's nodes, read once."""
        if self._circuit is None:
            text = self._text if self._text is not None else self.path.read_text() if self.path is not None else ""
            self._circuit = Circuit(text)
        return self._circuit

    def uniform(self, amount: int, seed: int, assumptions: Sequence[int] = ()) -> list[list[int]]:
        """`amount` selections (or variants) with `assumptions`, each drawn uniformly at
        random and independently (so one may come twice), as the literals of the form's
        variables (the selections form: of its features only)."""
        drawn = self._answers.random(list(assumptions), amount, seed)
        if self.kind is not Kind.VARIANTS:
            return [list(sample[: self.features]) for sample in drawn]
        return [list(sample) for sample in drawn]

    def atomic_sets(self, candidates: Sequence[int]) -> list[list[int]]:
        """The sets of two or more of the `candidates` (variables of features that are
        neither core nor dead) that every selection (or variant) has all or none of, by
        ddnnife; each set as its variables."""
        return [sorted(found) for found in self._answers.atomic_sets(list(candidates), [], False)]

    def feature_of(self, variable: int) -> int:
        """The feature whose selection is `variable` (`literal`'s inverse)."""
        return (variable - 1) // 3 if self.kind is Kind.VARIANTS else variable - 1

    def bindings(self, literals: Sequence[int]) -> list[Binding | None]:
        """A variant drawn from the variants form, per feature: its binding, None when off."""
        found: list[Binding | None] = []
        for i in range(self.features):
            selected, early, static = (literals[3 * i + k] > 0 for k in range(3))
            found.append(Binding.from_flags(early, static) if selected else None)
        return found


class Circuit:
    """A smooth d-DNNF read from c2d's text, in Python: for `every_literal` and `Shares`."""

    def __init__(self, text: str) -> None:
        self.kinds = bytearray()  # per node: 0 literal, 1 AND, 2 OR
        self.children: list[tuple[int, ...]] = []
        self.literal: list[int] = []
        for line in text.splitlines()[1:]:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "L":
                self.kinds.append(0)
                self.children.append(())
                self.literal.append(int(parts[1]))
            else:
                self.kinds.append(1 if parts[0] == "A" else 2)
                self.children.append(tuple(map(int, parts[2 if parts[0] == "A" else 3 :])))
                self.literal.append(0)

    def every_literal(self, assumptions: Sequence[int]) -> tuple[int, dict[int, int]]:
        """The model count under `assumptions`, and per literal the count with it too: the
        count upwards, then each node's derivative downwards (a model is counted through
        each of its literals once: the d-DNNF is smooth and deterministic)."""
        kinds, children, literal = self.kinds, self.children, self.literal
        n = len(kinds)
        if n == 0:
            return 0, {}
        ruled_out = {-a for a in assumptions}
        value = [0] * n
        for i in range(n):
            if kinds[i] == 0:
                value[i] = 0 if literal[i] in ruled_out else 1
            elif kinds[i] == 1:
                product = 1
                for c in children[i]:
                    product *= value[c]
                    if not product:
                        break
                value[i] = product
            else:
                value[i] = sum(value[c] for c in children[i])
        through = [0] * n
        through[n - 1] = 1
        for i in range(n - 1, -1, -1):
            above = through[i]
            if not above or kinds[i] == 0:
                continue
            parts = children[i]
            if kinds[i] == 2:
                for c in parts:
                    through[c] += above
                continue
            before = [1]
            for c in parts:
                before.append(before[-1] * value[c])
            after = 1
            for j in range(len(parts) - 1, -1, -1):
                through[parts[j]] += above * before[j] * after
                after *= value[parts[j]]
        counts: dict[int, int] = {}
        for i in range(n):
            if kinds[i] == 0 and value[i]:
                counts[literal[i]] = counts.get(literal[i], 0) + through[i]
        return value[n - 1], counts


class Shares:
    """The share of a smooth d-DNNF's models (under assumptions) that have each literal, in
    floating point: the model counts as logarithms (a count of 10^1,261 is past what a
    float holds), one height of nodes at a time in numpy, from the leaves up, then each
    node's derivative from the root down.

    Only the edges between inner nodes are walked. Nineteen edges in twenty lead to a leaf
    (Automotive01's variants form: 1.77 million of 1.85 million), and a leaf's count is 1,
    or 0 when the assumptions rule its literal out: an AND node with such a leaf counts 0,
    an OR node counts its leaves left, and what a literal's leaves pass on is what passes
    through their parents (an AND parent's derivative times its count, an OR parent's
    derivative). A Python pass in exact integers over that form took 509 ms; the numpy pass
    over every edge, 87 ms; this, some 15.

    Zero is exact (a logarithm of minus infinity), so a share is 0.0 exactly when no model
    has the literal, and 1.0 when none has its negation; every other share is strictly
    between (a share of 1 - 10^-100 is not rounded to 1)."""

    def __init__(self, circuit: Circuit) -> None:
        import numpy as np

        self.circuit = circuit
        kinds, children, literals = circuit.kinds, circuit.children, circuit.literal
        if kinds and kinds[-1] == 0:  # (a root that is a leaf: under an AND of it alone, as every other root is)
            kinds, children, literals = kinds + bytearray([1]), [*children, (len(kinds) - 1,)], [*literals, 0]
        n = self.n = len(kinds)
        kind = np.frombuffer(bytes(kinds), dtype=np.uint8)
        sizes = np.fromiter(map(len, children), dtype=np.int64, count=n)
        parent = np.repeat(np.arange(n, dtype=np.int64), sizes)
        child = np.fromiter(chain.from_iterable(children), dtype=np.int64, count=int(sizes.sum()))
        literal = np.asarray(literals, dtype=np.int64)
        to_leaf = kind[child] == 0
        self.is_and = kind == 1
        # the leaves: per literal, the parents of its leaves (once per edge), grouped
        leaf_parent, leaf_literal = parent[to_leaf], literal[child[to_leaf]]
        order = np.argsort(leaf_literal, kind="stable")
        self.parents_by_literal = leaf_parent[order]
        self.literals, starts = np.unique(leaf_literal[order], return_index=True)
        self.literal_spans = np.stack((starts, np.append(starts[1:], len(order))[: len(starts)]), axis=1)
        self.or_leaves = np.bincount(leaf_parent[~self.is_and[leaf_parent]], minlength=n).astype(np.float64)
        # the inner edges, by the height of their parents (the longest way down to a leaf)
        inner_parent, inner_child = parent[~to_leaf], child[~to_leaf]
        first = np.searchsorted(inner_parent, np.arange(n + 1))
        height = [0] * n
        ends, heights = first.tolist(), inner_child.tolist()
        for i in np.flatnonzero(kind != 0).tolist():
            height[i] = 1 + max((height[c] for c in heights[ends[i] : ends[i + 1]]), default=0)
        by_height: dict[int, list[int]] = {}
        for i in np.flatnonzero(kind != 0).tolist():
            by_height.setdefault(height[i], []).append(i)
        self.levels = [self._level(np.asarray(by_height[h], dtype=np.int64), first, inner_child, np) for h in sorted(by_height)]
        # A deep form with few edges is quicker in exact integers: the numpy pass costs some
        # 20 calls a height (a generated chain's form of 692 heights took 92 ms so, 46 ms in
        # integers), the integers' pass a Python step an edge. The first call times both.
        self.exact: bool | None = None
        self._wanted: tuple[tuple[int, ...], Any] | None = None  # (`_edges_of`, for the literals last asked)

    def _level(self, nodes: Any, first: Any, inner_child: Any, np: Any) -> tuple[Any, ...]:
        """One height's nodes: per kind (AND, OR) those with inner children (the nodes,
        their inner children end to end, where each starts, how many each has) and those
        without; then how the contributions to their children gather (the order that
        groups them by child, the children, where each starts, how many each has)."""
        parts: list[Any] = []
        for wanted in (True, False):
            group = nodes[self.is_and[nodes] == wanted]
            counts = first[group + 1] - first[group]
            with_inner = group[counts > 0]
            counts = counts[counts > 0]
            edges = (
                np.concatenate([inner_child[first[i] : first[i + 1]] for i in with_inner.tolist()])
                if len(with_inner)
                else np.zeros(0, dtype=np.int64)
            )
            parts += [with_inner, edges, np.cumsum(counts) - counts, counts, group[first[group + 1] == first[group]]]
        targets = np.concatenate((parts[1], parts[6]))
        order = np.argsort(targets, kind="stable")
        gathered, starts = np.unique(targets[order], return_index=True)
        return (*parts, order, gathered, starts, np.diff(np.append(starts, len(order))))

    def of(self, assumptions: Sequence[int], literals: Sequence[int]) -> list[float] | None:
        """Per literal of `literals`, the share of the models with `assumptions` that have
        it; None when no model has them."""
        if not self.n:
            return None
        if self.exact is None:
            began = time.perf_counter()
            self._exactly(assumptions, literals)
            middle = time.perf_counter()
            found = self._in_floats(assumptions, literals)
            self.exact = middle - began < time.perf_counter() - middle
            return found
        return self._exactly(assumptions, literals) if self.exact else self._in_floats(assumptions, literals)

    def _in_floats(self, assumptions: Sequence[int], literals: Sequence[int]) -> list[float] | None:
        """`of` by the numpy pass in logarithms."""
        import numpy as np

        minus = -np.inf
        ruled_out = {-a for a in assumptions}
        dead = np.zeros(self.n, dtype=bool)  # AND nodes with a leaf ruled out
        leaves_left = self.or_leaves.copy()
        for lit in ruled_out:
            at = np.searchsorted(self.literals, lit)
            if at < len(self.literals) and self.literals[at] == lit:
                start, end = self.literal_spans[at]
                parents = self.parents_by_literal[start:end]
                and_parents = self.is_and[parents]
                dead[parents[and_parents]] = True
                np.subtract.at(leaves_left, parents[~and_parents], 1.0)
        value = np.zeros(self.n)
        with np.errstate(invalid="ignore", divide="ignore"):
            log_leaves = np.log(leaves_left)
            for level in self.levels:
                and_nodes, and_edges, and_starts, _, and_bare, or_nodes, or_edges, or_starts, or_counts, or_bare = level[:10]
                if len(and_nodes):
                    value[and_nodes] = np.add.reduceat(value[and_edges], and_starts)
                value[and_bare] = 0.0
                if len(or_nodes):
                    value[or_nodes] = np.logaddexp(_log_sums(value[or_edges], or_starts, or_counts, np), log_leaves[or_nodes])
                value[or_bare] = log_leaves[or_bare]
                for group in (and_nodes, and_bare):
                    value[group[dead[group]]] = minus
            root = value[self.n - 1]
            if root == minus:
                return None
            through = np.full(self.n, minus)
            through[self.n - 1] = 0.0
            for level in reversed(self.levels):
                and_nodes, and_edges, and_starts, and_counts, _, or_nodes, _, _, or_counts, _ = level[:10]
                order, gathered, starts, counts = level[10:]
                below = value[and_edges]
                zero = np.isneginf(below)
                if len(and_nodes):
                    zeros = np.repeat(np.add.reduceat(zero, and_starts) + dead[and_nodes], and_counts)
                    rest = np.repeat(through[and_nodes] + np.add.reduceat(np.where(zero, 0.0, below), and_starts), and_counts)
                    from_and = np.where(zeros == 0, rest - below, np.where((zeros == 1) & zero, rest, minus))
                else:
                    from_and = below
                contributions = np.concatenate((from_and, np.repeat(through[or_nodes], or_counts)))[order]
                if len(contributions):
                    through[gathered] = np.logaddexp(through[gathered], _log_sums(contributions, starts, counts, np))
            # what each literal's leaves pass on, over the models: through each parent
            passed = through + np.where(self.is_and, value, 0.0) - root
            kept, edges, spans = self._edges_of(literals, np)
            chosen = passed[edges]
            reached = np.add.reduceat(np.isfinite(chosen), spans).tolist() if len(edges) else []
            share = np.add.reduceat(np.exp(chosen), spans).tolist() if len(edges) else []
        found = {lit: (bool(reached[k]) and lit not in ruled_out, share[k]) for k, lit in enumerate(kept)}
        shares: list[float] = []
        for lit in literals:
            (have, part), (lack, _) = found.get(lit, (False, 0.0)), found.get(-lit, (False, 0.0))
            shares.append(0.0 if not have else 1.0 if not lack else min(max(part, _LEAST), _MOST))
        return shares

    def _exactly(self, assumptions: Sequence[int], literals: Sequence[int]) -> list[float] | None:
        """`of` from the exact counts (`Circuit.every_literal`)."""
        total, through = self.circuit.every_literal(assumptions)
        if not total:
            return None
        shares: list[float] = []
        for lit in literals:
            have = through.get(lit, 0)
            shares.append(0.0 if not have else 1.0 if have == total else min(max(have / total, _LEAST), _MOST))
        return shares

    def _edges_of(self, literals: Sequence[int], np: Any) -> tuple[list[int], Any, Any]:
        """The literals of `literals` and their negations that have leaves, the parents of
        those leaves (once per edge, grouped by literal, in that order), and where each
        literal's start: made once for the literals asked about (menuconfig asks about
        the same ones after every decision)."""
        key = tuple(literals)
        if self._wanted is None or self._wanted[0] != key:
            kept: list[int] = []
            pieces: list[Any] = []
            spans: list[int] = []
            at = 0
            for lit in dict.fromkeys([*key, *(-lit for lit in key)]):
                k = int(np.searchsorted(self.literals, lit))
                if k < len(self.literals) and self.literals[k] == lit:
                    start, end = self.literal_spans[k].tolist()
                    kept.append(lit)
                    pieces.append(self.parents_by_literal[start:end])
                    spans.append(at)
                    at += end - start
            edges = np.concatenate(pieces) if pieces else np.zeros(0, dtype=np.int64)
            self._wanted = (key, (kept, edges, np.asarray(spans, dtype=np.int64)))
        return self._wanted[1]


_LEAST, _MOST = math.nextafter(0.0, 1.0), math.nextafter(1.0, 0.0)  # the shares strictly between


def _log_sums(values: Any, starts: Any, counts: Any, np: Any) -> Any:
    """log(sum(exp(x))) over each segment of `values` (its starts, its lengths; none empty):
    minus infinity where every x is."""
    top = np.maximum.reduceat(values, starts)
    safe = np.where(np.isneginf(top), 0.0, top)
    total = np.add.reduceat(np.exp(values - np.repeat(safe, counts)), starts)
    return np.where(np.isneginf(top), -np.inf, safe + np.log(total))


@dataclass(frozen=True)
class NotCompiled:
    """Why no compiled form is at hand."""

    reason: str


def cnf(model: FeatureModel, kind: Kind) -> tuple[int, list[list[int]], list[int]]:
    """(variables, clauses, projection) of a form."""
    if kind is Kind.SELECTIONS:
        selection = enc.selection_cnf(model, compact=True)
        return selection.variables, selection.clauses, list(range(1, selection.variables + 1))
    from .analysis import variant_cnf

    variant = variant_cnf(model)
    if kind is Kind.VALID_SELECTIONS:
        return variant.variables, variant.clauses, variant.projection[0::3]
    return variant.variables, variant.clauses, variant.projection


def key(kind: Kind, variables: int, clauses: Sequence[Sequence[int]], projection: Sequence[int]) -> str:
    """The name of what is compiled: its kind, the compiler's format, the clauses and the
    projection, hashed."""
    digest = hashlib.sha256(f"motivml compiled form {FORMAT} {kind} {variables}\n".encode())
    digest.update(array("i", projection).tobytes())
    for clause in clauses:
        digest.update(array("i", [*clause, 0]).tobytes())
    return digest.hexdigest()[:24]


def compiled_form(
    model: FeatureModel,
    beside: Path | None,
    kind: Kind,
    limit: float | None = COMPILE_LIMIT,
    make: bool = True,
    stop: Callable[[], bool] | None = None,
) -> CompiledForm | NotCompiled:
    """The kept compiled form of `model` (in `beside`/.motivml/compiled, or where
    MOTIVML_COMPILED_DIR says; None: keep nothing), or one made now within `limit` seconds
    (None: no limit) if `make`; `stop()` true gives the compile up at once (nothing is
    remembered)."""
    variables, clauses, projection = cnf(model, kind)
    name = f"{kind}-{key(kind, variables, clauses, projection)}"
    elsewhere = os.environ.get(ELSEWHERE)
    folder = Path(elsewhere) if elsewhere else beside / FOLDER if beside is not None else None
    if folder is not None:
        kept = _kept(folder, name, kind, len(model.features))
        if kept is not None:
            return kept
        gave_up = _gave_up(folder / f"{name}.gaveup")
        if gave_up is not None and (limit is not None and limit <= gave_up):
            return NotCompiled(f"its compile was given up after {gave_up:g} s before (`motivml compile` with a longer --limit tries again)")
    if not make:
        return NotCompiled("it is not compiled yet (`motivml compile`)")
    started = time.monotonic()
    try:
        dnnf = compile_cnf(variables, clauses, projection, None if limit is None else started + limit, stop)
    except CompileTimeout:
        if stop is not None and stop():
            return NotCompiled("its compile was stopped")
        if folder is not None and limit is not None:
            _keep(folder, {f"{name}.gaveup": json.dumps({"format": FORMAT, "limit": limit}) + "\n"})
        return NotCompiled(f"its compile did not end within {limit:g} s")
    seconds = time.monotonic() - started
    if folder is not None:
        try:
            (folder / f"{name}.gaveup").unlink(missing_ok=True)  # (an earlier, shorter try's)
        except OSError:
            pass  # (nothing can be kept there: `_made` says so)
    return _made(dnnf, folder, name, kind, len(model.features), seconds)


def _made(dnnf: Dnnf, folder: Path | None, name: str, kind: Kind, features: int, seconds: float) -> CompiledForm:
    """The new form loaded, and kept in `folder` when it can be (else in a temporary file
    that is gone once ddnnife has read it)."""
    import io

    text = io.StringIO()
    dnnf.write_c2d(text)
    data = text.getvalue()
    meta = {
        "format": FORMAT,
        "kind": str(kind),
        "features": features,
        "variables": dnnf.variables,
        "nodes": len(dnnf.nodes),
        "decisions": dnnf.decisions,
        "seconds": round(seconds, 3),
        "sha256": hashlib.sha256(data.encode()).hexdigest(),
    }
    path = None
    why = "no folder to keep it in" if folder is None else _keep(
        folder, {f"{name}.nnf": data, f"{name}.json": json.dumps(meta, indent=2) + "\n"}
    )
    if not why:
        path = folder / f"{name}.nnf" if folder is not None else None
        assert path is not None
        answers = _load(path, dnnf.variables)
    else:
        handle, temporary = tempfile.mkstemp(suffix=".nnf")
        try:
            with os.fdopen(handle, "w") as out:
                out.write(data)
            answers = _load(Path(temporary), dnnf.variables)
        finally:
            os.unlink(temporary)
    form = CompiledForm(
        kind, features, dnnf.variables, path, seconds, True, len(dnnf.nodes), answers, data if path is None else None
    )
    form.not_kept = why
    return form


def _kept(folder: Path, name: str, kind: Kind, features: int) -> CompiledForm | None:
    """The form kept under `name`, if it is there whole (its text has the hash its
    description names); None otherwise (then it is made again)."""
    path, described = folder / f"{name}.nnf", folder / f"{name}.json"
    try:
        meta = json.loads(described.read_text())
        data = path.read_bytes()
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            return None
        if hashlib.sha256(data).hexdigest() != meta.get("sha256"):
            return None
        variables = int(meta["variables"])
        answers = _load(path, variables)
        return CompiledForm(kind, features, variables, path, float(meta["seconds"]), False, int(meta["nodes"]), answers)
    except Exception:  # noqa: BLE001 - (unreadable, damaged, gone meanwhile, refused by ddnnife: made again)
        return None


def _gave_up(path: Path) -> float | None:
    """The limit that an earlier compile passed, if one did."""
    try:
        meta = json.loads(path.read_text())
        return float(meta["limit"]) if isinstance(meta, dict) and meta.get("format") == FORMAT else None
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _keep(folder: Path, files: dict[str, str]) -> str:
    """Write `files` into `folder` (each whole or not at all); why not, when they cannot
    be written there (read-only, full): the form is then not kept, which costs a compile
    next time; '' when written."""
    from ..documents.writing import write_if_changed
    from ..errors import EnvironmentProblem

    try:
        fresh = not folder.exists()
        write_if_changed(folder, files)
        if fresh and folder.parent.name == ".motivml":  # (a cache beside the model: never to be committed)
            write_if_changed(folder.parent, {".gitignore": "# motivml's kept answers: made again when missing\n*\n"})
        return ""
    except EnvironmentProblem as exc:
        said = exc.diagnostics[0] if exc.diagnostics else None
        return f"{said.location}: {said.message}" if said is not None else f"{folder}: cannot write"


def _load(path: Path, variables: int) -> Any:
    import ddnnife

    return ddnnife.Ddnnf.from_file(str(path), variables).as_mut()

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
import os
import tempfile
import time
from array import array
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
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
        (`Circuit.every_literal`; ddnnife's `count_multiple` asks once per variable: 212 ms
        for Automotive01's selections form, where this takes 25; it grows with the nodes
        and the digits: 166 ms for eCos's selections form of 48,916 nodes, 509 ms for
        Automotive01's variants form of 27,464)."""
        if self._circuit is None:
            text = self._text if self._text is not None else self.path.read_text() if self.path is not None else ""
            self._circuit = Circuit(text)
        return self._circuit.every_literal(assumptions)

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
    """A smooth d-DNNF read from c2d's text, in Python: for `every_literal`."""

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

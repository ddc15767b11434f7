"""Questions asked of the one encoding about a model or a configuration.

A configuration is valid iff the solver finds a variant under its facts; when it does
not, every independent minimal conflict is explained. Analyses of a model alone (a void
model, dead features, bindings a feature allows but can never take) need many solves, so
the CLI runs them when a model is validated without a configuration.
"""

from __future__ import annotations

import os
import pickle
import signal
import threading
from dataclasses import replace
from typing import BinaryIO, NoReturn

from ..documents.forked import HELD, can_fork, die_with_parent, end, unblock
from ..documents.loader import no_gc
from ..errors import Diagnostic, Location, Severity, warning
from ..language.model import OFF, Binding, Configuration, Feature, FeatureModel, FeatureState, Mode, Time
from . import encoding as enc
from .analysis import live_features_and_impossible_bindings
from .explain import Explainer
from .repair import configuration_repairs

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
    helper: _Helper | None = None
    try:
        if _parallel(model, parallel):
            helper = _Helper.start(model)
        with no_gc(), enc.Encoding(model) as hard:
            if not hard.solve(with_config=False):
                if helper is not None:
                    helper.close()  # (it builds for warnings; a void model has none)
                    helper = None
                with enc.Encoding(model, explain=True) as encoding:
                    return _void(encoding, Explainer(encoding, model, None))
            def explain_dead(alive: list[bool]) -> None:  # (explained while the bindings are searched)
                if helper is not None:
                    helper.ask(_dead(model, alive))

            alive, impossible = live_features_and_impossible_bindings(
                hard, model, explain_dead if helper is not None else None
            )
            dead = _dead(model, alive)
            if helper is not None:
                helper.ask(impossible)  # (before this solver is deleted: that takes a while)
        if not dead and not impossible:
            return []
        if helper is not None:
            found = helper.answer()
            if found is not None:
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


class _Helper:
    """A child process that builds the explain encoding and explains the warnings it is
    sent: first the dead features (indices), then the impossible bindings; it answers with
    their diagnostics, pickled. Each message is a pickle on a pipe."""

    def __init__(self, pid: int, to_child: BinaryIO, from_child: BinaryIO) -> None:
        self.pid, self._to, self._from = pid, to_child, from_child
        self._writing: threading.Thread | None = None

    @classmethod
    def start(cls, model: FeatureModel) -> _Helper | None:
        """The helper, forked now; None if it cannot be (then nothing is left behind).

        Ctrl-C and SIGTERM are held back from the fork until the helper is set up (or its
        child ended), so that an interruption never leaves a child unreaped or running
        this process's own exit path in the child."""
        pipes: list[int] = []
        held = HELD & signal.valid_signals()
        parent = os.getpid()
        made: _Helper | None = None
        signal.pthread_sigmask(signal.SIG_BLOCK, held)
        pid = 0
        try:
            try:
                down, up = os.pipe(), os.pipe()
                pipes = [*down, *up]
                pid = os.fork()
            except OSError:
                for fd in pipes:
                    os.close(fd)
                return None
            if pid == 0:
                _child(model, down, up, parent)
            try:
                os.close(down[0])
                os.close(up[1])
                made = cls(pid, open(down[1], "wb"), open(up[0], "rb"))
            except BaseException:
                end(pid)
                for fd in (down[1], up[0]):
                    try:
                        os.close(fd)
                    except OSError:
                        pass
                raise
        finally:
            unblock(held, made)
        return made

    def ask(self, what: object) -> None:
        """Send `what`, from a thread: a message larger than the pipe holds would otherwise
        hold this process up until the child, still building, reads it."""
        if not self.pid:  # (ended already: nothing to send)
            return
        if self._writing is not None:
            self._writing.join()  # (in order)
        message = pickle.dumps(what)
        writing = threading.Thread(target=self._write, args=(message,), name="motivml-explain-ask")
        try:
            writing.start()
        except RuntimeError:  # (no thread to be had: the child gets nothing, and `answer` says None)
            end(self.pid)
            self.pid = 0
            return
        self._writing = writing

    def _write(self, message: bytes) -> None:
        try:
            self._to.write(message)
            self._to.flush()
        except (OSError, ValueError):  # (the child has gone, or the pipe was closed: no answer)
            pass

    def answer(self) -> list[Diagnostic] | None:
        """The child's diagnostics; None if it ended without them."""
        if self._writing is not None:
            self._writing.join()
        if not self.pid:
            return None
        try:
            found = pickle.load(self._from)
        except Exception:  # noqa: BLE001 - an unpickling error, end of file, an OSError: no answer
            return None
        if not isinstance(found, list) or not all(isinstance(d, Diagnostic) for d in found):
            return None
        return found

    def close(self) -> None:
        """End the child (at once, if it is still at work) and reap it."""
        if self.pid:
            end(self.pid)
            self.pid = 0
        if self._writing is not None:
            self._writing.join()  # (a write to a child killed ends at once)
        for stream in (self._to, self._from):
            try:
                stream.close()
            except OSError:
                pass


def _child(model: FeatureModel, down: tuple[int, int], up: tuple[int, int], parent: int) -> NoReturn:
    """The helper's process, from the fork to its end (whatever happens, it ends here):
    requests come on `down`, the answer goes on `up`."""
    code = 1
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # (Ctrl-C is the parent's to handle; it ends this)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD & signal.valid_signals())
        die_with_parent(parent)
        os.close(down[1])
        os.close(up[0])
        with open(down[0], "rb") as requests, open(up[1], "wb") as answers:
            _explain_as_told(model, requests, answers)
        code = 0
    except BaseException:  # noqa: BLE001, S110 - the parent explains instead (it sees no answer)
        pass
    finally:
        os._exit(code)


def _explain_as_told(model: FeatureModel, requests: BinaryIO, answers: BinaryIO) -> None:
    """The helper's work (in the child)."""
    with no_gc(), enc.Encoding(model, explain=True) as encoding:
        explainer = Explainer(encoding, model, None)
        if model.source is not None:
            model.source.ready_to_locate()  # (while the parent still searches)
        found = _dead_warnings(encoding, explainer, pickle.load(requests))
        found += _binding_warnings(encoding, explainer, pickle.load(requests))
        pickle.dump(found, answers)  # (before the solver is deleted: that takes a while, and waits for none)
        answers.flush()


def _dead_warnings(encoding: enc.Encoding, explainer: Explainer, dead: list[int]) -> list[Diagnostic]:
    """Dead features (indices, each the highest of a dead subtree), the first ones explained."""
    model = explainer.model
    features = model.features
    found: list[Diagnostic] = []
    for count, i in enumerate(dead):
        f = features[i]
        below = len(model.subtree(f.index)) - 1
        extra = f" (and so are its {below} sub-features)" if below else ""
        head = f"{f.id} is dead: no valid variant selects it{extra}"
        if count >= LISTED_WARNINGS:
            found.append(_more([features[j] for j in dead[count:]], model, "model.dead-feature", "dead features"))
            break
        if count >= EXPLAINED_WARNINGS:
            found.append(warning(explainer.model_location(f.index, "id"), head, "model.dead-feature", f.id))
            continue
        q = encoding.query("query-selected", f.index, encoding.s(f.index))
        explainer.query_words[q] = f"{f.id} would be selected"
        (mus, *_) = encoding.conflicts(with_config=False, limit=1, queries=[q])
        where = explainer.model_location(f.index, "id")
        found.append(_as_warning(explainer.diagnostic(mus), where, head, "model.dead-feature", f.id))
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
        q1 = encoding.query("query-selected", i, encoding.s(i))
        q2 = encoding.query("query-binding", i, literal[value])
        explainer.query_words[q1] = f"{f.id} would be selected"
        explainer.query_words[q2] = f"{f.id} would be {value}"
        (mus, *_) = encoding.conflicts(with_config=False, limit=1, queries=[q1, q2])
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


def binding_states(model: FeatureModel, config: Configuration | None) -> list[set[FeatureState]]:
    """Per feature, what valid variants (of the configuration) can make of it.

    Each set holds OFF (not selected) and/or the bindings it can take; a one-element set is
    what the solver forces. This is the paper's "binding semantics interpreter", answered
    by `Encoding.cover`.
    """
    states: tuple[FeatureState, ...] = (OFF, *Binding)
    signs = [(1 if b.early else -1, 1 if b.static else -1) for b in Binding]
    with no_gc(), enc.Encoding(model) as hard:
        if config is not None:
            hard.set_configuration(config)
        targets: list[list[int]] = []
        for f in model.features:
            i = f.index
            s, e, st = hard.s(i), hard.E(i), hard.S(i)
            targets.append([-s])
            targets += [[s, te * e, ts * st] for te, ts in signs]
        possible = hard.cover(targets, with_config=config is not None)
    k = len(states)
    return [{states[j] for j in range(k) if possible[k * f.index + j]} for f in model.features]

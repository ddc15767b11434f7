"""analyse_model's explanations in a child process: the same warnings as in this one,
and whatever the child does, the parent still answers and leaves no process behind."""

from __future__ import annotations

import functools
import io
import json
import os
import pickle
import signal
import threading
from types import SimpleNamespace
from typing import Any

import pytest
from helpers import feature
from hypothesis import HealthCheck, given, settings
from test_property_sat import models

from motivml.binding import check
from motivml.binding.check import analyse_model
from motivml.documents.loader import parse
from motivml.language.model import FeatureModel
from motivml.language.reader import read_model
from motivml.process import forked
from motivml.process.forked import InChild

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="no os.fork here: the analyses run in one process")


def read(raw: dict[str, Any]) -> FeatureModel:
    model, _ = read_model(parse(json.dumps(raw), "model.json"))
    assert model is not None
    return model


def warned() -> FeatureModel:
    """Two dead features and a binding never possible: each kind explained."""
    return read(
        feature(
            "r",
            [
                feature("a", isMandatory=False, time="Any", mode="Any", exc=["b"]),
                feature("b", isMandatory=True, time="Early", mode="Static", inc=["e"]),
                feature("c", isMandatory=False, time="Any", mode="Any", inc=["a"]),
                feature("e", isMandatory=False, time="Any", mode="Any"),  # (Static and Early: b needs it)
            ],
        )
    )


def no_child_left() -> bool:
    try:
        os.waitpid(-1, os.WNOHANG)
    except ChildProcessError:
        return True
    return False


@pytest.fixture
def answered(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """Whether each helper's answer came (so that the parent did not explain instead)."""
    seen: list[bool] = []
    result = InChild.result

    def recorded(self: InChild[Any]) -> Any:
        found = result(self)
        seen.append(isinstance(found, list))
        return found

    monkeypatch.setattr(InChild, "result", recorded)
    return seen


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(models(max_features=9))
def test_the_child_explains_as_this_process_does(answered: list[bool], raw: dict[str, Any]) -> None:
    model = read(raw)
    answered.clear()
    assert analyse_model(model, parallel=True) == analyse_model(read(raw), parallel=False)
    assert all(answered)  # (none asked of a model without warnings, or a void one)
    assert no_child_left()


def test_the_child_s_explanations_are_the_ones_shown(answered: list[bool]) -> None:
    assert analyse_model(warned(), parallel=True) == analyse_model(warned(), parallel=False)
    assert answered == [True]


def many() -> FeatureModel:
    """Dead features and impossible bindings past what is explained and what is listed."""
    dead = [feature(f"d{k}", isMandatory=False, time="Any", mode="Any", inc=["x"]) for k in range(5)]
    fixed = [feature(f"e{k}", isMandatory=False, time="Any", mode="Any") for k in range(5)]
    return read(
        feature(
            "r",
            [
                feature("x", isMandatory=False, time="Any", mode="Any", exc=["m"]),
                feature("m", isMandatory=True, time="Early", mode="Static", inc=[f"e{k}" for k in range(5)]),
                *dead,
                *fixed,
            ],
        )
    )


def test_past_the_explained_and_the_listed_warnings_the_child_says_what_this_process_says(
    monkeypatch: pytest.MonkeyPatch, answered: list[bool]
) -> None:
    monkeypatch.setattr(check, "EXPLAINED_WARNINGS", 1)  # (the child has them as they are at the fork)
    monkeypatch.setattr(check, "LISTED_WARNINGS", 3)
    alone = analyse_model(many(), parallel=False)
    assert sum("more" in d.message for d in alone) == 2 and sum(bool(d.facts) for d in alone) == 2
    assert analyse_model(many(), parallel=True) == alone
    assert answered == [True]


def test_a_void_model_ends_its_child_before_it_explains_here(monkeypatch: pytest.MonkeyPatch) -> None:
    raw = feature("r", [feature("a", isMandatory=True, exc=["b"]), feature("b", isMandatory=True)])
    expected = analyse_model(read(raw), parallel=False)
    events: list[str] = []
    close, void = InChild.close, check._void
    monkeypatch.setattr(InChild, "close", lambda self: (events.append("child ended"), close(self))[1])
    monkeypatch.setattr(check, "_void", lambda *args: (events.append("explained here"), void(*args))[1])
    found = analyse_model(read(raw), parallel=True)
    assert found == expected and all(d.message.startswith("the model has no valid variant: ") for d in found)
    assert events[:2] == ["child ended", "explained here"]
    assert no_child_left()


def test_the_fork_holds_ctrl_c_and_sigterm_back_until_the_child_is_set_up(monkeypatch: pytest.MonkeyPatch) -> None:
    held: list[set[signal.Signals]] = []
    fork = os.fork

    def watched() -> int:
        held.append(set(signal.pthread_sigmask(signal.SIG_BLOCK, [])))
        return fork()

    monkeypatch.setattr(forked.os, "fork", watched)
    helper = InChild.start(functools.partial(check._explain_as_told, warned()))
    assert helper is not None
    helper.close()
    assert {signal.SIGINT, signal.SIGTERM} <= held[0]
    assert not {signal.SIGINT, signal.SIGTERM} & set(signal.pthread_sigmask(signal.SIG_BLOCK, []))
    assert no_child_left()


def test_a_request_larger_than_the_pipe_holds_does_not_hold_the_parent_up(monkeypatch: pytest.MonkeyPatch) -> None:
    """The child reads nothing until the parent has sent its first request (a megabyte)
    and opened a gate: a request written in the parent's own thread would wait forever."""
    gate = os.pipe()

    def waits(requests: Any) -> list[Any]:
        os.read(gate[0], 1)
        sizes = [len(pickle.load(requests)), len(pickle.load(requests))]
        return [check.warning(check.Location("m.json"), f"{sizes}", "test")]

    helper = InChild.start(waits)
    assert helper is not None
    previous = signal.signal(signal.SIGALRM, lambda *args: pytest.fail("the request held the parent up"))
    signal.alarm(60)
    try:
        helper.ask(list(range(200_000)))  # (about a megabyte pickled)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    os.write(gate[1], b"x")
    helper.ask([1, 2])
    found = helper.result()
    helper.close()
    assert isinstance(found, list) and [d.message for d in found] == ["[200000, 2]"]
    assert no_child_left()


def test_no_thread_to_send_with_leaves_the_parent_to_explain(monkeypatch: pytest.MonkeyPatch) -> None:
    expected, model = analyse_model(warned(), parallel=False), warned()

    class Refused(threading.Thread):
        def start(self) -> None:
            raise RuntimeError("can't start new thread")

    monkeypatch.setattr(forked, "threading", SimpleNamespace(Thread=Refused, active_count=threading.active_count))
    assert analyse_model(model, parallel=True) == expected
    assert no_child_left()


def test_the_model_here_has_warnings_of_both_kinds() -> None:
    rules = {d.rule for d in analyse_model(warned(), parallel=False)}
    assert rules == {"model.dead-feature", "model.impossible-binding"}


def test_the_child_s_work_gives_what_this_process_would() -> None:
    """`_explain_as_told` in this process, its requests and its answer through buffers."""
    model = warned()
    expected = analyse_model(warned(), parallel=False)
    dead = [f.index for f in model.features if f.id in {"a", "c"}]
    impossible = [(i, aspect, value) for i, aspect, value in _impossible(model)]
    requests = io.BytesIO(pickle.dumps(dead) + pickle.dumps(impossible))
    handler = signal.getsignal(signal.SIGINT)
    assert check._explain_as_told(model, requests) == expected
    assert signal.getsignal(signal.SIGINT) is handler  # (the child's own Ctrl-C handling is `forked._child`'s)


def _impossible(model: FeatureModel) -> list[Any]:
    from motivml.binding import encoding as enc
    from motivml.binding.analysis import impossible_bindings

    with enc.Encoding(model) as hard:
        alive = hard.cover([[hard.s(i)] for i in range(len(model.features))], with_config=False)
        return impossible_bindings(hard, model, alive)


@pytest.mark.parametrize("failure", ["raises", "answers nonsense", "answers a list of nonsense", "dies"])
def test_a_child_that_fails_leaves_the_parent_to_explain(monkeypatch: pytest.MonkeyPatch, failure: str) -> None:
    def fails(model: FeatureModel, requests: Any) -> Any:
        if failure == "raises":
            raise RuntimeError("no explanations today")
        if failure.startswith("answers"):
            return {"not": "a list"} if failure == "answers nonsense" else ["not", "diagnostics"]
        os._exit(3)

    expected = analyse_model(warned(), parallel=False)
    monkeypatch.setattr(check, "_explain_as_told", fails)  # (the child runs the patched one)
    assert analyse_model(warned(), parallel=True) == expected
    assert no_child_left()


def test_an_interrupted_analysis_ends_its_child(monkeypatch: pytest.MonkeyPatch) -> None:
    def interrupted(hard: Any, model: FeatureModel, on_alive: Any = None) -> Any:
        if on_alive is not None:
            on_alive([True] * len(model.features))  # (the child is at work: no dead feature to explain)
        raise KeyboardInterrupt

    monkeypatch.setattr(check, "live_features_and_impossible_bindings", interrupted)
    with pytest.raises(KeyboardInterrupt):
        analyse_model(warned(), parallel=True)
    assert no_child_left()


def test_a_fork_refused_leaves_the_analysis_in_this_process(monkeypatch: pytest.MonkeyPatch) -> None:
    def refused() -> int:
        raise OSError(11, "Resource temporarily unavailable")

    expected = analyse_model(warned(), parallel=False)
    monkeypatch.setattr(check.os, "fork", refused)
    assert analyse_model(warned(), parallel=True) == expected


def test_big_models_are_analysed_in_two_processes_and_small_ones_in_one(monkeypatch: pytest.MonkeyPatch) -> None:
    model = warned()
    assert check._parallel(model, None) is False  # 5 features
    monkeypatch.setattr(check, "PARALLEL_FROM", 5)
    assert check._parallel(model, None) is True
    assert check._parallel(model, False) is False


def test_the_explaining_child_builds_its_encoding_only_when_there_is_something_to_explain(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The explain build is the largest thing a child makes (330 MB at 100,000 features):
    none for a model with neither dead features nor impossible bindings, one for both kinds."""
    from motivml.binding import encoding as enc

    built: list[bool] = []
    original = enc.Encoding.__init__

    def counting(self: enc.Encoding, *args: Any, **kwargs: Any) -> None:
        built.append(bool(kwargs.get("explain")))
        original(self, *args, **kwargs)

    monkeypatch.setattr(enc.Encoding, "__init__", counting)
    model = warned()
    assert check._explain_as_told(model, io.BytesIO(pickle.dumps([]) + pickle.dumps([]))) == []
    assert built == []
    expected = analyse_model(model, parallel=False)
    dead = [d for d in expected if d.rule == "model.dead-feature"]
    bindings = [d for d in expected if d.rule == "model.impossible-binding"]
    assert dead and bindings
    requests: list[bytes] = []  # what analyse_model sends its child, kept here
    monkeypatch.setattr(InChild, "ask", lambda self, value: requests.append(pickle.dumps(value)))
    monkeypatch.setattr(InChild, "start", classmethod(lambda cls, job: cls.__new__(cls)))
    monkeypatch.setattr(InChild, "result", lambda self: None)
    monkeypatch.setattr(InChild, "close", lambda self: None)
    analyse_model(model, parallel=True)
    built.clear()
    found = check._explain_as_told(model, io.BytesIO(b"".join(requests)))
    assert built == [True]  # one explain build for both kinds
    assert found == expected

"""analyse_model's explanations in a child process: the same warnings as in this one,
and whatever the child does, the parent still answers and leaves no process behind."""

from __future__ import annotations

import io
import json
import os
import pickle
import signal
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


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(models(max_features=9))
def test_the_child_explains_as_this_process_does(raw: dict[str, Any]) -> None:
    model = read(raw)
    assert analyse_model(model, parallel=True) == analyse_model(read(raw), parallel=False)
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
    requests, answers = io.BytesIO(pickle.dumps(dead) + pickle.dumps(impossible)), io.BytesIO()
    handler = signal.getsignal(signal.SIGINT)
    check._explain_as_told(model, requests, answers)
    assert pickle.loads(answers.getvalue()) == expected
    assert signal.getsignal(signal.SIGINT) is handler  # (the child's own Ctrl-C handling is `_child`'s)


def _impossible(model: FeatureModel) -> list[Any]:
    from motivml.binding import encoding as enc
    from motivml.binding.analysis import impossible_bindings

    with enc.Encoding(model) as hard:
        alive = hard.cover([[hard.s(i)] for i in range(len(model.features))], with_config=False)
        return impossible_bindings(hard, model, alive)


@pytest.mark.parametrize("failure", ["raises", "answers nonsense", "dies"])
def test_a_child_that_fails_leaves_the_parent_to_explain(monkeypatch: pytest.MonkeyPatch, failure: str) -> None:
    def fails(model: FeatureModel, requests: Any, answers: Any) -> None:
        if failure == "raises":
            raise RuntimeError("no explanations today")
        if failure == "answers nonsense":
            pickle.dump({"not": "a list"}, answers)
            answers.flush()
            return
        os._exit(3)

    expected = analyse_model(warned(), parallel=False)
    monkeypatch.setattr(check, "_explain_as_told", fails)  # (the child runs the patched one)
    assert analyse_model(warned(), parallel=True) == expected
    assert no_child_left()


def test_an_interrupted_analysis_ends_its_child(monkeypatch: pytest.MonkeyPatch) -> None:
    def interrupted(*args: Any) -> Any:
        raise KeyboardInterrupt

    monkeypatch.setattr(check, "impossible_bindings", interrupted)
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


def test_the_child_process_reads_its_requests_answers_and_ends(monkeypatch: pytest.MonkeyPatch) -> None:
    """`_child` as the forked process runs it, here (its end, `os._exit`, made an exception)."""
    model = warned()
    expected = analyse_model(warned(), parallel=False)
    down, up = os.pipe(), os.pipe()
    with open(down[1], "wb") as requests:
        requests.write(pickle.dumps([f.index for f in model.features if f.id in {"a", "c"}]))
        requests.write(pickle.dumps(_impossible(model)))
    # `_child` closes the ends that are not its own: here, copies (one is closed, one is read)
    down, reader = (down[0], os.dup(down[0])), up[0]
    up = (os.dup(up[0]), up[1])

    def ends(code: int) -> None:
        raise SystemExit(code)

    monkeypatch.setattr(check.os, "_exit", ends)
    monkeypatch.setattr(check.signal, "signal", lambda *args: None)  # (this process keeps its Ctrl-C)
    with pytest.raises(SystemExit) as ended:
        check._child(model, down, up)
    assert ended.value.code == 0
    with open(reader, "rb") as answer:
        assert pickle.load(answer) == expected
    with pytest.raises(SystemExit) as failed:  # (nothing to read now: it fails, and says so)
        check._child(model, os.pipe(), os.pipe())
    assert failed.value.code == 1

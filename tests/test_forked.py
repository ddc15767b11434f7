"""process.forked (one job in a forked child) and the schema check it runs beside the
reading of a big model (schema.read_checked_then)."""

from __future__ import annotations

import ctypes
import os
import signal
from pathlib import Path
from typing import Any

import pytest
from test_check_parallel import no_child_left
from test_corpus import corpus

from motivml import process
from motivml.documents import schema
from motivml.language.reader import load_model
from motivml.process import forked
from motivml.process.forked import FAILED, InChild


def test_a_child_s_job_comes_back_as_it_returned() -> None:
    child = InChild.start(lambda requests: {"answer": [42, "x"]})
    assert child is not None
    try:
        assert child.result() == {"answer": [42, "x"]}
    finally:
        child.close()
    assert no_child_left()


@pytest.mark.parametrize("how", ["raises", "dies", "returns what cannot be pickled"])
def test_a_child_that_fails_gives_failed(how: str) -> None:
    def job(requests: Any) -> Any:
        if how == "raises":
            raise RuntimeError("not today")
        if how == "dies":
            os._exit(3)
        return lambda: None

    child = InChild.start(job)
    assert child is not None
    try:
        assert child.result() is FAILED
    finally:
        child.close()
    assert no_child_left()


def test_closing_ends_a_child_still_at_work() -> None:
    reading, writing = os.pipe()
    child = InChild.start(lambda requests: os.read(reading, 1))  # (nothing is ever written: it waits)
    assert child is not None
    child.close()
    os.close(reading)
    os.close(writing)
    assert no_child_left()


def test_a_fork_refused_gives_no_child(monkeypatch: pytest.MonkeyPatch) -> None:
    def refused() -> int:
        raise OSError(11, "Resource temporarily unavailable")

    monkeypatch.setattr(forked.os, "fork", refused)
    assert InChild.start(lambda requests: 1) is None
    assert not {signal.SIGINT, signal.SIGTERM} & set(signal.pthread_sigmask(signal.SIG_BLOCK, []))


def test_a_ctrl_c_held_back_from_the_fork_ends_the_child_it_interrupts(monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C pressed during the fork is raised when the signals are let through again:
    the child just made is ended and reaped first."""
    mask = signal.pthread_sigmask

    def interrupted(how: int, signals: Any) -> Any:
        mask(how, signals)
        if how == signal.SIG_UNBLOCK:
            raise KeyboardInterrupt

    reading, writing = os.pipe()
    monkeypatch.setattr(forked.signal, "pthread_sigmask", interrupted)
    with pytest.raises(KeyboardInterrupt):
        InChild.start(lambda requests: os.read(reading, 1))  # (it would wait for ever)
    os.close(reading)
    os.close(writing)
    assert no_child_left()


def test_no_child_is_forked_beside_another_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(forked.threading, "active_count", lambda: 1)
    assert forked.can_fork()
    monkeypatch.setattr(forked.threading, "active_count", lambda: 2)
    assert not forked.can_fork()


def test_ending_a_child_that_has_no_process_kills_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """os.kill(0, ...) or os.kill(-1, ...) would kill this process's whole group (this test
    run with it): no pid that names a group is ever signalled or waited for."""
    calls: list[tuple[str, int]] = []
    monkeypatch.setattr(os, "kill", lambda pid, sig: calls.append(("kill", pid)))
    monkeypatch.setattr(os, "waitpid", lambda pid, options: calls.append(("waitpid", pid)) or (pid, 0))
    forked.end(0)
    forked.end(-1)
    assert calls == []
    forked.end(12345)  # (the fakes above: nothing is signalled for real)
    assert calls == [("kill", 12345), ("waitpid", 12345)]


class _Libc:
    def __init__(self) -> None:
        self.calls: list[tuple[int, ...]] = []

    def prctl(self, *args: int) -> int:
        self.calls.append(args)
        return 0


def test_the_child_asks_to_die_with_its_parent_and_to_go_first_when_memory_runs_out(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    libc, score = _Libc(), tmp_path / "oom_score_adj"
    monkeypatch.setattr(ctypes, "CDLL", lambda *args, **kwargs: libc)
    monkeypatch.setattr(forked, "_OOM_SCORE", str(score))
    forked.die_with_parent(os.getppid())
    assert libc.calls == [(forked._PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)]
    assert score.read_text() == "1000"
    monkeypatch.setattr(forked, "_OOM_SCORE", str(tmp_path / "no such folder" / "oom_score_adj"))
    forked.die_with_parent(os.getppid())  # (a system without it: nothing to ask)
    with pytest.raises(SystemExit):  # (the parent ended before the request took effect: so does the child)
        forked.die_with_parent(os.getppid() + 1)


def test_the_child_s_life_ends_in_the_child_whatever_its_job_does(monkeypatch: pytest.MonkeyPatch) -> None:
    """`_child` in this process: it closes the parent's ends of the pipes and says that the
    process ends at once (nothing need be freed before the answer); the job reads its
    requests, its result goes on the pipe and the exit code is 0; or the exit code is 1 and
    nothing is sent."""
    import pickle

    def ends(code: int) -> None:
        raise SystemExit(code)

    monkeypatch.setattr(forked.os, "_exit", ends)
    monkeypatch.setattr(forked.signal, "signal", lambda *args: None)  # (this process keeps its Ctrl-C,
    monkeypatch.setattr(forked, "die_with_parent", lambda parent: None)  # its parent and its OOM score)
    monkeypatch.setattr(process, "_at_once", False)  # (given back when the test ends)
    for job, code in ((lambda asked: [pickle.load(asked), 2], 0), (lambda asked: 1 / 0, 1)):
        down, up, parents = os.pipe(), os.pipe(), os.pipe()
        with open(down[1], "wb") as requests:
            requests.write(pickle.dumps(1))
        with pytest.raises(SystemExit) as ended:
            forked._child(job, down[0], up[1], os.getppid(), parents)
        assert ended.value.code == code and process.keeping_all()
        for fd in parents:
            with pytest.raises(OSError):
                os.fstat(fd)
        with open(up[0], "rb") as answer:
            data = answer.read()
        assert (pickle.loads(data) if code == 0 else data) == ([1, 2] if code == 0 else b"")


def test_a_big_model_is_read_as_a_small_one_is_whatever_is_wrong_with_it(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Each mutated model of the robustness corpus, read with its schema checked in a child
    beside the reading, gives the model and the diagnostics of the reading in one process."""
    path = tmp_path / "model.json"
    forks = 0
    start = InChild.start

    def counted(job: Any) -> Any:
        nonlocal forks
        forks += 1
        return start(job)

    monkeypatch.setattr(schema.InChild, "start", counted)
    for number, data in corpus("model"):
        path.write_bytes(data)
        alone = _read(path)
        with monkeypatch.context() as big:
            big.setattr(schema, "BESIDE_FROM", 0)
            assert _read(path) == alone, number
    assert forks > 100 and no_child_left()  # (those the loader refuses fork nothing)


def _read(path: Path) -> tuple[Any, ...]:
    model, diagnostics = load_model(path)
    ids = [f.id for f in model.features] if model is not None else None
    return ids, [(str(d.location), d.message, d.rule) for d in diagnostics]


def test_a_child_that_fails_leaves_the_check_to_this_process(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    class Broken:
        def result(self) -> Any:
            return FAILED

        def close(self) -> None:
            pass

    path = tmp_path / "model.json"
    path.write_text('{"id": "r", "name": "R", "sub": [{"id": "a", "name": "A", "isMandatory": 3}]}')
    expected = _read(path)
    assert expected[0] is None and expected[1]  # (a schema error)
    monkeypatch.setattr(schema, "BESIDE_FROM", 0)
    monkeypatch.setattr(schema.InChild, "start", lambda job: Broken())
    assert _read(path) == expected


def test_what_the_reading_raises_counts_only_for_a_sound_document(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    def fails(doc: Any) -> Any:
        raise RuntimeError("a reader's bug")

    forks: list[Any] = []
    start = InChild.start

    def counted(job: Any) -> Any:
        forks.append(job)
        return start(job)

    monkeypatch.setattr(schema.InChild, "start", counted)
    monkeypatch.setattr(schema, "BESIDE_FROM", 0)
    unsound, sound = tmp_path / "unsound.json", tmp_path / "sound.json"
    unsound.write_text('{"id": "r", "name": "R", "sub": 3}')
    sound.write_text('{"id": "r", "name": "R"}')
    doc, problems, outcome = schema.read_checked_then(unsound, schema.check_feature_model, fails)
    assert doc is None and problems and outcome is None
    with pytest.raises(RuntimeError, match="a reader's bug"):
        schema.read_checked_then(sound, schema.check_feature_model, fails)
    assert len(forks) == 2 and no_child_left()


def test_a_string_or_an_object_where_a_list_belongs_is_read_as_no_members(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Read beside the schema check, before it has refused such a model: a string of
    formulas or of included ids is not read character by character."""
    from motivml.language import reader

    parsed: list[str] = []
    parse = reader.parse
    monkeypatch.setattr(reader, "parse", lambda text, position: parsed.append(text) or parse(text, position))
    doc = '{"id": "r", "name": "R", "formulas": "' + "a" * 50 + '", "sub": [{"id": "a", "name": "A", '
    doc += '"constraints": {"featuresIncluded": "' + "b" * 50 + '", "featuresExcluded": {"c": 1}}}]}'
    path = tmp_path / "model.json"
    path.write_text(doc)
    model, problems = reader.read_model(schema.load_file(path))
    assert parsed == [] and model.features[1].includes == () and model.features[1].excludes == ()
    assert not [d for d in problems if d.rule in ("model.unknown-id", "2.4")]
    assert load_model(path)[0] is None  # (the schema refuses it)


def test_no_pipe_gives_no_child(monkeypatch: pytest.MonkeyPatch) -> None:
    def refused() -> tuple[int, int]:
        raise OSError(24, "Too many open files")

    monkeypatch.setattr(forked.os, "pipe", refused)
    assert InChild.start(lambda requests: 1) is None


def test_a_child_that_cannot_be_set_up_after_the_fork_is_ended(monkeypatch: pytest.MonkeyPatch) -> None:
    def refused(*args: Any, **kwargs: Any) -> Any:
        raise OSError(24, "Too many open files")

    monkeypatch.setattr(forked, "open", refused, raising=False)  # (the child cannot open its pipe either)
    assert InChild.start(lambda requests: 1) is None  # (as a fork refused: the caller does the job)
    assert no_child_left()
    assert not {signal.SIGINT, signal.SIGTERM} & set(signal.pthread_sigmask(signal.SIG_BLOCK, []))


def test_closing_a_stream_that_fails_or_a_process_that_is_gone_raises_nothing(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    class Failing:
        def close(self) -> None:
            raise OSError(5, "Input/output error")

    InChild(0, Failing(), Failing()).close()  # type: ignore[arg-type]
    forked.end(2**22 + 1)  # (above any pid Linux gives: no such process to kill or reap)


def test_a_system_without_prctl_still_sets_the_oom_score(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    def missing(*args: Any, **kwargs: Any) -> Any:
        raise OSError("no C library here")

    score = tmp_path / "oom_score_adj"
    monkeypatch.setattr(ctypes, "CDLL", missing)
    monkeypatch.setattr(forked, "_OOM_SCORE", str(score))
    forked.die_with_parent(os.getppid())
    assert score.read_text() == "1000"

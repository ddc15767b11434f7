"""The run's typed vocabulary (runtime/events.py): every event reads back from what a record
writes of it, and gives the label a picture shows."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from motivml.runtime.events import (
    Answered,
    Changed,
    Ended,
    Faulted,
    Listeners,
    Logged,
    Missed,
    Note,
    Refused,
    RunEvent,
    Started,
    StateChanged,
    StatusChanged,
    Written,
    kind_of,
    parse,
)

WORDS = st.text(st.characters(blacklist_categories=("Cs", "Cc")), min_size=1, max_size=30)
NAME = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,12}", fullmatch=True)  # feature, component, state ids
REQUEST = st.builds(lambda verb, names: f"{verb} {' '.join(names)}", st.sampled_from(["load", "unload", "swap"]), st.lists(NAME, min_size=1, max_size=3))
TICK = st.integers(0, 10**9)

EVENTS = st.one_of(
    st.builds(Started, TICK, WORDS),
    st.builds(Changed, TICK, REQUEST),
    st.builds(Refused, TICK, REQUEST, WORDS),
    st.builds(Faulted, TICK, NAME, st.one_of(st.none(), WORDS)),
    st.builds(StatusChanged, TICK, NAME, st.sampled_from(["ongoing", "converged", "tracking", "running", "learning", "stopped"])),
    st.builds(StateChanged, TICK, st.booleans(), NAME),
    st.builds(Missed, TICK, st.integers(0, 10**6)),
    st.builds(Ended, TICK, WORDS),
)


@given(EVENTS)
def test_every_event_reads_back_from_its_kind_and_text(event: RunEvent) -> None:
    assert parse(event.tick, kind_of(event), event.text) == event


@pytest.mark.parametrize(
    ("event", "text", "label"),
    [
        (Changed(3, "swap hectorslam kartoslam"), "swap hectorslam kartoslam", "swap hectorslam kartoslam"),
        (Refused(4, "load x", "x is Static: no unload or load at run time"), "load x: x is Static: no unload or load at run time", "refused load x"),
        (Faulted(5, "grip", "ValueError: bad (at grip.py:7)"), "grip raised in its step: ValueError: bad (at grip.py:7)", "fault: grip"),
        (Faulted(6, "grip", None), "stop() of plugin grip raised", "fault: stop() of plugin grip"),
        (StatusChanged(7, "reach", "converged"), "reach converged", "reach converged"),
        (StateChanged(8, True, "Gripping"), "entered Gripping", "Gripping"),
        (StateChanged(9, False, "Gripping"), "exited Gripping", None),
        (Missed(10, 1), "1 deadline", None),
        (Missed(10, 4), "4 deadlines", None),
    ],
)
def test_each_event_says_what_the_record_and_the_picture_show(event: RunEvent, text: str, label: str | None) -> None:
    assert (event.text, event.label) == (text, label)


def test_a_text_this_version_does_not_write_is_kept_as_written() -> None:
    """A record edited by hand (or written by another version): the event stays, unlabelled."""
    odd = [("refused", "no colon here"), ("fault", "grip fell over"), ("missed", "many"), ("state", "left X")]
    odd += [("missed", "\u00b2 deadlines"), ("missed", "9" * 5000 + " deadlines")]  # (isdigit, yet no int for int())
    for kind, text in odd:
        event = parse(2, kind, text)
        assert event == Written(2, kind, text) and (kind_of(event), event.text, event.label) == (kind, text, None)


def test_every_listener_is_told_and_a_listeners_bug_is_said_not_raised() -> None:
    said: list[str] = []
    heard: list[RunEvent] = []
    listeners = Listeners(said.append)

    def broken(event: RunEvent) -> None:
        raise KeyError("no such thing")

    listeners.listen(broken)
    listeners.listen(heard.append)
    listeners.publish(Changed(1, "load a"))
    assert heard == [Changed(1, "load a")] and len(said) == 1
    assert said[0].startswith("a listener of the run raised KeyError: 'no such thing' (at ")  # (where, as for a plugin)


def test_a_listener_that_fails_on_the_words_of_its_own_failure_is_said_once() -> None:
    """The runtime's `said` is its log, and its log is told to the listeners: a listener that
    raises on everything is said once per event, not again on the line that says it."""
    said: list[str] = []
    listeners = Listeners(lambda text: (said.append(text), listeners.publish(Started(0, text))))

    def broken(event: RunEvent) -> None:
        raise RuntimeError("always")

    listeners.listen(broken)
    listeners.publish(Changed(1, "load a"))
    listeners.publish(Changed(2, "load b"))
    assert len(said) == 2 and all("RuntimeError: always" in text for text in said)


def test_a_forgotten_listener_hears_nothing_more() -> None:
    heard: list[RunEvent] = []
    listeners = Listeners(lambda text: None)
    listeners.listen(heard.append)
    listeners.publish(Changed(1, "load a"))
    listeners.forget(heard.append)
    listeners.forget(heard.append)  # (twice: nothing happens)
    listeners.publish(Changed(2, "load b"))
    assert heard == [Changed(1, "load a")]


def test_the_log_and_the_binders_answers_are_told_but_not_recorded() -> None:
    note = Note(0.5, 500, "hello")
    answer = Answered(3, "load a", True, "", ("a",), (), frozenset({"a"}), (3, "load a"))
    assert (Logged(500, note).text, Logged(500, note).recorded) == ("hello", False)
    assert (answer.text, answer.recorded, Changed(3, "load a").recorded) == ("load a", False, True)
    refused = Answered(3, "load b", False, "b is Static", (), (), frozenset(), None)
    assert refused.text == "load b: b is Static"


def test_the_log_tells_its_lines_in_its_own_order_and_a_late_listener_hears_each_once() -> None:
    import threading

    from motivml.runtime.events import Log

    log = Log(Listeners(lambda text: None))
    log.write(Note(0.0, 0, "launched"))
    heard: list[str] = []
    late: list[str] = []

    def writer(name: str) -> None:
        for k in range(2000):
            log.write(Note(0.0, k, f"{name} {k}"))
            if name == "a" and k == 1000:
                log.listen_from_the_first_line(lambda e: late.append(e.text) if isinstance(e, Logged) else None)

    log.listen_from_the_first_line(lambda e: heard.append(e.text) if isinstance(e, Logged) else None)
    threads = [threading.Thread(target=writer, args=(name,)) for name in "ab"]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert heard == [note.text for note in log.lines] == late  # (each once, in the log's order)

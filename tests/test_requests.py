"""runtime.requests: the one parser of requests, shared by run --at, ctl, the control socket
and the statechart's actions; what each request names and how it is said."""

from __future__ import annotations

import pytest

from motivml.runtime import requests
from motivml.runtime.requests import (
    Event,
    Load,
    Reload,
    RequestError,
    Set,
    Swap,
    Unload,
    change,
    named,
    parse,
)


@pytest.mark.parametrize(
    ("verb", "words", "expected"),
    [
        ("load", ["a", "b"], Load(("a", "b"))),
        ("unload", ["a"], Unload(("a",))),
        ("reload", ["a"], Reload(("a",))),
        ("swap", ["a", "b"], Swap("a", "b")),
        ("event", ["stop"], Event("stop")),
    ],
)
def test_each_verb_parses_to_its_own_value(verb: str, words: list[str], expected: object) -> None:
    assert parse(verb, words) == expected
    assert str(expected) == " ".join([verb, *words])


@pytest.mark.parametrize(
    ("verb", "words", "message"),
    [
        ("load", [], "load needs at least one feature"),
        ("reload", [], "reload needs at least one feature"),
        ("swap", ["a"], "swap needs two features: the one to unload, then the one to load"),
        ("swap", ["a", "b", "c"], "swap needs two features"),
        ("event", [], "event needs one name"),
        ("event", ["a", "b"], "event needs one name"),
        ("explode", ["a"], "unknown request 'explode' (requests: load, unload, reload, swap, event)"),
    ],
)
def test_what_is_not_a_request_is_said_once_for_every_door(verb: str, words: list[str], message: str) -> None:
    with pytest.raises(RequestError, match=message.replace("(", r"\(").replace(")", r"\)")):
        parse(verb, words)


def test_a_change_is_a_request_that_moves_features() -> None:
    assert change("swap", ["a", "b"]) == Swap("a", "b")
    with pytest.raises(RequestError, match="unknown request 'event'"):
        change("event", ["stop"])


def test_what_a_request_names_and_says() -> None:
    assert named(Swap("out", "in")) == ("out", "in")
    assert named(Set(("a", "b"), ("c",))) == ("a", "b", "c")
    assert named(Load(("a",))) == ("a",)
    assert str(Set(("a",), ("b",))) == "set +a -b"
    assert str(Unload(("x",), cause="after the fault of y")) == "unload x (after the fault of y)"
    assert requests.VERBS == ("load", "unload", "reload", "swap")

"""What every test module shares: the repository's paths (`paths.py`, importable as a
module from every test: `from paths import ROOT, SIMPLEBOT`), and the `slow` marker.

Paths live in a module of their own rather than here because pytest imports conftest.py
itself: a test importing `conftest` would get a second copy of it.

Tests marked `slow` (property tests against brute force, the robustness corpus, builds of
packages and C++) run only with `--slow`: `pytest` alone is the quick suite a change is
tried with, `make test` (and CI) runs every test."""

from __future__ import annotations

import pytest


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--slow", action="store_true", help="also run the tests marked slow (make test does)")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.getoption("--slow") or config.getoption("-m"):  # (-m says itself what runs)
        return
    quick = [item for item in items if item.get_closest_marker("slow") is None]
    if len(quick) < len(items):
        config.hook.pytest_deselected(items=[item for item in items if item.get_closest_marker("slow")])
        items[:] = quick

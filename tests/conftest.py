"""What every test module shares: the repository's paths (`paths.py`, importable as a
module from every test: `from paths import ROOT, SIMPLEBOT`), and the `slow` marker.

Paths live in a module of their own rather than here because pytest imports conftest.py
itself: a test importing `conftest` would get a second copy of it.

Tests marked `slow` (property tests against brute force, the robustness corpus, builds of
packages and C++) run only with `--slow`: `pytest` alone is the quick suite a change is
tried with, `make test` (and CI) runs every test."""

from __future__ import annotations

import os
import shutil
import tempfile

import pytest

_COMPILED = "MOTIVML_COMPILED_DIR"


def pytest_configure(config: pytest.Config) -> None:
    """Compiled forms (`motivml compile`, and analyse, sample and menuconfig on first use)
    are kept in a scratch folder of this process, not beside the repository's models; the
    tests of where they are kept beside a model unset it."""
    if _COMPILED not in os.environ:
        os.environ[_COMPILED] = tempfile.mkdtemp(prefix="motivml-tests-compiled-")
        config.stash[_STASHED] = os.environ[_COMPILED]


def pytest_unconfigure(config: pytest.Config) -> None:
    folder = config.stash.get(_STASHED, None)
    if folder is not None:
        shutil.rmtree(folder, ignore_errors=True)
        os.environ.pop(_COMPILED, None)


_STASHED = pytest.StashKey[str]()


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--slow", action="store_true", help="also run the tests marked slow (make test does)")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.getoption("--slow") or config.getoption("-m"):  # (-m says itself what runs)
        return
    quick = [item for item in items if item.get_closest_marker("slow") is None]
    if len(quick) < len(items):
        config.hook.pytest_deselected(items=[item for item in items if item.get_closest_marker("slow")])
        items[:] = quick

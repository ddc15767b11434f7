"""What every test module shares: the repository's paths (`paths.py`, importable as a
module from every test: `from paths import ROOT, SIMPLEBOT`), and the markers.

Paths live in a module of their own rather than here because pytest imports conftest.py
itself: a test importing `conftest` would get a second copy of it."""

from __future__ import annotations

"""The repository's paths the tests read (29 test modules defined ROOT each)."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FEATURE_MODELS = ROOT / "feature_models"
SIMPLEBOT = FEATURE_MODELS / "simplebot"
PLUGINS = ROOT / "plugins"

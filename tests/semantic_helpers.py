"""Run the product's semantic check on in-memory documents."""

from __future__ import annotations

import json
from typing import Any

from motivml.binding.check import check_variant
from motivml.documents.loader import parse
from motivml.errors import Diagnostic
from motivml.language.reader import read_configuration, read_model


def variant_errors(model: dict[str, Any], config: dict[str, Any]) -> list[Diagnostic]:
    """Errors of a configuration (partial allowed), via loader, reader and SAT."""
    doc = parse(json.dumps(model, indent=1), "model.json")
    feature_model, diagnostics = read_model(doc)
    assert not [d for d in diagnostics if d.severity.value == "error"], diagnostics
    config_doc = parse(json.dumps(config, indent=1), "variant.json")
    configuration, diagnostics = read_configuration(config_doc, feature_model, partial=True)
    assert not [d for d in diagnostics if d.severity.value == "error"], diagnostics
    return check_variant(feature_model, configuration)

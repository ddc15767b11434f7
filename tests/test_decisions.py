"""Decisions files (reference.md section 1): `configure --save-decisions` writes entries from
which `configure` derives the same variant, and `"partial": true` files validate as partial."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from click.testing import CliRunner
from helpers import model_of
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from paths import ROOT
from test_property_sat import configurations, models

from motivml.binding.resolve import NoVariant, decisions, resolve
from motivml.cli import main
from motivml.documents.loader import parse
from motivml.language.model import Configuration
from motivml.language.reader import read_configuration


def outcome(variant: Any) -> list[tuple[str, bool, str | None]]:
    return [(d.feature.id, d.selected, d.binding.value if d.selected else None) for d in variant.decisions]


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_the_decisions_derive_the_same_variant(data: st.DataObject) -> None:
    raw = data.draw(models(max_features=8))
    model = model_of(raw)
    prefer = data.draw(st.sampled_from([(), ("late",), ("dynamic",), ("late", "dynamic")]))
    document = data.draw(configurations(raw))
    config, problems = read_configuration(parse(json.dumps(document), "v.json"), model, partial=True)
    if config is None or problems:
        return
    try:
        variant = resolve(model, config, prefer)
    except NoVariant:
        return
    saved = decisions(variant, prefer)
    assert outcome(resolve(model, saved, prefer)) == outcome(variant)
    assert len(saved.entries) <= len(model.features) - 1
    for fid in saved.entries:  # each entry left matters: without it, the variant changes
        rest = {k: v for k, v in saved.entries.items() if k != fid}
        try:
            changed = outcome(resolve(model, Configuration(rest), prefer)) != outcome(variant)
        except NoVariant:
            changed = True
        assert changed, fid


def test_configure_save_decisions(tmp_path: Path) -> None:
    runner = CliRunner()
    robot = ROOT / "feature_models" / "simplebot"
    saved = tmp_path / "field.json"
    first = runner.invoke(
        main,
        [
            "configure",
            str(robot),
            "--variant",
            "field",
            "-o",
            str(tmp_path / "a"),
            "--save-decisions",
            str(saved),
        ],
    )
    assert first.exit_code == 0, first.output
    assert first.output.splitlines()[-1] == f"  wrote {saved} (the decisions it derives from)"
    document = json.loads(saved.read_text())
    assert document["partial"] is True and len(document["properties"]) < 18
    # the decisions file validates (as partial, by its own say) and configures to the same lock
    assert runner.invoke(main, ["validate", str(robot / "model.json"), "--config", str(saved)]).exit_code == 0
    folder = tmp_path / "robot"
    (folder / "variants").mkdir(parents=True)
    (folder / "model.json").write_text((robot / "model.json").read_text())
    (folder / "variants" / "field.json").write_text(saved.read_text())
    second = runner.invoke(main, ["configure", str(folder), "--variant", "field", "-o", str(tmp_path / "b")])
    assert second.exit_code == 0, second.output
    lock = [json.loads((tmp_path / side / "variant.lock.json").read_text())["properties"] for side in "ab"]
    assert [(p["id"], p["selected"], p.get("props")) for p in lock[0]] == [
        (p["id"], p["selected"], p.get("props")) for p in lock[1]
    ]


def test_a_decisions_file_validates_as_partial_wherever_it_is(tmp_path: Path) -> None:
    robot = tmp_path / "robot"
    (robot / "variants").mkdir(parents=True)
    (robot / "model.json").write_text(
        (ROOT / "guidelines" / "examples" / "minibot" / "model.json").read_text()
    )
    (robot / "variants" / "decided.json").write_text(
        json.dumps({"partial": True, "properties": [{"id": "karto"}]})
    )
    (robot / "variants" / "plain.json").write_text(json.dumps({"properties": [{"id": "karto"}]}))
    result = CliRunner().invoke(main, ["validate", str(robot)])
    assert result.exit_code == 1  # plain.json is incomplete; decided.json is not
    lines = result.output.splitlines()
    assert [line for line in lines if "decided.json" in line] == [
        f"valid: {robot / 'variants' / 'decided.json'} (4 features and 1 binding left to the configurator), 0 errors, 0 warnings"
    ]
    assert "plain.json" in result.output and "the configuration is incomplete" in result.output

"""`motivml configure`: resolution (checked against brute force), generated files, writing."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest
import reference_semantics as ref
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_property_sat import configurations, models

from motivml.binding.codegen import outputs
from motivml.binding.resolve import NoVariant, resolve
from motivml.cli import main
from motivml.documents.loader import parse
from motivml.language.reader import load_configuration, load_model, read_configuration, read_model
from motivml.validate import validate

ROOT = Path(__file__).resolve().parent.parent
SIMPLEBOT = ROOT / "feature_models" / "simplebot"
GOLDEN = Path(__file__).resolve().parent / "golden"


def configure(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, ["configure", *args])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


@pytest.mark.parametrize("variant", ["lab", "field"])
@pytest.mark.parametrize(
    "name", ["variant.lock.json", "features.h", "bindings.yaml", "static_loader.hpp", "plugins.json"]
)
def test_golden_files(tmp_path: Path, variant: str, name: str) -> None:
    code, output = configure(str(SIMPLEBOT), "--variant", variant, "-o", str(tmp_path))
    assert code == 0, output
    golden = GOLDEN / "simplebot" / variant / name
    if os.environ.get("MOTIVML_UPDATE_GOLDEN"):
        golden.parent.mkdir(parents=True, exist_ok=True)
        golden.write_bytes((tmp_path / name).read_bytes())
    assert (tmp_path / name).read_text() == golden.read_text()


def test_lock_validates_back(tmp_path: Path) -> None:
    configure(str(SIMPLEBOT), "--variant", "field", "-o", str(tmp_path))
    _, report = validate(SIMPLEBOT / "model.json", [tmp_path / "variant.lock.json"])
    assert report.valid and report.diagnostics == [] and report.open_bindings == 0


def test_unchanged_files_are_not_rewritten(tmp_path: Path) -> None:
    configure(str(SIMPLEBOT), "--variant", "lab", "-o", str(tmp_path))
    stamps = {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()}
    code, output = configure(str(SIMPLEBOT), "--variant", "lab", "-o", str(tmp_path))
    assert code == 0 and output.count("unchanged ") == 5
    assert {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()} == stamps


def test_a_failing_configure_leaves_earlier_output_untouched(tmp_path: Path) -> None:
    configure(str(SIMPLEBOT), "--variant", "lab", "-o", str(tmp_path))
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    code, output = configure(str(SIMPLEBOT), "--variant", "broken_gridmap_dynamic", "-o", str(tmp_path))
    assert code == 1 and "nothing written" in output and "binding rule 3.1" in output
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_default_output_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    code, output = configure(str(SIMPLEBOT), "--variant", "lab")
    assert code == 0, output
    assert (tmp_path / "build" / "simplebot" / "lab" / "features.h").is_file()


def test_same_input_same_bytes() -> None:
    model, _ = load_model(SIMPLEBOT / "model.json")
    assert model is not None
    config, _ = load_configuration(SIMPLEBOT / "variants" / "warehouse.json", model)
    assert config is not None
    assert outputs(resolve(model, config)) == outputs(resolve(model, config))


def test_no_variant_raises_with_the_validate_explanation() -> None:
    model, _ = load_model(SIMPLEBOT / "model.json")
    assert model is not None
    config, _ = load_configuration(SIMPLEBOT / "variants" / "broken_gridmap_dynamic.json", model)
    assert config is not None
    with pytest.raises(NoVariant) as info:
        resolve(model, config)
    assert info.value.diagnostics[0].rule == "3.1"


def cost(
    model: dict[str, Any], config: dict[str, Any], variant: dict[str, tuple[bool, bool]], prefer: set[str]
) -> tuple[int, int, int]:
    """The lexicographic cost configure minimises, computed on a brute-force variant."""
    entries = {e["id"]: e for e in config["properties"]}
    root = model["id"]
    undecided = times = modes = 0
    for fid, (early, static) in variant.items():
        if fid == root:
            continue
        entry = entries.get(fid)
        props = entry.get("props", {}) if entry else {}
        if entry is None:
            undecided += 1
        if props.get("time", "Any") == "Any" and early == ("late" in prefer):
            times += 1
        if props.get("mode", "Any") == "Any" and static == ("dynamic" in prefer):
            modes += 1
    return undecided, times, modes


@settings(max_examples=120, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data(), prefer=st.sets(st.sampled_from(["late", "dynamic"])))
def test_resolution_is_valid_and_optimal(data: st.DataObject, prefer: set[str]) -> None:
    model = data.draw(models(max_features=8))
    config = data.draw(configurations(model))
    feature_model, _ = read_model(parse(json.dumps(model), "model.json"))
    configuration, _ = read_configuration(parse(json.dumps(config), "c.json"), feature_model, partial=True)
    variants = list(ref.valid_variants(model, config))
    if not variants:
        with pytest.raises(NoVariant):
            resolve(feature_model, configuration, prefer)
        return
    resolved = resolve(feature_model, configuration, prefer)
    chosen = {d.feature.id: (d.binding.early, d.binding.static) for d in resolved.decisions if d.selected}
    lock = json.loads(outputs(resolved)["variant.lock.json"])
    assert ref.is_valid(model, lock)
    assert cost(model, config, chosen, prefer) == min(cost(model, config, v, prefer) for v in variants)


def test_ids_differing_only_in_case_are_refused(tmp_path: Path) -> None:
    (tmp_path / "variants").mkdir()
    (tmp_path / "model.json").write_text(
        '{"id": "r", "name": "R", "sub": [{"id": "slam", "name": "a"}, {"id": "SLAM", "name": "b"}]}'
    )
    (tmp_path / "variants" / "v.json").write_text('{"properties": []}')
    code, output = configure(str(tmp_path), "--variant", "v", "-o", str(tmp_path / "out"))
    assert code == 1
    assert (
        "model.json:1:70: SLAM and slam differ only in case, so their C++ macros would be the same name"
        in output
    )
    assert not (tmp_path / "out").exists()


def test_a_prefix_that_cannot_start_a_macro_is_a_usage_error(tmp_path: Path) -> None:
    code, output = configure(str(SIMPLEBOT), "--variant", "lab", "--prefix", "1X", "-o", str(tmp_path))
    assert code == 2 and "cannot start a C++ macro name" in output
    assert not any(tmp_path.iterdir())


def test_files_get_the_usual_permissions_and_a_failed_write_changes_nothing(tmp_path: Path) -> None:
    configure(str(SIMPLEBOT), "--variant", "lab", "-o", str(tmp_path))
    umask = os.umask(0)
    os.umask(umask)
    assert {p.stat().st_mode & 0o777 for p in tmp_path.iterdir()} == {0o666 & ~umask}
    (tmp_path / "static_loader.hpp").unlink()
    (tmp_path / "static_loader.hpp").mkdir()  # in the way of the last file
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    code, output = configure(str(SIMPLEBOT), "--variant", "field", "-o", str(tmp_path))
    assert code == 3 and "static_loader.hpp: cannot write" in output
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()} == before
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_yaml_ids_are_quoted(tmp_path: Path) -> None:
    configure(str(SIMPLEBOT), "--variant", "lab", "-o", str(tmp_path))
    assert '  dynamic_late: ["gesture_recognition", "hands"]' in (tmp_path / "bindings.yaml").read_text()

"""`motivml configure`: resolution (checked against brute force), generated files, writing."""

from __future__ import annotations

import itertools
import json
import os
from pathlib import Path
from typing import Any

import pytest
import reference_semantics as ref
from click.testing import CliRunner
from helpers import UPDATE_GOLDEN, assert_matches_golden, feature
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from paths import ROOT, SIMPLEBOT
from test_property_sat import configurations, models

from motivml.binding.codegen import BANNER, _printable, lock_json, outputs
from motivml.binding.resolve import Decision, NoVariant, Variant, resolve
from motivml.cli import main
from motivml.documents.loader import parse
from motivml.language.model import Binding, Feature, FeatureModel
from motivml.language.reader import load_configuration, load_model, read_configuration, read_model
from motivml.validate import validate

GOLDEN = Path(__file__).resolve().parent / "golden"


def configure(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, ["configure", *args])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


@pytest.mark.parametrize("variant", ["lab", "field"])
@pytest.mark.parametrize(
    "name",
    [
        "variant.lock.json",
        "features.h",
        "bindings.yaml",
        "static_loader.hpp",
        "plugins.json",
        "ros2_params.yaml",
    ],
)
def test_golden_files(tmp_path: Path, variant: str, name: str) -> None:
    code, output = configure(str(SIMPLEBOT), "--variant", variant, "-o", str(tmp_path))
    assert code == 0, output
    assert_matches_golden((tmp_path / name).read_bytes(), GOLDEN / "simplebot" / variant / name)


def test_golden_check_fails_in_update_mode_until_nothing_changes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    golden = tmp_path / "out" / "features.h"
    monkeypatch.delenv(UPDATE_GOLDEN, raising=False)
    with pytest.raises(pytest.fail.Exception, match="no golden file"):
        assert_matches_golden(b"new\n", golden)
    assert not golden.exists()
    monkeypatch.setenv(UPDATE_GOLDEN, "1")
    with pytest.raises(pytest.fail.Exception, match="updated"):
        assert_matches_golden(b"new\n", golden)
    assert golden.read_bytes() == b"new\n"
    stamp = golden.stat().st_mtime_ns
    assert_matches_golden(b"new\n", golden)  # nothing changed: passes, nothing written
    assert golden.stat().st_mtime_ns == stamp
    with pytest.raises(pytest.fail.Exception, match=r"(?s)updated.*-new\n\+newer"):
        assert_matches_golden(b"newer\n", golden)
    assert golden.read_bytes() == b"newer\n"
    monkeypatch.delenv(UPDATE_GOLDEN)
    with pytest.raises(AssertionError, match=r"(?s)differs.*-newer\r?\n\+newer\r\n"):
        assert_matches_golden(b"newer\r\n", golden)  # bytes, not text: line ends count
    assert golden.read_bytes() == b"newer\n"


def test_lock_validates_back(tmp_path: Path) -> None:
    configure(str(SIMPLEBOT), "--variant", "field", "-o", str(tmp_path))
    (report,) = validate(SIMPLEBOT / "model.json", [tmp_path / "variant.lock.json"]).configurations
    assert report.valid and report.diagnostics == [] and report.open_bindings == 0


def test_unchanged_files_are_not_rewritten(tmp_path: Path) -> None:
    configure(str(SIMPLEBOT), "--variant", "lab", "-o", str(tmp_path))
    stamps = {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()}
    code, output = configure(str(SIMPLEBOT), "--variant", "lab", "-o", str(tmp_path))
    assert code == 0 and output.count("unchanged ") == 6
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


@st.composite
def completable_configurations(draw: st.DrawFn, model: dict[str, Any]) -> dict[str, Any]:
    """Part of a valid variant the reference finds, so that a completion exists and has
    choices left: each feature's entry is left out, or says its selection, and its time and
    mode each either as in the variant or Any."""
    variants = list(itertools.islice(ref.valid_variants(model, None), 5000))
    if not variants:
        return draw(configurations(model))
    variant = variants[draw(st.integers(0, len(variants) - 1))]
    properties: list[dict[str, Any]] = []
    stack = list(model.get("sub", []))
    while stack:
        node = stack.pop()
        stack.extend(node.get("sub", []))
        if draw(st.booleans()):
            continue  # undecided
        binding = variant.get(node["id"])
        if binding is None:
            properties.append({"id": node["id"], "selected": False})
            continue
        early, static = binding
        time = draw(st.sampled_from(["Early" if early else "Late", "Any"]))
        mode = draw(st.sampled_from(["Static" if static else "Dynamic", "Any"]))
        properties.append({"id": node["id"], "props": {"time": time, "mode": mode}})
    return {"properties": properties}


@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data(), prefer=st.sets(st.sampled_from(["late", "dynamic"])))
def test_resolution_is_valid_and_optimal(data: st.DataObject, prefer: set[str]) -> None:
    """resolve's variant is one of the completions the reference enumerates, and none of
    them meets configure's wishes better (reference_semantics.completion_cost).  Ties are
    not broken by the spec, so only the cost is compared, not the variant."""
    model = data.draw(models(max_features=7))
    config = data.draw(st.one_of(completable_configurations(model), configurations(model)))
    feature_model, _ = read_model(parse(json.dumps(model), "model.json"))
    configuration, _ = read_configuration(parse(json.dumps(config), "c.json"), feature_model, partial=True)
    variants = list(ref.valid_variants(model, config))
    wishes = tuple(sorted(prefer))
    if not variants:
        with pytest.raises(NoVariant):
            resolve(feature_model, configuration, prefer)
        return
    resolved = resolve(feature_model, configuration, prefer)
    chosen = {d.feature.id: (d.binding.early, d.binding.static) for d in resolved.decisions if d.selected}
    assert chosen in variants
    lock = json.loads(outputs(resolved)["variant.lock.json"])
    assert list(ref.valid_variants(model, lock)) == [chosen]
    best = min(ref.completion_cost(model, config, v, wishes) for v in variants)
    assert ref.completion_cost(model, config, chosen, wishes) == best


@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data(), prefer=st.sets(st.sampled_from(["late", "dynamic"])))
def test_optimise_gives_the_variant_rc2_gives_for_the_formula_built_clause_by_clause(
    data: st.DataObject, prefer: set[str]
) -> None:
    """Encoding.optimise runs RC2 on the encoding's own solver; the variant (not only its
    cost: the lock files must not change) is the one RC2 finds for the same formula built
    as a WCNF clause by clause, as optimise once did."""
    from pysat.examples.rc2 import RC2
    from pysat.formula import WCNF

    from motivml.binding import encoding as enc
    from motivml.binding.resolve import _preferences

    model = data.draw(models(max_features=9))
    config = data.draw(st.one_of(completable_configurations(model), configurations(model)))
    feature_model, _ = read_model(parse(json.dumps(model), "model.json"))
    configuration, _ = read_configuration(parse(json.dumps(config), "c.json"), feature_model, partial=True)
    with enc.Encoding(feature_model, record=True) as encoding:
        encoding.set_configuration(configuration)
        soft = _preferences(encoding, feature_model, configuration, prefer)
        found = encoding.optimise(soft)
        assert encoding.recorded is not None
        formula = WCNF()
        for clause in encoding.recorded:
            formula.append(clause)
        for literal in encoding.assumptions():
            formula.append([literal])
        for literal, weight in soft:
            formula.append([literal], weight=weight)
        with RC2(formula, solver="g4") as maxsat:
            expected = maxsat.compute()
    assert found == (list(expected) if expected is not None else None)


def test_optimise_gives_rc2s_variant_where_rc2_builds_totalizers() -> None:
    """Undecided members of the root's OR groups: each core holds several of them, so RC2
    relaxes it with a totalizer numbered after the formula's highest variable. The
    variant is the one RC2 finds for the formula built clause by clause."""
    from pysat.examples.rc2 import RC2
    from pysat.formula import WCNF

    from motivml.binding import encoding as enc
    from motivml.binding.resolve import _preferences

    raw = feature(
        "r",
        [
            feature("g", [feature(f"x{k}", group="OR", time="Any", mode="Any") for k in range(4)]),
            feature("h", [feature(f"y{k}", group="OR", time="Any", mode="Any") for k in range(3)]),
        ],
    )
    feature_model, _ = read_model(parse(json.dumps(raw), "model.json"))
    configuration, _ = read_configuration(parse('{"properties": []}', "c.json"), feature_model, partial=True)
    with enc.Encoding(feature_model, record=True) as encoding:
        encoding.set_configuration(configuration)
        soft = _preferences(encoding, feature_model, configuration, {"late"})
        found = encoding.optimise(soft)
        assert encoding.recorded is not None
        formula = WCNF()
        for clause in encoding.recorded:
            formula.append(clause)
        for literal, weight in soft:
            formula.append([literal], weight=weight)
        with RC2(formula, solver="g4") as maxsat:
            expected = maxsat.compute()
            assert maxsat.tobj  # (totalizers were built)
    assert found == expected


def test_the_start_state_takes_each_choice_from_the_latest_variant() -> None:
    """x and y are Dynamic Late alternatives (an XOR group); one is active at start, x,
    the first. With the solver's phases preferring y, the first variant activates y; the
    choice of x then needs a solve, whose variant (not the first) must decide y."""
    from motivml.binding import encoding as enc
    from motivml.binding.resolve import _start_on

    raw = feature("r", [feature(k, group="XOR", time="Late", mode="Dynamic") for k in ("x", "y")])
    feature_model, _ = read_model(parse(json.dumps(raw), "model.json"))
    configuration, _ = read_configuration(
        parse('{"properties": [{"id": "x"}, {"id": "y"}]}', "c.json"), feature_model, partial=True
    )
    variant = resolve(feature_model, configuration, start=False)
    with enc.Encoding(feature_model) as encoding:
        encoding.solver.set_phases([encoding.a(2), -encoding.a(1)])
        assert _start_on(encoding, variant) == [0, 1]


def test_an_encoding_with_its_configuration_for_good_answers_nothing_without_it() -> None:
    """After optimise the configuration is in the solver as units: a question about the
    model alone would be answered for the configuration, so it is refused; and optimise
    runs on Glucose 4 only, as RC2 did."""
    from motivml.binding import encoding as enc

    model, _ = load_model(SIMPLEBOT / "model.json")
    assert model is not None
    config, _ = load_configuration(SIMPLEBOT / "variants" / "field.json", model, partial=True)
    assert config is not None
    with enc.Encoding(model) as encoding:
        encoding.set_configuration(config)
        assert encoding.optimise([]) is not None
        with pytest.raises(ValueError, match="for good"):
            encoding.solve(with_config=False)
    with enc.Encoding(model, solver="minisat22") as other, pytest.raises(ValueError, match="Glucose 4"):
        other.optimise([])


@settings(max_examples=200, deadline=None, suppress_health_check=list(HealthCheck))
@given(model=models(max_features=12))
def test_every_variable_up_to_top_occurs_in_the_encodings_clauses(model: dict[str, Any]) -> None:
    """optimise tells RC2 that `top` is the formula's highest variable, as a WCNF counting
    the clauses would (RC2 numbers its totalizers after it): so no variable is made
    without a clause."""
    from motivml.binding import encoding as enc

    feature_model, _ = read_model(parse(json.dumps(model), "model.json"))
    with enc.Encoding(feature_model, record=True) as encoding:
        assert encoding.recorded is not None
        used = {abs(literal) for clause in encoding.recorded for literal in clause}
        assert used == set(range(1, encoding.top + 1))


def test_optimise_refuses_an_encoding_that_has_solved_already() -> None:
    """Its result is RC2's own only on a solver in the state RC2 would build: a solve
    before it would change the search, and so perhaps the variant among equals."""
    from motivml.binding import encoding as enc

    model, _ = load_model(SIMPLEBOT / "model.json")
    assert model is not None
    with enc.Encoding(model) as encoding:
        assert encoding.solve()
        with pytest.raises(ValueError, match="not solved anything yet"):
            encoding.optimise([])


def test_the_start_state_follows_optimise_on_the_same_solver() -> None:
    """After optimise the solver holds RC2's totalizers and the configuration as units;
    the start state found there is the one a fresh encoding finds, and the encoding takes
    no other configuration."""
    from motivml.binding import encoding as enc
    from motivml.binding.resolve import _preferences, _start_on, as_configuration

    model, _ = load_model(SIMPLEBOT / "model.json")
    assert model is not None
    config, _ = load_configuration(SIMPLEBOT / "variants" / "field.json", model, partial=True)
    assert config is not None
    variant = resolve(model, config, start=False)
    with enc.Encoding(model) as fresh:
        expected = _start_on(fresh, variant)
    with enc.Encoding(model) as encoding:
        encoding.set_configuration(config)
        assert encoding.optimise(_preferences(encoding, model, config, {"late"})) is not None
        assert _start_on(encoding, variant) == expected
        with pytest.raises(ValueError, match="for good"):
            encoding.set_configuration(as_configuration(variant))
    with enc.Encoding(model, explain=True) as explaining:  # (its model facts stay assumed)
        assert _start_on(explaining, variant) == expected
    assert expected is not None and len(expected) > 1


def test_fewer_undecided_features_come_before_the_time_wish() -> None:
    """The root's OR group needs w, or u with v. w is Early only and requires p and q, which
    then cannot be Late; u and v leave them free. With --prefer late the wishes are
    lexicographic: one undecided feature (w) beats two (u, v), whatever the times cost."""

    def node(fid: str, time: str = "Any", group: str = "", includes: tuple[str, ...] = ()) -> dict[str, Any]:
        constraints = {
            "bindingTimeAllowed": time,
            "bindingModeAllowed": "Any",
            "featuresIncluded": list(includes),
        }
        return {"id": fid, "name": fid, "group": group, "isMandatory": False, "constraints": constraints}

    model = {
        "id": "r",
        "name": "R",
        "sub": [
            node("w", "Early", "OR", ("p", "q")),
            node("u", "Any", "OR", ("v",)),
            node("v"),
            node("p"),
            node("q"),
        ],
    }
    config = {"properties": [{"id": "p"}, {"id": "q"}]}
    variants = list(ref.valid_variants(model, config))
    costs = sorted((ref.completion_cost(model, config, v, ("late",)), sorted(v)) for v in variants)
    assert costs[0] == ((1, 3, 0), ["p", "q", "r", "w"]) and costs[1][0] > costs[0][0]
    feature_model, _ = read_model(parse(json.dumps(model), "model.json"))
    configuration, _ = read_configuration(parse(json.dumps(config), "c.json"), feature_model, partial=True)
    resolved = resolve(feature_model, configuration, {"late"})
    assert sorted(d.feature.id for d in resolved.selected()) == ["p", "q", "r", "w"]


def test_ids_differing_only_in_case_are_refused(tmp_path: Path) -> None:
    (tmp_path / "variants").mkdir()
    (tmp_path / "model.json").write_text(
        '{"id": "r", "name": "R", "sub": [{"id": "slam", "name": "a"}, {"id": "SLAM", "name": "b"}]}'
    )
    (tmp_path / "variants" / "v.json").write_text('{"properties": []}')
    code, output = configure(str(tmp_path), "--variant", "v", "-o", str(tmp_path / "out"))
    assert code == 1
    assert (
        "model.json:1:70: $.sub[1].id: error: SLAM and slam differ only in case, "
        "so their C++ macros would be the same name" in output
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


def test_ros2_params_of_the_shipped_ros2_example(tmp_path: Path) -> None:
    """The UV robot's ros2_ward: the motivml node's start state and every lifecycle node's
    parameters (the ROS tests load this file into real nodes: tests/test_ros2_example.py)."""
    code, output = configure(
        str(ROOT / "feature_models" / "uv_disinfection"), "--variant", "ros2_ward", "-o", str(tmp_path)
    )
    assert code == 0 and "warning" not in output, output
    golden = GOLDEN / "uv_disinfection" / "ros2_ward" / "ros2_params.yaml"
    assert_matches_golden((tmp_path / "ros2_params.yaml").read_bytes(), golden)


def test_ros2_params_quote_ids_and_strings_and_keep_doubles_doubles(tmp_path: Path) -> None:
    """Ids and strings quoted (YAML 1.1 reads `on` as true), characters YAML would take for
    line breaks escaped, floats with a point, relative node names matched in any namespace
    (`/**/`), absolute ones as they are; a feature of another kind gets no node entry."""
    model = feature(
        "bot",
        [
            feature("on", time="Late", mode="Dynamic", isMandatory=False),
            feature("lamp", time="Early", mode="Dynamic", isMandatory=False),
            feature("slam", time="Late", mode="Dynamic", isMandatory=False),
        ],
    )
    (tmp_path / "variants").mkdir()
    (tmp_path / "model.json").write_text(json.dumps(model))
    (tmp_path / "variants" / "v.json").write_text(
        json.dumps({"properties": [{"id": "on"}, {"id": "lamp"}, {"id": "slam"}]})
    )
    (tmp_path / "robot.json").write_text(json.dumps({"pluginDirectories": ["plugins"]}))
    manifests = {
        "on": {"node": "detector", "parameters": {"label": 'a "b"\u2028c\u0085\u00e9', "big": 1e20, "n": -3}},
        "lamp": {
            "node": "/uv/lamp",
            "parameters": {"camera.fps": 30.0, "flags": [True, False], "names": ["x"]},
        },
    }
    for fid, entry in manifests.items():
        (tmp_path / "plugins" / fid).mkdir(parents=True)
        manifest = {"feature": fid, "kind": "ros2_lifecycle", "entry": entry}
        (tmp_path / "plugins" / fid / "plugin.json").write_text(json.dumps(manifest))
    (tmp_path / "plugins" / "slam").mkdir()
    (tmp_path / "plugins" / "slam" / "plugin.json").write_text(
        json.dumps({"feature": "slam", "kind": "python", "entry": {"module": "slam", "class": "Slam"}})
    )
    code, output = configure(str(tmp_path), "--variant", "v", "-o", str(tmp_path / "out"))
    assert code == 0, output
    assert (tmp_path / "out" / "ros2_params.yaml").read_text() == (
        "# Generated by motivml configure; do not edit (edit the model or the variant and re-run).\n"
        "# model bot, variant v\n"
        "/**/motivml:\n"
        "  ros__parameters:\n"
        "    features:\n"
        '      "on":\n'
        "        active: false\n"
        '      "lamp":\n'
        "        active: true\n"
        '      "slam":\n'
        "        active: false\n"
        "\n"
        "/**/detector:\n"
        "  ros__parameters:\n"
        '    label: "a \\"b\\"\\u2028c\\u0085\u00e9"\n'
        "    big: 1.0e+20\n"
        "    n: -3\n"
        '    motivml.feature: "on"\n'
        '    motivml.binding: "Dynamic Late"\n'
        "\n"
        "/uv/lamp:\n"
        "  ros__parameters:\n"
        "    camera.fps: 30.0\n"
        "    flags: [true, false]\n"
        '    names: ["x"]\n'
        '    motivml.feature: "lamp"\n'
        '    motivml.binding: "Dynamic Early"\n'
    )


_IDS = st.text(min_size=1, max_size=8)  # any text: quotes, backslashes, control and non-ASCII characters
_BY = st.sampled_from(["configuration", "solver", "model"])


@settings(max_examples=200, deadline=None)
@given(
    root=_IDS,
    name=st.text(max_size=8),
    entries=st.lists(
        st.tuples(_IDS, st.booleans(), st.sampled_from(list(Binding)), _BY, _BY, _BY), max_size=6
    ),
)
def test_the_lock_file_is_json_dumps_of_its_document_with_an_indent_of_2(
    root: str, name: str, entries: list[tuple[str, bool, Binding, str, str, str]]
) -> None:
    """lock_json writes the text itself (json's indenting encoder is pure Python): it must be
    exactly what json.dumps(indent=2) makes of the same document, escaping included."""
    features = [_feature(0, root, None)] + [_feature(k, e[0], 0) for k, e in enumerate(entries, 1)]
    model = FeatureModel(features, {}, [], source=None)
    decisions = [Decision(features[0], True, Binding.SE, "model", "model", "model")] + [
        Decision(features[k], selected, binding, by, time_by, mode_by)
        for k, (_, selected, binding, by, time_by, mode_by) in enumerate(entries, 1)
    ]
    variant = Variant(model, name, tuple(decisions))
    assert lock_json(variant) == json.dumps(_lock_document(variant), indent=2) + "\n"


def _lock_document(variant: Variant) -> dict[str, Any]:
    """The lock file as a document: each entry as a configuration entry with who decided it."""
    properties: list[dict[str, Any]] = []
    for d in variant.decisions[1:]:
        decided: dict[str, Any] = {"selection": d.selection_by}
        entry: dict[str, Any] = {"id": d.feature.id, "selected": d.selected}
        if d.selected:
            entry["props"] = {"time": d.binding.time, "mode": d.binding.mode}
            decided |= {"time": d.time_by, "mode": d.mode_by}
        properties.append({**entry, "x-decided": decided})
    return {
        "x-generated": BANNER,
        "x-model": variant.model.root.id,
        "x-variant": _printable(variant.name),
        "properties": properties,
    }


def _feature(index: int, feature_id: str, parent: int | None) -> Feature:
    return Feature(index, feature_id, feature_id, parent, 0, "", "", False, None, None, None, (), ())


literals = st.integers(1, 8).flatmap(lambda v: st.sampled_from([v, -v]))


@settings(max_examples=200, deadline=None)
@given(
    clauses=st.lists(st.lists(literals, min_size=1, max_size=3), max_size=12),
    soft=st.lists(st.tuples(literals, st.integers(0, 5)), min_size=1, max_size=10),  # (0: garbage at once)
    more=st.lists(st.tuples(st.integers(1, 8), st.integers(1, 5)), max_size=4),
)
def test_rc2_with_its_selectors_kept_at_c_speed_is_rc2(
    clauses: list[list[int]], soft: list[tuple[int, int]], more: list[tuple[int, int]]
) -> None:
    """The RC2 that `optimise` uses keeps the same selectors in the same order after every
    core as pysat's own, with soft literals added between two answers (RC2 appends their
    selectors; each contradicts the last answer, so the next one takes cores): the same
    costs, the same models."""
    from pysat.examples.rc2 import RC2
    from pysat.formula import WCNF

    from motivml.binding.encoding import _rc2

    formula = WCNF()
    for clause in clauses:
        formula.append(clause)
    for literal, weight in soft:
        formula.append([literal], weight=weight)
    seen: dict[type, list[list[int]]] = {}
    for kind in (RC2, _rc2()):

        class Watched(kind):  # type: ignore[misc, valid-type]
            watched = kind

            def filter_assumps(self) -> None:
                super().filter_assumps()
                state = [list(self.sels), list(self.sums), sorted(self.sels_set), sorted(self.wght.items())]
                seen.setdefault(self.watched, []).append(state)

        with Watched(formula, solver="g4") as maxsat:
            answers = [(maxsat.compute(), maxsat.cost)]
            for variable, weight in more:  # the last answer's value of a variable, wished otherwise
                model = answers[-1][0]
                if model is None:
                    break
                maxsat.add_clause([-model[(variable - 1) % len(model)]], weight=weight)
                answers.append((maxsat.compute(), maxsat.cost))
        seen.setdefault(kind, []).append(answers)  # type: ignore[arg-type]
    assert seen[RC2] == seen[_rc2()]


def test_the_configure_pipeline_writes_all_or_nothing(tmp_path: Path) -> None:
    """motivml.configure, as the CLI calls it: a valid variant's files and its decisions;
    an invalid one raises NotConfigured with its errors and the file they are in, and
    writes nothing."""
    from motivml.configure import NotConfigured, configure
    from motivml.documents.robot_folder import RobotFolder

    robot = RobotFolder.open(SIMPLEBOT)
    done = configure(robot, robot.variant_path("field"), tmp_path / "field", save_decisions=tmp_path / "d.json")
    assert done.folder == tmp_path / "field" and all(done.written.values())
    assert sorted(done.written) == sorted(p.name for p in (tmp_path / "field").iterdir())
    assert done.decisions == tmp_path / "d.json" and json.loads(done.decisions.read_text())["partial"] is True
    assert done.variant.model is not None and done.variant.selected()[0].feature.id == "root_feature"
    with pytest.raises(NotConfigured) as refused:
        configure(robot, robot.variant_path("broken_gridmap_dynamic"), tmp_path / "broken")
    assert refused.value.what.endswith("broken_gridmap_dynamic.json") and refused.value.diagnostics
    assert not (tmp_path / "broken").exists()

"""Pictures as DOT and GraphML: one node per feature, the right edges, escaping, deep models."""

from __future__ import annotations

import json
import re
import shutil
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
from helpers import feature
from paths import SIMPLEBOT

from motivml.architecture.document import Architecture, read_architecture
from motivml.binding.resolve import Variant, resolve
from motivml.documents.loader import parse
from motivml.errors import EnvironmentProblem
from motivml.graph import (
    architecture_dot,
    architecture_graphml,
    feature_model_dot,
    feature_model_graphml,
    render_svg,
)
from motivml.language.model import Feature, FeatureModel, token
from motivml.language.reader import load_configuration, load_model, read_model

NS = {"g": "http://graphml.graphdrawing.org/xmlns", "svg": "http://www.w3.org/2000/svg"}
NODE = re.compile(r'^\s*"((?:[^"\\]|\\.)*)" \[', re.MULTILINE)
EDGE = re.compile(r'^\s*"((?:[^"\\]|\\.)*)" -> "((?:[^"\\]|\\.)*)" \[(.*)\];$', re.MULTILINE)
NASTY = 'Say "hi" to <R&D> &amp; C:\\new\\'  # quotes, an entity, a \n that is not one, a final backslash


def simplebot() -> FeatureModel:
    model, diagnostics = load_model(SIMPLEBOT / "model.json")
    assert model is not None, diagnostics
    return model


def lab(model: FeatureModel) -> Variant:
    config, diagnostics = load_configuration(SIMPLEBOT / "variants" / "lab.json", model)
    assert config is not None, diagnostics
    return resolve(model, config)


def graphml(text: str) -> tuple[dict[str, dict[str, str]], list[tuple[str, str, dict[str, str]]]]:
    """Nodes (id -> data) and edges (source, target, data) of a GraphML document."""
    root = ET.fromstring(text.encode("utf-8"))
    keys = {k.get("id"): k.get("attr.name") for k in root.findall("g:key", NS)}

    def data(element: ET.Element) -> dict[str, str]:
        return {str(keys[d.get("key")]): d.text or "" for d in element.findall("g:data", NS)}

    nodes = {str(n.get("id")): data(n) for n in root.iterfind("g:graph/g:node", NS)}
    edges = [
        (str(e.get("source")), str(e.get("target")), data(e)) for e in root.iterfind("g:graph/g:edge", NS)
    ]
    return nodes, edges


def node_lines(dot: str) -> dict[str, str]:
    found: dict[str, str] = {}
    for match in NODE.finditer(dot):
        assert match.group(1) not in found, f"{match.group(1)} drawn twice"
        found[match.group(1)] = dot[match.start() : dot.index("\n", match.start())]
    return found


def svg_labels(svg: bytes) -> dict[str, list[str]]:
    """Node title -> the lines of text Graphviz drew in it."""
    root = ET.fromstring(svg)
    return {
        str(g.findtext("svg:title", namespaces=NS)): [t.text or "" for t in g.iterfind("svg:text", NS)]
        for g in root.iter("{http://www.w3.org/2000/svg}g")
        if g.get("class") == "node"
    }


def test_graphml_has_one_node_per_feature_and_the_tree_and_constraint_edges() -> None:
    model = simplebot()
    nodes, edges = graphml(feature_model_graphml(model))
    assert list(nodes) == [f.id for f in model.features]  # pre-order
    assert nodes["slam"]["label"] == model["slam"].name
    assert (nodes["slam"]["timeAllowed"], nodes["slam"]["modeAllowed"]) == ("Any", "Any")
    tree = {(s, t, d["kind"]) for s, t, d in edges if d["kind"] not in ("requires", "excludes")}
    expected_tree = set()
    for f in model.features[1:]:
        assert f.parent is not None
        kind = f.group.lower() if f.group else "mandatory" if f.mandatory else "optional"
        expected_tree.add((model.features[f.parent].id, f.id, kind))
    assert tree == expected_tree
    assert {"or", "xor", "mandatory", "optional"} <= {kind for _, _, kind in tree}
    constraints = {(s, t, d["kind"]) for s, t, d in edges if d["kind"] in ("requires", "excludes")}
    assert constraints == {(f.id, t, "requires") for f in model.features for t in f.includes} | {
        (f.id, t, "excludes") for f in model.features for t in f.excludes
    }
    assert ("slam", "grid_map", "requires") in constraints
    assert len(edges) == len(tree) + len(constraints)


def test_dot_draws_every_feature_once_with_foda_edges() -> None:
    model = simplebot()
    dot = feature_model_dot(model)
    nodes = node_lines(dot)
    assert [n for n in nodes if "/" not in n] == [f.id for f in model.features]
    assert {n for n in nodes if "/" in n} == {f"{model.features[g.parent].id}/{g.kind}" for g in model.groups}
    slam = model["slam"]
    assert f'label="{slam.name}\\n{token(slam.time_allowed)} · {token(slam.mode_allowed)}"' in nodes["slam"]
    edges = {(s, t): attrs for s, t, attrs in EDGE.findall(dot)}
    mandatory = next(f for f in model.features[1:] if f.mandatory)
    optional = next(f for f in model.features[1:] if not f.mandatory and not f.group)
    assert 'arrowhead="dot"' in edges[(model.features[mandatory.parent or 0].id, mandatory.id)]
    assert 'arrowhead="odot"' in edges[(model.features[optional.parent or 0].id, optional.id)]
    assert 'label="requires"' in edges[("slam", "grid_map")] and "dashed" in edges[("slam", "grid_map")]
    assert dot == feature_model_dot(simplebot())  # deterministic


def test_a_variant_greys_out_unselected_features_and_shows_bindings() -> None:
    model = simplebot()
    variant = lab(model)
    unselected = [d.feature.id for d in variant.decisions if not d.selected]
    selected = [d for d in variant.decisions if d.selected]
    assert unselected and selected
    lines = node_lines(feature_model_dot(model, variant))
    for fid in unselected:
        assert "dashed" in lines[fid] and "not selected" in lines[fid]
    names = {"SE": "Static Early", "SL": "Static Late", "DE": "Dynamic Early", "DL": "Dynamic Late"}
    for d in selected:
        assert "dashed" not in lines[d.feature.id]
        assert f"\\n{names[d.binding]}" in lines[d.feature.id]
    nodes, _ = graphml(feature_model_graphml(model, variant))
    assert {n for n, data in nodes.items() if data["selected"] == "false"} == set(unselected)
    assert all(nodes[d.feature.id]["binding"] == d.binding for d in selected)


def test_graphml_declares_its_keys_with_types() -> None:
    model = simplebot()
    root = ET.fromstring(feature_model_graphml(model, lab(model)))
    assert root.tag == "{http://graphml.graphdrawing.org/xmlns}graphml"
    keys = {k.get("id"): (k.get("for"), k.get("attr.type")) for k in root.findall("g:key", NS)}
    assert keys["label"] == ("all", "string") and keys["kind"] == ("all", "string")
    assert keys["mandatory"] == keys["selected"] == ("node", "boolean")
    assert keys["binding"] == ("node", "string")
    used = {d.get("key") for d in root.iter("{http://graphml.graphdrawing.org/xmlns}data")}
    assert used == set(keys)
    assert ET.fromstring(architecture_graphml(architecture())).find("g:key[@id='dimension']", NS) is not None


def test_a_variant_of_another_model_is_refused() -> None:
    other = lab(simplebot())
    with pytest.raises(ValueError, match="no decision for 'f0'"):
        feature_model_dot(chain(3), other)


def test_labels_are_escaped_for_xml_and_dot() -> None:
    doc = {"id": "root", "name": "R", "sub": [feature("odd", name=NASTY), feature("plain", inc=["odd"])]}
    model, _ = read_model(parse(json.dumps(doc), "model.json"))
    nodes, _ = graphml(feature_model_graphml(model))
    assert nodes["odd"]["label"] == NASTY
    dot = feature_model_dot(model)
    assert node_lines(dot).keys() >= {"root", "odd", "plain"}
    if shutil.which("dot") is None:
        pytest.skip("Graphviz dot is not installed: the rendered labels are not checked")
    svg = render_svg(dot)
    assert svg is not None
    assert svg_labels(svg)["odd"] == [NASTY, "Static · Early"]


def test_control_characters_and_newlines_stay_well_formed() -> None:
    doc = {"id": "root", "name": "R", "sub": [feature("odd", name="two\nlines\x01\r\nend")]}
    model, _ = read_model(parse(json.dumps(doc), "model.json"))
    nodes, _ = graphml(feature_model_graphml(model))
    assert nodes["odd"]["label"] == "two\nlines\ufffd\r\nend"  # \r kept as &#13;
    assert 'label="two\\nlines\ufffd\\nend\\n' in node_lines(feature_model_dot(model))["odd"]


def chain(depth: int) -> FeatureModel:
    features = [
        Feature(i, f"f{i}", f"F{i}", i - 1 if i else None, 0, "", "", bool(i), None, None, None, (), ())
        for i in range(depth)
    ]
    for f in features[1:]:
        features[f.index - 1].children.append(f.index)
    return FeatureModel(features, {f.id: f.index for f in features}, [], "chain")


def test_a_2000_deep_model_draws_without_recursion() -> None:
    model = chain(2000)
    nodes, edges = graphml(feature_model_graphml(model))
    assert len(nodes) == 2000 and len(edges) == 1999
    assert len(node_lines(feature_model_dot(model))) == 2000


MODEL = {
    "id": "arm",
    "name": "Arm",
    "sub": [feature("reaching", isMandatory=False), feature("gait", isMandatory=False)],
}
ARCHITECTURE: dict[str, Any] = {
    "spaces": [
        {"id": "pose_goal", "type": "Pose", "dimension": 6, "unit": "m, rad", "feature": "reaching"},
        {"id": "joint_goal", "type": "JointAngles", "dimension": 7, "unit": "rad", "feature": "reaching"},
        {"id": "joints", "type": "JointAngles", "dimension": 7, "unit": "rad", "feature": "arm"},
        {"id": "command", "type": "JointAngles", "dimension": 7, "feature": "arm"},
        {"id": "legs", "type": "JointAngles", "dimension": 4, "unit": "rad", "feature": "gait"},
        {"id": "leg_joints", "type": "JointAngles", "dimension": 4, "unit": "rad", "feature": "arm"},
    ],
    "mappings": [
        {
            "id": "ik",
            "kind": "adaptiveMapping",
            "from": "pose_goal",
            "to": "joint_goal",
            "learner": {"type": "elm"},
            "feature": "reaching",
        },
        {
            "id": "limit",
            "kind": "transformation",
            "from": "joint_goal",
            "to": "command",
            "feature": "reaching",
        },
        {
            "id": "to_joints",
            "kind": "transformation",
            "from": "legs",
            "to": "leg_joints",
            "function": {"type": "scale", "factor": 2},
            "feature": "gait",
        },
    ],
    "modules": [
        {
            "id": "reach_dmp",
            "systems": [{"type": "dmp", "dimension": 7}],
            "learners": [{"type": "ridge", "mode": "offline"}],
            "feature": "reaching",
        },
        {"id": "cpg", "systems": [{"type": "oscillators", "dimension": 4}], "feature": "gait"},
        {"id": "spare", "systems": [{"type": "pointAttractor", "dimension": 7}], "feature": "arm"},
    ],
    "components": [
        {
            "id": "reacher",
            "kind": "ReachingController",
            "module": "reach_dmp",
            "rate": 100,
            "goal": {"space": "pose_goal", "through": "ik"},
            "feedback": {"space": "joints"},
            "output": {"space": "command", "through": "limit"},
            "criterion": {"type": "convergence", "tolerance": 0.01},
            "feature": "reaching",
        },
        {
            "id": "walker",
            "kind": "PatternGenerator",
            "module": "cpg",
            "output": {"space": "legs"},
            "feature": "gait",
        },
    ],
}


def architecture() -> Architecture:
    model, _ = read_model(parse(json.dumps(MODEL), "model.json"))
    arch, diagnostics = read_architecture(
        parse(json.dumps(ARCHITECTURE, indent=1), "architecture.json"), model
    )
    assert arch is not None, diagnostics
    return arch


def test_architecture_graphml_has_elements_and_wiring() -> None:
    nodes, edges = graphml(architecture_graphml(architecture()))
    spaces = ["pose_goal", "joint_goal", "joints", "command", "legs", "leg_joints"]
    mappings = ["ik", "limit", "to_joints"]
    assert list(nodes) == spaces + mappings + ["reach_dmp", "cpg", "spare", "reacher", "walker"]
    assert (nodes["ik"]["type"], nodes["ik"]["to"], nodes["to_joints"]["function"]) == (
        "adaptiveMapping",
        "joint_goal",
        "scale",
    )
    assert nodes["pose_goal"] == {
        **{"label": "pose_goal", "kind": "space", "feature": "reaching"},
        **{"type": "Pose", "dimension": "6", "unit": "m, rad"},
    }
    assert nodes["reacher"] == {
        **{"label": "reacher", "kind": "component", "feature": "reaching"},
        **{"type": "ReachingController", "module": "reach_dmp", "rate": "100.0"},
    }
    assert {(s, t, d["kind"]) for s, t, d in edges} == {
        ("pose_goal", "ik", "from"),  # ik and limit convert on ports: joint_goal is their module side
        ("ik", "reacher", "goal"),
        ("reacher", "limit", "output"),
        ("limit", "command", "to"),
        ("legs", "to_joints", "from"),
        ("to_joints", "leg_joints", "to"),
        ("reacher", "reach_dmp", "runs"),
        ("joints", "reacher", "feedback"),
        ("walker", "cpg", "runs"),
        ("walker", "legs", "output"),
    }


def test_architecture_dot_clusters_per_feature_and_draws_modules_inside_components() -> None:
    dot = architecture_dot(architecture())
    nodes = node_lines(dot)
    spaces = {"pose_goal", "joint_goal", "joints", "command", "legs", "leg_joints"}
    assert set(nodes) == spaces | {"ik", "limit", "to_joints", "spare", "reacher", "walker"}  # modules inside
    assert 'label="pose_goal\\nPose(6) [m, rad]", shape="ellipse"' in nodes["pose_goal"]
    assert "reach_dmp\\ndmp(7)\\nlearns: ridge offline" in nodes["reacher"] and "record" in nodes["reacher"]
    assert re.findall(r'subgraph "cluster_(\w+)"', dot) == ["reaching", "arm", "gait"]
    edges = {(s, t): attrs for s, t, attrs in EDGE.findall(dot)}
    assert edges[("ik", "reacher")].startswith('label="goal"')
    assert 'label="feedback", style="dashed"' == edges[("joints", "reacher")]
    assert edges[("reacher", "limit")] == 'label="output"'
    assert ("ik", "joint_goal") not in edges and ("joint_goal", "limit") not in edges


def test_architecture_of_selected_features_shows_absent_references() -> None:
    arch = architecture()
    nodes, _ = graphml(architecture_graphml(arch, {"arm", "gait"}))
    assert "reacher" not in nodes and "ik" not in nodes and "walker" in nodes
    assert all(data["feature"] in ("arm", "gait") for data in nodes.values())
    only_reaching = architecture_dot(arch, {"arm", "reaching"})
    lines = node_lines(only_reaching)
    assert "legs" not in lines and "walker" not in lines
    assert "(not present)" not in only_reaching
    gait_alone = {"gait"}  # its transformation writes into leg_joints, brought by arm
    assert "(not present)" in node_lines(architecture_dot(arch, gait_alone))["leg_joints"]
    assert nodes["to_joints"]["feature"] == "gait" and nodes["leg_joints"]["feature"] == "arm"
    gait_nodes, _ = graphml(architecture_graphml(arch, gait_alone))
    assert gait_nodes["leg_joints"]["kind"] == "absent"


def test_render_svg(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr(shutil, "which", lambda name: None)
    assert render_svg("digraph { a }") is None  # no Graphviz: nothing to render, no error
    with pytest.raises(EnvironmentProblem, match="cannot run Graphviz") as missing:
        render_svg("digraph { a }", str(tmp_path / "no-dot"))
    assert missing.value.exit_code == 3
    slow = tmp_path / "slow-dot"
    slow.write_text(f"#!{sys.executable}\nimport time\ntime.sleep(5)\n")
    slow.chmod(0o755)
    with pytest.raises(EnvironmentProblem, match="took longer than 0.2 s"):
        render_svg("digraph { a }", str(slow), timeout=0.2)
    monkeypatch.undo()
    if shutil.which("dot") is None:
        pytest.skip("Graphviz dot is not installed")
    with pytest.raises(EnvironmentProblem, match=r"Graphviz failed \(exit status 1\): .*syntax error"):
        render_svg("digraph { a -> }")
    svg = render_svg(architecture_dot(architecture()))
    assert svg is not None and b"<svg" in svg
    assert "reacher" in svg_labels(svg)


# ------------------------------------------------------------------ motivml graph
def test_graph_command_draws_a_variants_model_and_architecture(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from motivml.cli import main

    examples = Path(__file__).resolve().parent.parent / "feature_models"
    out = tmp_path / "pictures"
    args = ["graph", str(examples / "quadruped"), "--variant", "trot", "--format", "graphml", "-o", str(out)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir()) == ["architecture.graphml", "feature-model.graphml"]
    architecture = ET.parse(out / "architecture.graphml").getroot()
    ids = {node.get("id") for node in architecture.iter("{http://graphml.graphdrawing.org/xmlns}node")}
    assert "TrotGenerator" in str(ids) and "PaceGenerator" not in str(ids)  # the start state only
    assert "ReflexController" not in str(ids)  # Late reflexes do not start
    again = CliRunner().invoke(main, args)
    assert "unchanged" in again.output and "wrote" not in again.output


def test_graph_command_refuses_an_invalid_variant_and_writes_nothing(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from motivml.cli import main

    examples = Path(__file__).resolve().parent.parent / "feature_models"
    out = tmp_path / "pictures"
    result = CliRunner().invoke(
        main, ["graph", str(examples / "quadruped"), "--variant", "broken_two_gaits", "-o", str(out)]
    )
    assert result.exit_code == 1 and "rules 2.2 and 3.3" in result.output and not out.exists()
    model_only = CliRunner().invoke(main, ["graph", str(examples / "uv_disinfection"), "-o", str(out)])
    assert model_only.exit_code == 0 and "drawing the feature model only" in model_only.output
    names = sorted(p.name for p in out.iterdir())
    assert names == (
        ["feature-model.dot", "feature-model.svg"] if shutil.which("dot") else ["feature-model.dot"]
    )


PICTURES = {
    "reaching_arm": "dmp",
    "quadruped": "gaits_at_run_time",
    "mixture_arm": "mixed",
    "laundry_gripping": "learned",
}


@pytest.mark.parametrize("robot", sorted(PICTURES))
def test_the_guides_pictures_are_what_graph_draws_now(robot: str, tmp_path: Path) -> None:
    from click.testing import CliRunner

    from motivml.cli import main

    root = Path(__file__).resolve().parent.parent
    args = ["graph", str(root / "feature_models" / robot), "--variant", PICTURES[robot], "-o", str(tmp_path)]
    assert CliRunner().invoke(main, args).exit_code == 0
    committed = root / "guidelines" / "images" / robot
    for drawn in sorted(tmp_path.iterdir()):
        assert drawn.read_text() == (committed / drawn.name).read_text(), (
            f"regenerate {committed / drawn.name}"
        )


# --------------------------------------------- graph without Graphviz, export's refusals
def test_graph_without_graphviz_writes_the_dot_files_and_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from click.testing import CliRunner

    from motivml.cli import main

    examples = Path(__file__).resolve().parent.parent / "feature_models"
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))  # no dot anywhere
    out = tmp_path / "pictures"
    result = CliRunner().invoke(main, ["graph", str(examples / "reaching_arm"), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir()) == ["architecture.dot", "feature-model.dot"]
    assert result.output.splitlines()[-1] == (
        "Graphviz's dot is not installed: no SVG (install graphviz, or render the .dot files elsewhere)"
    )


def test_export_without_or_with_a_broken_coordination_writes_nothing(tmp_path: Path) -> None:
    import json

    from click.testing import CliRunner

    from motivml.cli import main

    examples = Path(__file__).resolve().parent.parent / "feature_models"
    target = tmp_path / "chart.scxml"
    none = CliRunner().invoke(main, ["export", "scxml", str(examples / "reaching_arm"), "-o", str(target)])
    assert none.exit_code == 3
    assert none.output == (
        f"nothing to export: {examples / 'reaching_arm' / 'coordination.json'} does not exist\n"
    )
    robot = tmp_path / "arm"
    shutil.copytree(examples / "coordinated_arm", robot)
    (robot / "coordination.json").write_text(json.dumps({"initial": "Gone", "states": [{"id": "Here"}]}))
    broken = CliRunner().invoke(main, ["export", "scxml", str(robot), "-o", str(target)])
    assert broken.exit_code == 1
    assert "error: the initial state 'Gone' is not a top-level state" in broken.output
    assert broken.output.splitlines()[-1] == f"nothing exported: {robot}"
    assert not target.exists()

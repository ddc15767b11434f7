"""Bad input of any kind: never a traceback, always a located message and exit 1 (or 0)."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis_jsonschema import from_schema
from paths import SIMPLEBOT

from motivml.cli import main
from motivml.documents.schema import CONFIGURATION, load_schema

pytestmark = pytest.mark.slow  # property tests: schema-valid documents through every stage

LOCATED = re.compile(r"^\S+\.json:\d+:\d+: \$.*: (error|warning): ", re.M)

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)
SETTINGS = settings(max_examples=120, deadline=None, suppress_health_check=list(HealthCheck))


def check(args: list[str]) -> None:
    result = CliRunner().invoke(main, args)
    assert isinstance(result.exception, SystemExit) or result.exception is None, result.output
    assert result.exit_code in (0, 1), (result.exit_code, result.output)
    if result.exit_code == 1:
        assert LOCATED.search(result.output), result.output


def write(tmp: Path, name: str, value: Any) -> str:
    path = tmp / name
    path.write_text(json.dumps(value, indent=1, allow_nan=True))
    return str(path)


def model_schema(levels: int = 2) -> dict[str, Any]:
    """The feature-model schema with its recursion unrolled `levels` deep (for generation)."""
    published = load_schema("feature-model.schema.json")
    defs = published["$defs"]

    def feature(level: int) -> dict[str, Any]:
        body = copy.deepcopy(defs["featureBody"])
        body["properties"]["id"] = defs["identifier"]
        body["properties"]["constraints"] = copy.deepcopy(defs["constraints"])
        for key in ("featuresIncluded", "featuresExcluded"):
            body["properties"]["constraints"]["properties"][key]["items"] = {"enum": ["a", "b", "c", "r"]}
        body["properties"]["id"] = {"enum": ["a", "b", "c", "r"]}
        body["properties"]["sub"] = {
            "type": "array",
            "maxItems": 3,
            "items": feature(level - 1) if level else False,
        }
        body["additionalProperties"] = False
        body.pop("patternProperties")
        return body

    return feature(levels)


@SETTINGS
@given(value=json_values)
def test_arbitrary_json_as_model(tmp_path_factory: Any, value: Any) -> None:
    tmp = tmp_path_factory.mktemp("m")
    check(["validate", write(tmp, "model.json", value)])


@SETTINGS
@given(value=json_values)
def test_arbitrary_json_as_configuration(tmp_path_factory: Any, value: Any) -> None:
    tmp = tmp_path_factory.mktemp("c")
    check(["validate", str(SIMPLEBOT / "model.json"), "--config", write(tmp, "c.json", value)])


@SETTINGS
@given(model=from_schema(model_schema()))
def test_schema_valid_models(tmp_path_factory: Any, model: Any) -> None:
    tmp = tmp_path_factory.mktemp("s")
    check(["validate", write(tmp, "model.json", model)])


@SETTINGS
@given(config=from_schema({**load_schema(CONFIGURATION), "$id": "urn:test"}))
def test_schema_valid_configurations(tmp_path_factory: Any, config: Any) -> None:
    tmp = tmp_path_factory.mktemp("v")
    check(["validate", str(SIMPLEBOT / "model.json"), "--config", write(tmp, "c.json", config), "--partial"])


def mutations(document: Any) -> st.SearchStrategy[Any]:
    """Near-valid documents: one node of a real document replaced, dropped or renamed."""
    nodes: list[tuple[Any, Any]] = []
    stack = [document]
    while stack:
        node = stack.pop()
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else []
        for key, child in items:
            nodes.append((node, key))
            stack.append(child)

    @st.composite
    def mutate(draw: st.DrawFn) -> Any:
        copied = copy.deepcopy(document)
        index = draw(st.integers(0, len(nodes) - 1))
        # find the same node in the copy by replaying the walk
        copied_nodes: list[tuple[Any, Any]] = []
        stack2 = [copied]
        while stack2:
            node = stack2.pop()
            items = (
                node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else []
            )
            for key, child in items:
                copied_nodes.append((node, key))
                stack2.append(child)
        container, key = copied_nodes[index]
        action = draw(st.sampled_from(["replace", "drop", "rename"]))
        if action == "replace":
            container[key] = draw(json_values)
        elif action == "drop":
            del container[key]
        elif isinstance(container, dict):
            container[draw(st.text(max_size=12))] = container.pop(key)
        return copied

    return mutate()


SIMPLEBOT_MODEL = json.loads((SIMPLEBOT / "model.json").read_text())
LAB = json.loads((SIMPLEBOT / "variants" / "lab.json").read_text())


@SETTINGS
@given(model=mutations(SIMPLEBOT_MODEL))
def test_near_valid_models(tmp_path_factory: Any, model: Any) -> None:
    tmp = tmp_path_factory.mktemp("n")
    check(["validate", write(tmp, "model.json", model)])


@SETTINGS
@given(config=mutations(LAB))
def test_near_valid_configurations(tmp_path_factory: Any, config: Any) -> None:
    tmp = tmp_path_factory.mktemp("k")
    check(["validate", str(SIMPLEBOT / "model.json"), "--config", write(tmp, "c.json", config)])

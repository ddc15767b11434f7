"""Small builders shared by the tests, and the golden-file check."""

from __future__ import annotations

import difflib
import json
import os
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

UPDATE_GOLDEN = "MOTIVML_UPDATE_GOLDEN"


def feature(fid: str, sub: list[dict[str, Any]] | None = None, **extra: Any) -> dict[str, Any]:
    """A feature object; `time`/`mode` set the allowed binding, `inc`/`exc` the constraints."""
    node: dict[str, Any] = {"id": fid, "name": fid.capitalize()}
    constraints: dict[str, Any] = {}
    if "time" in extra:
        constraints["bindingTimeAllowed"] = extra.pop("time")
    if "mode" in extra:
        constraints["bindingModeAllowed"] = extra.pop("mode")
    if "inc" in extra:
        constraints["featuresIncluded"] = extra.pop("inc")
    if "exc" in extra:
        constraints["featuresExcluded"] = extra.pop("exc")
    if constraints:
        node["constraints"] = constraints
    node.update(extra)
    if sub:
        node["sub"] = sub
    return node


def dumps(value: Any) -> str:
    """Pretty JSON, so that messages have distinct lines."""
    return json.dumps(value, indent=2)


def config(*entries: tuple[Any, ...]) -> dict[str, Any]:
    """Entries as (id,) / (id, False) / (id, time, mode)."""
    properties = []
    for entry in entries:
        if len(entry) == 1:
            properties.append({"id": entry[0]})
        elif len(entry) == 2:
            properties.append({"id": entry[0], "selected": entry[1]})
        else:
            properties.append({"id": entry[0], "props": {"time": entry[1], "mode": entry[2]}})
    return {"properties": properties}


def assert_matches_golden(actual: bytes, golden: Path) -> None:
    """`actual` must equal the golden file's bytes.

    With MOTIVML_UPDATE_GOLDEN=1 in the environment, a golden file that differs (or is
    missing) is rewritten with `actual`, and the test still fails, showing the difference
    and asking for a re-run: an update run can never pass a changed output unseen, and the
    new golden file is then checked like any other. An unchanged golden file is left alone.
    """
    expected = golden.read_bytes() if golden.exists() else None
    if actual == expected:
        return
    was = [] if expected is None else expected.decode(errors="replace").splitlines(keepends=True)
    diff = "".join(
        difflib.unified_diff(
            was, actual.decode(errors="replace").splitlines(keepends=True), f"{golden} (golden)", "(now)"
        )
    )
    if os.environ.get(UPDATE_GOLDEN):
        golden.parent.mkdir(parents=True, exist_ok=True)
        golden.write_bytes(actual)
        pytest.fail(
            f"golden file {golden} updated ({UPDATE_GOLDEN} is set): review the change and "
            f"re-run without {UPDATE_GOLDEN}\n{diff}",
            pytrace=False,
        )
    if expected is None:
        pytest.fail(
            f"no golden file {golden}: create it with {UPDATE_GOLDEN}=1, then review it", pytrace=False
        )
    raise AssertionError(f"output differs from {golden} (to accept the change: {UPDATE_GOLDEN}=1)\n{diff}")


def until(condition: Callable[[], Any], timeout: float = 20.0, what: str = "") -> Any:
    """Poll a condition (cheap, local) until it holds; fail after `timeout`."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        threading.Event().wait(0.02)  # a poll interval, not a wait for the outcome
    pytest.fail(f"timed out waiting for {what or condition}")


def model_of(document: dict[str, Any]) -> Any:
    """The FeatureModel of a model document (as model.json), which must have no errors."""
    from motivml.documents.loader import parse
    from motivml.language.reader import read_model

    model, problems = read_model(parse(json.dumps(document, indent=1), "model.json"))
    assert not [p for p in problems if p.severity.value == "error"], problems
    return model


def simulated_run(robot: str | Path, variant: str, seconds: float, *requests: tuple[float, str]) -> list[str]:
    """The arguments of `motivml run` on the simulated clock, without the live view or the
    control socket, making each (time, request) of `requests`."""
    args = ["run", str(robot), "--variant", variant, "--duration", f"{seconds:g}", "--clock", "simulated"]
    args += ["--no-live", "--no-control"]
    for at, request in requests:
        args += ["--at", f"{at:g}", request]
    return args

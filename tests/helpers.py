"""Small builders shared by the tests."""

from __future__ import annotations

import json
from typing import Any


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

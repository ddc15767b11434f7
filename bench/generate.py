"""Generator of realistic random MoTiVML models with a valid complete configuration.

`generate(n, seed)` returns `(model, config)` as JSON-ready dicts: a tree of `n` features
(deep, as real 100k-feature models are: about n/50 levels), about a fifth of the parents with
an OR or XOR group, ~30% of the ungrouped children mandatory, ~10% of the features in
includes/excludes, and mixed bindings (~20% Late, ~15% Dynamic). The configuration is built
first (top-down, obeying reference.md sections 2-4) and the constraints are then drawn so
that it stays valid, so the benchmark measures a realistic *valid* check end to end.

    python bench/generate.py 10000 --seed 1 -o /tmp/m10k   # writes model.json, variants/full.json

`open_decisions(config, seed)` (`--open`) turns that configuration into a decisions file with
many open decisions, as a team writes one for `configure`: a tenth of the entries left out
(their selection open) and each remaining selected entry's time and mode `Any` with
probability 1/2 (half the bindings open). The complete configuration is one of its
completions, so it stays satisfiable.
"""

from __future__ import annotations

import argparse
import json
import os
import random
from typing import Any


def generate(n: int, seed: int = 0, window: int = 100) -> tuple[dict[str, Any], dict[str, Any]]:
    rng = random.Random(seed)
    parent = [-1] + [max(0, i - 1 - rng.randrange(window)) for i in range(1, n)]
    children: list[list[int]] = [[] for _ in range(n)]
    for i in range(1, n):
        children[parent[i]].append(i)

    group = [""] * n
    mandatory = [False] * n
    for p in range(n):
        kids = children[p]
        if len(kids) >= 2 and rng.random() < 0.2:
            label = rng.choice(["OR", "XOR"])
            members = kids[: rng.randint(2, min(5, len(kids)))]
            for c in members:
                group[c] = label
        for c in kids:
            if not group[c]:
                mandatory[c] = rng.random() < 0.3

    # Bindings top-down for every feature (so allowed bindings of unselected features are
    # consistent too), then the selection.
    early = [True] * n
    static = [True] * n
    for c in range(1, n):
        p = parent[c]
        if not static[p]:
            static[c] = False
            early[c] = early[p] if mandatory[c] else (early[p] and rng.random() < 0.8)
        elif mandatory[c]:
            static[c], early[c] = True, early[p]
        else:
            static[c] = rng.random() >= 0.15
            early[c] = early[p] and rng.random() >= 0.2
    selected = [False] * n
    selected[0] = True
    for p in range(n):  # parents come before children: indices are a topological order
        kids = children[p]
        if not selected[p]:
            continue
        xor = [c for c in kids if group[c] == "XOR"]
        orr = [c for c in kids if group[c] == "OR"]
        for c in kids:
            if not group[c]:
                selected[c] = mandatory[c] or rng.random() < 0.6
        if xor:
            selected[rng.choice(xor)] = True
        if orr:
            for c in rng.sample(orr, rng.randint(1, len(orr))):
                selected[c] = True

    includes: list[list[int]] = [[] for _ in range(n)]
    excludes: list[list[int]] = [[] for _ in range(n)]
    chosen = [i for i in range(1, n)]
    rng.shuffle(chosen)
    # Includes target selected Static Early features, so every feature stays selectable
    # (real models have few dead features); excludes pair a feature with an unselected one.
    targets = [i for i in range(1, n) if selected[i] and static[i] and early[i]]
    unselected = [i for i in range(1, n) if not selected[i]]
    for x in chosen[: n // 20]:
        if targets:
            y = rng.choice(targets)
            if y != x:
                includes[x].append(y)
    for x in chosen[n // 20 : n // 10]:
        if unselected:
            y = rng.choice(unselected)
            if y != x:
                excludes[x].append(y)

    def time_token(i: int) -> str:
        if rng.random() < 0.5:
            return "Any"
        return "Early" if early[i] else "Late"

    def mode_token(i: int) -> str:
        if rng.random() < 0.5:
            return "Any"
        return "Static" if static[i] else "Dynamic"

    nodes: list[dict[str, Any]] = []
    for i in range(n):
        node: dict[str, Any] = {
            "id": f"f{i}",
            "name": f"Feature {i}",
            "constraints": {
                "featuresIncluded": [f"f{j}" for j in includes[i]],
                "featuresExcluded": [f"f{j}" for j in excludes[i]],
                "bindingTimeAllowed": time_token(i) if i else "Early",
                "bindingModeAllowed": mode_token(i) if i else "Static",
            },
            "group": group[i],
            "isMandatory": mandatory[i] if not group[i] else False,
            "sub": [],
        }
        if i == 0:
            node["isSelected"] = True
        nodes.append(node)
        if i:
            nodes[parent[i]]["sub"].append(node)

    properties: list[dict[str, Any]] = []
    for i in range(1, n):
        if selected[i]:
            properties.append(
                {
                    "id": f"f{i}",
                    "props": {
                        "time": "Early" if early[i] else "Late",
                        "mode": "Static" if static[i] else "Dynamic",
                    },
                }
            )
        else:
            properties.append({"id": f"f{i}", "selected": False})
    return nodes[0], {"properties": properties}


def depth(model: dict[str, Any]) -> int:
    best, stack = 0, [(model, 1)]
    while stack:
        node, d = stack.pop()
        best = max(best, d)
        stack.extend((c, d + 1) for c in node.get("sub", []))
    return best


def open_decisions(
    config: dict[str, Any], seed: int = 0, selections: float = 0.1, bindings: float = 0.5
) -> tuple[dict[str, Any], int, int]:
    """The decisions file of `config` with about `selections` of its entries left out and
    `bindings` of the selected entries' times and modes `Any`; and how many of each."""
    rng = random.Random(seed)
    kept: list[dict[str, Any]] = []
    left_out = opened = 0
    for entry in config["properties"]:
        if rng.random() < selections:
            left_out += 1
            continue
        entry = json.loads(json.dumps(entry))
        for key in ("time", "mode"):
            if "props" in entry and rng.random() < bindings:
                entry["props"][key] = "Any"
                opened += 1
        kept.append(entry)
    return {"partial": True, "properties": kept}, left_out, opened


def write(n: int, seed: int, out: str, open_: bool = False) -> tuple[str, str]:
    model, config = generate(n, seed)
    if open_:
        config = open_decisions(config, seed)[0]
    os.makedirs(os.path.join(out, "variants"), exist_ok=True)
    model_path = os.path.join(out, "model.json")
    config_path = os.path.join(out, "variants", "full.json")
    # json.dump recurses; deep models need a raised limit here (the loader itself does not)
    import sys

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 4 * depth(model) + 1000))
    with open(model_path, "w", encoding="utf-8") as handle:
        handle.write(json.dumps(model))
    with open(config_path, "w", encoding="utf-8") as handle:
        handle.write(json.dumps(config, indent=0))
    return model_path, config_path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n", type=int)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("-o", "--out", required=True)
    parser.add_argument(
        "--open", action="store_true", help="a decisions file with many open decisions (see open_decisions)"
    )
    args = parser.parse_args()
    model_path, _ = write(args.n, args.seed, args.out, args.open)
    print(f"wrote {model_path} ({os.path.getsize(model_path):,} bytes)")


if __name__ == "__main__":
    main()

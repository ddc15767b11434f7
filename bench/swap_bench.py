"""Benchmark: hot-swapping a Dynamic Python plugin in a running 1 kHz loop of 20 components.

Builds the robot of run_bench.py (20 components), adds two Dynamic Late alternatives
(`left`, `right`, an XOR pair) each implemented by a Python plugin, runs the loop on the
real clock at --rate Hz, and swaps the two --swaps times, one request after the other,
through the binder (the control socket's path minus the socket), one request every
--interval seconds. Prints the request-to-
commit latency p50/p99/max, and the loop's jitter and missed deadlines over the swaps.

    python bench/swap_bench.py [--swaps 1000] [--rate 1000]

Target (issue 5): p99 latency under 5 ms, no tick more than 1 ms late.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run_bench import robot  # noqa: E402

from motivml.launch import launch  # noqa: E402
from motivml.reconfigure import Request  # noqa: E402
from motivml.runtime import RealClock, RunStats  # noqa: E402

PLUGIN = """
from motivml.plugin_api import FeaturePlugin


class Plugin(FeaturePlugin):
    def start(self):
        self.steps = 0

    def step(self, time):
        self.steps += 1
"""


def swappable(folder: Path) -> None:
    """Add the two alternatives, their plugins, and a variant binding them Dynamic Late."""
    model = json.loads((folder / "model.json").read_text())
    any_binding = {"bindingTimeAllowed": "Any", "bindingModeAllowed": "Any"}
    model["sub"].append(
        {
            "id": "side",
            "name": "Side",
            "isMandatory": False,
            "constraints": any_binding,
            "sub": [
                {"id": name, "name": name.title(), "group": "XOR", "constraints": any_binding}
                for name in ("left", "right")
            ],
        }
    )
    (folder / "model.json").write_text(json.dumps(model))
    late = {"time": "Late", "mode": "Dynamic"}
    properties = [{"id": "side", "props": {"time": "Early", "mode": "Dynamic"}}]
    properties += [{"id": name, "props": late} for name in ("left", "right")]
    (folder / "variants" / "swap.json").write_text(json.dumps({"properties": properties}))
    (folder / "robot.json").write_text(json.dumps({"pluginDirectories": ["plugins"]}))
    for name in ("left", "right"):
        plugin = folder / "plugins" / name
        plugin.mkdir(parents=True)
        entry = {"module": f"side_{name}", "class": "Plugin"}
        (plugin / "plugin.json").write_text(json.dumps({"feature": name, "kind": "python", "entry": entry}))
        (plugin / f"side_{name}.py").write_text(PLUGIN)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--swaps", type=int, default=1000)
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--interval", type=float, default=0.01, help="seconds between two requests")
    args = parser.parse_args()
    ms = 1e3
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        robot(folder, 20)
        swappable(folder)
        built = launch(folder, "swap", rate=args.rate)
        runtime, binder = built.runtime, built.binder
        assert len(built.assembly.components) == 20 and set(runtime.plugins) == {"left"}
        result: list[RunStats] = []
        loop = threading.Thread(target=lambda: result.append(runtime.run(3600.0, RealClock())))
        loop.start()
        latencies: list[float] = []
        sides = ("left", "right")
        refused: list[Any] = []
        for k in range(args.swaps):
            time.sleep(args.interval)
            out, into = sides[k % 2], sides[(k + 1) % 2]
            outcome = binder.request(Request("swap", (out, into)))
            if not outcome.accepted:
                refused.append(outcome.reason)
                break
            latencies.append(outcome.latency)
        runtime.stop()
        loop.join()
        built.close()
    stats = result[0]
    lat = np.array(latencies)
    print(
        f"{len(latencies)} swaps of a Dynamic Python plugin, one every {args.interval * 1e3:g} ms, "
        f"20 components at {args.rate:g} Hz (real clock)"
    )
    if refused:
        print(f"  stopped: a swap was refused: {refused[0]}")
    print(
        f"  request to commit  p50 {np.percentile(lat, 50) * ms:.2f} ms, p99 {np.percentile(lat, 99) * ms:.2f} ms, "
        f"max {lat.max() * ms:.2f} ms"
    )
    late = stats.jitter
    print(
        f"  loop over the swaps {stats.ticks} ticks in {stats.elapsed:.2f} s: {stats.achieved:,.1f} Hz achieved"
    )
    print(
        f"  jitter             p50 {np.percentile(late, 50) * ms:.3f} ms, p99 {np.percentile(late, 99) * ms:.3f} ms, "
        f"max {late.max() * ms:.3f} ms; ticks more than 1 ms late: {int((late > 0.001).sum())}"
    )
    print(f"  missed deadlines   {stats.missed} (deadlines at which no tick started: an earlier one overran)")
    print("  C++ plugins        not measured: loading C++ plugins at run time is not available yet")


if __name__ == "__main__":
    main()

"""Benchmark: `motivml fleet list`, `plan` and `apply` over 20 running robots on loopback,
each beside its floor measured in the same run (issue 35).

The robots are simplebot (feature_models/simplebot, variant field, its SLAM features Python
plugins), each a `motivml run --ros2` process with its bridge, in namespaces /bench/r1 ..
/bench/r20 of a ROS graph of the bench's own (--domain, loopback). The change is `swap
hectorslam kartoslam` (and back, alternately), so every robot really reconfigures.

Every command is timed as a user meets it: a new process, from start to exit. The floor is
a bare rclpy client (this script with --floor), also a new process, that does the same
graph work without any check or wait: it finds the 20 `motivml` nodes and reads their
active sets (the floor of `plan`), and also one /diagnostics message of each (the floor of
`list`, which shows their health), and, for `apply`, then makes the same
set_parameters_atomically calls, in the same order, one after the other.

Targets: `fleet list` within 2 s of the floor's discovery (list - floor <= 2 s), with a
fleet file (it knows whom to wait for) and without (it waits until no new robot has
appeared for 1.5 s); `fleet
plan` <= 1.5 x floor + 1 s; `fleet apply --healthy 0` <= 1.5 x floor + 2 s. Each is run
--rounds times, alternating with its floor, and the medians are compared.

    .venv-ros/bin/python bench/fleet_bench.py [--robots 20] [--rounds 5] [--domain 91]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ROBOT = ROOT / "feature_models" / "simplebot"
SWAP = ["swap", "hectorslam", "kartoslam"]
BACK = ["swap", "kartoslam", "hectorslam"]


def floor(count: int, prefix: str, calls: str | None) -> int:
    """The bare client: find `count` motivml nodes under `prefix`, read their active sets,
    then (with `calls`, a JSON {feature: bool}) make that call on each, in namespace order."""
    import threading

    import rclpy
    from rcl_interfaces.srv import SetParametersAtomically
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import String

    rclpy.init()
    node = rclpy.create_node(f"floor_{os.getpid()}")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinning = threading.Thread(target=executor.spin, daemon=True)
    spinning.start()
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    states: dict[str, str] = {}
    followed: set[str] = set()
    reported: set[str] = set()  # (for `list`: the robots a /diagnostics message came from)
    if calls == "list":
        from diagnostic_msgs.msg import DiagnosticArray

        node.create_subscription(
            DiagnosticArray, "/diagnostics",
            lambda m: reported.update(s.hardware_id.removesuffix("/motivml") for s in m.status), 50,
        )
    while len(states) < count or (calls == "list" and not set(states) <= reported):
        for name, namespace in node.get_node_names_and_namespaces():
            if name == "motivml" and namespace.startswith(prefix) and namespace not in followed:
                followed.add(namespace)
                node.create_subscription(
                    String, f"{namespace}/motivml/active_features",
                    lambda m, ns=namespace: states.__setitem__(ns, m.data), latched,
                )
        time.sleep(0.01)
    if calls is not None and calls != "list":
        wanted = json.loads(calls)
        message = [Parameter(f"features.{f}.active", value=v).to_parameter_msg() for f, v in wanted.items()]
        for namespace in sorted(states, key=lambda ns: int(ns.rsplit("r", 1)[1])):
            client = node.create_client(SetParametersAtomically, f"{namespace}/motivml/set_parameters_atomically")
            client.wait_for_service()
            while True:  # (a new client's first request may be lost before discovery matched it)
                done = threading.Event()
                future = client.call_async(SetParametersAtomically.Request(parameters=message))
                future.add_done_callback(lambda _, done=done: done.set())
                if done.wait(1.0):
                    assert future.result().result.successful, future.result().result.reason
                    break
                client.remove_pending_request(future)
    executor.shutdown()
    spinning.join()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def timed(args: list[str], env: dict[str, str]) -> float:
    start = time.perf_counter()
    done = subprocess.run(args, env=env, capture_output=True, text=True, cwd=ROOT, check=False)  # noqa: S603
    took = time.perf_counter() - start
    if done.returncode not in (0,):
        sys.exit(f"{' '.join(args[2:])} failed ({done.returncode}):\n{done.stdout}{done.stderr}")
    return took


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--domain", type=int, default=91)
    parser.add_argument("--floor", nargs=3, metavar=("COUNT", "PREFIX", "CALLS"), help=argparse.SUPPRESS)
    options = parser.parse_args()
    if options.floor:
        count, prefix, calls = options.floor
        return floor(int(count), prefix, None if calls == "-" else calls)

    env = dict(os.environ, ROS_DOMAIN_ID=str(options.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    env.pop("ROS_STATIC_PEERS", None)
    names = [f"/bench/r{k}" for k in range(1, options.robots + 1)]
    scratch = tempfile.TemporaryDirectory(prefix="motivml-fleet-bench-")
    work = Path(scratch.name)
    fleet = work / "bench.fleet.json"
    robots = [{"namespace": ns, "robot": str(ROBOT), "variant": "field"} for ns in names]
    fleet.write_text(json.dumps({"name": "bench", "robots": robots}))
    motivml = [sys.executable, "-m", "motivml.cli"]
    runs = [
        subprocess.Popen(  # noqa: S603 (our own interpreter)
            [*motivml, "run", str(ROBOT), "--variant", "field", "--duration", "inf", "--rate", "50",
             "--no-live", "--no-control", "--ros2", "--ros-namespace", ns],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT,
        )
        for ns in names
    ]
    me = [sys.executable, str(Path(__file__).resolve())]
    try:
        # every robot up: the floor's own discovery, untimed
        timed([*me, "--floor", str(len(names)), "/bench/", "-"], env)
        lists, prefixed, plans, applies = [], [], [], []
        floors_read, floors_list, floors_apply = [], [], []
        change = SWAP
        for round_ in range(options.rounds):
            floors_read.append(timed([*me, "--floor", str(len(names)), "/bench/", "-"], env))
            floors_list.append(timed([*me, "--floor", str(len(names)), "/bench/", "list"], env))
            lists.append(timed([*motivml, "fleet", "list", "--fleet", str(fleet), "--format", "json"], env))
            prefixed.append(timed([*motivml, "fleet", "list", "--prefix", "/bench", "--format", "json"], env))
            plans.append(timed([*motivml, "fleet", "plan", str(fleet), *change], env))
            applies.append(timed([*motivml, "fleet", "apply", str(fleet), *change, "--healthy", "0", "--canary", "1",
                                  "--waves", "2", "--record", str(work / f"r{round_}.jsonl")], env))
            change = BACK if change is SWAP else SWAP
            calls = {change[1]: False, change[2]: True}
            floors_apply.append(timed([*me, "--floor", str(len(names)), "/bench/", json.dumps(calls)], env))
            change = BACK if change is SWAP else SWAP
        m = statistics.median
        floor_read, floor_list, floor_apply = m(floors_read), m(floors_list), m(floors_apply)
        rows = [
            ("fleet list --fleet (20 robots)", m(lists), floor_list, f"<= floor + 2 s = {floor_list + 2:.2f} s", m(lists) <= floor_list + 2),
            ("fleet list --prefix (no fleet file)", m(prefixed), floor_list, f"<= floor + 2 s = {floor_list + 2:.2f} s",
             m(prefixed) <= floor_list + 2),
            ("fleet plan swap", m(plans), floor_read, f"<= 1.5 x floor + 1 s = {1.5 * floor_read + 1:.2f} s",
             m(plans) <= 1.5 * floor_read + 1),
            ("fleet apply swap --healthy 0", m(applies), floor_apply, f"<= 1.5 x floor + 2 s = {1.5 * floor_apply + 2:.2f} s",
             m(applies) <= 1.5 * floor_apply + 2),
        ]
        print(f"{len(names)} robots (simplebot, run --ros2 at 50 Hz) on loopback, {options.rounds} rounds, medians; "
              "every figure a new process, start to exit")
        print(f"{'command':34} {'motivml':>9} {'floor':>9}  target")
        for name, ours, base, target, met in rows:
            print(f"{name:34} {ours:8.2f}s {base:8.2f}s  {target}: {'met' if met else 'MISSED'}")
        print("rounds: list " + " ".join(f"{t:.2f}" for t in lists) + " | floor " + " ".join(f"{t:.2f}" for t in floors_list))
        print("rounds: plan's floor " + " ".join(f"{t:.2f}" for t in floors_read))
        print("rounds: list --prefix " + " ".join(f"{t:.2f}" for t in prefixed))
        print("rounds: plan " + " ".join(f"{t:.2f}" for t in plans))
        print("rounds: apply " + " ".join(f"{t:.2f}" for t in applies) + " | floor " + " ".join(f"{t:.2f}" for t in floors_apply))
    finally:
        for run in runs:
            run.terminate()
        for run in runs:
            try:
                run.wait(timeout=20)
            except subprocess.TimeoutExpired:
                run.kill()
                run.wait()  # (reaped: no zombie left behind)
        scratch.cleanup()
    return 0


if __name__ == "__main__":
    sys.exit(main())

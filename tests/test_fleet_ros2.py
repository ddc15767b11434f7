"""`motivml fleet list`, `plan` and `apply` on a real ROS 2 graph (loopback, a domain of the
module's own): UV robots, each a `motivml run --ros2` process with its bridge and its
lifecycle nodes in processes of their own (issue 35).

Fleet A is six robots under /fa: five on the variant ros2_ward, /fa/uv6 on
ros2_ward_dosimetry (its irradiation is Static: it refuses to unload it). Robot /fa/uv3's
lamp node runs in a process of its own, to be killed in a rollout's second wave. Fleet B is
one robot under /fb, on the same graph. The tests run in this file's order (the last one
kills the lamp); every wait is on a condition with a deadline.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from helpers import until
from ros2_support import ROOT, ROS2, Client, domain, environment, processes, python_process

pytestmark = ROS2

NODES = ROOT / "plugins" / "ros2" / "uv_nodes.py"
UV = ROOT / "feature_models" / "uv_disinfection"
WARD_NODES = ["irradiation", "low_intensity", "high_intensity", "person_detection", "thermal_detection"]
A = [f"/fa/uv{k}" for k in range(1, 7)]
B = ["/fb/uv1"]
VARIANTS = {**dict.fromkeys(A[:5] + B, "ros2_ward"), A[5]: "ros2_ward_dosimetry"}
SWAP = ["swap", "camera_person_detection", "thermal_presence_detection"]
BACK = ["swap", "thermal_presence_detection", "camera_person_detection"]


@dataclass
class Fleets:
    domain_id: int
    fleet_a: Path
    fleet_b: Path
    lamp: subprocess.Popen[str]  # /fa/uv3's lamp node
    client: Client
    runs: dict[str, subprocess.Popen[str]]


def fleet_file(folder: Path, name: str, robots: list[str]) -> Path:
    path = folder / f"{name}.fleet.json"
    entries = [{"namespace": ns, "robot": str(UV), "variant": VARIANTS[ns]} for ns in robots]
    path.write_text(json.dumps({"name": name, "robots": entries}, indent=1))
    return path


@pytest.fixture(scope="module")
def fleets(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Fleets]:
    domain_id = domain()
    folder = tmp_path_factory.mktemp("fleets")
    lamp: subprocess.Popen[str] | None = None
    with processes() as started:
        for ns in A + B:
            nodes = WARD_NODES + (["dosimeter"] if VARIANTS[ns] == "ros2_ward_dosimetry" else [])
            together = nodes if ns == A[2] else [*nodes, "lamp"]
            started.append(python_process([str(NODES), *together, "--ros-args", "-r", f"__ns:={ns}"], domain_id))
            if ns == A[2]:
                lamp = python_process([str(NODES), "lamp", "--ros-args", "-r", f"__ns:={ns}"], domain_id)
                started.append(lamp)
        client = Client(domain_id)
        try:
            for ns in A + B:  # every node up before its robot starts
                until(lambda ns=ns: client.state(f"{ns.lstrip('/')}/lamp"), timeout=60, what=f"{ns}'s nodes")
            runs = {}
            for ns in A + B:
                runs[ns] = python_process(
                    ["-m", "motivml.cli", "run", str(UV), "--variant", VARIANTS[ns], "--duration", "inf", "--rate", "100"]
                    + ["--no-live", "--no-control", "--ros2", "--ros-namespace", ns],
                    domain_id,
                )
                started.append(runs[ns])
            assert lamp is not None
            ready(runs)
            yield Fleets(domain_id, fleet_file(folder, "a", A), fleet_file(folder, "b", B), lamp, client, runs)
        finally:
            client.close()


def ready(runs: dict[str, subprocess.Popen[str]]) -> None:
    """Every robot's node on the graph with its active set, or the output of a run that ended."""
    from motivml.ros2.fleet import Watch

    watch = Watch("/")
    try:
        def up() -> bool:
            ended = {ns: run for ns, run in runs.items() if run.poll() is not None}
            if ended:
                ns, run = next(iter(ended.items()))
                output = run.stdout.read() if run.stdout is not None else ""
                pytest.fail(f"the run of {ns} ended ({run.returncode}) before the tests:\n{output}")
            return set(watch.discover(0.5, expected=list(runs))) >= set(runs)

        until(up, timeout=120, what="every robot on the graph")
    finally:
        watch.close()


def fleet(fleets: Fleets, *args: str) -> Any:
    """`motivml fleet ARGS` in this process (on the module's graph: its ROS_DOMAIN_ID is set)."""
    from motivml.cli import main

    return CliRunner().invoke(main, ["fleet", *args])


def listed(fleets: Fleets, *args: str) -> list[dict[str, Any]]:
    result = fleet(fleets, "list", "--format", "json", "--wait", "60", *args)
    assert result.exit_code == 0, result.output
    return list(json.loads(result.output))


def active(fleets: Fleets) -> dict[str, list[str]]:
    """Fleet A's active sets (the fleet file names the robots: each is waited for)."""
    return {row["namespace"]: row["active"] for row in listed(fleets, "--fleet", str(fleets.fleet_a))}


# ---------------------------------------------------------------------- tests
def test_the_watch_keeps_what_nodes_say_and_ignores_what_is_not_theirs() -> None:
    """motivml.ros2.fleet.Watch on a graph of its own with no robot: what it does with
    messages that are not a robot's, a call to a robot that is not there, waits that end."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

    from motivml.ros2.fleet import Watch, natural

    domain()
    watch = Watch("/x")
    try:
        assert watch.discover(0.1) == [] and watch.namespaces() == [] and not watch.alive("/x/uv1")
        watch.follow(["/x/uv1"])
        for data in ("not json", "[1, 2]"):
            watch._state("/x/uv1", data)  # (another publisher on the topic: ignored)
        assert watch.heard() == []
        watch._state("/x/uv1", json.dumps({"robot": "r", "variant": "v", "active": ["a"], "tick": 3}))
        assert watch.heard() == ["/x/uv1"]
        watch.wait_reports(["/x/uv1"], 0.05)  # (none comes: the wait ends)
        statuses = [
            DiagnosticStatus(level=b"\x01", name="motivml: r loop", message="slow", hardware_id="/x/uv1/motivml",
                             values=[KeyValue(key="ticks", value="10")]),
            DiagnosticStatus(level=b"\x00", name="other", message="ok", hardware_id="/x/uv1/camera"),
            DiagnosticStatus(level=b"\x00", name="motivml: q loop", message="ok", hardware_id="/y/motivml"),
        ]
        watch._diagnostics(DiagnosticArray(status=statuses))
        seen = watch.snapshot("/x/uv1")
        assert seen is not None and seen.reports == 1 and seen.state == {"robot": "r", "variant": "v", "active": ["a"], "tick": 3}
        assert [(s["name"], s["level"], s["values"]) for s in seen.statuses] == [("motivml: r loop", "WARN", {"ticks": "10"})]
        assert watch.snapshot("/y") is None  # (not followed)
        accepted, reason = watch.set("/x/uv1", {"a": False}, 0.2)
        assert accepted is False and reason == "/x/uv1/motivml/set_parameters_atomically is not on the graph"
        assert sorted(["/a/uv10", "/a/uv9", "/a/uv1"], key=natural) == ["/a/uv1", "/a/uv9", "/a/uv10"]
    finally:
        watch.close()


def test_list_shows_each_fleet_under_its_prefix_and_no_other(fleets: Fleets) -> None:
    rows = listed(fleets, "--fleet", str(fleets.fleet_a))
    assert [r["namespace"] for r in rows] == A
    assert {r["namespace"]: r["variant"] for r in rows} == {ns: VARIANTS[ns] for ns in A}
    assert all(r["robot"] == "uv_disinfection" and r["health"] in ("OK", "WARN") for r in rows)
    assert all("camera_person_detection" in r["active"] and r["rate"] == 100.0 for r in rows)
    # without a fleet file: every robot under the prefix, as discovery finds them
    found: set[str] = set()
    until(lambda: found.update(r["namespace"] for r in listed(fleets, "--prefix", "/fa")) or found == set(A),
          timeout=60, what="fleet A under /fa")
    assert [r["namespace"] for r in listed(fleets, "--prefix", "/fb")] == B
    table = fleet(fleets, "list", "--fleet", str(fleets.fleet_b))
    assert table.exit_code == 0, table.output
    lines = table.output.splitlines()
    assert lines[0].split() == ["namespace", "robot", "variant", "active", "rate", "missed", "faults", "health"]
    assert len(lines) == 2 and lines[1].split()[:4] == ["/fb/uv1", "uv_disinfection", "ros2_ward", "19"]


def test_a_plan_on_the_running_robots_with_one_refusing(fleets: Fleets) -> None:
    result = fleet(fleets, "plan", str(fleets.fleet_a), "unload", "irradiation")
    assert result.exit_code == 1, result.output
    text = " ".join(result.output.split())
    for ns in A[:5]:
        assert f"{ns}: accepted: unloads low_intensity, uv_lamp_control, irradiation" in text
    assert "robot /fa/uv6: irradiation is bound Static Late" in text and "/fa/uv6: refused" in text
    assert "accepted by 5 of 6 robots, refused by 1 (checked against the active set each running robot reports)" in text
    # and nothing moved
    assert all("irradiation" in features for features in active(fleets).values())


def test_an_apply_that_one_robot_would_refuse_touches_no_robot(fleets: Fleets) -> None:
    before = active(fleets)
    result = fleet(fleets, "apply", str(fleets.fleet_a), "unload", "irradiation", "--healthy", "0")
    assert result.exit_code == 1, result.output
    assert "/fa/uv6: planned: refused: robot /fa/uv6: irradiation is bound Static Late" in " ".join(result.output.split())
    assert "refused: 1 of 6 robots refuse it in the plan: nothing changed" in result.output
    assert active(fleets) == before


def test_an_apply_in_waves_changes_every_robot_and_its_nodes(fleets: Fleets, tmp_path: Path) -> None:
    from rcl_interfaces.msg import Log

    logs = fleets.client.subscribe(Log, "/rosout")
    record = tmp_path / "r.jsonl"
    result = fleet(fleets, "apply", str(fleets.fleet_a), *SWAP, "--canary", "1", "--waves", "2",
                   "--healthy", "1", "--record", str(record))
    assert result.exit_code == 0, result.output
    # each step in words on rosout too, from the command's own node (the first ones may go
    # out before this client has matched the new node's rosout publisher)
    said = f"rollout of {' '.join(SWAP)}: wave 3: every robot changed so far healthy for 1 s"
    until(lambda: any(m.msg == said and m.name.startswith("motivml_fleet_") for m in logs), what="rosout")
    steps = [json.loads(line) for line in record.read_text().splitlines()]
    assert steps[0]["waves"] == [A[:1], A[1:4], A[4:]]
    assert [s["robot"] for s in steps if s["step"] == "changed"] == A
    assert [s["wave"] for s in steps if s["step"] == "healthy"] == [1, 2, 3]
    for ns in A:
        assert fleets.client.state(f"{ns.lstrip('/')}/thermal_detection") == "active"
        until(lambda ns=ns: fleets.client.state(f"{ns.lstrip('/')}/person_detection") == "unconfigured", what="clean-up")
    assert fleets.client.state("fb/uv1/person_detection") == "active"  # (fleet B untouched)
    back = fleet(fleets, "apply", str(fleets.fleet_a), *BACK, "--canary", "0", "--healthy", "0",
                 "--record", str(tmp_path / "back.jsonl"))
    assert back.exit_code == 0, back.output
    assert all("camera_person_detection" in features for features in active(fleets).values())
    # fleet list reads the record: each robot's latest step
    listing = fleet(fleets, "list", "--fleet", str(fleets.fleet_a), "--record", str(record), "--format", "json")
    assert {r["namespace"]: r["rollout"]["step"] for r in json.loads(listing.output)} == dict.fromkeys(A, "changed")


def test_a_robot_killed_in_the_second_wave_rolls_every_changed_robot_back(fleets: Fleets, tmp_path: Path) -> None:
    """/fa/uv3's lamp node is killed just after /fa/uv3 is changed, in the second wave
    (/fa/uv2 to /fa/uv4): the robot unloads irradiation after the fault, the rollout sees
    the new fault when the wave's health is watched, and changes back /fa/uv4 to /fa/uv1,
    last first; /fa/uv5 and /fa/uv6 were never touched."""
    before = active(fleets)
    states = {ns: fleets.client.state(f"{ns.lstrip('/')}/person_detection") for ns in A}
    record = tmp_path / "killed.jsonl"
    apply = subprocess.Popen(  # noqa: S603 (our own interpreter)
        [sys.executable, "-m", "motivml.cli", "fleet", "apply", str(fleets.fleet_a), *SWAP, "--canary", "1",
         "--waves", "2", "--healthy", "6", "--record", str(record)],
        env=environment(fleets.domain_id), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT,
    )
    try:
        until(lambda: record.exists() and '"changed", "robot": "/fa/uv3"' in record.read_text(), timeout=90,
              what="/fa/uv3 changed")
        fleets.lamp.kill()
        output, _ = apply.communicate(timeout=120)
    finally:
        if apply.poll() is None:
            apply.kill()
    assert apply.returncode == 1, output
    assert "/fa/uv3: unhealthy: 1 new fault(s) since the change" in output
    kinds = [(s["step"], s.get("robot")) for s in map(json.loads, record.read_text().splitlines())]
    assert [r for k, r in kinds if k == "rolled back"] == ["/fa/uv4", "/fa/uv3", "/fa/uv2", "/fa/uv1"]
    assert [r for k, r in kinds if k == "changed"] == A[:4]
    after = active(fleets)
    lost = {"irradiation", "uv_lamp_control", "low_intensity"}  # (what the fault unloaded)
    assert {ns: after[ns] for ns in A if ns != "/fa/uv3"} == {ns: before[ns] for ns in A if ns != "/fa/uv3"}
    assert after["/fa/uv3"] == [f for f in before["/fa/uv3"] if f not in lost]
    assert {ns: fleets.client.state(f"{ns.lstrip('/')}/person_detection") for ns in A} == states
    for ns in A:  # (a clean-up is not waited for: the rollback may return before it is done)
        until(lambda ns=ns: fleets.client.state(f"{ns.lstrip('/')}/thermal_detection") == "unconfigured", what="clean-up")

"""The UV robot's ROS 2 example on a real graph: its lifecycle nodes, and configure's ros2_params.yaml.

Each test starts the nodes it needs as processes (`plugins/ros2/uv_nodes.py NAME`, in the
namespace /uv) on a ROS domain of its own, and talks to them from an rclpy node of its own
context, through the standard services (`lifecycle_msgs` ChangeState and GetState,
`rcl_interfaces` GetParameters). Nothing sleeps: every wait is for a condition, with a
deadline, spinning the test's executor in short steps meanwhile.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from ros2_support import ROOT, ROS2, domain, processes, python_process

from motivml.cli import main

pytestmark = ROS2

NAMESPACE = "/uv"
DEADLINE = 15.0  # s: discovery, a process starting, a service answering
PERIOD = 0.05  # s: how often the nodes publish in these tests
QUIET = 6 * PERIOD  # s watched for a message that must not come
SCRIPT = "plugins/ros2/uv_nodes.py"

# node -> (topic under the node, message type's module and name)
TOPICS = {
    "lamp": ("irradiance", "Float64"),
    "dosimeter": ("dose", "Float64"),
    "person_detection": ("people", "String"),
    "thermal_detection": ("people", "String"),
    "irradiation": ("lamps_allowed", "Bool"),
    "low_intensity": ("power", "Float64"),
    "high_intensity": ("power", "Float64"),
}
UNCONFIGURED, INACTIVE, ACTIVE = 1, 2, 3  # lifecycle_msgs/msg/State primary states
CONFIGURE, CLEANUP, ACTIVATE, DEACTIVATE = 1, 2, 3, 4  # lifecycle_msgs/msg/Transition ids
GOALS = {CONFIGURE: INACTIVE, CLEANUP: UNCONFIGURED, ACTIVATE: ACTIVE, DEACTIVATE: INACTIVE}
RESEND = 1.0  # s: a request unanswered this long is sent again (see Graph.call)


class Graph:
    """The test's side of the graph: an rclpy context, node and executor of its own."""

    def __init__(self, domain_id: int) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = rclpy.create_node("motivml_test", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.clients: dict[str, Any] = {}

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()

    def wait_until(self, condition: Callable[[], bool], what: str, timeout: float = DEADLINE) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                raise AssertionError(f"waited {timeout} s for {what}")
            self.executor.spin_once(timeout_sec=0.02)

    def watch(self, seconds: float) -> None:
        """Spin for `seconds`: a window in which something must *not* happen."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.02)

    def call(self, service_type: Any, name: str, request: Any, resend: bool = True) -> Any:
        """The answer to one request; without `resend`, None if none came within RESEND s.

        A client is made once per service. A new client's first request can be lost: the
        server may list the service before it has matched the client's reader (DDS discovery),
        and its answer then goes nowhere. With `resend` (for requests that may be repeated, as
        a question is) the request is sent again each second until the deadline."""
        client = self.clients.get(name)
        if client is None:
            client = self.clients[name] = self.node.create_client(service_type, name)
            assert client.wait_for_service(timeout_sec=DEADLINE), f"no service {name}"
        deadline = time.monotonic() + DEADLINE
        while True:
            future = client.call_async(request)
            self.executor.spin_until_future_complete(future, timeout_sec=RESEND)
            if future.done():
                return future.result()
            client.remove_pending_request(future)
            if not resend:
                return None
            assert time.monotonic() < deadline, f"{name} did not answer within {DEADLINE} s"

    def state(self, node: str) -> int:
        from lifecycle_msgs.srv import GetState

        return int(self.call(GetState, f"{node}/get_state", GetState.Request()).current_state.id)

    def change(self, node: str, transition: int) -> bool:
        """Ask for a transition; whether it succeeded. A transition is not sent twice blindly:
        when no answer comes, the node's state says whether the request arrived."""
        from lifecycle_msgs.srv import ChangeState

        request = ChangeState.Request()
        request.transition.id = transition
        deadline = time.monotonic() + DEADLINE
        while True:
            answer = self.call(ChangeState, f"{node}/change_state", request, resend=False)
            if answer is not None:
                return bool(answer.success)
            if self.state(node) == GOALS[transition]:
                return True  # it arrived and succeeded; only the answer was lost
            assert time.monotonic() < deadline, f"{node}/change_state did not answer within {DEADLINE} s"

    def parameters(self, node: str, names: list[str]) -> dict[str, Any]:
        from rcl_interfaces.srv import GetParameters
        from rclpy.parameter import parameter_value_to_python

        answer = self.call(GetParameters, f"{node}/get_parameters", GetParameters.Request(names=names))
        return {n: parameter_value_to_python(v) for n, v in zip(names, answer.values, strict=True)}

    def heard(self, node: str) -> list[Any]:
        """What the node publishes on its topic from now on (sensor-data QoS, as it publishes)."""
        import std_msgs.msg
        from rclpy.qos import qos_profile_sensor_data

        topic, kind = TOPICS[node]
        messages: list[Any] = []
        self.node.create_subscription(
            getattr(std_msgs.msg, kind),
            f"{NAMESPACE}/{node}/{topic}",
            messages.append,
            qos_profile_sensor_data,
        )
        return messages


@contextmanager
def graph(domain_id: int) -> Iterator[Graph]:
    made = Graph(domain_id)
    try:
        yield made
    finally:
        made.close()


def start(started: list[Any], domain_id: int, node: str, *ros_args: str) -> str:
    """Start the node NODE in /uv; its fully qualified name."""
    args = [SCRIPT, node, "--ros-args", "-r", f"__ns:={NAMESPACE}", "-p", f"period:={PERIOD}", *ros_args]
    started.append(python_process(args, domain_id))
    return f"{NAMESPACE}/{node}"


def configured(variant: str, folder: Path) -> tuple[Path, dict[str, str]]:
    """configure's ros2_params.yaml for the UV robot's variant, and the binding of each
    selected feature in words, from the lock file written beside it."""
    robot = ROOT / "feature_models" / "uv_disinfection"
    result = CliRunner().invoke(main, ["configure", str(robot), "--variant", variant, "-o", str(folder)])
    assert result.exit_code == 0 and "warning" not in result.output, result.output
    lock = json.loads((folder / "variant.lock.json").read_text())
    bindings = {
        p["id"]: f"{p['props']['mode']} {p['props']['time']}" for p in lock["properties"] if p["selected"]
    }
    return folder / "ros2_params.yaml", bindings


def manifest_parameters() -> dict[str, tuple[str, dict[str, Any]]]:
    """node -> (feature, parameters), from plugins/ros2/*/plugin.json."""
    found = {}
    for path in sorted((ROOT / "plugins" / "ros2").glob("*/plugin.json")):
        manifest = json.loads(path.read_text())
        found[manifest["entry"]["node"]] = (manifest["feature"], manifest["entry"].get("parameters", {}))
    return found


# variant -> the features active at start among those not compiled in (dose_monitoring,
# Static Late in ros2_ward_dosimetry, is loaded on request, and then for good)
STARTS = {
    "ros2_ward": {"camera_person_detection", "irradiation", "uv_lamp_control", "low_intensity"},
    "ros2_ward_dosimetry": {"camera_person_detection", "irradiation", "uv_lamp_control", "low_intensity"},
}


@pytest.mark.parametrize("variant", sorted(STARTS))
def test_configures_parameters_file_loads_into_every_node_of_the_variant(
    variant: str, tmp_path: Path
) -> None:
    """ros2_params.yaml loads with --params-file into the real nodes: each gets its manifest's
    parameters, with the manifest's types (a double stays a double, a string array one), and
    what it implements; the motivml section gives a node called motivml the start state."""
    params, bindings = configured(variant, tmp_path)
    manifests = {node: m for node, m in manifest_parameters().items() if m[0] in bindings}
    domain_id = domain()
    with processes() as started, graph(domain_id) as ros:
        nodes = {
            name: start(started, domain_id, name, "--params-file", str(params)) for name in sorted(manifests)
        }
        for name, node in nodes.items():
            feature, given = manifests[name]
            expected = {**given, "motivml.feature": feature, "motivml.binding": bindings[feature]}
            got = ros.parameters(node, list(expected))
            assert got == expected, name
            assert {k: type(v) for k, v in got.items()} == {k: type(v) for k, v in expected.items()}, name
        assert ros.parameters(nodes["lamp"], ["power"]) == {"power": 0.8}  # not the node's default, 1.0

        import rclpy

        motivml = rclpy.create_node(
            "motivml",
            namespace=NAMESPACE,
            context=ros.context,
            cli_args=["--ros-args", "--params-file", str(params)],
            automatically_declare_parameters_from_overrides=True,
        )
        try:
            active = {
                name.removesuffix(".active"): p.value
                for name, p in motivml.get_parameters_by_prefix("features").items()
            }
        finally:
            motivml.destroy_node()
    assert set(active) == set(bindings)  # every selected feature, and only those
    changeable = {f for f, words in bindings.items() if words != "Static Early"}
    assert {f for f in changeable if active[f]} == STARTS[variant]
    assert all(active[f] for f in set(bindings) - changeable)


@pytest.mark.parametrize("name", sorted(TOPICS))
def test_a_node_goes_through_its_lifecycle_and_publishes_only_while_active(name: str) -> None:
    domain_id = domain()
    with processes() as started, graph(domain_id) as ros:
        node = start(started, domain_id, name)
        heard = ros.heard(name)
        assert ros.state(node) == UNCONFIGURED
        assert ros.change(node, CONFIGURE) and ros.state(node) == INACTIVE
        ros.watch(QUIET)
        assert heard == [], "published while inactive"
        assert ros.change(node, ACTIVATE) and ros.state(node) == ACTIVE
        ros.wait_until(lambda: len(heard) >= 2, f"two messages from {node} while active")
        assert ros.change(node, DEACTIVATE) and ros.state(node) == INACTIVE
        ros.state(node)  # one more round trip for what was sent before the deactivation
        heard.clear()
        ros.watch(QUIET)
        assert heard == [], "published after deactivation"
        assert ros.change(node, CLEANUP) and ros.state(node) == UNCONFIGURED
        assert ros.change(node, CONFIGURE) and ros.change(node, ACTIVATE)  # and again
        ros.wait_until(lambda: len(heard) >= 1, f"a message from {node} when active again")
    assert all(p.returncode == 0 for p in started), [p.stdout.read() for p in started if p.stdout]


def test_fail_on_activate_makes_the_activation_fail_and_the_node_stays_inactive() -> None:
    domain_id = domain()
    with processes() as started, graph(domain_id) as ros:
        node = start(started, domain_id, "lamp", "-p", "fail_on:=activate")
        heard = ros.heard("lamp")
        assert ros.change(node, CONFIGURE) and ros.state(node) == INACTIVE
        assert ros.change(node, ACTIVATE) is False
        assert ros.state(node) == INACTIVE
        ros.watch(QUIET)
        assert heard == []
        assert ros.change(node, CLEANUP) and ros.state(node) == UNCONFIGURED
    (lamp,) = started
    assert lamp.returncode == 0
    assert lamp.stdout is not None and "activate fails: fail_on is 'activate'" in lamp.stdout.read()


def test_a_node_ends_quietly_on_sigint_and_sigterm() -> None:
    """Ctrl-C and a TERM end a node with exit code 0 and no traceback, active or not."""
    import signal

    domain_id = domain()
    with processes() as started, graph(domain_id) as ros:
        first = start(started, domain_id, "dosimeter")
        start(started, domain_id, "person_detection")
        assert ros.change(first, CONFIGURE) and ros.change(first, ACTIVATE)
        ros.state(f"{NAMESPACE}/person_detection")
        started[0].send_signal(signal.SIGINT)
        started[1].send_signal(signal.SIGTERM)
        outputs = [p.communicate(timeout=DEADLINE)[0] for p in started]
    assert [p.returncode for p in started] == [0, 0]
    assert not any("Traceback" in text for text in outputs), outputs


def test_an_unknown_node_or_transition_is_a_usage_error() -> None:
    domain_id = domain()
    with processes() as started:
        started.append(python_process([SCRIPT, "wiper"], domain_id))
        started.append(python_process([SCRIPT, "lamp", "--ros-args", "-p", "fail_on:=activation"], domain_id))
        outputs = [p.communicate(timeout=DEADLINE)[0] for p in started]
    assert [p.returncode for p in started] == [2, 2]
    assert "NODE: one of lamp, dosimeter" in outputs[0]
    assert "fail_on names a transition: one of configure, activate, deactivate, cleanup" in outputs[1]

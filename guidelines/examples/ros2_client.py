"""Change a running robot's features over ROS 2, or print its active set: a client to copy.

    python ros2_client.py [--namespace /uv] camera_person_detection=false thermal_presence_detection=true
    python ros2_client.py [--namespace /uv]
    python ros2_client.py [--namespace /uv] --parameters

With assignments, it sets `features.<id>.active` of the robot's `motivml` node (started by
`motivml run ROBOT --variant V --ros2 --ros-namespace NS`) in ONE call of the standard
`set_parameters_atomically` service: the robot checks the whole change against its model
and commits all of it between two ticks, or none of it. It prints `accepted` (exit 0) or
`refused: <the robot's reason>` (exit 1). Without assignments, it prints the active set,
which the robot keeps on `NS/motivml/active_features` (transient-local, so a late
subscriber like this one gets the current set at once). With `--parameters`, it prints the
node's `features.<id>.active` parameters instead, as `ros2 param dump` would read them.

Exit codes: 0 accepted or printed, 1 refused, 2 usage, 3 no motivml node answered within
`--timeout` seconds, 130 Ctrl-C. It uses only rclpy and standard interfaces; the ROS domain
and discovery range come from ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE, as for any node.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
NAMESPACE = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*)?$")  # without its slashes
VALUES = {"true": True, "false": False}


class Usage(Exception):
    """A mistake on the command line (exit 2)."""


class NotThere(Exception):
    """No motivml node answered in time (exit 3): what was asked, and how long we waited."""

    def __init__(self, what: str, seconds: float) -> None:
        super().__init__(what)
        self.what, self.seconds = what, seconds


def parse(argv: list[str]) -> tuple[str, dict[str, bool], float, bool]:
    """The node's namespace, the features to set, the timeout, and whether to print parameters."""
    parser = argparse.ArgumentParser(
        prog="ros2_client.py",
        description="Set features of a robot run with `motivml run --ros2` in one atomic call, "
        "or print its active set.",
    )
    parser.add_argument("--namespace", default="/", help="the run's --ros-namespace (default /)")
    parser.add_argument(
        "--timeout", type=float, default=10.0, help="seconds to wait for the node (default 10)"
    )
    parser.add_argument("--parameters", action="store_true", help="print the features.<id>.active parameters")
    parser.add_argument("assignments", nargs="*", metavar="FEATURE=true|false")
    args = parser.parse_args(argv)  # exits 2 with argparse's message on its own mistakes
    if not NAMESPACE.match(args.namespace.strip("/")):
        raise Usage(
            f"{args.namespace!r} is not a ROS namespace: names of letters, digits and _ joined by / (like /uv)"
        )
    if args.timeout <= 0:
        raise Usage("--timeout is a number of seconds above 0")
    if args.parameters and args.assignments:
        raise Usage("--parameters prints; it takes no FEATURE=VALUE")
    wanted: dict[str, bool] = {}
    for text in args.assignments:
        feature, _, value = text.partition("=")
        if not NAME.match(feature) or value.lower() not in VALUES:
            raise Usage(f"{text!r}: write FEATURE=true or FEATURE=false (a feature id, as in the model)")
        if feature in wanted:
            raise Usage(f"{feature} is given twice")
        wanted[feature] = VALUES[value.lower()]
    return "/" + args.namespace.strip("/"), wanted, args.timeout, args.parameters


class Client:
    """One rclpy context and node of its own, spun in short steps on this thread."""

    def __init__(self, namespace: str) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        self.robot = namespace.rstrip("/") + "/motivml"  # the motivml node's full name
        # rclpy's own signal handlers stay out: Ctrl-C only sets `interrupted`, checked
        # between two spins, so it never lands inside an rclpy call.
        self.interrupted = threading.Event()
        signal.signal(signal.SIGINT, lambda *_: self.interrupted.set())
        self.context = rclpy.Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node(
            f"motivml_client_{os.getpid()}", context=self.context, start_parameter_services=False
        )
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.sent = False  # a request is on its way: Ctrl-C cannot take it back

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()

    def wait(self, done: Callable[[], bool], timeout: float) -> bool:
        """Spin until `done()` or the timeout; KeyboardInterrupt on Ctrl-C."""
        deadline = time.monotonic() + timeout
        while not done():
            if self.interrupted.is_set():
                raise KeyboardInterrupt
            if time.monotonic() > deadline:
                return False
            self.executor.spin_once(timeout_sec=0.05)
        return True

    def call(self, kind: Any, service: str, request: Any, timeout: float, answer: float | None = None) -> Any:
        """One call of a service of the motivml node: wait for the service at most `timeout`
        seconds, and for its answer at most `answer` seconds (default: `timeout`)."""
        name = f"{self.robot}/{service}"
        client: Any = self.node.create_client(kind, name)
        if not self.wait(client.service_is_ready, timeout):
            raise NotThere(name, timeout)
        future = client.call_async(request)
        self.sent = True
        if not self.wait(future.done, answer or timeout):
            raise NotThere(name, answer or timeout)
        return future.result()

    def set_features(self, wanted: dict[str, bool], timeout: float) -> Any:
        """One set_parameters_atomically call: its SetParametersResult."""
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
        from rcl_interfaces.srv import SetParametersAtomically

        request = SetParametersAtomically.Request(
            parameters=[
                Parameter(
                    name=f"features.{feature}.active",
                    value=ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value),
                )
                for feature, value in wanted.items()
            ]
        )
        # The robot answers once the change is committed or refused; lifecycle nodes that
        # configure and activate on the way take their time, so allow more than discovery.
        return self.call(
            SetParametersAtomically, "set_parameters_atomically", request, timeout, timeout + 30
        ).result

    def feature_parameters(self, timeout: float) -> dict[str, bool]:
        """features.<id>.active of the motivml node, with the standard list and get services."""
        from rcl_interfaces.srv import GetParameters, ListParameters

        listed = self.call(
            ListParameters, "list_parameters", ListParameters.Request(prefixes=["features"]), timeout
        )
        names = list(listed.result.names)
        got = self.call(GetParameters, "get_parameters", GetParameters.Request(names=names), timeout)
        return {name: value.bool_value for name, value in zip(names, got.values, strict=True)}

    def active_features(self, timeout: float) -> dict[str, Any]:
        """The robot's latest message on ~/active_features, as JSON."""
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import String

        topic = f"{self.robot}/active_features"
        latched = QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
        )
        heard: list[str] = []
        self.node.create_subscription(String, topic, lambda message: heard.append(message.data), latched)
        if not self.wait(lambda: bool(heard), timeout):
            raise NotThere(topic, timeout)
        return dict(json.loads(heard[-1]))


def main(argv: list[str]) -> int:
    try:
        namespace, wanted, timeout, parameters = parse(argv)
    except Usage as problem:
        print(f"ros2_client.py: error: {problem}", file=sys.stderr)
        return 2
    try:
        import rclpy  # noqa: F401 (only to say clearly that it is missing)
    except ImportError:
        print("ros2_client.py: rclpy is not installed here: use ROS 2's Python (.venv-ros)", file=sys.stderr)
        return 3
    client = Client(namespace)
    try:
        if wanted:
            result = client.set_features(wanted, timeout)
            print("accepted" if result.successful else f"refused: {result.reason}")
            return 0 if result.successful else 1
        if parameters:
            for name, value in client.feature_parameters(timeout).items():
                print(f"{name}: {str(value).lower()}")
            return 0
        message = client.active_features(timeout)
        print("active: " + ", ".join(message["active"]))
        print(f"since tick {message['tick']}: {message['request'] or 'the start'}")
        return 0
    except NotThere as missing:
        domain = os.environ.get("ROS_DOMAIN_ID", "0")
        print(
            f"ros2_client.py: nothing answered on {missing.what} within {missing.seconds:g} s: no motivml node "
            f"{client.robot} on ROS_DOMAIN_ID {domain} (is `motivml run ... --ros2 --ros-namespace "
            f"{namespace}` running, with the same ROS_DOMAIN_ID?)",
            file=sys.stderr,
        )
        return 3
    except KeyboardInterrupt:
        maybe = (
            ": the change may still be committed (check with no FEATURE=VALUE)"
            if wanted and client.sent
            else ""
        )
        print(f"interrupted{maybe}", file=sys.stderr)
        return 130
    finally:
        client.close()


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

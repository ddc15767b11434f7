"""The UV disinfection robot's features as ROS 2 lifecycle nodes: the nodes named, in one process.

    python plugins/ros2/uv_nodes.py lamp [--ros-args -r __ns:=/uv --params-file ros2_params.yaml]
    python plugins/ros2/uv_nodes.py irradiation low_intensity high_intensity [--ros-args ...]

(One node a process is how a node is killed on its own, as a fault; several in one process
spare a small machine that runs many robots, as the fleet guide does.)

Nodes: `lamp` (UVLampControl), `dosimeter` (DoseMonitoring), `person_detection`
(CameraPersonDetection), `thermal_detection` (ThermalPresenceDetection), `irradiation`
(UVIrradiation's interlock), `low_intensity` and `high_intensity`; the manifests beside this
script say which feature each implements.

motivml (plugin kind `ros2_lifecycle`) configures and activates a node when its feature
loads, and deactivates and cleans it up when the feature unloads; any lifecycle manager,
or `ros2 lifecycle set`, can do the same. Each node publishes its reading only while it is
active, on `~/<topic>`. They are stand-ins with simulated readings, small enough to read:
what matters is that they behave like real lifecycle nodes.

Every node declares `fail_on` (default ""): naming a transition (`configure`, `activate`,
`deactivate`, `cleanup`) makes that transition's callback return FAILURE, which is how the
tests make an activation fail. `motivml.feature` and `motivml.binding` are what configure's
ros2_params.yaml says the node implements. SIGINT and SIGTERM end a node quietly.
"""

from __future__ import annotations

import json
import signal
import sys
import threading
from typing import Any

import rclpy
from rcl_interfaces.msg import SetParametersResult
from rclpy.executors import SingleThreadedExecutor
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.qos import qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from rclpy.timer import Timer
from rclpy.utilities import remove_ros_args
from std_msgs.msg import Bool, Float64, String

TRANSITIONS = ("configure", "activate", "deactivate", "cleanup")


class FeatureNode(LifecycleNode):
    """A lifecycle node that publishes `reading()` on `~/<topic>` every `period` s while active."""

    topic = "reading"
    message: Any = Float64

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.declare_parameter("fail_on", "")
        self.declare_parameter("period", 0.1)
        self.declare_parameter("motivml.feature", "")
        self.declare_parameter("motivml.binding", "")
        self._publisher: Publisher | None = None
        self._timer: Timer | None = None

    def reading(self) -> Any:
        raise NotImplementedError

    def _fails(self, transition: str) -> bool:
        if self.get_parameter("fail_on").value != transition:
            return False
        self.get_logger().warning(f"{transition} fails: fail_on is {transition!r}")
        return True

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        if self._fails("configure"):
            return TransitionCallbackReturn.FAILURE
        self._publisher = self.create_publisher(self.message, f"~/{self.topic}", qos_profile_sensor_data)
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        if self._fails("activate"):
            return TransitionCallbackReturn.FAILURE
        self._timer = self.create_timer(self.get_parameter("period").value, self._publish)
        feature = self.get_parameter("motivml.feature").value or "no feature"
        self.get_logger().info(
            f"active ({feature}, {self.get_parameter('motivml.binding').value or 'unbound'})"
        )
        return TransitionCallbackReturn.SUCCESS

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        if self._fails("deactivate"):
            return TransitionCallbackReturn.FAILURE
        self._stop_timer()
        return TransitionCallbackReturn.SUCCESS

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        if self._fails("cleanup"):
            return TransitionCallbackReturn.FAILURE
        self._forget_publisher()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._stop_timer()
        self._forget_publisher()
        return TransitionCallbackReturn.SUCCESS

    def _publish(self) -> None:
        if self._publisher is not None:
            self._publisher.publish(self.reading())

    def _stop_timer(self) -> None:
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None

    def _forget_publisher(self) -> None:
        if self._publisher is not None:
            self.destroy_publisher(self._publisher)
            self._publisher = None


class Lamp(FeatureNode):
    """UV-C lamp driver: irradiance (W/m²) at the lamp's `power` (0..1), only while active."""

    topic = "irradiance"

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.declare_parameter("power", 1.0)
        self.declare_parameter("max_irradiance", 1.8)
        self.add_on_set_parameters_callback(self._check_power)

    def _check_power(self, parameters: list[Parameter]) -> SetParametersResult:
        for p in parameters:
            if p.name == "power" and not 0.0 <= p.value <= 1.0:
                return SetParametersResult(successful=False, reason="power is between 0 and 1")
        return SetParametersResult(successful=True)

    def reading(self) -> Float64:
        return Float64(data=self.get_parameter("power").value * self.get_parameter("max_irradiance").value)


class Dosimeter(FeatureNode):
    """UV dose (J/m²) accumulated from the lamp's irradiance since the node was configured."""

    topic = "dose"

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.declare_parameter("irradiance_topic", "lamp/irradiance")
        self._dose = 0.0
        self._irradiance = 0.0

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        outcome = super().on_configure(state)
        if outcome == TransitionCallbackReturn.SUCCESS:
            self._dose = 0.0
            topic = self.get_parameter("irradiance_topic").value
            self._heard_from = self.create_subscription(Float64, topic, self._heard, qos_profile_sensor_data)
        return outcome

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        outcome = super().on_cleanup(state)
        if outcome == TransitionCallbackReturn.SUCCESS:
            self.destroy_subscription(self._heard_from)
        return outcome

    def _heard(self, message: Float64) -> None:
        self._irradiance = message.data

    def reading(self) -> Float64:
        self._dose += self._irradiance * self.get_parameter("period").value
        return Float64(data=self._dose)


class PresenceDetector(FeatureNode):
    """People in the room as JSON ({"people": n, "method": ...}); simulated: nobody."""

    topic = "people"
    message = String
    method = "camera"

    def reading(self) -> String:
        return String(data=json.dumps({"people": 0, "method": self.method}))


class ThermalDetector(PresenceDetector):
    method = "thermal"


class Intensity(FeatureNode):
    """A lamp intensity (LowIntensity, HighIntensity): the power it asks of the lamp, on `~/power`."""

    topic = "power"

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.declare_parameter("power", 0.5)

    def reading(self) -> Float64:
        return Float64(data=self.get_parameter("power").value)


class Interlock(FeatureNode):
    """UV irradiation's safety interlock: lamps allowed (`~/lamps_allowed`) while the
    presence detectors report nobody."""

    topic = "lamps_allowed"
    message = Bool

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.declare_parameter("people_topics", ["person_detection/people", "thermal_detection/people"])
        self._people = 0
        for topic in self.get_parameter("people_topics").value:
            self.create_subscription(String, topic, self._heard, qos_profile_sensor_data)

    def _heard(self, message: String) -> None:
        self._people = int(json.loads(message.data).get("people", 0))

    def reading(self) -> Bool:
        return Bool(data=self._people == 0)


NODES: dict[str, type[FeatureNode]] = {
    "lamp": Lamp,
    "dosimeter": Dosimeter,
    "person_detection": PresenceDetector,
    "thermal_detection": ThermalDetector,
    "irradiation": Interlock,
    "low_intensity": Intensity,
    "high_intensity": Intensity,
}


def main(argv: list[str]) -> int:
    names = ", ".join(NODES)
    own = remove_ros_args(argv)[1:]
    if not own or any(name not in NODES for name in own) or len(set(own)) != len(own):
        print(f"usage: uv_nodes.py NODE... [--ros-args ...] (NODE: one of {names}; each once)", file=sys.stderr)
        return 2
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    # SIGINT and SIGTERM only ask the loop below to end, between two callbacks: a
    # KeyboardInterrupt raised inside a callback can leave rclpy's handles half torn down.
    ending = threading.Event()
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, lambda *_: ending.set())
    nodes = [NODES[name](name) for name in own]
    executor = SingleThreadedExecutor()
    try:
        for node in nodes:
            if node.get_parameter("fail_on").value not in ("", *TRANSITIONS):
                print(f"uv_nodes.py: fail_on names a transition: one of {', '.join(TRANSITIONS)}", file=sys.stderr)
                return 2
            executor.add_node(node)
        while not ending.is_set():
            executor.spin_once(timeout_sec=0.1)
    finally:
        executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

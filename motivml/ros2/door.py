"""The run's side of the `motivml` ROS 2 node (`run --ros2`): a front door of the binder.

The node itself lives in the run's ROS 2 bridge (`motivml.ros2.node`, in the process that
holds rclpy: see `motivml.plugins.bridge`). This side, in the run's process, holds no rclpy:

* it tells the bridge what the node shows (the selected features, their bindings, the
  active set), and starts the node;
* it answers the node's `set` calls (one `set_parameters(_atomically)` call: the features
  wanted on and off) with one `Set` request to the binder, on the link's reading thread;
* it tells the node every answer of the binder (it listens to the run's events for
  `Answered`: ctl's changes and a fault's unloads too), and, once a second, the loop's
  health for `/diagnostics`.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from ..errors import EnvironmentProblem, Location, describe_exception, error
from ..plugins import bridge as bridges
from ..plugins.bridge import Bridge, LinkBroken
from ..plugins.ros2 import ros2_missing
from ..runtime.events import Answered, RunEvent
from ..runtime.launch import Robot
from ..runtime.requests import Set

DIAGNOSTICS_PERIOD = 1.0  # s
MISSED_WARNING = 0.01  # the loop's status is WARN when more than this share of its deadlines were missed


class Door:
    """The robot's `motivml` node, as the run sees it."""

    def __init__(self, robot: Robot, ns: str, timeout: float = 5.0) -> None:
        missing = ros2_missing()
        if missing is not None:
            raise missing
        self.robot = robot
        self.binder = robot.binder
        self.runtime = robot.runtime
        self.timeout = timeout
        model = robot.variant.model
        self.order = model.index
        # every selected feature but the root (always there, nothing to switch)
        self.selected = [d for d in robot.variant.decisions if d.selected and d.feature.parent is not None]
        self._closed = threading.Event()
        self.bridge: Bridge = bridges.open_bridge(ns, bridges.BRIDGE_CPUS)
        try:
            self.bridge.on("set", self._set)
            answer = self.bridge.call(
                "door",
                bridges.START_TIMEOUT,
                robot=robot.folder.name,
                variant=robot.variant.name,
                configuration=robot.variant.digest(),
                timeout=timeout,
                features=[
                    {
                        "id": d.feature.id,
                        "words": d.binding.words,
                        "read_only": d.binding.static and d.binding.early,
                    }
                    for d in self.selected
                ],
                active=self._ordered(self.binder.active),
                tick=self.runtime.ticks,
            )
            if "error" in answer:
                raise EnvironmentProblem(error(Location("ros2"), str(answer["error"]), "ros2.start"))
        except LinkBroken as exc:
            bridges.release_bridge(self.bridge)
            raise EnvironmentProblem(error(Location("ros2"), f"ROS 2 could not start: {exc}", "ros2.start")) from None
        except BaseException:
            bridges.release_bridge(self.bridge)
            raise
        self.name = str(answer["name"])
        # The latest outcome told to the node (its number, the active set after it): a set
        # call's answer carries both, so that the node never takes an older outcome still
        # on its way for newer than its answer.
        self._told: tuple[int, list[str]] = (0, self._ordered(self.binder.active))
        self.runtime.told.listen(self._heard)
        self._ticks = (self.runtime.ticks, time.perf_counter())
        self._missed = self.runtime.missed
        self._health = threading.Thread(target=self._report, daemon=True, name="motivml-ros2-health")
        self._health.start()

    def _ordered(self, features: frozenset[str]) -> list[str]:
        return sorted(features, key=self.order.__getitem__)

    # ------------------------------------------------------------- the node's calls
    def _set(self, message: dict[str, Any]) -> None:
        """On the link's thread: one call of the node (the binder's calls to the bridge go the
        other way, on the link's other socket pair, so this thread may wait for them)."""
        try:
            if self._closed.is_set():
                answer: dict[str, Any] = {"accepted": False, "reason": "the run is ending: nothing changed"}
            else:
                answer = self._change(dict(message["wanted"]))
        except Exception as exc:
            answer = {"error": f"motivml could not handle the call: {describe_exception(exc)}"}
        self.bridge.link.answer(message, **answer)

    def _change(self, wanted: dict[str, bool]) -> dict[str, Any]:
        active = self.binder.active
        loads = [f for f, on in wanted.items() if on and f not in active]
        unloads = [f for f, on in wanted.items() if not on and f in active]
        if loads or unloads:
            outcome = self.binder.request(Set(tuple(loads), tuple(unloads)), timeout=self.timeout)
            if not outcome.accepted:
                return {"accepted": False, "reason": outcome.reason}
        told, now = self._told  # (this request's own outcome among them)
        return {"accepted": True, "active": now, "told": told}

    # ---------------------------------------------------------- the binder's news
    def _heard(self, event: RunEvent) -> None:
        """An answer of the binder (on the requesting thread, with the binder held): tell the
        node (one small message). The run's other events are not the node's."""
        if not isinstance(event, Answered) or self._closed.is_set():
            return
        told = self._told[0] + 1
        after = self._ordered(event.active)
        news = {
            "event": "outcome",
            "told": told,
            "accepted": event.accepted,
            "request": event.request,
            "reason": event.reason,
            "loads": list(event.loads),
            "unloads": list(event.unloads),
            "active": after,
            "tick": event.tick,
            "change": event.change[1] if event.change is not None else None,
        }
        self._told = (told, after)
        try:
            self.bridge.link.send(news)
        except LinkBroken:
            pass

    # ------------------------------------------------------------ diagnostics
    def _report(self) -> None:
        while not self._closed.wait(DIAGNOSTICS_PERIOD):
            try:
                self.bridge.link.send({"event": "health", "statuses": self.health()})
            except LinkBroken:
                return

    def health(self) -> list[dict[str, Any]]:
        """The loop's status and one per selected feature, for /diagnostics."""
        runtime = self.runtime
        ticks, now = runtime.ticks, time.perf_counter()
        before, then = self._ticks
        achieved = (ticks - before) / (now - then) if now > then else 0.0
        self._ticks = (ticks, now)
        missed_now = runtime.missed - self._missed
        self._missed = runtime.missed
        level, message = "OK", "running"
        if runtime.failure is not None:
            level, message = "ERROR", f"stopped by the fault of {runtime.failure.feature}"
        elif missed_now > MISSED_WARNING * runtime.rate * DIAGNOSTICS_PERIOD:
            level, message = "WARN", f"{missed_now} deadlines missed in the last second"
        elif missed_now:
            message = f"running ({missed_now} deadlines missed in the last second)"
        statuses = [
            {
                "name": "loop",
                "level": level,
                "message": message,
                "values": [
                    ("rate", f"{runtime.rate:g}"),
                    ("achieved rate", f"{achieved:.1f}"),
                    ("ticks", str(ticks)),
                    ("missed deadlines", str(runtime.missed)),
                    ("faults", str(len(runtime.faults))),
                    ("active features", str(len(self.binder.active))),
                ],
            }
        ]
        faulted = {f.feature: f.error for f in runtime.faults}
        plugins = dict(runtime.plugins)
        active = self.binder.active
        for d in self.selected:
            feature = d.feature.id
            running = plugins.get(feature)
            level, state = "OK", "active" if feature in active else "inactive"
            if running is not None and running.faulted:
                level, state = "ERROR", f"faulted: {faulted.get(feature, '')}"
            elif feature in faulted and feature not in active:
                level, state = "WARN", f"unloaded after a fault: {faulted[feature]}"
            values = [("binding", d.binding.words)]
            if running is not None:
                try:
                    values.append(("status", str(running.instance.status())[:200]))
                except BaseException as exc:  # plugin code: a report never fails because of it
                    values.append(("status", f"status() raised {type(exc).__name__}"))
            statuses.append({"name": f"feature {feature}", "level": level, "message": state, "values": values})
        return statuses

    # --------------------------------------------------------------- closing
    def close(self) -> None:
        """Leave the graph (before the robot's plugins stop)."""
        if self._closed.is_set():
            return
        self._closed.set()
        self.runtime.told.forget(self._heard)
        if self.bridge.gone is None:
            try:
                self.bridge.call("door_close", bridges.END_TIMEOUT)
            except (LinkBroken, TimeoutError):
                pass
        self._health.join(timeout=2.0)
        bridges.release_bridge(self.bridge)


def start(robot: Robot, ns: str) -> Door:
    """The robot's `motivml` node, in the run's ROS 2 bridge."""
    return Door(robot, ns)

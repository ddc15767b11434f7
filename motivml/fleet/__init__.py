"""Fleets (reference.md section 9): many robots of one model, checked robot by robot, and
changes rolled out to the running ones in stages.

`layers` reads a fleet file (robots by namespace, each a robot folder and a variant, with
decisions overridden in layers), checks every robot's configuration, and plans a change for
each robot; `rollout` takes a change to the running robots wave by wave, watching their
health, and takes it back when one refuses or goes unhealthy. Neither speaks ROS 2: the
running robots reach them through a `rollout.Graph` (motivml.ros2.fleet's `Watch` on a real
graph).
"""

from .layers import (
    Layer,
    RobotPlan,
    RobotReport,
    UnknownGroup,
    fleet_file,
    fleet_robot,
    is_fleet_file,
    namespaces,
    plan_fleet,
    selected,
    selected_namespaces,
    validate_fleet,
)

__all__ = [
    "Layer",
    "RobotPlan",
    "RobotReport",
    "UnknownGroup",
    "fleet_file",
    "fleet_robot",
    "is_fleet_file",
    "namespaces",
    "plan_fleet",
    "selected",
    "selected_namespaces",
    "validate_fleet",
]

"""HectorSLAM stand-in: integrates the base's velocity into a pose estimate every tick.

A real plugin would wrap the SLAM library; this one keeps the interface honest: it reads a
space, keeps state, writes a space, and continues from the pose it finds when swapped in.
"""

from __future__ import annotations

import math

from motivml.plugins.api import FeaturePlugin


class HectorSLAM(FeaturePlugin):
    def start(self) -> None:
        self.pose = [float(v) for v in self.context.read("PoseEstimate")]  # continue, if swapped in
        self.dt = 1.0 / self.context.rate
        self.updates = 0

    def step(self, time: float) -> None:
        speed, turn = self.context.read("BaseVelocity")
        x, y, heading = self.pose
        heading += turn * self.dt
        self.pose = [x + speed * math.cos(heading) * self.dt, y + speed * math.sin(heading) * self.dt, heading]
        self.context.write("PoseEstimate", self.pose)
        self.updates += 1

    def status(self) -> str:
        x, y, heading = self.pose
        return f"pose ({x:.2f} m, {y:.2f} m, {heading:.2f} rad), {self.updates} updates"

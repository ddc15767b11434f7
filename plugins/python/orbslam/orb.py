"""OrbSLAM stand-in: monocular visual odometry at 30 Hz whose scale drifts by 2 % per metre."""

from __future__ import annotations

import math

from motivml.plugins.api import FeaturePlugin


class OrbSLAM(FeaturePlugin):
    def start(self) -> None:
        self.pose = [float(v) for v in self.context.read("PoseEstimate")]
        self.every = max(1, round(self.context.rate / 30.0))  # camera frames at 30 Hz
        self.ticks = 0
        self.scale = 1.0
        self.frames = 0

    def step(self, time: float) -> None:
        self.ticks += 1
        if self.ticks % self.every:
            return
        speed, turn = self.context.read("BaseVelocity")
        dt = self.every / self.context.rate
        distance = speed * dt * self.scale
        self.scale *= 1.0 + 0.02 * abs(speed * dt)  # no absolute scale from one camera
        x, y, heading = self.pose
        heading += turn * dt
        self.pose = [x + distance * math.cos(heading), y + distance * math.sin(heading), heading]
        self.context.write("PoseEstimate", self.pose)
        self.frames += 1

    def status(self) -> str:
        x, y, heading = self.pose
        return f"pose ({x:.2f} m, {y:.2f} m, {heading:.2f} rad), {self.frames} frames, scale {self.scale:.3f}"

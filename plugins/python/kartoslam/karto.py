"""KartoSLAM stand-in: a pose update at 10 Hz from the motion since the last one (scan matching)."""

from __future__ import annotations

import math

from motivml.plugins.api import FeaturePlugin


class KartoSLAM(FeaturePlugin):
    def start(self) -> None:
        self.pose = [float(v) for v in self.context.read("PoseEstimate")]
        self.every = max(1, round(self.context.rate / 10.0))  # scans at 10 Hz
        self.ticks = 0
        self.motion = [0.0, 0.0]  # distance and turn since the last scan
        self.updates = 0

    def step(self, time: float) -> None:
        speed, turn = self.context.read("BaseVelocity")
        self.motion[0] += speed / self.context.rate
        self.motion[1] += turn / self.context.rate
        self.ticks += 1
        if self.ticks % self.every:
            return
        distance, turned = self.motion
        x, y, heading = self.pose
        middle = heading + turned / 2  # the arc's mean heading
        self.pose = [x + distance * math.cos(middle), y + distance * math.sin(middle), heading + turned]
        self.motion = [0.0, 0.0]
        self.context.write("PoseEstimate", self.pose)
        self.updates += 1

    def status(self) -> str:
        x, y, heading = self.pose
        return f"pose ({x:.2f} m, {y:.2f} m, {heading:.2f} rad), {self.updates} scans"

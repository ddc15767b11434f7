"""Dynamical systems for motion primitives: the inside of an adaptive module.

The motion architecture's adaptive modules hold one or more dynamical systems, stepped at
a fixed rate with an explicit time step (no clocks here, so tests run in simulated time):

* goal-directed: `PointAttractor` (a critically damped spring towards a goal) and
  `DiscreteDMP` (a dynamic movement primitive after Ijspeert et al.: the attractor plus
  a learned forcing term that fades with a canonical phase; learned from one
  demonstration, it reproduces it and generalises to a new goal);
* periodic: `CoupledOscillators`, phase oscillators coupled so that they lock to given
  phase differences (a central pattern generator, e.g. a quadruped's trot).

All state is numpy arrays of the space's dimension; `step(dt)` integrates with
semi-implicit Euler, which is stable for these systems at control rates (100 Hz-1 kHz).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .learners import ridge

Vector = NDArray[np.float64]


def _vector(value: float | list[float] | Vector) -> Vector:
    return np.atleast_1d(np.asarray(value, dtype=float)).copy()


@dataclass
class PointAttractor:
    """x'' = alpha * (beta * (goal - x) - x'), beta = alpha / 4: critically damped."""

    position: Vector
    goal: Vector
    alpha: float = 25.0
    velocity: Vector = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        self.position = _vector(self.position)
        self.goal = _vector(self.goal)
        if self.velocity.size == 0:
            self.velocity = np.zeros_like(self.position)

    @property
    def beta(self) -> float:
        return self.alpha / 4.0

    def step(self, dt: float) -> Vector:
        acceleration = self.alpha * (self.beta * (self.goal - self.position) - self.velocity)
        self.velocity = self.velocity + dt * acceleration
        self.position = self.position + dt * self.velocity
        return self.position

    def converged(self, tolerance: float) -> bool:
        return bool(np.linalg.norm(self.goal - self.position) <= tolerance)


@dataclass
class DiscreteDMP:
    """A discrete dynamic movement primitive.

    tau^2 x'' = alpha (beta (g - x) - tau x') + f(s) (g - x0),  tau s' = -alpha_s s,
    f(s) = s * sum_i psi_i(s) w_i / sum_i psi_i(s), with Gaussian basis functions psi_i
    spread along the phase s (1 -> 0). Scaling f by (g - x0) lets a learned shape carry over
    to a new start and goal.
    """

    dimension: int
    basis: int = 30
    alpha: float = 25.0
    alpha_s: float = 4.0
    tau: float = 1.0
    weights: Vector = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        self.centres = np.exp(-self.alpha_s * np.linspace(0.0, 1.0, self.basis))
        widths = np.diff(self.centres) ** 2
        self.widths = 1.0 / np.append(widths, widths[-1])
        self._negative_widths = -self.widths
        if self.weights.size == 0:
            self.weights = np.zeros((self.basis, self.dimension))
        self.reset(np.zeros(self.dimension), np.zeros(self.dimension))

    @property
    def beta(self) -> float:
        return self.alpha / 4.0

    def _features(self, s: float | Vector) -> Vector:
        s = np.atleast_1d(s)
        psi = np.exp(-self.widths * (s[:, None] - self.centres) ** 2)
        return np.asarray(psi * s[:, None] / psi.sum(axis=1, keepdims=True), dtype=float)

    def learn(self, demonstration: Vector, dt: float, regularisation: float = 1e-6) -> None:
        """Fit the forcing term to one demonstration (T x dimension samples, step dt).

        The duration sets tau; the weights solve a ridge regression of the forcing term
        the demonstration needs (learners.ridge).
        """
        y = np.asarray(demonstration, dtype=float).reshape(len(demonstration), -1)
        if y.shape[1] != self.dimension or len(y) < 3:
            raise ValueError(f"a demonstration is at least 3 samples of dimension {self.dimension}")
        self.tau = (len(y) - 1) * dt
        yd = np.gradient(y, dt, axis=0)
        ydd = np.gradient(yd, dt, axis=0)
        x0, goal = y[0], y[-1]
        time = np.arange(len(y)) * dt
        s = np.exp(-self.alpha_s * time / self.tau)
        scale = np.where(np.abs(goal - x0) > 1e-9, goal - x0, 1.0)
        target = (self.tau**2 * ydd - self.alpha * (self.beta * (goal - y) - self.tau * yd)) / scale
        self.weights = ridge(self._features(s), target, regularisation)

    def reset(self, start: Vector | list[float], goal: Vector | list[float]) -> None:
        self.x0 = _vector(start)
        self.goal = _vector(goal)
        self.position = self.x0.copy()
        self.velocity = np.zeros_like(self.x0)
        self.phase = 1.0
        self._scale = np.where(np.abs(self.goal - self.x0) > 1e-9, self.goal - self.x0, 1.0)

    def step(self, dt: float) -> Vector:
        phase = self.phase
        psi = np.exp(self._negative_widths * (phase - self.centres) ** 2)
        forcing = (psi @ self.weights) * (phase / psi.sum()) * self._scale
        tau = self.tau
        spring = self.alpha * self.beta
        acceleration = (
            spring * (self.goal - self.position) - (self.alpha * tau) * self.velocity + forcing
        ) / (tau * tau)
        self.velocity = self.velocity + dt * acceleration
        self.position = self.position + dt * self.velocity
        self.phase += dt * (-self.alpha_s * self.phase / self.tau)
        return self.position

    def rollout(
        self, start: Vector | list[float], goal: Vector | list[float], dt: float, steps: int
    ) -> Vector:
        self.reset(start, goal)
        return np.array([self.position.copy()] + [self.step(dt).copy() for _ in range(steps - 1)])


@dataclass
class CoupledOscillators:
    """Phase oscillators locking to given phase offsets (a central pattern generator).

    phi_i' = 2 pi f + k * sum_j sin(phi_j - phi_i - (offset_j - offset_i)); the output of
    oscillator i is amplitude * sin(phi_i). From any start the phase differences converge
    to the offsets (for k > 0) from almost every start (a few symmetric starts are unstable
    equilibria that any perturbation leaves), which is what keeps a gait.
    """

    offsets: Vector
    frequency: float = 1.0
    coupling: float = 4.0
    amplitude: float = 1.0
    phases: Vector = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        self.offsets = _vector(self.offsets)
        if self.phases.size == 0:
            self.phases = np.zeros_like(self.offsets)
        self.phases = _vector(self.phases)

    def step(self, dt: float) -> Vector:
        # sin(phi_j - phi_i - (o_j - o_i)) = sin(u_j - u_i) with u = phi - o, and
        # sum_j sin(u_j - u_i) = cos(u_i) sum_j sin(u_j) - sin(u_i) sum_j cos(u_j): O(n), not O(n^2)
        u = self.phases - self.offsets
        sines, cosines = np.sin(u), np.cos(u)
        coupling = self.coupling * (cosines * sines.sum() - sines * cosines.sum())
        self.phases = self.phases + dt * (2 * np.pi * self.frequency + coupling)
        return self.output()

    def output(self) -> Vector:
        return self.amplitude * np.sin(self.phases)

    def locking_error(self) -> float:
        """Largest distance (rad) of the phase differences from the wanted ones."""
        u = self.phases - self.offsets
        return float(np.abs(np.mod(u - u[0] + np.pi, 2 * np.pi) - np.pi).max())

    def phase_differences(self) -> Vector:
        """Phases relative to oscillator 0, wrapped into [0, 2 pi)."""
        return np.asarray(np.mod(self.phases - self.phases[0], 2 * np.pi), dtype=float)

"""Dynamical systems and learners against known behaviour (simulated time, fixed seeds)."""

from __future__ import annotations

import numpy as np
import pytest

from motivml.architecture.dynamics import CoupledOscillators, DiscreteDMP, PointAttractor
from motivml.architecture.learners import ExtremeLearningMachine, ridge

DT = 0.001


def test_point_attractor_converges_without_overshoot() -> None:
    attractor = PointAttractor([0.0, 0.0], [1.0, -0.5])
    path = np.array([attractor.step(DT).copy() for _ in range(3000)])
    assert attractor.converged(1e-3)
    assert path[:, 0].max() <= 1.0 + 1e-9 and path[:, 1].min() >= -0.5 - 1e-9  # critically damped
    assert not PointAttractor([0.0], [1.0]).converged(1e-3)


def demonstration() -> np.ndarray:
    t = np.linspace(0.0, 1.0, 1001)
    return np.stack([np.sin(np.pi * t) * 0.3 + t, t**2], axis=1)


def test_dmp_reproduces_its_demonstration() -> None:
    demo = demonstration()
    dmp = DiscreteDMP(2)
    dmp.learn(demo, DT)
    rollout = dmp.rollout(demo[0], demo[-1], DT, len(demo))
    assert np.sqrt(np.mean((rollout - demo) ** 2)) < 0.03
    assert np.linalg.norm(rollout[-1] - demo[-1]) < 0.01


def test_dmp_generalises_to_a_new_goal() -> None:
    demo = demonstration()
    dmp = DiscreteDMP(2)
    dmp.learn(demo, DT)
    rollout = dmp.rollout(demo[0], [2.0, 0.5], DT, 2500)
    assert np.linalg.norm(rollout[-1] - [2.0, 0.5]) < 0.01
    # the shape carries over: the first coordinate still bulges above the straight line
    straight = np.linspace(0.0, 2.0, len(rollout))
    assert (rollout[len(rollout) // 5, 0] - straight[len(rollout) // 5]) > 0.05


def test_dmp_refuses_a_demonstration_of_the_wrong_dimension() -> None:
    with pytest.raises(ValueError, match="dimension 2"):
        DiscreteDMP(2).learn(np.zeros((10, 3)), DT)


def test_cpg_locks_to_trot_phases_from_random_starts() -> None:
    trot = [0.0, np.pi, np.pi, 0.0]  # left fore, right fore, left hind, right hind
    rng = np.random.default_rng(3)
    for _ in range(5):
        cpg = CoupledOscillators(trot, phases=rng.uniform(0.0, 2 * np.pi, 4))
        for _ in range(5000):
            cpg.step(DT)
        error = np.angle(np.exp(1j * (cpg.phase_differences() - np.array(trot))))
        assert np.abs(error).max() < 1e-3
        assert cpg.output().shape == (4,)


def test_ridge_recovers_linear_weights() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(size=(200, 3))
    w = np.array([[1.0], [-2.0], [0.5]])
    assert np.allclose(ridge(x, x @ w, 1e-9), w, atol=1e-6)


def test_elm_fits_a_known_function_offline_and_online() -> None:
    x = np.linspace(-3, 3, 200)[:, None]
    test = np.linspace(-2.9, 2.9, 57)[:, None]
    offline = ExtremeLearningMachine(1, 1, hidden=60)
    offline.fit(x, np.sin(x))
    assert np.sqrt(np.mean((offline.predict(test) - np.sin(test)) ** 2)) < 0.01
    online = ExtremeLearningMachine(1, 1, hidden=60, regularisation=1e-3)
    for value in np.random.default_rng(1).uniform(-3, 3, 2000):
        online.update([[value]], [np.sin(value)])
    assert np.sqrt(np.mean((online.predict(test) - np.sin(test)) ** 2)) < 0.01

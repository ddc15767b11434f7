"""Learners of adaptive modules and adaptive mappings: least squares and an ELM.

* `ridge(features, targets, regularisation)`: regularised least squares, the batch
  learner of DMP weights and of linear mappings;
* `ExtremeLearningMachine`: a single hidden layer of fixed random tanh units whose output
  weights are learned by ridge regression (Huang et al.), the learned mapping of the
  paper's redundancy learner; it learns offline (`fit`) or online, sample by sample, with
  recursive least squares (`update`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Matrix = NDArray[np.float64]


def ridge(features: Matrix, targets: Matrix, regularisation: float = 1e-6) -> Matrix:
    """argmin_W |features W - targets|^2 + regularisation |W|^2."""
    x = np.asarray(features, dtype=float)
    y = np.asarray(targets, dtype=float)
    gram = x.T @ x + regularisation * np.eye(x.shape[1])
    return np.asarray(np.linalg.solve(gram, x.T @ y))


class LinearRLS:
    """y = [x, 1] W learned online by recursive least squares (an affine map)."""

    def __init__(self, inputs: int, outputs: int, regularisation: float = 1e-6) -> None:
        self.weights = np.zeros((inputs + 1, outputs))
        self._inverse = np.eye(inputs + 1) / regularisation

    @staticmethod
    def _features(x: Matrix) -> Matrix:
        x = np.atleast_2d(np.asarray(x, dtype=float))
        return np.hstack([x, np.ones((len(x), 1))])

    def fit(self, x: Matrix, y: Matrix) -> None:
        """Offline learning: all samples at once (ridge regression)."""
        h = self._features(x)
        self.weights = ridge(h, np.asarray(y, dtype=float).reshape(len(h), -1))
        self._inverse = np.asarray(np.linalg.inv(h.T @ h + 1e-6 * np.eye(h.shape[1])), dtype=float)

    def update(self, x: Matrix, y: Matrix) -> None:
        h = self._features(x)[0]
        ph = self._inverse @ h
        gain = ph / (1.0 + h @ ph)
        self.weights = self.weights + np.outer(gain, np.atleast_1d(y) - h @ self.weights)
        self._inverse = self._inverse - np.outer(gain, ph)

    def predict(self, x: Matrix) -> Matrix:
        return np.asarray(self._features(x) @ self.weights)


class ExtremeLearningMachine:
    """y = tanh(x A + b) W, with A, b random and fixed, W learned."""

    def __init__(
        self, inputs: int, outputs: int, hidden: int = 100, regularisation: float = 1e-6, seed: int = 0
    ):
        rng = np.random.default_rng(seed)
        self.input_weights = rng.normal(0.0, 1.0, (inputs, hidden))
        self.bias = rng.uniform(-1.0, 1.0, hidden)
        self.regularisation = regularisation
        self.output_weights = np.zeros((hidden, outputs))
        self._inverse = np.eye(hidden) / regularisation  # for online updates (RLS)

    def hidden(self, x: Matrix) -> Matrix:
        return np.tanh(np.atleast_2d(np.asarray(x, dtype=float)) @ self.input_weights + self.bias)

    def fit(self, x: Matrix, y: Matrix) -> None:
        """Offline learning: all samples at once."""
        h = self.hidden(x)
        self.output_weights = ridge(h, np.asarray(y, dtype=float).reshape(len(h), -1), self.regularisation)
        self._inverse = np.asarray(
            np.linalg.inv(h.T @ h + self.regularisation * np.eye(h.shape[1])), dtype=float
        )

    def update(self, x: Matrix, y: Matrix) -> None:
        """Online learning: one sample, recursive least squares on the output weights."""
        h = self.hidden(x)[0]
        y = np.atleast_1d(np.asarray(y, dtype=float))
        ph = self._inverse @ h
        gain = ph / (1.0 + h @ ph)
        self.output_weights = np.asarray(
            self.output_weights + np.outer(gain, y - h @ self.output_weights), dtype=float
        )
        self._inverse = self._inverse - np.outer(gain, ph)

    def predict(self, x: Matrix) -> Matrix:
        return np.asarray(self.hidden(x) @ self.output_weights)

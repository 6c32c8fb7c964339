"""The problem a training algorithm minimises.

Every algorithm in :mod:`encal.training` sees the problem only through this
protocol, so the same code trains the 1:N:1 network and the known-answer test
problems. The performance is the mean squared error of the residuals,
``mse(w) = mean(r(w)**2)``, with ``r = prediction - target`` in the units the
problem chooses (the network uses targets normalised to [-1, 1]).
"""

from typing import Protocol

import numpy as np

__all__ = ["Objective", "LinearLeastSquares"]


class Objective(Protocol):
    """A nonlinear least-squares problem in ``n_params`` unknowns.

    Attributes
    ----------
    n_params : int
        Number of unknowns (weights and biases).
    n_samples : int
        Number of residuals.
    """

    n_params: int
    n_samples: int

    def residuals(self, w):
        """Residuals ``r(w) = prediction - target``, shape (n_samples,)."""

    def residuals_and_jacobian(self, w):
        """``(r, J)`` with ``J[i, j] = d r_i / d w_j``, shapes (m,) and (m, n)."""

    def mse(self, w):
        """Mean squared residual, a float."""

    def mse_and_gradient(self, w):
        """``(mse, g)`` with ``g = d mse / d w = 2 J^T r / m``, shape (n,)."""


class LinearLeastSquares:
    """``r(w) = A w - b``: a problem with a known answer, for tests.

    Parameters
    ----------
    A : array-like of shape (m, n)
    b : array-like of shape (m,)
    """

    def __init__(self, A, b):
        self.A = np.asarray(A, dtype=float)
        self.b = np.asarray(b, dtype=float)
        self.n_samples, self.n_params = self.A.shape

    def residuals(self, w):
        return self.A @ w - self.b

    def residuals_and_jacobian(self, w):
        return self.residuals(w), self.A

    def mse(self, w):
        r = self.residuals(w)
        return float(r @ r) / self.n_samples

    def mse_and_gradient(self, w):
        r = self.residuals(w)
        return float(r @ r) / self.n_samples, 2.0 * (self.A.T @ r) / self.n_samples

    def solution(self):
        """The least-squares minimiser (minimum-norm if rank deficient)."""
        return np.linalg.lstsq(self.A, self.b, rcond=None)[0]

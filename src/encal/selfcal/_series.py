"""A truncated Fourier series of an error profile, with the covariance of its coefficients.

Every self-calibration method estimates the encoder's error as such a series in the encoder reading:
``error(phi) = sum_k a_k cos(k phi) + b_k sin(k phi)`` (arc-minutes, ``phi`` in degrees), orders
``k = 1..K`` without the constant, which no method without a reference can see (the zero of a motor
is arbitrary). The covariance of ``(a_1..a_K, b_1..b_K)`` gives the standard uncertainty of the
error at any reading.
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["HarmonicSeries", "design_matrix"]


def design_matrix(angle_deg, orders):
    """Columns ``cos(k phi)`` for every order, then ``sin(k phi)`` for every order.

    Parameters
    ----------
    angle_deg : array-like of shape (n,)
        Angles in degrees.
    orders : array-like of shape (m,) of int
        Harmonic orders.

    Returns
    -------
    ndarray of shape (n, 2 m)
    """
    phase = np.radians(np.asarray(angle_deg, dtype=float))[:, None] * np.asarray(orders, dtype=float)[None, :]
    return np.hstack([np.cos(phase), np.sin(phase)])


@dataclass(frozen=True)
class HarmonicSeries:
    """Fourier coefficients of an error profile and their covariance.

    Parameters
    ----------
    orders : ndarray of shape (m,) of int
        Harmonic orders, each >= 1.
    cos_arcmin, sin_arcmin : ndarray of shape (m,)
        Coefficients of ``cos(k phi)`` and ``sin(k phi)`` in arc-minutes.
    covariance : ndarray of shape (2 m, 2 m)
        Covariance of ``(cos_arcmin, sin_arcmin)`` in arcmin^2.
    """

    orders: np.ndarray
    cos_arcmin: np.ndarray
    sin_arcmin: np.ndarray
    covariance: np.ndarray

    @classmethod
    def from_vector(cls, orders, vector, covariance):
        """A series from the stacked vector ``(cos..., sin...)`` and its covariance."""
        orders = np.asarray(orders, dtype=int)
        vector = np.asarray(vector, dtype=float)
        m = orders.size
        return cls(orders, vector[:m].copy(), vector[m:].copy(), np.asarray(covariance, dtype=float))

    @property
    def vector(self):
        """The stacked coefficients ``(cos..., sin...)`` in arc-minutes."""
        return np.concatenate([self.cos_arcmin, self.sin_arcmin])

    @property
    def amplitude_arcmin(self):
        """Amplitude of each order, ``hypot(a_k, b_k)``, in arc-minutes."""
        return np.hypot(self.cos_arcmin, self.sin_arcmin)

    @property
    def amplitude_sigma_arcmin(self):
        """Standard uncertainty of each order's amplitude in arc-minutes (the larger axis of its covariance)."""
        m = self.orders.size
        var_a = np.diag(self.covariance)[:m]
        var_b = np.diag(self.covariance)[m:]
        return np.sqrt(np.maximum(var_a, var_b))

    def evaluate(self, angle_deg):
        """The error in arc-minutes at encoder readings ``angle_deg`` (degrees)."""
        angle = np.asarray(angle_deg, dtype=float)
        if self.orders.size == 0:
            return np.zeros(angle.shape)
        return (design_matrix(angle.reshape(-1), self.orders) @ self.vector).reshape(angle.shape)

    def sigma(self, angle_deg):
        """Standard uncertainty (one sigma) of :meth:`evaluate` in arc-minutes at readings ``angle_deg``."""
        angle = np.asarray(angle_deg, dtype=float)
        if self.orders.size == 0:
            return np.zeros(angle.shape)
        x = design_matrix(angle.reshape(-1), self.orders)
        variance = np.einsum("ij,jk,ik->i", x, self.covariance, x)
        return np.sqrt(np.maximum(variance, 0.0)).reshape(angle.shape)

    def without(self, orders):
        """The series with the given orders removed."""
        keep = ~np.isin(self.orders, np.asarray(list(orders), dtype=int))
        index = np.concatenate([np.flatnonzero(keep), self.orders.size + np.flatnonzero(keep)])
        return HarmonicSeries(self.orders[keep], self.cos_arcmin[keep], self.sin_arcmin[keep],
                              self.covariance[np.ix_(index, index)])

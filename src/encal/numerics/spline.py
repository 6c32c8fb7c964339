"""The periodic smoothing spline: a smooth periodic curve through noisy values of the encoder angle.

The paper draws a "smoothened spline" through its error profiles and residuals; encal's is the periodic
cubic smoothing spline of Wahba (1975), its smoothing chosen by generalised cross-validation. The figures
(:mod:`encal.figures`) draw it; this module computes it.
"""

from dataclasses import dataclass

import numpy as np

from .._core.errors import InputError

__all__ = ["PeriodicSpline", "periodic_smoothing_spline"]


@dataclass(frozen=True, eq=False)
class PeriodicSpline:
    """A periodic smoothing spline: a trigonometric polynomial of degrees.

    Attributes
    ----------
    orders : ndarray of int
        Orders 0..K.
    cos, sin : ndarray
        Coefficients of ``cos(k θ)`` and ``sin(k θ)`` (θ in radians), in the data's unit.
    lam : float
        Smoothing parameter chosen by generalised cross-validation.
    edf : float
        Effective degrees of freedom (trace of the smoother matrix).
    """

    orders: np.ndarray
    cos: np.ndarray
    sin: np.ndarray
    lam: float
    edf: float

    def __call__(self, theta_deg):
        """The spline at ``theta_deg`` (degrees)."""
        theta = np.radians(np.asarray(theta_deg, dtype=float))[..., None]
        k = self.orders
        return (np.cos(k * theta) @ self.cos + np.sin(k * theta) @ self.sin)[()]


def periodic_smoothing_spline(theta_deg, values, max_order=None):
    """Fit a periodic cubic smoothing spline, its smoothing chosen by generalised cross-validation.

    Minimises ``Σ (y_i − f(θ_i))² + λ ∫ f''(θ)² dθ`` over 2π-periodic ``f``. In the Fourier basis the
    roughness is ``π Σ k⁴ (a_k² + b_k²)``, so the periodic smoothing spline (Wahba 1975) is a ridge
    regression on ``cos kθ, sin kθ`` with penalty ``k⁴``; orders above ``max_order`` are negligible under
    that penalty and are dropped. λ minimises the GCV score ``n RSS / (n − edf)²``.

    Parameters
    ----------
    theta_deg : array-like of shape (n,)
        Angles in degrees, any order.
    values : array-like of shape (n,)
        Data (arcmin).
    max_order : int, optional
        Highest order; default ``min((n_distinct − 1) // 2 − 1, 150)``.

    Returns
    -------
    PeriodicSpline

    Examples
    --------
    >>> theta = np.arange(0.0, 360.0, 2.0)
    >>> spline = periodic_smoothing_spline(theta, np.sin(np.radians(theta)))
    >>> bool(abs(spline(90.0) - 1.0) < 1e-3)
    True
    """
    theta = np.radians(np.mod(np.asarray(theta_deg, dtype=float).reshape(-1), 360.0))
    y = np.asarray(values, dtype=float).reshape(-1)
    if theta.size != y.size or theta.size < 8 or not np.all(np.isfinite(y)):
        raise InputError(f"periodic_smoothing_spline expects at least 8 finite values, one per angle. "
                         f"Got {theta.size} angles and {y.size} values instead.")
    n_distinct = np.unique(np.round(theta, 12)).size
    if max_order is None:
        max_order = min((n_distinct - 1) // 2 - 1, 150)
    orders = np.arange(max(int(max_order), 1) + 1)
    design = np.hstack([np.cos(np.outer(theta, orders)), np.sin(np.outer(theta, orders[1:]))])
    penalty = np.pi * np.concatenate([orders.astype(float) ** 4, orders[1:].astype(float) ** 4])
    # Diagonalise once (R = chol(AᵀA), M = R⁻ᵀ D R⁻¹ = U Λ Uᵀ), then every λ costs O(p):
    # fitted values Q z / (1 + λ Λ) with Q = A R⁻¹ U orthonormal and z = Qᵀ y.
    gram = design.T @ design
    gram.flat[:: gram.shape[0] + 1] += 1e-12 * np.trace(gram) / gram.shape[0]
    R = np.linalg.cholesky(gram).T
    R_inv = np.linalg.inv(R)
    eigenvalues, U = np.linalg.eigh(R_inv.T @ (penalty[:, None] * R_inv))
    eigenvalues = np.clip(eigenvalues, 0.0, None)
    Q = design @ (R_inv @ U)
    z = Q.T @ y
    outside = float(y @ y - z @ z)  # part of y the basis cannot represent
    n = y.size

    def gcv(log_lam):
        shrink = 1.0 / (1.0 + 10.0**log_lam * eigenvalues)
        rss = max(outside, 0.0) + float(np.sum((z * (1.0 - shrink)) ** 2))
        edf = float(shrink.sum())
        return n * rss / max(n - edf, 1e-9) ** 2, edf

    grid = np.linspace(-12.0, 4.0, 161)
    scores = [gcv(g)[0] for g in grid]
    best = grid[int(np.argmin(scores))]
    fine = np.linspace(best - 0.1, best + 0.1, 21)
    best = fine[int(np.argmin([gcv(g)[0] for g in fine]))]
    lam = 10.0**best
    coefficients = R_inv @ (U @ (z / (1.0 + lam * eigenvalues)))
    k = orders.size
    return PeriodicSpline(orders, coefficients[:k], np.r_[0.0, coefficients[k:]], float(lam), gcv(best)[1])


# --------------------------------------------------------------------------- figures and files

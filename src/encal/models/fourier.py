"""Fourier-series error model (Kaul et al. 2008; Eq. 3 of Dhar et al.).

``ε̂(θ) = Σ_k a_k cos(k θ) + b_k sin(k θ)`` over a chosen set of harmonic
orders ``k``, θ the encoder angle in radians. The paper keeps the ten
harmonics of largest amplitude (``select='top'``); encal can also choose how
many of them to keep by cross-validation (``select='cv'``).
"""

import numpy as np

from ..errors import InputError, ModelFileError
from ..profile import (
    distinct_angles,
    fit_harmonic_series,
    harmonics,
    identifiable_order,
    nested_harmonic_fits,
    profile_arrays,
)
from .base import Model, register_model

__all__ = ["FourierModel", "fit_fourier"]


@register_model
class FourierModel(Model):
    """A truncated Fourier series of the encoder angle.

    Parameters
    ----------
    orders : sequence of int
        Distinct non-negative harmonic orders (cycles per revolution).
    cos, sin : sequence of float
        Coefficients ``a_k`` and ``b_k`` in arc-minutes, one per order.
    encoder, training : dict, optional
        See :class:`~encal.models.base.Model`.

    Examples
    --------
    >>> model = FourierModel([0, 2], cos=[1.0, 0.0], sin=[0.0, 3.0])
    >>> float(model.predict(45.0))
    4.0
    """

    kind = "fourier"

    def __init__(self, orders, cos, sin, *, encoder=None, training=None):
        super().__init__(encoder=encoder, training=training)
        orders = np.asarray(orders).reshape(-1)
        cos = np.asarray(cos, dtype=float).reshape(-1)
        sin = np.asarray(sin, dtype=float).reshape(-1)
        if not (orders.size == cos.size == sin.size):
            raise InputError(
                "FourierModel expects one cos and one sin coefficient per order; "
                f"got {orders.size} orders, {cos.size} cos and {sin.size} sin coefficients"
            )
        if orders.size and (
            not np.issubdtype(orders.dtype, np.integer) and not np.all(orders == np.round(orders))
            or np.any(orders < 0)
            or np.unique(orders).size != orders.size
        ):
            raise InputError(
                f"FourierModel expects distinct non-negative integer orders; got {orders.tolist()}"
            )
        if not (np.all(np.isfinite(cos)) and np.all(np.isfinite(sin))):
            raise InputError("FourierModel expects finite coefficients in arc-minutes; got NaN or infinity")
        self.orders = orders.astype(int)
        self.cos = cos
        self.sin = np.where(self.orders == 0, 0.0, sin)

    def _predict(self, theta_deg):
        phase = np.multiply.outer(np.radians(theta_deg), self.orders)
        return np.cos(phase) @ self.cos + np.sin(phase) @ self.sin

    def parameters(self):
        return {
            "orders": [int(k) for k in self.orders],
            "cos": [float(a) for a in self.cos],
            "sin": [float(b) for b in self.sin],
        }

    @classmethod
    def from_parameters(cls, parameters, *, encoder=None, training=None):
        try:
            return cls(parameters["orders"], parameters["cos"], parameters["sin"],
                       encoder=encoder, training=training)
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelFileError(
                "fourier model parameters must be {'orders': [int...], 'cos': [float...], "
                f"'sin': [float...]}} of equal length; {_reason(exc)}"
            ) from None

    def __repr__(self):
        name = self.encoder.get("name") or "unnamed encoder"
        return f"<FourierModel orders={self.orders.tolist()} for {name}>"


def _reason(exc):
    return f"missing key {exc}" if isinstance(exc, KeyError) else str(exc)


def fit_fourier(theta_enc_deg, error_arcmin, *, orders=None, n_orders=10, select="top",
                max_order=None, folds=5):
    """Fit a Fourier-series model to an error profile by least squares.

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees (any order and spacing).
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.
    orders : sequence of int, optional
        Harmonic orders to fit: distinct ints >= 0 (at most ``max_order`` if
        that is given) that the angles identify together. None may exceed
        the highest order ``m`` distinct angles determine, ``m // 2`` on a
        regular grid and ``(m - 1) // 2`` otherwise (see
        :func:`~encal.profile.identifiable_order`): above it an order aliases
        a lower one, and a fit that is exact at the points is wrong between
        them. When given, ``select`` and ``n_orders`` are not used.
    n_orders : int, default=10
        With ``select='top'``: how many orders to keep (fewer if the angles
        identify fewer).
    select : {'top', 'cv'}, default='top'
        How to choose the orders:

        - ``'top'``: the paper's rule, the ``n_orders`` orders of largest
          amplitude in the harmonic analysis of the profile;
        - ``'cv'``: rank the orders the same way and keep the smallest
          number of them whose ``folds``-fold cross-validated RMS error is
          within one standard error of the lowest (see
          :func:`cross_validate_order_count`).
    max_order : int, optional
        Highest order ranked by ``select``; default and upper limit
        :func:`~encal.profile.identifiable_order` of the angles (the Nyquist
        order on a uniform grid).
    folds : int, default=5
        Number of cross-validation folds for ``select='cv'``.

    Returns
    -------
    FourierModel
        With ``training = {'select': ..., 'orders': [...], ...}``.

    Raises
    ------
    InputError
        If an option is invalid or the angles cannot identify the orders
        (an order above the limit of ``orders``, or orders that alias one another).

    Examples
    --------
    >>> theta = np.arange(0.0, 360.0, 2.0)
    >>> error = 2.0 * np.sin(np.radians(theta)) + 0.5 * np.cos(np.radians(16 * theta))
    >>> model = fit_fourier(theta, error, n_orders=2)
    >>> model.orders.tolist(), round(float(model.predict(90.0)), 9)
    ([1, 16], 2.5)
    """
    theta, error = profile_arrays(theta_enc_deg, error_arcmin, "fit_fourier")
    stable = identifiable_order(theta)
    limit = stable if max_order is None else _check_count(max_order, "max_order", 0)
    if orders is not None:
        chosen = _check_orders(orders, None if max_order is None else limit)
        training = {"select": "explicit"}
    elif select == "top":
        n_orders = _check_count(n_orders, "n_orders", 1)
        chosen = harmonics(theta, error, min(limit, stable)).top(n_orders)
        training = {"select": "top", "n_orders": n_orders}
    elif select == "cv":
        folds = _check_count(folds, "folds", 2)
        counts, cv_rms, cv_se = cross_validate_order_count(theta, error, folds=folds, max_order=limit)
        best = _one_standard_error_rule(cv_rms, cv_se, scale=np.sqrt(np.mean(error**2)))
        chosen = harmonics(theta, error, min(limit, stable)).top(counts[best])
        training = {"select": "cv", "folds": folds, "cv_rms_arcmin": [float(r) for r in cv_rms]}
    else:
        raise InputError(
            f"The 'select' parameter of fit_fourier must be 'top' or 'cv'. Got {select!r} instead."
        )
    cos, sin = fit_harmonic_series(theta, error, chosen, caller="fit_fourier")
    training.update(orders=[int(k) for k in chosen], max_order=int(limit))
    return FourierModel(chosen, cos, sin, training=training)


def cross_validate_order_count(theta_enc_deg, error_arcmin, *, folds=5, max_order=None):
    """Cross-validated RMS error of keeping the ``c`` largest harmonics, for every ``c``.

    The orders are ranked once, by the harmonic analysis of the whole profile
    (the paper's ranking); cross-validation chooses how many of them to keep.
    The distinct encoder angles, sorted around the circle, are dealt to the
    folds in turn (0, 1, ..., folds-1, 0, 1, ...), so every fold is spread
    evenly over the circle and the other folds still cover it; repeated
    readings of one angle stay in one fold. For each fold the ``c``
    top-ranked orders are fitted to the other folds, with the terms of the
    whole grid (a Nyquist order keeps its single term), and predict the
    held-out errors.

    Because the ranking has seen the held-out points, orders that only fit
    noise rank a little higher than they should and the curve favours
    keeping too many; :func:`fit_fourier` offsets this with the
    one-standard-error rule. Ranking inside each fold would avoid it, but a
    fold with a fifth of the points missing cannot see the orders near the
    Nyquist limit, which real profiles need (``docs/statistics.md``).

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees.
    error_arcmin : array-like of shape (n,)
        Errors in arc-minutes.
    folds : int, default=5
        Number of folds, 2 to the number of distinct angles.
    max_order : int, optional
        Highest order ranked; default :func:`~encal.profile.identifiable_order`.

    Returns
    -------
    counts : ndarray of int
        ``1, 2, ..., C``; ``C`` is the longest prefix of the ranking that
        every fold's training part identifies.
    cv_rms_arcmin : ndarray of float
        Cross-validated RMS error for each count (all held-out points pooled),
        in arc-minutes.
    cv_se_arcmin : ndarray of float
        Its standard error from the spread of the folds' mean squared
        errors, in arc-minutes.
    """
    theta, error = profile_arrays(theta_enc_deg, error_arcmin, "cross_validate_order_count")
    distinct, group = distinct_angles(theta)
    if not 2 <= folds <= distinct.size:
        raise InputError(
            f"cross-validation expects between 2 and {distinct.size} folds for "
            f"{distinct.size} distinct encoder angles; got {folds}"
        )
    limit = identifiable_order(theta) if max_order is None else min(max_order, identifiable_order(theta))
    ranking = harmonics(theta, error, limit).ranked()
    fold = (np.arange(distinct.size) % folds)[group]
    squared, sizes = [], []
    for f in range(folds):
        train, test = fold != f, fold == f
        cos, sin = nested_harmonic_fits(theta[train], error[train], ranking, grid_deg=theta)
        phase = np.radians(np.outer(ranking, theta[test]))
        predicted = cos @ np.cos(phase) + sin @ np.sin(phase)  # one row per count
        squared.append(np.sum((error[test] - predicted) ** 2, axis=1))
        sizes.append(test.sum())
    n_counts = min(s.size for s in squared)
    squared = np.array([s[:n_counts] for s in squared])
    rms = np.sqrt(squared.sum(axis=0) / theta.size)
    fold_mse = squared / np.array(sizes)[:, np.newaxis]
    mse_se = fold_mse.std(axis=0, ddof=1) / np.sqrt(folds)
    rms_se = mse_se / (2.0 * np.maximum(rms, np.finfo(float).tiny))  # delta method
    return np.arange(1, n_counts + 1), rms, rms_se


def _one_standard_error_rule(cv_rms, cv_se, scale):
    """Index of the smallest count within one standard error (or rounding of ``scale``) of the best."""
    best = int(np.argmin(cv_rms))
    threshold = cv_rms[best] + max(cv_se[best], 1e-9 * scale)
    return int(np.flatnonzero(cv_rms <= threshold)[0])


def _check_count(value, name, lowest):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lowest:
        raise InputError(
            f"The '{name}' parameter of fit_fourier must be an int >= {lowest}. Got {value!r} instead."
        )
    return int(value)


def _check_orders(orders, limit):
    values = np.asarray(orders).reshape(-1)
    upper = np.inf if limit is None else limit
    if (
        values.size == 0
        or not np.issubdtype(values.dtype, np.integer)
        or np.any(values < 0)
        or np.any(values > upper)
        or np.unique(values).size != values.size
    ):
        up_to = "" if limit is None else f" up to max_order={limit}"
        raise InputError(
            f"The 'orders' parameter of fit_fourier must hold distinct ints >= 0{up_to}. "
            f"Got {values.tolist()} instead."
        )
    return [int(k) for k in values]

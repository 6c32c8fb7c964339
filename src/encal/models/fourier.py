"""Fourier-series error model (Kaul et al. 2008; Eq. 3 of Dhar et al.).

``ε̂(θ) = Σ_k a_k cos(k θ) + b_k sin(k θ)`` over a chosen set of harmonic
orders ``k``, θ the encoder angle in radians. The paper keeps the ten
harmonics of largest amplitude (``select='top'``); encal can also choose how
many of them to keep by cross-validation (``select='cv'``).
"""

import numpy as np

from .._core.errors import InputError, ModelFileError
from ..numerics.harmonic_series import HarmonicSeries
from .._core.parameters import check_int
from ..analysis.profile import (
    distinct_angles,
    fit_harmonic_series,
    harmonic_series_and_order,
    identifiable_order,
    nested_harmonic_predictions,
    profile_arrays,
    rank_orders,
    uniform_grid,
)
from .base import Model
from .validation import held_out_predictions, interleaved_folds

__all__ = ["FourierModel", "fit_fourier", "MAX_ORDER"]

#: Largest order a model may hold: the highest a C ``int`` holds on every platform, which the C export
#: stores orders in. The model file's reader applies the same bound.
MAX_ORDER = 32767


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
    _harmonics = None  # the HarmonicSeries that evaluates it, planned on first use

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
            or np.any(orders > MAX_ORDER)
            or _repeats(orders)
        ):
            raise InputError(
                f"FourierModel expects distinct integer orders from 0 to {MAX_ORDER}; got {orders.tolist()}"
            )
        if not (np.all(np.isfinite(cos)) and np.all(np.isfinite(sin))):
            raise InputError("FourierModel expects finite coefficients in arc-minutes; got NaN or infinity")
        self.orders = orders.astype(int)
        self.cos = cos
        self.sin = np.where(self.orders == 0, 0.0, sin)

    def _predict(self, theta_deg):
        return self._series_evaluator()(np.radians(theta_deg))

    def _series_evaluator(self):
        """The :class:`~encal.numerics.harmonic_series.HarmonicSeries` of the coefficients (arc-minutes), which
        evaluates the series the cheapest way for its orders."""
        if self._harmonics is None:
            self._harmonics = HarmonicSeries(self.orders, self.cos, self.sin)
        return self._harmonics

    def _table_bound(self):
        from ._table import series_bound

        return series_bound(self.orders, self.cos, self.sin), 0.0

    def _correction_table(self):  # the nodes by one inverse FFT
        if self._table is False:
            from ._table import series_table

            self._table = series_table(self.orders, self.cos, self.sin) if self.orders.size else None
        return self._table

    def free_parameters(self):
        return sum(1 if k == 0 else 2 for k in self.orders.tolist())

    @property
    def evaluation_width(self):
        return self._series_evaluator().width

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


def _repeats(values):
    """Whether a 1-D array holds a value twice (without ``np.unique``, whose first call imports ``numpy.ma``:
    8 ms of ``encal correct``'s start-up)."""
    ordered = np.sort(values)
    return bool(np.any(ordered[1:] == ordered[:-1]))


def _reason(exc):
    return f"missing key {exc}" if isinstance(exc, KeyError) else str(exc)


def fit_fourier(theta_enc_deg, error_arcmin, *, orders=None, n_orders=10, select="top",
                max_order=None, folds=5, grid_points=None):
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
        :func:`~encal.analysis.profile.identifiable_order`): above it an order aliases
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
        :func:`~encal.analysis.profile.identifiable_order` of the angles (the Nyquist
        order on a uniform grid).
    folds : int, default=5
        Number of cross-validation folds for ``select='cv'``.
    grid_points : int, optional
        The angles lie on a uniform grid of ``grid_points`` nodes per
        revolution (each within a quarter of the spacing of its node), as
        the readings of a calibration at a motor's ``N`` full steps do, and
        any subset of them: at the nodes, orders up to ``grid_points // 2``
        are distinguishable, the Nyquist order ``N / 2`` with its single
        term locked to the grid. The orders (ranked, ``max_order``) may then
        go up to that order even when the angles are a subset of the grid
        with gaps, such as a cross-validation fold's training part; an order
        set that the occupied nodes cannot identify is refused (``orders``)
        or avoided (``select``; see :func:`~encal.analysis.profile.rank_orders`).
        ``fit_auto`` passes it for a calibration on a uniform grid. Between
        the nodes a Nyquist term interpolates a ``cos(N/2 · θ)`` wave: right
        when the per-step pattern it fits is real at the angles the model
        corrects, not for readings between the steps. Default: the angles'
        own grid (``identifiable_order``).

    Returns
    -------
    FourierModel
        With ``training = {'select': ..., 'orders': [...], ...}`` (and
        ``'grid_points'`` when it was given).

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
    nodes = _grid_nodes(theta, grid_points, "fit_fourier")
    if orders is not None and max_order is None and nodes is None:
        chosen = _check_orders(orders, None)
        cos, sin, stable = harmonic_series_and_order(theta, error, chosen, caller="fit_fourier")
        return _fourier_model(chosen, cos, sin, {"select": "explicit"}, stable, grid_points)
    stable = identifiable_order(theta) if nodes is None else nodes.size // 2
    limit = stable if max_order is None else check_int(max_order, "max_order", "fit_fourier", low=0)
    if orders is not None:
        chosen = _check_orders(orders, None if max_order is None else limit)
        training = {"select": "explicit"}
    elif select == "top":
        n_orders = check_int(n_orders, "n_orders", "fit_fourier", low=1)
        chosen = rank_orders(theta, error, min(limit, stable), grid_deg=nodes, count=n_orders)
        training = {"select": "top", "n_orders": n_orders}
    elif select == "cv":
        folds = check_int(folds, "folds", "fit_fourier", low=2)
        counts, cv_rms, cv_se = cross_validate_order_count(theta, error, folds=folds, max_order=limit,
                                                           grid_points=grid_points)
        best = _one_standard_error_rule(cv_rms, cv_se, scale=np.sqrt(np.mean(error**2)))
        chosen = rank_orders(theta, error, min(limit, stable), grid_deg=nodes, count=counts[best])
        training = {"select": "cv", "folds": folds, "cv_rms_arcmin": [float(r) for r in cv_rms]}
    else:
        raise InputError(
            f"The 'select' parameter of fit_fourier must be 'top' or 'cv'. Got {select!r} instead."
        )
    cos, sin = fit_harmonic_series(theta, error, chosen, caller="fit_fourier", grid_deg=nodes)
    return _fourier_model(chosen, cos, sin, training, limit, grid_points)


def _fourier_model(chosen, cos, sin, training, max_order, grid_points):
    training.update(orders=[int(k) for k in chosen], max_order=int(max_order))
    if grid_points is not None:
        training["grid_points"] = int(grid_points)
    return FourierModel(chosen, cos, sin, training=training)


def _grid_nodes(theta, grid_points, caller):
    """Nodes of the declared grid of ``grid_points``, or None when not declared or the angles fill it."""
    if grid_points is None:
        return None
    if isinstance(grid_points, bool) or not isinstance(grid_points, (int, np.integer)) or grid_points < 1:
        raise InputError(f"The 'grid_points' parameter of {caller} must be an int >= 1. "
                         f"Got {grid_points!r} instead.")
    n_distinct = distinct_angles(theta)[0].size
    nodes = uniform_grid(theta, grid_points) if grid_points >= n_distinct else None
    if nodes is None:
        raise InputError(f"{caller} was told the encoder angles lie on a uniform grid of {grid_points} "
                         f"points per revolution, but its {n_distinct} distinct angles do not (each must "
                         "be within a quarter of the spacing of its own node)")
    return None if n_distinct == grid_points else nodes


def cross_validate_order_count(theta_enc_deg, error_arcmin, *, folds=5, max_order=None, grid_points=None):
    """Cross-validated RMS error of keeping the ``c`` largest harmonics, for every ``c``.

    The orders are ranked as :func:`fit_fourier` ranks them (the paper's
    ranking by amplitude, :func:`~encal.analysis.profile.rank_orders`); cross-validation
    chooses how many of them to keep. The distinct encoder angles, sorted
    around the circle, are dealt to the folds in turn (0, 1, ..., folds-1,
    0, 1, ...), so every fold is spread evenly over the circle and the other
    folds still cover it; repeated readings of one angle stay in one fold.
    For each fold the ``c`` top-ranked orders are fitted to the other folds,
    with the terms of the whole grid (a Nyquist order keeps its single term),
    and predict the held-out errors; an order that a fold's training angles
    cannot identify together with the orders before it is left out of that
    fold's fits (see :func:`~encal.analysis.profile.nested_harmonic_predictions`). One
    QR per fold gives every count: O(n p²) for ``p`` terms.

    Counts are tried up to 64 orders first, and the range is doubled only
    while its upper half lowers the CV error by more than one standard error
    below the best of its lower half (less could not move the
    one-standard-error choice of :func:`fit_fourier` much), so a long ranking
    (a 10,000-point grid has 5,001 orders) costs only what the curve needs.

    Because the ranking has seen the held-out points, orders that only fit
    noise rank a little higher than they should and the curve favours
    keeping too many; :func:`fit_fourier` offsets this with the
    one-standard-error rule. On a proper subset of a declared grid
    (``grid_points``) the ranking is a greedy forward selection among up to
    ``N / 2`` orders, whose bias is far larger, so there each fold ranks its
    own training points. Ranking inside each fold everywhere was measured
    worse where a profile has many harmonics near the noise
    (``docs/model-selection.md`` gives both figures).

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees.
    error_arcmin : array-like of shape (n,)
        Errors in arc-minutes.
    folds : int, default=5
        Number of folds, 2 to the number of distinct angles.
    max_order : int, optional
        Highest order ranked; default :func:`~encal.analysis.profile.identifiable_order`,
        or ``grid_points // 2``.
    grid_points : int, optional
        The angles lie on a uniform grid of so many points (see :func:`fit_fourier`).

    Returns
    -------
    counts : ndarray of int
        ``1, 2, ..., C``.
    cv_rms_arcmin : ndarray of float
        Cross-validated RMS error for each count (all held-out points pooled),
        in arc-minutes.
    cv_se_arcmin : ndarray of float
        Its standard error from the spread of the folds' mean squared
        errors, in arc-minutes.
    """
    theta, error = profile_arrays(theta_enc_deg, error_arcmin, "cross_validate_order_count")
    distinct = distinct_angles(theta)[0]
    if distinct.size < 2:
        raise InputError("cross-validation expects at least 2 distinct encoder angles; "
                         f"got {theta.size} readings all at {distinct[0]:.9g} degrees")
    if not 2 <= folds <= distinct.size:
        raise InputError(
            f"cross-validation expects between 2 and {distinct.size} folds for "
            f"{distinct.size} distinct encoder angles; got {folds}"
        )
    nodes = _grid_nodes(theta, grid_points, "cross_validate_order_count")
    limit = identifiable_order(theta) if nodes is None else nodes.size // 2
    if max_order is not None:
        limit = min(max_order, limit)
    fold = interleaved_folds(theta, folds)
    count = min(_FIRST_COUNT, limit + 1)
    while True:
        ranking = None if nodes is not None else rank_orders(theta, error, limit, count=count)
        rms, rms_se = _cv_curve(theta, error, fold, ranking, theta if nodes is None else nodes, limit, count)
        if ranking is None:
            ranking = range(rms.size)
        half = rms.size // 2
        best = int(np.argmin(rms[:half])) if half else 0
        # More counts could move the one-standard-error choice only by beating the best of the
        # lower half by more than its standard error.
        if len(ranking) < count or count > limit or rms.min() >= rms[best] - rms_se[best]:
            return np.arange(1, rms.size + 1), rms, rms_se
        count = min(2 * count, limit + 1)


#: Counts that cross_validate_order_count tries first (then doubled as the curve needs).
_FIRST_COUNT = 64


def _cv_curve(theta, error, fold, ranking, grid_deg, limit=None, count=None):
    """Pooled CV RMS and its standard error (arcmin) for every prefix of ``ranking``.

    With ``ranking=None`` each fold ranks its own training points (forward selection on
    the grid of ``grid_deg``, up to ``count`` orders of at most ``limit``).
    """
    lengths = []

    def fit_predict(k, train_theta, train_error, test_theta):
        ranked = ranking
        if ranked is None:
            ranked = rank_orders(train_theta, train_error, limit, grid_deg=grid_deg, count=count)
        predicted = nested_harmonic_predictions(train_theta, train_error, ranked, test_theta, grid_deg=grid_deg)
        if ranking is None and len(ranked) < count:  # the fold's points are exhausted
            predicted = np.vstack([predicted, np.repeat(predicted[-1:], count - len(ranked), axis=0)])
        lengths.append(len(ranked))
        return predicted

    predicted = held_out_predictions(fit_predict, theta, error, fold)
    tests = [fold == k for k in range(fold.max() + 1)]
    # Row by row in memory (a boolean column index gives a column-major copy), as every fold's own fit gave
    # them: the sums then add in the same order.
    squared = [np.sum((error[test] - np.ascontiguousarray(predicted[:, test])) ** 2, axis=1) for test in tests]
    sizes = [test.sum() for test in tests]
    longest = max(lengths)
    squared = np.array(squared)[:, :longest]
    rms = np.sqrt(squared.sum(axis=0) / theta.size)
    fold_mse = squared / np.array(sizes)[:, np.newaxis]
    mse_se = fold_mse.std(axis=0, ddof=1) / np.sqrt(squared.shape[0])
    rms_se = mse_se / (2.0 * np.maximum(rms, np.finfo(float).tiny))  # delta method
    return rms, rms_se


def _one_standard_error_rule(cv_rms, cv_se, scale):
    """Index of the smallest count within one standard error (or rounding of ``scale``) of the best."""
    best = int(np.argmin(cv_rms))
    threshold = cv_rms[best] + max(cv_se[best], 1e-9 * scale)
    return int(np.flatnonzero(cv_rms <= threshold)[0])


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

"""The spectral model's prior learned from a fleet: empirical Bayes over units.

The spectral model (:mod:`encal.models.spectral`) puts independent zero-mean Gaussian priors on the
Fourier coefficients of one unit, with a variance per order chosen from that unit's own data. Units
of one kind, built and mounted alike, share much of their error: the same orders, often the same
phases. :class:`FleetPrior` is that prior learned from the fleet instead: per order ``k`` the mean of
the coefficients ``(a_k, b_k)`` across units and their 2x2 covariance across units (empirical Bayes: the
units are draws from the prior, so its moments are estimated from them; a unit's gain or a design's
quadrature moves one of ``a_k, b_k`` more than the other, so the two need not spread alike). A new unit of the same
kind is then the fleet's mean profile plus what its own readings show, and a few readings, or a
partial sweep, suffice where the unit alone needs a full turn.

:func:`fit_with_prior` is the posterior of a new unit under the fleet prior (Gaussian linear
regression, closed form), the noise ``σ`` chosen by its marginal likelihood (type-II maximum likelihood, as the
spectral model chooses its own), the zero offset under a flat prior (a motor's zero is arbitrary). A unit may be
louder or quieter than the fleet: its prior covariance is a scale ``s`` times the fleet's, ``s`` drawn from how
loud the fleet's own units are against the fleet's robust spread (a heavy-tailed hyperprior learned with the
prior) and averaged over, so that the posterior standard deviation, and the held-out estimate a unit is graded by,
hold what a partial calibration leaves unknown of ``s``. It returns a
:class:`~encal.models.spectral.SpectralModel`: the same model file, the same posterior standard deviation,
read and evaluated as every spectral model is.

``benchmarks/bench_fleet_prior.py`` measures its accuracy leave-one-out on the 60 real Mechaduino boards and on
simulated lots, ``benchmarks/bench_fleet_prior_claim.py`` what its units claim against their truth
(docs/production.md, "A fleet prior").
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_triangular

from .._core.errors import InputError
from .._core.parameters import check_number, check_type, real_array
from ..models.base import Model
from .._core.threads import single_blas_thread

__all__ = ["FleetPrior", "StorePrior", "fleet_prior", "fit_with_prior", "MIN_UNITS", "LEAVE_ONE_OUT_UNITS",
           "DEFAULT_ORDERS", "ALIAS_RATIO"]

#: Fewest units a fleet prior is learned from.
MIN_UNITS = 5
#: Up to this many units to learn from, a unit in the store is fitted under the prior of the others
#: (:class:`StorePrior`), learned again for it: 9 ms of CPU a unit at 1000 units, 84 ms at 10,000, more than the fit.
#: Above it, one record of so many moves the prior by little: removing one unit of 1001 (60 orders, Gaussian)
#: moved an order's mean by at most 0.57 % of its spread and its variance by 1.0 % (0.056 % and 0.12 % of 10,001;
#: ``python benchmarks/bench_fleet_prior_feedback.py``).
LEAVE_ONE_OUT_UNITS = 1000
#: Highest order of a fleet prior unless named (profiles are compared on 360 points).
DEFAULT_ORDERS = 60
#: Prior variance of the zero offset (arcmin²): flat for any offset of a turn.
_FLAT_VARIANCE = 1e12
#: Smallest prior variance of an order (arcmin²), so that the fleet never forbids what its units did not show.
_MIN_VARIANCE = 1e-8
#: How far the noise search goes either side of the fleet's median noise (a factor).
_NOISE_RANGE = 100.0
#: How far a unit's scale of the fleet's spread goes either side of 1 (a factor).
_SCALE_RANGE = 30.0
#: On regular stops, an order past their Nyquist order is fitted (not held at the fleet's mean) when the fleet's
#: variance there is more than this many times that of the order it aliases onto: the fleet then says which of
#: the two carries the harmonic (``benchmarks/bench_fleet_prior.py --alias-ratio``: a quarter of the simulated
#: lot's points is 1.89x its full calibration with 1, 2.12x with 2, which holds its order 48, about twice the
#: variance of its alias, order 3).
ALIAS_RATIO = 1.0
#: Smallest spread of the log of a unit's scale in a fleet prior's hyperprior: units that all look alike in the fleet
#: still leave a new unit's scale uncertain by this much (about the sampling spread of a scale from 60 orders).
_MIN_LOG_SCALE_STD = 0.1
#: Points of the grid over the log of a unit's scale (from 1/_SCALE_RANGE to _SCALE_RANGE) that the posterior is
#: averaged over: 0.057 apart.
_SCALE_POINTS = 121
#: Degrees of freedom of the Student's t hyperprior on the log of a unit's scale.
_SCALE_DOF = 3.0
#: Median absolute deviation to standard deviation, for a normal distribution.
_MAD_TO_STD = 1.4826


def _golden(function, low, high, steps=25):
    """The maximum of ``function`` on [low, high] by golden-section search."""
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    for _ in range(steps):
        a, b = high - ratio * (high - low), low + ratio * (high - low)
        if function(a) > function(b):
            high = b
        else:
            low = a
    return 0.5 * (low + high)


@dataclass(frozen=True)
class FleetPrior:
    """A Gaussian prior on a unit's Fourier coefficients, learned from a fleet.

    Attributes
    ----------
    orders : ndarray of shape (K,)
        Orders 1..K.
    mean_cos, mean_sin : ndarray of shape (K,)
        The fleet's mean coefficients (arc-minutes).
    variance : ndarray of shape (K,)
        The variance of a coefficient across units at each order (arcmin², the mean of cos and sin).
    noise_std_arcmin : float
        The fleet's median noise (the noise search starts there).
    units : int
        Units it was learned from.
    variance_cos, variance_sin, covariance_cos_sin : ndarray of shape (K,), optional
        The 2x2 covariance of ``(a_k, b_k)`` across units at each order (arcmin²); default ``variance``,
        ``variance`` and 0 (the two alike and independent).
    """

    orders: np.ndarray
    mean_cos: np.ndarray
    mean_sin: np.ndarray
    variance: np.ndarray
    noise_std_arcmin: float
    units: int
    variance_cos: np.ndarray | None = None
    variance_sin: np.ndarray | None = None
    covariance_cos_sin: np.ndarray | None = None
    log_scale_mean: float | None = None
    log_scale_std: float | None = None

    def blocks(self):
        """``(var_cos, var_sin, cov_cos_sin)``, each of shape (K,), arcmin²: the prior's 2x2 block at each order."""
        variance = np.asarray(self.variance, dtype=float)
        cos = variance if self.variance_cos is None else np.asarray(self.variance_cos, dtype=float)
        sin = variance if self.variance_sin is None else np.asarray(self.variance_sin, dtype=float)
        cross = np.zeros_like(variance) if self.covariance_cos_sin is None else np.asarray(self.covariance_cos_sin,
                                                                                            dtype=float)
        return cos, sin, cross

    def as_dict(self):
        """JSON-ready."""
        cos, sin, cross = self.blocks()
        return {"orders": [int(k) for k in self.orders], "mean_cos": [float(v) for v in self.mean_cos],
                "mean_sin": [float(v) for v in self.mean_sin], "variance": [float(v) for v in self.variance],
                "variance_cos": [float(v) for v in cos], "variance_sin": [float(v) for v in sin],
                "covariance_cos_sin": [float(v) for v in cross],
                "noise_std_arcmin": float(self.noise_std_arcmin), "units": int(self.units),
                "log_scale_mean": None if self.log_scale_mean is None else float(self.log_scale_mean),
                "log_scale_std": None if self.log_scale_std is None else float(self.log_scale_std)}


def _robust_variance(values):
    """Variance across units (axis 0) from the median absolute deviation: a few units far off do not widen it."""
    deviation = np.median(np.abs(values - np.median(values, axis=0)), axis=0)
    return (_MAD_TO_STD * deviation) ** 2


def _robust_block(cos, sin):
    """Robust 2x2 covariance of ``(cos, sin)`` across units (axis 0), per order.

    The variances from the median absolute deviation; the correlation from those of the sum and the
    difference of the standardised parts (Gnanadesikan and Kettenring: ``cov(u, w) = (var(u + w) -
    var(u - w)) / 4`` for unit variances, here in its normalised form ``(var(u + w) - var(u - w)) / (var(u + w) +
    var(u - w))``), kept inside (-1, 1) so that every block is positive definite.
    """
    var_cos, var_sin = _robust_variance(cos), _robust_variance(sin)
    std_cos, std_sin = np.sqrt(np.maximum(var_cos, _MIN_VARIANCE)), np.sqrt(np.maximum(var_sin, _MIN_VARIANCE))
    u, w = cos / std_cos, sin / std_sin
    plus, minus = _robust_variance(u + w), _robust_variance(u - w)
    correlation = np.clip((plus - minus) / np.maximum(plus + minus, 1e-300), -0.99, 0.99)
    var_cos, var_sin = np.maximum(var_cos, _MIN_VARIANCE), np.maximum(var_sin, _MIN_VARIANCE)
    return var_cos, var_sin, correlation * np.sqrt(var_cos * var_sin)


@single_blas_thread
def fleet_prior(models, *, orders=DEFAULT_ORDERS, points=360):
    """Learn the prior from the fitted models of a fleet's units.

    Parameters
    ----------
    models : sequence of Model
        One per unit (a full calibration each), e.g. ``[r.model() for r in store.latest_records()]``; a model of an
        arc, or one fitted under a fleet prior itself, is left out.
    orders : int, default=DEFAULT_ORDERS
        Highest order.
    points : int, default=360
        Each model is evaluated on this many encoder angles.

    Returns
    -------
    FleetPrior

    Raises
    ------
    InputError
        With fewer than :data:`MIN_UNITS` models.
    """
    given = len(models)
    for number, model in enumerate(models):
        check_type(model, Model, f"models[{number}]", "fleet_prior", "a Model")
    models = [model for model in models if _learns(model)]
    if len(models) < MIN_UNITS:
        raise InputError(_too_few(len(models), given))
    coefficients, noises = _unit_harmonics(models, orders, points)
    return _prior_of(coefficients, noises)


def _learns(model):
    """Whether a fleet prior learns from ``model``: a model of the whole turn (an arc's is NaN off the arc) fitted on
    its unit's own data, not under a fleet prior.

    A unit fitted under the prior (a quarter turn) is drawn to the fleet's mean by it: learned from again, it narrows
    the fleet's spread, and every later unit's held-out estimate (what it is graded by) claims too little. A store of
    20 units calibrated in full and 40 fitted from a quarter turn under their prior halved the variance of orders 1
    and 2; 20 new units' median held-out estimate under it was 1.20 arcmin, their true error 1.68 (1.91 and 1.53
    under the prior of the 20 alone; ``benchmarks/bench_fleet_prior_feedback.py``).
    """
    return model.range_deg is None and not (getattr(model, "training", None) or {}).get("fleet_prior")


def _too_few(count, given):
    """The refusal of a fleet prior with ``count`` models to learn from among ``given``."""
    return (f"a fleet prior needs {MIN_UNITS} or more units calibrated over the whole turn and fitted on their own "
            f"data; got {count}" + (f" ({given - count} of {given} calibrated over an arc or fitted under a fleet "
                                    "prior themselves, left out)" if given > count else ""))


def _unit_harmonics(models, orders, points):
    """Each model's harmonics (complex, arc-minutes; zero offset removed) and its noise (NaN when it holds none)."""
    from .statistics import harmonics

    grid = np.arange(points) * (360.0 / points)
    profiles = np.array([np.asarray(m.predict(grid), dtype=float) for m in models]).reshape(len(models), points)
    noises = np.array([m.uncertainty["noise_std_arcmin"] if getattr(m, "uncertainty", None) and
                       "noise_std_arcmin" in m.uncertainty else np.nan for m in models], dtype=float)
    return harmonics(profiles - profiles.mean(axis=1, keepdims=True), orders), noises


def _prior_of(coefficients, noises):
    """The prior of units with these harmonics (n, K) and noises (n,; NaN for none)."""
    # robust moments: a few units far off (a bad mount, a prototype) must not widen the prior of every unit.
    mean = np.median(coefficients.real, axis=0) + 1j * np.median(coefficients.imag, axis=0)
    var_cos, var_sin, cross = _robust_block(coefficients.real, coefficients.imag)
    known = noises[np.isfinite(noises)]
    noise = float(np.median(known)) if known.size else 0.1
    log_scales = np.log(_unit_scales(coefficients, mean, var_cos, var_sin, cross))
    centre = float(np.median(log_scales))
    spread = max(_MAD_TO_STD * float(np.median(np.abs(log_scales - centre))), _MIN_LOG_SCALE_STD)
    return FleetPrior(np.arange(1, coefficients.shape[1] + 1), mean.real.copy(), mean.imag.copy(),
                      0.5 * (var_cos + var_sin), max(noise, 1e-6), len(coefficients), var_cos, var_sin, cross,
                      centre, spread)


def _unit_scales(coefficients, mean, var_cos, var_sin, cross):
    """Each unit's scale of the fleet's spread: the mean over orders of its squared Mahalanobis distance per part.

    The maximum-likelihood ``s`` of a unit's coefficients under the prior covariance ``s`` times the fleet's: 1 on
    average for units of a Gaussian fleet, more where the fleet's tails are heavier than its robust spread says.
    Orders where the fleet does not spread (at :data:`_MIN_VARIANCE`) say nothing of a unit's loudness and are left
    out; with none left every scale is 1.
    """
    spreads = (var_cos > _MIN_VARIANCE) | (var_sin > _MIN_VARIANCE)
    if not np.any(spreads):
        return np.ones(coefficients.shape[0])
    cos, sin = coefficients.real - mean.real, coefficients.imag - mean.imag
    determinant = var_cos * var_sin - cross**2
    distance = (var_sin * cos**2 - 2.0 * cross * cos * sin + var_cos * sin**2) / determinant
    return np.maximum(np.mean(distance[:, spreads], axis=1) / 2.0, 1e-12)


class StorePrior:
    """The fleet prior of a store's units, each unit fitted under the prior of the *other* units.

    A unit recalibrated against a store that holds its earlier calibration (``encal fleet fit NEW/ --prior-from
    STORE`` with STORE its ``--store``, or the lot's own store) would otherwise be fitted under a prior learned
    partly from itself: its posterior drawn toward its own earlier profile (a drift shrunk), its held-out estimate
    claiming an independence it does not have. :meth:`for_unit` leaves out every record of the unit's serial
    number and every record of the same calibration bytes (SHA-256) under any serial, in a store of up to
    :data:`LEAVE_ONE_OUT_UNITS` units to learn from (above, the whole store's prior, which one unit barely moves).

    Parameters
    ----------
    records : sequence of encal.store.Record
        The latest record of every unit (``store.latest_records()``); those of an arc, and those fitted under a fleet
        prior themselves, are left out (:func:`fleet_prior`).
    orders, points
        As :func:`fleet_prior`.

    Raises
    ------
    InputError
        With fewer than :data:`MIN_UNITS` units calibrated over the whole turn.
    """

    def __init__(self, records, *, orders=DEFAULT_ORDERS, points=360):
        pairs = [(record, record.model()) for record in records]
        given = len(pairs)
        pairs = [(record, model) for record, model in pairs if _learns(model)]
        if len(pairs) < MIN_UNITS:
            raise InputError(_too_few(len(pairs), given))
        self._serials = np.array([record.serial for record, _ in pairs], dtype=object)
        self._sha256 = np.array([record.source_sha256 for record, _ in pairs], dtype=object)
        self._coefficients, self._noises = _unit_harmonics([model for _, model in pairs], orders, points)
        self.prior = _prior_of(self._coefficients, self._noises)
        self._cache = {}

    @property
    def units(self):
        """Units the whole prior is learned from."""
        return self.prior.units

    def for_unit(self, serial, sha256s=()):
        """The prior learned from every unit but ``serial`` and any record of the calibrations ``sha256s``.

        Raises
        ------
        InputError
            When fewer than :data:`MIN_UNITS` units are left.
        """
        keep = (self._serials != serial) & ~np.isin(self._sha256, [s for s in sha256s if s is not None])
        if keep.all() or self.units > LEAVE_ONE_OUT_UNITS:
            return self.prior
        key = tuple(np.flatnonzero(~keep))
        if key not in self._cache:
            if keep.sum() < MIN_UNITS:
                raise InputError(f"the fleet prior without {serial}'s own records holds {int(keep.sum())} units "
                                 f"to learn from; expected {MIN_UNITS} or more (a unit is never fitted under a prior "
                                 "learned from itself: --prior-from a store of more units)")
            self._cache[key] = _prior_of(self._coefficients[keep], self._noises[keep])
        return self._cache[key]


def _design(theta_deg, orders):
    theta = np.radians(np.asarray(theta_deg, dtype=float))
    angles = np.multiply.outer(theta, orders)
    return np.column_stack([np.ones_like(theta), np.cos(angles), np.sin(angles)])


def _prior_precision(var_cos, var_sin, cross):
    """Precision of the prior on ``(offset, a_1..a_K, b_1..b_K)`` and the log determinant of its 2x2 blocks."""
    orders = var_cos.size
    determinant = var_cos * var_sin - cross**2
    precision = np.zeros((2 * orders + 1, 2 * orders + 1))
    precision[0, 0] = 1.0 / _FLAT_VARIANCE
    cos, sin = np.arange(1, orders + 1), np.arange(orders + 1, 2 * orders + 1)
    precision[cos, cos], precision[sin, sin] = var_sin / determinant, var_cos / determinant
    precision[cos, sin] = precision[sin, cos] = -cross / determinant
    return precision, float(np.sum(np.log(determinant)))


def _posterior(gram, projected, residual_square, n, prior_precision, prior_log_det, noise_var):
    """Posterior mean offset from the prior mean, Cholesky factor of the posterior precision, log evidence.

    ``gram`` is ``X'X``, ``projected`` ``X'r`` and ``residual_square`` ``r'r`` for the design ``X`` and the
    residual ``r`` of the readings from the prior mean; the log evidence is up to the flat offset's constant.
    """
    precision = prior_precision + gram / noise_var
    cholesky = np.linalg.cholesky(precision)
    solved = solve_triangular(cholesky, projected / noise_var, lower=True)
    shift = solve_triangular(cholesky, solved, lower=True, trans="T")
    log_det = 2.0 * np.sum(np.log(np.diag(cholesky))) + prior_log_det + n * math.log(noise_var)
    quadratic = residual_square / noise_var - solved @ solved
    log_evidence = -0.5 * (quadratic + log_det + n * math.log(2.0 * math.pi))
    return shift, cholesky, log_evidence


def _held_orders(theta_deg, orders, variance):
    """Which orders are held at the fleet's mean: past the Nyquist order of regular stops, unless the fleet says.

    On ``m`` regular stops over the turn an order ``k`` takes the values of its alias ``|k - j m|`` (the
    nearest multiple ``j m``): the data show only their sum. Such an order is held at the fleet's mean, its alias
    taking the data, unless the fleet's variance at ``k`` is more than :data:`ALIAS_RATIO` times that of its
    alias: then the fleet knows which of the two carries the harmonic and the posterior splits the data by their
    variances. A multiple of ``m`` aliases onto the flat offset and is always held. What the rule gains and costs
    is measured in docs/production.md ("A fleet prior"). Stops over part of a turn, or uneven, do not alias so and
    hold nothing.
    """
    from ..analysis.profile import distinct_angles

    held = np.zeros(orders.size, dtype=bool)
    stops = distinct_angles(np.mod(theta_deg, 360.0))[0]
    spacing = np.diff(np.r_[stops, stops[0] + 360.0])
    if stops.size < 3 or np.max(spacing) >= 1.5 * 360.0 / stops.size:  # not about evenly over the whole turn
        return held
    m = stops.size
    by_order = dict(zip((int(k) for k in orders), variance))
    for index, order in enumerate(int(k) for k in orders):
        if order <= (m - 1) // 2:
            continue
        folded = order % m
        alias = min(folded, m - folded)
        # the offset (alias 0) is flat, and the Nyquist order (m even) is its own alias
        held[index] = alias == 0 or alias == order or not variance[index] > ALIAS_RATIO * by_order.get(alias, np.inf)
    return held


def _held_variance(grid, gram, cholesky, noise_var, held, blocks, scale):
    """Variance (arcmin², at each row of ``grid``) of the error that the orders held at the fleet's mean leave.

    A held order is not fitted, but the unit's own coefficients there depart from the fleet's mean by its spread
    (``blocks``, the prior's 2x2 blocks of the held orders, times the unit's ``scale``); those departures reach the
    fit through the orders they alias onto, and the model's error between the stops is the linear map
    ``grid A⁻¹ X'X_held / σ² - grid_held`` of them (``A = L L'`` the posterior precision). Without it the band
    claimed the posterior of orders that take, at the stops, harmonics they do not have between them.
    """
    if not np.any(held):
        return 0.0
    count = held.size
    columns = np.r_[1 + np.flatnonzero(held), 1 + count + np.flatnonzero(held)]
    reach = solve_triangular(cholesky, solve_triangular(cholesky, gram[:, columns], lower=True), lower=True,
                             trans="T") / noise_var
    effect = grid @ reach - grid[:, columns]  # (points, 2H): cos parts, then sin parts
    var_cos, var_sin, cross = (scale * np.asarray(b, dtype=float) for b in blocks)
    first, other = effect[:, :var_cos.size], effect[:, var_cos.size:]
    return np.sum(first**2 * var_cos + 2.0 * first * other * cross + other**2 * var_sin, axis=1)


@single_blas_thread
def fit_with_prior(theta_enc_deg, error_arcmin, prior, *, noise_arcmin=None):
    """Fit one unit under a fleet prior: the posterior mean of its coefficients.

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees (any subset of a turn: a few points, a partial sweep).
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.
    prior : FleetPrior
    noise_arcmin : float, optional
        The noise of one reading when known; default chosen by the marginal likelihood.

    Returns
    -------
    SpectralModel
        With its posterior standard deviation (``uncertainty``: of the shape about the zero offset, as
        :func:`~encal.models.spectral.fit_spectral`'s, averaged over the unit's scale of the fleet's spread, and
        holding what the orders held at the fleet's mean leave between the stops) and ``training['prior']`` saying it
        is the fleet's; ``training['fleet_prior']['spread_scale']`` is the scale's most probable value,
        ``training['fleet_prior']['offset_std_arcmin']`` the zero offset's posterior standard deviation (arc-minutes),
        for a reference whose zero is fixed.

    Raises
    ------
    InputError
        With fewer than 2 readings, or readings that are not finite.
    """
    from ..models.spectral import SpectralModel

    check_type(prior, FleetPrior, "prior", "fit_with_prior", "a FleetPrior (from fleet_prior)")
    theta = real_array(theta_enc_deg, "theta_enc_deg", "fit_with_prior", "encoder angles in degrees").reshape(-1)
    error = real_array(error_arcmin, "error_arcmin", "fit_with_prior", "errors in arc-minutes").reshape(-1)
    if noise_arcmin is not None:
        noise_arcmin = check_number(noise_arcmin, "noise_arcmin", "fit_with_prior", low=0.0, low_open=True,
                                    note="the noise of one reading in arc-minutes, or None")
    if theta.size != error.size or theta.size < 2 or not (np.all(np.isfinite(theta)) and np.all(np.isfinite(error))):
        raise InputError(f"fit_with_prior expects 2 or more finite readings, as many angles as errors; got "
                         f"{theta.size} angles and {error.size} errors")
    orders = np.asarray(prior.orders)
    var_cos, var_sin, cross = prior.blocks()
    held = _held_orders(theta, orders, 0.5 * (var_cos + var_sin))
    held_blocks = var_cos[held], var_sin[held], cross[held]
    var_cos, var_sin = np.where(held, _MIN_VARIANCE, var_cos), np.where(held, _MIN_VARIANCE, var_sin)
    cross = np.where(held, 0.0, cross)
    design = _design(theta, orders)
    prior_mean = np.r_[0.0, prior.mean_cos, prior.mean_sin]
    residual = error - design @ prior_mean
    gram, projected, residual_square = design.T @ design, design.T @ residual, float(residual @ residual)
    precision, log_det = _prior_precision(var_cos, var_sin, cross)
    spread = 2 * orders.size  # coefficients whose prior the unit's scale multiplies (all but the flat offset)

    # the noise σ by type-II maximum likelihood (unless known); the unit's scale s of the fleet's spread (a unit may be
    # louder or quieter than the fleet: its prior covariance is s times the fleet's) drawn from the fleet's own
    # spread of scales (its hyperprior) and averaged over: a quarter turn pins s down poorly, and its single best
    # value shrank the band where the data say nothing
    def posterior(log_sigma, log_scale):
        scaled = precision * math.exp(-log_scale)
        scaled[0, 0] = precision[0, 0]
        return _posterior(gram, projected, residual_square, error.size, scaled, log_det + spread * log_scale,
                          math.exp(2 * log_sigma))

    scale_low, scale_high = -math.log(_SCALE_RANGE), math.log(_SCALE_RANGE)

    def hyperprior(log_scale):  # Student's t on the log scale: a unit far louder than the fleet is fitted as loud
        if prior.log_scale_mean is None:
            return 0.0
        standard = (log_scale - float(prior.log_scale_mean)) / float(prior.log_scale_std)
        return -0.5 * (_SCALE_DOF + 1.0) * math.log1p(standard**2 / _SCALE_DOF)

    def evidence(log_sigma, log_scale):
        return posterior(log_sigma, log_scale)[2] + hyperprior(log_scale)

    if noise_arcmin is not None:
        sigmas = np.array([math.log(float(noise_arcmin))])
        source = "supplied"
    else:
        centre_sigma = math.log(prior.noise_std_arcmin)
        sigmas = centre_sigma + np.linspace(-math.log(_NOISE_RANGE), math.log(_NOISE_RANGE), 21)
        source = "marginal likelihood under the fleet prior"
    scales = np.linspace(scale_low, scale_high, 13)
    values = np.array([[evidence(g, c) for c in scales] for g in sigmas])
    best_sigma, best_scale = np.unravel_index(int(np.argmax(values)), values.shape)
    log_sigma, log_scale = float(sigmas[best_sigma]), float(scales[best_scale])
    for _ in range(2):  # alternate golden-section refinements about the best grid point
        if sigmas.size > 1:
            log_sigma = _golden(lambda g: evidence(g, log_scale), log_sigma - (sigmas[1] - sigmas[0]),
                                log_sigma + (sigmas[1] - sigmas[0]))
        log_scale = _golden(lambda c: evidence(log_sigma, c), log_scale - (scales[1] - scales[0]),
                            log_scale + (scales[1] - scales[0]))
    noise_var = math.exp(2 * log_sigma)
    # the posterior averaged over the scale (its weights: evidence times hyperprior, on a grid); the band is of the
    # shape about the offset, as fit_spectral's (a motor's zero is set at run time): the offset's column is out of
    # the grid, its own posterior variance kept apart (``offset_std_arcmin``)
    grid = _design(np.arange(360) * 1.0, orders)
    grid[:, 0] = 0.0
    offset_row = np.eye(1, prior_mean.size)
    averaged = np.linspace(scale_low, scale_high, _SCALE_POINTS)
    weights = np.array([evidence(log_sigma, c) for c in averaged])
    weights = np.exp(weights - weights.max())
    # the scales of negligible weight are left out and the others' weights renormalised: the moments below are raw
    # (second minus mean squared), and weights summing to 1 - ε left ε times the mean's square in the variance (a real
    # board's arbitrary zero of -3792 arcmin: a phantom 6.4 arcmin in its band)
    kept = weights >= 1e-6 * weights.sum()
    averaged, weights = averaged[kept], weights[kept] / weights[kept].sum()
    shift, second = np.zeros(prior_mean.size), np.zeros(grid.shape[0])
    offset_second = 0.0
    log_evidence = posterior(log_sigma, log_scale)[2]
    for weight, value in zip(weights, averaged):
        shift_at, cholesky, _ = posterior(log_sigma, value)
        at_grid = grid @ shift_at
        shift += weight * shift_at
        second += weight * (np.sum(solve_triangular(cholesky, grid.T, lower=True) ** 2, axis=0) + at_grid**2
                            + _held_variance(grid, gram, cholesky, noise_var, held, held_blocks, math.exp(value)))
        offset_second += weight * (float(np.sum(solve_triangular(cholesky, offset_row.T, lower=True) ** 2))
                                   + shift_at[0] ** 2)
    variance = np.maximum(second - (grid @ shift) ** 2, 0.0)  # the law of total variance over the scale
    offset_std = math.sqrt(max(offset_second - shift[0] ** 2, 0.0))
    mean = prior_mean + shift
    all_orders = np.r_[0, orders]
    cos = np.r_[mean[0], mean[1:orders.size + 1]]
    sin = np.r_[0.0, mean[orders.size + 1:]]
    training = {
        "select": "fleet prior",
        "prior": (f"the fleet's: the mean and the 2x2 covariance of each order 1..{int(orders.max())} across "
                  f"{prior.units} units (empirical Bayes), the zero offset flat"),
        "noise": {"source": source, "std_arcmin": math.sqrt(noise_var)},
        "fleet_prior": {"units": int(prior.units), "orders": int(orders.max()), "spread_scale": math.exp(log_scale),
                        "held_orders": [int(k) for k in orders[held]], "offset_std_arcmin": offset_std},
        "log_evidence_nats": float(log_evidence),
        "stops": int(np.unique(np.round(theta, 9)).size),
    }
    model = SpectralModel(all_orders, cos, sin, training=training)
    model.uncertainty = {"method": "posterior", "grid_step_deg": 1.0,
                         "model_std_arcmin": [float(v) for v in np.sqrt(variance)],
                         "noise_std_arcmin": math.sqrt(noise_var)}
    return model

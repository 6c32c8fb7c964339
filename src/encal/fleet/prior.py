"""The spectral model's prior learned from a fleet: empirical Bayes over units.

The spectral model (:mod:`encal.models.spectral`) puts independent zero-mean Gaussian priors on the
Fourier coefficients of one unit, with a variance per order chosen from that unit's own data. Units
of one kind, built and mounted alike, share much of their error: the same orders, often the same
phases. :class:`FleetPrior` is that prior learned from the fleet instead: per order ``k`` the mean of
the coefficients ``(a_k, b_k)`` across units and their variance across units (empirical Bayes: the
units are draws from the prior, so its moments are estimated from them). A new unit of the same
kind is then the fleet's mean profile plus what its own readings show, and a few readings, or a
partial sweep, suffice where the unit alone needs a full turn.

:func:`fit_with_prior` is the posterior of a new unit under the fleet prior (Gaussian linear
regression, closed form), the noise ``σ`` and a scale of the fleet's spread for this unit chosen by
their marginal likelihood (type-II maximum likelihood, as the spectral model chooses its own), the
zero offset under a flat prior (a motor's zero is arbitrary). It returns a :class:`~encal.models.spectral.SpectralModel`: the same model file,
the same posterior standard deviation, read and evaluated as every spectral model is.

``benchmarks/bench_fleet_prior.py`` measures it leave-one-out on the 60 real Mechaduino boards and on
simulated lots (docs/production.md, "A fleet prior").
"""

import math
from dataclasses import dataclass

import numpy as np

from .._core.errors import InputError

__all__ = ["FleetPrior", "fleet_prior", "fit_with_prior", "MIN_UNITS", "DEFAULT_ORDERS"]

#: Fewest units a fleet prior is learned from.
MIN_UNITS = 5
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
    """

    orders: np.ndarray
    mean_cos: np.ndarray
    mean_sin: np.ndarray
    variance: np.ndarray
    noise_std_arcmin: float
    units: int

    def as_dict(self):
        """JSON-ready."""
        return {"orders": [int(k) for k in self.orders], "mean_cos": [float(v) for v in self.mean_cos],
                "mean_sin": [float(v) for v in self.mean_sin], "variance": [float(v) for v in self.variance],
                "noise_std_arcmin": float(self.noise_std_arcmin), "units": int(self.units)}


def fleet_prior(models, *, orders=DEFAULT_ORDERS, points=360):
    """Learn the prior from the fitted models of a fleet's units.

    Parameters
    ----------
    models : sequence of Model
        One per unit (a full calibration each), e.g. ``[r.model() for r in store.latest_records()]``.
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
    from .statistics import harmonics

    models = [model for model in models if model.range_deg is None]  # an arc's model is NaN off the arc
    if len(models) < MIN_UNITS:
        raise InputError(f"a fleet prior needs {MIN_UNITS} or more units calibrated over the whole turn; got "
                         f"{len(models)}")
    grid = np.arange(points) * (360.0 / points)
    profiles = np.array([np.asarray(m.predict(grid), dtype=float) for m in models])
    coefficients = harmonics(profiles - profiles.mean(axis=1, keepdims=True), orders)
    # robust moments: a few units far off (a bad mount, a prototype) must not widen the prior of every unit.
    # The median of the cos and sin coefficients; for a complex Gaussian of variance v per part, |c - mean|^2 is
    # exponential with mean 2v, so its median is 2v ln 2.
    mean = np.median(coefficients.real, axis=0) + 1j * np.median(coefficients.imag, axis=0)
    variance = np.maximum(np.median(np.abs(coefficients - mean) ** 2, axis=0) / (2.0 * math.log(2.0)), _MIN_VARIANCE)
    noises = [m.uncertainty["noise_std_arcmin"] for m in models
              if getattr(m, "uncertainty", None) and "noise_std_arcmin" in m.uncertainty]
    noise = float(np.median(noises)) if noises else 0.1
    return FleetPrior(np.arange(1, coefficients.shape[1] + 1), mean.real.copy(), mean.imag.copy(), variance,
                      max(noise, 1e-6), len(models))


def _design(theta_deg, orders):
    theta = np.radians(np.asarray(theta_deg, dtype=float))
    angles = np.multiply.outer(theta, orders)
    return np.column_stack([np.ones_like(theta), np.cos(angles), np.sin(angles)])


def _posterior(design, error, prior_mean, prior_variance, noise_var):
    """Posterior mean, covariance and log marginal likelihood (up to the flat offset's constant)."""
    n = error.size
    residual = error - design @ prior_mean
    precision = np.diag(1.0 / prior_variance) + design.T @ design / noise_var
    cholesky = np.linalg.cholesky(precision)
    projected = design.T @ residual / noise_var
    solved = np.linalg.solve(cholesky, projected)
    mean = prior_mean + np.linalg.solve(cholesky.T, solved)
    log_det = 2.0 * np.sum(np.log(np.diag(cholesky))) + np.sum(np.log(prior_variance[1:])) + n * math.log(noise_var)
    quadratic = residual @ residual / noise_var - solved @ solved
    log_evidence = -0.5 * (quadratic + log_det + n * math.log(2.0 * math.pi))
    return mean, cholesky, log_evidence


def _highest_order(theta_deg, highest):
    """``highest``, or below the Nyquist order of stops on a regular grid over the whole turn.

    On ``m`` regular stops the orders ``k`` and ``m - k`` take the same values: past the Nyquist order the
    prior alone would split a unit's harmonic between an order and its alias, and the correction between
    the stops would be wrong (on the real Mechaduino boards, a quarter of the stops: 4.6 arcmin at the stops
    left out with every order free, 3.2 with this; benchmarks/bench_fleet_prior.py). Stops over part of a
    turn do not alias so and keep every order.
    """
    from ..analysis.profile import distinct_angles

    stops = distinct_angles(np.mod(theta_deg, 360.0))[0]
    spacing = np.diff(np.r_[stops, stops[0] + 360.0])
    if stops.size >= 3 and np.max(spacing) < 1.5 * 360.0 / stops.size:  # about evenly over the whole turn
        return min(highest, (stops.size - 1) // 2)
    return highest


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
        With its posterior standard deviation (``uncertainty``) and ``training['prior']`` saying it is
        the fleet's.

    Raises
    ------
    InputError
        With fewer than 2 readings, or readings that are not finite.
    """
    from ..models.spectral import SpectralModel

    theta = np.asarray(theta_enc_deg, dtype=float).reshape(-1)
    error = np.asarray(error_arcmin, dtype=float).reshape(-1)
    if theta.size != error.size or theta.size < 2 or not (np.all(np.isfinite(theta)) and np.all(np.isfinite(error))):
        raise InputError(f"fit_with_prior expects 2 or more finite readings, as many angles as errors; got "
                         f"{theta.size} angles and {error.size} errors")
    orders = np.asarray(prior.orders)
    # past the Nyquist order of regular stops an order is held at the fleet's mean (its alias takes the data)
    variance = np.where(orders <= _highest_order(theta, int(np.max(orders))), prior.variance, _MIN_VARIANCE)
    design = _design(theta, orders)
    prior_mean = np.r_[0.0, prior.mean_cos, prior.mean_sin]
    prior_variance = np.r_[_FLAT_VARIANCE, variance, variance]
    # type-II maximum likelihood over the noise σ (unless known) and the unit's scale s of the fleet's spread
    # (a unit may be louder or quieter than the fleet: its prior variances are s times the fleet's)
    def evidence(log_sigma, log_scale):
        scaled = np.r_[_FLAT_VARIANCE, prior_variance[1:] * math.exp(log_scale)]
        return _posterior(design, error, prior_mean, scaled, math.exp(2 * log_sigma))[2]

    if noise_arcmin is not None:
        sigmas = np.array([math.log(float(noise_arcmin))])
        source = "supplied"
    else:
        centre = math.log(prior.noise_std_arcmin)
        sigmas = centre + np.linspace(-math.log(_NOISE_RANGE), math.log(_NOISE_RANGE), 21)
        source = "marginal likelihood under the fleet prior"
    scales = np.linspace(-math.log(_SCALE_RANGE), math.log(_SCALE_RANGE), 13)
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
    prior_variance = np.r_[_FLAT_VARIANCE, prior_variance[1:] * math.exp(log_scale)]
    mean, cholesky, log_evidence = _posterior(design, error, prior_mean, prior_variance, noise_var)
    all_orders = np.r_[0, orders]
    cos = np.r_[mean[0], mean[1:orders.size + 1]]
    sin = np.r_[0.0, mean[orders.size + 1:]]
    training = {
        "select": "fleet prior",
        "prior": (f"the fleet's: the mean and the spread of each order 1..{int(orders.max())} across "
                  f"{prior.units} units (empirical Bayes), the zero offset flat"),
        "noise": {"source": source, "std_arcmin": math.sqrt(noise_var)},
        "fleet_prior": {"units": int(prior.units), "orders": int(orders.max()), "spread_scale": math.exp(log_scale)},
        "log_evidence_nats": float(log_evidence),
        "stops": int(np.unique(np.round(theta, 9)).size),
    }
    model = SpectralModel(all_orders, cos, sin, training=training)
    points = 360
    grid = _design(np.arange(points) * (360.0 / points), orders)
    variance = np.sum(np.linalg.solve(cholesky, grid.T) ** 2, axis=0)  # g A^-1 g' at each angle, A = L L'
    model.uncertainty = {"method": "posterior", "grid_step_deg": 360.0 / points,
                         "model_std_arcmin": [float(v) for v in np.sqrt(variance)],
                         "noise_std_arcmin": math.sqrt(noise_var)}
    return model

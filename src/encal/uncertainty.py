"""Prediction uncertainty of an error model: how far a new reading's residual may fall from zero.

A model's prediction ``ε̂(θ)`` misses a new reading's error for two reasons:

- the model itself is uncertain (``σ_model(θ)``): refitted to another calibration of the same encoder
  with other noise (and, for a network, another random start), it would predict something else;
- the new reading carries what no function of the angle predicts (``σ_noise``): reading and reference
  noise, quantisation, and any part of the profile the model does not represent.

The predictive standard uncertainty of a new residual is ``sqrt(σ_model(θ)² + σ_noise²)``, and the expanded
uncertainty of the corrected angle is ``U = k · std`` (``k = 2`` by default).

How they are estimated (:func:`add_uncertainty`), with the same method and options as the model:

1. ``n_folds``-fold interleaved cross-validation on the calibration gives held-out residuals ``r``.
   Their mean square is ``σ_noise² (1 + g)``: the noise plus the variance of the fold models' own
   predictions at the held-out points, ``g σ_noise²``.
2. A parametric bootstrap refits the model ``n_boot`` times to its own prediction plus Gaussian noise of
   the cross-validated size. The spread of the refits on a 1-degree grid is ``σ_model(θ)``. As many
   refits on ``n_folds - 1`` folds, in pairs with independent noise, measure the fold models' noise gain
   ``g`` (half the mean squared difference of a pair at its held-out points).
3. ``σ_noise² = mean(r²) / (1 + g)``, and ``σ_model`` is rescaled from the trial noise to ``σ_noise``.

Step 3 treats the fit as linear in the data, which is exact for ``fourier`` with fixed orders and for
``lut``, and a first-order approximation for order selection and for networks. The cross-validated
residuals fall between calibration points, so ``σ_noise`` includes the part of the profile the model
cannot follow there; it also includes the reference's own noise, which makes it conservative for readings
in service. ``docs/uncertainty.md`` gives measured coverage on the demo fleet.

The result is stored with the model as :attr:`Model.uncertainty`, JSON data that the model file keeps::

    {"method": "parametric-bootstrap", "grid_step_deg": 1.0,
     "model_std_arcmin": [...360 values at 0, 1, ..., 359 deg...], "noise_std_arcmin": 0.14, ...}

``σ_model`` between grid angles is the periodic linear interpolation of the table.
"""

import math
import warnings

import numpy as np

from .angles import ARCMIN_PER_DEG, wrap180, wrap360
from .calibration import Calibration
from .errors import InputError, ModelFileError

__all__ = [
    "UNCERTAINTY_METHOD",
    "add_uncertainty",
    "estimate_uncertainty",
    "predictive_std",
    "expanded_uncertainty",
    "coverage",
    "cross_validated_residuals",
    "recorded_options",
    "check_uncertainty",
]

UNCERTAINTY_METHOD = "parametric-bootstrap"

#: Keys every stored uncertainty has; the model file may keep more (they are informative only).
_REQUIRED_KEYS = ("method", "grid_step_deg", "model_std_arcmin", "noise_std_arcmin")


# --------------------------------------------------------------------------- evaluation


def check_uncertainty(uncertainty, where="model uncertainty"):
    """Check stored uncertainty data and return it as a plain dict.

    Parameters
    ----------
    uncertainty : dict
        As made by :func:`add_uncertainty` or read from a model file.
    where : str
        Names the data in error messages (a file name, for instance).

    Returns
    -------
    dict

    Raises
    ------
    ModelFileError
        If a key is missing, the grid step does not divide 360 degrees, the table does not hold one
        finite value >= 0 per grid angle, or the noise is not a finite number >= 0.
    """
    if not isinstance(uncertainty, dict):
        raise ModelFileError(f"{where}: expected an object of uncertainty data, got {type(uncertainty).__name__}")
    missing = [key for key in _REQUIRED_KEYS if key not in uncertainty]
    if missing:
        raise ModelFileError(f"{where}: expected the keys {', '.join(_REQUIRED_KEYS)}, "
                             f"got none for {', '.join(missing)}")
    step = uncertainty["grid_step_deg"]
    size = _grid_size(step)
    if size is None:
        raise ModelFileError(f"{where}: expected grid_step_deg to divide 360 degrees, got {step!r}")
    table = uncertainty["model_std_arcmin"]
    values = np.asarray(table, dtype=float) if isinstance(table, list) else None
    if values is None or values.shape != (size,) or not np.all(np.isfinite(values)) or np.any(values < 0):
        raise ModelFileError(f"{where}: expected model_std_arcmin to be a list of {size} finite numbers "
                             "of arc-minutes >= 0, one per grid angle")
    noise = uncertainty["noise_std_arcmin"]
    if isinstance(noise, bool) or not isinstance(noise, (int, float)) or not math.isfinite(noise) or noise < 0:
        raise ModelFileError(f"{where}: expected noise_std_arcmin to be a finite number >= 0, got {noise!r}")
    return dict(uncertainty)


def _grid_size(step):
    if isinstance(step, bool) or not isinstance(step, (int, float)) or not math.isfinite(step) or step <= 0:
        return None
    size = round(360.0 / step)
    return size if size >= 1 and abs(size * step - 360.0) < 1e-9 else None


def predictive_std(uncertainty, theta_enc_deg):
    """Standard uncertainty of a new reading's residual, ``sqrt(σ_model(θ)² + σ_noise²)``.

    Parameters
    ----------
    uncertainty : dict or None
        A model's :attr:`~encal.models.base.Model.uncertainty`.
    theta_enc_deg : float or array-like
        Encoder readings in degrees.

    Returns
    -------
    float or ndarray
        Arc-minutes, same shape as ``theta_enc_deg``.

    Raises
    ------
    InputError
        If the model has no uncertainty.

    Examples
    --------
    >>> u = {"method": "given", "grid_step_deg": 90.0, "model_std_arcmin": [0.3, 0.0, 0.3, 0.0],
    ...      "noise_std_arcmin": 0.4}
    >>> round(float(predictive_std(u, 360.0)), 6), round(float(predictive_std(u, 90.0)), 6)
    (0.5, 0.4)
    """
    if uncertainty is None:
        raise InputError("return_std=True needs a model with an uncertainty; this model has none "
                         "(add one with encal.uncertainty.add_uncertainty or fit(..., uncertainty=True))")
    uncertainty = check_uncertainty(uncertainty)
    theta = np.asarray(theta_enc_deg, dtype=float)
    step = float(uncertainty["grid_step_deg"])
    table = np.asarray(uncertainty["model_std_arcmin"], dtype=float)
    grid = np.arange(table.size) * step
    model_std = np.interp(wrap360(theta), grid, table, period=360.0)
    noise = float(uncertainty["noise_std_arcmin"])
    return np.sqrt(np.square(model_std) + noise**2).reshape(theta.shape)[()]


def expanded_uncertainty(model, theta_enc_deg, *, coverage_factor=2.0, **predict_options):
    """Expanded uncertainty ``U = k · std`` of the corrected angle, in arc-minutes.

    The corrected angle's error ``θ_cor − θ_ref`` is the residual ``ε − ε̂``, so its standard uncertainty
    is the predictive standard uncertainty of the model; with ``k = 2`` and a Gaussian residual, about
    95 % of corrected readings lie within ``±U`` of the reference.

    Parameters
    ----------
    model : Model
        A model with an uncertainty.
    theta_enc_deg : float or array-like
        Encoder readings in degrees.
    coverage_factor : float, default=2.0
        ``k``.
    **predict_options
        Passed to ``model.predict`` (``direction`` for a directional model).

    Returns
    -------
    float or ndarray
        Arc-minutes, same shape as ``theta_enc_deg``.
    """
    k = _positive(coverage_factor, "coverage_factor", "expanded_uncertainty")
    _, std = model.predict(theta_enc_deg, return_std=True, **predict_options)
    return k * std


def coverage(model, cal, *, coverage_factor=2.0):
    """Share of a calibration's residuals inside ``±k · std`` of a model with an uncertainty.

    Parameters
    ----------
    model : Model
        A model with an uncertainty.
    cal : Calibration
        Ideally one the model was not fitted on; with a ``direction`` column and a directional model, each
        point is judged with its own direction's prediction.
    coverage_factor : float, default=2.0
        ``k``.

    Returns
    -------
    float
        Between 0 and 1.
    """
    k = _positive(coverage_factor, "coverage_factor", "coverage")
    options = {"direction": cal.direction} if getattr(model, "kind", None) == "directional" else {}
    mean, std = model.predict(cal.encoder_deg, return_std=True, **options)
    residual = _wrapped_arcmin(cal.errors_arcmin - mean)
    return float(np.mean(np.abs(residual) <= k * std))


# --------------------------------------------------------------------------- estimation


def add_uncertainty(model, cal, *, method=None, options=None, n_boot=30, n_folds=10, grid_step_deg=1.0,
                    rng=None):
    """Estimate a model's prediction uncertainty and attach it as ``model.uncertainty``.

    Parameters
    ----------
    model : Model
        A model fitted to ``cal``.
    cal : Calibration
        The calibration the model was fitted on. A bidirectional calibration (``direction`` column) is
        handled by :func:`encal.bidirectional.add_bidirectional_uncertainty`.
    method : str, optional
        The method the model was fitted with; default ``model.training['method']``, else its kind.
    options : dict, optional
        The options it was fitted with (``hidden``, ``orders``, ...); default ``model.training['fit_options']``,
        else ``model.training['options']``, else none. Pass the options you gave :func:`encal.fit`: the refits
        must be made the same way as the model.
    n_boot : int, default=30
        Bootstrap refits on all points (and as many on ``n_folds - 1`` folds for the noise gain).
    n_folds : int, default=10
        Cross-validation folds, ``2 <= n_folds <= n / 2``.
    grid_step_deg : float, default=1.0
        Step of the stored ``σ_model`` table; must divide 360.
    rng : int or numpy.random.Generator, optional
        Source of the bootstrap noise and of the refits' seeds.

    Returns
    -------
    Model
        The same model, with ``uncertainty`` set (see the module docstring for the data).

    Raises
    ------
    InputError
        If an option is invalid or a refit fails.

    Examples
    --------
    >>> import numpy as np, encal
    >>> from encal.uncertainty import add_uncertainty
    >>> ref = np.arange(0.0, 360.0, 2.0)
    >>> noise = np.random.default_rng(1).normal(0.0, 0.2, ref.size)
    >>> cal = encal.Calibration(ref, ref + (np.sin(np.radians(ref)) + noise) / 60)
    >>> model = add_uncertainty(encal.fit(cal, "fourier", orders=[0, 1]), cal, options={"orders": [0, 1]}, rng=0)
    >>> mean, std = model.predict(90.0, return_std=True)
    >>> 0.15 < float(std) < 0.25
    True
    """
    if not isinstance(cal, Calibration):
        raise InputError(f"add_uncertainty expects a Calibration. Got {type(cal).__name__} instead.")
    both_directions = cal.direction is not None and np.unique(cal.direction).size == 2
    if both_directions or getattr(model, "kind", None) == "directional":
        from .bidirectional import add_bidirectional_uncertainty

        return add_bidirectional_uncertainty(model, cal, method=method, options=options, n_boot=n_boot,
                                             n_folds=n_folds, grid_step_deg=grid_step_deg, rng=rng)
    model.uncertainty = estimate_uncertainty(
        model, cal.encoder_deg, cal.errors_arcmin, method=method, options=options, n_boot=n_boot,
        n_folds=n_folds, grid_step_deg=grid_step_deg, rng=rng)
    return model


def estimate_uncertainty(model, theta_enc_deg, error_arcmin, *, method=None, options=None, n_boot=30,
                         n_folds=10, grid_step_deg=1.0, rng=None):
    """The uncertainty data of :func:`add_uncertainty`, from plain arrays, without attaching it.

    Parameters
    ----------
    model : Model
        Fitted to ``(theta_enc_deg, error_arcmin)``.
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees.
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.
    method, options, n_boot, n_folds, grid_step_deg, rng
        As for :func:`add_uncertainty`.

    Returns
    -------
    dict
        JSON-ready: ``method``, ``grid_step_deg``, ``model_std_arcmin``, ``noise_std_arcmin``, ``n_boot``,
        ``n_folds``, ``cv_rms_arcmin``, ``noise_gain``, ``fit_method``, ``refit_warnings``.
    """
    theta = np.asarray(theta_enc_deg, dtype=float).reshape(-1)
    error = np.asarray(error_arcmin, dtype=float).reshape(-1)
    n_boot = _count(n_boot, "n_boot", 2)
    fold = _folds(theta, n_folds)
    n_folds = int(fold.max()) + 1
    size = _grid_size(grid_step_deg)
    if size is None:
        raise InputError("The 'grid_step_deg' parameter of add_uncertainty must be a number of degrees that "
                         f"divides 360. Got {grid_step_deg!r} instead.")
    grid = np.arange(size) * float(grid_step_deg)
    method = method or model.training.get("method") or model.kind
    refit = _Refitter(method, recorded_options(model) if options is None else options, rng)
    cv_mean_square = float(np.mean(np.square(_held_out_residuals(refit, theta, error, fold))))

    # Trial noise of the cross-validated size (a tiny floor keeps an exact fit from collapsing the trials).
    trial_std = math.sqrt(cv_mean_square) or 1e-9 * max(1.0, float(np.max(np.abs(error))))
    fitted = model.predict(theta)
    spread = _bootstrap_spread(refit, theta, fitted, grid, trial_std, n_boot)
    noise_gain = _fold_noise_gain(refit, theta, fitted, fold, trial_std, math.ceil(n_boot / 2))
    noise_var = cv_mean_square / (1.0 + noise_gain)
    scale = math.sqrt(noise_var) / trial_std
    return {
        "method": UNCERTAINTY_METHOD,
        "grid_step_deg": float(grid_step_deg),
        "model_std_arcmin": [float(s) for s in np.round(spread * scale, 9)],
        "noise_std_arcmin": float(math.sqrt(noise_var)),
        "n_boot": n_boot,
        "n_folds": n_folds,
        "cv_rms_arcmin": math.sqrt(cv_mean_square),
        "noise_gain": noise_gain,
        "fit_method": method,
        "refit_warnings": refit.warnings,
    }


def _bootstrap_spread(refit, theta, fitted, grid, trial_std, n_boot):
    """Standard deviation over the grid of refits to ``fitted`` plus trial noise (arcmin)."""
    replicates = [refit(theta, fitted + refit.noise(theta.size, trial_std)).predict(grid) for _ in range(n_boot)]
    return np.std(replicates, axis=0, ddof=1)


def _fold_noise_gain(refit, theta, fitted, fold, trial_std, n_pairs):
    """Variance of a fold model's prediction at its held-out points, per unit noise variance.

    Two refits on the same folds that differ only in their trial noise differ by sqrt(2) times the spread of
    one; half their mean squared difference is the variance.
    """
    n_folds = int(fold.max()) + 1
    samples = []
    for pair in range(n_pairs):
        held = fold == pair % n_folds
        train_theta, train_fitted = theta[~held], fitted[~held]
        first, second = (refit(train_theta, train_fitted + refit.noise(train_theta.size, trial_std))
                         .predict(theta[held]) for _ in range(2))
        samples.append(np.square(first - second) / 2.0)
    return float(np.mean(np.concatenate(samples))) / trial_std**2


def cross_validated_residuals(theta_enc_deg, error_arcmin, method, *, options=None, n_folds=10, rng=None):
    """Held-out residuals of a fitting method: each point predicted by a model fitted without its fold.

    The points are dealt round-robin by encoder angle into ``n_folds`` folds
    (:func:`encal.models.select.interleaved_folds`), so every held-out point lies between points the fold
    model was fitted on.

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees.
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.
    method : str
        Any method of :func:`encal.fit`.
    options : dict, optional
        Its options.
    n_folds : int, default=10
        ``2 <= n_folds <= n / 2``.
    rng : int or numpy.random.Generator, optional
        Seeds of the randomised methods' fits.

    Returns
    -------
    ndarray of shape (n,)
        Observed minus held-out predicted error, arc-minutes, in the order of the points.
    """
    theta = np.asarray(theta_enc_deg, dtype=float).reshape(-1)
    error = np.asarray(error_arcmin, dtype=float).reshape(-1)
    fold = _folds(theta, n_folds)
    return _held_out_residuals(_Refitter(method, options, rng), theta, error, fold)


def _folds(theta, n_folds):
    from .models.select import interleaved_folds

    n_folds = _count(n_folds, "n_folds", 2)
    if n_folds > theta.size // 2:
        raise InputError(f"The 'n_folds' parameter must be at most half the number of calibration points "
                         f"({theta.size // 2}). Got {n_folds} instead.")
    return interleaved_folds(theta, n_folds)


def _held_out_residuals(refit, theta, error, fold):
    residual = np.empty_like(error)
    for k in np.unique(fold):
        held = fold == k
        residual[held] = _wrapped_arcmin(error[held] - refit(theta[~held], error[~held]).predict(theta[held]))
    return residual


class _Refitter:
    """Refit the model's method with its options on new data, each randomised refit with a new seed."""

    def __init__(self, method, options, rng):
        from .fitting import RANDOMISED_METHODS, fitter

        self.fit = fitter(method)
        self.options = {key: value for key, value in dict(options or {}).items() if key != "rng"}
        self.randomised = method in RANDOMISED_METHODS
        self.method = method
        self.generator = np.random.default_rng(rng)
        self.warnings = 0

    def noise(self, size, std):
        return self.generator.normal(0.0, std, size)

    def __call__(self, theta, error):
        seed = {"rng": int(self.generator.integers(2**32))} if self.randomised else {}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                model = self.fit(theta, error, **self.options, **seed)
            except (TypeError, ValueError) as exc:
                raise InputError(f"expected to refit method {self.method!r} with options {self.options!r} on "
                                 f"{np.size(theta)} points, but the refit failed: {exc}") from None
        # Refits that warn (a network stopping early) still count: they are draws of the same procedure.
        self.warnings += bool(caught)
        return model


def recorded_options(model):
    """The fit options a model records: ``training['fit_options']``, else ``training['options']``, else none."""
    training = model.training
    recorded = training.get("fit_options", training.get("options"))
    return dict(recorded) if isinstance(recorded, dict) else {}


def _wrapped_arcmin(error_arcmin):
    return wrap180(np.asarray(error_arcmin, dtype=float) / ARCMIN_PER_DEG) * ARCMIN_PER_DEG


def _count(value, name, lowest):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lowest:
        raise InputError(f"The '{name}' parameter must be an int >= {lowest}. "
                         f"Got {value!r} instead.")
    return int(value)


def _positive(value, name, caller):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) or not value > 0 \
            or not math.isfinite(value):
        raise InputError(f"The '{name}' parameter of {caller} must be a finite number > 0. Got {value!r} instead.")
    return float(value)

"""Prediction uncertainty of an error model: how far a new reading's residual may fall from zero.

A model's prediction ``ε̂(θ)`` misses a new reading's error for two reasons:

- the model itself is uncertain (``σ_model(θ)``): refitted to another calibration of the same encoder
  with other noise (and, for a network, another random start), it would predict something else;
- the new reading carries what no function of the angle predicts (``σ_noise``): reading and reference
  noise, quantisation, and any part of the profile the model does not represent.

The predictive standard uncertainty of a new residual is ``sqrt(σ_model(θ)² + σ_noise²)``, and the expanded
uncertainty of the corrected angle is ``U = k · std`` (``k = 2`` by default).

The spectral model is Bayesian: its uncertainty is its posterior, made by the fit
(:mod:`encal.models.spectral`), and :func:`add_uncertainty` keeps it. For every other family they are
estimated by :func:`add_uncertainty`, with the same method and options as the model:

1. A parametric bootstrap refits the model ``n_boot`` times to its own prediction plus Gaussian trial noise of
   size ``s``, each randomised refit (a network) from a new random start: the refits are an ensemble over
   seeds *and* noise. Their spread on a 1-degree grid is ``σ_model(θ)``; at the calibration points their
   covariance with the trial noise and their variance give the fit's residual degrees of freedom
   ``ν = n − 2 Σ cov(ŷ*_i, y*_i) / s² + Σ var(ŷ*_i) / s²`` (for a linear smoother ``S``, ``n − 2 tr S + tr SSᵀ``;
   for a network, Ye's generalised degrees of freedom, seed spread included).
2. The noise, when ``ν ≥ n / 4``: ``σ_noise² = Σ r² / ν`` from the model's residuals ``r`` on its calibration
   (the classical unbiased estimate for a linear smoother, and ``RSS / (n − p)`` for least squares). For a
   randomised method ``Σ r²`` is averaged over the model and ``ceil(n_boot / 3)`` refits to the same data
   from other seeds, because ``ν`` is an average over random starts and one network's ``Σ r²`` varies with
   its start about as much as with the noise. The bootstrap is then repeated at ``s = σ_noise`` (at most
   three rounds in all) until ``s`` is within 10 % of it: a network's spread is not proportional to the noise
   (its seed spread does not shrink with it), so it must be measured at the noise of the data.
3. The noise, when ``ν < n / 4`` (a model that nearly reproduces its points, such as a lookup table, whose
   residuals hold almost nothing of the noise): ``n_folds``-fold interleaved cross-validation gives held-out
   residuals whose mean square is ``σ_noise² (1 + g)``, the noise plus the fold models' own variance at the
   held-out points; ``g`` is measured by pairs of bootstrap refits on ``n_folds - 1`` folds that differ only
   in their noise, and ``σ_noise² = mean(r_cv²) / (1 + g)``.

``σ_model`` is rescaled from ``s`` to ``σ_noise``. Why not cross-validation for every model: a network that
nearly interpolates its points wiggles far more across the double gaps that cross-validation leaves than
between its points, so ``g`` is large, ``σ_noise`` is a small remainder of two large, noisy terms, and it
comes out low (``docs/uncertainty.md`` gives the measurements). The residual estimator needs no fold
models: its error is that of ``ν`` degrees of freedom, about ``1 / sqrt(2ν)`` relative, plus the spread of
the seed average.

Both estimates include the squared bias of the model at its points (the part of the profile it does not
follow), which a new reading also meets; the cross-validated one includes it at the held-out points, midway
in gaps of two grid steps, which overstates it for a table. Both include the reference's own noise, which
makes them conservative for readings in service. ``docs/uncertainty.md`` gives measured coverage.

The result is stored with the model as :attr:`Model.uncertainty`, JSON data that the model file keeps::

    {"method": "parametric-bootstrap", "grid_step_deg": 1.0,
     "model_std_arcmin": [...360 values at 0, 1, ..., 359 deg...], "noise_std_arcmin": 0.14, ...}

``σ_model`` between grid angles is the periodic linear interpolation of the table.
"""

import math
import warnings

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, model_input, wrap180, wrap360
from ..analysis.profile import distinct_angles
from ..data.reversal import (direction_subset, has_both_directions, largest_per_angle, mean_calibration,
                             require_directions, reversal)
from ..data.calibration import READING_NOISE_KEY, Calibration
from .._core.errors import InputError
from .._core.parameters import check_int, check_number, check_type
from . import model_kind
from .stored_uncertainty import check_uncertainty, grid_size, predictive_std
from .validation import held_out_predictions, interleaved_folds

__all__ = [
    "UNCERTAINTY_METHOD",
    "add_uncertainty",
    "estimate_uncertainty",
    "predictive_std",
    "expanded_uncertainty",
    "coverage",
    "cross_validated_residuals",
    "recorded_options",
    "refit_spec",
    "has_posterior",
    "with_half_reversal",
    "with_reference_uncertainty",
    "reading_noise",
    "with_reading_noise",
    "included_text",
    "reference_std_rms",
    "with_reference_rms",
    "check_uncertainty",
]

UNCERTAINTY_METHOD = "parametric-bootstrap"

# --------------------------------------------------------------------------- evaluation


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
    k = check_number(coverage_factor, "coverage_factor", "expanded_uncertainty", low=0.0, low_open=True)
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
    k = check_number(coverage_factor, "coverage_factor", "coverage", low=0.0, low_open=True)
    check_type(cal, Calibration, "cal", "coverage", "a Calibration")
    if len(cal) == 0:
        raise InputError(f"coverage expects a calibration with points; {cal.source or cal.name or 'the calibration'} "
                         "has none")
    mean, std = model.predict(cal.readings_deg, return_std=True, direction=cal.direction)
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
        estimated per direction (see :func:`_add_bidirectional_uncertainty`).
    method : str, optional
        The method the model was fitted with; default ``model.training['method']``, else its kind.
    options : dict, optional
        The options it was fitted with (``hidden``, ``orders``, ...); default ``model.training['fit_options']``,
        else ``model.training['options']``, else none. Pass the options you gave :func:`encal.fit`: the refits
        must be made the same way as the model.
    n_boot : int, default=30
        Bootstrap refits on all points per round (one round for a linear fit, up to three for a network),
        plus ``ceil(n_boot / 3)`` refits to the data from other seeds for a randomised method; when the noise
        is cross-validated, ``n_folds`` and ``n_boot`` more for the noise gain.
    n_folds : int, default=10
        Cross-validation folds, ``2 <= n_folds <= n / 2``; used only for a model that nearly reproduces
        its points (see the module docstring).
    grid_step_deg : float, default=1.0
        Step of the stored ``σ_model`` table; must divide 360.
    rng : int or numpy.random.Generator, optional
        Source of the bootstrap noise and of the refits' seeds.

    Returns
    -------
    Model
        The same model, with ``uncertainty`` set (see the module docstring for the data). A model whose
        uncertainty is its posterior (the spectral model, :func:`has_posterior`) keeps it: a bootstrap
        would measure the spread of refits, not the posterior the model is made of. A model of the mean of
        both directions of travel gets the half reversal value added to its noise either way.

    Raises
    ------
    InputError
        If an option is invalid or a refit fails.

    Examples
    --------
    >>> import numpy as np, encal
    >>> from encal.models.uncertainty import add_uncertainty
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
    if has_both_directions(cal) or getattr(model, "kind", None) == "directional":
        return _add_bidirectional_uncertainty(model, cal, method=method, options=options, n_boot=n_boot,
                                             n_folds=n_folds, grid_step_deg=grid_step_deg, rng=rng)
    if not has_posterior(model):
        model.uncertainty = estimate_uncertainty(
            model, cal.encoder_deg, cal.errors_arcmin, method=method, options=options, n_boot=n_boot,
            n_folds=n_folds, grid_step_deg=grid_step_deg, rng=rng)
    model.uncertainty = with_reference_uncertainty(model.uncertainty, cal)
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
        JSON-ready: ``method``, ``grid_step_deg``, ``model_std_arcmin``, ``noise_std_arcmin``,
        ``noise_estimator`` (``'residual'`` or ``'cross-validation'``), ``residual_dof``, ``trial_std_arcmin``,
        ``bootstrap_rounds``, ``seed_refits``, ``n_boot``, ``n_folds``, ``cv_rms_arcmin`` and ``noise_gain``
        (``None`` unless cross-validated), ``fit_method``, ``refit_warnings``.

    Notes
    -----
    With ``r`` the residuals of the model on its own calibration, a parametric bootstrap at trial noise
    ``s`` (refits to the model's prediction plus ``N(0, s²)``, each from a new random start) gives the
    residual degrees of freedom

    ``ν = n − 2 Σ cov(ŷ*_i, y*_i) / s² + Σ var(ŷ*_i) / s²``

    (for a linear smoother ``S``: ``n − 2 tr S + tr SSᵀ``, whose ``E[Σ r²] = σ² ν`` plus the squared bias;
    for a network the covariances and variances are those of the bootstrap, random start included). Then:

    - ``ν ≥ n / 4`` (the fit leaves at least a quarter of the data's degrees of freedom in its residuals):
      ``σ_noise² = Σ r² / ν`` (``Σ r²`` averaged over the model and ``ceil(n_boot / 3)`` refits to the same
      data from other seeds for a randomised method), and the bootstrap is repeated at ``s = σ_noise`` (at
      most twice more) until the two agree within 10 %, because a network's spread is not proportional to
      the noise.
    - ``ν < n / 4`` (a model that nearly reproduces its points, such as a table): the residuals hold too
      little of the noise, and ``σ_noise² = mean(r_cv²) / (1 + g)`` from ``n_folds``-fold
      cross-validation, as described in the module docstring.

    ``σ_model`` is the bootstrap spread on the grid, times ``σ_noise / s``.
    """
    theta = np.asarray(theta_enc_deg, dtype=float).reshape(-1)
    error = np.asarray(error_arcmin, dtype=float).reshape(-1)
    n_boot = check_int(n_boot, "n_boot", "add_uncertainty", low=2)
    fold = _folds(theta, n_folds, error)
    n_folds = int(fold.max()) + 1
    size = grid_size(grid_step_deg)
    if size is None:
        raise InputError("The 'grid_step_deg' parameter of add_uncertainty must be a number of degrees that "
                         f"divides 360. Got {grid_step_deg!r} instead.")
    grid = np.arange(size) * float(grid_step_deg)
    method = method or model.training.get("method") or model.kind
    refit = _Refitter(method, recorded_options(model) if options is None else options, rng)

    fitted = model.predict(model_input(theta, model.reading_sign))  # theta are model inputs; the map is its own inverse
    residual_square = float(np.sum(np.square(_wrapped_arcmin(error - fitted))))
    seed_refits = 0
    if refit.randomised:
        # One network's residual sum of squares depends on its random start as much as on the noise (on the
        # demo fleet, the training RMS of four seeds on the same data spans 0.10-0.16 arcmin); nu is an
        # average over starts, so the numerator is averaged over the model and refits to the same data.
        seed_refits = math.ceil(n_boot / 3)
        squares = [residual_square]
        for _ in range(seed_refits):
            squares.append(float(np.sum(np.square(_wrapped_arcmin(error - refit(theta, error).predict(theta))))))
        residual_square = float(np.mean(squares))
    # A tiny floor on the trial noise keeps an exact fit from collapsing the trials into rounding error.
    floor = 1e-9 * max(1.0, float(np.max(np.abs(error))))
    trial_std = max(math.sqrt(residual_square / theta.size), floor)
    cv_rms = noise_gain = None
    for round_ in range(1, _MAX_BOOTSTRAP_ROUNDS + 1):
        spread, dof = _bootstrap(refit, theta, fitted, grid, trial_std, n_boot)
        if dof >= _MIN_DOF_SHARE * theta.size:
            estimator, noise_std = "residual", math.sqrt(residual_square / dof)
        else:
            if cv_rms is None:
                cv_mean_square = float(np.mean(np.square(_held_out_residuals(refit, theta, error, fold))))
                cv_rms = math.sqrt(cv_mean_square)
                noise_gain = _fold_noise_gain(refit, theta, fitted, fold, max(cv_rms, floor),
                                              math.ceil(n_boot / 2))
            estimator, noise_std = "cross-validation", math.sqrt(cv_mean_square / (1.0 + noise_gain))
        settled = abs(max(noise_std, floor) / trial_std - 1.0) <= _TRIAL_TOLERANCE
        if settled or round_ == _MAX_BOOTSTRAP_ROUNDS:
            break
        trial_std = max(noise_std, floor)
    return {
        "method": UNCERTAINTY_METHOD,
        "grid_step_deg": float(grid_step_deg),
        "model_std_arcmin": [float(s) for s in np.round(spread * (noise_std / trial_std), 9)],
        "noise_std_arcmin": float(noise_std),
        "noise_estimator": estimator,
        "residual_dof": float(dof),
        "trial_std_arcmin": float(trial_std),
        "bootstrap_rounds": round_,
        "seed_refits": seed_refits,
        "n_boot": n_boot,
        "n_folds": n_folds,
        "cv_rms_arcmin": cv_rms,
        "noise_gain": noise_gain,
        "fit_method": method,
        "refit_warnings": refit.warnings,
    }


#: The residual estimator of the noise is used when the fit leaves at least this share of the points'
#: degrees of freedom in its residuals (below it, cross-validation).
_MIN_DOF_SHARE = 0.25
#: The bootstrap is repeated at the estimated noise until the trial noise is within this relative distance.
_TRIAL_TOLERANCE = 0.10
_MAX_BOOTSTRAP_ROUNDS = 3


def _bootstrap(refit, theta, fitted, grid, trial_std, n_boot):
    """Parametric bootstrap at trial noise ``trial_std``: the refits' spread on ``grid`` and the residual dof.

    Each refit is fitted to ``fitted + e*`` with ``e* ~ N(0, trial_std²)`` (and, for a randomised method, a
    new seed). ``ν = n − 2 Σ_i cov(ŷ*_i, e*_i) / s² + Σ_i var(ŷ*_i) / s²`` at the calibration points: the
    expected residual sum of squares of the fit per unit noise variance.
    """
    at_points, on_grid, noises = [], [], []
    for _ in range(n_boot):
        noise = refit.noise(theta.size, trial_std)
        replicate = refit(theta, fitted + noise)
        at_points.append(replicate.predict(theta))
        on_grid.append(replicate.predict(grid))
        noises.append(noise)
    at_points, noises = np.asarray(at_points), np.asarray(noises)
    # The trial noise has known mean zero, so centring the predictions alone gives an unbiased covariance.
    covariance = np.sum((at_points - at_points.mean(axis=0)) * noises, axis=0) / (n_boot - 1)
    variance = np.var(at_points, axis=0, ddof=1)
    dof = theta.size + (float(np.sum(variance)) - 2.0 * float(np.sum(covariance))) / trial_std**2
    return np.std(on_grid, axis=0, ddof=1), dof


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
    (:func:`encal.models.validation.interleaved_folds`), so every held-out point lies between points the fold
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
    fold = _folds(theta, n_folds, error)
    return _held_out_residuals(_Refitter(method, options, rng), theta, error, fold)


def _folds(theta, n_folds, error):
    n_folds = check_int(n_folds, "n_folds", "add_uncertainty", low=2)
    if n_folds > theta.size // 2:
        raise InputError(f"The 'n_folds' parameter must be at most half the number of calibration points "
                         f"({theta.size // 2}). Got {n_folds} instead.")
    # Repeated approaches to one target (an ISO 230-2 run) read slightly different encoder angles but share the
    # reference angle: dealt apart, a held-out reading has its twins in the training folds, and a model through
    # every point (lut) predicts it from them, so the held-out residual and the noise estimate come out low.
    reference = wrap360(theta - error / ARCMIN_PER_DEG)
    n_references = distinct_angles(reference)[0].size
    if 4 <= n_references < distinct_angles(wrap360(theta))[0].size:
        return interleaved_folds(reference, min(n_folds, n_references // 2))
    return interleaved_folds(theta, n_folds)


def _held_out_residuals(refit, theta, error, fold):
    def fit_predict(k, train_theta, train_error, test_theta):
        return refit(train_theta, train_error).predict(test_theta)

    return _wrapped_arcmin(error - held_out_predictions(fit_predict, theta, error, fold))


class _Refitter:
    """Refit the model's method with its options on new data, each randomised refit with a new seed."""

    def __init__(self, method, options, rng):
        self.fit = model_kind(method, role="method of the refits").fit
        self.options = {key: value for key, value in dict(options or {}).items() if key != "rng"}
        self.randomised = model_kind(method).randomised
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


def _add_bidirectional_uncertainty(model, cal, *, method=None, options=None, n_boot=30, n_folds=10,
                                  grid_step_deg=1.0, rng=None):
    """Prediction uncertainty of a model of a bidirectional calibration (see :func:`add_uncertainty`).

    A :class:`~encal.models.directional.DirectionalModel` gets one uncertainty per direction, each estimated
    on that direction's points. A one-direction model of the mean of both directions (``mode='mean'``) gets
    the uncertainty of the mean profile, and its ``noise_std_arcmin`` adds the RMS half reversal value,
    ``sqrt(mean(B_i²) / 4)``, in quadrature: a new reading comes from one direction, unknown to the model.

    Returns
    -------
    Model
        The same model, with its uncertainty (or its parts' uncertainties) set.
    """
    settings = {"n_boot": n_boot, "n_folds": n_folds, "grid_step_deg": grid_step_deg}
    if options is None:
        options = recorded_options(model)
    generator = np.random.default_rng(rng)
    if model.kind == "directional":
        require_directions(cal, "add_uncertainty of a directional model")
        sides = {sign: direction_subset(cal, sign) for sign in (1, -1)}
        return add_part_uncertainties(model, sides, method=method, options=options, rng=generator, **settings)
    add_mean_uncertainty(model, mean_calibration(cal), method=method, options=options, rng=generator, **settings)
    model.uncertainty = with_half_reversal(model.uncertainty, cal)
    return model


def add_part_uncertainties(model, sides, *, method, options, rng, **settings):
    """Each part of a directional model gets its uncertainty, estimated on its own direction's points.

    Parameters
    ----------
    model : DirectionalModel
        Its parts fitted to ``sides[1]`` (forward) and ``sides[-1]`` (reverse); a part with a posterior keeps it.
    sides : dict of {1: Calibration, -1: Calibration}
        The calibration's two directions, as the parts were fitted on them.
    method, options, rng
        As :func:`add_uncertainty` takes them (``rng`` a Generator, drawn from by both parts in turn).
    **settings
        ``n_boot``, ``n_folds``, ``grid_step_deg`` of :func:`estimate_uncertainty`.

    Returns
    -------
    DirectionalModel
        The same model.
    """
    for sign, part in ((1, model.forward), (-1, model.reverse)):
        if not has_posterior(part):
            part_method, part_options = refit_spec(part, method or part.training.get("method"), options)
            part.uncertainty = estimate_uncertainty(part, sides[sign].encoder_deg, sides[sign].errors_arcmin,
                                                    method=part_method, options=part_options, rng=rng, **settings)
        part.uncertainty = with_reference_uncertainty(part.uncertainty, sides[sign])
    return model


def add_mean_uncertainty(model, mean, *, method, options, rng, **settings):
    """The uncertainty of a model of the mean of both directions, estimated on that mean (``mean``, a
    Calibration); the half reversal value is the caller's to add (:func:`with_half_reversal`). A model with a
    posterior keeps it. Returns the same model."""
    if not has_posterior(model):
        mean_method, mean_options = refit_spec(model, method or model.training.get("method"), options)
        model.uncertainty = estimate_uncertainty(model, mean.encoder_deg, mean.errors_arcmin, method=mean_method,
                                                 options=mean_options, rng=rng, **settings)
    model.uncertainty = with_reference_uncertainty(model.uncertainty, mean)
    return model


def has_posterior(model):
    """Whether ``model.uncertainty`` is the model's own posterior (the spectral model's), not a bootstrap."""
    uncertainty = getattr(model, "uncertainty", None)
    return isinstance(uncertainty, dict) and uncertainty.get("method") == "posterior"


def with_half_reversal(uncertainty, cal):
    """``uncertainty`` with the RMS half reversal value of ``cal`` added to its noise in quadrature.

    For a model of the mean of both directions of travel: a new reading comes from one direction, unknown
    to the model, and lies about half the reversal value ``B_i`` from the mean, ``sqrt(mean(B_i²) / 4)``
    (arcmin) in RMS. Added once: an uncertainty that records ``half_reversal_rms_arcmin`` is returned as
    it is.

    Raises
    ------
    CalibrationError
        If no target position of ``cal`` was approached in both directions.
    """
    if "half_reversal_rms_arcmin" in uncertainty:
        return uncertainty
    half_reversal = math.sqrt(float(np.mean(np.square(reversal(cal).reversal_arcmin))) / 4.0)
    return {**uncertainty, "half_reversal_rms_arcmin": half_reversal,
            "noise_std_arcmin": math.hypot(uncertainty["noise_std_arcmin"], half_reversal)}


def with_reference_uncertainty(uncertainty, cal):
    """``uncertainty`` with the reference's own standard uncertainty of ``cal`` added to ``σ_model`` in quadrature.

    A calibration whose reference is itself estimated (a self-calibration's recovered profile, ``encal
    selfcal``) or certified to some uncertainty carries it per point (:attr:`Calibration.reference_std_arcmin`).
    Neighbouring points share it, so no fit averages it away, and a model fitted to the points inherits it
    whole: ``σ_model(θ)² + σ_ref(θ)²``, ``σ_ref`` interpolated (periodic, linear) from the points' encoder
    angles to the table's grid. The noise is left as it is (it is a new reading's own). Added once: an
    uncertainty that records ``reference_std_rms_arcmin`` is returned as it is, and so are None and an
    uncertainty of a calibration without the column.

    Parameters
    ----------
    uncertainty : dict or None
        A model's stored uncertainty (see the module docstring).
    cal : Calibration
        The calibration the model was fitted on.

    Returns
    -------
    dict or None
        A new dict when something was added (``reference_std_rms_arcmin`` records its RMS over the table's grid,
        the average a posterior's held-out estimate takes).
    """
    uncertainty = with_reading_noise(uncertainty, cal)
    std = getattr(cal, "reference_std_arcmin", None)
    if uncertainty is None or std is None or "reference_std_rms_arcmin" in uncertainty:
        return uncertainty
    uncertainty = check_uncertainty(uncertainty)
    table = np.asarray(uncertainty["model_std_arcmin"], dtype=float)
    grid = np.arange(table.size) * float(uncertainty["grid_step_deg"])
    angles, largest = largest_per_angle(cal.encoder_deg, std)  # (readings of one angle: the largest)
    reference_std = np.interp(grid, angles, largest, period=360.0)
    return {**uncertainty, "model_std_arcmin": np.hypot(table, reference_std).tolist(),
            "reference_std_rms_arcmin": float(np.sqrt(np.mean(np.square(reference_std))))}


def reading_noise(cal):
    """One reading's noise (arcmin RMS) a self-calibration measured from its log and wrote with its curve
    (``# reading_noise_arcmin: X``, :data:`~encal.data.calibration.READING_NOISE_KEY` in ``cal.metadata``), or None."""
    value = getattr(cal, "metadata", {}).get(READING_NOISE_KEY)
    return None if value is None else float(value)


def with_reading_noise(uncertainty, cal):
    """``uncertainty`` with the reading noise ``cal`` records (:func:`reading_noise`) added to ``σ_noise``.

    A self-calibration writes a smoothed curve: the noise a fit estimates from its points is nearly 0, so the
    model's band and held-out estimate held the profile's uncertainty alone (25 % of a noisy encoder's new readings
    inside the 95 % band, benchmarks/bench_report_band.py). The noise the self-calibration measured from its log
    is a new reading's own: ``σ_noise² + σ_reading²``, recorded as ``reading_noise_arcmin``. Added once; None and
    a calibration without it are returned as they are.
    """
    noise = reading_noise(cal)
    if uncertainty is None or noise is None or READING_NOISE_KEY in uncertainty:
        return uncertainty
    return {**uncertainty, READING_NOISE_KEY: noise,
            "noise_std_arcmin": math.hypot(float(uncertainty["noise_std_arcmin"]), noise)}


def included_text(reference_rms_arcmin=None, reading_noise_arcmin=None):
    """What a held-out estimate holds beyond the fit's own figures, as its report says it: the reference's own
    uncertainty and a self-calibration's measured reading noise (arcmin RMS; either None). '' with neither."""
    parts = []
    if reference_rms_arcmin is not None:
        parts.append(f"the reference's own uncertainty (its sigma_arcmin column, RMS {reference_rms_arcmin:.3g} "
                     "arcmin)")
    if reading_noise_arcmin is not None:
        parts.append(f"a new reading's noise ({reading_noise_arcmin:.3g} arcmin RMS, measured by the self-calibration "
                     "from its log: the file's reading_noise_arcmin comment)")
    return " and ".join(parts)


def reference_std_rms(cal):
    """RMS (arcmin) over the points of ``cal``'s own reference uncertainty (:attr:`Calibration.reference_std_arcmin`),
    or None without it."""
    std = getattr(cal, "reference_std_arcmin", None)
    return None if std is None else float(np.sqrt(np.mean(np.square(std))))


def with_reference_rms(rms_arcmin, cal):
    """A cross-validated RMS (arcmin) with ``cal``'s reference uncertainty in quadrature: no fold sees an error the
    reference shares with its neighbours; and the reading noise a self-calibration measured (:func:`reading_noise`),
    which its smoothed points do not show. ``rms_arcmin`` as it is without either (a posterior's estimate has both
    already: :func:`with_reference_uncertainty`)."""
    reference, noise = reference_std_rms(cal), reading_noise(cal)
    if rms_arcmin is None:
        return rms_arcmin
    return math.hypot(rms_arcmin, reference or 0.0, noise or 0.0)


def refit_spec(model, method, options):
    """``(method, options)`` that refit ``model`` the way it was made, for the uncertainty's bootstrap.

    A model made by ``method='auto'`` is refitted as the family it chose (a stack as its members and
    weights), not by the whole selection, which would cost about 70 fits per refit.
    """
    selection = model.training.get("selection")
    if method != "auto" or selection is None:
        return method, dict(options)
    chosen = next((row for row in selection["table"] if row["label"] == selection["chosen"]), None)
    if chosen is None:  # the evidence scheme's spectral model, chosen without a table
        noise = options.get("noise_arcmin")
        return "spectral", {} if noise is None else {"noise_arcmin": noise}
    return chosen["family"], dict(chosen["options"])


def recorded_options(model):
    """The fit options a model records: ``training['fit_options']``, else ``training['options']``, else none."""
    training = model.training
    recorded = training.get("fit_options", training.get("options"))
    return dict(recorded) if isinstance(recorded, dict) else {}


def _wrapped_arcmin(error_arcmin):
    return wrap180(np.asarray(error_arcmin, dtype=float) / ARCMIN_PER_DEG) * ARCMIN_PER_DEG

"""``fit`` and ``evaluate``: the public entry points from a calibration to a model and back.

Each model kind provides ``fit_<kind>(theta_enc_deg, error_arcmin, **options) -> Model`` on plain
arrays, listed in the registry of kinds (:mod:`encal.models.registry`); :func:`fit` takes a
:class:`~encal.calibration.Calibration`, looks ``method`` up there, and records the encoder and where the
model came from.
"""

import hashlib
from dataclasses import dataclass

import numpy as np

from .angles import ARCMIN_PER_DEG, resolution_of_readings, wrap180
from .calibration import Calibration, check_folds
from .errors import InputError
from .models import kind_names, model_kind
from .profile import ErrorStats, error_stats

__all__ = ["fit", "evaluate", "Evaluation", "fitter", "calibration_sha256", "resolution_bits"]


def calibration_sha256(cal):
    """SHA-256 (hex) of a calibration's angles, to tie a model to the data it was fitted on."""
    digest = hashlib.sha256()
    for array in (cal.reference_deg, cal.encoder_deg):
        digest.update(np.ascontiguousarray(array, dtype="<f8").tobytes())
    if cal.direction is not None:
        digest.update(np.ascontiguousarray(cal.direction, dtype="i1").tobytes())
    return digest.hexdigest()


def fitter(method):
    """The fit function of a method: ``fit_<kind>(theta_enc_deg, error_arcmin, **options) -> Model``."""
    methods = [name for name in kind_names() if model_kind(name).fit is not None]
    if method not in methods:
        raise InputError(f"The 'method' parameter of fit must be one of {', '.join(methods)}. "
                         f"Got {method!r} instead.")
    return model_kind(method).fit


def fit(cal, method="auto", *, rng=None, uncertainty=False, **options):
    """Fit an error model to a calibration.

    Parameters
    ----------
    cal : Calibration
        The calibration run (encoder readings and reference angles in degrees).
    method : {'auto', 'fourier', 'lut', 'ann', 'hybrid', 'stack'}, default='auto'
        Model family; ``'auto'`` chooses by cross-validation; ``'stack'`` is a weighted mean of
        members of the other families.
    rng : int or numpy.random.Generator, optional
        Seed for the methods that draw random numbers (network initialisation) and, with
        ``uncertainty=True``, for the bootstrap; for ``'fourier'`` and ``'lut'`` only then.
    uncertainty : bool, default=False
        Also estimate the prediction uncertainty (bootstrap refits; see :mod:`encal.uncertainty`), so that
        ``model.predict(theta, return_std=True)`` works. Costs 30 (Fourier) to 100 (lookup table, networks) refits.
    **options
        Passed to the family's fit function (``hidden``, ``algorithm``, ``encoding`` for ``'ann'``;
        ``orders``, ``n_orders``, ``select`` for ``'fourier'``; ``interpolation`` for ``'lut'``;
        ``members`` and ``weights`` for ``'stack'``).

    Returns
    -------
    Model
        Predicts the error ``encoder - reference`` in arc-minutes from the encoder angle in degrees.

    Raises
    ------
    InputError
        If the method or an option is invalid.
    CalibrationError
        If the encoder goes back while the reference goes forward, so that the error is not a function
        of the encoder angle (see :func:`~encal.calibration.check_folds`).

    Examples
    --------
    >>> import numpy as np, encal
    >>> ref = np.arange(0.0, 360.0, 2.0)
    >>> cal = encal.Calibration(ref, ref + np.sin(np.radians(ref)) / 60)   # 1 arcmin first harmonic
    >>> model = encal.fit(cal, method="fourier", orders=[0, 1])
    >>> round(float(model.predict(90.0 + 1 / 60)), 3)
    1.0
    """
    if not isinstance(cal, Calibration):
        raise InputError(f"fit expects a Calibration. Got {type(cal).__name__} instead.")
    fit_family = fitter(method)
    check_folds(cal, where=cal.source or cal.name or "calibration")
    fit_options = dict(options)
    if model_kind(method).randomised:
        options["rng"] = rng
    elif rng is not None and not uncertainty:
        raise InputError(f"method {method!r} draws no random numbers; rng must be None "
                         "(it seeds only the bootstrap of uncertainty=True)")
    model = fit_family(cal.encoder_deg, cal.errors_arcmin, **options)
    model.encoder = {"name": cal.name, "resolution_bits": resolution_bits(cal)}
    model.training = {
        "method": method,
        **model.training,
        "n_points": len(cal),
        "data_sha256": calibration_sha256(cal),
    }
    model.training.setdefault("fit_options", fit_options)
    if isinstance(rng, (int, np.integer)):
        model.training.setdefault("seed", int(rng))
    if uncertainty and model.uncertainty is None:  # a spectral model has its posterior already
        from .uncertainty import add_uncertainty

        refit_method, refit_options = refit_spec(model, method, fit_options)
        add_uncertainty(model, cal, method=refit_method, options=refit_options, rng=rng)
    model.reading_sign = cal.reading_sign
    return model


def resolution_bits(cal):
    """The calibration's declared resolution, else the one its readings show (all whole codes), else None.

    Examples
    --------
    >>> import numpy as np, encal
    >>> ref = np.arange(0.0, 360.0, 1.8)
    >>> codes = np.round((ref + 0.3 * np.sin(np.radians(ref))) * 2**14 / 360)
    >>> resolution_bits(encal.Calibration(ref, codes * 360 / 2**14))
    14
    """
    if cal.resolution_bits is not None:
        return int(cal.resolution_bits)
    return resolution_of_readings(cal.encoder_deg)


def refit_spec(model, method, options):
    """``(method, options)`` that refit ``model`` the way it was made, for the uncertainty's bootstrap.

    A model made by ``method='auto'`` is refitted as the family it chose (a stack as its members and
    weights), not by the whole selection, which would cost about 70 fits per refit.
    """
    selection = model.training.get("selection")
    if method != "auto" or selection is None:
        return method, dict(options)
    chosen = next(row for row in selection["table"] if row["label"] == selection["chosen"])
    return chosen["family"], dict(chosen["options"])


@dataclass(frozen=True)
class Evaluation:
    """A model's accuracy on one calibration.

    Attributes
    ----------
    before : ErrorStats
        Statistics of the raw errors ``encoder - reference`` (arcmin).
    after : ErrorStats
        Statistics of the errors of the corrected angles ``corrected - reference`` (arcmin).
    encoder_deg : ndarray
        Encoder angles of the points (degrees).
    residual_arcmin : ndarray
        ``corrected - reference`` at every point (arcmin): the observed error minus the predicted one.
    """

    before: ErrorStats
    after: ErrorStats
    encoder_deg: np.ndarray
    residual_arcmin: np.ndarray

    def as_dict(self):
        """JSON-ready: the ``after`` statistics at top level and ``before`` as a nested object."""
        return {**self.after.as_dict(), "before": self.before.as_dict()}


def evaluate(model, cal):
    """Residual statistics of a model on a calibration (ideally one it was not fitted on).

    Parameters
    ----------
    model : Model
    cal : Calibration

    Returns
    -------
    Evaluation
    """
    if not isinstance(cal, Calibration):
        raise InputError(f"evaluate expects a Calibration. Got {type(cal).__name__} instead.")
    observed = cal.errors_arcmin
    # The model maps readings to its input itself (a model of a reversed encoder negates them).
    residual = wrap180((observed - model.predict(cal.readings_deg)) / ARCMIN_PER_DEG) * ARCMIN_PER_DEG
    return Evaluation(error_stats(observed), error_stats(residual), cal.encoder_deg.copy(), residual)

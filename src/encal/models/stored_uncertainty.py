"""A model's stored prediction uncertainty: checking it, and the predictive standard uncertainty it gives.

A model may carry :attr:`~encal.models.base.Model.uncertainty`, JSON data that the model file keeps::

    {"method": "parametric-bootstrap", "grid_step_deg": 1.0,
     "model_std_arcmin": [...360 values at 0, 1, ..., 359 deg...], "noise_std_arcmin": 0.14, ...}

``σ_model`` between grid angles is the periodic linear interpolation of the table, and the predictive
standard uncertainty of a new reading's residual is ``sqrt(σ_model(θ)² + σ_noise²)``. Estimating it
(refitting the model) is :mod:`encal.models.uncertainty`'s job; this module only reads it.
"""

import math

import numpy as np

from .._core.angles import wrap360
from .._core.errors import InputError, ModelFileError

__all__ = ["check_uncertainty", "predictive_std", "grid_size"]

#: Keys every stored uncertainty has; the model file may keep more (they are informative only).
REQUIRED_KEYS = ("method", "grid_step_deg", "model_std_arcmin", "noise_std_arcmin")


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
    missing = [key for key in REQUIRED_KEYS if key not in uncertainty]
    if missing:
        raise ModelFileError(f"{where}: expected the keys {', '.join(REQUIRED_KEYS)}, "
                             f"got none for {', '.join(missing)}")
    step = uncertainty["grid_step_deg"]
    size = grid_size(step)
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


def grid_size(step):
    """Points of a table with grid step ``step`` (degrees) over one turn, or None if it does not divide 360."""
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
                         "(add one with encal.models.uncertainty.add_uncertainty or fit(..., uncertainty=True))")
    uncertainty = check_uncertainty(uncertainty)
    theta = np.asarray(theta_enc_deg, dtype=float)
    step = float(uncertainty["grid_step_deg"])
    table = np.asarray(uncertainty["model_std_arcmin"], dtype=float)
    grid = np.arange(table.size) * step
    model_std = np.interp(wrap360(theta), grid, table, period=360.0)
    noise = float(uncertainty["noise_std_arcmin"])
    return np.sqrt(np.square(model_std) + noise**2).reshape(theta.shape)[()]

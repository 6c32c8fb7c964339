"""Online correction of encoder readings with a model."""

import os

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, model_input, wrap360
from ..models.base import Model, as_angles, direction_mask
from ..models.modelfile import model_to_dict, read_model
from .._core.parameters import check_bool, check_type

__all__ = ["Compensator"]


class Compensator:
    """Subtract a model's predicted error from encoder readings.

    Parameters
    ----------
    model : Model or str or os.PathLike
        A model, or the path of a model file.

    Attributes
    ----------
    model : Model
    source : str or None
        The model file, when built from one.

    Examples
    --------
    >>> from encal.models.fourier import FourierModel
    >>> comp = Compensator(FourierModel([0], [30.0], [0.0]))   # a constant +30 arcmin
    >>> comp.correct([10.0, 0.25]).tolist()
    [9.5, 359.75]
    """

    def __init__(self, model):
        check_type(model, (Model, str, os.PathLike), "model", "Compensator", "a Model or the path of a model file")
        if isinstance(model, Model):
            self.model, self.source, self._sha256 = model, None, None
        else:
            self.model, self._sha256 = read_model(model)
            self.source = os.fspath(model)

    @property
    def sha256(self):
        """Checksum of the model file (None for a model that was never saved)."""
        if self._sha256 is None and self.model.training.get("date"):
            self._sha256 = model_to_dict(self.model)["sha256"]
        return self._sha256

    @property
    def kind(self):
        return self.model.kind

    @property
    def encoder(self):
        return self.model.encoder

    @property
    def reading_sign(self):
        """1, or -1 when the model negates readings first (see :func:`encal._core.angles.model_input`)."""
        return self.model.reading_sign

    def predict(self, theta_enc_deg, direction=None, return_std=False):
        """Predicted error at encoder readings.

        Parameters
        ----------
        theta_enc_deg : float or array-like
            Encoder readings in degrees (any finite value).
        direction : int or array-like of {+1, -1}, optional
            Direction of travel into each reading. A model with one profile per
            direction (``kind='directional'``) uses it, and the mean of both
            without it; the other kinds have one profile and ignore it.
        return_std : bool, default=False
            Also return the model's predictive standard uncertainty (arc-minutes;
            the model must carry an uncertainty).

        Returns
        -------
        mean : float or ndarray
            Predicted error ``encoder - reference`` in arc-minutes, same shape.
        std : float or ndarray
            Only with ``return_std=True``.
        """
        theta = as_angles(theta_enc_deg)
        options = {"return_std": True} if check_bool(return_std, "return_std", "predict") else {}
        if direction is not None:
            forward = direction_mask(direction, theta.shape).reshape(-1)
            options["direction"] = np.where(forward, 1, -1).astype(np.int8)
        # Models see one flat array, whatever the shape of the readings.
        result = self.model.predict(theta.reshape(-1), **options)
        if return_std:
            return tuple(np.reshape(part, theta.shape)[()] for part in result)
        return np.reshape(result, theta.shape)[()]

    def correct(self, theta_enc_deg, direction=None):
        """Corrected angles ``(theta_in - predict(theta_enc) / 60) mod 360``.

        ``theta_in`` is the reading, negated when the model's ``reading_sign`` is -1 (an encoder
        counting against its reference; the corrected angle is then in the reference's sense).
        Parameters are those of :meth:`predict`.

        Returns
        -------
        float or ndarray
            Corrected angles in degrees, in [0, 360), same shape.
        """
        theta = as_angles(theta_enc_deg)
        if direction is None and type(self.model).correct is Model.correct:
            # The same formula, evaluated by the model a chunk at a time (in cache, memory flat).
            return np.reshape(self.model.correct(theta.reshape(-1)), theta.shape)[()]
        # model_input negates and wraps in one rounding, as the model, the runtime and the format do: a reading
        # wrapped before it is negated rounds twice, an ulp away, and at an arc's end inside became outside.
        return wrap360(model_input(theta, self.reading_sign) - self.predict(theta, direction) / ARCMIN_PER_DEG)[()]

    __call__ = correct

    def __repr__(self):
        origin = f" from {self.source}" if self.source else ""
        return f"<Compensator {self.model!r}{origin}>"

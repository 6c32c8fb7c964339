"""A model per direction of travel: the ``directional`` kind.

An encoder with hysteresis (a converter's 1-LSB dead band, a coupling's backlash) reads differently when the
shaft arrives at an angle turning forward (+1) than turning back (-1). A directional model holds one model of
any kind for each direction; it uses the one of the known direction, and the mean of the two when the
direction is not known. Fit one with :func:`encal.fit` from a calibration with a ``direction`` column.
"""

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, model_input, wrap360
from .._core.errors import InputError, ModelFileError
from .base import Model, as_angles, chunk_angles, direction_mask
from .kind import model_kind
from .stored_uncertainty import check_uncertainty

__all__ = ["DirectionalModel"]

_PARTS = ("forward", "reverse")


class DirectionalModel(Model):
    """Two error models, one per direction of travel.

    Parameters
    ----------
    forward : Model
        Predicts the error of readings taken turning forward (direction +1), arc-minutes.
    reverse : Model
        Predicts the error of readings taken turning back (direction -1), arc-minutes.
    encoder, training : dict, optional
        See :class:`~encal.models.base.Model`.

    Examples
    --------
    >>> from encal.models.fourier import FourierModel
    >>> model = DirectionalModel(FourierModel([0], [0.2], [0.0]), FourierModel([0], [-0.2], [0.0]))
    >>> float(model.predict(10.0, direction=1)), float(model.predict(10.0, direction=-1))
    (0.2, -0.2)
    >>> float(model.predict(10.0))
    0.0
    """

    kind = "directional"

    def __init__(self, forward, reverse, *, encoder=None, training=None):
        super().__init__(encoder=encoder, training=training)
        for name, part in (("forward", forward), ("reverse", reverse)):
            if not isinstance(part, Model) or isinstance(part, DirectionalModel):
                raise InputError(f"DirectionalModel expects a one-direction Model as {name}; "
                                 f"got {type(part).__name__}")
        self.forward = forward
        self.reverse = reverse

    def _predict(self, theta_deg):
        return 0.5 * (self.forward._predict(theta_deg) + self.reverse._predict(theta_deg))

    @property
    def evaluation_width(self):
        return max(self.forward.evaluation_width, self.reverse.evaluation_width)

    @property
    def has_uncertainty(self):
        """Whether both parts carry an uncertainty (then ``predict(..., return_std=True)`` works)."""
        return self.forward.uncertainty is not None and self.reverse.uncertainty is not None

    def expected_rms_between_points(self):
        """The parts' posterior estimates of their RMS error at angles not calibrated, pooled (arc-minutes):
        ``sqrt((f² + r²) / 2)``, a reading's direction known; None unless both parts have one."""
        expected = [getattr(part, "expected_rms_between_points", lambda: None)() for part in (self.forward,
                                                                                                self.reverse)]
        if any(value is None for value in expected):
            return None
        return float(np.sqrt(0.5 * (expected[0] ** 2 + expected[1] ** 2)))

    def predict(self, theta_enc_deg, return_std=False, direction=None):
        """Predicted error at the given encoder readings.

        Parameters
        ----------
        theta_enc_deg : float or array-like
            Encoder readings in degrees.
        return_std : bool, default=False
            Also return the standard uncertainty of a new reading's residual (needs both parts to carry an
            uncertainty). With an unknown direction it adds half the predicted reversal in quadrature.
        direction : {+1, -1} or array-like of them, optional
            Direction of travel into each reading (broadcast against ``theta_enc_deg``); ``None`` when not
            known: the mean of both directions' predictions.

        Returns
        -------
        mean : float or ndarray
            Arc-minutes, same shape as ``theta_enc_deg``.
        std : float or ndarray
            Only with ``return_std=True``; arc-minutes.
        """
        theta = model_input(as_angles(theta_enc_deg), self.reading_sign)  # the parts count with the reference
        forward = self.forward.predict(theta, return_std=return_std)
        reverse = self.reverse.predict(theta, return_std=return_std)
        if not return_std:
            forward, reverse = (forward, None), (reverse, None)
        (f_mean, f_std), (r_mean, r_std) = forward, reverse
        if direction is None:
            mean = 0.5 * (f_mean + r_mean)
            if not return_std:
                return mean
            half_reversal = 0.5 * (f_mean - r_mean)
            return mean, np.sqrt(0.5 * (f_std**2 + r_std**2) + half_reversal**2)
        forward_side = direction_mask(direction, theta.shape)
        mean = np.where(forward_side, f_mean, r_mean)[()]
        if not return_std:
            return mean
        return mean, np.where(forward_side, f_std, r_std)[()]

    @property
    def range_deg(self):
        """The calibrated range (see :class:`~encal.models.base.Model`), shared by both parts."""
        return getattr(self, "_range_deg", None)

    @range_deg.setter
    def range_deg(self, value):
        self._range_deg = value
        for part in (self.forward, self.reverse):  # each part answers NaN outside it (issue 31)
            part.range_deg = value

    def correct(self, theta_enc_deg, direction=None, *, table=False):
        """Corrected angles ``(theta_enc - predict(theta_enc, direction=direction) / 60) mod 360``, degrees.

        Evaluated a chunk of angles at a time (:func:`~encal.models.base.in_chunks`'s chunks), so peak memory
        is the result and one chunk's temporaries, as for every other kind.
        """
        theta = as_angles(theta_enc_deg)
        flat = theta.reshape(-1)
        forward_side = None if direction is None else direction_mask(direction, theta.shape).reshape(-1)
        step = chunk_angles(self.evaluation_width)
        out = np.empty(flat.size)
        for start in range(0, flat.size, step):
            inside = model_input(flat[start:start + step], self.reading_sign)  # the parts' angles
            forward, reverse = self.forward._predict(inside), self.reverse._predict(inside)
            if forward_side is None:
                error = 0.5 * (forward + reverse)
            else:
                error = np.where(forward_side[start:start + step], forward, reverse)
            out[start:start + step] = wrap360(inside - error / ARCMIN_PER_DEG)
        if self.range_deg is not None:  # never a number outside the calibrated arc (issue 31)
            from .._core.arcs import inside as in_range

            out[~in_range(model_input(flat, self.reading_sign), self.range_deg)] = np.nan
        return out.reshape(theta.shape)[()]

    def free_parameters(self):
        return self.forward.free_parameters() + self.reverse.free_parameters()

    def parameters(self):
        return {name: self._part_data(getattr(self, name)) for name in _PARTS}

    @staticmethod
    def _part_data(part):
        data = part.file_entry()
        if part.uncertainty is not None:
            data["uncertainty"] = part.uncertainty
        return data

    @classmethod
    def from_parameters(cls, parameters, *, encoder=None, training=None):
        try:
            parts = [cls._part_from_data(parameters[name]) for name in _PARTS]
        except (KeyError, TypeError) as exc:
            raise ModelFileError(f"directional parameters: expected 'forward' and 'reverse' objects with "
                                 f"'kind' and 'parameters', got {exc!s}") from None
        return cls(*parts, encoder=encoder, training=training)

    @staticmethod
    def _part_from_data(data):
        kind = data["kind"]
        if kind == DirectionalModel.kind:
            raise ModelFileError("directional parameters: expected one-direction parts, got a directional part")
        try:
            part_kind = model_kind(kind, role="kind of a directional model's part", directional_part=True)
        except InputError as exc:
            raise ModelFileError(f"directional parameters: {exc}") from None
        part = part_kind.read(data["parameters"])
        if data.get("uncertainty") is not None:
            part.uncertainty = check_uncertainty(data["uncertainty"], "directional part uncertainty")
        return part

    def __repr__(self):
        name = self.encoder.get("name") or "unnamed encoder"
        return (f"<DirectionalModel forward={self.forward.kind!r} reverse={self.reverse.kind!r} "
                f"for {name}>")

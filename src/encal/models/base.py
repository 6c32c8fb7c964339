"""The interface every error model implements.

A model is a periodic function of the encoder reading: it predicts the error
``encoder - reference`` in arc-minutes from the encoder angle in degrees. The
corrected angle is ``(encoder - predicted / 60) mod 360``.

Each model kind is a subclass with a ``kind`` name, listed in
:mod:`encal.models.registry`; its ``parameters()`` are plain JSON data (lists
and floats) from which ``from_parameters`` rebuilds it exactly. The model file
stores ``kind``, ``parameters()`` and the metadata dicts.
"""

from abc import ABC, abstractmethod

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, model_input, wrap360
from .._core.arcs import inside
from .._core.errors import InputError
from .._core.parameters import check_bool, invalid
from ._table import TABLE_MIN_ANGLES, correct_through_table
from .modelfile import save_model
from .stored_uncertainty import predictive_std

__all__ = ["Model", "as_angles", "direction_mask", "in_chunks", "chunk_angles"]

#: Angles per evaluation of a model's formula: its temporaries (angles x orders, x neurons, ...) stay
#: within a few MB, in cache, whatever the number of angles.
CHUNK_ANGLES = 1 << 13
#: Most temporary numbers of one chunk: a wide model (a network of 2000 neurons) takes fewer angles at a time.
CHUNK_NUMBERS = 1 << 21


def as_angles(theta_enc_deg):
    """Encoder angles as a float array (any shape), checked finite."""
    if theta_enc_deg is None:
        raise InputError("encoder angles must be finite numbers of degrees; got None")
    try:
        theta = np.asarray(theta_enc_deg, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:  # 'abc', a dict, a complex number, a ragged list, 10**400
        raise InputError(f"encoder angles must be finite numbers of degrees; {exc}") from None
    if not np.all(np.isfinite(theta)):
        raise InputError("encoder angles must be finite numbers of degrees (found NaN or infinity)")
    return theta


def direction_mask(direction, shape):
    """``True`` where a reading was taken turning forward: ``direction`` (+1 or -1 per reading) checked and
    broadcast to ``shape``.

    Raises
    ------
    InputError
        If a value is not +1 or -1, or the shape does not broadcast.
    """
    values = np.asarray(direction)
    expected = "+1 (forward), -1 (reverse) or None (unknown), one value or one per reading"
    if values.dtype.kind not in "iuf" or not np.all(np.isin(values, (-1, 1))):
        raise invalid("direction", "predict", expected, direction,
                      shown=f"the values {np.unique(values)[:4].tolist()}")
    try:
        return np.broadcast_to(values > 0, shape)
    except ValueError:
        raise invalid("direction", "predict", f"{expected} (the shape {shape} of the encoder angles)", direction,
                      shown=f"the shape {values.shape}") from None


def chunk_angles(width=1):
    """Angles per chunk for a model of ``width`` temporary numbers per angle (see :func:`in_chunks`)."""
    return max(1, min(CHUNK_ANGLES, CHUNK_NUMBERS // max(1, int(width))))


def in_chunks(function, theta, width=1):
    """``function(theta)`` for a flat float array, evaluated a chunk of angles at a time.

    A chunk holds :data:`CHUNK_ANGLES` angles, fewer for a wide model (``width`` temporary numbers per
    angle: a network's hidden nodes, a series' terms), at most :data:`CHUNK_NUMBERS` numbers in all.
    ``function`` maps a flat array to values of the same size; peak memory is then the result plus
    one chunk's temporaries, whatever ``theta.size`` and the model's width.
    """
    step = chunk_angles(width)
    if theta.size <= step:
        return function(theta)
    out = np.empty(theta.size)
    for start in range(0, theta.size, step):
        out[start:start + step] = function(theta[start:start + step])
    return out


class Model(ABC):
    """An error model ``predict(theta_enc_deg) -> error_arcmin``.

    Attributes
    ----------
    kind : str
        Registered name of the model family (``'fourier'``, ``'lut'``, ``'ann'``, ...).
    form : str or None
        For a kind the model-file format does not name: the form its ``parameters()`` take, one of
        :data:`encal.runtime.FORMS` (a new kind stored as a Fourier series says ``'fourier'``), so that the
        model file, the standalone runtime and the C export hold and evaluate it unchanged. None for the kinds
        the format names (:data:`encal.runtime.KIND_FORMS`), which have their own form.
    encoder : dict
        The encoder's name and resolution (``{'name': str, 'resolution_bits': int | None}``).
    training : dict
        How the model was made (method, algorithm, options, seed, data hash, ...).
    uncertainty : dict or None
        Prediction uncertainty as JSON-ready data (see :mod:`encal.models.uncertainty`), or ``None`` when the
        model has none. The model file stores it as its ``uncertainty`` field.
    reading_sign : {1, -1}
        -1 when the encoder counts against its reference (the calibration was read with ``reverse=True``):
        the model is then evaluated at ``-theta_enc`` (see :func:`encal._core.angles.model_input`) and the
        corrected angle is in the reference's sense. Set by :func:`encal.fit`; stored in the model file.
    """

    kind = "abstract"
    form = None
    uncertainty = None
    reading_sign = 1
    #: ``[start, end]`` in degrees of the model's input angle when the model was calibrated over an arc (see
    #: :mod:`encal._core.arcs`): outside it ``predict`` and ``correct`` answer NaN. None for a full turn.
    range_deg = None

    def __init__(self, *, encoder=None, training=None):
        self.encoder = dict(encoder or {})
        self.training = dict(training or {})

    @abstractmethod
    def _predict(self, theta_deg):
        """Predicted error in arcmin at angles ``theta_deg`` (finite 1-D ndarray, degrees in [0, 360))."""

    @abstractmethod
    def parameters(self):
        """Everything needed to evaluate the model, as JSON-ready data."""

    @abstractmethod
    def free_parameters(self):
        """Number of fitted values (``int``): what the tie rule of ``fit(method='auto')`` counts."""

    @classmethod
    @abstractmethod
    def from_parameters(cls, parameters, *, encoder=None, training=None):
        """Rebuild a model from ``parameters()``."""

    def file_entry(self):
        """The model as a stack's member or a directional model's part stores it: ``{'kind', 'parameters'}``,
        and ``'form'`` for a kind the model-file format does not name."""
        return {"kind": self.kind, **({} if self.form is None else {"form": self.form}),
                "parameters": self.parameters()}

    def predict(self, theta_enc_deg, return_std=False, direction=None):
        """Predicted error at the given encoder readings.

        Every kind has this signature; only a ``'directional'`` model's prediction depends on ``direction``.

        Parameters
        ----------
        theta_enc_deg : float or array-like
            Encoder readings in degrees (any real value; the model is periodic), as the encoder gives
            them: a model with ``reading_sign=-1`` negates them first.
        return_std : bool, default=False
            Also return the standard uncertainty of a new reading's residual
            (needs :attr:`uncertainty`, see :func:`encal.models.uncertainty.add_uncertainty`).
        direction : {+1, -1} or array-like of them, optional
            Direction of travel into each reading (broadcast against ``theta_enc_deg``), ``None`` when not
            known. A model of one profile has the same error both ways: it checks the values and ignores
            them.

        Returns
        -------
        mean : float or ndarray
            Predicted error ``encoder - reference`` in arc-minutes, same shape.
        std : float or ndarray
            Only with ``return_std=True``: ``sqrt(sigma_model**2 + sigma_noise**2)`` in arc-minutes,
            same shape.
        """
        return_std = check_bool(return_std, "return_std", "predict")
        theta = model_input(as_angles(theta_enc_deg), self.reading_sign)
        if direction is not None:
            direction_mask(direction, theta.shape)
        # Subclasses see a flat array of angles in [0, 360); the caller's shape is restored here.
        mean = np.asarray(in_chunks(self._predict, theta.reshape(-1), self.evaluation_width),
                          dtype=float).reshape(theta.shape)
        outside = None if self.range_deg is None else ~inside(theta, self.range_deg)
        if outside is not None:
            mean[outside] = np.nan  # never a number where the encoder was not calibrated
        if not return_std:
            return mean[()]
        std = np.array(predictive_std(self.uncertainty, theta), dtype=float).reshape(theta.shape)
        if outside is not None:
            std[outside] = np.nan
        return mean[()], std[()]

    #: Temporary numbers per angle of ``_predict`` (a network's hidden nodes, a series' terms): angles are
    #: evaluated in chunks small enough that memory stays bounded however wide the model (see in_chunks).
    evaluation_width = 1

    def correct(self, theta_enc_deg, direction=None, *, table=False):
        """Corrected angles ``(theta_in - predict(theta_enc, direction=direction) / 60) mod 360``, in degrees.

        ``theta_in = model_input(theta_enc, reading_sign)``: the reading itself unless the encoder counts
        against its reference. ``direction`` as for :meth:`predict`.

        ``table=True`` corrects a large array (:data:`~encal.models._table.TABLE_MIN_ANGLES` angles or more)
        through a table of the model built once, interpolated within
        :data:`~encal.models._table.TABLE_TOLERANCE_ARCMIN` of the formula, several times faster (BENCHMARKS.md,
        "Hot paths"). It is asked for, never the default: by default an angle's correction is the formula's
        to rounding, the same whatever the size of the array it comes in (``encal correct`` streams in chunks
        of any size, and the runtime and every export are judged against this).
        """
        theta = as_angles(theta_enc_deg)
        table = check_bool(table, "table", "correct")
        if table and direction is None and self.range_deg is None and theta.size >= TABLE_MIN_ANGLES:
            table = self._correction_table()
            if table is not None:  # many angles: through a table of the model (see encal.models._table)
                return correct_through_table(theta.reshape(-1), self.reading_sign, table).reshape(theta.shape)
        if direction is None:  # chunk by chunk: peak memory is the result and one chunk's temporaries
            return in_chunks(self._correct, theta.reshape(-1), self.evaluation_width).reshape(theta.shape)[()]
        return self._correct(theta, direction)

    _table = False  # the correction table, built on first use; None: none fits

    def _table_bound(self):
        """``(max|f''|, largest slope jump)`` of the model's error, in arc-minutes per degree squared and per
        degree, from its parameters; None when the model has no such bound (a table would not be exact)."""
        return None

    def _correction_table(self):
        """A table of ``predict / 60`` for :func:`encal.models._table.correct_through_table`, within
        :data:`~encal.models._table.TABLE_TOLERANCE_ARCMIN` of the model (:meth:`_table_bound`), or None
        (evaluated as it is)."""
        if self._table is False:
            from ._table import points_for_bound, sampled_table

            bound = self._table_bound()
            points = None if bound is None else points_for_bound(*bound)
            self._table = None if points is None else sampled_table(
                lambda nodes: in_chunks(self._predict, nodes, self.evaluation_width), points)
        return self._table

    def _correct(self, theta, direction=None):
        # model_input wraps first: multi-turn readings keep their precision
        wrapped = model_input(theta, self.reading_sign)
        if direction is None and theta.ndim == 1 and type(self).predict is Model.predict:
            # a chunk of correct(): predict's own steps without repeating its checks and wrap
            predicted = in_chunks(self._predict, wrapped, self.evaluation_width)
        else:
            predicted = self.predict(theta, direction=direction)
        corrected = wrap360(wrapped - predicted / ARCMIN_PER_DEG)
        if self.range_deg is not None:
            corrected = np.where(inside(wrapped, self.range_deg), corrected, np.nan)
        return corrected

    def save(self, path, **options):
        """Write the model file (see :func:`encal.deploy.save_model`)."""
        return save_model(self, path, **options)

    def __str__(self):
        """A short table: kind, encoder, how it was fitted, its size and the error it predicts (arcmin)."""
        name = self.encoder.get("name") or "unnamed encoder"
        grid = np.linspace(0.0, 360.0, 3600, endpoint=False)
        predicted = self.predict(grid)
        training = self.training
        fitted = ", ".join(f"{key} {training[key]}" for key in ("method", "seed") if training.get(key) is not None)
        rows = [("kind", self.kind), ("encoder", name),
                ("fitted on", f"{training.get('n_points', '?')} points" + (f" ({fitted})" if fitted else "")),
                ("parameters", f"{self.free_parameters()} fitted values")]
        if training.get("zero_offset_arcmin") is not None:
            rows.append(("zero offset", f"{training['zero_offset_arcmin']:+.3f} arcmin (arbitrary zero, in the model)"))
        over = "0..360 deg" if self.range_deg is None else f"{self.range_deg[0]:.6g}..{self.range_deg[1]:.6g} deg"
        rows += [("predicts", f"{np.nanmin(predicted):+.3f} .. {np.nanmax(predicted):+.3f} arcmin over {over}, "
                              f"peak-to-peak {np.nanmax(predicted) - np.nanmin(predicted):.3f}"),
                 ("uncertainty", "yes" if self.uncertainty is not None else "no")]
        width = max(len(label) for label, _ in rows)
        return "\n".join(f"{label:<{width}}  {value}" for label, value in rows)

    def _repr_html_(self):
        """Rich display in a notebook: the text table and the figure."""
        from ..figures import html_repr

        return html_repr(self)

    def plot(self, ax=None, *, data=None, title=None):
        """The predicted error (arcmin) against the encoder angle (deg), with its uncertainty band when the
        model has one and the calibration points ``data = (theta_deg, error_arcmin)`` if given; returns the axes."""
        from ..figures import plot_model

        return plot_model(self, data=data, ax=ax, title=title)

    def __repr__(self):
        name = self.encoder.get("name") or "unnamed encoder"
        return f"<{type(self).__name__} kind={self.kind!r} for {name}>"

"""Lookup-table error model (Kaul et al. 1997).

The calibration points themselves are the table: between them the error is
interpolated, linearly or by a periodic cubic spline, around the whole circle
(the segment from the last angle to the first one + 360° closes it). The table
is stored as a periodic piecewise polynomial in SciPy's ``PPoly`` convention,
so the model file alone evaluates it.
"""

import numpy as np

from .._core.errors import InputError, ModelFileError
from .._core.parameters import check_choice
from ..analysis.profile import ANGLE_TOLERANCE_DEG, distinct_angles, profile_arrays
from .base import Model

__all__ = ["LookupTableModel", "fit_lut"]

#: Polynomial degree of each interpolation.
DEGREE = {"linear": 1, "cubic": 3}

#: The cubic table averages readings closer than this fraction of the median spacing into one entry.
#: A spline through two noisy readings a hair apart takes the slope between them, and swings far past
#: the data (a random 2000-point calibration within ±3.3 arcmin gave a spline reaching 1800 arcmin);
#: with this fraction it stayed within ±4.6. No real calibration of ../shared/data/real comes near it
#: (its closest readings are 0.73 of the median spacing apart), and a uniform grid never does.
CUBIC_MERGE_FRACTION = 0.1


class LookupTableModel(Model):
    """A periodic piecewise polynomial of the encoder angle.

    Parameters
    ----------
    breaks_deg : sequence of float of length n + 1
        Increasing break points in degrees with ``breaks_deg[-1] == breaks_deg[0] + 360``.
    coefficients : sequence of sequences, shape (degree + 1, n)
        ``PPoly`` coefficients: on ``[x_i, x_{i+1})``,
        ``ε̂(θ) = Σ_m c[m][i] (θ - x_i)^(degree - m)``, in arc-minutes.
    interpolation : {'linear', 'cubic'}
        The interpolation the table was made with (degree 1 or 3).
    encoder, training : dict, optional
        See :class:`~encal.models.base.Model`.

    Examples
    --------
    >>> model = LookupTableModel([0.0, 180.0, 360.0], [[0.01, -0.01], [0.0, 1.8]], "linear")
    >>> float(model.predict(90.0)), float(model.predict(-90.0))
    (0.9, 0.9)
    """

    kind = "lut"

    def __init__(self, breaks_deg, coefficients, interpolation, *, encoder=None, training=None):
        super().__init__(encoder=encoder, training=training)
        if interpolation not in DEGREE:
            raise InputError(
                f"LookupTableModel expects interpolation 'linear' or 'cubic'; got {interpolation!r}"
            )
        breaks = np.asarray(breaks_deg, dtype=float).reshape(-1)
        coefficients = np.asarray(coefficients, dtype=float)
        degree = DEGREE[interpolation]
        if (
            breaks.size < 2
            or not np.all(np.isfinite(breaks))
            or not np.all(np.diff(breaks) > 0)
            or not np.isclose(breaks[-1] - breaks[0], 360.0, rtol=0.0, atol=1e-9)
        ):
            raise InputError(
                "LookupTableModel expects increasing breaks_deg spanning exactly 360 degrees "
                f"(last = first + 360); got {breaks.size} breaks from {breaks[:1].tolist()} "
                f"to {breaks[-1:].tolist()}"
            )
        if coefficients.shape != (degree + 1, breaks.size - 1) or not np.all(np.isfinite(coefficients)):
            raise InputError(
                f"LookupTableModel expects finite {interpolation} coefficients of shape "
                f"({degree + 1}, {breaks.size - 1}); got shape {coefficients.shape}"
            )
        self.interpolation = interpolation
        self.breaks_deg = breaks
        self.coefficients = coefficients
        self._pieces = _PieceIndex(breaks)
        # One row per piece, its break and its terms (constant first): one gather fetches a reading's all.
        self._rows = np.ascontiguousarray(np.vstack([breaks[:-1], coefficients[::-1]]).T)
        self._rows[:, 1] += 0.0  # PPoly's sum starts from 0.0: a constant term -0.0 counts as +0.0

    @property
    def table_deg(self):
        """Encoder angles of the table entries, in degrees."""
        return self.breaks_deg[:-1]

    @property
    def table_arcmin(self):
        """Errors of the table entries, in arc-minutes."""
        return self.coefficients[-1]

    def _predict(self, theta_deg):
        first = self.breaks_deg[0]
        inside = theta_deg
        # Into [x_0, x_0 + 360) without touching angles already there (table points stay exact); when all
        # are (the expression's floor is 0 for the extremes, hence for all), theta_deg is the answer.
        if not (theta_deg.size and first <= theta_deg.min() and (theta_deg.max() - first) / 360.0 < 1.0):
            inside = theta_deg - 360.0 * np.floor((theta_deg - first) / 360.0)
        # PPoly's sum, term by term in its order (c_d + c_{d-1} s + c_{d-2} s^2 + ..., the powers by
        # repeated products), with its pieces found by index arithmetic instead of a bisection.
        rows = np.take(self._rows, self._pieces.locate(inside), axis=0)
        offset = inside - rows[:, 0]
        total = rows[:, 1] + rows[:, 2] * offset
        power = offset
        for m in range(3, rows.shape[1]):
            power = power * offset
            total += rows[:, m] * power
        return total

    def _table_bound(self):
        from ._table import piecewise_bound

        return piecewise_bound(self.breaks_deg, self.coefficients)

    def free_parameters(self):
        return self.breaks_deg.size - 1

    def parameters(self):
        return {
            "interpolation": self.interpolation,
            "breaks_deg": [float(x) for x in self.breaks_deg],
            "coefficients": [[float(c) for c in row] for row in self.coefficients],
        }

    @classmethod
    def from_parameters(cls, parameters, *, encoder=None, training=None):
        try:
            return cls(parameters["breaks_deg"], parameters["coefficients"], parameters["interpolation"],
                       encoder=encoder, training=training)
        except (KeyError, TypeError, ValueError) as exc:
            reason = f"missing key {exc}" if isinstance(exc, KeyError) else str(exc)
            raise ModelFileError(
                "lut model parameters must be {'interpolation', 'breaks_deg', 'coefficients'} "
                f"as in docs/model-file.md; {reason}"
            ) from None

    def __repr__(self):
        name = self.encoder.get("name") or "unnamed encoder"
        return f"<LookupTableModel {self.interpolation} with {self.table_deg.size} entries for {name}>"


#: A table fitted to more distinct angles than this (a dense sweep) averages them in as many equal bins.
DENSE_ENTRIES = 4096


class _PieceIndex:
    """Which piece of increasing breaks holds each angle, by index arithmetic (``PPoly``'s choice).

    A grid of equal cells over the breaks' span stores the last break at or below each cell's start; an
    angle's cell is one multiplication away (taken a hair low, so rounding never puts an angle a cell
    late), and comparisons with the next break, as many as the most breaks a cell holds plus one, finish
    the search: for breaks on a uniform grid, the usual table, two. The answer is the piece ``i`` with
    ``breaks[i] <= x < breaks[i + 1]``, the first piece below the first break and the last one from the
    last break on, as ``PPoly`` extrapolates.
    """

    def __init__(self, breaks):
        self.cells = 4 * (breaks.size - 1)
        self.scale = self.cells / (breaks[-1] - breaks[0])
        self.shift = breaks[0] * self.scale + 1e-6
        starts = breaks[0] + np.arange(self.cells + 2) / self.scale
        self.first_piece = np.clip(np.searchsorted(breaks, starts, side="right") - 1, 0, breaks.size - 2)
        # an angle is placed in its cell or the one before: as many steps as breaks in two cells
        self.steps = int(np.max(self.first_piece[2:] - self.first_piece[:-2], initial=0))
        # the break that ends each piece; the last piece never ends (PPoly extrapolates it)
        self.piece_end = np.concatenate((breaks[1:-1], [np.inf]))

    def locate(self, x):
        """Pieces of the angles ``x`` (degrees, within a hair of the breaks' span), as an int array."""
        cell = x * self.scale - self.shift  # a millionth of a cell low: far more than any rounding
        np.clip(cell, 0.0, self.cells, out=cell)
        piece = np.take(self.first_piece, cell.astype(np.intp))
        for _ in range(self.steps):
            piece += x >= np.take(self.piece_end, piece)
        return piece


def fit_lut(theta_enc_deg, error_arcmin, *, interpolation="linear", max_entries=DENSE_ENTRIES):
    """Build a lookup-table model from calibration points.

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees, any order; wrapped to [0, 360).
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.
    interpolation : {'linear', 'cubic'}, default='linear'
        Periodic linear interpolation, or a periodic cubic spline
        (``scipy.interpolate.CubicSpline`` with ``bc_type='periodic'``).
    max_entries : int or None, default=DENSE_ENTRIES
        Most table entries. A dense sweep with more distinct angles is averaged in
        ``max_entries`` equal bins of encoder angle (each entry the mean angle and mean error
        of its readings): a table of 50,000 breaks through noisy readings follows their noise
        and costs firmware memory for nothing. An angle within 1e-9° below a bin's edge is the
        edge's (the edges fall on codes, which a unit's conversion can give back a hair low).
        None keeps every distinct angle.

    Returns
    -------
    LookupTableModel
        Passes exactly through every distinct calibration point. Repeated
        encoder angles (closer than 1e-9°) become one entry holding the mean
        of their errors; for ``'cubic'``, so do readings closer than
        :data:`CUBIC_MERGE_FRACTION` of the median spacing (the entry at their
        mean angle), which a spline would otherwise join by a steep swing far
        beyond the data. ``training`` records the interpolation and the
        number of entries.

    Examples
    --------
    >>> model = fit_lut([270.0, 90.0, 90.0], [-1.0, 1.0, 2.0])
    >>> float(model.predict(90.0)), float(model.predict(0.0))
    (1.5, 0.25)
    """
    check_choice(interpolation, "interpolation", "fit_lut", tuple(DEGREE))
    theta, error = profile_arrays(theta_enc_deg, error_arcmin, "fit_lut")
    if max_entries is not None and (isinstance(max_entries, bool) or not isinstance(max_entries, (int, np.integer))
                                    or max_entries < 2):
        raise InputError(f"The 'max_entries' parameter of fit_lut must be an int >= 2 or None. "
                         f"Got {max_entries!r} instead.")
    angles, group = distinct_angles(theta)
    binned_from = None
    if max_entries is not None and angles.size > max_entries:
        binned_from = int(angles.size)
        # An angle within ANGLE_TOLERANCE_DEG below a bin's edge is the edge's, as distinct_angles makes them one
        # angle: the edges fall on codes (every 4th of a 14-bit encoder), which a file in radians or in (-180, 180]
        # gives back a hair below, and the bin below took them (the table moved by the readings' scatter).
        position = (theta + ANGLE_TOLERANCE_DEG) * (max_entries / 360.0)
        wraps = position >= max_entries  # a hair below 360: the angle 0's bin
        group = np.where(wraps, 0, np.minimum(position.astype(int), max_entries - 1))
        _, group = np.unique(group, return_inverse=True)
        angles = np.maximum(np.bincount(group, weights=np.where(wraps, theta - 360.0, theta)) / np.bincount(group),
                            0.0)
    counts = np.bincount(group)
    values = np.bincount(group, weights=error) / counts
    if interpolation == "cubic":
        angles, values = _merge_close(angles, values, counts, CUBIC_MERGE_FRACTION)
    breaks = np.r_[angles, angles[0] + 360.0]
    closed = np.r_[values, values[0]]
    if interpolation == "linear":
        coefficients = np.vstack([np.diff(closed) / np.diff(breaks), values])
    else:
        from scipy.interpolate import CubicSpline  # here: reading a table model needs no SciPy

        coefficients = CubicSpline(breaks, closed, bc_type="periodic").c
    training = {"interpolation": interpolation, "n_entries": int(angles.size)}
    if binned_from is not None:
        training["binned_from_angles"] = binned_from
    return LookupTableModel(breaks, coefficients, interpolation, training=training)


def _merge_close(angles, values, counts, fraction):
    """Average runs of increasing ``angles`` (degrees) closer than ``fraction`` of their median spacing.

    Each run becomes one entry at its readings' mean angle with their mean error; ``counts`` (readings per
    entry) weight both. A run may span 0/360. Returns the angles (increasing, in [0, 360)) and values.
    """
    gaps = np.diff(np.r_[angles, angles[0] + 360.0])  # gaps[i]: from angles[i] to the next, round the circle
    close = gaps < fraction * np.median(gaps)
    if angles.size < 3 or not close.any():
        return angles, values
    if close.all():  # every reading within a tiny arc of the next: nothing to interpolate between
        return angles, values
    # Start the circle just after a wide gap, so no run is split by the wrap.
    first = (int(np.flatnonzero(~close)[-1]) + 1) % angles.size
    order = np.roll(np.arange(angles.size), -first)
    unwrapped = angles[order] + 360.0 * (order < first)
    run = np.r_[0, np.cumsum(~close[order][:-1])]
    weight = np.bincount(run, weights=counts[order])
    merged_angles = np.mod(np.bincount(run, weights=counts[order] * unwrapped) / weight, 360.0)
    merged_values = np.bincount(run, weights=counts[order] * values[order]) / weight
    increasing = np.argsort(merged_angles, kind="stable")
    return merged_angles[increasing], merged_values[increasing]

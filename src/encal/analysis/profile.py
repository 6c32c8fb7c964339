"""Error profile statistics and harmonic analysis.

An error profile is the error ``encoder - reference`` in arc-minutes at a set
of encoder angles in degrees. This module summarises it (:func:`error_stats`)
and splits it into harmonics of the shaft angle (:func:`harmonics`), the
analysis the paper uses to choose the terms of its Fourier-series model.

The harmonic analysis is a least-squares fit of ``a_k cos(k θ) + b_k sin(k θ)``,
so it works on any set of angles; on a uniform grid it equals the discrete
Fourier transform, and is computed with the FFT. How many orders a set of
angles can identify is decided by :func:`identifiable_order`;
``docs/statistics.md`` explains the rules.
"""

import math
import numbers
from dataclasses import dataclass

import numpy as np

from ..numerics.trigsums import trig_moments, trig_moments_real
from .._core.angles import ARCMIN_PER_DEG, wrap180, wrap360
from .._core.errors import InputError
from .._core.parameters import check_choice, check_number, invalid, real_array
from .._core.sorting import stable_argsort

__all__ = [
    "ErrorStats",
    "error_stats",
    "ZERO_MODES",
    "ARBITRARY_ZERO_ARCMIN",
    "zero_offset_arcmin",
    "zero_is_arbitrary",
    "zero_sentence",
    "WORSE_MARGIN",
    "correction_is_worse",
    "worse_sentence",
    "remove_offset",
    "Harmonics",
    "harmonics",
    "identifiable_order",
    "fit_harmonic_series",
    "harmonic_series_and_order",
    "nested_harmonic_predictions",
    "rank_orders",
    "uniform_grid",
    "distinct_angles",
]

#: Encoder angles closer than this (degrees) are the same angle; 1e-9° is
#: about 1e-5 of the LSB of a 24-bit encoder.
ANGLE_TOLERANCE_DEG = 1e-9

#: A design matrix whose smallest singular value is below this fraction of its
#: largest cannot identify its coefficients (numerical rank deficiency).
_RCOND = 1e-8

#: A grid is regular when each angle lies within this fraction of the spacing
#: of its own node of a uniform grid (Kadec's 1/4 bound).
_REGULAR_DEVIATION = 0.25

#: Conjugate gradients on the normal equations stop when the residual is below
#: this fraction of the right-hand side, and give up (for the QR) after so many steps.
_CG_RTOL = 1e-14
_CG_MAX_ITER = 1000


# --------------------------------------------------------------------------- statistics


#: How a reference's zero is treated: 'fixed' counts the offset as error, 'arbitrary' states it apart,
#: 'auto' decides by :data:`ARBITRARY_ZERO_ARCMIN`.
ZERO_MODES = ("auto", "arbitrary", "fixed")

#: With ``zero='auto'`` a zero offset larger than this (arc-minutes; 1 degree) marks the reference's zero as
#: arbitrary: a rotary table's zero is set to arc-minutes, a motor's is wherever it stood when it started.
ARBITRARY_ZERO_ARCMIN = 60.0


def zero_offset_arcmin(error_arcmin):
    """The zero offset of an error profile: the circular mean of the errors, in arc-minutes.

    Parameters
    ----------
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.

    Returns
    -------
    float
        ``arg mean exp(i e)``, in arc-minutes within (-10800, 10800].

    Examples
    --------
    >>> round(zero_offset_arcmin([3540.0, 3550.0, 3560.0]), 6)
    3550.0
    >>> round(zero_offset_arcmin([10790.0, -10790.0]), 6)   # about 180 degrees, across the wrap
    10800.0
    """
    radians = np.radians(np.asarray(error_arcmin, dtype=float).reshape(-1) / ARCMIN_PER_DEG)
    mean = np.degrees(np.arctan2(np.sin(radians).mean(), np.cos(radians).mean()))
    return float(wrap180(mean)) * ARCMIN_PER_DEG


def zero_is_arbitrary(zero, *offsets_arcmin):
    """Whether statistics are taken about the zero offset under ``zero`` ('auto', 'arbitrary', 'fixed').

    With 'auto' the zero is arbitrary when any of ``offsets_arcmin`` exceeds :data:`ARBITRARY_ZERO_ARCMIN`.
    """
    check_choice(zero, "zero", "zero_is_arbitrary", ZERO_MODES)
    if zero != "auto":
        return zero == "arbitrary"
    return any(abs(offset) > ARBITRARY_ZERO_ARCMIN for offset in offsets_arcmin)


def zero_sentence(zero, offset_arcmin, arbitrary):
    """One sentence saying how the zero offset was treated, for a report or a terminal.

    Parameters
    ----------
    zero : {'auto', 'arbitrary', 'fixed'}
        What the user asked for.
    offset_arcmin : float
        The zero offset (circular mean of the errors), arc-minutes.
    arbitrary : bool
        Whether the statistics are about the offset (:func:`zero_is_arbitrary`).
    """
    value = f"zero offset {offset_arcmin:+.2f} arcmin ({offset_arcmin / ARCMIN_PER_DEG:+.3f} deg)"
    if arbitrary and zero == "auto":
        return (f"{value}, larger than {ARBITRARY_ZERO_ARCMIN / ARCMIN_PER_DEG:g} deg: the reference's zero is "
                "taken as arbitrary (a motor's start position), the offset is stated apart and the statistics "
                "are of the shape about it (--zero fixed counts it as error)")
    if arbitrary:
        return f"{value}, stated apart as asked (arbitrary zero); the statistics are of the shape about it"
    if zero == "auto":
        return (f"{value}, within {ARBITRARY_ZERO_ARCMIN / ARCMIN_PER_DEG:g} deg: the reference's zero is taken "
                "as fixed and the offset counts as error (--zero arbitrary states it apart)")
    return f"{value}, counted as error as asked (fixed zero)"


#: A correction makes a calibration's errors larger when their RMS after it exceeds the RMS before it by more than
#: this share: an RMS over a few hundred points varies by a few per cent from one set of readings to the next, so a
#: correction within the noise is not called worse.
WORSE_MARGIN = 0.01


def correction_is_worse(before_rms_arcmin, after_rms_arcmin):
    """Whether a correction leaves a larger RMS error than none (by more than :data:`WORSE_MARGIN`)."""
    return bool(after_rms_arcmin > before_rms_arcmin * (1.0 + WORSE_MARGIN) + 1e-9)


def worse_sentence(before_rms_arcmin, after_rms_arcmin, where=""):
    """The sentence saying that a correction makes the errors larger, with both figures; None when it does not.

    Parameters
    ----------
    before_rms_arcmin, after_rms_arcmin : float
        RMS error without and with the correction, arc-minutes.
    where : str, default=''
        Where, for the sentence (e.g. ``' on enc2.csv'``).
    """
    if not correction_is_worse(before_rms_arcmin, after_rms_arcmin):
        return None
    return (f"the correction makes the errors larger{where}: RMS {before_rms_arcmin:.4g} arcmin without it, "
            f"{after_rms_arcmin:.4g} arcmin with it ({after_rms_arcmin / max(before_rms_arcmin, 1e-300):.2f} times); "
            "expected a model that fits this encoder as it is mounted now (a model of another encoder, of this "
            "one before it was remounted, or one whose fit went wrong, can do more harm than none: fit it again "
            "and check its held-out estimate)")


@dataclass(frozen=True)
class ErrorStats:
    """Summary statistics of errors, in arc-minutes.

    Attributes
    ----------
    n : int
        Number of errors.
    mae : float
        Mean absolute error, ``mean(|e|)``.
    rms : float
        Root mean square about zero, ``sqrt(mean(e**2))``.
    std : float
        Root mean square about the mean (population standard deviation,
        ``ddof=0``), so that ``rms**2 == mean**2 + std**2``.
    min, max : float
        Smallest and largest (signed) error.
    pp : float
        Peak-to-peak error ``max - min``.
    offset : float or None
        The zero offset taken out of the errors before the statistics above (arbitrary zero,
        see :func:`error_stats`), or None when they are about zero.
    """

    n: int
    mae: float
    rms: float
    std: float
    min: float
    max: float
    pp: float
    offset: float | None = None

    @property
    def max_abs(self):
        """Largest absolute error, in arc-minutes."""
        return max(abs(self.min), abs(self.max))

    def as_dict(self):
        """The statistics as JSON-ready data with unit-bearing keys.

        ``zero_offset_arcmin`` is present only when the statistics are about a zero offset.

        Examples
        --------
        >>> sorted(error_stats([1.0, -1.0]).as_dict())  # doctest: +NORMALIZE_WHITESPACE
        ['mae_arcmin', 'max_abs_arcmin', 'max_arcmin', 'min_arcmin', 'n', 'pp_arcmin',
         'rms_arcmin', 'std_arcmin']
        """
        data = {
            "n": int(self.n),
            "mae_arcmin": float(self.mae),
            "rms_arcmin": float(self.rms),
            "std_arcmin": float(self.std),
            "min_arcmin": float(self.min),
            "max_arcmin": float(self.max),
            "max_abs_arcmin": float(self.max_abs),
            "pp_arcmin": float(self.pp),
        }
        if self.offset is not None:
            data["zero_offset_arcmin"] = float(self.offset)
        return data

    def rows(self):
        """``(label, value)`` of every statistic, in the order tables show them (arc-minutes; n a count)."""
        rows = [("n", self.n)]
        if self.offset is not None:
            rows.append(("zero offset (apart)", self.offset))
        return rows + [("MAE", self.mae), ("RMS", self.rms), ("STD (RMS about mean)", self.std),
                       ("min", self.min), ("max", self.max), ("peak-to-peak", self.pp), ("max |error|", self.max_abs)]

    def __str__(self):
        """A two-column table of the statistics, in arc-minutes.

        Examples
        --------
        >>> print(error_stats([1.0, 2.0, 3.0]))  # doctest: +NORMALIZE_WHITESPACE
        statistic                 arcmin
        n                              3
        MAE                        2.000
        RMS                        2.160
        STD (RMS about mean)       0.816
        min                        1.000
        max                        3.000
        peak-to-peak               2.000
        max |error|                3.000
        """
        lines = [f"{'statistic':<22}{'arcmin':>10}"]
        for label, value in self.rows():
            lines.append(f"{label:<22}{value:>10d}" if label == "n" else f"{label:<22}{value:>10.3f}")
        return "\n".join(lines)

    def _repr_html_(self):
        """Rich display in a notebook: the text table and the figure."""
        from ..figures import html_repr

        return html_repr(self)

    def plot(self, ax=None, *, label=None):
        """Horizontal bars of MAE, RMS, STD and max |error| (arcmin); returns the axes.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; a new figure's when None.
        label : str, optional
            Legend label of the bars.
        """
        from ..figures import plot_error_stats

        return plot_error_stats({label or "errors": self}, ax=ax)


def error_stats(data, *, zero="fixed"):
    """Summary statistics of an error profile.

    Parameters
    ----------
    data : Calibration or array-like of float
        A calibration (its ``errors_arcmin`` are used) or errors in arc-minutes.
    zero : {'fixed', 'arbitrary', 'auto'}, default='fixed'
        The reference's zero. 'fixed': statistics about zero, the offset counts as error (the
        paper's Table 1). 'arbitrary': the zero offset (:func:`zero_offset_arcmin`) is taken out
        first and recorded as ``offset``. 'auto': arbitrary when the offset exceeds 1 degree.

    Returns
    -------
    ErrorStats
        n, MAE, RMS, STD, min, max and peak-to-peak, in arc-minutes.

    Raises
    ------
    InputError
        If there are no errors or one of them is not finite.

    Examples
    --------
    >>> stats = error_stats([1.0, 2.0, 3.0])
    >>> stats.mae, round(stats.rms, 4), round(stats.std, 4), stats.pp
    (2.0, 2.1602, 0.8165, 2.0)
    >>> shape = error_stats([3599.0, 3600.0, 3601.0], zero="auto")   # a 60-degree offset
    >>> round(shape.offset, 6), round(shape.rms, 4)
    (3600.0, 0.8165)
    """
    errors = real_array(getattr(data, "errors_arcmin", data), "data", "error_stats",
                        "a Calibration or errors in arc-minutes (real numbers)").reshape(-1)
    if errors.size == 0:
        raise InputError("error_stats expects at least one error value; got none")
    if not np.all(np.isfinite(errors)):
        raise InputError("error_stats expects finite errors in arc-minutes; got NaN or infinity")
    check_choice(zero, "zero", "error_stats", ZERO_MODES)
    offset = None
    if zero != "fixed":
        candidate = zero_offset_arcmin(errors)
        if zero_is_arbitrary(zero, candidate):
            offset = candidate
            errors = remove_offset(errors, offset)
    mean = errors.mean()
    return ErrorStats(
        n=int(errors.size),
        mae=float(np.mean(np.abs(errors))),
        rms=float(np.sqrt(np.mean(errors**2))),
        std=float(np.sqrt(np.mean((errors - mean) ** 2))),
        min=float(errors.min()),
        max=float(errors.max()),
        pp=float(errors.max() - errors.min()),
        offset=offset,
    )


def remove_offset(error_arcmin, offset_arcmin):
    """Errors minus a zero offset, wrapped to within 180 degrees of zero (arc-minutes)."""
    shifted = np.asarray(error_arcmin, dtype=float) - offset_arcmin
    return wrap180(shifted / ARCMIN_PER_DEG) * ARCMIN_PER_DEG


# --------------------------------------------------------------------------- sampling grid


def profile_arrays(theta_deg, error_arcmin, caller, copy=True):
    """Validated angle and error arrays of one profile.

    Returns ``(theta_deg wrapped to [0, 360), error_arcmin)`` as 1-D float
    arrays of equal length; ``caller`` names the function in error messages.
    With ``copy=False`` the angles are the array given when it is one in
    [0, 360) already (for a caller that only reads them: 8 bytes an angle).
    """
    theta = real_array(theta_deg, "theta_deg", caller, "encoder angles in degrees (real numbers)").reshape(-1)
    error = real_array(error_arcmin, "error_arcmin", caller, "errors in arc-minutes (real numbers)").reshape(-1)
    if theta.size != error.size:
        raise InputError(
            f"{caller} expects one error per encoder angle; "
            f"got {theta.size} angles and {error.size} errors"
        )
    if theta.size == 0:
        raise InputError(f"{caller} expects at least one calibration point; got none")
    if not (np.all(np.isfinite(theta)) and np.all(np.isfinite(error))):
        raise InputError(
            f"{caller} expects finite angles (degrees) and errors (arc-minutes); "
            "got NaN or infinity"
        )
    return (wrap360(theta) if copy else _in_turn(theta)), error


def distinct_angles(theta_deg):
    """The distinct angles of a set of angles on the circle.

    Angles closer than ``ANGLE_TOLERANCE_DEG`` (1e-9°), also across 0/360,
    count as one; each group is represented by its first angle in
    ascending order (for a group spanning 0/360, the one just above 0).

    Parameters
    ----------
    theta_deg : array-like of shape (n,)
        Angles in degrees, wrapped to [0, 360).

    Returns
    -------
    distinct_deg : ndarray of shape (m,)
        The distinct angles in degrees, increasing.
    group : ndarray of int of shape (n,)
        Index into ``distinct_deg`` of every input angle.

    Examples
    --------
    >>> angles, group = distinct_angles([90.0, 0.0, 90.0])
    >>> angles.tolist(), group.tolist()
    ([0.0, 90.0], [1, 0, 1])
    """
    theta = np.asarray(theta_deg, dtype=float).reshape(-1)
    order, sorted_theta = stable_argsort(theta, return_sorted=True)  # np.argsort's stable order, 3x faster on 10^6
    starts_group = np.r_[True, np.diff(sorted_theta) > ANGLE_TOLERANCE_DEG]
    group_sorted = np.cumsum(starts_group)
    group_sorted -= 1  # (in place: a fit of 10^6 angles peaks here, 8 bytes an angle a copy)
    if group_sorted[-1] > 0 and sorted_theta[0] + 360.0 - sorted_theta[-1] <= ANGLE_TOLERANCE_DEG:
        group_sorted[group_sorted == group_sorted[-1]] = 0  # the last group wraps onto the first
    distinct = sorted_theta[starts_group][: group_sorted.max() + 1]
    del sorted_theta, starts_group
    group = np.empty_like(group_sorted)
    group[order] = group_sorted
    return distinct, group


@dataclass(frozen=True)
class _Grid:
    """How a set of angles samples the circle."""

    n_distinct: int
    phase_rad: float | None  # phase of the uniform grid the angles match, if they match one
    largest_gap_deg: float
    uniform: bool  # every angle within the tolerance (ANGLE_TOLERANCE_DEG unless told) of its node
    offset_rad: float = 0.0  # the largest distance of an angle from its node of that grid (NaN: plainly off it)

    @property
    def nyquist_order(self):
        """Order sampled at exactly two points per period, or None."""
        if self.phase_rad is None or self.n_distinct % 2:
            return None
        return self.n_distinct // 2

    @property
    def max_order(self):
        """Highest order whose series the distinct angles can determine at all."""
        if self.phase_rad is not None:
            return self.n_distinct // 2
        return (self.n_distinct - 1) // 2

    @property
    def stable_order(self):
        """Highest order the angles determine stably (see :func:`identifiable_order`)."""
        if self.phase_rad is not None:
            return self.n_distinct // 2
        below_half_period = int(np.ceil(180.0 / self.largest_gap_deg)) - 1  # K * gap < 180°
        return min(self.max_order, below_half_period)


def _distinct_values(theta_deg):
    """``distinct_angles(theta_deg)[0]``, the distinct angles alone: one ``np.sort`` of the values, no argsort nor
    groups (800,000 random angles: 6 ms, against 34)."""
    ordered = np.sort(np.asarray(theta_deg, dtype=float).reshape(-1))
    distinct = ordered[np.r_[True, np.diff(ordered) > ANGLE_TOLERANCE_DEG]]
    if distinct.size > 1 and ordered[0] + 360.0 - ordered[-1] <= ANGLE_TOLERANCE_DEG:
        distinct = distinct[:-1]  # the last group wraps onto the first
    return distinct


def _grid(theta_deg, tolerance_deg=ANGLE_TOLERANCE_DEG):
    return _grid_of_distinct(_distinct_values(theta_deg), tolerance_deg)


def angles_and_grid(theta_deg):
    """``(distinct, group, grid)``: :func:`distinct_angles` of the angles and how they sample the circle, from one
    sort.

    ``grid.stable_order`` is :func:`identifiable_order`, and ``grid.phase_rad`` is not None exactly when
    :func:`uniform_grid` of the distinct angles is not None (its nodes ``φ + 360° j / m``). A fit that asks all
    three of 10^6 angles sorted them three times (tens of milliseconds each).
    """
    distinct, group = distinct_angles(_in_turn(theta_deg))
    return distinct, group, _grid_of_distinct(distinct)


def _grid_of_distinct(distinct, tolerance_deg=ANGLE_TOLERANCE_DEG):
    m = distinct.size
    largest_gap = float(np.max(np.diff(np.r_[distinct, distinct[0] + 360.0])))
    if _off_every_grid(largest_gap, m):
        return _Grid(m, None, largest_gap, False, math.nan)
    phase, deviation, regular = _fit_grid(distinct, m)
    uniform = regular and deviation * 360.0 / m <= tolerance_deg
    return _Grid(m, phase if regular else None, largest_gap, uniform, deviation * 2.0 * np.pi / m)


def _off_every_grid(largest_gap_deg, points):
    """Whether ``points`` distinct angles with this largest gap between neighbours (degrees, across 0/360 too) are
    plainly on no uniform grid of ``points`` nodes, which :func:`_fit_grid` would find (without its passes).

    One angle a node, each within a quarter spacing of it (:data:`_REGULAR_DEVIATION`), leaves gaps under 1.5
    spacings; 1.75 leaves room for rounding. Random or jittered angles (a sweep's encoder readings) have gaps of
    many spacings.
    """
    return largest_gap_deg > (1.0 + 3.0 * _REGULAR_DEVIATION) * 360.0 / points


def _fit_grid(distinct_deg, points):
    """Phase (rad) of the uniform ``points``-node grid nearest the angles, their largest
    deviation from their nodes (in spacings), and whether they lie on it (one per node,
    each within a quarter spacing)."""
    theta = np.radians(distinct_deg)
    # Best-fitting phase: every node has points·θ ≡ points·φ (mod 2π). (The exponential in place: 16 bytes an
    # angle less at the peak of a fit of 10^6 distinct angles.)
    phasors = 1j * points * theta
    phase = float(np.angle(np.sum(np.exp(phasors, out=phasors)))) / points
    del phasors
    position = theta  # in grid spacings: (theta - phase) * points / (2 pi), in place
    position -= phase
    position *= points
    position /= 2.0 * np.pi
    node = np.round(position)
    position -= node
    deviation = float(np.max(np.abs(position, out=position)))
    del position, theta
    # one angle a node: asked only of angles near their nodes (a sort of every node otherwise)
    on_grid = deviation < _REGULAR_DEVIATION and np.unique(np.mod(node, points)).size == node.size
    return phase, deviation, bool(on_grid)


def uniform_grid(theta_deg, points=None):
    """The nodes of the uniform grid a set of angles lies on, or None.

    The angles lie on a uniform grid of ``points`` nodes per revolution when
    every distinct angle is within a quarter of the spacing of its own node
    (the regular grid of :func:`identifiable_order`), at most one per node.
    A calibration on ``N`` motor steps lies on a grid of ``N`` nodes, and so
    does any subset of it, such as the training part of a cross-validation
    fold: at the nodes, orders up to ``N // 2`` are distinguishable.

    Parameters
    ----------
    theta_deg : array-like of shape (n,)
        Encoder angles in degrees.
    points : int, optional
        Nodes per revolution; default the number of distinct angles (the
        angles must then fill the grid).

    Returns
    -------
    ndarray of shape (points,) or None
        The node angles in degrees, ``φ + 360° j / points``, or None when the
        angles do not lie on such a grid.

    Examples
    --------
    >>> uniform_grid(np.arange(0.0, 360.0, 90.0)).tolist()
    [0.0, 90.0, 180.0, 270.0]
    >>> uniform_grid([0.0, 3.6, 10.8], points=100).size   # three nodes of a 3.6° grid
    100
    >>> uniform_grid([0.0, 3.6, 5.0], points=100) is None  # 5.0° is 0.39 spacings off
    True
    """
    distinct = _distinct_values(_in_turn(theta_deg))
    if points is None:
        points = distinct.size
    if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < distinct.size:
        raise InputError(f"uniform_grid expects points to be an int >= the {distinct.size} distinct "
                         f"encoder angles. Got {points!r} instead.")
    if distinct.size and points == distinct.size \
            and _off_every_grid(float(np.max(np.diff(np.r_[distinct, distinct[0] + 360.0]))), points):
        return None
    phase, _, on_grid = _fit_grid(distinct, int(points))
    if not on_grid:
        return None
    return wrap360(np.degrees(phase) + 360.0 * np.arange(points) / points)


def _in_turn(theta_deg):
    """The angles as a 1-D float array in [0, 360): the array itself when it is one already (and holds no -0.0),
    else wrapped (a copy). For the functions that only read it: a fit of 10^6 angles peaks in them."""
    theta = np.asarray(theta_deg, dtype=float).reshape(-1)
    if theta.size and theta.min() >= 0.0 and theta.max() < 360.0 and not np.signbit(theta).any():
        return theta
    return wrap360(theta)


def _snap(theta_deg, grid):
    """The angles moved to their nodes of a regular grid (degrees)."""
    spacing = 360.0 / grid.n_distinct
    phase = np.degrees(grid.phase_rad)
    return phase + spacing * np.round((np.asarray(theta_deg) - phase) / spacing)


def identifiable_order(theta_deg):
    """Highest harmonic order a set of encoder angles identifies stably.

    This is the default ``max_order`` of :func:`harmonics` and
    :func:`~encal.models.fourier.fit_fourier`. With ``m`` distinct angles
    (closer than 1e-9° counts as one):

    - on a *regular* grid, one whose angles pair one-to-one with the nodes
      of a uniform ``m``-point grid, each within a quarter of the spacing of
      its node, it is the Nyquist order ``m // 2``; for even ``m`` that
      order has a single term (two samples per period cannot tell a cosine
      from a sine);
    - otherwise it is the highest order ``K`` whose half-period exceeds the
      largest gap ``g`` between neighbouring angles, ``K g < 180°``, and at
      most ``(m - 1) // 2``. Below that bound every trigonometric polynomial
      of order ``K`` is stably determined by its samples (Gröchenig 1992);
      above it, a gap can hide a whole half-period.

    Higher orders, up to ``(m - 1) // 2`` (``2K + 1`` distinct angles
    determine a trigonometric polynomial of order ``K``), can be asked for
    explicitly; they are refused when the least squares is rank-deficient.
    Orders above that limit (``m // 2`` on a regular grid) are always
    refused: there an order aliases a lower one, even where rounding or a
    slightly irregular grid keeps the least squares full-rank.

    Parameters
    ----------
    theta_deg : array-like of shape (n,)
        Encoder angles in degrees.

    Returns
    -------
    int

    Examples
    --------
    >>> identifiable_order(range(0, 360, 2))          # uniform, 180 points
    90
    >>> identifiable_order([0, 10, 20, 30, 50, 100])  # irregular: largest gap 260°
    0
    >>> identifiable_order(np.r_[0:300:2.0])          # 150 points with a 62° gap
    2
    """
    theta = _in_turn(theta_deg)
    if theta.size == 0:
        raise InputError("identifiable_order expects at least one angle; got none")
    return _grid(theta).stable_order


def _design(theta_deg, orders, grid):
    """Columns [cos(kθ), sin(kθ)] per order, with the grid's special cases.

    Returns the design matrix and, per order, a complex number that maps its
    fitted column coefficients to (a_k, b_k): see :func:`fit_harmonic_series`.
    """
    theta = np.radians(theta_deg)
    columns, owners = [], []
    for index, k in enumerate(orders):
        if k == 0:
            columns.append(np.ones_like(theta))
            owners.append((index, "cos"))
        elif k == grid.nyquist_order:
            # Two samples per period: only the term locked to the grid phase exists.
            columns.append(np.cos(k * (theta - grid.phase_rad)))
            owners.append((index, "nyquist"))
        else:
            columns += [np.cos(k * theta), np.sin(k * theta)]
            owners += [(index, "cos"), (index, "sin")]
    return np.column_stack(columns), owners


def fit_harmonic_series(theta_deg, error_arcmin, orders, *, caller="fit_harmonic_series", grid_deg=None):
    """Least-squares coefficients of chosen harmonic orders.

    Fits ``ε(θ) = Σ a_k cos(k θ) + b_k sin(k θ)`` (θ in radians) to the
    profile. At the Nyquist order of a regular grid with an even number of
    angles only the term ``c cos(k (θ - φ))`` locked to the grid phase φ is
    fitted (``a_k = c cos kφ``, ``b_k = c sin kφ``); on a grid starting at 0°
    that is the plain cosine.

    Parameters
    ----------
    theta_deg : array-like of shape (n,)
        Encoder angles in degrees.
    error_arcmin : array-like of shape (n,)
        Errors in arc-minutes.
    orders : sequence of int
        Distinct non-negative harmonic orders.
    caller : str, default='fit_harmonic_series'
        Function named in error messages.
    grid_deg : array-like, optional
        The nodes of a uniform grid the angles are a subset of (see
        :func:`uniform_grid`): the orders then may go up to its Nyquist
        order, whose single term is locked to its phase, and the orders
        must be identifiable at the nodes the angles occupy, not merely at
        the angles (which a small deviation from the nodes can make
        full-rank where the nodes are not). Default: the angles' own grid.

    Returns
    -------
    cos_arcmin, sin_arcmin : ndarray of shape (len(orders),)
        ``a_k`` and ``b_k`` in arc-minutes; ``b_0 = 0``.

    Raises
    ------
    InputError
        If an order exceeds the highest order the angles determine at all
        (see :func:`identifiable_order`; above it an order aliases a lower
        one), or the angles cannot identify the orders together
        (numerically rank-deficient least squares).

    Examples
    --------
    >>> theta = np.arange(0.0, 360.0, 30.0)
    >>> a, b = fit_harmonic_series(theta, 2 + np.sin(np.radians(3 * theta)), [0, 3])
    >>> np.round(a, 12).tolist(), np.round(b, 12).tolist()
    ([2.0, 0.0], [0.0, 1.0])
    """
    theta, error = profile_arrays(theta_deg, error_arcmin, caller)
    grid = _grid(theta if grid_deg is None else _in_turn(grid_deg))
    return _fit_series(theta, error, [int(k) for k in orders], caller, grid, grid_deg is not None)


def harmonic_series_and_order(theta_deg, error_arcmin, orders, *, caller="harmonic_series_and_order"):
    """:func:`fit_harmonic_series` of the angles' own grid, and their :func:`identifiable_order`, from one sort of
    them (a fit of 10^6 angles spent 20-30 ms in each).

    Returns
    -------
    cos_arcmin, sin_arcmin : ndarray of shape (len(orders),)
    identifiable_order : int
    """
    theta, error = profile_arrays(theta_deg, error_arcmin, caller)
    grid = _grid(theta)
    return (*_fit_series(theta, error, [int(k) for k in orders], caller, grid, False), grid.stable_order)


def _fit_series(theta, error, orders, caller, grid, on_given_grid):
    too_high = [k for k in orders if k > grid.max_order]
    if too_high:
        raise InputError(_aliasing_message(caller, too_high, grid))
    if theta.size >= _GRAM_ABOVE:
        solution, owners = _solution_by_gram(theta, error, orders, grid, check_nodes=on_given_grid)
        if solution is not None:
            return _coefficients(solution, owners, orders, grid)
    import scipy.linalg  # here, not at the top: the commands that only read a model never import SciPy

    design, owners = _design(theta, orders, grid)
    # QR with column pivoting (gelsy): rank-revealing, and much faster than the SVD.
    solution, _, rank, _ = scipy.linalg.lstsq(design, error, cond=_RCOND, lapack_driver="gelsy",
                                              check_finite=False)
    if on_given_grid and grid.phase_rad is not None and rank == design.shape[1]:
        at_nodes = _design(_snap(theta, grid), orders, grid)[0]
        rank = np.linalg.matrix_rank(at_nodes, tol=_RCOND * np.linalg.norm(at_nodes, 2))
    if rank < design.shape[1]:
        raise InputError(
            f"{caller} cannot identify harmonic orders {_short_list(orders)} from "
            f"{grid.n_distinct} distinct encoder angles (rank-deficient least squares); "
            f"expected orders up to {grid.max_order} that do not alias one another"
        )
    return _coefficients(solution, owners, orders, grid)


def nested_harmonic_predictions(theta_deg, error_arcmin, ranked_orders, predict_deg, *, grid_deg=None):
    """Predictions of the least-squares fits of the first 1, 2, 3, ... orders of a ranking.

    One QR of the design serves every prefix: with ``A = QR`` the fit of the
    first ``p`` columns predicts ``X[:, :p] R[:p, :p]⁻¹ (Qᵀε)[:p]``, and
    ``X R⁻¹`` restricted to its first ``p`` columns is exactly
    ``X[:, :p] R[:p, :p]⁻¹`` (``R⁻¹`` is upper triangular), so all prefixes
    are the cumulative sums of one product: O(n p²) for ``p`` columns.

    An order whose terms the angles cannot identify together with the
    orders before it (its columns numerically in their span, judged at the
    grid nodes when the angles lie on a regular grid) is left out of every
    prefix that contains it, so each prefix's fit is well defined; once the
    kept terms interpolate the points, every further order is left out.

    Parameters
    ----------
    theta_deg : array-like of shape (n,)
        Encoder angles of the fitted points, degrees.
    error_arcmin : array-like of shape (n,)
        Their errors, arc-minutes.
    ranked_orders : sequence of int
        Distinct orders in the order they are added.
    predict_deg : array-like of shape (m,)
        Angles to predict at, degrees.
    grid_deg : array-like, optional
        The angles whose grid fixes the terms of each order (the single
        term of a Nyquist order, see :func:`fit_harmonic_series`) and at
        whose nodes identifiability is judged; default ``theta_deg``.
        Cross-validation passes the whole calibration (or the nodes of its
        grid) so that each fold fits the same series as the whole data.

    Returns
    -------
    ndarray of shape (len(ranked_orders), m)
        Row ``c - 1``: prediction (arcmin) of the fit of the first ``c`` orders.
    """
    theta, error = profile_arrays(theta_deg, error_arcmin, "nested_harmonic_predictions")
    predict = wrap360(np.asarray(predict_deg, dtype=float).reshape(-1))
    orders = [int(k) for k in ranked_orders]
    grid = _grid(theta if grid_deg is None else _in_turn(grid_deg))
    design, owners = _design(theta, orders, grid)
    owner = np.array([index for index, _ in owners])
    check = design if grid.phase_rad is None else _design(_snap(theta, grid), orders, grid)[0]
    kept_orders = _identifiable_orders(check, owner, len(orders))
    kept = kept_orders[owner]
    import scipy.linalg

    q, r = np.linalg.qr(design[:, kept])
    projected = q.T @ error
    # (X R^-1)^T, one row per kept column: its cumulative sums weighted by Qᵀε are the prefixes' predictions.
    weights = scipy.linalg.solve_triangular(r, _design(predict, orders, grid)[0][:, kept].T, trans="T",
                                            check_finite=False)
    cumulative = np.vstack([np.zeros(predict.size), np.cumsum(weights * projected[:, np.newaxis], axis=0)])
    columns_in_prefix = np.cumsum(np.bincount(owner[kept], minlength=len(orders)))
    return cumulative[columns_in_prefix]


def _identifiable_orders(design, owner, n_orders, block=64):
    """Greedy: which orders add columns independent of those of the kept orders before them.

    An order is kept whole or left out whole. Columns are orthogonalised in
    blocks against the kept ones (two passes of Gram-Schmidt) and a block
    whose QR shows no dependent column is kept whole (BLAS-3, the common
    case); otherwise it is taken order by order: O(n p²) for ``p`` columns.
    """
    n = design.shape[0]
    kept = np.zeros(n_orders, dtype=bool)
    norms = np.linalg.norm(design, axis=0)
    width = min(n, design.shape[1])
    if owner[width - 1] == owner[min(width, design.shape[1] - 1)] and width < design.shape[1]:
        width -= 1  # never split an order's two columns
    diagonal = np.abs(np.diag(np.linalg.qr(design[:, :width], mode="r")))
    if np.all(diagonal > _RCOND * norms[:width]):  # the common case: one LAPACK QR
        kept[np.unique(owner[:width])] = True
        return kept
    basis = np.empty((n, min(n, design.shape[1])), order="F")
    rank = 0
    start = 0
    while start < design.shape[1] and rank < n:
        stop = min(start + block, design.shape[1])
        while stop < design.shape[1] and owner[stop] == owner[stop - 1]:
            stop += 1  # an order's two columns in one block
        chunk = design[:, start:stop].copy()
        for _ in range(2):  # twice is enough (Giraud et al. 2005)
            chunk -= basis[:, :rank] @ (basis[:, :rank].T @ chunk)
        q, r = np.linalg.qr(chunk)
        if rank + chunk.shape[1] <= n and np.all(np.abs(np.diag(r)) > _RCOND * norms[start:stop]):
            basis[:, rank : rank + chunk.shape[1]] = q
            rank += chunk.shape[1]
            kept[np.unique(owner[start:stop])] = True
        else:
            # The chunk is already orthogonal to the basis: the greedy works within the chunk.
            accepted = np.empty((n, chunk.shape[1]), order="F")
            done = 0
            for index in np.unique(owner[start:stop]):
                columns = np.flatnonzero(owner[start:stop] == index)
                extended = _extend_basis(accepted, done, chunk[:, columns], norms[start + columns],
                                         room=n - rank)
                kept[index] = extended > done
                done = extended
            basis[:, rank : rank + done] = accepted[:, :done]
            rank += done
        start = stop
    return kept


#: From this many readings :func:`fit_harmonic_series` solves its normal equations, built from trigonometric moments
#: (no design matrix: 10^6 readings of 16 orders held 264 MB in it, and its QR took 1.3 s).
_GRAM_ABOVE = 20_000

#: The normal equations are solved when their matrix's condition number is at most this, else the design's QR.
#: Each Gram entry is a trigonometric moment within about 1e-14 of the readings' count (:func:`trig_moments`), so the
#: solution is then within about 1e-10 of the QR's, relative; and the design, its condition at most 100, is of full
#: rank by far (the QR's rank test is at :data:`_RCOND`).
_GRAM_CONDITION = 1e4


def _column_phasors(orders, grid):
    """Per design column of :func:`_design`, its order ``k`` and phasor ``α``: the column is ``Re(α e^{ikθ})``."""
    ks, alphas, owners = [], [], []
    for index, k in enumerate(orders):
        if k == 0:
            ks.append(0), alphas.append(1.0), owners.append((index, "cos"))
        elif k == grid.nyquist_order:
            ks.append(k), alphas.append(np.exp(-1j * k * grid.phase_rad)), owners.append((index, "nyquist"))
        else:
            ks += [k, k]
            alphas += [1.0, -1j]  # Re(e^{ikθ}) = cos kθ, Re(-i e^{ikθ}) = sin kθ
            owners += [(index, "cos"), (index, "sin")]
    return np.array(ks, dtype=int), np.array(alphas, dtype=complex), owners


def _gram(theta_rad, weights, ks, alphas):
    """``Aᵀ diag(w) A`` of the columns ``Re(α_j e^{i k_j θ})``, from the moments ``S_m = Σ w e^{imθ}``:
    ``½ Re(α_j α_l S_{k_j+k_l} + α_j conj(α_l) S_{k_j-k_l})``."""
    moments = trig_moments(theta_rad, weights, 2 * int(ks.max()))
    difference = ks[:, None] - ks[None, :]
    s_difference = moments[np.abs(difference)]
    s_difference = np.where(difference >= 0, s_difference, np.conj(s_difference))
    gram = 0.5 * np.real(alphas[:, None] * alphas[None, :] * moments[ks[:, None] + ks[None, :]]
                         + alphas[:, None] * np.conj(alphas)[None, :] * s_difference)
    return 0.5 * (gram + gram.T)


def _well_conditioned(gram):
    """The Cholesky factor of a symmetric matrix whose condition number is at most :data:`_GRAM_CONDITION`, or None."""
    eigenvalues = np.linalg.eigvalsh(gram)
    if not eigenvalues[0] > 0.0 or eigenvalues[-1] > _GRAM_CONDITION * eigenvalues[0]:
        return None
    return np.linalg.cholesky(gram)


def _solution_by_gram(theta_deg, error_arcmin, orders, grid, check_nodes):
    """The least-squares column coefficients of :func:`_design` from the normal equations, and their owners; the
    solution is None when the Gram matrix (or, with ``check_nodes``, the one at the grid's nodes the angles occupy)
    is not well conditioned: the QR then decides, with its rank test."""
    ks, alphas, owners = _column_phasors(orders, grid)
    theta = np.radians(theta_deg)
    factor = _well_conditioned(_gram(theta, np.ones(theta.size), ks, alphas))
    if factor is None:
        return None, owners
    if check_nodes and grid.phase_rad is not None:
        nodes = np.unique(np.radians(_snap(theta_deg, grid)))
        if _well_conditioned(_gram(nodes, np.ones(nodes.size), ks, alphas)) is None:
            return None, owners
    projection = np.real(alphas * trig_moments(theta, error_arcmin, int(ks.max()))[ks])  # Aᵀ ε
    within = np.linalg.solve(factor, projection)
    return np.linalg.solve(factor.T, within), owners


def _coefficients(solution, owners, orders, grid):
    """(a_k, b_k) per order from the solved column coefficients."""
    cos_arcmin, sin_arcmin = np.zeros(len(orders)), np.zeros(len(orders))
    for value, (index, term) in zip(solution, owners):
        if term == "cos":
            cos_arcmin[index] = value
        elif term == "sin":
            sin_arcmin[index] = value
        else:
            shift = orders[index] * grid.phase_rad
            cos_arcmin[index] = value * np.cos(shift)
            sin_arcmin[index] = value * np.sin(shift)
    return cos_arcmin, sin_arcmin


def _aliasing_message(caller, orders, grid):
    """One sentence refusing orders above ``grid.max_order``."""
    m = grid.n_distinct
    named = f"order {orders[0]}" if len(orders) == 1 else f"orders {_short_list(orders)}"
    example = ""
    if grid.phase_rad is not None:  # on a regular grid order k looks like order ±k mod m
        folded = orders[0] % m
        example = f" (here order {orders[0]} looks like order {min(folded, m - folded)})"
    return (
        f"{caller} cannot identify harmonic {named} from {m} distinct encoder angles: the highest "
        f"order they determine is {grid.max_order}, and above it an order aliases a lower one{example}"
    )


def _short_list(orders, limit=12):
    text = ", ".join(str(k) for k in orders[:limit])
    return f"[{text}{', ...' if len(orders) > limit else ''}]"


# --------------------------------------------------------------------------- harmonics


@dataclass(frozen=True, eq=False)
class Harmonics:
    """Harmonic content of an error profile, ``ε(θ) = Σ A_k cos(k θ - φ_k)``.

    Attributes
    ----------
    orders : ndarray of int of shape (K + 1,)
        Orders ``0, 1, ..., K`` (cycles per revolution).
    cos_arcmin, sin_arcmin : ndarray of shape (K + 1,)
        Coefficients ``a_k`` and ``b_k`` of ``a_k cos(k θ) + b_k sin(k θ)``
        (θ in radians), in arc-minutes.
    n_points : int
        Number of calibration points analysed.
    grid_bound_arcmin : ndarray of shape (K + 1,) or None
        When the angles were taken at the nodes of a uniform grid (the FFT path, see
        :func:`harmonics`): for every order ``k``, a bound on how far the coefficient ``a_k - i b_k``
        (the DFT's ``c Σ_i w_i ε_i e^{-ikν_i}`` at the nodes ``ν_i``) can be from the same sum at the
        readings' own angles, ``c Σ_i w_i ε_i e^{-ikθ_i}``, in arc-minutes: ``c k δ Σ_i w_i |ε_i|``
        for the largest distance ``δ`` (radians) of a reading from its node; ``c = 2`` (1 at the
        Nyquist order), ``w_i = 1 / (m r_i)`` for ``m`` nodes and ``r_i`` readings at the reading's
        node (``1/N`` when every node has as many). 0 for order 0. None when the angles were used as
        they are.
    """

    orders: np.ndarray
    cos_arcmin: np.ndarray
    sin_arcmin: np.ndarray
    n_points: int
    grid_bound_arcmin: np.ndarray | None = None

    @property
    def amplitude_arcmin(self):
        """Amplitude ``A_k = hypot(a_k, b_k)`` of every order, in arc-minutes (``A_0 = |a_0|``)."""
        return np.hypot(self.cos_arcmin, self.sin_arcmin)

    @property
    def phase_rad(self):
        """Phase ``φ_k = atan2(b_k, a_k)`` of every order, in radians (0 or π for order 0)."""
        return np.arctan2(self.sin_arcmin, self.cos_arcmin)

    @property
    def max_order(self):
        """Highest order analysed."""
        return int(self.orders[-1])

    def ranked(self):
        """All orders, largest amplitude first.

        Amplitudes equal to 12 significant digits of the largest one count as
        equal (rounding must not decide); the lower order comes first.
        """
        amplitude = self.amplitude_arcmin
        scale = amplitude.max(initial=0.0) or 1.0
        return self.orders[np.lexsort((self.orders, -np.round(amplitude / scale, 12)))]

    def top(self, n=10):
        """The ``n`` orders of largest amplitude, largest first, as the paper lists them.

        Parameters
        ----------
        n : int, default=10
            How many orders; all of them if there are fewer.

        Returns
        -------
        list of int
        """
        if int(n) != n or n < 0:
            raise InputError(f"Harmonics.top expects a count n >= 0; got {n!r}")
        return [int(k) for k in self.ranked()[: int(n)]]

    def as_list(self, n=None):
        """``[{"order": k, "amplitude_arcmin": A_k, "phase_deg": φ_k}, ...]``, largest first (the ``n`` largest
        if given); ``ε(θ) = Σ A_k cos(k θ - φ_k)``, φ_k in degrees within (-180, 180]."""
        amplitude, phase = self.amplitude_arcmin, np.degrees(self.phase_rad)
        chosen = self.ranked() if n is None else self.top(n)
        return [{"order": int(k), "amplitude_arcmin": float(amplitude[k]), "phase_deg": float(phase[k])}
                for k in chosen]

    def __str__(self):
        """The ten largest orders as a table: order, amplitude (arcmin), phase (degrees)."""
        lines = [f"harmonics of {self.n_points} points, orders 0..{self.max_order}, largest first",
                 f"{'order':>5}{'amplitude/arcmin':>19}{'phase/deg':>12}"]
        lines += [f"{e['order']:>5d}{e['amplitude_arcmin']:>19.3f}{e['phase_deg']:>12.1f}" for e in self.as_list(10)]
        return "\n".join(lines)

    def _repr_html_(self):
        """Rich display in a notebook: the text table and the figure."""
        from ..figures import html_repr

        return html_repr(self)

    def plot(self, ax=None, *, n_label=10, title=None):
        """The amplitude spectrum (:func:`encal.figures.plot_harmonics`); returns the axes."""
        from ..figures import plot_harmonics

        return plot_harmonics(self, n_label=n_label, ax=ax, title=title)

    def __call__(self, theta_deg):
        """The harmonic series evaluated at ``theta_deg`` (degrees), in arc-minutes."""
        theta = real_array(theta_deg, "theta_deg", "Harmonics", "encoder angles in degrees (real numbers)")
        if not np.all(np.isfinite(theta)):  # a model's predict refuses them too: never NaN for a reading
            raise InputError("Harmonics expects finite encoder angles in degrees; got NaN or infinity")
        theta = np.radians(theta)[..., np.newaxis]
        series = self.cos_arcmin * np.cos(self.orders * theta) + self.sin_arcmin * np.sin(self.orders * theta)
        return series.sum(axis=-1)[()]


def harmonics(theta_deg, error_arcmin, max_order=None, *, grid_tolerance_deg=ANGLE_TOLERANCE_DEG):
    """Harmonic analysis of an error profile by least squares.

    Parameters
    ----------
    theta_deg : array-like of shape (n,)
        Encoder angles in degrees; any order, any spacing, repeats allowed.
    error_arcmin : array-like of shape (n,)
        Errors in arc-minutes.
    max_order : int, optional
        Highest order to analyse. Default: :func:`identifiable_order` of the
        angles (the Nyquist order ``n // 2`` on a uniform grid of ``n``
        points). Up to ``(m - 1) // 2`` for ``m`` distinct angles may be asked
        for; it is refused if the least squares is rank-deficient.
    grid_tolerance_deg : float, default=1e-9
        The angles count as lying on a uniform grid, and are analysed at its nodes by the FFT, when
        every one is within this many degrees of its node. Above 1e-9° this trades exactness for
        speed, and the result says by how much: ``Harmonics.grid_bound_arcmin`` bounds, for every
        order, the change of its trigonometric sum from moving each reading to its node.

    Returns
    -------
    Harmonics
        Orders ``0..max_order`` with their coefficients. On a uniform grid of
        ``N`` points with the default ``max_order`` the result equals the DFT
        ``X_k = Σ ε_j e^{-2πi jk/N} / N``: ``A_0 = |X_0|``, ``A_k = 2 |X_k|``,
        and ``A_{N/2} = |X_{N/2}|`` for even ``N``.

    Raises
    ------
    InputError
        If ``max_order`` exceeds what the angles can determine.

    Notes
    -----
    The least squares is solved by the cheapest route that gives its answer
    (``K`` is ``max_order``):

    - on a uniform grid (every angle within ``grid_tolerance_deg`` of its
      node), with the Nyquist order or with as many readings at every angle:
      the FFT of the mean error at each node, O(n log n). Moving a reading
      by ``δ`` radians changes ``ε e^{-ikθ}`` by at most ``|ε| k δ``
      (``|1 - e^{ix}| <= |x|``), hence the bound ``grid_bound_arcmin``;
    - otherwise, up to :func:`identifiable_order`: the normal equations. For
      this basis they are a Toeplitz system in the sums ``Σ_i e^{imθ_i}``,
      ``m <= 2K``, formed in O(n K) by two small matrix products and solved by
      conjugate gradients with FFT products, O(K log K) a step. Below the
      identifiable order the system is well conditioned and a few dozen steps
      reach the QR answer to rounding;
    - above it, or if the gradients do not converge: the rank-revealing QR
      of :func:`fit_harmonic_series`, O(n K²).

    Examples
    --------
    >>> theta = np.arange(0.0, 360.0, 2.0)
    >>> h = harmonics(theta, 1.0 + 3.0 * np.cos(np.radians(2 * theta - 40)))
    >>> h.top(2)
    [2, 0]
    >>> round(float(h.amplitude_arcmin[2]), 12), round(float(np.degrees(h.phase_rad[2])), 9)
    (3.0, 40.0)
    """
    theta, error = profile_arrays(theta_deg, error_arcmin, "harmonics")
    tolerance = check_number(grid_tolerance_deg, "grid_tolerance_deg", "harmonics", low=0.0, high=180.0,
                             high_open=True, note="degrees")
    grid = _grid(theta, tolerance)
    if max_order is None:
        max_order = grid.stable_order
    elif isinstance(max_order, bool) or not isinstance(max_order, numbers.Integral) \
            or not 0 <= max_order <= grid.max_order:
        raise invalid("max_order", "harmonics", f"an int from 0 to {grid.max_order} (the highest order "
                      f"{grid.n_distinct} distinct encoder angles can determine), or None", max_order)
    max_order = int(max_order)
    series, bound = None, None
    if grid.uniform:
        series = _series_by_fft(theta, error, max_order, grid)
        if series is not None:
            series, bound = series[:2], series[2]
    if series is None and max_order <= grid.stable_order:
        series = _series_by_normal_equations(theta, error, max_order, grid)
    if series is None:
        series = fit_harmonic_series(theta, error, range(max_order + 1), caller="harmonics")
    return Harmonics(np.arange(max_order + 1), *series, int(theta.size), bound)


def rank_orders(theta_deg, error_arcmin, max_order=None, *, grid_deg=None, count=None):
    """Harmonic orders, most important first, as the Fourier model adds them.

    Parameters
    ----------
    theta_deg : array-like of shape (n,)
        Encoder angles in degrees.
    error_arcmin : array-like of shape (n,)
        Errors in arc-minutes.
    max_order : int, optional
        Highest order ranked; default :func:`identifiable_order` of the
        angles, or with ``grid_deg`` the Nyquist order of that grid.
    grid_deg : array-like, optional
        Nodes of a uniform grid the angles lie on (:func:`uniform_grid`).
    count : int, optional
        Rank only the first ``count`` orders (default all).

    Returns
    -------
    list of int

    Notes
    -----
    Without ``grid_deg``, or when the angles occupy every node of it, this
    is the paper's ranking, :meth:`Harmonics.ranked`: by the amplitude of
    the harmonic analysis. On a proper subset of the grid (the training part
    of a cross-validation fold of a step-by-step calibration) the analysis up
    to the grid's Nyquist order has more unknowns than points; its
    minimum-norm solution is the DFT of the errors with the missing nodes set
    to zero, whose amplitudes leak a strong order into the orders that alias
    it at the missing nodes. The orders are therefore chosen by forward
    selection: each step takes the order of largest amplitude in the DFT of
    the zero-filled *residual* of the fit of the orders taken so far, and
    skips orders that the occupied nodes cannot identify together with
    them. On a complete grid the terms are orthogonal and forward selection
    gives the ranking by amplitude. Each step costs an FFT of the grid and
    one Gram-Schmidt step, O(N log N + n c) for ``c`` orders taken.
    """
    theta, error = profile_arrays(theta_deg, error_arcmin, "rank_orders")
    grid = None if grid_deg is None else _grid(_in_turn(grid_deg))
    if grid is None or grid.phase_rad is None or _grid(theta).n_distinct == grid.n_distinct:
        ranking = harmonics(theta, error, max_order).ranked()
        return [int(k) for k in ranking[:count]]
    max_order = grid.max_order if max_order is None else min(int(max_order), grid.max_order)
    return _forward_selection(theta, error, grid, max_order, max_order + 1 if count is None else count)


def _forward_selection(theta_deg, error_arcmin, grid, max_order, count):
    """Orders by forward selection on a proper subset of a regular grid (see :func:`rank_orders`)."""
    nodes = grid.n_distinct
    node = np.round((np.radians(theta_deg) - grid.phase_rad) * nodes / (2.0 * np.pi)).astype(int) % nodes
    snapped = _snap(theta_deg, grid)
    weight = np.full(max_order + 1, 2.0)  # amplitude 2|X_k|, but |X_0| and |X_{N/2}| (one term)
    weight[0] = 1.0
    if grid.nyquist_order == max_order:
        weight[-1] = 1.0
    residual = error_arcmin.astype(float)
    basis_fit = np.empty((theta_deg.size, min(theta_deg.size, 2 * count)), order="F")  # at the angles: the residual
    basis_nodes = np.empty_like(basis_fit)  # at the nodes: identifiability
    rank = 0
    available = np.ones(max_order + 1, dtype=bool)
    ranking, scale = [], None
    while len(ranking) < count and available.any() and rank < basis_fit.shape[1]:
        spectrum = np.fft.rfft(np.bincount(node, weights=residual, minlength=nodes))[: max_order + 1]
        amplitude = weight * np.abs(spectrum) / theta_deg.size
        scale = scale or float(amplitude.max()) or 1.0
        key = np.where(available, np.round(amplitude / scale, 12), -1.0)
        order = int(np.argmax(key))  # ties: the lower order
        available[order] = False
        at_nodes = _design(snapped, [order], grid)[0]
        at_angles = _design(theta_deg, [order], grid)[0]
        extended = _extend_basis(basis_nodes, rank, at_nodes, np.linalg.norm(at_nodes, axis=0))
        if extended == rank or _extend_basis(basis_fit, rank, at_angles,
                                             np.linalg.norm(at_angles, axis=0)) != extended:
            continue  # not identifiable with the orders taken: skip it
        rank = extended
        residual = error_arcmin - basis_fit[:, :rank] @ (basis_fit[:, :rank].T @ error_arcmin)
        ranking.append(order)
    return ranking


def _extend_basis(basis, rank, columns, lengths, room=None):
    """Append the orthonormalised ``columns`` to ``basis[:, :rank]`` in place, all or none.

    ``lengths`` are the norms the columns had before any orthogonalisation. Returns the new
    rank, or ``rank`` unchanged if a column is (nearly) in the span of the others or the rank
    would exceed ``room`` (default the basis's width).
    """
    if rank + columns.shape[1] > min(basis.shape[1], basis.shape[1] if room is None else room):
        return rank
    new = []
    for column, length in zip(columns.T, lengths):
        for _ in range(2):  # Gram-Schmidt twice is enough (Giraud et al. 2005)
            column = column - basis[:, :rank] @ (basis[:, :rank].T @ column)
            for vector in new:
                column = column - vector * (vector @ column)
        if np.linalg.norm(column) <= _RCOND * length:
            return rank
        new.append(column / np.linalg.norm(column))
    basis[:, rank : rank + len(new)] = np.column_stack(new)
    return rank + len(new)


def _series_by_fft(theta_deg, error_arcmin, max_order, grid):
    """Least-squares ``(a_k, b_k)``, k <= max_order, on a uniform grid, from the FFT, and the bound
    ``grid_bound_arcmin`` of :class:`Harmonics`.

    The least squares fits the mean error at each node, equally weighted when
    every node has as many readings or when the series has as many terms as
    there are nodes (it then interpolates the means). Returns None otherwise.
    """
    m = grid.n_distinct
    position = (np.radians(theta_deg) - grid.phase_rad) * m / (2.0 * np.pi)  # in grid spacings
    nearest = np.round(position)
    node = nearest.astype(int) % m
    readings = np.bincount(node, minlength=m)
    if max_order < m // 2 and readings.min() != readings.max():
        return None
    mean = np.bincount(node, weights=error_arcmin, minlength=m) / readings
    # The bound of the change of each sum from moving every reading to its node (see Harmonics).
    offset_rad = float(np.max(np.abs(position - nearest), initial=0.0)) * 2.0 * np.pi / m
    weighted = float(np.sum(np.bincount(node, weights=np.abs(error_arcmin), minlength=m) / readings)) / m
    bound = 2.0 * np.arange(max_order + 1) * offset_rad * weighted
    spectrum = np.fft.rfft(mean)[: max_order + 1] / m  # X_k of the means at φ + 2πj/m
    coefficient = 2.0 * spectrum * np.exp(-1j * np.arange(max_order + 1) * grid.phase_rad)  # a_k - i b_k
    cos_arcmin, sin_arcmin = coefficient.real.copy(), -coefficient.imag
    cos_arcmin[0], sin_arcmin[0] = spectrum[0].real, 0.0
    if max_order == grid.nyquist_order:  # the single term c cos(k(θ - φ)); the means alternate: c = X_k
        shift = max_order * grid.phase_rad
        cos_arcmin[-1], sin_arcmin[-1] = spectrum[-1].real * np.cos(shift), spectrum[-1].real * np.sin(shift)
        bound[-1] /= 2.0
    return cos_arcmin, sin_arcmin, bound


def _series_by_normal_equations(theta_deg, error_arcmin, max_order, grid):
    """Least-squares ``(a_k, b_k)``, k <= max_order, from the normal equations.

    In complex form the series is ``Σ_{|k| <= L} c_k e^{ikθ}`` with
    ``c_{-k} = conj(c_k)`` and ``a_k - i b_k = 2 c_k``, plus, when
    ``K = max_order`` is the Nyquist order (then ``L = K - 1``), the real
    term ``d cos(K(θ - φ))``. With ``s_m = Σ_i e^{imθ_i}`` and
    ``r_j = Σ_i ε_i e^{-ijθ_i}`` the normal equations are

        Σ_k s_{k-j} c_k + u_j d = r_j                 (|j| <= L)
        Σ_k conj(u_k) c_k + v d = Re(e^{iKφ} r_K)

    with ``u_j = (e^{-iKφ} s_{K-j} + e^{iKφ} s_{-K-j}) / 2`` and
    ``v = (n + Re(e^{-2iKφ} s_{2K})) / 2``: a Hermitian Toeplitz matrix,
    bordered by one row and column for ``d``. The matrix keeps vectors with
    ``x_{-j} = conj(x_j)``, as are the right-hand side and every iterate of
    conjugate gradients started at zero: they run on ``c_0 .. c_L`` alone,
    with the inner product of the whole vectors (:func:`_symmetric_inner`)
    and the products of :func:`_toeplitz_product`. Returns None if
    conjugate gradients do not converge.
    """
    theta = np.radians(theta_deg)
    order = max_order
    nyquist = order > 0 and order == grid.nyquist_order
    half = order - 1 if nyquist else order  # L
    moments, projections = _trigonometric_sums(theta, error_arcmin, 2 * order + 1, order + 1)
    rhs = projections[: half + 1].copy()  # r_0 .. r_L
    rhs[0] = rhs[0].real  # Σ ε_i: real (the non-uniform FFT leaves a rounding's imaginary part)
    multiplicity = np.full(half + 1, 2.0)  # x_j stands for x_j and x_{-j}
    multiplicity[0] = 1.0
    diagonal = np.full(half + 1, float(theta.size))  # s_0 = n
    product = _toeplitz_product(moments, half)
    if nyquist:
        j = np.arange(half + 1)
        turn = np.exp(1j * order * grid.phase_rad)
        border = 0.5 * (moments[order - j] / turn + turn * np.conj(moments[order + j]))  # u_0 .. u_L
        corner = 0.5 * (theta.size + np.real(moments[2 * order] / turn**2))
        rhs = np.r_[rhs, np.real(turn * projections[order])]
        diagonal = np.r_[diagonal, corner]
        toeplitz_product, border_weights = product, multiplicity * np.conj(border)
        multiplicity = np.r_[multiplicity, 1.0]

        def product(z):
            x, d = z[:-1], z[-1].real
            along = float(np.sum((border_weights * x).real))  # Σ_{|k| <= L} conj(u_k) x_k: real
            return np.r_[toeplitz_product(x) + border * d, along + corner * d]

    solution = _conjugate_gradients(product, rhs, diagonal, multiplicity)
    if solution is None:
        return None
    c = solution[: half + 1]  # c_0 .. c_L
    cos_arcmin, sin_arcmin = np.zeros(order + 1), np.zeros(order + 1)
    cos_arcmin[: half + 1], sin_arcmin[: half + 1] = 2.0 * c.real, -2.0 * c.imag
    cos_arcmin[0], sin_arcmin[0] = c[0].real, 0.0
    if nyquist:
        shift = order * grid.phase_rad
        cos_arcmin[-1], sin_arcmin[-1] = solution[-1].real * np.cos(shift), solution[-1].real * np.sin(shift)
    return cos_arcmin, sin_arcmin


def _fast_length(n):
    """The smallest ``2^a 3^b 5^c >= n``: an FFT of that length runs at full speed (an FFT of a length with a large
    prime factor, 147,285 = 3 · 5 · 9,819, took 12 times as long as one of 147,456)."""
    n = max(int(n), 1)
    best = 1 << (n - 1).bit_length()  # a power of 2
    power5 = 1
    while power5 < best:
        odd = power5  # 3^b 5^c
        while odd < best:
            length = odd
            while length < n:
                length *= 2
            best = min(best, length)
            odd *= 3
        power5 *= 5
    return best


def _toeplitz_product(moments, half):
    """``x ↦ (Σ_{|k| <= L} s_{k-j} x_k)_{j = 0..L}`` for vectors with ``x_{-k} = conj(x_k)`` given by
    ``x_0 .. x_L``.

    ``L`` is ``half`` and ``moments`` holds ``s_0 .. s_{2L}`` (at least), ``s_{-m} = conj(s_m)``. On a circle of
    ``M >= 4L + 1`` points (:func:`_fast_length`) the product is a circular convolution without wrap-around; with
    ``x_k`` placed at ``k mod M``, ``X(t) = Σ_k x_k e^{2πikt/M}`` and the spectrum ``H(t) = Σ_m s_m e^{-2πimt/M}``
    are real (Hermitian sequences), so each product is one inverse real FFT, a real product and one real FFT of
    length ``M``: ``rfft(H · irfft(x, M))[: L + 1]``. ``H`` is computed once. (SciPy's ``matmul_toeplitz`` took
    three complex FFTs of the whole vector's embedding a product, its spectrum among them: on 10^6 random angles
    to order 36,821, 27 ms a product, against 2 ms.)
    """
    size = _fast_length(4 * half + 1)
    spectrum = np.fft.hfft(moments[: 2 * half + 1], n=size)  # Σ_m s_m e^{-2πimt/M}, |m| <= 2L: real

    def product(x):
        return np.fft.rfft(spectrum * np.fft.irfft(x, n=size))[: half + 1]

    return product


#: Above this many terms (points times moments) the trigonometric sums of the normal equations come
#: from the non-uniform FFT of :mod:`encal.numerics.trigsums`; below it from the exact products, which are
#: then as fast.
_NUFFT_ABOVE = 2_000_000


#: Above this order the sums of :func:`_trigonometric_sums` are taken Taylor term by term with real FFTs
#: (:func:`~encal.numerics.trigsums.trig_moments_real`); up to it by :func:`trig_moments`, which then bins every
#: term in one pass.
_REAL_FFT_ABOVE_ORDER = 1000


def _moments(theta_rad, weights, highest_order):
    """:func:`trig_moments` of the angles, by :func:`~encal.numerics.trigsums.trig_moments_real` above
    ``_REAL_FFT_ABOVE_ORDER``."""
    if highest_order > _REAL_FFT_ABOVE_ORDER:
        return trig_moments_real(theta_rad, weights, highest_order)
    return trig_moments(theta_rad, weights, highest_order)


def _trigonometric_sums(theta_rad, error_arcmin, n_moments, n_projections, chunk=4096):
    """``s_m = Σ_i e^{imθ_i}`` for m < n_moments and ``r_j = Σ_i ε_i e^{-ijθ_i}`` for j < n_projections.

    Large sums (more than ``_NUFFT_ABOVE`` terms) are computed by the non-uniform FFT,
    O(n + M log M). Otherwise:

    With ``m = pB + q`` and ``B ≈ √M``, ``e^{imθ} = e^{ipBθ} e^{iqθ}``, so the
    sums are products of an ``(M/B, n)`` and an ``(n, B)`` matrix: O(n M)
    multiply-adds in BLAS, O(n √M) exponentials. Points go in chunks of
    ``chunk`` to bound the memory.
    """
    if theta_rad.size * n_moments > _NUFFT_ABOVE:
        # O(n + M log M) by the Taylor-expanded non-uniform FFT, to about 1e-14 of Σ|weights|
        moments = _moments(theta_rad, np.ones(theta_rad.size), n_moments - 1)
        projections = np.conj(_moments(theta_rad, error_arcmin, n_projections - 1))
        return moments, projections
    block = int(np.ceil(np.sqrt(n_moments)))
    coarse = np.arange(-(-n_moments // block)) * block
    fine = np.arange(block)
    projected_rows = -(-n_projections // block)
    moments = np.zeros((coarse.size, block), dtype=complex)
    projections = np.zeros((projected_rows, block), dtype=complex)
    for start in range(0, theta_rad.size, chunk):
        theta = theta_rad[start : start + chunk]
        outer = np.exp(1j * np.outer(coarse, theta))
        inner = np.exp(1j * np.outer(theta, fine))
        moments += outer @ inner
        projections += (outer[:projected_rows] * error_arcmin[start : start + chunk]) @ inner
    return moments.reshape(-1)[:n_moments], np.conj(projections.reshape(-1)[:n_projections])


def _symmetric_inner(a, b, multiplicity):
    """``Re Σ_j conj(a_j) b_j`` of whole vectors given by their halves: ``multiplicity`` counts each entry's copies."""
    return float(np.sum(multiplicity * (a.real * b.real + a.imag * b.imag)))


def _conjugate_gradients(product, rhs, diagonal, multiplicity):
    """Solve ``product(x) = rhs``, Hermitian positive definite, by Jacobi-preconditioned CG.

    The vectors are halves of vectors with ``x_{-j} = conj(x_j)``, and inner products are those of the whole
    vectors (:func:`_symmetric_inner` with ``multiplicity``). Returns None if the residual is not below
    ``_CG_RTOL`` of ``rhs`` within ``_CG_MAX_ITER`` steps (an ill-conditioned system: the QR is then used).
    """
    def norm(vector):
        return math.sqrt(_symmetric_inner(vector, vector, multiplicity))

    x = np.zeros_like(rhs)
    residual = rhs.copy()
    target = _CG_RTOL * norm(rhs)
    preconditioned = residual / diagonal
    direction = preconditioned.copy()
    energy = _symmetric_inner(residual, preconditioned, multiplicity)
    for _ in range(_CG_MAX_ITER):
        if norm(residual) <= target:
            return x
        image = product(direction)
        curvature = _symmetric_inner(direction, image, multiplicity)
        if not curvature > 0.0:
            return None
        step = energy / curvature
        x += step * direction
        residual -= step * image
        preconditioned = residual / diagonal
        energy, previous = _symmetric_inner(residual, preconditioned, multiplicity), energy
        direction = preconditioned + (energy / previous) * direction
    return None

"""Bidirectional calibrations: the reversal (hysteresis) error, and models per direction of travel.

A calibration with a ``direction`` column (+1 forward, -1 reverse) visits the target angles turning both
ways. :func:`reversal` evaluates it the way ISO 230-2:2014 (clause 3, terms and definitions) evaluates a
rotary axis: at each target position ``i`` the mean deviation approached forward ``x̄↑_i`` and reverse
``x̄↓_i``, the reversal value ``B_i = x̄↑_i − x̄↓_i``, and for the axis the reversal value ``B = max |B_i|``,
the mean reversal value ``B̄ = mean(B_i)``, the systematic positional deviations ``E↑``, ``E↓`` and the
bidirectional ``E``, and the range ``M`` of the mean bidirectional positional deviation. With at least two
approaches per direction and target it adds the repeatability ``R`` and the accuracy ``A``.
``docs/bidirectional.md`` lists the definitions and how encal applies them to an encoder.

:func:`encal.fit` fits such a calibration with one model per direction (a
:class:`~encal.models.directional.DirectionalModel`) or one model of the two directions' mean
(:func:`encal.models.fitting.fit_bidirectional`); this module holds the analysis both use.
"""

from dataclasses import dataclass

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, lsb_arcmin, wrap360
from .calibration import MIN_POINTS, Calibration
from .._core.errors import CalibrationError
from .._core.parameters import check_type, invalid

__all__ = [
    "MODES",
    "ReversalAnalysis",
    "reversal",
    "mean_calibration",
    "direction_subset",
    "require_directions",
    "has_both_directions",
    "forward_travel",
]

#: How :func:`encal.models.fitting.fit_bidirectional` treats the two directions.
MODES = ("per-direction", "mean")

#: Reference angles closer than this (degrees) are the same target position.
TARGET_TOLERANCE_DEG = 1e-6
#: How the deviations are taken, for every statement of the ISO 230-2 values (docs/bidirectional.md, "Sign").
DEVIATION_SIGN_NOTE = ("deviation x = encoder − reference, the negative of a machine test's actual − target: B_i and "
                       "B̄ have the opposite sign, the other values the same")

#: Slack (degrees) on a target tolerance: angles written a tolerance apart (100 and 100.01 under 0.01) differ by
#: it give or take a double's rounding (100.01 - 100 = 0.010000000000005), and are one target all round the circle.
_TOLERANCE_SLACK_DEG = 1e-9


@dataclass(frozen=True, eq=False)
class ReversalAnalysis:
    """Positional deviations of a bidirectional calibration, evaluated as in ISO 230-2:2014.

    The deviation at a target is the encoder's error ``x = θ_enc − θ_ref`` (arc-minutes): the reference
    angle is the target position and the encoder's reading the position it indicates.

    Attributes
    ----------
    target_deg : ndarray of shape (m,)
        Target positions (reference angles, degrees) approached in both directions, ascending.
    n_forward, n_reverse : ndarray of int of shape (m,)
        Number of approaches in each direction.
    mean_forward_arcmin, mean_reverse_arcmin : ndarray of shape (m,)
        Mean unidirectional positional deviations ``x̄↑_i`` and ``x̄↓_i``.
    std_forward_arcmin, std_reverse_arcmin : ndarray of shape (m,)
        Estimators of the unidirectional repeatability ``s↑_i``, ``s↓_i`` (``ddof=1``); NaN with fewer than
        two approaches.
    n_unmatched : int
        Points at target positions approached in one direction only (left out).
    resolution_bits : int or None
        Encoder resolution, for values in LSB.
    target_tolerance_deg : float
        Reference angles within this many degrees of a neighbour were taken as one target (see
        :func:`target_positions`).
    forward_travel : int
        Which way the points labelled +1 (``↑``) moved from target to target, in the order given: +1 towards
        increasing reference angles (ISO 230-2's positive direction), -1 towards decreasing ones while the
        points labelled -1 moved towards increasing (the labels are the opposite of the standard's ``↑`` and
        ``↓``), 0 when the order does not tell (see :func:`forward_travel`).
    """

    target_deg: np.ndarray
    n_forward: np.ndarray
    n_reverse: np.ndarray
    mean_forward_arcmin: np.ndarray
    mean_reverse_arcmin: np.ndarray
    std_forward_arcmin: np.ndarray
    std_reverse_arcmin: np.ndarray
    n_unmatched: int = 0
    resolution_bits: int | None = None
    target_tolerance_deg: float = TARGET_TOLERANCE_DEG
    forward_travel: int = 0

    @property
    def reversal_arcmin(self):
        """Reversal value at each target, ``B_i = x̄↑_i − x̄↓_i`` (arcmin)."""
        return self.mean_forward_arcmin - self.mean_reverse_arcmin

    @property
    def mean_bidirectional_arcmin(self):
        """Mean bidirectional positional deviation at each target, ``x̄_i = (x̄↑_i + x̄↓_i) / 2`` (arcmin)."""
        return 0.5 * (self.mean_forward_arcmin + self.mean_reverse_arcmin)

    @property
    def reversal_value(self):
        """Reversal value of the axis, ``B = max |B_i|`` (arcmin)."""
        return float(np.max(np.abs(self.reversal_arcmin)))

    @property
    def mean_reversal_value(self):
        """Mean reversal value of the axis, ``B̄ = mean(B_i)`` (arcmin, signed)."""
        return float(np.mean(self.reversal_arcmin))

    @property
    def systematic_deviation_forward(self):
        """Unidirectional systematic positional deviation ``E↑ = max x̄↑_i − min x̄↑_i`` (arcmin)."""
        return float(np.ptp(self.mean_forward_arcmin))

    @property
    def systematic_deviation_reverse(self):
        """Unidirectional systematic positional deviation ``E↓ = max x̄↓_i − min x̄↓_i`` (arcmin)."""
        return float(np.ptp(self.mean_reverse_arcmin))

    @property
    def systematic_deviation(self):
        """Bidirectional systematic positional deviation ``E = max(x̄↑, x̄↓) − min(x̄↑, x̄↓)`` (arcmin)."""
        both = np.concatenate([self.mean_forward_arcmin, self.mean_reverse_arcmin])
        return float(np.ptp(both))

    @property
    def mean_bidirectional_deviation(self):
        """Range of the mean bidirectional positional deviation ``M = max x̄_i − min x̄_i`` (arcmin)."""
        return float(np.ptp(self.mean_bidirectional_arcmin))

    @property
    def has_repeats(self):
        """Whether every target was approached at least twice in each direction (needed for R and A)."""
        return bool(np.all(self.n_forward >= 2) and np.all(self.n_reverse >= 2))

    @property
    def repeatability_forward(self):
        """Unidirectional repeatability of positioning ``R↑ = max 4 s↑_i`` (arcmin), or None without repeats."""
        return float(4 * np.max(self.std_forward_arcmin)) if self.has_repeats else None

    @property
    def repeatability_reverse(self):
        """Unidirectional repeatability of positioning ``R↓ = max 4 s↓_i`` (arcmin), or None without repeats."""
        return float(4 * np.max(self.std_reverse_arcmin)) if self.has_repeats else None

    @property
    def repeatability(self):
        """Bidirectional repeatability of positioning ``R = max R_i`` (arcmin), or None without repeats.

        ``R_i = max(2 s↑_i + 2 s↓_i + |B_i|, 4 s↑_i, 4 s↓_i)``.
        """
        if not self.has_repeats:
            return None
        up, down = self.std_forward_arcmin, self.std_reverse_arcmin
        r_i = np.maximum.reduce([2 * up + 2 * down + np.abs(self.reversal_arcmin), 4 * up, 4 * down])
        return float(np.max(r_i))

    @property
    def accuracy_forward(self):
        """Unidirectional accuracy of positioning ``A↑ = max(x̄↑_i + 2 s↑_i) − min(x̄↑_i − 2 s↑_i)`` (arcmin), or
        None without repeats."""
        if not self.has_repeats:
            return None
        return _band_range(self.mean_forward_arcmin, self.std_forward_arcmin)

    @property
    def accuracy_reverse(self):
        """Unidirectional accuracy of positioning ``A↓ = max(x̄↓_i + 2 s↓_i) − min(x̄↓_i − 2 s↓_i)`` (arcmin), or
        None without repeats."""
        if not self.has_repeats:
            return None
        return _band_range(self.mean_reverse_arcmin, self.std_reverse_arcmin)

    @property
    def min_approaches(self):
        """Fewest approaches in one direction at one target; ISO 230-2 asks for 5 (``R`` and ``A`` need 2)."""
        return int(min(self.n_forward.min(), self.n_reverse.min()))

    @property
    def accuracy(self):
        """Bidirectional accuracy of positioning ``A`` (arcmin), or None without repeats.

        ``A = max(x̄↑ + 2 s↑, x̄↓ + 2 s↓) − min(x̄↑ − 2 s↑, x̄↓ − 2 s↓)`` over all targets.
        """
        if not self.has_repeats:
            return None
        return _band_range(np.concatenate([self.mean_forward_arcmin, self.mean_reverse_arcmin]),
                           np.concatenate([self.std_forward_arcmin, self.std_reverse_arcmin]))

    def caption(self):
        """How many targets the values rest on, the points left out, and the fewest approaches (one line)."""
        caption = (f"{self.target_deg.size} targets approached both ways, at least {self.min_approaches} "
                   "time(s) each way (ISO 230-2 asks for 5)")
        if self.n_unmatched:
            points, are = ("point", "is") if self.n_unmatched == 1 else ("points", "are")
            caption += (f"; {self.n_unmatched} {points} at reference angles approached one way only (targets match "
                        f"within {self.target_tolerance_deg:g} degree) {are} left out")
        elif self.target_tolerance_deg != TARGET_TOLERANCE_DEG:
            caption += f"; reference angles within {self.target_tolerance_deg:g} degree are one target"
        if self.forward_travel == -1:
            caption += ("; the points labelled +1 (↑) turned towards decreasing reference angles and those labelled "
                        "-1 towards increasing: ISO 230-2's ↑ is the positive direction, so its ↑ figures are the ↓ "
                        "here and B_i, B̄ change sign (swap the labels of the direction column for the standard's)")
        return caption

    def as_dict(self):
        """The axis values as JSON-ready data (arc-minutes; LSB too when the resolution is known)."""
        data = {
            "n_targets": int(self.target_deg.size),
            "n_unmatched": int(self.n_unmatched),
            "reversal_value_arcmin": self.reversal_value,
            "mean_reversal_value_arcmin": self.mean_reversal_value,
            "systematic_deviation_forward_arcmin": self.systematic_deviation_forward,
            "systematic_deviation_reverse_arcmin": self.systematic_deviation_reverse,
            "systematic_deviation_arcmin": self.systematic_deviation,
            "mean_bidirectional_deviation_arcmin": self.mean_bidirectional_deviation,
            "repeatability_forward_arcmin": self.repeatability_forward,
            "repeatability_reverse_arcmin": self.repeatability_reverse,
            "repeatability_arcmin": self.repeatability,
            "accuracy_forward_arcmin": self.accuracy_forward,
            "accuracy_reverse_arcmin": self.accuracy_reverse,
            "accuracy_arcmin": self.accuracy,
            "min_approaches": self.min_approaches,
            "target_tolerance_deg": self.target_tolerance_deg,
            "forward_travel": {1: "increasing reference angle", -1: "decreasing reference angle"}.get(
                self.forward_travel),
            "deviation": "encoder - reference",
        }
        if self.resolution_bits is not None:
            lsb = lsb_arcmin(self.resolution_bits)
            data["reversal_value_lsb"] = self.reversal_value / lsb
            data["mean_reversal_value_lsb"] = self.mean_reversal_value / lsb
        return data

    def per_target(self):
        """Each target's values as JSON-ready data: ``target_deg``, ``n_forward``, ``n_reverse`` and, in arcmin,
        ``x̄↑_i``, ``x̄↓_i``, ``s↑_i``, ``s↓_i`` (None with one approach), ``B_i`` and ``x̄_i``: the table and
        plot an ISO 230-2 report gives besides the axis values."""
        def number(value):
            return None if not np.isfinite(value) else float(value)

        return [{"target_deg": float(target), "n_forward": int(up_n), "n_reverse": int(down_n),
                 "mean_forward_arcmin": float(up_mean), "mean_reverse_arcmin": float(down_mean),
                 "std_forward_arcmin": number(up_std), "std_reverse_arcmin": number(down_std),
                 "reversal_arcmin": float(up_mean - down_mean),
                 "mean_bidirectional_arcmin": float((up_mean + down_mean) / 2)}
                for target, up_n, down_n, up_mean, down_mean, up_std, down_std in zip(
                    self.target_deg, self.n_forward, self.n_reverse, self.mean_forward_arcmin,
                    self.mean_reverse_arcmin, self.std_forward_arcmin, self.std_reverse_arcmin)]


def _band_range(mean, std):
    """``max(mean + 2 std) − min(mean − 2 std)``: the range an accuracy of positioning spans (arcmin)."""
    return float(np.max(mean + 2 * std) - np.min(mean - 2 * std))


def require_directions(cal, caller):
    """Refuse a calibration without at least MIN_POINTS points in each direction of travel (one sentence)."""
    check_type(cal, Calibration, "cal", caller, "a Calibration")
    if cal.direction is None:
        raise CalibrationError(f"{caller} expects a calibration with a direction column (+1/-1); "
                               f"{cal.source or cal.name or 'the calibration'} has none")
    counts = {sign: int(np.sum(cal.direction == sign)) for sign in (1, -1)}
    if min(counts.values()) < MIN_POINTS:
        raise CalibrationError(f"{caller} expects at least {MIN_POINTS} points in each direction; "
                               f"{cal.source or cal.name or 'the calibration'} has {counts[1]} forward "
                               f"and {counts[-1]} reverse")


def has_both_directions(cal):
    """Whether a calibration has readings taken turning forward (+1) and readings taken turning back (-1)."""
    return cal.direction is not None and bool(np.any(cal.direction == 1)) and bool(np.any(cal.direction == -1))


def direction_subset(cal, direction):
    """The points of one direction of travel (+1 forward, -1 reverse), without the direction column."""
    check_type(cal, Calibration, "cal", "direction_subset", "a Calibration")
    if isinstance(direction, bool) or direction not in (1, -1):
        raise invalid("direction", "direction_subset", "1 (forward) or -1 (reverse)", direction)
    keep = cal.direction == direction
    part = cal.subset(keep)
    return Calibration(part.reference_deg, part.encoder_deg, epoch=part.epoch, name=cal.name,
                       resolution_bits=cal.resolution_bits, source=cal.source, metadata=dict(cal.metadata),
                       reading_sign=cal.reading_sign, reference_std_arcmin=part.reference_std_arcmin)


def target_positions(reference_deg, tolerance_deg=TARGET_TOLERANCE_DEG, *, where=None):
    """The target position of every reading: reference angles within ``tolerance_deg`` of a neighbour are one target.

    Sorted reference angles (wrapped to [0, 360); when the angles on both sides of 0 are within the tolerance, the
    circle cut at the widest gap between neighbours instead) split where two neighbours are more than
    ``tolerance_deg`` apart; each group's target is its median angle (the angle itself when
    it was written the same way every time). Rounding to a grid instead would split two readings 1e-9 degree apart
    on either side of a grid line.

    Parameters
    ----------
    reference_deg : ndarray
        Reference angles (degrees).
    tolerance_deg : float
        Largest gap (degrees) between neighbouring angles of one target: a gap of exactly the tolerance (to
        1e-9 degree) joins them.
    where : str, optional
        The calibration's file or name. When given, a group whose angles span more than ``tolerance_deg`` (its
        neighbours each within the tolerance, so that neighbouring targets were joined) is refused, naming it.

    Returns
    -------
    ndarray
        Target position (degrees, in [0, 360)) of each reading.

    Raises
    ------
    CalibrationError
        With ``where``: when one target's angles span more than ``tolerance_deg``.
    """
    angle = wrap360(np.asarray(reference_deg, dtype=float))
    limit = tolerance_deg + _TOLERANCE_SLACK_DEG
    if angle.size >= 2 and angle.min() + 360.0 - angle.max() <= limit:
        # A target that straddles 0/360 is one group: the circle is cut at its widest gap between neighbours (a
        # fixed cut at 360 - tolerance split a target there, such as 355 deg under a tolerance of 5).
        ordered = np.sort(angle)
        widest = int(np.argmax(np.diff(ordered)))
        angle = np.where(angle > ordered[widest], angle - 360.0, angle)
    order = np.argsort(angle, kind="stable")
    ordered = angle[order]
    starts = np.r_[True, np.diff(ordered) > limit]
    first = np.flatnonzero(starts)
    last = np.r_[first[1:], ordered.size] - 1
    if where is not None:
        span = ordered[last] - ordered[first]
        if np.any(span > limit):
            worst = int(np.argmax(span))
            joined = "all the reference angles" if first.size == 1 else (
                f"the reference angles from {wrap360(ordered[first[worst]]):.6g} to "
                f"{wrap360(ordered[last[worst]]):.6g} deg")
            raise CalibrationError(
                f"{where}: {joined}, each within the target tolerance {tolerance_deg:g} deg of a neighbour, span "
                f"{span[worst]:.3g} deg as one target; expected the approaches to one target within the tolerance "
                "of each other (give a target tolerance above the scatter of one target's angles and below the "
                "spacing of the targets)")
    # the median of each group (sorted): exact for an angle written the same way every time
    median = 0.5 * (ordered[first + (last - first) // 2] + ordered[first + (last - first + 1) // 2])
    target = np.empty_like(angle)
    target[order] = median[np.cumsum(starts) - 1]
    return wrap360(target)


def forward_travel(reference_deg, direction):
    """Which way the points labelled +1 moved between targets, in the order given: ISO 230-2's ``↑`` is the
    positive direction of the axis, here the reference angle's increase.

    Each direction's steps between consecutive points of that direction (wrapped to ±180 degrees; steps of
    0, repeats at one target, and of more than 90 degrees, the return to the start of a pass, left out) are
    counted; the labels are taken as the standard's when most +1 steps increase and most -1 steps decrease,
    as its opposite when the other way round.

    Parameters
    ----------
    reference_deg : ndarray
        Reference angles (degrees), in the order the points were taken.
    direction : ndarray of {+1, -1}
        Each point's label.

    Returns
    -------
    int
        +1 (the +1 points turned towards increasing angles, the -1 points towards decreasing), -1 (the
        opposite), 0 (the order does not tell: sorted data, or a sense that differs from the labels' pairing).
    """
    senses = []
    for sign in (1, -1):
        steps = np.diff(np.asarray(reference_deg, dtype=float)[direction == sign])
        steps = (steps + 180.0) % 360.0 - 180.0
        steps = steps[(steps != 0.0) & (np.abs(steps) <= 90.0)]
        up, down = int(np.count_nonzero(steps > 0)), int(np.count_nonzero(steps < 0))
        senses.append(0 if up == down else (1 if up > down else -1))
    return senses[0] if senses[0] == -senses[1] else 0


def reversal(cal):
    """Reversal (hysteresis) error of a bidirectional calibration, as ISO 230-2:2014 evaluates it.

    Parameters
    ----------
    cal : Calibration
        With a ``direction`` column; target positions are matched by reference angle: angles within the
        calibration's ``target_tolerance_deg`` (by default 1e-6 degree) of a neighbour are one target
        (:func:`target_positions`).

    Returns
    -------
    ReversalAnalysis

    Raises
    ------
    CalibrationError
        If the calibration has no direction column, fewer than 8 points in a direction, no target
        position approached in both directions, or (with a ``target_tolerance_deg`` given) one target whose
        reference angles span more than the tolerance.

    Examples
    --------
    >>> import numpy as np, encal
    >>> ref = np.tile(np.arange(0.0, 360.0, 10.0), 2)
    >>> direction = np.repeat([1, -1], 36)
    >>> cal = encal.Calibration(ref, ref + (0.5 + 0.1 * direction) / 60, direction=direction)
    >>> round(reversal(cal).mean_reversal_value, 9), round(reversal(cal).systematic_deviation, 9)
    (0.2, 0.2)
    """
    require_directions(cal, "reversal")
    tolerance = cal.target_tolerance_deg
    where = cal.source or cal.name or "the calibration"
    target = target_positions(cal.reference_deg, TARGET_TOLERANCE_DEG if tolerance is None else tolerance,
                              where=None if tolerance is None else where)
    error = cal.errors_arcmin
    stats = {}
    for sign in (1, -1):
        side = cal.direction == sign
        keys, inverse, counts = np.unique(target[side], return_inverse=True, return_counts=True)
        sums = np.bincount(inverse, weights=error[side])
        means = sums / counts
        squares = np.bincount(inverse, weights=np.square(error[side] - means[inverse]))
        with np.errstate(invalid="ignore", divide="ignore"):
            stds = np.where(counts >= 2, np.sqrt(squares / np.maximum(counts - 1, 1)), np.nan)
        stats[sign] = (keys, counts, means, stds)
    common, up_index, down_index = np.intersect1d(stats[1][0], stats[-1][0], return_indices=True)
    if common.size == 0:
        within = "" if tolerance is None else f" within {tolerance:g} deg"
        raise CalibrationError(f"{where}: no reference angle was approached in both directions{within}; expected "
                               "the same target positions forward and reverse (a reference read afresh at every "
                               "approach needs a target tolerance: --target-tolerance DEG)")
    unmatched = int(stats[1][1].sum() - stats[1][1][up_index].sum()
                    + stats[-1][1].sum() - stats[-1][1][down_index].sum())
    up, down = stats[1], stats[-1]
    return ReversalAnalysis(
        target_deg=common,
        n_forward=up[1][up_index], n_reverse=down[1][down_index],
        mean_forward_arcmin=up[2][up_index], mean_reverse_arcmin=down[2][down_index],
        std_forward_arcmin=up[3][up_index], std_reverse_arcmin=down[3][down_index],
        n_unmatched=unmatched, resolution_bits=cal.resolution_bits,
        target_tolerance_deg=TARGET_TOLERANCE_DEG if tolerance is None else tolerance,
        forward_travel=forward_travel(cal.reference_deg, cal.direction),
    )


def mean_calibration(cal):
    """The mean of both directions at every target position, as a one-direction calibration.

    Parameters
    ----------
    cal : Calibration
        With a ``direction`` column.

    Returns
    -------
    Calibration
        At each target approached in both directions: ``reference_deg`` the target and ``encoder_deg`` the
        target plus the mean bidirectional positional deviation ``x̄_i``.
    """
    analysis = reversal(cal)
    reference = analysis.target_deg
    std = cal.reference_std_arcmin
    if std is not None:  # at each target, the reference's uncertainty where its readings were taken
        # (the largest of the readings at one reference angle, whichever direction: np.interp would take
        # whichever its sort put last)
        angles, largest = largest_per_angle(cal.reference_deg, std)
        std = np.interp(reference, angles, largest, period=360.0)
    return Calibration(reference, reference + analysis.mean_bidirectional_arcmin / ARCMIN_PER_DEG,
                       name=cal.name, resolution_bits=cal.resolution_bits, source=cal.source,
                       metadata={**cal.metadata, "bidirectional": "mean"}, reading_sign=cal.reading_sign,
                       reference_std_arcmin=std)


def largest_per_angle(angle_deg, values):
    """The distinct angles of ``angle_deg`` (wrapped to [0, 360)) and the largest of ``values`` at each: what
    ``np.interp(..., period=360)`` of a per-point uncertainty needs (at angles read twice it takes whichever of
    the values its sort puts last)."""
    angles, group = np.unique(wrap360(np.asarray(angle_deg, dtype=float)), return_inverse=True)
    largest = np.full(angles.size, -np.inf)
    np.maximum.at(largest, group.reshape(-1), values)
    return angles, largest

"""Drift between repeated calibrations of one encoder, and whether a model fitted on the first still holds.

The paper validates its method by calibrating each encoder again at later epochs and finding the error
profiles "near reproducible". :func:`compare_calibrations` measures that: the difference of each later
profile from the first, and the residual of a model fitted on the first calibration when it corrects the
later ones.

Zero offset. A calibration's zero is often arbitrary: a stepper motor's reference starts wherever the motor
stood, so two repeats differ by a constant of tens of degrees that says nothing about the encoder. By
default (``offset='remove'``) each calibration's circular-mean offset ``ō = arg mean exp(i (θ_enc − θ_ref))``
is taken out of its errors, and its reference angles are moved by the change of offset,
``θ_ref + (ō_k − ō_0)``, into the first calibration's zero, so the profiles are compared at the same shaft
position; the change of offset is reported on its own, and residuals are taken about their mean.
``offset='keep'`` compares errors as measured, at the raw reference angles, for a setup whose zero is fixed.

The verdict. The model (by default the paper's ten-harmonic Fourier series fitted on the first calibration)
has residual RMS ``rms₀`` on the first calibration and ``rms_k`` on a later one. ``rms₀`` is in-sample and
optimistic: on a repeat of an unchanged encoder with fresh noise of RMS ``σ`` a least-squares fit leaves
``rms_e = sqrt(2 σ² − rms₀²)`` (``σ`` estimated from the first calibration's point-to-point scatter,
:func:`noise_rms_arcmin`; never below ``rms₀``). The model still holds when ``rms_k − rms_e <= tolerance``, by
default ``max(1 LSB, max(0.1, 3 / sqrt(n)) · rms_e)`` over ``n`` points: a change below one LSB is below what the
encoder resolves (its quantisation and 1-LSB hysteresis), and 10 % covers the sampling error of an RMS over 180
points (about 5 %) twice, three standard errors on fewer. See ``docs/drift.md``.
"""

import math
import re
import warnings
from dataclasses import dataclass, replace

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, lsb_arcmin, resolution_of_readings, wrap180, wrap360
from ..data.calibration import MAX_BITS, MIN_POINTS, Calibration
from .._core.errors import EncalWarning, InputError
from ..models.base import Model
from .._core.parameters import check_choice, check_int, check_number, check_type, invalid
from ..analysis.profile import correction_is_worse, error_stats, worse_sentence, zero_offset_arcmin

__all__ = [
    "OFFSET_MODES",
    "match_profile",
    "EpochDrift",
    "DriftReport",
    "compare_calibrations",
    "split_epochs",
    "circular_mean_offset_arcmin",
    "infer_resolution_bits",
    "noise_rms_arcmin",
    "expected_repeat_rms_arcmin",
]

#: How :func:`compare_calibrations` treats each calibration's zero offset.
OFFSET_MODES = ("remove", "keep")

#: Default tolerance: the residual RMS may exceed a repeat's by ``max(1 LSB, RELATIVE_TOLERANCE * rms_e)``.
RELATIVE_TOLERANCE = 0.10

#: ... or by this many standard errors of ``rms_k − rms_e`` on pure noise (``1 / sqrt(n)`` of ``rms_e``), if more.
SAMPLING_STANDARD_ERRORS = 3.0

#: Positions closer than this (degrees, 3.6 arcsec) are the same point when matching two calibrations.
MATCH_TOLERANCE_DEG = 1e-3


@dataclass(frozen=True, eq=False)
class EpochDrift:
    """One later calibration compared with the first.

    Attributes
    ----------
    label : str
        Name of the later calibration.
    angle_deg : ndarray of shape (n,)
        Positions of its points: reference angles, in the first calibration's zero with
        ``offset='remove'`` (degrees).
    difference_arcmin : ndarray of shape (n,)
        Its error minus the first calibration's error at the same position (arcmin).
    interpolated : bool
        Whether some positions were not within 0.001 degree of a point of the first calibration (its profile
        was interpolated linearly and periodically there).
    offset_change_arcmin : float
        Its circular-mean offset minus the first's (arcmin).
    share_within_lsb : float or None
        Share of ``|difference| <= 1 LSB``, when the resolution is known.
    residual_rms_arcmin : float
        RMS residual of the model on this calibration (about the mean with ``offset='remove'``), arcmin.
    increase_arcmin : float
        ``residual_rms_arcmin`` minus ``expected_rms_arcmin``, arcmin.
    uncorrected_rms_arcmin : float or None
        RMS error of this calibration without the correction (about the mean with ``offset='remove'``), arcmin.
    holds : bool
        Whether ``increase_arcmin <= tolerance``.
    noise_rms_arcmin : float or None
        The pair's noise ``sqrt(σ₀² + σ_k²)`` from second differences: the smaller of the two calibrations'
        own (:func:`noise_rms_arcmin`) and the difference profile's, arcmin.
    expected_rms_arcmin : float or None
        The residual RMS the model should leave on it were the encoder unchanged
        (:func:`expected_repeat_rms_arcmin`), arcmin.
    """

    label: str
    angle_deg: np.ndarray
    difference_arcmin: np.ndarray
    interpolated: bool
    offset_change_arcmin: float
    share_within_lsb: float | None
    residual_rms_arcmin: float
    increase_arcmin: float
    holds: bool
    uncorrected_rms_arcmin: float | None = None
    noise_rms_arcmin: float | None = None
    expected_rms_arcmin: float | None = None

    @property
    def correction_worse(self):
        """Whether the model's correction leaves a larger RMS error here than no correction."""
        return self.uncorrected_rms_arcmin is not None and correction_is_worse(self.uncorrected_rms_arcmin,
                                                                               self.residual_rms_arcmin)

    def worse_sentence(self):
        """The sentence saying that the correction makes this calibration's errors larger, or None."""
        if self.uncorrected_rms_arcmin is None:
            return None
        return worse_sentence(self.uncorrected_rms_arcmin, self.residual_rms_arcmin, f" on {self.label}")

    @property
    def difference(self):
        """:class:`~encal.analysis.profile.ErrorStats` of the difference profile (arcmin)."""
        return error_stats(self.difference_arcmin)

    def as_dict(self):
        stats = self.difference
        return {
            "label": self.label,
            "n": int(stats.n),
            "interpolated": bool(self.interpolated),
            "offset_change_arcmin": float(self.offset_change_arcmin),
            "difference": {
                "rms_arcmin": float(stats.rms),
                "max_abs_arcmin": float(stats.max_abs),
                "mean_arcmin": float(np.mean(self.difference_arcmin)),
                "std_arcmin": float(stats.std),
                "share_within_lsb": self.share_within_lsb,
            },
            "residual_rms_arcmin": float(self.residual_rms_arcmin),
            "increase_arcmin": float(self.increase_arcmin),
            "noise_rms_arcmin": self.noise_rms_arcmin,
            "expected_rms_arcmin": self.expected_rms_arcmin,
            "holds": bool(self.holds),
            "uncorrected_rms_arcmin": (None if self.uncorrected_rms_arcmin is None
                                       else float(self.uncorrected_rms_arcmin)),
            "correction_worse": bool(self.correction_worse),
            "correction_note": self.worse_sentence(),
        }


@dataclass(frozen=True, eq=False)
class DriftReport:
    """Later calibrations of an encoder compared with its first.

    Attributes
    ----------
    baseline_label : str
        Name of the first calibration.
    epochs : tuple of EpochDrift
        One per later calibration, in the order given.
    offset : {'remove', 'keep'}
        How zero offsets were treated.
    model_kind : str
        Kind of the model judged.
    method : str or None
        Fitting method, when the model was fitted here.
    baseline_rms_arcmin : float
        The model's residual RMS on the first calibration, ``rms₀`` (about the mean with
        ``offset='remove'``), arcmin.
    tolerance_arcmin : float
        Allowed increase of the residual RMS.
    tolerance_rule : str
        Where the tolerance came from.
    resolution_bits : int or None
        Encoder resolution used for LSB figures.
    resolution_inferred : bool
        Whether the resolution was inferred from readings on a grid of ``360 / 2**bits`` degrees.
    baseline_offset_arcmin : float or None
        The first calibration's zero offset (circular mean of its errors), arcmin.
    noise_rms_arcmin : float or None
        Point-to-point noise of the first calibration (:func:`noise_rms_arcmin`), arcmin.
    expected_rms_arcmin : float or None
        The smallest of the later calibrations' ``expected_rms_arcmin``: what the tolerance and the detectable
        drift are relative to. None stands for ``baseline_rms_arcmin``.
    """

    baseline_label: str
    epochs: tuple
    offset: str
    model_kind: str
    method: str | None
    baseline_rms_arcmin: float
    tolerance_arcmin: float
    tolerance_rule: str
    resolution_bits: int | None
    resolution_inferred: bool
    baseline_offset_arcmin: float | None = None
    noise_rms_arcmin: float | None = None
    expected_rms_arcmin: float | None = None

    @property
    def holds(self):
        """Whether the model holds on every later calibration."""
        return all(epoch.holds for epoch in self.epochs)

    @property
    def lsb_arcmin(self):
        """One LSB in arcmin, or None when the resolution is unknown."""
        return None if self.resolution_bits is None else lsb_arcmin(self.resolution_bits)

    @property
    def detectable_drift_rms_arcmin(self):
        """RMS of the smallest drift the verdict catches, ``sqrt((rms_e + tol)² − rms_e²)`` (arcmin).

        A drift ``d`` uncorrelated with the residual adds in quadrature: ``rms_k² ≈ rms_e² + rms(d)²``, with
        ``rms_e`` the residual expected on an unchanged repeat.
        """
        base = self.baseline_rms_arcmin if self.expected_rms_arcmin is None else self.expected_rms_arcmin
        return math.sqrt((base + self.tolerance_arcmin) ** 2 - base**2)

    def as_dict(self):
        """JSON-ready: the settings, the verdict, and one object per later calibration under ``epochs``."""
        return {
            "baseline": self.baseline_label,
            "offset": self.offset,
            "model_kind": self.model_kind,
            "method": self.method,
            "resolution_bits": self.resolution_bits,
            "resolution_inferred": self.resolution_inferred,
            "baseline_offset_arcmin": self.baseline_offset_arcmin,
            "lsb_arcmin": self.lsb_arcmin,
            "baseline_rms_arcmin": float(self.baseline_rms_arcmin),
            "noise_rms_arcmin": self.noise_rms_arcmin,
            "expected_rms_arcmin": self.expected_rms_arcmin,
            "tolerance_arcmin": float(self.tolerance_arcmin),
            "tolerance_rule": self.tolerance_rule,
            "detectable_drift_rms_arcmin": self.detectable_drift_rms_arcmin,
            "holds": self.holds,
            "epochs": [epoch.as_dict() for epoch in self.epochs],
        }


# --------------------------------------------------------------------------- helpers


def split_epochs(cal):
    """The runs of a calibration with an ``epoch`` column, one calibration per label, in order of appearance.

    Raises
    ------
    InputError
        If an epoch has fewer than ``MIN_POINTS`` (8) points, as a calibration file may not (fuzz5: one row
        whose label was mistyped got a drift verdict of its own).
    """
    if cal.epoch is None:
        return [cal]
    labels = dict.fromkeys(cal.epoch.tolist())  # first appearance order
    _warn_if_labels_sort_otherwise(cal, list(labels))
    runs = [cal.subset(cal.epoch == label) for label in labels]
    for label, run in zip(labels, runs):
        if len(run) < MIN_POINTS:
            raise InputError(f"{cal.source or cal.name or 'the calibration'}: epoch {label} has {len(run)} "
                             f"calibration point{'' if len(run) == 1 else 's'}, expected at least {MIN_POINTS} in each "
                             "epoch, as in a calibration file (is its label mistyped?)")
    return runs


#: Epoch labels whose order is their meaning: numbers (``1``, ``2.5``) or ISO 8601 dates and times (``2026-11-28``,
#: ``2026-11-28T09:30``).
_ORDERED_LABEL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|\d{4}-\d{2}-\d{2}([T ][\d:.]+)?")


def _warn_if_labels_sort_otherwise(cal, labels):
    """Warn when every epoch label is a number or a date and they first appear in another order than theirs: the
    runs are taken in order of appearance, the first the baseline, and a file sorted by angle (in a spreadsheet) put
    a later run first and judged the earlier against it."""
    if len(labels) < 2 or not all(_ORDERED_LABEL.fullmatch(label) for label in labels):
        return
    numbers = all(not re.fullmatch(r"\d{4}-\d{2}-\d{2}.*", label) for label in labels)
    ordered = sorted(labels, key=float) if numbers else sorted(labels)
    if ordered != labels:
        warnings.warn(f"{cal.source or cal.name or 'the calibration'}: its epochs are taken in the order their rows "
                      f"first appear ({', '.join(labels)}), the first as the baseline, but their labels run "
                      f"{', '.join(ordered)}; sort the rows by epoch, or give the runs as files in the order wanted",
                      EncalWarning, stacklevel=3)


def circular_mean_offset_arcmin(cal):
    """Circular mean of ``θ_enc − θ_ref`` over a calibration, in arc-minutes within (−10800, 10800]."""
    return zero_offset_arcmin(cal.errors_arcmin)


def infer_resolution_bits(cal, *, max_bits=24):
    """Resolution of an encoder whose readings are whole counts, or None.

    Parameters
    ----------
    cal : Calibration
    max_bits : int, default=24

    Returns
    -------
    int or None
        The smallest ``bits`` (8 to ``max_bits``) for which every reading is within 0.001 count of a
        multiple of ``360 / 2**bits`` degrees; None when there is none (readings that are not counts).

    Examples
    --------
    >>> import numpy as np, encal
    >>> ref = np.arange(0.0, 360.0, 1.8)
    >>> counts = np.round((ref + 0.1) * 2**14 / 360)
    >>> infer_resolution_bits(encal.Calibration(ref, counts * 360 / 2**14))
    14
    """
    check_type(cal, Calibration, "cal", "infer_resolution_bits", "a Calibration")
    max_bits = check_int(max_bits, "max_bits", "infer_resolution_bits", low=8, high=MAX_BITS)
    return resolution_of_readings(cal.encoder_deg, max_bits=max_bits)


def _common_coverage(first, later):
    """The two calibrations cut to the positions both cover, when either covers an arc only (None when both
    cover the full turn). A later calibration reaching past the first's arc was compared with the first's
    profile interpolated across its gap, and each offset was a mean over different positions: an unchanged
    encoder calibrated over 100-200 deg against 30-150 deg showed a difference of 1.23 arcmin RMS and an offset
    change of -1.01 arcmin (arc8).

    Raises
    ------
    CalibrationError
        When the two cover no common position.
    """
    from .._core.arcs import arc_of, describe_range, inside
    from .._core.errors import CalibrationError
    from ..models.arc import MAX_GAP_DEG

    arcs = [arc_of(cal.reference_deg, MAX_GAP_DEG) for cal in (first, later)]
    if arcs[0] is None and arcs[1] is None:
        return None
    keep_first = inside(first.reference_deg, arcs[1]) & inside(first.reference_deg, arcs[0])
    keep_later = inside(later.reference_deg, arcs[0]) & inside(later.reference_deg, arcs[1])
    if keep_first.sum() < 2 or keep_later.sum() < 2:
        where = later.source or later.name or "a later calibration"
        covers = [describe_range(arc) if arc is not None else "the full turn" for arc in arcs]
        raise CalibrationError(f"{where} covers {covers[1]} and the first calibration {covers[0]}: fewer than two "
                               "readings of each lie where both have readings; expected calibrations of one "
                               "encoder over overlapping positions")
    return first.subset(keep_first), later.subset(keep_later)


def _profile(cal, offset, base_offset_arcmin):
    """Positions (deg, in the first calibration's zero) and errors (arcmin) of a calibration."""
    error = cal.errors_arcmin
    if offset == "keep":
        return cal.reference_deg, error
    mean_offset = circular_mean_offset_arcmin(cal)
    # Subtract, then wrap: the errors' own wrapping may differ from the offset's by 360 degrees.
    error = wrap180((error - mean_offset) / ARCMIN_PER_DEG) * ARCMIN_PER_DEG
    shift_deg = float(wrap180((mean_offset - base_offset_arcmin) / ARCMIN_PER_DEG))
    return wrap360(cal.reference_deg + shift_deg), error


def match_profile(angle_deg, value, at_deg, tolerance_deg=MATCH_TOLERANCE_DEG):
    """A profile at other positions: how a later calibration is compared with an earlier one.

    Parameters
    ----------
    angle_deg, value : ndarray of shape (n,)
        The profile: positions (degrees) and values (arc-minutes).
    at_deg : array-like of shape (m,)
        Positions to read it at, degrees.
    tolerance_deg : float, default=MATCH_TOLERANCE_DEG
        A position within this distance of a point of the profile (round the circle) takes that point's
        value; the nearest one, the lower on a tie.

    Returns
    -------
    values : ndarray of shape (m,)
        The profile at ``at_deg``: a matched point's value, else the periodic linear interpolation.
    matched : ndarray of bool of shape (m,)
        Which positions matched a point.
    """
    tolerance_deg = check_number(tolerance_deg, "tolerance_deg", "match_profile", low=0.0)
    order = np.argsort(angle_deg, kind="stable")
    grid, values = angle_deg[order], value[order]
    at = np.asarray(at_deg, dtype=float)
    above = np.searchsorted(grid, at) % grid.size
    candidates = np.stack([above - 1, above])  # index -1 wraps to the last point
    distance = np.abs(wrap180(at[None, :] - grid[candidates]))
    nearest = candidates[distance.argmin(axis=0), np.arange(at.size)]
    matched = distance.min(axis=0) <= tolerance_deg
    result = np.interp(at, grid, values, period=360.0)
    result[matched] = values[nearest[matched]]
    return result, matched


def _uncorrected_rms(cal, offset):
    """RMS error of a calibration without correction (about its mean with ``offset='remove'``), arcmin."""
    error = cal.errors_arcmin
    if offset == "remove":
        error = error - error.mean()
    return float(np.sqrt(np.mean(np.square(error))))


def _residual_rms(model, cal, offset):
    residual = wrap180((cal.errors_arcmin - model.predict(cal.readings_deg)) / ARCMIN_PER_DEG) * ARCMIN_PER_DEG
    if getattr(model, "range_deg", None) is not None:  # a model over an arc: the residual over the arc (issue 31)
        from .._core.arcs import within_model_range

        residual = residual[within_model_range(model, cal)]
    if offset == "remove":
        residual = residual - residual.mean()
    return float(np.sqrt(np.mean(np.square(residual))))


def noise_rms_arcmin(cal):
    """Point-to-point noise of a calibration's errors, model-free, from its local second differences (arcmin).

    Sorted by reference angle, each interior point's error minus the straight line through its two neighbours,
    ``e_i − (h₊ e₋ + h₋ e₊) / (h₋ + h₊)`` (``h₋``, ``h₊`` the spacings), has variance
    ``σ² (1 + (h₋² + h₊²) / (h₋ + h₊)²)`` for independent noise of variance ``σ²`` and removes any part of the
    profile that is linear over three points. Structure the grid barely resolves (a stepper's 50th harmonic
    on 200 points) counts as noise: the estimate is then high.

    Parameters
    ----------
    cal : Calibration

    Returns
    -------
    float
        The estimated noise standard deviation ``σ``, arc-minutes (0.0 with fewer than three points).
    """
    error = wrap180((cal.errors_arcmin - circular_mean_offset_arcmin(cal)) / ARCMIN_PER_DEG) * ARCMIN_PER_DEG
    return _second_difference_rms(cal.reference_deg, error)


def _second_difference_rms(angle_deg, value):
    """Noise standard deviation of ``value`` along ``angle_deg`` from local second differences (see above)."""
    order = np.argsort(angle_deg, kind="stable")
    angle, value = np.asarray(angle_deg)[order], np.asarray(value)[order]
    if value.size < 3:
        return 0.0
    before, after = np.diff(angle)[:-1], np.diff(angle)[1:]
    span = before + after
    usable = span > 0
    before, after, span = before[usable], after[usable], span[usable]
    centre, left, right = value[1:-1][usable], value[:-2][usable], value[2:][usable]
    if centre.size == 0:
        return 0.0
    departure = centre - (after * left + before * right) / span
    variance_factor = 1.0 + (before**2 + after**2) / span**2
    return float(np.sqrt(np.mean(departure**2 / variance_factor)))


def expected_repeat_rms_arcmin(baseline_arcmin, noise_arcmin, repeat_noise_arcmin=None):
    """The residual RMS a model should leave on a repeat of an unchanged encoder (arcmin).

    A least-squares fit with ``p`` parameters on ``n`` points of noise ``σ₀`` leaves ``rms₀² = b² + σ₀² (n − p) / n``
    in-sample (``b`` what it does not model), so its own error has mean square ``σ₀² p / n``; on a repeat with
    noise ``σ_k`` it leaves ``b² + σ_k² + σ₀² p / n = σ_k² + σ₀² − rms₀² + 2 b²``, whatever ``p`` (a table
    through its points, ``rms₀ = 0``, gives ``sqrt(σ_k² + σ₀²)``). Taken with ``b = 0`` and never below ``rms₀``.

    Parameters
    ----------
    baseline_arcmin : float
        The model's residual RMS on the first calibration, ``rms₀`` (arcmin).
    noise_arcmin : float
        The first calibration's noise ``σ₀``, arcmin; or, with ``repeat_noise_arcmin=0``, the pair's
        ``sqrt(σ₀² + σ_k²)``.
    repeat_noise_arcmin : float, optional
        The repeat's noise ``σ_k``, arcmin; default ``σ₀``.
    """
    repeat = noise_arcmin if repeat_noise_arcmin is None else repeat_noise_arcmin
    square = repeat**2 + noise_arcmin**2 - baseline_arcmin**2
    return float(math.sqrt(max(baseline_arcmin**2, square)))


def _pair_noise_arcmin(first_noise, cal, angle, difference):
    """``sqrt(σ₀² + σ_k²)`` of a first and a later calibration (arcmin): the smaller of two estimates that
    err high for different reasons. Each calibration's own second differences count structure the grid barely
    resolves (shared by both, so it cancels from their difference); the difference profile's count a drift
    of high order (which each calibration's own do not see)."""
    own = math.hypot(first_noise, noise_rms_arcmin(cal))
    return min(own, _second_difference_rms(angle, difference))


def _tolerance(given_arcmin, expected_arcmin, lsb, n_points):
    """The allowed excess of the residual RMS (arcmin) and a phrase saying where it came from.

    The relative term is the larger of 10 % and three standard errors of ``rms_k − rms_e`` on pure noise,
    about ``1 / sqrt(n)`` of ``rms_e`` for ``n`` points (measured: 6.4 % on 180 points, 3.9 % on 720; drift5).
    """
    if given_arcmin is not None:
        return float(given_arcmin), "given"
    share = max(RELATIVE_TOLERANCE, SAMPLING_STANDARD_ERRORS / math.sqrt(max(n_points, 1)))
    relative = share * expected_arcmin
    phrase = f"{100 * share:.0f}% of the residual expected on a repeat"
    if lsb is None:
        return relative, f"{phrase} (resolution unknown)"
    return max(lsb, relative), f"max(1 LSB, {phrase})"


def _calibrations(cals):
    expected = "a sequence of Calibrations or one Calibration with an epoch column"
    if isinstance(cals, Calibration):
        runs = split_epochs(cals)
    else:
        try:
            runs = list(cals)
        except TypeError:
            raise invalid("cals", "compare_calibrations", expected, cals,
                          shown=f"an object of type {type(cals).__name__}") from None
        if len(runs) == 1 and isinstance(runs[0], Calibration):
            runs = split_epochs(runs[0])
    for index, cal in enumerate(runs):
        check_type(cal, Calibration, f"cals[{index}]", "compare_calibrations", "a Calibration")
        if cal.direction is not None and np.unique(cal.direction).size > 1:
            raise InputError(f"compare_calibrations compares one direction of travel at a time; "
                             f"{_label(cal, index)} has both (select one with "
                             "encal.data.reversal.direction_subset)")
    if len(runs) < 2:
        raise InputError("compare_calibrations expects at least two calibrations (or one with two epochs); "
                         f"got {len(runs)}")
    return runs


def _label(cal, index):
    if cal.epoch is not None and np.unique(cal.epoch).size == 1 and cal.epoch[0]:
        return f"{cal.name} {cal.epoch[0]}".strip()
    return cal.name or (cal.source or f"calibration {index + 1}")


def _unique_labels(labels):
    seen = {}
    unique = []
    for label in labels:
        seen[label] = seen.get(label, 0) + 1
        unique.append(label if seen[label] == 1 else f"{label} ({seen[label]})")
    return unique


def _resolution(runs):
    known = [cal.resolution_bits for cal in runs if cal.resolution_bits is not None]
    if known:  # the finest, the strictest LSB term: the first's 12 bits made a 0.73' drift at 16 bits hold (drift5)
        return int(max(known)), False
    inferred = {infer_resolution_bits(cal) for cal in runs}
    if len(inferred) == 1 and None not in inferred:
        return inferred.pop(), True
    return None, False


# --------------------------------------------------------------------------- comparison


def compare_calibrations(cals, *, tolerance_arcmin=None, model=None, method="fourier", offset="remove",
                         labels=None, rng=None, **options):
    """Compare later calibrations of an encoder with the first, and judge whether its model still holds.

    Parameters
    ----------
    cals : sequence of Calibration, or Calibration
        The first calibration, then the later ones; or one calibration whose ``epoch`` column names the runs
        (in order of appearance). One direction of travel each.
    tolerance_arcmin : float, optional
        Allowed excess of a later calibration's residual RMS over the one expected on an unchanged repeat,
        arc-minutes. Default ``max(1 LSB, max(10 %, 3 / sqrt(n)) · rms_e)`` (the relative term alone when the
        resolution is unknown and cannot be inferred from the readings).
    model : Model, optional
        The model to judge, normally fitted on the first calibration. Default: fit ``method`` on it.
    method : str, default='fourier'
        Fitting method when ``model`` is None (with its defaults, the paper's ten largest harmonics).
    offset : {'remove', 'keep'}, default='remove'
        Take each calibration's circular-mean offset out before comparing (see the module docstring).
    labels : sequence of str, optional
        Names of the calibrations; default their epoch label or encoder name.
    rng : int or numpy.random.Generator, optional
        Seed of a randomised method.
    **options
        Options of ``method``.

    Returns
    -------
    DriftReport

    Raises
    ------
    InputError
        On fewer than two calibrations, a bidirectional one, or an invalid option.

    Examples
    --------
    >>> import numpy as np, encal
    >>> ref = np.arange(0.0, 360.0, 2.0)
    >>> profile = 2.0 * np.sin(np.radians(ref)) + 0.5 * np.cos(np.radians(3 * ref))
    >>> noise = np.random.default_rng(0).normal(0.0, 0.1, (2, ref.size))
    >>> first, later = (encal.Calibration(ref, ref + (profile + n) / 60, resolution_bits=16) for n in noise)
    >>> report = compare_calibrations([first, later], orders=[0, 1, 3])
    >>> report.holds, round(report.tolerance_arcmin, 4)
    (True, 0.3296)
    """
    from ..models.fitting import fit

    where = "compare_calibrations"
    runs = _calibrations(cals)
    offset = check_choice(offset, "offset", where, OFFSET_MODES)
    if tolerance_arcmin is not None:
        tolerance_arcmin = check_number(tolerance_arcmin, "tolerance_arcmin", where, low=0.0,
                                        note="arc-minutes, or None for the default")
    if model is not None:
        check_type(model, Model, "model", where, "a Model or None")
    if labels is None:
        names = [_label(cal, i) for i, cal in enumerate(runs)]
    elif isinstance(labels, (str, bytes)) or not hasattr(labels, "__len__") or len(labels) != len(runs):
        raise invalid("labels", where, f"a sequence of one label per calibration ({len(runs)}), or None", labels)
    else:
        names = [str(x) for x in labels]
    names = _unique_labels(names)
    bits, inferred = _resolution(runs)
    lsb = None if bits is None else lsb_arcmin(bits)

    first = runs[0]
    if model is None:
        model = fit(first, method, rng=rng, **options)
    else:
        method = None
    baseline = _residual_rms(model, first, offset)
    # The verdict's reference is the residual of an unchanged repeat, not the in-sample one: the latter is
    # optimistic by far more than 10 % for a model that selects harmonics or interpolates (drift5).
    noise = noise_rms_arcmin(first)

    base_offset = circular_mean_offset_arcmin(first)
    base_angle, base_error = _profile(first, offset, base_offset)
    epochs = []
    for name, cal in zip(names[1:], runs[1:]):
        base_offset_here, base_angle_here, base_error_here, compared = base_offset, base_angle, base_error, cal
        common = _common_coverage(first, cal)
        if common is not None:  # arcs (arc8): compared where both calibrations have readings, never across a gap
            first_common, compared = common
            base_offset_here = circular_mean_offset_arcmin(first_common)
            base_angle_here, base_error_here = _profile(first_common, offset, base_offset_here)
        cal_offset = circular_mean_offset_arcmin(compared)
        angle, error = _profile(compared, offset, base_offset_here)
        expected, matched = match_profile(base_angle_here, base_error_here, angle)
        interpolated = bool(not np.all(matched))
        difference = error - expected
        residual = _residual_rms(model, cal, offset)
        epoch_noise = _pair_noise_arcmin(noise, compared, angle, difference)
        epoch_expected = expected_repeat_rms_arcmin(baseline, epoch_noise, 0.0)
        increase = residual - epoch_expected  # holds: set below, against the tolerance
        epochs.append(EpochDrift(
            label=name,
            angle_deg=angle,
            difference_arcmin=difference,
            interpolated=interpolated,
            offset_change_arcmin=float(wrap180((cal_offset - base_offset_here) / ARCMIN_PER_DEG)) * ARCMIN_PER_DEG,
            share_within_lsb=None if lsb is None else float(np.mean(np.abs(difference) <= lsb)),
            residual_rms_arcmin=residual,
            increase_arcmin=increase,
            holds=False,
            uncorrected_rms_arcmin=_uncorrected_rms(cal, offset),
            noise_rms_arcmin=epoch_noise,
            expected_rms_arcmin=epoch_expected,
        ))
    # One tolerance for all: relative to the smallest expected residual, the most demanding.
    expected_rms = min(epoch.expected_rms_arcmin for epoch in epochs)
    tolerance, rule = _tolerance(tolerance_arcmin, expected_rms, lsb, min(len(cal) for cal in runs))
    epochs = [replace(epoch, holds=bool(epoch.increase_arcmin <= tolerance)) for epoch in epochs]
    return DriftReport(
        baseline_label=names[0], epochs=tuple(epochs), offset=offset, model_kind=model.kind, method=method,
        baseline_rms_arcmin=baseline, tolerance_arcmin=tolerance,
        tolerance_rule=rule, resolution_bits=bits, resolution_inferred=inferred, baseline_offset_arcmin=base_offset,
        noise_rms_arcmin=noise, expected_rms_arcmin=expected_rms,
    )

"""Isolated points: calibration readings far off their neighbours on both sides.

A single misread point (a glitch, a reading taken before the table settled)
poisons every model of the profile: a lookup table passes through it, a
Fourier series spreads it round the circle, a network bends to it and can
swing far from the data elsewhere. A step in the profile, or the alternation
of a stepper's full steps, is not isolated: on one side at least the point
agrees with its neighbours.

A point is *isolated* when its error differs from the mean of its two
neighbours on the left and from the mean of its two neighbours on the right
in the same direction, by more than :data:`ISOLATION_FACTOR` times the
typical step between neighbouring errors (1.4826 × the median absolute
difference, the standard deviation of the steps for Gaussian steps). On
the 60 real calibrations of ``../shared/data/real`` and on the demo fleet no
point is; one misread point of 500 arcmin among errors of 3 arcmin is, at
about 90 times the typical step.

Repeated readings (a continuous sweep over several revolutions reads each stop once per turn) are judged
otherwise: sorted by encoder angle, a stop's readings come in the order of their errors, the steps between
them are a fraction of the noise, and the tails of every stop's spread looked isolated (a clean sweep of
5·10^5 readings over 5 turns raised a warning). When most stops hold two or more readings, a reading is
isolated when it lies more than :data:`ISOLATION_FACTOR` times the readings' typical spread (1.4826 × the
median absolute difference between successive readings of a stop, divided by sqrt(2): the noise's standard
deviation for Gaussian noise) from the median of its stop's readings. A stop read once is judged against the
median of its reading and the medians of the two neighbouring stops; of a stop's two readings, as far from
their mean both, the one farther from the neighbouring stops is named.
"""

from dataclasses import dataclass

import numpy as np

from .._core.angles import wrap360
from .._core.sorting import stable_argsort
from .._core.parameters import check_number
from .profile import profile_arrays

__all__ = ["IsolatedPoints", "isolated_points", "ISOLATION_FACTOR"]

#: How many typical steps between neighbouring errors make a point isolated.
ISOLATION_FACTOR = 10.0

#: Fewest points for which the test is made (two neighbours on each side, and some to spare).
MIN_POINTS = 8


@dataclass(frozen=True)
class IsolatedPoints:
    """The isolated points of a profile.

    Attributes
    ----------
    index : ndarray of int
        Indices of the isolated points in the input, in input order.
    deviation_arcmin : ndarray
        For each, the smaller of its two differences from its neighbours' means (signed), arcmin.
    typical_step_arcmin : float
        The typical step between neighbouring errors the deviations are measured against, arcmin; for
        repeated readings (``repeated``), the readings' typical spread (their noise's standard deviation).
    repeated : bool, default=False
        The points were judged against the other readings at their stop (most stops were read several
        times): ``deviation_arcmin`` is then from the median of the stop's readings.
    """

    index: np.ndarray
    deviation_arcmin: np.ndarray
    typical_step_arcmin: float
    repeated: bool = False


def isolated_points(theta_enc_deg, error_arcmin, *, reference_deg=None, quantum_arcmin=None,
                    factor=ISOLATION_FACTOR, reference_order=None):
    """Find the calibration points whose error is far off their neighbours' on both sides.

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees; neighbours are taken round the circle, by angle.
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.
    reference_deg : array-like of shape (n,), optional
        Reference angles in degrees: readings at the same reference angle (to 1e-9 degrees) are repeated
        readings of one stop. When most stops hold two or more, the points are judged against their
        stop's readings (see the module docstring).
    quantum_arcmin : float, optional
        The errors' resolution (one LSB), a floor for the typical step: on a quantised profile that
        is flat over several points the median step is 0, and a one-LSB blip is no misread. Default:
        the smallest non-zero step.
    factor : float, default=ISOLATION_FACTOR
        How many typical steps make a point isolated.
    reference_order : ndarray of int, optional
        The stable argsort of ``reference_deg`` (in [0, 360)), if the caller has it: the stops are then
        labelled and grouped without sorting again.

    Returns
    -------
    IsolatedPoints
        Empty (``index.size == 0``) for fewer than 8 points.

    Examples
    --------
    >>> theta = np.arange(0.0, 360.0, 10.0)
    >>> error = np.sin(np.radians(theta))
    >>> error[7] = 50.0
    >>> found = isolated_points(theta, error)
    >>> found.index.tolist(), round(float(found.deviation_arcmin[0]), 1)
    [7, 49.1]
    """
    theta, error = profile_arrays(theta_enc_deg, error_arcmin, "isolated_points")
    if quantum_arcmin is not None:
        quantum_arcmin = check_number(quantum_arcmin, "quantum_arcmin", "isolated_points", low=0.0,
                                      note="arc-minutes, or None")
    factor = check_number(factor, "factor", "isolated_points", low=0.0, low_open=True)
    if reference_deg is not None:
        reference = np.asarray(reference_deg, dtype=float).reshape(-1)
        if reference.shape != theta.shape:
            raise ValueError(f"reference_deg has {reference.size} values but theta_enc_deg has {theta.size}; "
                             "expected one reference angle per reading")
    k, distinct, starts = 0, None, None
    if reference_deg is not None and reference_order is not None:
        k, distinct, starts = _readings_per_stop(reference, reference_order)
        if k >= 3 and theta.size >= MIN_POINTS and _has_identical(theta, error) is False:
            # k >= 3 readings at every stop and no point identical: the stops' table, without a sort of the
            # encoder angles
            return _isolated_table(error, reference_order, k, quantum_arcmin, factor)
    # Identical repeated points (accepted as they are) count once: their zero steps would shrink the
    # typical step, and a point next to its own repeat has no neighbour on that side.
    by_angle, sorted_theta = stable_argsort(theta, return_sorted=True)  # one sort (angles in [0, 360) already)
    first = _first_of_identical(theta, error, by_angle, sorted_theta)
    del sorted_theta
    if first.size < theta.size:
        found = isolated_points(theta[first], error[first], quantum_arcmin=quantum_arcmin, factor=factor,
                                reference_deg=None if reference_deg is None else reference[first])
        return IsolatedPoints(first[found.index], found.deviation_arcmin, found.typical_step_arcmin,
                              found.repeated)
    none = IsolatedPoints(np.zeros(0, dtype=int), np.zeros(0), 0.0)
    if theta.size < MIN_POINTS:
        return none
    if k >= 3:
        return _isolated_table(error, reference_order, k, quantum_arcmin, factor)
    if reference_deg is not None:
        # a median of two or more readings a stop needs n >= 1.5 stops: the common case is told without a sort
        if distinct is None:
            stops = np.round(wrap360(reference), 9)
            distinct = np.unique(stops).size
        if 1.5 * distinct <= theta.size:  # (then starts is known if reference_order is: no other sort)
            if starts is None:
                stop = np.unique(stops, return_inverse=True)[1].reshape(-1)
            else:
                new_stop = np.zeros(theta.size, dtype=np.intp)
                new_stop[starts] = 1
                stop = np.empty(theta.size, dtype=np.intp)
                stop[reference_order] = np.cumsum(new_stop)
            counts = np.bincount(stop)
            if np.median(counts) >= 2:
                return _isolated_repeats(error, stop, counts, quantum_arcmin, factor, by_stop=reference_order)
    order = by_angle
    e = error[order]
    around = np.concatenate((e[-2:], e, e[:2]))  # the neighbours round the circle as views, no copies by np.roll
    before, before2, after, after2 = around[1:-3], around[:-4], around[3:-1], around[4:]
    steps = np.abs(e - before)
    quantum = quantum_arcmin
    if quantum is None:
        quantum = float(np.min(steps, where=steps > 0, initial=np.inf))
        quantum = 0.0 if quantum == np.inf else quantum
    typical = max(1.4826 * float(np.median(steps)), quantum)
    if typical == 0.0:  # a constant profile
        return none
    from_left = e - (before + before2) / 2.0
    from_right = e - (after + after2) / 2.0
    del around, before, before2, after, after2, steps
    # far off both neighbours' means on the same side: |deviation| over the bound (deviation below)
    bound = factor * typical
    far = np.flatnonzero((np.minimum(from_left, from_right) > bound) | (np.maximum(from_left, from_right) < -bound))
    from_left, from_right = from_left[far], from_right[far]
    deviation = np.sign(from_left) * np.minimum(np.abs(from_left), np.abs(from_right))
    in_input_order = np.argsort(order[far], kind="stable")
    return IsolatedPoints(order[far][in_input_order], deviation[in_input_order], typical)


#: Points whose angles agree to this many decimals of a degree, and errors to this many of an arc-minute, are
#: identical: far below any reading, far above the rounding of a double (a reading of 455 deg wrapped to 95 deg
#: differs from one of 95 deg by about 1e-14 deg, and its error by about 1e-12 arcmin).
IDENTICAL_DECIMALS = 9


def _rounded_angles(theta):
    """Angles in [0, 360) rounded to :data:`IDENTICAL_DECIMALS` decimals, one just under 360 rounded to 0."""
    theta = np.round(theta, IDENTICAL_DECIMALS)
    theta[theta == 360.0] = 0.0
    return theta


def _has_identical(theta, error):
    """Whether some points are identical (as :func:`_first_of_identical` finds them; angles in [0, 360)), told by
    one sort of the rounded angles (a quarter of the time of an argsort) and a look at the few points that share
    an angle; None when more than 64 angles are shared (the caller's argsort is then as quick)."""
    rounded = _rounded_angles(theta)
    ordered = np.sort(rounded)
    equal = ordered[1:] == ordered[:-1]
    if not equal.any():
        return False
    shared = np.unique(ordered[1:][equal])
    if shared.size > 64:
        return None
    candidates = np.flatnonzero(np.isin(rounded, shared))
    return bool(_first_of_identical(theta[candidates], error[candidates]).size < candidates.size)


def _readings_per_stop(reference, reference_order):
    """``(k, distinct, starts)``: k > 0 if the reference angles (``reference_order`` their stable argsort) are k
    readings at every stop (equal to 9 decimals once wrapped to [0, 360), as :func:`isolated_points` compares them),
    else 0; the number of distinct stops; ``starts``, where each stop but the first begins in that order (None when
    there are more than two stops for three readings: no test of repeated readings then)."""
    ordered = np.round(wrap360(reference[reference_order]), 9)  # rounding keeps the order
    new_stop = ordered[1:] != ordered[:-1]
    distinct = int(np.count_nonzero(new_stop)) + 1
    if 1.5 * distinct > ordered.size:  # too few repeats for the test of repeated readings: no labels needed
        return 0, distinct, None
    starts = np.flatnonzero(new_stop) + 1
    k = ordered.size // distinct
    regular = k * distinct == ordered.size and np.array_equal(starts, np.arange(k, ordered.size, k))
    return (k if regular else 0), distinct, starts


def _first_of_identical(theta, error, by_angle=None, sorted_theta=None):
    """Indices of the first of each set of identical (angle, error) points (to :data:`IDENTICAL_DECIMALS`
    decimals: the readings of a noise-free log over several turns differ by the rounding of doubles only), in
    input order. ``by_angle``: the stable argsort of ``theta`` (in [0, 360)), if known; ``sorted_theta``:
    ``theta[by_angle]``, if known."""
    theta = _rounded_angles(theta)  # an angle just under 360 rounds up to it: the same as 0
    if by_angle is None:
        by_angle = np.argsort(theta, kind="stable")
        sorted_theta = theta[by_angle]
    else:  # rounding keeps the order but for angles that round up to 360 and wrap to 0: they go first
        sorted_theta = theta[by_angle] if sorted_theta is None else _rounded_angles(sorted_theta)
        wrapped = np.flatnonzero(sorted_theta[1:] < sorted_theta[:-1])
        if wrapped.size:
            by_angle = np.roll(by_angle, -(int(wrapped[0]) + 1))
            sorted_theta = theta[by_angle]
    equal = sorted_theta[1:] == sorted_theta[:-1]
    del sorted_theta
    if not equal.any():  # the common case: one sort, no pairs
        return np.arange(theta.size)
    tied = np.zeros(theta.size, dtype=bool)
    tied[1:] |= equal
    tied[:-1] |= equal
    candidates = by_angle[tied]  # only the points that share their angle are sorted by (angle, error)
    candidate_error = np.round(error[candidates], IDENTICAL_DECIMALS)
    by_pair = np.lexsort((candidate_error, theta[candidates]))
    candidates, candidate_error = candidates[by_pair], candidate_error[by_pair]
    same = (theta[candidates][1:] == theta[candidates][:-1]) & (candidate_error[1:] == candidate_error[:-1])
    if not same.any():
        return np.arange(theta.size)
    first = np.ones(candidates.size, dtype=bool)
    first[1:] = ~same
    group = np.cumsum(first) - 1
    earliest = np.full(group[-1] + 1, theta.size)
    np.minimum.at(earliest, group, candidates)  # the earliest point of each set in input order
    keep = np.ones(theta.size, dtype=bool)
    keep[candidates] = False
    keep[earliest] = True
    return np.flatnonzero(keep)


def _group_medians(values, groups, n_groups, by_group=None):
    """The median of ``values`` in each group (labels 0 .. n_groups - 1, every group non-empty); ``by_group``:
    indices that sort ``groups``, if known."""
    counts = np.bincount(groups, minlength=n_groups)
    if by_group is not None and counts.min() == counts.max():  # k readings at every stop: a (stops, k) table
        return np.median(values[by_group].reshape(n_groups, -1), axis=1)
    order = np.argsort(values)
    order = order[np.argsort(groups[order], kind="stable")]
    counts = np.bincount(groups, minlength=n_groups)
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    ordered = values[order]
    return (ordered[starts + (counts - 1) // 2] + ordered[starts + counts // 2]) / 2.0


def _isolated_table(error, by_stop, k, quantum, factor):
    """:func:`_isolated_repeats` when every stop holds the same number ``k >= 3`` of readings, ``by_stop`` sorting
    them: the readings as a (stops, k) table, in which a stop's median, its deviations and the steps between its
    successive readings need no gather by label (the same numbers, a third of the time at 10^6 readings)."""
    table = error[by_stop].reshape(-1, k)
    if k % 2:  # the middle one: what np.median takes, in half its time
        medians = np.partition(table, k // 2, axis=1)[:, k // 2]
    else:
        medians = np.median(table, axis=1)
    deviation = (table - medians[:, None]).reshape(-1)
    if quantum is None:
        nonzero = np.abs(deviation[deviation != 0])
        quantum = float(nonzero.min()) if nonzero.size else 0.0
    typical = max(1.4826 * float(np.median(np.abs(np.diff(table, axis=1)))) / np.sqrt(2.0), quantum)
    if typical == 0.0:  # identical readings at every stop
        return IsolatedPoints(np.zeros(0, dtype=int), np.zeros(0), 0.0, True)
    far = np.flatnonzero(np.abs(deviation) > factor * typical)
    in_input_order = np.argsort(by_stop[far])
    return IsolatedPoints(by_stop[far][in_input_order], deviation[far][in_input_order], typical, True)


def _isolated_repeats(error, stop, counts, quantum, factor, by_stop=None):
    """Readings far off their stop (see the module docstring); ``stop`` labels the stops in order of angle,
    ``by_stop`` (optional) sorts them."""
    medians = _group_medians(error, stop, counts.size, by_stop)
    centre = medians[stop]
    alone = np.flatnonzero(counts[stop] == 1)  # judged against the neighbouring stops
    if alone.size:
        centre[alone] = np.median(np.stack((error[alone], np.roll(medians, 1)[stop[alone]],
                                            np.roll(medians, -1)[stop[alone]])), axis=0)
    deviation = error - centre
    del centre
    repeated = counts[stop] >= 2
    if quantum is None:
        nonzero = np.abs(deviation[repeated & (deviation != 0)])
        quantum = float(nonzero.min()) if nonzero.size else 0.0
    # The noise from the differences between successive readings of a stop (sqrt(2) sigma for Gaussian
    # noise): the deviations from a stop's median are biased low (one of three readings is the median).
    if by_stop is None:
        by_stop = np.argsort(stop, kind="stable")
    same = stop[by_stop][1:] == stop[by_stop][:-1]
    steps = np.abs(np.diff(error[by_stop]))[same]
    del by_stop, same
    typical = max(1.4826 * float(np.median(steps)) / np.sqrt(2.0), quantum)
    if typical == 0.0:  # identical readings at every stop
        return IsolatedPoints(np.zeros(0, dtype=int), np.zeros(0), 0.0, True)
    far = np.abs(deviation) > factor * typical
    # Of a stop's two readings, both are as far from their mean: the misread is the one farther from the
    # neighbouring stops.
    pair = far & (counts[stop] == 2)
    if pair.any():
        at = np.flatnonzero(pair)
        order = at[np.argsort(stop[at], kind="stable")]
        off = np.abs(error[order] - (np.roll(medians, 1)[stop[order]] + np.roll(medians, -1)[stop[order]]) / 2.0)
        same = stop[order][1:] == stop[order][:-1]
        drop = np.zeros(order.size, dtype=bool)
        drop[1:] |= same & (off[1:] <= off[:-1])
        drop[:-1] |= same & (off[:-1] < off[1:])
        far[order[drop]] = False
    far = np.flatnonzero(far)
    return IsolatedPoints(far, deviation[far], typical, True)

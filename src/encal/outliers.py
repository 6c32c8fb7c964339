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
"""

from dataclasses import dataclass

import numpy as np

from .parameters import check_number
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
        The typical step between neighbouring errors the deviations are measured against, arcmin.
    """

    index: np.ndarray
    deviation_arcmin: np.ndarray
    typical_step_arcmin: float


def isolated_points(theta_enc_deg, error_arcmin, *, quantum_arcmin=None, factor=ISOLATION_FACTOR):
    """Find the calibration points whose error is far off their neighbours' on both sides.

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees; neighbours are taken round the circle, by angle.
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.
    quantum_arcmin : float, optional
        The errors' resolution (one LSB), a floor for the typical step: on a quantised profile that
        is flat over several points the median step is 0, and a one-LSB blip is no misread. Default:
        the smallest non-zero step.
    factor : float, default=ISOLATION_FACTOR
        How many typical steps make a point isolated.

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
    # Identical repeated points (accepted as they are) count once: their zero steps would shrink the
    # typical step, and a point next to its own repeat has no neighbour on that side.
    _, first = np.unique(np.stack([np.mod(theta, 360.0), error], axis=1), axis=0, return_index=True)
    if first.size < theta.size:
        first = np.sort(first)
        found = isolated_points(theta[first], error[first], quantum_arcmin=quantum_arcmin, factor=factor)
        return IsolatedPoints(first[found.index], found.deviation_arcmin, found.typical_step_arcmin)
    none = IsolatedPoints(np.zeros(0, dtype=int), np.zeros(0), 0.0)
    if theta.size < MIN_POINTS:
        return none
    order = np.argsort(np.mod(theta, 360.0), kind="stable")
    e = error[order]
    steps = np.abs(e - np.roll(e, 1))
    quantum = quantum_arcmin
    if quantum is None:
        nonzero = steps[steps > 0]
        quantum = float(nonzero.min()) if nonzero.size else 0.0
    typical = max(1.4826 * float(np.median(steps)), quantum)
    if typical == 0.0:  # a constant profile
        return none
    from_left = e - (np.roll(e, 1) + np.roll(e, 2)) / 2.0
    from_right = e - (np.roll(e, -1) + np.roll(e, -2)) / 2.0
    same_side = np.sign(from_left) == np.sign(from_right)
    deviation = np.where(same_side, np.sign(from_left) * np.minimum(np.abs(from_left), np.abs(from_right)), 0.0)
    far = np.flatnonzero(np.abs(deviation) > factor * typical)
    in_input_order = np.argsort(order[far], kind="stable")
    return IsolatedPoints(order[far][in_input_order], deviation[far][in_input_order], typical)

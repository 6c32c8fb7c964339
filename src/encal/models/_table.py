"""Large arrays of angles corrected through a table of the model, built once.

Evaluating a Fourier series (a spectral model) costs a few tens of nanoseconds an angle; a table of the
corrections on a uniform grid, interpolated linearly, costs a few. :func:`series_table` builds the table of a
series exactly at its nodes by one inverse real FFT, with as many nodes as make the interpolation error at
most :data:`TABLE_TOLERANCE_ARCMIN`: between two nodes ``h`` radians apart, linear interpolation of ``f`` is off
by at most ``h**2 / 8 * max|f''|``, and ``max|f''| <= sum_k k**2 * sqrt(a_k**2 + b_k**2)`` (arc-minutes per
radian squared) for a series of cosine and sine coefficients ``a_k``, ``b_k``. A series that would need more
than :data:`MAX_TABLE_POINTS` nodes is evaluated term by term (a cubic lookup table likewise, by
:func:`piecewise_table`, from its pieces' second derivatives), as is an array of fewer than
:data:`TABLE_MIN_ANGLES` angles (the table's cost is not repaid). The table's memory is fixed (at most
32 MiB), not proportional to the number of angles, and the angles are corrected a chunk at a time.
"""

import numpy as np

from ..angles import model_input, wrap360

__all__ = ["series_table", "sampled_table", "correct_through_table", "points_for_bound", "series_bound",
           "piecewise_bound", "TABLE_TOLERANCE_ARCMIN", "TABLE_MIN_ANGLES", "MAX_TABLE_POINTS"]

#: Largest error of the table's interpolation, in arc-minutes (0.006 arc-seconds): far below the posterior
#: uncertainty of any calibrated profile (hundredths of an arc-minute and up) and below the 1e-3 arcmin to
#: which model files are compared.
TABLE_TOLERANCE_ARCMIN = 1e-4
#: Fewest angles for which :meth:`Model.correct <encal.models.base.Model.correct>` builds the table.
TABLE_MIN_ANGLES = 1 << 16
#: Most nodes of a table (32 MiB of doubles).
MAX_TABLE_POINTS = 1 << 22
#: Fewest nodes of a table.
MIN_TABLE_POINTS = 1 << 10
#: Angles corrected at a time (their temporaries stay in cache).
_CHUNK = 1 << 14


def points_for_bound(curvature, slope_jump=0.0, tolerance_arcmin=TABLE_TOLERANCE_ARCMIN, highest_order=0):
    """Fewest nodes (a power of two) of a table whose linear interpolation is within ``tolerance_arcmin`` of a
    function with ``|f''| <= curvature`` (arc-minutes per degree squared) whose slope jumps by at most
    ``slope_jump`` (arc-minutes per degree) at a few kinks: ``h**2 / 8 * curvature + h / 4 * slope_jump``
    for nodes ``h`` degrees apart. None beyond :data:`MAX_TABLE_POINTS`."""
    if not (np.isfinite(curvature) and np.isfinite(slope_jump)):
        return None
    if curvature <= 0.0 and slope_jump <= 0.0:
        step = 360.0 / MIN_TABLE_POINTS
    elif curvature <= 0.0:
        step = 4.0 * tolerance_arcmin / slope_jump
    else:
        step = (-slope_jump / 4.0 + np.sqrt((slope_jump / 4.0) ** 2 + curvature / 2.0 * tolerance_arcmin)) \
            / (curvature / 4.0)
    points = max(MIN_TABLE_POINTS, 4 * (int(highest_order) + 1), int(np.ceil(360.0 / step)))
    points = 1 << int(np.ceil(np.log2(points)))
    return points if points <= MAX_TABLE_POINTS else None


def series_bound(orders, cos, sin):
    """``max|f''|`` of a Fourier series, arc-minutes per degree squared: ``sum_k k**2 |c_k|`` per radian squared."""
    orders = np.asarray(orders, dtype=float)
    return float(np.sum(orders**2 * np.hypot(cos, sin))) * (np.pi / 180.0) ** 2


def table_points(orders, cos, sin, tolerance_arcmin=TABLE_TOLERANCE_ARCMIN):
    """Nodes of a table of the series within ``tolerance_arcmin`` (:func:`points_for_bound`), or None."""
    highest = int(np.max(orders)) if np.size(orders) else 0
    return points_for_bound(series_bound(orders, cos, sin), 0.0, tolerance_arcmin, highest)


def sampled_table(evaluate, points):
    """``evaluate`` (arc-minutes, at angles in [0, 360); it bounds its own memory) at ``points`` uniform nodes,
    in degrees, for :func:`correct_through_table` (the first two nodes repeated at the end)."""
    values = evaluate(np.arange(points) * (360.0 / points)) / 60.0
    return np.concatenate([values, values[:2]])


def series_table(orders, cos, sin, tolerance_arcmin=TABLE_TOLERANCE_ARCMIN):
    """The series ``sum_k a_k cos(k theta) + b_k sin(k theta)`` (arc-minutes) in degrees at ``M`` uniform nodes.

    Returns
    -------
    ndarray of shape (M + 2,) or None
        The values divided by 60 (degrees) at ``theta = 360 j / M``, j = 0 .. M + 1 (the last two repeat the
        first two, so that an angle that rounds up to 360 degrees needs no test); None when the series needs
        more than :data:`MAX_TABLE_POINTS` nodes.
    """
    orders = np.asarray(orders, dtype=int).reshape(-1)
    cos, sin = np.asarray(cos, dtype=float).reshape(-1), np.asarray(sin, dtype=float).reshape(-1)
    points = table_points(orders, cos, sin, tolerance_arcmin)
    if points is None:
        return None
    spectrum = np.zeros(points // 2 + 1, dtype=complex)
    # irfft(X)[j] = (X_0 + 2 Re sum_k X_k e^{2 pi i k j / M}) / M for orders below M / 2
    np.add.at(spectrum, orders, np.where(orders == 0, 1.0, 0.5) * points * (cos - 1j * np.where(orders == 0, 0.0, sin)))
    values = np.fft.irfft(spectrum, n=points) / 60.0
    return np.concatenate([values, values[:2]])


def correct_through_table(theta, reading_sign, table):
    """``wrap360(model_input(theta) - f(model_input(theta)) / 60)`` with ``f / 60`` interpolated in ``table``.

    Parameters
    ----------
    theta : ndarray of shape (n,)
        Encoder readings in degrees.
    reading_sign : {1, -1}
    table : ndarray
        From :func:`series_table`.
    """
    points = table.size - 2
    scale = points / 360.0
    out = np.empty(theta.size)
    for start in range(0, theta.size, _CHUNK):
        wrapped = model_input(theta[start:start + _CHUNK], reading_sign)
        position = wrapped * scale
        index = position.astype(np.intp)  # floor: the angles are in [0, 360)
        position -= index
        low = table[index]
        index += 1
        value = table[index]
        value -= low
        value *= position
        value += low
        np.subtract(wrapped, value, out=wrapped)
        out[start:start + _CHUNK] = wrap360(wrapped)
    return out


def piecewise_bound(breaks_deg, coefficients):
    """``(max|f''|, largest slope jump)`` of a continuous piecewise cubic (a cubic lookup-table model), in
    arc-minutes per degree squared and per degree, or None for a table whose pieces do not join, or of another
    degree (a linear table is as cheap evaluated as a table of it, whose kinks would need ~10^6 nodes).

    ``coefficients`` of shape (4, p): each piece's polynomial in ``s = theta - break``, highest power first;
    ``f''`` is linear within a piece, so its largest magnitude is at a piece's ends.
    """
    breaks = np.asarray(breaks_deg, dtype=float)
    c = np.asarray(coefficients, dtype=float)
    if c.ndim != 2 or c.shape[0] != 4:
        return None
    width = np.diff(breaks)
    end_value = ((c[0] * width + c[1]) * width + c[2]) * width + c[3]
    end_slope = (3.0 * c[0] * width + 2.0 * c[1]) * width + c[2]
    scale = max(1.0, float(np.max(np.abs(c[3]))))
    if np.max(np.abs(np.roll(c[3], -1) - end_value)) > 1e-9 * scale:
        return None
    slope_jump = float(np.max(np.abs(np.roll(c[2], -1) - end_slope)))
    curvature = float(np.max(np.maximum(np.abs(2.0 * c[1]), np.abs(6.0 * c[0] * width + 2.0 * c[1]))))
    return curvature, slope_jump

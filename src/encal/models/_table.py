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

__all__ = ["series_table", "correct_through_table", "TABLE_TOLERANCE_ARCMIN", "TABLE_MIN_ANGLES",
           "MAX_TABLE_POINTS"]

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


def table_points(orders, cos, sin, tolerance_arcmin=TABLE_TOLERANCE_ARCMIN):
    """Nodes (a power of two) of a table of the series within ``tolerance_arcmin``, or None beyond
    :data:`MAX_TABLE_POINTS`."""
    orders = np.asarray(orders, dtype=float)
    curvature = float(np.sum(orders**2 * np.hypot(cos, sin)))  # bounds |f''|, arcmin / rad^2
    needed = 2.0 * np.pi * np.sqrt(curvature / (8.0 * tolerance_arcmin))
    highest = int(orders.max()) if orders.size else 0
    points = max(MIN_TABLE_POINTS, 4 * (highest + 1), int(np.ceil(needed)))
    points = 1 << int(np.ceil(np.log2(points)))
    return points if points <= MAX_TABLE_POINTS else None


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


def piecewise_table(breaks_deg, coefficients, evaluate, tolerance_arcmin=TABLE_TOLERANCE_ARCMIN):
    """A table of a continuous piecewise polynomial (a lookup-table model) within ``tolerance_arcmin``, or None.

    Within a piece, linear interpolation between nodes ``h`` degrees apart is off by at most ``h**2 / 8`` times
    the largest ``|f''|``; across a break where the slope jumps by ``d``, by at most ``h * |d| / 4`` more. The
    nodes are the fewest (a power of two) for which the sum is within the tolerance; a table whose pieces do
    not join (a jump in the value) or that would need more than :data:`MAX_TABLE_POINTS` nodes is None.

    Parameters
    ----------
    breaks_deg : ndarray of shape (p + 1,)
        Increasing breaks spanning one turn.
    coefficients : ndarray of shape (degree + 1, p)
        Each piece's polynomial in ``s = theta - break``, highest power first (arc-minutes).
    evaluate : callable
        The model's error (arc-minutes) at angles in [0, 360) (evaluated a chunk at a time).
    """
    from .base import in_chunks

    breaks = np.asarray(breaks_deg, dtype=float)
    c = np.asarray(coefficients, dtype=float)
    width = np.diff(breaks)
    degree = c.shape[0] - 1
    if degree < 2:  # a linear table is as cheap as a table of it, whose kinks would need ~10^6 nodes
        return None
    powers = np.arange(degree, -1, -1)[:, None]
    end_value = np.sum(c * width ** powers, axis=0)
    slope = c[:-1] * powers[:-1]  # the derivative's coefficients
    end_slope = np.sum(slope * width ** (powers[:-1] - 1), axis=0)
    start_value, start_slope = c[-1], (c[-2] if degree >= 1 else np.zeros(width.size))
    scale = max(1.0, float(np.max(np.abs(c[-1]))))
    if np.max(np.abs(np.roll(start_value, -1) - end_value)) > 1e-9 * scale:
        return None
    slope_jump = float(np.max(np.abs(np.roll(start_slope, -1) - end_slope)))
    curvature = 0.0
    if degree >= 2:
        second = slope[:-1] * (powers[:-2] - 1)
        at_start = second[-1]
        at_end = np.sum(second * width ** (powers[:-2] - 2), axis=0)
        if degree > 3:
            return None  # |f''| of higher degrees is not bounded by its ends
        curvature = float(np.max(np.maximum(np.abs(at_start), np.abs(at_end))))  # f'' linear in a cubic piece
    if curvature == 0.0 and slope_jump == 0.0:
        step = 360.0 / MIN_TABLE_POINTS
    elif curvature == 0.0:
        step = 4.0 * tolerance_arcmin / slope_jump
    else:
        step = (-slope_jump / 4.0 + np.sqrt((slope_jump / 4.0) ** 2 + curvature / 2.0 * tolerance_arcmin)) \
            / (curvature / 4.0)
    points = max(MIN_TABLE_POINTS, int(np.ceil(360.0 / step)))
    points = 1 << int(np.ceil(np.log2(points)))
    if points > MAX_TABLE_POINTS:
        return None
    values = in_chunks(evaluate, np.arange(points) * (360.0 / points)) / 60.0
    return np.concatenate([values, values[:2]])

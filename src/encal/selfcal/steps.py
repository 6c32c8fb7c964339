"""Stepper full steps as the reference, and the shift method that separates the stepper's own error.

A stepper energised one full step at a time stands at ``k * 360/N`` plus its own error: a pattern that
repeats every 4 full steps (one rotor tooth; orders N/4, N/2, ... of an N-step motor) plus an error
of each tooth. One calibration sees the encoder error plus that error. The 4-step pattern is found
as the mean of each of the 4 phases and removed (with the encoder's error at the orders that are
multiples of N/4); the tooth errors stay, confounded at every order.

Two calibrations with the magnet turned on the rotor by an angle ``a`` between them separate the two
completely (the shift method): at the same full step the stepper's error is the same, so the
difference of the two errors is ``e(phi_B) - e(phi_A)``, the encoder's error at two readings ``a``
apart, in which the stepper's error cancels. Order ``n`` of the encoder's error appears in it scaled
by ``|2 sin(n a / 2)|``: the orders where that is small cannot be seen and are taken from the
calibrations as measured. The turn need not be known: the two calibrations' mean offset holds it,
once the steps are paired (the same start, or a known shift between the starts; the phase of the
4-step pattern fixes the shift within a tooth). See docs/self-calibration.md.
"""

from dataclasses import replace

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, wrap180
from .._core.errors import InputError
from .._core.parameters import check_int, check_number, check_type
from ..analysis.profile import distinct_angles
from ..data.calibration import Calibration
from ._series import HarmonicSeries, design_matrix
from .result import SelfCalibration
from .._core.threads import single_blas_thread

__all__ = ["steps", "step_errors"]

#: Offsets between two calibrations within this fraction of a whole number of full steps are taken for a start
#: at another step with the magnet not turned (a repeat).
WHOLE_STEP_TOLERANCE = 0.05
#: Offsets within this fraction of a whole number of steps but beyond the tolerance above are pointed out.
NEAR_WHOLE_STEP = 0.2
#: What the summary says when the reading noise is not measured.
NOT_MEASURED = ("not measured: a full-step calibration's point is usually the firmware's mean of several reads "
                "(Mechaduino 10, Klipper every sample over 50 ms), whose noise is not one read's; with two "
                "calibrations of one read per step, --single-reads measures it; the band of a model of this "
                "calibration is the encoder error's, not a new reading's")
#: Orders whose visibility |2 sin(n a / 2)| in the difference of the two calibrations is below this are not separated.
MIN_VISIBILITY = 0.25


def step_errors(cal, where=None):
    """Readings and errors of a full-step calibration ordered by step.

    Parameters
    ----------
    cal : Calibration
        One reading at each of ``N`` full steps: ``reference_deg = k * 360 / N``.
    where : str, optional
        Name of the calibration, for messages.

    Returns
    -------
    reading_deg : ndarray of shape (N,)
    error_arcmin : ndarray of shape (N,)
        ``reading - k * 360/N`` wrapped around its circular mean, in arc-minutes.
    """
    where = where or cal.source or cal.name or "calibration"
    n = len(cal)
    stops = distinct_angles(cal.reference_deg)[0].size
    if stops < n:
        raise InputError(f"{where}: has {n} readings at {stops} reference angles; expected one reading per full "
                         "step (--average-duplicates averages repeated readings)")
    if n < 16 or n % 4:
        raise InputError(f"{where}: has {n} full steps; expected a whole revolution of full steps, a multiple of 4 "
                         "(200 for a 1.8 deg stepper)")
    step = 360.0 / n
    index = np.round(cal.reference_deg / step).astype(int) % n
    off = np.abs(wrap180(cal.reference_deg - index * step))
    if off.max() > step / 100 or np.unique(index).size != n:
        raise InputError(f"{where}: the reference angles are not the {n} full steps of one revolution (multiples of "
                         f"{step:g} deg, each once); expected one reading per full step")
    order = np.argsort(index)
    reading = cal.encoder_deg[order]
    difference = reading - np.arange(n) * step
    centre = np.degrees(np.angle(np.mean(np.exp(1j * np.radians(difference)))))
    return reading, (centre + wrap180(difference - centre)) * ARCMIN_PER_DEG


@single_blas_thread
def steps(first, second=None, *, turn_deg=None, step_shift=None, max_order=16, name="", single_reads=False):
    """Recover the encoder error from one or two full-step calibrations.

    Parameters
    ----------
    first : Calibration
        One reading at each full step of one revolution.
    second : Calibration, optional
        The same after turning the magnet on the rotor (by any angle; 137.5 deg sees every low order).
    turn_deg : float, optional
        The turn of the magnet from ``first`` to ``second`` in degrees, if known (fixes the pairing of steps).
    step_shift : int, optional
        Full steps between the two calibrations' starts, if known (``second``'s step ``j`` is ``first``'s
        step ``j + step_shift``). Without it or ``turn_deg``: an offset of a whole number of steps
        (within 0.05 step) is taken for a repeat with the magnet not turned; otherwise the starts are taken
        to lie within a tooth (4 steps) and the phase of the 4-step pattern fixes them.
    max_order : int, default=16
        Highest order of the encoder's error recovered (below N/2). A magnetic encoder's error is of low
        order; each order more adds noise, and the encoder's error above it stays in the stepper's error.
    name : str, default=''
    single_reads : bool, default=False
        Each point of the two calibrations is one reading of the encoder, not the mean of several: the noise of a
        point the two calibrations' difference measures is then a new reading's, and is recorded
        (``reading_noise_arcmin``). Needs ``second``.

    Returns
    -------
    SelfCalibration
        ``reading_noise_arcmin`` is one reading's noise with ``single_reads``, else None: a full-step
        calibration's point is usually the firmware's mean of several reads (Mechaduino's routine averages 10,
        Klipper's ``ANGLE_CALIBRATE`` every sample over 50 ms), and its noise, measured from two calibrations
        as ``calibration_point_noise_arcmin`` in ``details``, is not one read's, nor that scaled by the square
        root of the reads (the mean is truncated to a whole code; docs/self-calibration.md). One calibration
        cannot measure it at all: its tooth errors are confounded with its noise.
        ``details`` holds the stepper's 4-step pattern, and with two calibrations the turn, the step shift,
        the stepper's error at each full step of ``first`` (``stepper_error_arcmin``, arcmin) and its
        standard uncertainty (``stepper_sigma_arcmin``), and the same error modelled as the 4-step
        pattern plus one error per tooth (``stepper_model_arcmin``, ``stepper_model_sigma_arcmin``).
        ``step_zero_deg`` (degrees) is the reference angle, in the calibration :meth:`SelfCalibration.write`
        writes, of ``first``'s reference 0 (its full step 0): a Mechaduino or Klipper export of a model fitted
        to that calibration takes it as ``--step-zero`` where ``first`` itself would take 0.
    """
    if turn_deg is not None:
        turn_deg = check_number(turn_deg, "turn_deg", "steps", note="an angle in degrees, or None")
    if step_shift is not None:
        step_shift = check_int(step_shift, "step_shift", "steps", note="full steps, or None")
    max_order = check_int(max_order, "max_order", "steps", low=1)
    check_type(first, Calibration, "first", "steps", "a Calibration")
    if second is not None:
        check_type(second, Calibration, "second", "steps", "a Calibration or None")
    reading_a, error_a = step_errors(first)
    n = reading_a.size
    if max_order >= n // 2:
        raise InputError(f"max_order {max_order} is too high for {n} full steps; expected below {n // 2}")
    orders = np.arange(1, max_order + 1)
    if second is None:
        if single_reads:
            raise InputError("single_reads needs a second calibration: one calibration's tooth errors are "
                             "confounded with its noise; give the calibration after turning the magnet (or a repeat)")
        result = _one(reading_a, error_a, orders, name or first.name)
        return replace(result, reading_sign=first.reading_sign,
                       details={**_with_step_zero(result, reading_a), "reading_noise": NOT_MEASURED})
    if second.reading_sign != first.reading_sign:
        raise InputError("one calibration was read with reverse (--reverse) and the other without; expected both "
                         "read the same way (the encoder counts the same way in both)")
    reading_b, error_b = step_errors(second)
    if reading_b.size != n:
        raise InputError(f"the calibrations have {n} and {reading_b.size} full steps; expected the same motor")
    result = _two(reading_a, error_a, reading_b, error_b, orders, turn_deg, step_shift, name or first.name)
    details = _with_step_zero(result, reading_a)
    noise = details["calibration_point_noise_arcmin"] if single_reads else None
    if noise is None:
        details["reading_noise"] = NOT_MEASURED
    return replace(result, reading_sign=first.reading_sign, details=details, reading_noise_arcmin=noise)


def _with_step_zero(result, reading_deg):
    """``result.details`` with ``step_zero_deg``: where the first calibration's reference 0 lies in the one written.

    The calibration written has ``reference = reading - error/60`` with an error of zero mean: its zero is the
    encoder's, not the stepper's. A firmware table tied to the stepper's phase (Mechaduino, Klipper) needs the
    stepper's full step 0 in that frame: the circular mean over the steps of ``reading_k - error_k/60 - k*step``.
    """
    n = reading_deg.size
    frame = reading_deg - result.error_arcmin(reading_deg) / ARCMIN_PER_DEG - np.arange(n) * (360.0 / n)
    step_zero = np.degrees(np.angle(np.mean(np.exp(1j * np.radians(frame))))) % 360.0
    return {**result.details, "step_zero_deg": float(step_zero)}


def _pattern(values):
    """Mean of each of the 4 phases of the full steps, about the overall mean."""
    pattern = np.array([values[j::4].mean() for j in range(4)])
    return pattern - pattern.mean()


def _fit(reading, values, orders):
    """Least-squares Fourier series (with a constant) of ``values`` at ``reading``: coefficients, covariance and
    residual."""
    x = np.hstack([np.ones((reading.size, 1)), design_matrix(reading, orders)])
    coefficients = np.linalg.lstsq(x, values, rcond=None)[0]
    residual = values - x @ coefficients
    variance = residual @ residual / max(reading.size - x.shape[1], 1)
    return coefficients[1:], variance * np.linalg.inv(x.T @ x)[1:, 1:], residual


def _one(reading, error, orders, name):
    n = reading.size
    pattern = _pattern(error)
    coefficients, covariance, _ = _fit(reading, error - np.tile(pattern, n // 4), orders)
    removed = tuple(int(k) for k in orders if k % (n // 4) == 0)
    series = HarmonicSeries.from_vector(orders, coefficients, covariance).without(removed)
    confounded = (f"one calibration: the stepper's error at each tooth is confounded with the encoder error at every "
                  f"order; its 4-step pattern (orders {n // 4}, {n // 2}, ...) was removed"
                  + (", with the encoder's error at those orders" if removed else "")
                  + "; turn the magnet on the rotor and calibrate again to separate the two")
    details = {"stepper_pattern_arcmin": ", ".join(f"{v:.3g}" for v in pattern),
               "stepper_pattern_rms_arcmin": float(np.sqrt(np.mean(pattern ** 2)))}
    return SelfCalibration("steps", series, removed, confounded, details, name)


def _two(reading_a, error_a, reading_b, error_b, orders, turn_deg, step_shift, name):
    n = reading_a.size
    step = 360.0 / n
    offset = np.degrees(np.angle(np.mean(np.exp(1j * np.radians(reading_b - reading_a)))))
    whole = offset / step
    if step_shift is not None:
        shift, how = int(step_shift) % n, "given"
    elif turn_deg is not None:
        shift, how = int(round((offset - turn_deg) / step)) % n, "from the given turn"
    elif abs(whole - round(whole)) < WHOLE_STEP_TOLERANCE:
        shift, how = int(round(whole)) % n, "whole"
    else:
        shift, how = _pattern_shift(error_a, error_b), "pattern"
    best = _pair(reading_a, reading_b, shift, orders)
    turn, visible = best["turn_deg"], best["visible"]
    b_index = (np.arange(n) - shift) % n  # second's step paired with each of first's steps
    identified = np.zeros(2 * orders.size)
    identified_cov = np.zeros((2 * orders.size, 2 * orders.size))
    columns = np.concatenate([visible, orders.size + visible])
    identified[columns] = best["coefficients"]
    identified_cov[np.ix_(columns, columns)] = best["covariance"]
    known = HarmonicSeries.from_vector(orders, identified, identified_cov)
    # the stepper's error: the mean of both calibrations less the identified encoder error
    rest_a = error_a - known.evaluate(reading_a)
    rest_b = error_b[b_index] - known.evaluate(reading_b[b_index])
    rest = 0.5 * (rest_a + (rest_b - np.mean(rest_b - rest_a)))
    hidden = np.setdiff1d(np.arange(orders.size), visible)
    vector, covariance = identified, identified_cov
    if hidden.size:  # orders the turn cannot see: taken as measured (stepper error not removed there)
        pattern = _pattern(rest)
        coefficients, cov, _ = _fit(reading_a, rest - np.tile(pattern, n // 4), orders[hidden])
        hidden_columns = np.concatenate([hidden, orders.size + hidden])
        vector = vector.copy()
        vector[hidden_columns] = coefficients
        covariance = covariance.copy()
        covariance[np.ix_(hidden_columns, hidden_columns)] = cov
        rest = rest - HarmonicSeries.from_vector(orders[hidden], coefficients, cov).evaluate(reading_a)
    series = HarmonicSeries.from_vector(orders, vector, covariance)
    stepper = rest - rest.mean()
    # the noise of one calibration's point (arcmin): the difference holds two, the stepper's error cancelled in it
    noise = np.sqrt(best["variance"] / 2)
    stepper_sigma = np.sqrt(noise ** 2 / 2 + series.sigma(reading_a) ** 2)
    pattern = _pattern(stepper)
    tooth = np.array([(stepper - np.tile(pattern, n // 4))[4 * t:4 * t + 4].mean() for t in range(n // 4)])
    model = np.tile(pattern, n // 4) + np.repeat(tooth, 4)
    model_sigma = np.sqrt((0.25 + 4.0 / n) * noise ** 2 / 2 + series.sigma(reading_a) ** 2)
    details = {"turn_deg": float(turn), "step_shift": int(shift), "repeat": not visible.size,
               "difference_residual_rms_arcmin": float(np.sqrt(best["variance"])),
               "calibration_point_noise_arcmin": float(noise),
               "stepper_error_rms_arcmin": float(np.sqrt(np.mean(stepper ** 2))),
               "stepper_pattern_arcmin": ", ".join(f"{v:.3g}" for v in pattern),
               "stepper_tooth_rms_arcmin": float(np.sqrt(np.mean(tooth ** 2))),
               "stepper_error_arcmin": stepper, "stepper_sigma_arcmin": stepper_sigma,
               "stepper_model_arcmin": model, "stepper_model_sigma_arcmin": model_sigma}
    hidden_orders = [int(k) for k in orders[hidden]]
    if not visible.size:
        why = (f"the second reads {whole:.3f} full steps from the first, a whole number: it began {shift} steps "
               "further and " if how == "whole" else "")
        confounded = (f"{why}the magnet was not turned on the rotor (turn {turn:.3g} deg after pairing the steps "
                      f"{shift} apart): the two calibrations are repeats and nothing was separated; their "
                      f"difference ({np.sqrt(best['variance']):.3g} arcmin RMS) measures their repeatability; if the "
                      "magnet was turned by a whole number of steps, say by how much with --turn")
    elif hidden_orders:
        confounded = (f"a turn of {turn:.4g} deg cannot see orders {', '.join(map(str, hidden_orders))} (visibility "
                      f"|2 sin(n a/2)| < {MIN_VISIBILITY:g}); they are taken from the calibrations as measured, "
                      "with the stepper's error at those orders")
    else:
        confounded = f"nothing up to order {orders[-1]}; the encoder's error above it stays in the stepper's error"
    if how == "pattern" and visible.size:
        confounded += (f"; the steps were paired {shift} apart as the 4-step patterns agree (the calibrations are "
                       "taken to begin within a tooth of each other): if not, the tooth errors do not cancel; give "
                       "--step-shift or --turn")
        if abs(whole - round(whole)) < NEAR_WHOLE_STEP:
            confounded += (f"; the second reads {whole:.3f} full steps from the first, near a whole number: if the "
                           f"magnet was not turned these are repeats (--step-shift {int(round(whole)) % n})")
    return SelfCalibration("steps", series, (), confounded, details, name)


def _pattern_shift(error_a, error_b):
    """Steps (0-3) between the starts of two calibrations, from the phase of their 4-step patterns."""
    pattern_a, pattern_b = _pattern(error_a), _pattern(error_b)
    # the second's step j is the first's step j + shift: its pattern is the first's rolled back by shift
    return int(np.argmax([pattern_a @ np.roll(pattern_b, q) for q in range(4)]))


def _pair(reading_a, reading_b, shift, orders):
    """The shift method's fit with the second calibration's step ``j`` at the first's step ``j + shift``."""
    n = reading_a.size
    paired = reading_b[(np.arange(n) - shift) % n]
    turn = np.degrees(np.angle(np.mean(np.exp(1j * np.radians(paired - reading_a)))))
    visibility = np.abs(2 * np.sin(np.radians(orders * turn) / 2))
    visible = np.flatnonzero(visibility >= MIN_VISIBILITY)
    difference = wrap180(paired - reading_a - turn) * ARCMIN_PER_DEG
    columns = orders[visible]
    x = np.hstack([np.ones((n, 1)), design_matrix(paired, columns) - design_matrix(reading_a, columns)])
    coefficients = np.linalg.lstsq(x, difference, rcond=None)[0]
    residual = difference - x @ coefficients
    dof = max(n - x.shape[1], 1)
    variance = residual @ residual / dof
    covariance = variance * np.linalg.pinv(x.T @ x)
    return {"shift": shift, "turn_deg": turn, "visible": visible, "coefficients": coefficients[1:],
            "covariance": covariance[1:, 1:], "variance": variance}

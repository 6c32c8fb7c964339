"""Inertial spin: the rotor's inertia as the reference.

A motor spinning at a nearly constant drive turns at a nearly constant speed: over many revolutions
its angle is a smooth function of time. The encoder's reading minus that smooth phase is the
encoder's error plus the rotor's speed ripple; one least-squares fit of a spline in time (the
smooth phase) and a Fourier series in the reading averages them over revolutions as a function of
the angle. The ripple comes from torque ripple (cogging, the drive, an
unbalanced load): its effect on the angle falls as 1/speed^2 while the encoder error does not, so
spins at two or more speeds separate them; with one speed, the orders at which the motor makes
torque ripple are left out. See docs/self-calibration.md.
"""

from dataclasses import dataclass

import numpy as np

from .._core.angles import ARCMIN_PER_DEG
from .._core.errors import InputError
from .._core.parameters import check_int, check_number
from .._core.limits import check_size
from ._series import HarmonicSeries, design_matrix
from .result import SelfCalibration
from .._core.threads import single_blas_thread

__all__ = ["SpinLog", "spin", "motor_ripple_orders"]

#: Fewest revolutions of one run: the smooth phase needs several to tell a turn's pattern from drift.
MIN_REVOLUTIONS = 4.0
#: Smallest ratio of the fastest to the slowest speed for separating speed ripple from encoder error.
MIN_SPEED_RATIO = 1.2
#: Chi-square per degree of freedom of three or more speeds about the 1/speed^2 law above which it is said not to hold.
MAX_LAW_CHI2 = 3.0
#: Samples per block when the normal equations are accumulated (bounds the memory used).
CHUNK = 20000
#: Passes that predict the speed ripple's second-order term from its first and fit the 1/speed^2 law again.
SECOND_ORDER_PASSES = 2
#: Arc-minutes per radian.
ARCMIN_PER_RAD = 10800.0 / np.pi
#: Groups of consecutive samples of a run, left out one at a time to measure the uncertainty (jackknife).
GROUPS = 10


@dataclass(frozen=True)
class SpinLog:
    """Encoder readings of one spin at a nearly constant drive.

    Parameters
    ----------
    time_s : array-like of shape (n,)
        Sample times in seconds, increasing.
    encoder_deg : array-like of shape (n,)
        Readings in degrees (any turn; they are unwrapped).
    label : str, default=''
        Name of the run, for messages.
    """

    time_s: np.ndarray
    encoder_deg: np.ndarray
    label: str = ""


def motor_ripple_orders(max_order, pole_pairs=None, slots=None):
    """Orders up to ``max_order`` at which a motor makes torque ripple: multiples of the pole pairs and slots.

    Cogging has lcm(slots, 2 pole pairs) periods per turn (a multiple of the pole pairs); the drive's
    torque ripple is periodic in the electrical angle (multiples of the pole pairs); unequal slots add
    multiples of the slot count.
    """
    orders = set()
    for base in (pole_pairs, slots):
        if base:
            orders.update(range(base, max_order + 1, base))
    return tuple(sorted(orders))


@single_blas_thread
def spin(runs, *, pole_pairs=None, slots=None, max_order=32, ripple_orders=(), knot_revolutions=4.0, name=""):
    """Recover the encoder error from spins at one or more (nearly) constant speeds.

    Parameters
    ----------
    runs : sequence of SpinLog
        One log per speed (at least 4 revolutions each, any direction).
    pole_pairs : int, optional
        Pole pairs of the motor; with one speed, multiples of it are left out (torque ripple).
    slots : int, optional
        Slots of the motor; with one speed, multiples of it are left out too.
    max_order : int, default=32
        Highest harmonic order of the encoder error to recover.
    ripple_orders : sequence of int, default=()
        More orders to leave out with one speed (e.g. 1 for an unbalanced load on a horizontal shaft).
    knot_revolutions : float, default=4
        Revolutions between the knots of the cubic spline that models the smooth phase in time.
    name : str, default=''

    Returns
    -------
    SelfCalibration
        ``details`` holds the speeds (rev/s), the RMS speed ripple found at each (arcmin, with two or more
        speeds), the revolutions used, and with three or more speeds the chi-square per degree of freedom
        of the runs about the 1/speed^2 law (``ripple_law_chi2_per_dof``; over 3 it is said not to hold).
        With two or more speeds the speed ripple's second-order term (1/speed^4) is predicted from the ripple
        fitted and taken off, its dependence on the motor's dynamics in the stated sigma (:func:`second_order_ripple`).

    Raises
    ------
    InputError
        For a run that is too short, goes back and forth, samples too coarsely for ``max_order``, or
        speeds too close together to separate.
    """
    runs = list(runs)
    if not runs:
        raise InputError("spin needs at least one log of (time, encoder reading)")
    max_order = check_int(max_order, "max_order", "spin", low=1)
    pole_pairs = None if pole_pairs is None else check_size("pole_pairs", pole_pairs, "spin")
    slots = None if slots is None else check_size("slots", slots, "spin")
    knot_revolutions = check_number(knot_revolutions, "knot_revolutions", "spin", low=0.0, low_open=True,
                                    note="revolutions")
    orders = np.arange(1, max_order + 1)
    estimates = [_run_coefficients(run, orders, knot_revolutions) for run in runs]
    speeds = np.array([e["speed_rev_s"] for e in estimates])
    details = {"speeds_rev_s": ", ".join(f"{s:.4g}" for s in speeds),
               "revolutions": ", ".join(f"{e['revolutions']:.1f}" for e in estimates)}
    if len(runs) == 1:
        vector, covariance = estimates[0]["vector"], estimates[0]["covariance"]
        removed = tuple(sorted(set(motor_ripple_orders(max_order, pole_pairs, slots))
                               | {int(k) for k in ripple_orders if 1 <= int(k) <= max_order}))
        everything = HarmonicSeries.from_vector(orders, vector, covariance)
        series = everything.without(removed)
        if removed and series.orders.size:
            # The speed ripple is periodic in the rotor's angle, the encoder's error in its reading: fitted in the
            # reading, the ripple's large orders leaked sidebands (k * ripple * error) into the orders kept, twice
            # the stated sigma. A second pass fits the orders left out in the smooth phase, the reading less all
            # the first pass fitted (the rotor's angle to first order in the ripple; less only the orders kept,
            # an encoder error left out with them, 4.8 arcmin at order 7, still left 3 times sigma).
            second = _run_coefficients(runs[0], series.orders, knot_revolutions,
                                       rotor_orders=np.array(removed), rotor_error_arcmin=everything.evaluate)
            series = HarmonicSeries.from_vector(series.orders, second["vector"], second["covariance"])
        confounded = _one_speed_text(pole_pairs, slots, removed, max_order)
    else:
        series, ripple, law = _separate(estimates, orders, speeds)
        removed = ()
        for speed, rms in zip(speeds, ripple):
            details[f"speed_ripple_rms_arcmin_at_{speed:.4g}_rev_s"] = float(rms)
        confounded = (f"nothing periodic in the angle, as long as the speed ripple scales as 1/speed^2 (a "
                      f"current- or torque-controlled drive, inertia-dominated); orders above {max_order} are "
                      "not estimated")
        if law is not None:
            details["ripple_law_chi2_per_dof"] = law
            if law > MAX_LAW_CHI2:
                confounded += (f"; the {speeds.size} speeds do not follow the 1/speed^2 law (chi-square per degree "
                               f"of freedom {law:.3g}): a damped, voltage-driven motor? part of the speed ripple "
                               "stays in the result")
    return SelfCalibration("spin", series, removed, confounded, details, name,
                           reading_noise_arcmin=reading_noise_arcmin(estimates))


def reading_noise_arcmin(estimates):
    """One reading's noise (arcmin RMS) from the runs' logs: the second differences of what each run's fit leaves.

    Each run's fit (a smooth phase in time plus orders 1 to ``max_order`` in the reading) leaves the reading noise
    and the rounding to the encoder's codes, which a new reading has too, but also the speed ripple the spline and
    those orders do not follow (cogging above ``max_order``: at 1 rev/s on the simulated motor it made the RMS
    left 2.36 arcmin for 2.04 of noise), which a reading at rest has not. Over consecutive samples that ripple is
    smooth and the noise is not: a white noise of variance ``σ²`` gives second differences of variance ``6 σ²``,
    so ``σ² = mean(Δ²r) / 6`` (2.01-2.05 arcmin on the same runs). What is smooth at the sample rate is missed:
    noise filtered by the encoder over several samples, and the encoder's own error above ``max_order``. None
    without samples.
    """
    square_sum = sum(e["curvature_square_sum_arcmin2"] for e in estimates)
    count = sum(e["curvature_count"] for e in estimates)
    return float(np.sqrt(square_sum / (6.0 * count))) if count > 0 else None


def _one_speed_text(pole_pairs, slots, removed, max_order):
    if removed:
        why = ("multiples of the pole pairs" + (" and of the slots" if slots else "")) if (pole_pairs or slots) \
            else "the orders given"
        text = (f"with one speed the speed ripple from torque ripple is confounded with the encoder error; the "
                f"{why} were left out; an unbalanced load on a horizontal shaft would add order 1, which is kept; "
                "spin at a second speed to separate everything")
    else:
        text = ("with one speed and no pole-pair count every order may hold speed ripple from torque ripple; "
                "nothing was left out; give --pole-pairs or spin at a second speed")
    return text + f"; orders above {max_order} are not estimated"


def _run_coefficients(run, orders, knot_revolutions, rotor_orders=(), rotor_error_arcmin=None):
    """Fourier coefficients (arcmin) of reading minus smooth phase for one run, with jackknife covariance.

    ``rotor_orders`` are fitted too, as functions of the rotor's angle (the reading less
    ``rotor_error_arcmin(reading)``, arcmin), and left out of the coefficients returned.
    """
    time = np.asarray(run.time_s, dtype=float).reshape(-1)
    reading = np.asarray(run.encoder_deg, dtype=float).reshape(-1)
    where = f"spin log {run.label}".strip()
    if time.size != reading.size:
        raise InputError(f"{where}: {time.size} times but {reading.size} readings; expected one reading per time")
    if time.size < 64:
        raise InputError(f"{where}: has {time.size} samples; expected at least 64")
    if not (np.all(np.isfinite(time)) and np.all(np.isfinite(reading))):
        raise InputError(f"{where}: times and readings must be finite numbers")
    if np.any(np.diff(time) <= 0):
        row = int(np.flatnonzero(np.diff(time) <= 0)[0]) + 2
        raise InputError(f"{where}: time does not increase at sample {row}; expected increasing sample times")
    phase = np.unwrap(reading, period=360.0)
    step = np.diff(phase)
    if np.median(np.abs(step)) > 90.0:
        raise InputError(f"{where}: the encoder moves {np.median(np.abs(step)):.0f} deg between samples; expected "
                         "under 90 deg (sample faster) so that the turns can be counted")
    travel = phase[-1] - phase[0]
    revolutions = abs(travel) / 360.0
    if revolutions < MIN_REVOLUTIONS:
        raise InputError(f"{where}: covers {revolutions:.2f} revolutions; expected at least {MIN_REVOLUTIONS:g} "
                         "at a constant drive")
    backwards = np.mean(np.sign(step) == -np.sign(travel))
    if backwards > 0.25:
        raise InputError(f"{where}: the encoder goes back in {100 * backwards:.0f} % of the samples; expected a "
                         "spin in one direction")
    angles = np.sort(np.mod(phase, 360.0))
    gap = float(np.max(np.diff(np.concatenate([angles, angles[:1] + 360.0]))))
    if gap > 180.0 / orders[-1]:
        raise InputError(f"{where}: the readings leave a gap of {gap:.3g} deg in the turn; expected samples all "
                         f"around it, no gap over {180.0 / orders[-1]:.3g} deg for order {orders[-1]} (log longer, "
                         "faster, or at a sample rate not locked to the speed; or lower max_order)")
    # one least-squares fit: a cubic spline in time (the smooth phase) plus a Fourier series in the reading
    n_intervals = max(1, int(revolutions // knot_revolutions))
    inner = np.linspace(time[0], time[-1], n_intervals + 1)[1:-1]
    knots = np.concatenate([[time[0]] * 4, inner, [time[-1]] * 4])
    groups = min(GROUPS, max(2, int(revolutions)))
    bounds = np.linspace(0, time.size, groups + 1).astype(int)
    n_smooth = knots.size - 4
    rotor_orders = np.asarray(rotor_orders, dtype=int)
    size = n_smooth + 2 * orders.size + 2 * rotor_orders.size
    normal = np.zeros((groups, size, size))
    right = np.zeros((groups, size))
    wanted = slice(n_smooth, n_smooth + 2 * orders.size)
    origin = phase[0]
    for g in range(groups):
        for start in range(bounds[g], bounds[g + 1], CHUNK):
            stop = min(start + CHUNK, bounds[g + 1])
            smooth = cubic_bspline_design(time[start:stop], knots)
            x = np.hstack([smooth, design_matrix(phase[start:stop], orders)])
            if rotor_orders.size:
                rotor = phase[start:stop] - rotor_error_arcmin(phase[start:stop]) / ARCMIN_PER_DEG
                x = np.hstack([x, design_matrix(rotor, rotor_orders)])
            normal[g] += x.T @ x
            right[g] += x.T @ (phase[start:stop] - origin)
    total_normal, total_right = normal.sum(axis=0), right.sum(axis=0)
    solution = np.linalg.solve(total_normal, total_right)
    full = solution[wanted]
    curvature_square_sum, curvature_count = 0.0, 0
    if not rotor_orders.size:  # the first pass fits every order: what it leaves is the readings' own scatter
        for start, stop in _noise_blocks(time.size):
            x = np.hstack([cubic_bspline_design(time[start:stop], knots), design_matrix(phase[start:stop], orders)])
            residual = phase[start:stop] - origin - x @ solution
            curvature_square_sum += float(np.sum(np.diff(residual, 2) ** 2))
            curvature_count += max(0, residual.size - 2)
    # A spline piece whose whole support lies in the group left out has no data in its replicate: the first and
    # last pieces span one knot interval, and a group spans more than one once a run is over 10 knot intervals
    # long (40 revolutions at the default spacing), which made the replicate's matrix singular. Its coefficient
    # is then undetermined and has no bearing on the Fourier part: the replicate leaves it out.
    has_data = np.diagonal(normal, axis1=1, axis2=2) > 0  # exact: sums of squares, zero only without data
    replicates = []
    for g in range(groups):
        kept = np.flatnonzero(np.delete(has_data, g, axis=0).any(axis=0))
        matrix = (total_normal - normal[g])[np.ix_(kept, kept)]
        solution = np.linalg.solve(matrix, (total_right - right[g])[kept])
        replicates.append(solution[(kept >= wanted.start) & (kept < wanted.stop)])
    replicates = np.stack(replicates) * ARCMIN_PER_DEG
    deviation = replicates - replicates.mean(axis=0)
    covariance = (groups - 1) / groups * deviation.T @ deviation
    speed = travel / 360.0 / (time[-1] - time[0])
    return {"vector": full * ARCMIN_PER_DEG, "covariance": covariance, "speed_rev_s": float(speed),
            "revolutions": float(revolutions),
            "curvature_square_sum_arcmin2": curvature_square_sum * ARCMIN_PER_DEG**2,
            "curvature_count": curvature_count}


#: Samples of a run whose residual gives the reading noise (:func:`reading_noise_arcmin`), in :data:`NOISE_BLOCKS`
#: blocks spread over the run: its second differences' mean square to about 1 % (a pass over every sample made
#: ``encal selfcal spin`` of 2e5 samples 2.2x a NumPy script of its least squares, 1.7x without it).
NOISE_SAMPLES, NOISE_BLOCKS = 20000, 10


def _noise_blocks(samples):
    """``(start, stop)`` of the blocks of a run of ``samples`` whose residual measures the reading noise."""
    if samples <= NOISE_SAMPLES:
        return [(0, samples)]
    size = NOISE_SAMPLES // NOISE_BLOCKS
    return [(int(start), int(start) + size) for start in np.linspace(0, samples - size, NOISE_BLOCKS)]


def cubic_bspline_design(x, knots):
    """The cubic B-spline basis on clamped ``knots`` at ``x``, as a dense matrix of shape (x.size, knots.size - 4).

    The Cox-de Boor recursion over the four functions that are non-zero in each knot interval, in NumPy: the
    same matrix as ``scipy.interpolate.BSpline.design_matrix(x, knots, 3).toarray()`` to rounding, without
    importing scipy.interpolate (half the time of ``encal selfcal spin`` on 2e5 samples). ``x`` lies within
    ``[knots[3], knots[-4]]``, the last point belonging to the last interval.
    """
    x = np.asarray(x, dtype=float).reshape(-1)
    knots = np.asarray(knots, dtype=float)
    n_basis = knots.size - 4
    interval = np.clip(np.searchsorted(knots, x, side="right") - 1, 3, n_basis - 1)
    left = np.empty((4, x.size))
    right = np.empty((4, x.size))
    values = np.zeros((4, x.size))
    values[0] = 1.0
    for j in range(1, 4):
        left[j] = x - knots[interval + 1 - j]
        right[j] = knots[interval + j] - x
        saved = np.zeros(x.size)
        for r in range(j):
            term = values[r] / (right[r + 1] + left[j - r])
            values[r] = saved + right[r + 1] * term
            saved = left[j - r] * term
        values[j] = saved
    design = np.zeros((x.size, n_basis))
    rows = np.arange(x.size)
    for r in range(4):
        design[rows, interval - 3 + r] = values[r]
    return design


def _separate(estimates, orders, speeds):
    """Encoder error and speed ripple from runs at several speeds: ``c_i = e + g x_i + h(g) x_i^2`` for every order.

    ``x_i`` is (slowest speed / speed_i)^2 and ``g`` the speed ripple at the slowest speed (first order, 1/speed^2);
    ``h(g)`` is its second-order term (1/speed^4), predicted from ``g`` by :func:`second_order_ripple` and taken
    off every run before the 1/speed^2 law is fitted again (twice, ``g`` being refined each time).
    """
    magnitude = np.abs(speeds)
    if magnitude.max() / magnitude.min() < MIN_SPEED_RATIO:
        raise InputError(f"the spins' speeds ({', '.join(f'{s:.4g}' for s in speeds)} rev/s) differ by less than a "
                         f"factor {MIN_SPEED_RATIO:g}; expected speeds far enough apart to separate speed ripple "
                         "(which falls as 1/speed^2) from the encoder error, e.g. a factor 2")
    scale = magnitude.min() ** 2
    slowness = scale / magnitude ** 2
    design = np.column_stack([np.ones(speeds.size), slowness])
    variance = np.array([max(np.trace(e["covariance"]) / e["covariance"].shape[0], 1e-30) for e in estimates])
    weights = 1.0 / variance
    normal = design.T @ (weights[:, None] * design)
    mixing = np.linalg.solve(normal, design.T * weights)  # (2, runs)
    measured = np.stack([e["vector"] for e in estimates])
    vectors = measured
    for _ in range(SECOND_ORDER_PASSES):
        ripple = mixing[1] @ vectors
        second, dynamic_spread = second_order_ripple(orders, ripple)
        vectors = measured - slowness[:, None] ** 2 * second[None, :]
    error = mixing[0] @ vectors
    ripple = mixing[1] @ vectors
    covariance = sum(m ** 2 * e["covariance"] for m, e in zip(mixing[0], estimates))
    # the prediction's dynamics are not known (see second_order_ripple): the spread is a standard uncertainty
    covariance = covariance + np.diag((float(mixing[0] @ slowness ** 2) * dynamic_spread) ** 2)
    ripple_rms = [np.sqrt(np.sum(ripple ** 2) / 2) * scale / s ** 2 for s in magnitude]
    law = None
    if speeds.size > 2:  # is the ripple 1/speed^2? chi-square of the runs about the fit, per degree of freedom
        residual = vectors - error[None, :] - design[:, 1:] * ripple[None, :]
        variances = np.stack([np.maximum(np.diag(e["covariance"]), 1e-30) for e in estimates])
        law = float(np.sum(residual ** 2 / variances) / ((speeds.size - 2) * vectors.shape[1]))
    return HarmonicSeries.from_vector(orders, error, covariance), ripple_rms, law


def second_order_ripple(orders, ripple_arcmin):
    """The speed ripple's second-order term (1/speed^4) predicted from its first-order term (1/speed^2).

    The fit sees the ripple as a function of the angle ``theta`` (radians), not of time. For a rotor whose
    angle is ``w t + r(w t)`` with ``r`` small and periodic (a "kinematic" ripple, sinusoidal in time), what it
    sees is ``r(theta) - r(theta) r'(theta)`` to second order (``r'`` = dr/dtheta): a ripple ``A cos(k theta)``
    (A in radians) adds ``(k A^2 / 2) sin(2 k theta)``, and two orders make terms at their sum and difference.
    A rotor driven by a torque ripple periodic in its angle (``J theta'' = T(theta)``, no damping) instead sees
    ``r - 3/2 integral(r'^2 - mean(r'^2))`` (from its energy, ``theta'^2 / 2 + V(theta) / J`` constant):
    ``3 k A^2 / 8`` for one order, and at the difference of two orders a term of other sign and several times
    the size. The second is returned: it is the physics of a motor spun at a constant current (its torque ripple
    periodic in the angle), which docs/self-calibration.md asks for; which the motor follows is not known for
    certain, so the difference of the two is returned as the prediction's standard uncertainty.

    Parameters
    ----------
    orders : ndarray of shape (m,) of int
        Harmonic orders of ``ripple_arcmin``, and of the coefficients returned.
    ripple_arcmin : ndarray of shape (2 m,)
        First-order ripple ``(cos..., sin...)`` in arc-minutes, at the speed the term is wanted for.

    Returns
    -------
    second : ndarray of shape (2 m,)
        The torque-driven rotor's second-order term's coefficients at ``orders`` in arc-minutes (terms at higher
        orders are dropped).
    spread : ndarray of shape (2 m,)
        Absolute difference of the two predictions' coefficients, arc-minutes.
    """
    orders = np.asarray(orders, dtype=int)
    points = 8 * int(orders.max()) + 8  # products reach twice the highest order: no aliasing onto ``orders``
    theta = np.arange(points) * (2 * np.pi / points)
    basis = design_matrix(np.degrees(theta), orders)
    m = orders.size
    cos_part, sin_part = ripple_arcmin[:m], ripple_arcmin[m:]
    value = basis @ ripple_arcmin
    slope = basis @ np.concatenate([orders * sin_part, -orders * cos_part]) / ARCMIN_PER_RAD  # dr/dtheta
    kinematic = -value * slope
    spectrum = np.fft.rfft(slope ** 2)
    spectrum[0] = 0.0
    spectrum[1:] /= 1j * np.arange(1, spectrum.size)
    inertial = -1.5 * np.fft.irfft(spectrum, n=points) * ARCMIN_PER_RAD

    def coefficients(values):
        return basis.T @ values * (2.0 / points)

    kinematic, inertial = coefficients(kinematic), coefficients(inertial)
    return inertial, np.abs(kinematic - inertial)

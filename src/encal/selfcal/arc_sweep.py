"""Open-loop sweep over a limited range: self-calibration of a joint that cannot turn a full revolution.

The sweep of :mod:`encal.selfcal.sweep` over an arc, back and forth (an arm or a gimbal that moteus or ODrive can
drive open loop but not spin). The reference is again the commanded electrical angle over the pole pairs; over
an arc the encoder's error is no periodic function, so it is fitted as a penalised cubic spline over the arc
(the ``arc`` kind's family, its smoothing chosen by the restricted marginal likelihood), together with

- the motor's own error, periodic in the electrical angle (cogging, the field's distortion): harmonics of
  ``p`` times the reference, which also take the encoder's error at those periods (left unknown, as over a
  full turn);
- the direction-dependent lag (the friction's angle): ``travel * g(angle)`` with ``g`` a cubic polynomial over
  the arc; its mean is the lag and its variation over the arc says whether the lag changes with angle (a
  load, friction that varies), which is tested and stated.

A load that pulls the rotor the same way in both directions (gravity on an arm) is not direction-dependent:
it is indistinguishable from the encoder's error and stays in it (docs/in-place.md).
"""

from dataclasses import dataclass, field

import numpy as np

from .._core.angles import ARCMIN_PER_DEG
from .._core.arcs import arc_of, describe_range, span_of
from .._core.errors import InputError
from .._core.parameters import check_int
from .._core.limits import check_size
from .sweep import DEFAULT_SKIP, NOT_MEASURED, check_sweep_travel, repeat_noise_arcmin, sweep_samples

__all__ = ["ArcSweepCalibration", "arc_sweep"]

#: Harmonics of the electrical angle fitted as the motor's own error (cogging and field distortion).
MOTOR_HARMONICS = 24  # as the full-turn sweep: multiples of p up to 24 p
#: Largest gap (degrees) inside the arc a sweep may leave.
MAX_GAP_DEG = 30.0
#: Degree of the lag's polynomial over the arc.
LAG_DEGREE = 3


@dataclass(frozen=True)
class ArcSweepCalibration:
    """An encoder's error over an arc, recovered from a back-and-forth open-loop sweep.

    Attributes
    ----------
    range_deg : list of float
        ``[start, end]`` of the readings, degrees (forward from start to end).
    grid_deg, error_arcmin, sigma_arcmin : ndarray
        The recovered error (zero mean over the arc: the zero is arbitrary) and its standard uncertainty on a
        grid of readings over the arc.
    details : dict
        The lag (arcmin and electrical degrees), its variation over the arc and whether it is significant.
    confounded : str
        What the method cannot separate.
    name : str
    reading_noise_arcmin : float or None
        One reading's noise about the recovered error, arc-minutes RMS, measured from the readings the sweep
        repeats at one commanded angle in one direction (:func:`~encal.selfcal.sweep.repeat_noise_arcmin`); None
        when it commands no angle twice in one direction. Written as ``# reading_noise_arcmin: X``; not part of
        ``sigma_arcmin``.
    """

    range_deg: list
    grid_deg: np.ndarray
    error_arcmin: np.ndarray
    sigma_arcmin: np.ndarray
    details: dict = field(default_factory=dict)
    confounded: str = ""
    name: str = ""
    method: str = "sweep over an arc"
    reading_noise_arcmin: float | None = None

    def write(self, path, points=None, resolution_bits=None):
        """Write the calibration CSV over the arc (``error_arcmin``, ``sigma_arcmin`` columns), atomically.

        ``encal fit`` of it sees one arc and fits the arc kind. ``points`` is ignored (the grid is the arc's).
        """
        from ..data.calibration import READING_NOISE_KEY, Calibration, write_calibration

        reference = np.mod(self.grid_deg - self.error_arcmin / ARCMIN_PER_DEG, 360.0)
        cal = Calibration(reference, np.mod(self.grid_deg, 360.0), name=self.name, resolution_bits=resolution_bits)
        comments = [f"encal selfcal sweep over an arc ({describe_range(self.range_deg)}): encoder error recovered "
                    "without a precision reference",
                    "error_arcmin = encoder - reference; sigma_arcmin = its standard uncertainty (1 sigma)",
                    f"not separable: {self.confounded}"]
        if self.reading_noise_arcmin is not None:
            # read back by read_calibration into the metadata: encal fit takes it as a new reading's noise
            comments.append(f"{READING_NOISE_KEY}: {self.reading_noise_arcmin:.6g}")
        write_calibration(path, cal, comments=comments, extra_columns={
            "error_arcmin": [float(v) for v in self.error_arcmin],
            "sigma_arcmin": [float(v) for v in self.sigma_arcmin]})

    def summary(self):
        d = self.details
        error_rms = np.sqrt(np.mean(self.error_arcmin ** 2))
        sigma_rms = np.sqrt(np.mean(self.sigma_arcmin ** 2))
        lines = [f"{self.name or 'encoder'}: self-calibration by an open-loop sweep over "
                 f"{describe_range(self.range_deg)}; recovered error RMS {error_rms:.4g} arcmin, peak-to-peak "
                 f"{np.ptp(self.error_arcmin):.4g} arcmin, uncertainty RMS {sigma_rms:.3g} arcmin (1 sigma)",
                 f"lag {d['lag_arcmin']:.4g} arcmin ({d['lag_deg_e']:.4g} electrical deg), separated by the two "
                 "directions",
                 d["lag_statement"],
                 (f"reading noise (one reading about the profile, measured from the repeated readings): "
                  f"{self.reading_noise_arcmin:.3g} arcmin RMS" if self.reading_noise_arcmin is not None
                  else f"reading noise: {NOT_MEASURED}"),
                 "not separable: " + self.confounded]
        return "\n".join(lines)


def arc_sweep(phase_deg_e, encoder_deg, travel, pole_pairs, *, skip=DEFAULT_SKIP, name="", where="sweep",
              points=None):
    """Recover the encoder's error over the arc an open-loop sweep covered, up and down.

    Parameters
    ----------
    phase_deg_e, encoder_deg, travel, pole_pairs, skip, name, where
        As for :func:`encal.selfcal.sweep.sweep`; the readings cover one arc (one gap over 30 degrees).
    points : int, optional
        Readings of the grid the result is given on; default one every 0.25 degree of the arc (at least 64).

    Returns
    -------
    ArcSweepCalibration

    Raises
    ------
    InputError
        For a wrong pole-pair count, readings that do not form one arc, a sweep missing a direction, or
        too few samples.
    """
    from scipy.interpolate import BSpline
    from scipy.optimize import minimize_scalar

    pole_pairs = check_size("pole_pairs", pole_pairs, "sweep")
    skip = check_int(skip, "skip", "sweep", low=0, note="samples")
    reference, encoder, travel = sweep_samples(phase_deg_e, encoder_deg, travel, pole_pairs, skip, where)
    reading = np.mod(encoder, 360.0)  # the readings within the turn
    counts_against = False
    for sign, label in ((1, "up"), (-1, "down")):
        members = np.flatnonzero(travel == sign)
        if members.size < 64:
            raise InputError(f"{where}: the sweep {label} has {members.size} samples; expected at least 64 over "
                             "the arc")
        counts_against = check_sweep_travel(where, label, reference[members], encoder[members], pole_pairs)
    arc = arc_of(reading, MAX_GAP_DEG)
    if arc is None:
        raise InputError(f"{where}: the readings do not form one arc (they leave no gap over {MAX_GAP_DEG:g} deg, or "
                         "several); expected a sweep back and forth over one arc, or a full turn for the full sweep")
    start, span = arc[0], span_of(arc)
    sense = -1.0 if counts_against else 1.0
    error = (encoder - sense * reference) * ARCMIN_PER_DEG
    offset = np.clip(np.mod(reading - start, 360.0), 0.0, span)
    offset = np.where(np.mod(reading - start, 360.0) > span + 1e-9, 0.0, offset)

    intervals = int(min(240, max(8, np.unique(np.round(offset, 6)).size // 4)))
    inner = np.linspace(0.0, span, intervals + 1)
    knots = np.concatenate([[0.0] * 3, inner, [span] * 3])
    size = intervals + 3
    spline = BSpline.design_matrix(offset, knots, 3).toarray()
    electrical = np.deg2rad(sense * reference * pole_pairs)
    harmonics = np.arange(1, MOTOR_HARMONICS + 1)
    motor = np.hstack([np.cos(np.outer(electrical, harmonics)), np.sin(np.outer(electrical, harmonics))])
    # The motor's error is periodic in the rotor's angle, which trails the command by the lag, one way going up and
    # the other going down: one set of harmonics for both directions left the difference (2 x lag x the cogging's
    # slope) in the encoder's error, 0.33 arcmin RMS against a stated sigma of 0.12. Each direction has its own
    # set, as in the full-turn sweep's fit of each direction.
    motor = np.hstack([motor * (travel == 1)[:, None], motor * (travel == -1)[:, None]])
    scaled = 2.0 * offset / span - 1.0
    lag = travel[:, None] * np.polynomial.legendre.legvander(scaled, LAG_DEGREE)
    design = np.hstack([spline, motor, lag])
    extra = motor.shape[1] + lag.shape[1]
    gram = design.T @ design
    rhs = design.T @ error
    yty = float(error @ error)
    second = np.diff(np.eye(size), 2, axis=0)
    penalty = np.zeros((size + extra, size + extra))
    penalty[:size, :size] = second.T @ second
    scale = np.trace(gram[:size, :size]) / np.trace(penalty)
    n, null_dim, rank = error.size, 2 + extra, size - 2

    def solve(log_lambda):
        weight = scale * np.exp(log_lambda)
        system = gram + weight * penalty
        try:
            factor = np.linalg.cholesky(system)
        except np.linalg.LinAlgError:
            return np.inf, None, None, None
        coef = np.linalg.solve(factor.T, np.linalg.solve(factor, rhs))
        deviance = max(yty - float(coef @ rhs), 1e-300 * max(yty, 1.0))
        criterion = (n - null_dim) * np.log(deviance) + 2.0 * np.sum(np.log(np.diag(factor))) - rank * np.log(weight)
        return criterion, coef, factor, deviance

    grid = np.linspace(-20.0, 20.0, 41)
    values = [solve(v)[0] for v in grid]
    best = int(np.argmin(values))
    found = minimize_scalar(lambda v: solve(v)[0], bounds=(grid[max(best - 1, 0)], grid[min(best + 1, 40)]),
                            method="bounded", options={"xatol": 1e-3})
    _, coef, factor, deviance = solve(float(found.x) if found.fun <= values[best] else float(grid[best]))
    noise_var = deviance / max(n - null_dim, 1)
    inverse = np.linalg.inv(factor)
    covariance = noise_var * (inverse.T @ inverse)

    count = points or max(64, int(round(span / 0.25)) + 1)
    where_grid = np.linspace(0.0, span, count)
    basis = BSpline.design_matrix(where_grid, knots, 3).toarray()
    centred = basis - basis.mean(axis=0)  # the zero is arbitrary: the error over the arc has zero mean
    profile = centred @ coef[:size]
    sigma = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", centred, covariance[:size, :size], centred), 0.0))

    lag_coef = coef[size + motor.shape[1]:]
    lag_cov = covariance[size + motor.shape[1]:, size + motor.shape[1]:]
    lag_arcmin = -sense * float(lag_coef[0])  # the rotor trails the command: the reading is behind going up
    varying, varying_cov = lag_coef[1:], lag_cov[1:, 1:]
    chi2 = float(varying @ np.linalg.solve(varying_cov, varying))
    values_on_grid = np.polynomial.legendre.legvander(np.linspace(-1, 1, 101), LAG_DEGREE)[:, 1:] @ varying
    variation = float(np.sqrt(np.mean(values_on_grid ** 2)))
    significant = chi2 > 16.27  # chi-square, 3 degrees of freedom, p = 0.001
    statement = (f"the lag varies over the arc by RMS {variation:.3g} arcmin (significant: chi2 {chi2:.1f} on "
                 f"{LAG_DEGREE} degrees of freedom): a load or friction that changes with angle; its direction-"
                 "dependent part is separated, a part that pulls both ways alike stays in the recovered error"
                 if significant else
                 f"the lag does not vary measurably over the arc (RMS {variation:.3g} arcmin, chi2 {chi2:.1f} on "
                 f"{LAG_DEGREE} degrees of freedom)")
    details = {"lag_arcmin": lag_arcmin, "lag_deg_e": lag_arcmin / ARCMIN_PER_DEG * pole_pairs,
               "lag_variation_rms_arcmin": variation, "lag_varies": bool(significant), "lag_statement": statement,
               "encoder_counts_against_phase": bool(counts_against), "pole_pairs": int(pole_pairs),
               "noise_arcmin": float(np.sqrt(noise_var))}
    confounded = (f"the encoder's error at the electrical period (360/{pole_pairs} deg) and its harmonics, taken "
                  "with the motor's own cogging and field distortion; its zero (arbitrary); a load torque that "
                  "shifts the rotor the same way in both directions (gravity on an arm), which stays in the "
                  "recovered error; and everything outside the arc")
    return ArcSweepCalibration([float(arc[0]), float(arc[1])], np.mod(start + where_grid, 360.0), profile, sigma,
                               details, confounded, name,
                               reading_noise_arcmin=repeat_noise_arcmin(reference, encoder, travel))

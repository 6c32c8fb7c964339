"""Two encoders on one joint calibrate each other: a motor encoder and an output encoder behind a gear.

A geared joint often carries two encoders: one on the motor (for commutation) and one on the output (moteus's
output source, ODrive's dual encoders). With a gear of ratio ``N`` (motor turns per output turn) the two
readings of one log differ, in output degrees, by

    r = output - motor / N = c + e_out(output) / 60 - e_motor(motor) / (60 N) + gear error,

where each encoder's error ``e`` (arc-minutes of its own shaft) is periodic in its own shaft's angle (the
closure idea of angle metrology: no precision reference is needed). :func:`dual` fits both Fourier series to
``r`` at once, with the prior of each shaft's harmonics and the noise chosen by evidence (MacKay's fixed
point), and returns each profile with the posterior covariance of its coefficients.

What it cannot separate:

- a motor order ``j`` and an output order ``k`` with ``j N`` within one cycle per log of ``k`` (exactly equal
  for a whole-number ratio: motor order j meets output order j N): both are the same function of time, and
  the prior alone splits them (their uncertainty says so; :attr:`DualCalibration.confounded` names them);
- each encoder's constant (the zero): without a reference it is arbitrary;
- the gear's own transmission error that is periodic in one shaft (a runout) is indistinguishable from that
  shaft's encoder error and is counted in it; the mixed terms (tooth mesh) fall on confounded pairs.
"""

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, wrap180
from .._core.errors import InputError
from ._logfile import read_columns
from ._series import HarmonicSeries
from .result import SelfCalibration

__all__ = ["DualCalibration", "dual", "read_dual_log", "simulate_dual", "confounded_pairs"]

#: Largest step of either encoder between two readings, degrees: beyond it the turns cannot be followed (as a
#: spin log's 90 degrees).
MAX_STEP_DEG = 90.0
#: Largest relative difference between the gear ratio given and the one the log shows. Beyond it the ratio is wrong
#: (the motor's profile, fitted in output arc-minutes times the ratio, scales with it: --ratio 12 on a 6:1 joint
#: doubled it) or the log is not of the joint.
RATIO_TOLERANCE = 0.01
#: Fixed-point iterations of the evidence (they converge in a few dozen).
ITERATIONS = 200
#: Prior precision of the unpenalised columns (constant, ratio slope): effectively flat.
FLAT_PRECISION = 1e-12


@dataclass(frozen=True)
class DualCalibration:
    """Both encoders' error profiles, recovered from one log of both.

    Attributes
    ----------
    motor, output : SelfCalibration
        Each encoder's recovered error (arc-minutes of its own shaft) as a function of its own reading, with
        the covariance of its coefficients.
    ratio : float
        The gear ratio given (motor turns per output turn).
    ratio_estimated : float
        The ratio the log shows (the slope fitted with the profiles).
    confounded : list of (int, int)
        ``(motor order, output order)`` pairs this log cannot separate.
    noise_arcmin : float
        RMS of the residual (output arc-minutes): reading noise and what no model of the two shafts explains.
    output_turns : float
        Output turns the log covers.
    """

    motor: SelfCalibration
    output: SelfCalibration
    ratio: float
    ratio_estimated: float
    confounded: list = field(default_factory=list)
    noise_arcmin: float = 0.0
    output_turns: float = 0.0

    def summary(self):
        """A few lines: the ratio, each profile's RMS and uncertainty, the pairs not separated."""
        pairs = ", ".join(f"motor {j} / output {k}" for j, k in self.confounded[:12])
        more = f", ... ({len(self.confounded)} pairs)" if len(self.confounded) > 12 else ""
        lines = [f"gear ratio {self.ratio:g} given, {self.ratio_estimated:.6g} in the log; {self.output_turns:.3g} "
                 f"output turns; residual RMS {self.noise_arcmin:.3g} arcmin (output)",
                 "motor encoder (arcmin of the motor shaft):", self.motor.summary(top=6),
                 "output encoder (arcmin of the output shaft):", self.output.summary(top=6)]
        lines.append("not separable from this log (the prior splits them; see their uncertainty): "
                     + (pairs + more if pairs else "none within the orders fitted"))
        return "\n".join(lines)


def confounded_pairs(ratio, motor_orders, output_orders, output_turns):
    """``(j, k)`` pairs whose frequencies over the log, ``j * ratio`` and ``k`` cycles per output turn, are
    closer than one cycle per log (``1 / output_turns``): the same function of time, not separable."""
    resolution = 1.0 / max(output_turns, 1e-12)
    return [(int(j), int(k)) for j in motor_orders for k in output_orders
            if abs(abs(j * ratio) - k) < resolution - 1e-12]


def dual(motor_deg, output_deg, ratio, *, motor_orders=30, output_orders=30, pinion_teeth=None, name=""):
    """Recover the motor encoder's and the output encoder's error profiles from one log of both.

    Parameters
    ----------
    motor_deg, output_deg : array-like of shape (n,)
        Both readings, degrees in [0, 360) or unwrapped, in time order, sampled often enough that each shaft
        moves less than half a turn between samples.
    ratio : float
        Motor turns per output turn (negative when the output turns the other way).
    motor_orders, output_orders : int, default=30
        Highest harmonic order fitted on each shaft.
    pinion_teeth : int, optional
        Teeth of the gear on the motor shaft: the gear's tooth-mesh error repeats that many times a motor turn,
        the same function of time as the motor encoder's error at those orders (and their multiples). Those
        orders are fitted in the motor angle corrected by a first pass's estimate of the encoder's error (the
        mesh error is a function of the true angle), absorbing the mesh error, and left out of the motor's
        profile (``removed_orders``).
    name : str
        Name for the results.

    Returns
    -------
    DualCalibration

    Raises
    ------
    InputError
        If the arrays differ in length or hold non-finite values, the ratio is zero or not finite, or the
        output turns less than one full turn (its profile would not be defined).
    """
    motor = np.asarray(motor_deg, dtype=float).reshape(-1)
    output = np.asarray(output_deg, dtype=float).reshape(-1)
    if motor.shape != output.shape or motor.size < 16:
        raise InputError(f"dual expects the two encoders' readings in columns of one length (at least 16); got "
                         f"{motor.size} motor and {output.size} output readings")
    if not (np.all(np.isfinite(motor)) and np.all(np.isfinite(output))):
        raise InputError("dual expects finite readings in degrees; found NaN or infinity")
    if isinstance(ratio, bool) or not isinstance(ratio, (int, float, np.floating)) or not np.isfinite(ratio) \
            or ratio == 0:
        raise InputError(f"the gear ratio must be a finite number of motor turns per output turn, not 0; got {ratio!r}")
    ratio = float(ratio)
    for shaft, reading in (("motor", motor), ("output", output)):
        raw = np.diff(reading)
        # A counter's wrap: from near the top of its span to near the bottom (a row out of order jumps less far).
        # arc8: 16-bit counts passed as degrees wrapped in a step of 75 "degrees": motor profile 0, exit 0.
        span = float(np.ptp(reading))
        back = np.flatnonzero(np.abs(raw) > max(180.0, span - 2.0 * MAX_STEP_DEG))
        if back.size and span > 360.0 + 1e-6:
            i = int(back[0])
            raise InputError(f"the {shaft} readings span {reading.min():.6g} to {reading.max():.6g} and jump by "
                             f"{raw[i]:.6g} between readings {i + 1} and {i + 2}; expected degrees, wrapped within one "
                             "turn or unwrapped (an encoder's counts: convert them, degrees = count x 360 / 2^B)")
        steps = np.abs(wrap180(raw))
        if steps.max() > MAX_STEP_DEG:  # fuzz5: a log out of time order was fitted (a motor profile of 0 +- 1e-147)
            jump = int(np.flatnonzero(steps > MAX_STEP_DEG)[0])
            raise InputError(f"the {shaft} encoder moves {steps[jump]:.4g} deg between readings {jump + 1} and "
                             f"{jump + 2}; expected at most {MAX_STEP_DEG:g} deg, so that its turns can be followed "
                             "(a log in time order, at least four readings a motor turn)")
    motor_u = np.rad2deg(np.unwrap(np.deg2rad(motor)))
    output_u = np.rad2deg(np.unwrap(np.deg2rad(output)))
    turns = float(np.ptp(output_u) / 360.0)
    if turns < 1.0 - 1e-9:
        raise InputError(f"the output turned {turns * 360:.4g} deg in the log; expected at least one full turn, so "
                         "that the output encoder's profile is defined over it (a joint of limited travel: "
                         "calibrate it with a reference over its arc, see docs/in-place.md)")
    ratio_sign = 1.0 if np.sign(motor_u[-1] - motor_u[0]) * np.sign(output_u[-1] - output_u[0]) >= 0 else -1.0
    if np.sign(ratio) != ratio_sign:
        raise InputError(f"the gear ratio {ratio:g} says the output turns {'with' if ratio > 0 else 'against'} the "
                         f"motor, but in the log it turns {'with' if ratio_sign > 0 else 'against'} it; expected "
                         f"--ratio {-ratio:g}")
    _refuse_all_confounded(ratio, int(motor_orders), int(output_orders), turns)
    residual = (output_u - motor_u / ratio) * ARCMIN_PER_DEG
    k_out = np.arange(1, int(output_orders) + 1)
    k_mot = np.arange(1, int(motor_orders) + 1)
    phase_out = np.deg2rad(np.mod(output, 360.0))
    phase_mot = np.deg2rad(np.mod(motor, 360.0))
    slope = (motor_u - motor_u.mean()) / (360.0 * abs(ratio))  # output turns: a ratio a little off
    mesh = np.zeros(k_mot.size, dtype=bool)
    if pinion_teeth is not None:
        if isinstance(pinion_teeth, bool) or int(pinion_teeth) != pinion_teeth or pinion_teeth < 1:
            raise InputError(f"the pinion's teeth must be a whole number >= 1; got {pinion_teeth!r}")
        mesh = (k_mot % int(pinion_teeth)) == 0
    groups = np.concatenate([[0, 0], np.full(2 * k_out.size, 1), np.full(2 * k_mot.size, 2)])
    # The prior of each shaft's order k has a variance falling as 1/k^2 (encoders' spectra decay): columns are
    # scaled by 1/k so that one precision per shaft weighs them, and the coefficients scaled back. A motor order
    # j and the output order j N it meets are then split toward the lower order of its own shaft.
    weight = np.concatenate([[1.0, 1.0], 1.0 / k_out, 1.0 / k_out, 1.0 / k_mot, 1.0 / k_mot])
    n_out, n_mot = 2 * k_out.size, 2 * k_mot.size
    mesh_phase = phase_mot
    for _ in range(2 if mesh.any() else 1):
        # The gear's mesh error is a function of the motor's true angle: its orders are fitted in the reading
        # corrected by the motor encoder's estimated error (second pass), else its product with the encoder's
        # error leaves sidebands at the neighbouring motor orders.
        angle_mot = np.where(mesh[None, :], np.outer(mesh_phase, k_mot), np.outer(phase_mot, k_mot))
        columns = [np.ones_like(residual), slope,
                   *np.cos(np.outer(phase_out, k_out)).T, *np.sin(np.outer(phase_out, k_out)).T,
                   *(-np.cos(angle_mot).T / ratio), *(-np.sin(angle_mot).T / ratio)]
        design = np.column_stack(columns)
        mean, covariance, noise_var = _evidence_fit(design * weight, residual, groups)
        mean, covariance = mean * weight, covariance * np.outer(weight, weight)
        encoder_part = np.concatenate([~mesh, ~mesh])
        motor_error = (np.hstack([np.cos(np.outer(phase_mot, k_mot)), np.sin(np.outer(phase_mot, k_mot))])
                       [:, encoder_part] @ mean[2 + n_out:][encoder_part])
        mesh_phase = phase_mot - np.deg2rad(motor_error / ARCMIN_PER_DEG)
    out_vec, out_cov = mean[2:2 + n_out], covariance[2:2 + n_out, 2:2 + n_out]
    mot_vec, mot_cov = mean[2 + n_out:], covariance[2 + n_out:, 2 + n_out:]
    ratio_estimated = _ratio_from_slope(ratio, mean[1])
    if not abs(ratio_estimated - ratio) <= RATIO_TOLERANCE * abs(ratio):
        raise InputError(f"the log turns the motor {ratio_estimated:.6g} times per output turn but the gear ratio is "
                         f"{ratio:g}; expected them to agree within {RATIO_TOLERANCE:.0%} (the motor encoder's profile "
                         f"scales with the ratio: is it --ratio {ratio_estimated:.4g}?)")
    pairs = confounded_pairs(ratio, k_mot, k_out, turns)
    out_cov, mot_cov = _widen_confounded(pairs, ratio, out_vec, out_cov, mot_vec, mot_cov)
    note = ("motor orders " + ", ".join(str(j) for j in sorted({j for j, _ in pairs})[:10])
            + " meet output orders at j x ratio; their split is the prior's" if pairs else "")
    removed = ()
    if mesh.any():
        removed = tuple(int(k) for k in k_mot[mesh])
        keep = np.concatenate([~mesh, ~mesh])
        k_mot, mot_vec, mot_cov = k_mot[~mesh], mot_vec[keep], mot_cov[np.ix_(keep, keep)]
    motor_result = SelfCalibration(
        "dual", HarmonicSeries.from_vector(k_mot, mot_vec, mot_cov), removed, _confounded_text("motor", pairs, note),
        {"gear_ratio": ratio}, name=f"{name}-motor" if name else "motor")
    output_result = SelfCalibration(
        "dual", HarmonicSeries.from_vector(k_out, out_vec, out_cov), (), _confounded_text("output", pairs, note),
        {"gear_ratio": ratio}, name=f"{name}-output" if name else "output")
    fitted = design @ mean
    return DualCalibration(motor_result, output_result, ratio, ratio_estimated, pairs,
                           float(np.sqrt(np.mean((residual - fitted) ** 2))), turns)


def _widen_confounded(pairs, ratio, out_vec, out_cov, mot_vec, mot_cov):
    """The covariances with each confounded pair's split made honest: the log fixes only the pair's sum, and
    either shaft may own all of it, so each member's cosine and sine get the pair's whole amplitude (in its
    shaft's arc-minutes) as a further standard deviation.

    The prior's split follows each shaft's evidence scale: at a ratio of 2 with the motor's error 4 and the
    output's 12 arcmin RMS, the motor's profile came out 4.0 arcmin RMS off with a +-2 sigma band covering 4 %
    of it (arc8; benchmarks/bench_arc_truth.py).
    """
    out_cov, mot_cov = out_cov.copy(), mot_cov.copy()
    n_out, n_mot = out_vec.size // 2, mot_vec.size // 2
    for j, k in pairs:
        output_amplitude = float(np.hypot(out_vec[k - 1], out_vec[n_out + k - 1]))
        motor_amplitude = float(np.hypot(mot_vec[j - 1], mot_vec[n_mot + j - 1]))
        in_output = output_amplitude + motor_amplitude / abs(ratio)  # the pair's amplitude, output arcmin
        for index in (k - 1, n_out + k - 1):
            out_cov[index, index] += in_output**2
        for index in (j - 1, n_mot + j - 1):
            mot_cov[index, index] += (abs(ratio) * in_output) ** 2
    return out_cov, mot_cov


def _refuse_all_confounded(ratio, motor_orders, output_orders, output_turns):
    """Refuse a log in which every order of one shaft meets an order of the other (a ratio of 1: both shafts at
    one speed). The log then holds only the two errors' difference; fitted anyway (arc8), the evidence gave the
    whole error to one encoder and a prior so tight that its +-2 sigma (0.5 arcmin) hid a 12 arcmin miss."""
    k_mot, k_out = np.arange(1, motor_orders + 1), np.arange(1, output_orders + 1)
    pairs = confounded_pairs(ratio, k_mot, k_out, output_turns)
    for shaft, orders, side in (("motor", k_mot, 0), ("output", k_out, 1)):
        if {int(k) for k in orders} <= {pair[side] for pair in pairs}:
            raise InputError(
                f"with the gear ratio {ratio:g} over {output_turns:.3g} output turns every {shaft} order up to "
                f"{orders[-1]} meets an order of the other shaft (the same function of time), so the log holds "
                "only the difference of the two encoders' errors and cannot tell them apart; expected a gear "
                "ratio farther from 1 in size, or a longer log (two encoders on one shaft: calibrate each "
                "against a reference with encal fit)")


def _ratio_from_slope(ratio, slope):
    """The ratio the log shows. The residual (arcmin) is ``60 motor (1/ratio_true - 1/ratio)``, fitted as
    ``slope * motor / (360 |ratio|)``: ``1/ratio_true = 1/ratio + slope / (360 * 60 * |ratio|)``."""
    inverse = 1.0 / ratio + slope / (360.0 * ARCMIN_PER_DEG * abs(ratio))
    return float(1.0 / inverse)


def _confounded_text(shaft, pairs, note):
    if not pairs:
        return ("each encoder's constant (its zero) and the gear's transmission error periodic in this shaft (a "
                "runout), which is counted in this encoder's error")
    return (f"each encoder's constant (its zero); the gear's transmission error periodic in the {shaft} shaft; and "
            f"{note}")


def _evidence_fit(design, target, groups):
    """Bayesian linear regression with one prior precision per group (group 0 flat), chosen by evidence.

    Returns the posterior mean, its covariance and the noise variance.
    """
    gram = design.T @ design
    rhs = design.T @ target
    n, p = design.shape
    scale = np.maximum(np.diag(gram), 1e-300)
    alpha = np.array([FLAT_PRECISION, 1.0, 1.0]) * np.median(scale)
    beta = 1.0 / max(np.var(target), 1e-12)
    for _ in range(ITERATIONS):
        precision = beta * gram + np.diag(alpha[groups])
        factor = np.linalg.cholesky(precision)
        inverse = np.linalg.inv(factor)
        covariance = inverse.T @ inverse
        mean = beta * (covariance @ rhs)
        misfit = float(np.sum((target - design @ mean) ** 2))
        gamma_total = 0.0
        new_alpha = alpha.copy()
        for g in (1, 2):
            members = groups == g
            gamma = float(np.sum(1.0 - alpha[g] * np.diag(covariance)[members]))
            gamma_total += gamma
            new_alpha[g] = max(gamma, 1e-6) / max(float(np.sum(mean[members] ** 2)), 1e-300)
        gamma_total += 2.0
        new_beta = max(n - gamma_total, 1.0) / max(misfit, 1e-300)
        converged = np.allclose(new_alpha, alpha, rtol=1e-6) and abs(new_beta - beta) <= 1e-6 * beta
        alpha, beta = new_alpha, new_beta
        if converged:
            break
    precision = beta * gram + np.diag(alpha[groups])
    covariance = np.linalg.inv(precision)
    mean = beta * (covariance @ rhs)
    return mean, covariance, 1.0 / beta


def read_dual_log(path):
    """Read a two-encoder log: columns ``motor_deg`` and ``output_deg`` (degrees), rows in time order.

    Raises
    ------
    InputError
        As the other self-calibration logs (a missing column, a cell that is not a number), one sentence.
    """
    columns = read_columns(path, (("motor_deg", "degrees"), ("output_deg", "degrees")),
                           optional=(("time_s", "seconds"),), what="two-encoder log")
    return columns["motor_deg"], columns["output_deg"], Path(path).stem


def simulate_dual(ratio=6.0, *, output_turns=3.0, samples_per_motor_turn=720, seed=0, motor_rms_arcmin=12.0,
                  output_rms_arcmin=4.0, motor_noise_arcmin=1.0, output_noise_arcmin=0.15,
                  gear_mesh_arcmin=0.6, gear_runout_arcmin=0.0, pinion_teeth=12, max_order=15):
    """A simulated joint with truth: both encoders' errors, the gear's transmission error, reading noise.

    Returns
    -------
    motor_deg, output_deg : ndarray
        The log (wrapped readings).
    truth : dict
        ``'motor'`` and ``'output'``: ``(orders, cos, sin)`` of each encoder's true error (arcmin of its shaft) as
        a function of the true angle; ``'motor_at_reading'`` and ``'output_at_reading'``: the same errors as
        functions of the reading (degrees -> arcmin), what encal estimates; ``'gear'``: a description.
    """
    rng = np.random.default_rng(seed)

    def profile(rms):
        orders = np.arange(1, max_order + 1)
        scale = 1.0 / orders  # a decaying spectrum, as encoders show
        cos, sin = rng.normal(0, 1, orders.size) * scale, rng.normal(0, 1, orders.size) * scale
        factor = rms / np.sqrt(np.sum(cos**2 + sin**2) / 2.0)
        return orders, cos * factor, sin * factor

    motor_profile, output_profile = profile(motor_rms_arcmin), profile(output_rms_arcmin)
    n = int(abs(ratio) * output_turns * samples_per_motor_turn)
    motor_true = np.linspace(0.0, 360.0 * abs(ratio) * output_turns, n) * np.sign(ratio) + rng.uniform(0, 360)
    output_true = motor_true / ratio + rng.uniform(0, 360)
    # gear transmission error (arcmin of the output): tooth mesh (pinion teeth per motor turn) and runouts
    mesh = gear_mesh_arcmin * np.sin(np.deg2rad(pinion_teeth * motor_true) + 0.4)
    runout = gear_runout_arcmin * np.sin(np.deg2rad(output_true) + 1.1)
    output_true = output_true + (mesh + runout) / ARCMIN_PER_DEG

    def error(profile_, angle):
        orders, cos, sin = profile_
        phase = np.deg2rad(np.outer(angle, orders))
        return np.cos(phase) @ cos + np.sin(phase) @ sin

    motor_read = motor_true + (error(motor_profile, motor_true) + rng.normal(0, motor_noise_arcmin, n)) / 60.0
    output_read = output_true + (error(output_profile, output_true) + rng.normal(0, output_noise_arcmin, n)) / 60.0
    truth = {"motor": motor_profile, "output": output_profile,
             "motor_at_reading": _at_reading(lambda a: error(motor_profile, a)),
             "output_at_reading": _at_reading(lambda a: error(output_profile, a)),
             "gear": f"tooth mesh {gear_mesh_arcmin:g} arcmin at motor order {pinion_teeth}, output runout "
                     f"{gear_runout_arcmin:g} arcmin"}
    return np.mod(motor_read, 360.0), np.mod(output_read, 360.0), truth


def _at_reading(error_at_angle):
    """The error as a function of the reading: solve ``reading = angle + error(angle) / 60`` for the angle."""
    def at_reading(reading_deg):
        reading = np.asarray(reading_deg, dtype=float)
        angle = reading.copy()
        for _ in range(8):  # a contraction: the error's slope is far below 60 arcmin per degree
            angle = reading - error_at_angle(angle.reshape(-1)).reshape(reading.shape) / ARCMIN_PER_DEG
        return error_at_angle(angle.reshape(-1)).reshape(reading.shape)

    return at_reading

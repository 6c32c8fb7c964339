"""Electrical-angle sweep: the commanded electrical angle as the reference.

A motor driven open loop follows the commanded electrical angle: the reference is the unwrapped
electrical angle divided by the pole pairs. The rotor lags the command by the friction's angle, in
opposite directions going up and down: the mean of the two sweeps removes the lag (and half their
difference measures it). Cogging and the distortion of the field's direction are periodic in the
electrical angle: averaging the error over one electrical period (360/p degrees) filters them, and
with them every order of the encoder's error that is a multiple of the pole pairs ``p``. The period
average multiplies order ``k`` by ``sinc(k/p)``: zero at multiples of ``p``; dividing the other orders
by that factor restores them, so the whole operation is leaving out the multiples of ``p``. It is
computed so: the multiples of ``p`` (up to 24 p: cogging included) are fitted as functions of the
reference angle, where the motor's error is periodic, and the other orders as functions of the
reading, where the encoder's is. See docs/self-calibration.md.
"""

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, wrap180
from .._core.errors import InputError
from .._core.parameters import check_int, real_array
from .._core.limits import check_size
from ._series import HarmonicSeries, design_matrix
from .result import SelfCalibration
from .._core.threads import single_blas_thread

__all__ = ["sweep", "sweep_capture", "check_sweep_travel", "repeat_noise_arcmin"]

#: Largest relative mismatch between the encoder's travel and the commanded travel / pole pairs (and at
#: most half a pole pair's worth).
MAX_TRAVEL_MISMATCH = 0.1
#: Samples at the start of a capture left out: the rotor is still settling on the first commanded angle.
DEFAULT_SKIP = 4
#: Fewest second differences of repeated readings for a reading noise (:func:`repeat_noise_arcmin`): its
#: standard error is then about sqrt(1.94 / (2 x 50)), 14 % (the squares of neighbouring second differences of white
#: noise correlate by 4/9 and 1/36, which inflates the variance of their mean by 1.94; 3.3 % for the 888 of a
#: one-turn sweep twice each way, whose estimates spread by 2.6-4.1 % over 24 seeds).
MIN_REPEAT_TERMS = 50
#: Commanded angles (mechanical degrees, modulo a turn) that agree to this are taken for the same angle.
REPEAT_RESOLUTION_DEG = 1e-6


@single_blas_thread
def sweep_capture(capture, pole_pairs, **options):
    """:func:`sweep` of a :class:`~encal.selfcal.moteus_capture.MoteusCapture`."""
    name = options.pop("name", None)
    if name is None:
        from pathlib import Path

        name = Path(capture.source).stem if capture.source else ""
    return sweep(capture.phase_deg_e, capture.encoder_deg, capture.travel, pole_pairs, name=name,
                 where=capture.source or "sweep", **options)


@single_blas_thread
def sweep(phase_deg_e, encoder_deg, travel, pole_pairs, *, max_order=32, slots=None, skip=DEFAULT_SKIP, name="",
          where="sweep"):
    """Recover the encoder error from an open-loop sweep of the electrical angle, up and down.

    Parameters
    ----------
    phase_deg_e : array-like of shape (n,)
        Commanded electrical angle in electrical degrees, in the order of the sweep (wrapped or not).
    encoder_deg : array-like of shape (n,)
        Encoder readings in degrees.
    travel : array-like of shape (n,) of {+1, -1}
        +1 where the phase goes up, -1 where it goes down.
    pole_pairs : int
    max_order : int, default=32
        Highest harmonic order recovered.
    slots : int, optional
        Also leave out multiples of the slot count (for a motor with unequal slots, whose ripple the period
        average does not remove).
    skip : int, default=4
        Samples left out at the start (the rotor settling).
    name : str, default=''
    where : str, default='sweep'
        Name of the input, for messages.

    Returns
    -------
    SelfCalibration
        ``details`` holds the lag (arcmin and electrical degrees), the RMS of its variation over the turn,
        and whether the encoder counts against the phase.

    Raises
    ------
    InputError
        For a wrong pole-pair count (the encoder's travel does not match), a sweep that does not cover
        the turn in both directions, or too few samples.
    """
    pole_pairs = check_size("pole_pairs", pole_pairs, "sweep")
    max_order = check_int(max_order, "max_order", "sweep", low=1)
    slots = None if slots is None else check_size("slots", slots, "sweep")
    skip = check_int(skip, "skip", "sweep", low=0, note="samples")
    reference, encoder, travel = sweep_samples(phase_deg_e, encoder_deg, travel, pole_pairs, skip, where)
    reading = np.mod(encoder, 360.0)  # the readings within the turn
    orders = np.arange(1, max_order + 1)
    fits, counts_against = {}, False
    for sign, label in ((1, "up"), (-1, "down")):
        members = np.flatnonzero(travel == sign)
        if members.size < 2 * orders.size + 8:
            raise InputError(f"{where}: the sweep {label} has {members.size} samples; expected at least "
                             f"{2 * orders.size + 8} for order {max_order}")
        counts_against = check_sweep_travel(where, label, reference[members], encoder[members], pole_pairs)
        _check_coverage(where, label, reading[members], max_order)
        fits[label] = members
    sense = -1.0 if counts_against else 1.0
    error = (encoder - sense * reference) * ARCMIN_PER_DEG
    removed = set(range(pole_pairs, max_order + 1, pole_pairs))
    if slots:
        removed |= set(range(slots, max_order + 1, slots))
    removed = tuple(sorted(removed))
    kept = np.array([k for k in orders if k not in removed])
    results = {}
    for label, members in fits.items():
        # the motor's own error is periodic in the rotor's angle (the reference), the encoder's in its reading:
        # the multiples of p (and of the slots) are fitted in the reference, so that the encoder's error, which
        # shifts the reading, cannot smear the motor's cogging into the orders kept
        motor = _motor_orders(pole_pairs, slots, members.size)
        x = np.hstack([np.ones((members.size, 1)), design_matrix(reading[members], kept),
                       design_matrix(sense * reference[members], motor)])
        coefficients = np.linalg.lstsq(x, error[members], rcond=None)[0]
        residual = error[members] - x @ coefficients
        variance = residual @ residual / max(members.size - x.shape[1], 1)
        covariance = variance * np.linalg.pinv(x.T @ x)
        n = 1 + 2 * kept.size
        results[label] = (coefficients[:n], covariance[:n, :n])
    (up, cov_up), (down, cov_down) = results["up"], results["down"]
    mean = 0.5 * (up + down)
    covariance = 0.25 * (cov_up + cov_down)
    lag = 0.5 * (down[0] - up[0]) * sense
    hysteresis = 0.5 * (down[1:] - up[1:])
    series = HarmonicSeries.from_vector(kept, mean[1:], covariance[1:, 1:])
    details = {"lag_arcmin": float(lag), "lag_deg_e": float(lag / ARCMIN_PER_DEG * pole_pairs),
               "lag_variation_rms_arcmin": float(np.sqrt(np.sum(hysteresis ** 2) / 2)),
               "encoder_counts_against_phase": bool(counts_against), "pole_pairs": int(pole_pairs)}
    multiples = ", ".join(map(str, range(pole_pairs, min(max_order, 4 * pole_pairs) + 1, pole_pairs)))
    confounded = (f"averaging over one electrical period (360/{pole_pairs} deg) removes the motor's cogging and field "
                  f"distortion and with them the encoder's error at every multiple of {pole_pairs} ({multiples}, ...), "
                  "which stays unknown"
                  + (f"; multiples of the {slots} slots were left out too" if slots else
                     "; torque ripple at other orders (unequal slots: multiples of the slot count; unequal magnets: "
                     "low orders) is not removed and would stay in the result")
                  + f"; orders above {max_order} are not estimated")
    noise = repeat_noise_arcmin(reference, encoder, travel)
    if noise is None:
        details["reading_noise"] = NOT_MEASURED
    return SelfCalibration("sweep", series, removed, confounded, details, name, reading_noise_arcmin=noise)


#: What the summary says when a sweep commanded no angle twice in one direction.
NOT_MEASURED = ("not measured: the sweep commands no angle twice in one direction (sweep up and down twice over "
                "the same commanded angles to measure it); the band of a model of this calibration is the encoder "
                "error's, not a new reading's")


def repeat_noise_arcmin(reference_deg, encoder_deg, travel, min_terms=MIN_REPEAT_TERMS):
    """One reading's noise (arcmin RMS) from the readings a sweep repeats at one commanded angle in one direction.

    Driven open loop and quasi-static, the rotor stands at the same place each time the same electrical angle is
    commanded in the same direction (same lag): the encoder's error and the motor's own (cogging, field
    distortion, the lag) are then the same, and the two readings differ by their noise alone. Two passes each
    way over the same commanded angles (two moteus ``d cal`` runs joined, a sweep over more than one turn, or a CSV
    stepping the same angles twice) give a difference ``d`` at each angle; its second
    differences along the sweep take off what changes slowly between the passes (a drift, another lag at
    another current), and for white noise of variance ``σ²`` have variance ``12 σ²``: ``σ² = mean(Δ²d²) / 12``.

    It is the noise and the rounding to the encoder's codes, which a new reading has too (measured against the
    truth in docs/self-calibration.md, ``benchmarks/bench_selfcal_noise.py``). It misses what is the same at both
    visits: part of the rounding when the noise is well below a code (the two readings then often fall in the same
    code), and noise the encoder filters over several samples. The residual of the sweep's own fit cannot stand in
    for it: it holds the motor's ripple above the orders fitted.

    Where too few angles repeat exactly, two passes in one direction whose angles do not coincide are paired by
    interpolation (:func:`interpolated_repeat_noise_arcmin`), and that estimate is kept only when a linear and a
    cubic interpolation agree within :data:`MAX_INTERPOLATION_DISAGREEMENT` (the sampling then resolves the motor's
    ripple between samples).

    Parameters
    ----------
    reference_deg : ndarray of shape (n,)
        The commanded electrical angle unwrapped, over the pole pairs (mechanical degrees), in sweep order.
    encoder_deg : ndarray of shape (n,)
        The readings, degrees.
    travel : ndarray of shape (n,) of {+1, -1}
        Direction of each sample.
    min_terms : int, default=50
        Fewest second differences for an estimate.

    Returns
    -------
    float or None
        None when fewer than ``min_terms`` second differences of repeats are found, and no interpolated estimate
        is found or kept.
    """
    reference = np.asarray(reference_deg, dtype=float)
    steps_per_turn = int(round(360.0 / REPEAT_RESOLUTION_DEG))
    angle = np.round(np.mod(reference, 360.0) / REPEAT_RESOLUTION_DEG).astype(np.int64) % steps_per_turn
    key = 2 * angle + (np.asarray(travel) > 0)
    order = np.lexsort((np.arange(key.size), key))  # by angle and direction, then in sweep order
    same = key[order][1:] == key[order][:-1]
    first, second = order[:-1][same], order[1:][same]  # consecutive visits of one angle in one direction
    by_first = np.argsort(first)
    first, second = first[by_first], second[by_first]
    difference = wrap180(np.asarray(encoder_deg, dtype=float)[second]
                         - np.asarray(encoder_deg, dtype=float)[first]) * ARCMIN_PER_DEG
    # three pairs in a row: consecutive samples of one pass paired with consecutive samples of another
    run = (first[2:] - first[:-2] == 2) & (first[1:-1] - first[:-2] == 1) \
        & (second[2:] - second[:-2] == 2) & (second[1:-1] - second[:-2] == 1)
    curvature = (difference[:-2] - 2 * difference[1:-1] + difference[2:])[run]
    if curvature.size >= min_terms:
        return float(np.sqrt(np.mean(curvature ** 2) / 12.0))
    # passes whose commanded angles do not coincide: interpolated, when the sampling resolves the errors between
    # samples (a linear and a cubic interpolation then agree; at moteus' default speed the motor's cogging
    # between prints made the linear 2-23 % higher, and the two 1.0-2.7 and 1.0-2.2 times the truth)
    cubic = interpolated_repeat_noise_arcmin(reference, encoder_deg, travel, min_terms, points=4)
    if cubic is None:
        return None
    linear = interpolated_repeat_noise_arcmin(reference, encoder_deg, travel, min_terms, points=2)
    return cubic if abs(linear - cubic) <= MAX_INTERPOLATION_DISAGREEMENT * cubic else None


#: Largest relative difference between the noise from a linear and from a cubic interpolation of the other pass
#: for an estimate: 0.4 % at most on the simulator's sweeps that resolve the motor's ripple (moteus at a quarter of
#: its default speed), 2.2 % at least on those that do not (its default speed).
MAX_INTERPOLATION_DISAGREEMENT = 0.01
#: Widest span of the other pass's samples (in samples) that one second difference may interpolate from.
MAX_INTERPOLATION_SPAN = 8


def interpolated_repeat_noise_arcmin(reference_deg, encoder_deg, travel, min_terms=MIN_REPEAT_TERMS, points=4):
    """One reading's noise (arcmin RMS) from two passes in one direction whose commanded angles do not coincide.

    Each reading of a pass is paired with the previous pass in the same direction, interpolated at the same
    commanded angle (a whole number of turns away) by the polynomial through its ``points`` nearest samples (2:
    linear; 4: cubic), which assumes the encoder's and the motor's errors smooth at the sample spacing. The second
    differences of those differences along the pass take off what changes slowly. Each is a known combination of
    independent readings: weights 1, -2, 1 on this pass's three, and on the other pass's the same weights spread by
    the interpolation (``1 - f`` and ``f`` at a fraction ``f`` of the way, linearly), which smooths the other
    pass's noise: a second difference of white noise interpolated at a constant ``f`` has variance
    ``(6 - 20 f (1 - f)) σ²``, not ``((1 - f)² + f²) 6 σ²``. So ``σ² = Σ (Δ²d)² / Σ |w|²``, with ``|w|²``
    each second difference's sum of squared weights (12 at ``f = 0``, as :func:`repeat_noise_arcmin`); a cubic's
    weights are the Lagrange polynomials'.

    Parameters
    ----------
    reference_deg, encoder_deg, travel, min_terms
        As :func:`repeat_noise_arcmin`. A pass is a run of samples of one direction.
    points : {2, 4}, default=4
        Samples of the other pass each interpolation uses.

    Returns
    -------
    float or None
        None when fewer than ``min_terms`` second differences are found.
    """
    reference = np.asarray(reference_deg, dtype=float)
    encoder = np.unwrap(np.asarray(encoder_deg, dtype=float), period=360.0)
    travel = np.asarray(travel)
    starts = np.flatnonzero(np.r_[True, travel[1:] != travel[:-1]])
    passes = np.split(np.arange(travel.size), starts[1:])
    numerator, denominator, terms = 0.0, 0.0, 0
    for number, this in enumerate(passes):
        earlier = [other for other in passes[:number] if travel[other[0]] == travel[this[0]] and other.size >= 2]
        if this.size < 3 or not earlier:
            continue
        other = earlier[-1]
        sign = 1.0 if reference[other[-1]] >= reference[other[0]] else -1.0
        other_reference = sign * reference[other]  # increasing along the other pass
        if np.any(np.diff(other_reference) <= 0):
            continue  # not a monotone sweep of the commanded angle
        # the same angle a whole number of turns away, inside the other pass
        turns = np.round((np.median(reference[other]) - np.median(reference[this])) / 360.0)
        position = sign * (reference[this] + 360.0 * turns)
        j = np.searchsorted(other_reference, position, side="right") - 1
        below = (points - 1) // 2  # samples of the other pass before the angle, besides its left neighbour
        inside = (j >= below) & (j < other.size - points + below)
        stencil = np.clip(j, below, other.size - points + below)[:, None] + np.arange(-below, points - below)
        nodes = other_reference[stencil]
        lagrange = np.ones(stencil.shape)
        for m in range(points):
            for n in range(points):
                if m != n:
                    lagrange[:, m] *= (position - nodes[:, n]) / (nodes[:, m] - nodes[:, n])
        interpolated = np.sum(lagrange * encoder[other][stencil], axis=1)
        difference = (encoder[this] - interpolated) * ARCMIN_PER_DEG
        curvature = difference[:-2] - 2 * difference[1:-1] + difference[2:]
        first = stencil[:-2, 0]
        usable = inside[:-2] & inside[1:-1] & inside[2:] & (stencil[2:, -1] - first < MAX_INTERPOLATION_SPAN)
        weights = np.zeros((curvature.size, MAX_INTERPOLATION_SPAN))
        rows = np.arange(curvature.size)
        for shift, coefficient in ((0, 1.0), (1, -2.0), (2, 1.0)):
            for m in range(points):
                offset = np.clip(stencil[shift:shift + curvature.size, m] - first, 0, MAX_INTERPOLATION_SPAN - 1)
                np.add.at(weights, (rows, offset), coefficient * lagrange[shift:shift + curvature.size, m])
        squared = 6.0 + np.sum(weights ** 2, axis=1)
        numerator += float(np.sum(curvature[usable] ** 2))
        denominator += float(np.sum(squared[usable]))
        terms += int(np.count_nonzero(usable))
    if terms < min_terms:
        return None
    return float(np.sqrt(numerator / denominator))


def sweep_samples(phase_deg_e, encoder_deg, travel, pole_pairs, skip, where):
    """A sweep's samples after the first ``skip``: the reference (the commanded electrical phase unwrapped, over
    the pole pairs) and the encoder unwrapped, degrees, and the direction of each sample.

    Raises
    ------
    InputError
        When the three differ in length.
    """
    phase = real_array(phase_deg_e, "phase_deg_e", where, "electrical degrees (real numbers)").reshape(-1)[skip:]
    reading = real_array(encoder_deg, "encoder_deg", where, "degrees (real numbers)").reshape(-1)[skip:]
    travel = np.asarray(travel).reshape(-1)[skip:]
    if not phase.size == reading.size == travel.size:
        raise InputError(f"{where}: phase, encoder and direction differ in length; expected one of each per sample")
    if not (np.all(np.isfinite(phase)) and np.all(np.isfinite(reading))):  # LAPACK's "SVD did not converge"
        raise InputError(f"{where}: expected finite phases and encoder readings; got NaN or infinity")
    return np.unwrap(phase, period=360.0) / pole_pairs, np.unwrap(reading, period=360.0), travel


def check_sweep_travel(where, label, reference_deg, encoder_deg, pole_pairs):
    """True when the encoder counts against the phase; refuses a pole-pair count its travel does not match.

    The one check of a sweep's pole pairs, for ``encal selfcal sweep`` and ``encal import moteus-cal``.

    Parameters
    ----------
    where, label : str
        The input and the pass (``'up'``, ``'down'``), for the message.
    reference_deg : ndarray
        The unwrapped commanded phase / ``pole_pairs`` over one pass, degrees.
    encoder_deg : ndarray
        The unwrapped encoder readings over the same pass, degrees.
    pole_pairs : int

    Raises
    ------
    InputError
        When the encoder's travel differs from the commanded travel / ``pole_pairs`` by more than
        :data:`MAX_TRAVEL_MISMATCH` (and at most half a pole pair's worth), naming the count that fits.
    """
    commanded = reference_deg[-1] - reference_deg[0]
    moved = encoder_deg[-1] - encoder_deg[0]
    tolerance = min(MAX_TRAVEL_MISMATCH, 0.5 / pole_pairs)  # a pole pair more or less is caught
    if abs(commanded) < 1e-9 or abs(abs(moved / commanded) - 1) > tolerance:
        suggestion = abs(moved) and abs(commanded) * pole_pairs / abs(moved)
        raise InputError(f"{where}: the encoder turned {abs(moved):.1f} deg while the phase / {pole_pairs} pole "
                         f"pairs turned {abs(commanded):.1f} deg in the sweep {label}; expected the same (is the "
                         f"pole-pair count {max(1, round(suggestion))}?)")
    return bool(moved * commanded < 0)


def _motor_orders(pole_pairs, slots, samples):
    """Orders of the motor's own error fitted in the reference: multiples of p (and of the slots) up to 24 p,
    as many as a third of the samples can identify."""
    highest = min(24 * pole_pairs, max(pole_pairs, samples // 3))
    orders = set(range(pole_pairs, highest + 1, pole_pairs))
    if slots:
        orders |= set(range(slots, highest + 1, slots))
    return np.array(sorted(orders), dtype=int)


def _check_coverage(where, label, reading, max_order):
    angles = np.sort(np.mod(reading, 360.0))
    gap = float(np.max(np.diff(np.concatenate([angles, angles[:1] + 360.0]))))
    if gap > 180.0 / max_order:
        raise InputError(f"{where}: the sweep {label} leaves a gap of {gap:.3g} deg in the turn; expected it to "
                         f"cover the whole turn with no gap over {180.0 / max_order:.3g} deg (sweep at least one "
                         "revolution, or lower max_order)")

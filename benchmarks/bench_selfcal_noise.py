"""The reading noise ``selfcal sweep`` and ``selfcal steps`` measure, against the simulators' known noise.

For 8 seeds at each noise level (a 14-bit encoder, ``draw_magnetic_encoder(seed, noise_arcmin=...)``, whose one
reading's noise about its profile is ``hypot(noise, LSB / sqrt(12))``), the ratio measured / truth, min-max:

- ``sweep``, full turn and arc (half a turn), of a 7-pole-pair motor (``make_motor(7, 12, seed)``) swept up and
  down twice (``passes=2``): the estimate from the repeated angles (:func:`encal.selfcal.sweep.repeat_noise_arcmin`),
  and what the sweep's own fit leaves (each direction's residual RMS; the arc's REML ``noise_arcmin``), which holds
  the motor's ripple; swept once each way, no estimate (``None``);
- ``sweep`` of moteus ``d cal`` captures simulated tick by tick (``simulate_moteus_cal``, 7 pole pairs): one run (once
  each way, as every moteus capture), two runs joined (the same phases exactly), and two runs whose phases do not
  coincide (the second started half a print step and 37 x seed counts on), at the default speed and at a quarter of
  it (the interpolated pairing, :func:`encal.selfcal.sweep.interpolated_repeat_noise_arcmin`);
- ``steps`` of two calibrations (``draw_stepper(seed)``), the magnet turned 137.5 deg and a repeat: the noise of a
  calibration point (``calibration_point_noise_arcmin``) with 10 reads a step (Mechaduino), that times sqrt(10),
  and with one read a step (what ``single_reads=True`` records).

Run:  PYTHONPATH=src OMP_NUM_THREADS=1 python benchmarks/bench_selfcal_noise.py   (about 20 s CPU)
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import time  # noqa: E402

import numpy as np  # noqa: E402

from encal.selfcal._series import design_matrix  # noqa: E402
from encal.selfcal.arc_sweep import arc_sweep  # noqa: E402
from encal.selfcal.steps import steps  # noqa: E402
from encal.selfcal.sweep import _motor_orders, sweep, sweep_samples  # noqa: E402
from encal.selfcal.synthetic import (draw_magnetic_encoder, draw_stepper, make_motor,  # noqa: E402
                                     simulate_moteus_cal, simulate_steps, simulate_sweep)

SEEDS = range(8)
POLE_PAIRS = 7


def one_reading_noise(encoder):
    return float(np.hypot(encoder.noise_arcmin, 21600.0 / 2**encoder.bits / np.sqrt(12.0)))


def fit_residual_arcmin(phase, reading, travel):
    """RMS of what each direction's fit of :func:`~encal.selfcal.sweep.sweep` leaves (per degree of freedom)."""
    reference, encoder, travel = sweep_samples(phase, reading, travel, POLE_PAIRS, 4, "sweep")
    kept = np.array([k for k in range(1, 33) if k % POLE_PAIRS])
    error = (encoder - reference) * 60.0
    variances = []
    for sign in (1, -1):
        members = np.flatnonzero(travel == sign)
        x = np.hstack([np.ones((members.size, 1)), design_matrix(np.mod(encoder[members], 360.0), kept),
                       design_matrix(reference[members], _motor_orders(POLE_PAIRS, None, members.size))])
        residual = error[members] - x @ np.linalg.lstsq(x, error[members], rcond=None)[0]
        variances.append(residual @ residual / (members.size - x.shape[1]))
    return float(np.sqrt(np.mean(variances)))


def span(values):
    stated = [v for v in values if v is not None]
    missing = len(values) - len(stated)
    text = f"{min(stated):.2f}-{max(stated):.2f}" if stated else "None"
    return text + (f" ({missing} None)" if stated and missing else "")


def main():
    start = time.process_time()
    print("| method | noise arcmin | truth arcmin | estimate / truth (min-max over 8 seeds) |\n|---|---:|---:|---|")
    for noise in (2.0, 0.5, 0.2):
        rows = {}
        for seed in SEEDS:
            encoder = draw_magnetic_encoder(seed, noise_arcmin=noise)
            truth = one_reading_noise(encoder)
            for passes in (2, 1):
                for label, method, revolutions in (("full turn", sweep, 1.0), ("arc", arc_sweep, 0.5)):
                    capture = simulate_sweep(make_motor(POLE_PAIRS, 12, seed), encoder, revolutions=revolutions,
                                             rng=seed, passes=passes)
                    args = (capture.phase * 360 / 65536, capture.encoder * 360 / 65536,
                            np.where(np.isin(capture.direction, (1, 3)), 1, -1))
                    result = method(*args, POLE_PAIRS)
                    measured = result.reading_noise_arcmin
                    rows.setdefault(f"sweep, {label}, {passes} passes each way: the repeats", []).append(
                        None if measured is None else measured / truth)
                    if passes == 2:
                        own = fit_residual_arcmin(*args) if method is sweep else result.details["noise_arcmin"]
                        rows.setdefault(f"sweep, {label}: the fit's own residual", []).append(own / truth)
            for label, speed, runs, offset in (("one run", 1.0, 1, False), ("two runs", 1.0, 2, False),
                                               ("two runs, phases offset", 1.0, 2, True),
                                               ("two runs, phases offset, speed 0.25", 0.25, 2, True)):
                step = 10 * int(speed * 65.536)
                capture = simulate_moteus_cal(make_motor(POLE_PAIRS, 12, seed), encoder, speed=speed, runs=runs,
                                              start_counts=[0, step // 2 + 37 * seed][:runs] if offset else 0,
                                              rng=seed)
                measured = sweep(capture.phase * 360 / 65536, capture.encoder * 360 / 65536,
                                 np.where(capture.direction == 1, 1, -1), POLE_PAIRS).reading_noise_arcmin
                rows.setdefault(f"sweep, moteus d cal, {label}", []).append(
                    None if measured is None else measured / truth)
            if noise == 0.2:
                continue
            stepper = draw_stepper(seed)
            for turn, what in ((137.5, "turned 137.5 deg"), (0.0, "repeat")):
                for reads in (10, 1):
                    first = simulate_steps(stepper, encoder, readings_per_step=reads, rng=seed).calibration
                    second = simulate_steps(stepper, encoder.turned(turn), readings_per_step=reads,
                                            rng=seed + 100).calibration
                    point = steps(first, second).details["calibration_point_noise_arcmin"]
                    rows.setdefault(f"steps, {what}, {reads} read(s) a step: a point's noise", []).append(
                        point / truth)
                    if reads > 1:
                        rows.setdefault(f"steps, {what}, {reads} reads a step: a point's noise x sqrt({reads})",
                                        []).append(point * np.sqrt(reads) / truth)
        for label, ratios in rows.items():
            print(f"| {label} | {noise:g} | {truth:.3f} | {span(ratios)} |", flush=True)
    print(f"<!-- {time.process_time() - start:.0f} s CPU -->")


if __name__ == "__main__":
    main()

"""Self-calibration over a limited range (issue 31): an open-loop sweep back and forth over an arc.

Usage::

    python benchmarks/bench_arc_sweep.py      # a few seconds

A simulated motor (encal.selfcal.synthetic.make_motor: cogging, field distortion, Coulomb friction) with a
magnetic encoder (draw_magnetic_encoder(21), 1.5 deg eccentricity) is swept open loop over a fraction of a
turn, two pairs of passes up and down, 64 samples per electrical period. ``encal.selfcal.arc_sweep`` recovers
the encoder's error over the arc and the lag. Compared with the truth after removing from both what a sweep
cannot see (the constant and the harmonics of the electrical angle): RMS miss / RMS truth, the +-2 sigma
coverage on the grid, and the lag against the friction's angle.
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from encal.selfcal.arc_sweep import arc_sweep  # noqa: E402
from encal.selfcal.synthetic import draw_magnetic_encoder, make_motor, simulate_sweep  # noqa: E402


def without_electrical_period(grid_deg, values, pole_pairs, harmonics=24):
    angle = np.deg2rad(grid_deg * pole_pairs)
    basis = np.column_stack([np.ones_like(angle)] + [f(m * angle) for m in range(1, harmonics + 1)
                                                     for f in (np.cos, np.sin)])
    return values - basis @ np.linalg.lstsq(basis, values, rcond=None)[0]


def main():
    encoder = draw_magnetic_encoder(21, eccentricity_deg=1.5)
    print(f"{'p':>3} {'arc/deg':>8} {'miss/truth':>10} {'cover':>6} {'lag/arcmin':>11} {'true lag':>9}")
    for pole_pairs, slots, revolutions in ((21, 36, 0.25), (21, 36, 0.1), (7, 12, 0.5), (7, 12, 0.35)):
        motor = make_motor(pole_pairs, slots, 4)
        capture = simulate_sweep(motor, encoder, revolutions=revolutions, rng=5, passes=2)
        result = arc_sweep(capture.phase * 360 / 65536, capture.encoder * 360 / 65536,
                           np.where(np.isin(capture.direction, (1, 3)), 1, -1), pole_pairs)
        truth = without_electrical_period(result.grid_deg, encoder.error_at_reading(result.grid_deg), pole_pairs)
        miss = without_electrical_period(result.grid_deg, result.error_arcmin, pole_pairs) - truth
        lag = np.degrees(np.arcsin(motor.coulomb_nm / motor.holding_torque_nm)) / pole_pairs * 60
        print(f"{pole_pairs:3d} {360 * revolutions:8.0f} {np.sqrt(np.mean(miss**2) / np.mean(truth**2)):10.3f} "
              f"{np.mean(np.abs(miss) <= 2 * result.sigma_arcmin):6.2f} {result.details['lag_arcmin']:11.3f} "
              f"{lag:9.3f}")


if __name__ == "__main__":
    main()

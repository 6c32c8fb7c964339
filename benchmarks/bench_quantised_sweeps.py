"""Dense noise-free sweeps of a quantised encoder: false lines, error off the truth and CPU of the spectral fit.

Usage::

    python benchmarks/bench_quantised_sweeps.py             # the 48 sweeps of docs/model-selection.md
    python benchmarks/bench_quantised_sweeps.py --seeds 0   # 24 of them

One reading per stop of a motor's log: 12 or 14 bits, 1,800, 2,400 or 3,600 stops (uniform, or each moved by up
to ±0.4 of the spacing), a profile of orders 1, 2, 4 and 14 (6, 3, 1.5 and 1 arcmin, or 0.3 times that), the
reference exact and no noise but the rounding to whole codes: the construction of
``tests/models/test_spectral.py::test_a_dense_noise_free_sweep_of_a_quantised_encoder_gets_no_false_line``.
Per sweep ``fit_spectral`` blind; printed: the lines at orders other than the profile's (false lines), the RMS of
the model off the truth on a 0.018° grid of encoder angles, the same for a least-squares fit of the true orders
(0, 1, 2, 4, 14) to the same readings, and the fit's CPU seconds (``time.process_time``, one BLAS thread).
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import itertools  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import sys  # noqa: E402
from pathlib import Path  # noqa: E402

from encal.models.spectral import fit_spectral  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.models.test_spectral import low_harmonics_at_encoder_angles, quantised_sweep  # noqa: E402

#: The profile's orders (those of ``low_harmonics``), with order 0.
TRUE_ORDERS = (0, 1, 2, 4, 14)


def least_squares_of_true_orders(reading_deg, error_arcmin, at_deg):
    """A least-squares Fourier fit of the profile's own orders, evaluated at ``at_deg``."""
    def design(theta_deg):
        r = np.radians(theta_deg)[:, None] * np.array(TRUE_ORDERS)
        return np.hstack([np.cos(r), np.sin(r[:, 1:])])
    coefficients = np.linalg.lstsq(design(reading_deg), error_arcmin, rcond=None)[0]
    return design(at_deg) @ coefficients


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1], help="seeds of the stops (default 0 1)")
    args = parser.parse_args()
    grid = np.arange(0.0, 360.0, 0.018)
    rows = []
    print("bits  stops  jitter  scale  seed  false lines  RMS off truth  least squares  ratio  CPU s")
    for bits, stops, jitter, scale, seed in itertools.product((12, 14), (1800, 2400, 3600), (False, True),
                                                              (1.0, 0.3), args.seeds):
        reading, error = quantised_sweep(bits, stops, jitter, scale, seed)
        start = time.process_time()
        model = fit_spectral(reading, error)
        cpu = time.process_time() - start
        truth = low_harmonics_at_encoder_angles(grid, scale)
        off = float(np.sqrt(np.mean((model.predict(grid) - truth) ** 2)))
        least = float(np.sqrt(np.mean((least_squares_of_true_orders(reading, error, grid) - truth) ** 2)))
        false_lines = sorted(set(model.training["lines"]) - set(TRUE_ORDERS))
        rows.append((jitter, len(false_lines), off, least, cpu))
        print(f"{bits:4d}  {stops:5d}  {'yes' if jitter else 'no':>6}  {scale:5.1f}  {seed:4d}  {len(false_lines):11d}"
              f"  {off:13.4f}  {least:13.4f}  {off / least:5.2f}  {cpu:5.2f}")
    for jitter in (False, True):
        part = [row for row in rows if row[0] == jitter]
        print(f"{'jittered' if jitter else 'uniform'} ({len(part)} sweeps): false lines {sum(r[1] for r in part)}, "
              f"worst RMS off the truth {max(r[2] for r in part):.3f} arcmin, worst least-squares fit of the true "
              f"orders {max(r[3] for r in part):.3f}, worst ratio {max(r[2] / r[3] for r in part):.2f}")
    print(f"CPU of the fits: {sum(r[4] for r in rows):.1f} s in all")


if __name__ == "__main__":
    main()

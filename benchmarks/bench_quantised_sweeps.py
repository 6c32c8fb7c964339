"""Dense noise-free sweeps of a quantised encoder: false lines, error off the truth and CPU of the spectral fit.

Usage::

    python benchmarks/bench_quantised_sweeps.py             # the 48 sweeps of docs/model-selection.md
    python benchmarks/bench_quantised_sweeps.py --seeds 0   # 24 of them
    python benchmarks/bench_quantised_sweeps.py --baselines # and the plain baselines on the seed-0 sweeps
    python benchmarks/bench_quantised_sweeps.py --timing    # median CPU of 3 of the page's cases and of random stops
    python benchmarks/bench_quantised_sweeps.py --divides-codes  # the limit: stops that divide the 2^B codes

The figures "before" on docs/model-selection.md are this command with the code of commit 410d2f6 (before
2026-11-28's change), run from this checkout: ``git worktree add /tmp/old 410d2f6`` and
``PYTHONPATH=/tmp/old/src python benchmarks/bench_quantised_sweeps.py``.

One reading per stop of a motor's log: 12 or 14 bits, 1,800, 2,400 or 3,600 stops (uniform, or each moved by up
to ±0.4 of the spacing), a profile of orders 1, 2, 4 and 14 (6, 3, 1.5 and 1 arcmin, or 0.3 times that), the
reference exact and no noise but the rounding to whole codes: the construction of
``tests/models/test_spectral.py::test_a_dense_noise_free_sweep_of_a_quantised_encoder_gets_no_false_line``.
Per sweep ``fit_spectral`` blind; printed: the lines at orders other than the profile's (false lines), the RMS of
the model off the truth on a 0.018° grid of encoder angles, the same for a least-squares fit of the true orders
(0, 1, 2, 4, 14) to the same readings, and the fit's CPU seconds (``time.process_time``, one BLAS thread); per
kind of stops the largest error off the truth too.
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
from tests.models.test_spectral import low_harmonics, low_harmonics_at_encoder_angles, quantised_sweep  # noqa: E402

#: The profile's orders (those of ``low_harmonics``), with order 0.
TRUE_ORDERS = (0, 1, 2, 4, 14)


def least_squares_of_true_orders(reading_deg, error_arcmin, at_deg):
    """A least-squares Fourier fit of the profile's own orders, evaluated at ``at_deg``."""
    def design(theta_deg):
        r = np.radians(theta_deg)[:, None] * np.array(TRUE_ORDERS)
        return np.hstack([np.cos(r), np.sin(r[:, 1:])])
    coefficients = np.linalg.lstsq(design(reading_deg), error_arcmin, rcond=None)[0]
    return design(at_deg) @ coefficients


def binned_interp(reading_deg, error_arcmin, at_deg, width_deg):
    """np.interp (periodic) of the errors averaged in bins of ``width_deg`` of the reading, at ``at_deg``."""
    bins = np.floor(reading_deg / width_deg).astype(int)
    counts = np.bincount(bins, minlength=int(round(360 / width_deg)))
    filled = counts > 0
    centres = (np.arange(counts.size) + 0.5)[filled] * width_deg
    means = np.bincount(bins, weights=error_arcmin, minlength=counts.size)[filled] / counts[filled]
    return np.interp(at_deg, centres, means, period=360.0)


def baselines(grid):
    """The plain baselines on the 24 seed-0 sweeps: the CV-chosen Fourier series and binned np.interp."""
    from encal.models.fourier import fit_fourier

    print("bits  stops  jitter  scale  fourier select=cv  binned np.interp 1/2/4 deg (best)")
    cv, binned = [], []
    for bits, stops, jitter, scale in itertools.product((12, 14), (1800, 2400, 3600), (False, True), (1.0, 0.3)):
        reading, error = quantised_sweep(bits, stops, jitter, scale, 0)
        truth = low_harmonics_at_encoder_angles(grid, scale)
        off_cv = float(np.sqrt(np.mean((fit_fourier(reading, error, select="cv").predict(grid) - truth) ** 2)))
        off_bins = [float(np.sqrt(np.mean((binned_interp(reading, error, grid, w) - truth) ** 2))) for w in (1, 2, 4)]
        cv.append(off_cv)
        binned.append(min(off_bins))
        print(f"{bits:4d}  {stops:5d}  {'yes' if jitter else 'no':>6}  {scale:5.1f}  {off_cv:17.4f}  "
              + " / ".join(f"{b:.4f}" for b in off_bins) + f" ({min(off_bins):.4f})")
    print(f"RMS off the truth: fourier select=cv {min(cv):.3f}-{max(cv):.3f} arcmin, "
          f"binned np.interp (best width) {min(binned):.3f}-{max(binned):.3f}")


def _median_cpu(reading, error, repeats):
    times = []
    for _ in range(repeats):
        start = time.process_time()
        fit_spectral(reading, error)
        times.append(time.process_time() - start)
    return float(np.median(times))


def timing(repeats=3):
    """Median CPU of ``repeats`` fits: the page's timed sweeps, and 10^4 random stops of 14 and 16 bits."""
    for bits, stops, jitter in ((12, 3600, False), (14, 3600, True)):
        reading, error = quantised_sweep(bits, stops, jitter, 1.0, 0)
        print(f"{bits}-bit, {stops} {'jittered' if jitter else 'uniform'} stops (seed 0): "
              f"{_median_cpu(reading, error, repeats):.2f} s CPU, median of {repeats}")
    for bits in (14, 16):
        rng = np.random.default_rng(0)
        reference = rng.uniform(0.0, 360.0, 10_000)
        code = 360.0 / 2**bits
        reading = np.mod(np.round((reference + low_harmonics(reference) / 60.0) / code) * code, 360.0)
        error = (np.mod(reading - reference + 180.0, 360.0) - 180.0) * 60.0
        print(f"{bits}-bit, 10^4 random stops (uniform draws, seed 0, no noise): "
              f"{_median_cpu(reading, error, repeats):.2f} s CPU, median of {repeats}")


def divides_codes(grid):
    """The limit: stops that divide the 2^B codes (seed 5, uniform, the profile at full scale)."""
    for bits, stops in ((12, 1024), (12, 2048), (14, 2048), (14, 4096)):
        reading, error = quantised_sweep(bits, stops, False, 1.0, 5)
        model = fit_spectral(reading, error)
        truth = low_harmonics_at_encoder_angles(grid)
        off = float(np.sqrt(np.mean((model.predict(grid) - truth) ** 2)))
        least = float(np.sqrt(np.mean((least_squares_of_true_orders(reading, error, grid) - truth) ** 2)))
        false_lines = sorted(set(model.training["lines"]) - set(TRUE_ORDERS))
        print(f"{bits}-bit, {stops} stops: RMS off the truth {off:.3f} arcmin, least squares of the true orders "
              f"{least:.3f}, lines {sorted(model.training['lines'])} (false: {false_lines})")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1], help="seeds of the stops (default 0 1)")
    parser.add_argument("--baselines", action="store_true", help="also the plain baselines on the seed-0 sweeps")
    parser.add_argument("--timing", action="store_true",
                        help="only the median CPU of 3 fits of the timed cases of docs/model-selection.md")
    parser.add_argument("--divides-codes", action="store_true",
                        help="only the limit's cases: stops that divide the 2^B codes")
    args = parser.parse_args()
    grid = np.arange(0.0, 360.0, 0.018)
    if args.timing:
        timing()
        return
    if args.divides_codes:
        divides_codes(grid)
        return
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
        largest = float(np.max(np.abs(model.predict(grid) - truth)))
        rows.append((jitter, len(false_lines), off, least, cpu, largest))
        print(f"{bits:4d}  {stops:5d}  {'yes' if jitter else 'no':>6}  {scale:5.1f}  {seed:4d}  {len(false_lines):11d}"
              f"  {off:13.4f}  {least:13.4f}  {off / least:5.2f}  {cpu:5.2f}")
    for jitter in (False, True):
        part = [row for row in rows if row[0] == jitter]
        print(f"{'jittered' if jitter else 'uniform'} ({len(part)} sweeps): false lines {sum(r[1] for r in part)}, "
              f"worst RMS off the truth {max(r[2] for r in part):.3f} arcmin, worst least-squares fit of the true "
              f"orders {max(r[3] for r in part):.3f}, worst ratio {max(r[2] / r[3] for r in part):.2f}, "
              f"largest error off the truth {max(r[5] for r in part):.2f}")
    print(f"CPU of the fits: {sum(r[4] for r in rows):.1f} s in all")
    if args.baselines:
        baselines(grid)


if __name__ == "__main__":
    main()

"""encal drift's verdict on pure-noise repeats: how much the residual grows, and how often a repeat "does not hold".

Usage::

    python benchmarks/bench_drift.py            # 200 seeds, about half a minute

Each seed draws two calibrations of one profile (orders 1, 2 and 5: the construction of
tests/reports/test_drift.py) with fresh noise of 0.3 arcmin and nothing else changed, and judges the second by
``compare_calibrations`` (the paper's ten largest harmonics fitted on the first, resolution unknown unless said).
Printed per grid: the standard deviation over the seeds of ``(rms_k - rms_e) / rms_e`` (the later calibration's
residual against the residual expected on an unchanged repeat; the tolerance is three of it, ``3/sqrt(n)``), the
share of repeats that do not hold, and how much the residual grows on a repeat over the first calibration's own
(the reference before 2026-11-28) for the ten harmonics, a linear table and auto; docs/drift.md quotes them.
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from encal.reports.drift import compare_calibrations  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.reports.test_drift import calibration, profile  # noqa: E402

NOISE = 0.3
SEEDS = range(200)


def repeats(points, method="fourier", bits=None):
    """(relative excess, holds, residual on the repeat, the first's own residual) for each seed's pure-noise
    repeat."""
    grid = np.arange(points) * 360.0 / points
    rows = []
    for seed in SEEDS:
        first, later = (calibration(grid, profile(grid), 2 * seed + k, noise=NOISE, resolution_bits=bits)
                        for k in range(2))
        report = compare_calibrations([first, later], method=method, rng=0).as_dict()
        epoch = report["epochs"][0]
        rows.append(((epoch["residual_rms_arcmin"] - epoch["expected_rms_arcmin"]) / epoch["expected_rms_arcmin"],
                     epoch["holds"], epoch["residual_rms_arcmin"], report["baseline_rms_arcmin"]))
    return np.array(rows, dtype=float)


def main():
    start = time.process_time()
    print(f"# encal drift on pure-noise repeats: noise {NOISE} arcmin, {len(SEEDS)} seeds; load "
          f"{open('/proc/loadavg').read().split()[0]}\n")
    for points, bits in ((180, None), (720, None), (180, 16), (180, 12)):
        rows = repeats(points, bits=bits)
        print(f"{points} points, {'resolution unknown' if bits is None else f'{bits} bits'}: (rms_k - rms_e) / rms_e "
              f"standard deviation {rows[:, 0].std(ddof=1):.3f} (3/sqrt(n) = {3 / np.sqrt(points):.3f}); do not hold "
              f"{100 * np.mean(rows[:, 1] == 0):.1f} %")
    for method in ("fourier", "auto", "lut"):
        rows = repeats(180, method=method)
        if method == "lut":  # it passes through its points: its own residual is 0
            print(f"180 points, lut: its own residual {rows[:, 3].max():.2g}, on a repeat {np.mean(rows[:, 2]):.3f} "
                  f"arcmin ({np.mean(rows[:, 2]) / NOISE:.3f} times the noise)")
        else:
            print(f"180 points, {method}: the residual on a repeat over the first's own, mean growth "
                  f"{100 * np.mean(rows[:, 2] / rows[:, 3] - 1.0):.0f} %")
    print(f"\nCPU time {time.process_time() - start:.0f} s")


if __name__ == "__main__":
    main()

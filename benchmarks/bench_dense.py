"""The automatic choice on a dense calibration: 10,000 points.

Usage::

    python benchmarks/bench_dense.py        # the spectral model (auto's default), under a second
    python benchmarks/bench_dense.py --cv   # the cross-validated choice (folds=5), about a minute on 2 cores
    python benchmarks/bench_dense.py --select-cv  # fit_fourier(select='cv') alone: orders kept, error, CPU

A metrology lab may calibrate at every 0.036 degrees. This script times
``encal.fit(cal, rng=0)`` (method ``auto``) on such a calibration: orders 1 and
2 (3 and 0.9 arcmin) and white noise of 0.1 arcmin, and prints the CPU time of
the whole fit, the choice, and with ``--cv`` (``folds=5``: the cross-validated choice of
docs/model-selection.md) each candidate's cross-validation wall time (``time_s`` of the CV table).
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import encal  # noqa: E402


def _three_orders(theta_deg):
    """The profile of docs/model-selection.md's select='cv' figures: a constant and orders 1, 2 and 16 (3, 1 and
    0.3 arcmin; the constant and the phases are this script's)."""
    r = np.radians(theta_deg)
    return 0.5 + 3.0 * np.cos(r + 0.2) + 1.0 * np.cos(2 * r - 0.7) + 0.3 * np.cos(16 * r + 1.1)


def select_cv():
    """``fit_fourier(theta, truth + noise, select='cv')`` on complete uniform grids (noise 0.15 arcmin, seeds 0 and
    1): orders kept and RMS against the truth on 7,919 angles, beside a fit of the true orders; then its CPU on
    10,000 points of a 12,500-point grid (``grid_points``) and on a complete 2,000-point grid (noise 0.1)."""
    from encal.models.fourier import fit_fourier

    test = np.arange(7919) * 360.0 / 7919
    print(f"# fit_fourier(select='cv'); load {open('/proc/loadavg').read().split()[0]}\n")
    print("| points | seed | orders kept | RMS off the truth | the true orders' fit |")
    print("|---|---|---|---|---|")
    for n in (180, 500, 2000):
        theta = np.arange(n) * 360.0 / n
        for seed in (0, 1):
            y = _three_orders(theta) + np.random.default_rng(seed).normal(0.0, 0.15, n)
            model = fit_fourier(theta, y, select="cv")
            true = fit_fourier(theta, y, orders=[0, 1, 2, 16])
            off = [float(np.sqrt(np.mean((m.predict(test) - _three_orders(test)) ** 2))) for m in (model, true)]
            print(f"| {n} | {seed} | {len(model.orders)} | {off[0]:.3f} | {off[1]:.3f} |")
    rng = np.random.default_rng(0)
    nodes = np.sort(rng.choice(12_500, 10_000, replace=False))
    for label, theta, grid in (("10,000 of a 12,500-point grid", nodes * 360.0 / 12_500, 12_500),
                               ("a complete 2,000-point grid", np.arange(2000) * 0.18, None)):
        y = _three_orders(theta) + rng.normal(0.0, 0.1, theta.size)
        start = time.process_time()
        model = fit_fourier(theta, y, select="cv", grid_points=grid)
        print(f"\n{label}: {time.process_time() - start:.2f} s CPU, {len(model.orders)} orders kept")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cv", action="store_true", help="the cross-validated choice (folds=5) instead of auto")
    parser.add_argument("--select-cv", action="store_true", help="only fit_fourier(select='cv'): orders, error, CPU")
    args = parser.parse_args()
    if args.select_cv:
        select_cv()
        return
    rng = np.random.default_rng(1)
    reference = np.arange(10_000) * 0.036
    error = (3.0 * np.sin(np.radians(reference)) + 0.9 * np.cos(np.radians(2 * reference))
             + rng.normal(0.0, 0.1, reference.size))
    cal = encal.Calibration(reference, reference + error / 60.0)
    print(f"# {'the cross-validated choice' if args.cv else 'auto'} on 10,000 points; python "
          f"{platform.python_version()}, numpy {np.__version__}, {os.cpu_count()} cores, "
          f"load {open('/proc/loadavg').read().split()[0]}\n")
    start = time.process_time()
    model = encal.fit(cal, rng=0, **({"folds": 5} if args.cv else {}))
    seconds = time.process_time() - start
    selection = model.training["selection"]
    print(f"whole fit: {seconds:.1f} s CPU; chose {selection['chosen']}\n")
    print("| candidate | CV wall time (s) |")
    print("|---|---|")
    for row in selection["table"]:
        print(f"| {row['label']} | {row['time_s']:.1f} |")


if __name__ == "__main__":
    main()

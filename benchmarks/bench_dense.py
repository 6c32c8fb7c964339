"""The automatic choice on a dense calibration: 10,000 points.

Usage::

    python benchmarks/bench_dense.py        # about a minute on 2 cores

A metrology lab may calibrate at every 0.036 degrees. This script times
``encal.fit(cal, rng=0)`` (method ``auto``) on such a calibration: orders 1 and
2 (3 and 0.9 arcmin) and white noise of 0.1 arcmin, and prints the CPU time of
the whole fit, the choice, and each candidate's cross-validation wall time
(``time_s`` of the CV table).
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import platform  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import encal  # noqa: E402


def main():
    rng = np.random.default_rng(1)
    reference = np.arange(10_000) * 0.036
    error = (3.0 * np.sin(np.radians(reference)) + 0.9 * np.cos(np.radians(2 * reference))
             + rng.normal(0.0, 0.1, reference.size))
    cal = encal.Calibration(reference, reference + error / 60.0)
    print(f"# auto on 10,000 points; python {platform.python_version()}, numpy {np.__version__}, "
          f"{os.cpu_count()} cores\n")
    start = time.process_time()
    model = encal.fit(cal, rng=0)
    seconds = time.process_time() - start
    selection = model.training["selection"]
    print(f"whole fit: {seconds:.1f} s CPU; chose {selection['chosen']}\n")
    print("| candidate | CV wall time (s) |")
    print("|---|---|")
    for row in selection["table"]:
        print(f"| {row['label']} | {row['time_s']:.1f} |")


if __name__ == "__main__":
    main()

"""``encal.fit`` called from a Python program, with and without the BLAS thread variables set.

    python benchmarks/bench_threads.py [--repeats 15]

A program that imports encal does not set ``OMP_NUM_THREADS`` or ``OPENBLAS_NUM_THREADS``; encal's own
command line and Makefile do. This runs the same script in fresh processes, alternately with every thread
variable unset and with ``OPENBLAS_NUM_THREADS=OMP_NUM_THREADS=1``, and prints the median seconds of
``encal.fit`` (the default model, and a 1:20:1 network with trainlm) on 180 points of a 2° grid and on 180
random angles, and the ratio unset / pinned. encal limits BLAS to one thread around its own work
(threadpoolctl), so the ratio should be near 1.
"""

import argparse
import os
import statistics
import subprocess
import sys

SCRIPT = r"""
import time, numpy as np, encal
rng = np.random.default_rng(0)
def cal(reference):
    r = np.radians(reference)
    error = 3 * np.sin(r + 0.3) + 1.2 * np.cos(2 * r) + 0.4 * np.sin(16 * r) + rng.normal(0, 0.05, r.size)
    return encal.Calibration(reference, reference + error / 60)
cases = {"grid": cal(np.arange(0.0, 360.0, 2.0)), "random": cal(np.sort(rng.uniform(0, 360, 180)))}
encal.fit(cases["grid"], rng=0)  # imports and first-call costs outside the timing
for name, c in cases.items():
    for method, options in (("auto", {}), ("ann", {"hidden": 20, "algorithm": "trainlm", "epochs": 100})):
        start = time.perf_counter()
        encal.fit(c, method=method, rng=0, **options)
        print(name, method, time.perf_counter() - start)
"""

VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def run(pinned):
    env = {key: value for key, value in os.environ.items() if key not in VARIABLES}
    if pinned:
        env.update(OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, check=True).stdout
    return {(line.split()[0], line.split()[1]): float(line.split()[2]) for line in out.splitlines()}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()
    times = {True: [], False: []}
    for _ in range(args.repeats):  # interleaved, so a change in the machine's load hits both alike
        for pinned in (False, True):
            times[pinned].append(run(pinned))
    print(f"# {args.repeats} fresh processes each, interleaved; {os.cpu_count()} cores; load average "
          f"{os.getloadavg()[0]:.2f}\n")
    print("| stops | method | unset, median s | pinned to 1, median s | unset / pinned |")
    print("|---|---|---:|---:|---:|")
    for key in times[True][0]:
        unset = statistics.median(run_[key] for run_ in times[False])
        pinned = statistics.median(run_[key] for run_ in times[True])
        print(f"| {key[0]} | {key[1]} | {unset:.4f} | {pinned:.4f} | {unset / pinned:.2f} |")


if __name__ == "__main__":
    main()

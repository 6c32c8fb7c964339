"""``encal report`` on dense motor logs: wall time and peak memory against the number of rows.

    python benchmarks/bench_report.py [--rows 20000 200000 1000000] [--with-comparison 20000]

Each log is one slow turn sampled at jittered reference angles (each row in its own slot of 360/rows
degrees, so no two rows share a stop) with
orders 1, 2, 16 and a 200-step detent at order 200 (3, 1.5, 0.6 and 0.3 arcmin) plus 0.1 arcmin of
noise, written with 10 decimals. Every report runs as its own process (``python -m encal report LOG -o
r.html --seed 0``), timed by wall clock; its peak memory is that process's maximum resident set size. By
default the comparison of the candidate families is left out above 5000 rows
(``encal.reports.encoder.COMPARISON_MAX_POINTS``); ``--with-comparison N`` also times the log of N rows
with ``--comparison``, and prints the ratio. This is the table of BENCHMARKS.md "encal report on dense
logs".
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def write_log(path, rows, seed=1):
    rng = np.random.default_rng(seed)
    reference = (np.arange(rows) + rng.uniform(0.1, 0.9, rows)) * (360.0 / rows)
    r = np.radians(reference)
    error = (3.0 * np.sin(r + 0.3) + 1.5 * np.sin(2 * r + 1.1) + 0.6 * np.sin(16 * r + 2.0)
             + 0.3 * np.sin(200 * r) + rng.normal(0.0, 0.1, rows))
    encoder = (reference + error / 60.0) % 360.0
    np.savetxt(path, np.c_[reference, encoder], delimiter=",", header="reference_deg,encoder_deg", comments="",
               fmt="%.10f")


#: Runs encal report in a fresh process and prints that process's peak resident set size (KiB) last.
_CHILD = ("import resource, sys\nfrom encal.cli import main\nstatus = main(sys.argv[1:])\n"
          "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)\nsys.exit(status)")


def run_report(log, out, *extra):
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", _CHILD, "report", str(log), "-o", str(out), "--seed", "0", *extra],
                          capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"encal report failed on {log}: {done.stderr.strip()}")
    return seconds, int(done.stderr.strip().splitlines()[-1]) / 1024.0  # KiB -> MiB


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, nargs="+", default=[20_000, 200_000, 1_000_000])
    parser.add_argument("--with-comparison", type=int, default=20_000, metavar="N")
    args = parser.parse_args()
    print(f"# python {sys.version.split()[0]}, {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.2f} before\n")
    print("| rows | options | wall s | peak MiB |")
    print("|---:|---|---:|---:|")
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        timed = {}
        for rows in sorted(set(args.rows) | {args.with_comparison}):
            log = folder / f"log{rows}.csv"
            write_log(log, rows)
            runs = [()] + ([("--comparison",)] if rows == args.with_comparison else [])
            for extra in runs:
                seconds, peak = run_report(log, folder / "r.html", *extra)
                timed[(rows, extra)] = seconds
                print(f"| {rows} | {' '.join(extra) or '(default)'} | {seconds:.1f} | {peak:.0f} |")
        n = args.with_comparison
        print(f"\nat {n} rows: --comparison / default = {timed[(n, ('--comparison',))] / timed[(n, ())]:.1f}")
    print(f"load average {os.getloadavg()[0]:.2f} after")


if __name__ == "__main__":
    main()

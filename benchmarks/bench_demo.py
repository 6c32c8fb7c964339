"""Time ``encal demo`` end to end and per stage, and show which fits dominate.

Usage:
    .venv/bin/python benchmarks/bench_demo.py [--quick] [--workers N] [--out DIR]

Runs the demo exactly as ``encal demo`` does (same settings, worker processes
and files), in this process so that the stage timings and the CPU time of
every fit can be read from its result, then prints:

- the machine (CPU count, load average before the run, versions);
- wall-clock time per stage, and the CPU time of the worker processes;
- CPU seconds per stage and per training algorithm, summed over fits: the
  time two idle cores need is about their sum / 2;
- the start-up time of the ``encal`` command (interpreter and imports).
"""

import argparse
import io
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time


def _children_cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _startup_seconds(repeats=3):
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "encal", "--version"], check=True, capture_output=True)
        best = min(best, time.perf_counter() - start)
    return best


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="time the --quick demo")
    parser.add_argument("--workers", type=int, default=None, help="worker processes (default: as encal demo)")
    parser.add_argument("--out", help="folder for the demo's files (default: a temporary folder)")
    args = parser.parse_args()

    import numpy
    import scipy

    from encal._version import __version__
    from encal.paper.demo import run_demo

    load = os.getloadavg()
    print(f"machine: {platform.machine()}, {os.cpu_count()} CPUs, {platform.platform()}")
    print(f"python {platform.python_version()}, numpy {numpy.__version__}, scipy {scipy.__version__}, "
          f"encal {__version__}")
    print(f"load average before the run (1, 5, 15 min): {load[0]:.2f}, {load[1]:.2f}, {load[2]:.2f}")
    startup = _startup_seconds()

    with tempfile.TemporaryDirectory() as scratch:
        out = args.out or os.path.join(scratch, "encal-demo")
        cpu_self, cpu_children = time.process_time(), _children_cpu()
        start = time.perf_counter()
        result = run_demo(out, quick=args.quick, workers=args.workers, progress=False, stdout=io.StringIO())
        wall = time.perf_counter() - start
        cpu_self, cpu_children = time.process_time() - cpu_self, _children_cpu() - cpu_children

    print(f"\nencal demo{' --quick' if args.quick else ''}: {wall:.1f} s wall with {result.workers} worker "
          f"process(es); CPU {cpu_self:.1f} s in this process + {cpu_children:.1f} s in workers; "
          f"`encal` start-up {startup:.2f} s\n")
    print("| stage | wall (s) |")
    print("|---|---:|")
    for stage, seconds in result.timings.items():
        print(f"| {stage} | {seconds:.1f} |")

    sweep, algorithms = result.sweep, result.algorithms
    rows = [(f"per-encoder fits, {name}", encoder.cpu_s, 1) for name, encoder in result.encoders.items()]
    rows += [(f"hidden-node sweep, {a}", float(sweep.cpu_s[a].sum()), sweep.cpu_s[a].size) for a in sweep.algorithms]
    rows += [(f"Table 2, {r.algorithm}", float(r.cpu_s.sum()), r.cpu_s.size) for r in algorithms.rows]
    print("\n| fits | CPU (s) | fits | CPU per fit (s) |")
    print("|---|---:|---:|---:|")
    for name, seconds, count in sorted(rows, key=lambda row: -row[1]):
        print(f"| {name} | {seconds:.1f} | {count} | {seconds / count:.2f} |")
    total = sum(row[1] for row in rows)
    print(f"\nall fits: {total:.1f} CPU s; on two idle cores that is about {total / 2:.1f} s of wall-clock time")


if __name__ == "__main__":
    main()

"""``encal selfcal spin`` on a dense log against a plain NumPy script of the same least squares.

Usage::

    PYTHONPATH=src python benchmarks/bench_selfcal_speed.py [--rows 200000] [--repeats 5] [--other-src PATH]

A spin log of ``--rows`` samples (two runs, at 2 and 4 rev/s, of a 7-pole-pair motor, ``encal.selfcal.synthetic``)
is written with ``write_spin_log``. The two commands run alternately as whole processes with one BLAS thread:

* ``python -m encal selfcal spin LOG --pole-pairs 7 -o CAL.csv``;
* a NumPy script that reads the log with ``np.loadtxt``, unwraps each run and solves, per run, the normal
  equations of a cubic polynomial per knot interval in time (no B-spline library: truncated powers) plus
  32 Fourier orders in the reading (powers of exp(i theta)), accumulated in blocks of 20000 samples.

``--other-src`` adds a third command, encal from another source folder (``before``), to each round.
The table gives the median wall time, the median of the pair ratios (min-max) and the peak resident memory.
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

NUMPY_SPIN = """
import sys
import numpy as np
table = np.loadtxt(sys.argv[1], delimiter=",", skiprows=1)
orders = np.arange(1, 33)
for run in np.unique(table[:, 2]):
    rows = table[table[:, 2] == run]
    time, phase = rows[:, 0], np.unwrap(rows[:, 1], period=360.0)
    revolutions = abs(phase[-1] - phase[0]) / 360.0
    knots = np.linspace(time[0], time[-1], max(2, int(revolutions // 4)) + 1)[1:-1]
    width = 4 + knots.size + 2 * orders.size
    normal, right = np.zeros((width, width)), np.zeros(width)
    for start in range(0, time.size, 20000):
        t, p = time[start:start + 20000], phase[start:start + 20000]
        scaled = (t - time[0]) / (time[-1] - time[0])
        smooth = np.column_stack([scaled ** d for d in range(4)]
                                 + [np.maximum(t - k, 0.0) ** 3 / (time[-1] - time[0]) ** 3 for k in knots])
        powers = np.cumprod(np.repeat(np.exp(1j * np.radians(p))[:, None], orders.size, axis=1), axis=1)
        x = np.hstack([smooth, powers.real, powers.imag])
        normal += x.T @ x
        right += x.T @ (p - phase[0])
    coefficients = np.linalg.lstsq(normal, right, rcond=None)[0][4 + knots.size:]
np.save(sys.argv[2], coefficients)
"""


def run_process(command, env):
    """Wall seconds and peak resident MiB of one process. The peak is GNU time's (``/usr/bin/time -f %M``): a
    child forked from this process counts this process's pages until it execs, so its own ``ru_maxrss`` would
    be this benchmark's size."""
    start = time.perf_counter()
    process = subprocess.run(["/usr/bin/time", "-f", "peak_kib %M", *map(str, command)], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    if process.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, command))} failed: {process.stderr.strip()[-400:]}")
    peak = next(line for line in reversed(process.stderr.splitlines()) if line.startswith("peak_kib "))
    return wall, int(peak.split()[1]) / 1024.0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=200_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--other-src", help="another encal source folder, timed as 'before'")
    args = parser.parse_args()
    from encal.selfcal.synthetic import draw_magnetic_encoder, make_motor, simulate_spin
    from encal.selfcal.spin import SpinLog
    from encal.selfcal.spin_log import write_spin_log

    motor, encoder = make_motor(7, 12, 3), draw_magnetic_encoder(31, eccentricity_deg=1.0)
    rate = 2000.0
    per_run = args.rows // 2
    runs = [simulate_spin(motor, encoder, speed, revolutions=per_run / rate * speed, sample_rate_hz=rate, rng=seed)
            for speed, seed in ((2.0, 1), (4.0, 2))]
    here = str(Path(__file__).resolve().parents[1] / "src")
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", PYTHONPATH=here)
    print(f"spin log of {sum(r.time_s.size for r in runs)} rows (2 runs), {args.repeats} rounds, load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as folder:
        log = Path(folder) / "spin.csv"
        write_spin_log(log, [SpinLog(r.time_s, r.encoder_deg) for r in runs])
        script = Path(folder) / "numpy_spin.py"
        script.write_text(NUMPY_SPIN)
        encal = [sys.executable, "-m", "encal", "selfcal", "spin", str(log), "--pole-pairs", "7",
                 "-o", str(Path(folder) / "cal.csv")]
        commands = {"encal selfcal spin": (encal, env),
                    "NumPy script": ([sys.executable, str(script), str(log), str(Path(folder) / "c.npy")], env)}
        if args.other_src:
            commands["encal selfcal spin (before)"] = (encal, dict(env, PYTHONPATH=args.other_src))
        for command, command_env in commands.values():
            run_process(command, command_env)
        results = {name: [] for name in commands}
        for _ in range(args.repeats):
            for name, (command, command_env) in commands.items():
                results[name].append(run_process(command, command_env))
    results = {name: np.array(values) for name, values in results.items()}
    peer = results["NumPy script"]
    print("\n| command | wall s (median) | / NumPy script, paired (min-max) | peak MiB |\n|---|---|---|---|")
    for name, values in results.items():
        ratio = values[:, 0] / peer[:, 0]
        print(f"| {name} | {np.median(values[:, 0]):.3g} | {np.median(ratio):.2f} ({ratio.min():.2f}-{ratio.max():.2f})"
              f" | {np.median(values[:, 1]):.0f} |")
    print(f"\nload average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()

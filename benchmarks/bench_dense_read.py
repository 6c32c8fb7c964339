"""Dense files: ``read_calibration`` against ``np.loadtxt``, ``encal fit`` against a plain NumPy script.

Usage::

    PYTHONPATH=src python benchmarks/bench_dense_read.py [--rows 1000000] [--repeats 5] [--files sweep,random]
    PYTHONPATH=src python benchmarks/bench_dense_read.py --phases

(``PYTHONPATH`` names the encal measured, in this process and in the ``encal fit`` processes.)

Two files of ``--rows`` rows are written to a temporary folder: a dense sweep (5 revolutions over the same
stops, orders 1, 2, 16, 32, 48 and 0.1 arcmin of noise, as ``benchmarks/dense_sweep.py``) and uniformly random
reference angles written with ``%.10f`` (where two angles agree to 9 decimals about three times in 10^6: they
must not be refused as one stop read twice). Every comparison is paired and interleaved (A B A B ...) so that
the ratio holds on a loaded machine; the table gives medians and the median of the pair ratios.

* ``read_calibration`` and ``np.loadtxt(delimiter=',', skiprows=1)`` of the same file, in this process (CPU
  time, ``time.process_time``: on a shared machine the wall time also counts the other programs).
* ``python -m encal fit FILE -o MODEL`` and a NumPy script that reads the same file with ``np.loadtxt`` and
  fits Fourier orders 1 to 16 by projection, each a whole process (CPU time, user + system, wall time, and peak
  resident memory, all from GNU ``/usr/bin/time``), both with one BLAS thread and Python's bytecode kept from the
  warm-up run on (in the temporary folder), as an installed package has it.
* ``encal fit FILE --method fourier --orders 1,...,16``: the script's own fit (Fourier orders 1 to 16, by least
  squares), with encal's checks and its held-out estimate (five refits), against the script.
* The same NumPy script that also imports what the spectral fit cannot do without, SciPy's optimiser (L-BFGS-B)
  and LAPACK (``scipy.optimize``, ``scipy.linalg``), and uses neither: the part of the ratio that is the
  imports', not the fit's (the "+ SciPy" rows).
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

NUMPY_FIT = """
import sys
import numpy as np
table = np.loadtxt(sys.argv[1], delimiter=",", skiprows=1)
reference, encoder = np.radians(table[:, 0]), np.radians(table[:, 1])
error = np.angle(np.exp(1j * (encoder - reference))) * 10800 / np.pi
z = np.exp(1j * encoder)
zk = np.ones_like(z)
coefficients = []
for order in range(1, 17):
    zk *= z
    coefficients.append(2.0 * np.mean(error * zk.conj()))
np.save(sys.argv[2], np.asarray(coefficients))
"""

#: The NumPy script with the imports of the spectral fit's SciPy modules (used by encal, not by the script).
NUMPY_FIT_WITH_SCIPY_IMPORTS = "import scipy.linalg, scipy.optimize\n" + NUMPY_FIT


def write_files(folder, rows, seed=0):
    rng = np.random.default_rng(seed)
    harmonics = ((1, 3.0, 0.3), (2, 1.5, 1.1), (16, 0.6, 2.0), (32, 0.3, 0.5), (48, 0.2, 2.5))

    def readings(reference):
        error = sum(a * np.cos(np.radians(k * reference) + p) for k, a, p in harmonics)
        return np.mod(reference + (error + rng.normal(0.0, 0.1, reference.size)) / 60.0, 360.0)

    stops = rows // 5
    sweep = np.tile(np.arange(stops) * 360.0 / stops, 5)
    random = rng.uniform(0.0, 360.0, rows)
    files = {}
    for name, reference in (("sweep", sweep), ("random", random)):
        path = Path(folder) / f"{name}.csv"
        np.savetxt(path, np.c_[reference, readings(reference)], fmt="%.10f", delimiter=",",
                   header="reference_deg,encoder_deg", comments="")
        files[name] = path
    return files


def paired(first, second, repeats):
    """CPU seconds of ``first()`` and ``second()`` run alternately, after one warm-up of each."""
    first(), second()
    a, b = [], []
    for _ in range(repeats):
        for call, times in ((first, a), (second, b)):
            start = time.process_time()
            call()
            times.append(time.process_time() - start)
    return np.array(a), np.array(b)


def run_process(command, env):
    """CPU seconds (user + system), wall seconds and peak resident MiB of one process, from GNU time
    (``/usr/bin/time``): a child forked from this process counts this process's pages until it execs, so its own
    ``ru_maxrss`` would be this benchmark's size."""
    process = subprocess.run(["/usr/bin/time", "-f", "usage %U %S %e %M", *map(str, command)], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if process.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, command))} failed: {process.stderr.strip()[-400:]}")
    usage = next(line for line in reversed(process.stderr.splitlines()) if line.startswith("usage "))
    user, system, wall, peak = map(float, usage.split()[1:])
    return user + system, wall, peak / 1024.0


def row(label, a, b, unit="s"):
    return f"| {label} | {np.median(a):.3g} {unit} | {np.median(b):.3g} {unit} | {np.median(a / b):.2f} " \
           f"({np.min(a / b):.2f}-{np.max(a / b):.2f}) |"


PHASES = """
import sys, time, tracemalloc
from encal.cli import main, cmd_fit
from encal.models import auto
measure_memory = sys.argv[2] == "memory"
figures = {}
def timed(module, name, label):
    function = getattr(module, name)
    def wrapper(*args, **kwargs):
        start, base = time.process_time(), tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        try:
            return function(*args, **kwargs)
        finally:
            figures[label] = (time.process_time() - start, base, tracemalloc.get_traced_memory()[1])
    setattr(module, name, wrapper)
timed(cmd_fit, "read_calibration_from_args", "reading")
timed(auto, "fit_spectral", "fit_spectral")
if measure_memory:
    tracemalloc.start()
main(["fit", sys.argv[1], "-o", sys.argv[3]])
total = time.process_time()
for label, (cpu, base, peak) in figures.items():
    if measure_memory:
        print(f"{label}: {base / 2**20:.1f} MiB live at its start, its peak {peak / 2**20:.1f} MiB (traced)",
              file=sys.stderr)
    else:
        print(f"{label}: {cpu:.2f} s CPU of the process's {total:.2f} s ({cpu / total:.0%})", file=sys.stderr)
"""


def phases(files, folder, env):
    """CPU time of the reading and of ``fit_spectral`` within one ``encal fit`` process each, and the memory
    traced (``tracemalloc``, in a second run: it slows NumPy's allocations) at their start and peak."""
    first = next(iter(files.values()))  # a warm-up run, not shown: it compiles the bytecode
    subprocess.run([sys.executable, "-c", PHASES, str(first), "cpu", str(Path(folder) / "m.json")], env=env,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for name, path in files.items():
        for what in ("cpu", "memory"):
            process = subprocess.run([sys.executable, "-c", PHASES, str(path), what, str(Path(folder) / "m.json")],
                                     env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            print("\n".join(f"{name}: {line}" for line in process.stderr.strip().splitlines()))


def _process_env(folder):
    """The environment of the measured processes: one BLAS thread, and Python's bytecode kept (in ``folder``, not
    the source tree) from the warm-up run on, as an installed package has it (pip compiles it); with
    ``PYTHONDONTWRITEBYTECODE`` set and no cache, every ``encal fit`` compiled encal's modules again (0.07 s CPU)."""
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               PYTHONPYCACHEPREFIX=str(Path(folder) / "bytecode"))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--files", default="sweep,random", help="which files: sweep, random or both")
    parser.add_argument("--phases", action="store_true",
                        help="only the share of the reading and of the spectral fit in one encal fit of each file")
    args = parser.parse_args()
    import warnings

    from encal import read_calibration

    print(f"rows {args.rows}, {args.repeats} pairs each, load average {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as folder:
        files = {name: path for name, path in write_files(folder, args.rows).items()
                 if name in args.files.split(",")}
        if args.phases:
            phases(files, folder, _process_env(folder))
            return
        print("\n| in one process, CPU | read_calibration | np.loadtxt | ratio (min-max) |\n|---|---|---|---|")
        for name, path in files.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                a, b = paired(lambda: read_calibration(path),
                              lambda: np.loadtxt(path, delimiter=",", skiprows=1), args.repeats)
            print(row(f"{name} file", a, b))
        script = Path(folder) / "numpy_fit.py"
        script.write_text(NUMPY_FIT)
        with_scipy = Path(folder) / "numpy_fit_scipy_imports.py"
        with_scipy.write_text(NUMPY_FIT_WITH_SCIPY_IMPORTS)
        env = _process_env(folder)
        print("\n| whole process | encal fit | NumPy script | ratio (min-max) |\n|---|---|---|---|")
        for name, path in files.items():
            encal = [sys.executable, "-m", "encal", "fit", str(path), "-o", str(Path(folder) / "model.json")]
            plain = [sys.executable, str(script), str(path), str(Path(folder) / "coefficients.npy")]
            imports = [sys.executable, str(with_scipy), str(path), str(Path(folder) / "coefficients.npy")]
            same_fit = encal[:5] + ["--method", "fourier", "--orders", ",".join(map(str, range(1, 17)))] + encal[5:]
            commands = {"encal": encal, "plain": plain, "imports": imports, "same": same_fit}
            for command in commands.values():
                run_process(command, env)
            results = {key: [] for key in commands}
            for _ in range(max(1, args.repeats - 2)):
                for key, command in commands.items():
                    results[key].append(run_process(command, env))
            encal_runs, plain_runs, import_runs, same_runs = (np.array(results[key]) for key in commands)
            print(row(f"{name}: CPU", encal_runs[:, 0], plain_runs[:, 0]))
            print(row(f"{name}: wall", encal_runs[:, 1], plain_runs[:, 1]))
            print(row(f"{name}: peak memory", encal_runs[:, 2], plain_runs[:, 2], unit="MiB"))
            print(row(f"{name}: CPU, against the script + SciPy's imports", encal_runs[:, 0], import_runs[:, 0]))
            print(row(f"{name}: the script + SciPy's imports, CPU, against the script", import_runs[:, 0],
                      plain_runs[:, 0]))
            print(row(f"{name}: the script's fit (`--method fourier --orders 1..16`), CPU", same_runs[:, 0],
                      plain_runs[:, 0]))
            print(row(f"{name}: the script's fit, peak memory", same_runs[:, 2], plain_runs[:, 2], unit="MiB"))
    print(f"\nload average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()

"""The hot paths beside their limits: every figure a ratio measured in one run.

    python benchmarks/bench_hotpaths.py [--before REV] [--only SECTION,...] [--quick] [--lines N]

On a machine that other work shares absolute timings drift, so each row times
a hot path and its limit (or peer) side by side, interleaved, best of several
repeats of CPU time, and reports their ratio. With ``--before REV`` (a git
revision of this repository) the same measurement also runs on that
revision's ``src`` (extracted with ``git archive`` into a temporary folder),
interleaved with the current one: before and after in one run.

Sections:

- ``c``: the exported C (``gcc -O2``), ns per reading of ``<prefix>_correct_counts``
  for the int16 table against a plain C lookup of the same table (a function
  in its own file doing ``table[code & mask] * scale``, the limit), and of
  the formula forms (before against after, with their libm calls per reading);
- ``correct``: ``Model.correct`` / ``predict`` in NumPy on 10^7 angles: ns per angle and
  peak memory against the dense table's lookup and a vectorised formula;
- ``trigsums``: the harmonic sums of 10^5 angles by direct products, encal's NumPy NUFFT, the
  ``finufft`` library when installed (not a dependency), and the FFT on a grid within a tolerance
  (with its stated error bound);
- ``trainlm``: one trainlm epoch (raw 1:80:1, 180 points) against the back-to-back
  BLAS/LAPACK calls it makes;
- ``fits``: whole 1000-epoch fits of the demo's costliest Table 2 algorithms (trainlm, trainbr,
  trainbfg), CPU seconds and a hash of the weights, before against after;
- ``stream``: ``encal correct`` lines per CPU second (a file, a pipe, ``--exact``) against a plain NumPy
  script, with and without the start-up;
- ``series``: a Fourier series on one chunk of angles (8,192), ns per angle of the direct form
  (``cos`` and ``sin`` of every ``k θ``) against the recurrence from one ``cos`` and ``sin`` along addition
  chains: through every order up to the highest, by squaring each order, by the difference from the previous
  order, and the planned chain (the cheaper route per order), with their numbers of products, and the spectral
  model's evaluator (Taylor expansion about the nodes of tables); the form ``HarmonicSeries`` chooses;
- ``startup``: the start-up of ``encal correct`` on an empty file and of ``encal --help``, and
  ``encal correct`` lines/s with the start-up counted (10^6 and 10^7 lines, a file and a pipe, a table
  and a Fourier model), wall and CPU seconds of the one process, before against after;

The load average is printed at the start and the end.
"""

import argparse
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np

from _ctiming import machine, timing_driver  # benchmarks/_ctiming.py

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"

C_LOOKUP = """\
#include <stdint.h>
#include "{prefix}_data.h"

float lookup_counts(uint32_t code);

float lookup_counts(uint32_t code)
{{
    return (float)((double)error_table[code & 0xFFFFu] * TABLE_SCALE_ARCMIN);
}}
"""

EXPORT_SCRIPT = """\
import sys
from encal.deploy import write_c
write_c(sys.argv[1], sys.argv[2], prefix="bench", table=None if sys.argv[3] == "formula" else sys.argv[3])
"""

C_MODELS = {"fourier (9 orders up to 97)": "model_v1_fourier.json",
            "ann (periodic 1:8:1)": "model_v1_ann.json",
            "hybrid (3 orders + 1:5:1)": "model_v1_hybrid.json",
            "stack (4 orders + cubic lut + 1:4:1)": "model_v1_stack.json"}


def load():
    return f"{os.getloadavg()[0]:.2f}"


def extract_source(revision, folder):
    """``src`` of ``revision`` extracted into ``folder``; the path to put on PYTHONPATH."""
    archive = folder / "src.tar"
    with open(archive, "wb") as handle:
        subprocess.run(["git", "-C", str(ROOT), "archive", revision, "src"], stdout=handle, check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(folder, filter="data")
    return folder / "src"


def run_with(source, *command, **options):
    env = {**os.environ, "PYTHONPATH": str(source), "OPENBLAS_NUM_THREADS": "1"}
    return subprocess.run(command, env=env, check=True, capture_output=True, text=True, **options)


# -- exported C ---------------------------------------------------------------------------

def build_c(source, model, table, folder, n):
    """Export ``model`` with the encal at ``source``, build the timing driver; the program's path."""
    gcc = shutil.which("gcc")
    folder.mkdir(parents=True)
    run_with(source, sys.executable, "-c", EXPORT_SCRIPT, str(model), str(folder), table)
    # codes in a scattered order
    (folder / "driver.c").write_text(timing_driver("bench_correct_counts(k * 40503u)", n=n,
                                                  declaration="float bench_correct_counts(uint32_t code);"))
    program = folder / "program"
    subprocess.run([gcc, "-std=c99", "-O2", "-I", str(folder), str(folder / "driver.c"),
                    str(folder / "bench.c"), "-lm", "-o", str(program)], check=True)
    return program


def build_lookup(exported, folder, n):
    """The limit: a function in its own file that only looks the code up in the exported table."""
    gcc = shutil.which("gcc")
    folder.mkdir(parents=True)
    text = (exported / "bench.c").read_text()
    start = text.index("static const int16_t error_table")
    end = text.index("#define TABLE_SCALE_ARCMIN")
    end = text.index("\n", end) + 1
    (folder / "bench_data.h").write_text(text[start:end])
    (folder / "lookup.c").write_text(C_LOOKUP.format(prefix="bench"))
    (folder / "driver.c").write_text(timing_driver("lookup_counts(k * 40503u)", n=n,
                                                  declaration="float lookup_counts(uint32_t code);"))
    program = folder / "program"
    subprocess.run([gcc, "-std=c99", "-O2", "-I", str(folder), str(folder / "driver.c"),
                    str(folder / "lookup.c"), "-o", str(program)], check=True)
    return program


def libm_calls(program):
    """libm functions the exported code calls (from the program's dynamic symbols)."""
    names = subprocess.run(["nm", "-D", "--undefined-only", str(program)], capture_output=True,
                           text=True).stdout.split()
    return sorted({n.split("@")[0] for n in names
                   if n.split("@")[0] in {"fmod", "sin", "cos", "tanh", "exp", "floor", "sincos"}})


def time_programs(programs, rounds=3):
    best = {name: np.inf for name in programs}
    for _ in range(rounds):
        for name, program in programs.items():
            output = subprocess.run([str(program)], capture_output=True, text=True, check=True).stdout
            best[name] = min(best[name], float(output.split()[0]))
    return best


def section_c(sources, folder, quick):
    n = 10**6 if quick else 10**7
    print("\n### exported C: ns per `correct_counts` reading (gcc -O2), best of 3 x 3\n")
    programs = {}
    for label, source in sources.items():
        programs[("table", label)] = build_c(source, DATA / "model_v1_fourier.json", "int16",
                                             folder / f"table-{label}", n)
    programs[("table", "limit")] = build_lookup(folder / "table-after", folder / "lookup", n)
    for name, file in C_MODELS.items():
        for label, source in sources.items():
            programs[(name, label)] = build_c(source, DATA / file, "formula", folder / f"{file}-{label}", n)
    times = time_programs(programs)
    labels = list(sources)
    print("| form | limit ns | " + " | ".join(f"{label} ns" for label in labels)
          + " | " + " | ".join(f"{label} / limit" for label in labels) + " |")
    print("|---|---|" + "---|" * (2 * len(labels)))
    limit = times[("table", "limit")]
    print(f"| int16 table (fourier) | {limit:.2f} | "
          + " | ".join(f"{times[('table', label)]:.2f}" for label in labels) + " | "
          + " | ".join(f"{times[('table', label)] / limit:.2f}" for label in labels) + " |")
    print("\n| formula | " + " | ".join(f"{label} ns (libm symbols)" for label in labels)
          + (" | after / before |" if len(labels) == 2 else " |"))
    print("|---|" + "---|" * (len(labels) + (len(labels) == 2)))
    for name in C_MODELS:
        cells = [f"{times[(name, label)]:.1f} ({', '.join(libm_calls(programs[(name, label)]))})"
                 for label in labels]
        ratio = (f" | {times[(name, 'after')] / times[(name, 'before')]:.2f}" if len(labels) == 2 else "")
        print(f"| {name} | " + " | ".join(cells) + ratio + " |")


# -- Model.correct in NumPy --------------------------------------------------------------

CORRECT_WORKER = """\
import json, sys, time, tracemalloc
import numpy as np
from encal.deploy import Compensator, compile_table
import inspect
model = Compensator(sys.argv[1]).model
sizes = [int(v) for v in sys.argv[2].split(",")]
fast = {"table": True} if "table" in inspect.signature(model.correct).parameters else {}  # asked for since 2026-11
result = {}
for n in sizes:
    theta = np.random.default_rng(0).uniform(0.0, 360.0, n)
    model.correct(theta[:1000])
    tracemalloc.start()
    start = time.process_time()
    model.correct(theta, **fast)
    elapsed = time.process_time() - start
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    result[n] = [1e9 * elapsed / n, peak / 2**20]
if sys.argv[3] == "table":
    table = compile_table(Compensator(sys.argv[1]), 16)
    codes = np.random.default_rng(0).integers(0, 2**16, 10**7).astype(np.uint16)
    start = time.process_time()
    table.correct_counts(codes)
    result["table"] = 1e9 * (time.process_time() - start) / codes.size
print(json.dumps(result))
"""

CORRECT_MODELS = {"lut (cubic, 180 points)": "model_v1_lut.json",
                  "fourier (9 orders up to 97)": "model_v1_fourier.json",
                  "ann (periodic 1:8:1)": "model_v1_ann.json",
                  "hybrid (3 orders + 1:5:1)": "model_v1_hybrid.json",
                  "stack (4 orders + cubic lut + 1:4:1)": "model_v1_stack.json",
                  "spectral": "model_v1_spectral.json"}


def section_correct(sources, folder, quick):
    import json

    big = 10**6 if quick else 10**7
    print("\n### Model.correct in NumPy: ns per angle and peak memory (tracemalloc) of one call\n")
    print("| model | dense table ns | " + " | ".join(
        f"{label} ns at 1e5 / 1e6 / {big:.0e} | {label} peak MB at 1e6 / {big:.0e}" for label in sources)
        + " | after / before ns at 1e6 | after / table |")
    print("|---|---|" + "---|---|" * len(sources) + "---|---|")
    for name, file in CORRECT_MODELS.items():
        best = {}
        for round_ in range(2):
            for label, source in sources.items():
                # before: the dense evaluation would need gigabytes at 1e7 angles; it is measured up to 1e6
                sizes = [10**5, 10**6] + ([big] if label == "after" and big > 10**6 else [])
                out = json.loads(run_with(source, sys.executable, "-c", CORRECT_WORKER, str(DATA / file),
                                          ",".join(map(str, sizes)), "table" if label == "after" else "-").stdout)
                previous = best.get(label, {})
                best[label] = {key: (min(value, previous[key]) if key == "table" else
                                     [min(value[0], previous[key][0]), max(value[1], previous[key][1])])
                               if key in previous else value for key, value in out.items()}
        cells = []
        for label in sources:
            ns = " / ".join(f"{best[label][str(n)][0]:.1f}" if str(n) in best[label] else "-"
                            for n in (10**5, 10**6, big))
            mb = " / ".join(f"{best[label][str(n)][1]:.0f}" if str(n) in best[label] else "-"
                            for n in (10**6, big))
            cells.append(f"{ns} | {mb}")
        after = best["after"]
        ratio = (f"{after[str(10**6)][0] / best['before'][str(10**6)][0]:.2f}" if "before" in best else "-")
        print(f"| {name} | {after['table']:.1f} | " + " | ".join(cells)
              + f" | {ratio} | {after[str(10**6)][0] / after['table']:.1f} |", flush=True)


# -- trainlm epoch -----------------------------------------------------------------------

TRAINLM_WORKER = """\
import hashlib, json, sys, time
import numpy as np
from scipy.linalg.blas import dgemm, dgemv, dsyrk
from scipy.linalg.lapack import dpotrf, dpotrs
from encal.training import train
from encal.training.network import NetworkProblem
theta = np.arange(0.0, 360.0, 2.0)
r = np.radians(theta)
error = 3 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r) + 0.5 * np.sin(4 * r + 1) + 0.3 * np.cos(7 * r)
problem = NetworkProblem.from_angles(theta, error, 80, encoding="raw")
epochs = int(sys.argv[1])
best = np.inf
for _ in range(3):
    start = time.process_time()
    result = train(problem, "trainlm", x0=problem.initial_weights(0), epochs=epochs)
    best = min(best, (time.process_time() - start) / result.epochs)
tries = (result.nfev - 1) / result.epochs - 1
out = {"epoch_ms": 1e3 * best, "tries": tries, "epochs": result.epochs,
       "weights_sha256": hashlib.sha256(np.asarray(result.x, dtype="<f8").tobytes()).hexdigest()[:16]}
if sys.argv[2] == "floor":
    # The BLAS/LAPACK calls of one epoch back to back, on arrays of the same sizes: the two rank-N
    # products of J Jt, then per try a Cholesky factorisation, its solve, Jt v, and the trial's
    # forward pass (inputs x W1t, then h W2).
    rng = np.random.default_rng(0)
    m, n_hidden = problem.n_samples, problem.hidden
    d, h = rng.standard_normal((m, n_hidden)), np.tanh(rng.standard_normal((m, n_hidden)))
    J = rng.standard_normal((m, problem.n_params))
    x, W1 = problem.inputs, rng.standard_normal((n_hidden, 1))
    w2, v = rng.standard_normal(n_hidden), rng.standard_normal(m)
    gram = dsyrk(1.0, d.T, trans=1, lower=1) + 1e3 * np.eye(m)
    def epoch():
        dsyrk(1.0, d.T, trans=1, lower=1)
        dsyrk(1.0, h.T, trans=1, lower=1)
        for _ in range(round(tries)):
            lower, _ = dpotrf(gram, lower=1, clean=0)
            dpotrs(lower, v, lower=1)
            dgemv(1.0, J, v, trans=1)
            dgemm(1.0, x, W1, trans_b=1)
            dgemv(1.0, h, w2)
    floor = np.inf
    for _ in range(3):
        start = time.process_time()
        for _ in range(epochs):
            epoch()
        floor = min(floor, (time.process_time() - start) / epochs)
    out["floor_ms"] = 1e3 * floor
print(json.dumps(out))
"""


def section_trainlm(sources, folder, quick):
    import json

    epochs = 100 if quick else 300
    print(f"\n### trainlm epoch (raw 1:80:1, 180 points, seed 0, {epochs} epochs, OPENBLAS_NUM_THREADS=1)\n")
    best = {}
    for _ in range(2):
        for label, source in sources.items():
            out = json.loads(run_with(source, sys.executable, "-c", TRAINLM_WORKER, str(epochs),
                                      "floor" if label == "after" else "-").stdout)
            previous = best.get(label)
            if previous is None or out["epoch_ms"] < previous["epoch_ms"]:
                out["floor_ms"] = min(out.get("floor_ms", np.inf), (previous or {}).get("floor_ms", np.inf))
                best[label] = out
            elif "floor_ms" in out:
                previous["floor_ms"] = min(previous["floor_ms"], out["floor_ms"])
    floor = best["after"]["floor_ms"]
    print("| | ms per epoch | / BLAS floor | μ tries per epoch | weights after training (sha256) |")
    print("|---|---|---|---|---|")
    print(f"| BLAS floor (the epoch's BLAS/LAPACK calls back to back) | {floor:.3f} | 1.00 | | |")
    for label in sources:
        row = best[label]
        print(f"| {label} | {row['epoch_ms']:.3f} | {row['epoch_ms'] / floor:.2f} | {row['tries']:.2f} "
              f"| {row['weights_sha256']} |")


# -- whole fits of Table 2 -------------------------------------------------------------------

FITS_WORKER = """\
import hashlib, json, sys, time
import numpy as np
from encal.simulate import demo_fleet
from encal.paper.studies._fits import fit_network, task_seed
cal = demo_fleet(1)[0].train.calibration
epochs = int(sys.argv[1])
out = {}
for algorithm in sys.argv[2].split(","):
    best = np.inf
    for _ in range(2):
        start = time.process_time()
        model = fit_network(cal.encoder_deg, cal.errors_arcmin, hidden=80, algorithm=algorithm,
                            seed=task_seed(0, 80, 0), epochs=epochs)
        best = min(best, time.process_time() - start)
    p = model.parameters()
    weights = np.concatenate([np.ravel(np.asarray(p[k], dtype="<f8")) for k in ("W1", "b1", "W2", "b2")])
    out[algorithm] = {"cpu_s": best, "epochs": int(model.train_result.epochs),
                      "weights_sha256": hashlib.sha256(weights.tobytes()).hexdigest()[:16]}
print(json.dumps(out))
"""

#: The algorithms of the demo's Table 2 whose fits cost the most CPU.
FIT_ALGORITHMS = ("trainlm", "trainbr", "trainbfg")


def section_fits(sources, folder, quick):
    import json

    epochs = 100 if quick else 1000
    print(f"\n### Table 2 fits (demo encoder 1, raw 1:80:1, seed of fit 0, {epochs} epochs): CPU seconds\n")
    best = {}
    for _ in range(2):
        for label, source in sources.items():
            out = json.loads(run_with(source, sys.executable, "-c", FITS_WORKER, str(epochs),
                                      ",".join(FIT_ALGORITHMS)).stdout)
            for algorithm, row in out.items():
                previous = best.setdefault(label, {}).get(algorithm)
                if previous is None or row["cpu_s"] < previous["cpu_s"]:
                    best[label][algorithm] = row
    labels = list(sources)
    print("| algorithm | epochs | " + " | ".join(f"{label} s (weights sha256)" for label in labels)
          + (" | before / after |" if len(labels) == 2 else " |"))
    print("|---|---|" + "---|" * (len(labels) + (len(labels) == 2)))
    for algorithm in FIT_ALGORITHMS:
        cells = [f"{best[label][algorithm]['cpu_s']:.3f} ({best[label][algorithm]['weights_sha256']})"
                 for label in labels]
        ratio = (f" | {best['before'][algorithm]['cpu_s'] / best['after'][algorithm]['cpu_s']:.2f}"
                 if len(labels) == 2 else "")
        print(f"| {algorithm} | {best['after'][algorithm]['epochs']} | " + " | ".join(cells) + ratio + " |")


# -- harmonic analysis ------------------------------------------------------------------------

HARMONICS_WORKER = """\
import json, sys, time
import numpy as np
from encal.models.fourier import fit_fourier
from encal.analysis.profile import harmonics
n = int(sys.argv[1])
rng = np.random.default_rng(0)
theta = (np.arange(n) + rng.uniform(-0.3, 0.3, n)) * (360.0 / n)  # a real grid: jittered, not uniform
r = np.radians(theta)
error = 3 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r) + 0.4 * np.sin(17 * r) + rng.normal(0.0, 0.05, n)
out = {}
for name, run in (("harmonics K=100", lambda: harmonics(theta, error, 100)),
                  ("harmonics K=1000", lambda: harmonics(theta, error, 1000)),
                  ("fit_fourier (default)", lambda: fit_fourier(theta, error))):
    best = np.inf
    for _ in range(2):
        start = time.process_time()
        run()
        best = min(best, time.process_time() - start)
    out[name] = best
print(json.dumps(out))
"""


def section_harmonics(sources, folder, quick):
    import json

    n = 10**4 if quick else 10**5
    print(f"\n### harmonic analysis of {n} jittered angles: CPU seconds\n")
    best = {}
    for _ in range(2):
        for label, source in sources.items():
            out = json.loads(run_with(source, sys.executable, "-c", HARMONICS_WORKER, str(n)).stdout)
            best[label] = {key: min(value, best.get(label, {}).get(key, np.inf)) for key, value in out.items()}
    labels = list(sources)
    print("| computation | " + " | ".join(f"{label} s" for label in labels)
          + (" | before / after |" if len(labels) == 2 else " |"))
    print("|---|" + "---|" * (len(labels) + (len(labels) == 2)))
    for name in best["after"]:
        ratio = f" | {best['before'][name] / best['after'][name]:.1f}" if len(labels) == 2 else ""
        print(f"| {name} | " + " | ".join(f"{best[label][name]:.3f}" for label in labels) + ratio + " |")


# -- trigonometric sums: FFT on a grid, NUFFT, direct ----------------------------------------

TRIGSUMS_WORKER = """\
import json, sys, time
import numpy as np
from encal.numerics.trigsums import trig_moments
from encal.analysis.profile import harmonics
n, orders = int(sys.argv[1]), [int(k) for k in sys.argv[2].split(",")]
rng = np.random.default_rng(0)
nodes = np.arange(n) * (360.0 / n)
jittered = nodes + rng.uniform(-0.3, 0.3, n) * (360.0 / n)  # a real grid: not uniform
near = nodes + rng.uniform(-1e-6, 1e-6, n)  # within 1e-6 degrees of a uniform grid
error = 3 * np.sin(np.radians(nodes) + 0.3) + 0.4 * np.sin(np.radians(17 * nodes)) + rng.normal(0.0, 0.05, n)
try:
    import finufft
except ImportError:
    finufft = None

def direct(theta_deg, highest):  # sum_i y_i exp(-i k theta_i), k = 0..highest, exact products in chunks
    theta, out = np.radians(theta_deg), np.zeros(highest + 1, complex)
    for start in range(0, n, 4096):
        block = slice(start, start + 4096)
        out += np.exp(-1j * np.multiply.outer(np.arange(highest + 1), theta[block])) @ error[block]
    return out

def timed(run, repeats=3):
    best, value = np.inf, None
    for _ in range(repeats):
        start = time.process_time()
        value = run()
        best = min(best, time.process_time() - start)
    return best, value

out = {}
scale = np.sum(np.abs(error))
for K in orders:
    row = {}
    t, exact = timed(lambda: direct(jittered, K), 1)
    row["direct"] = [t, 0.0]
    t, value = timed(lambda: np.conj(trig_moments(np.radians(jittered), error, K)))
    row["encal NUFFT (NumPy)"] = [t, float(np.max(np.abs(value - exact)) / scale)]
    if finufft is not None:
        theta = np.radians(jittered)
        def library():
            modes = finufft.nufft1d1(theta, error.astype(complex), 2 * K + 1, eps=1e-14, isign=-1, nthreads=1)
            return modes[K:]  # modes -K..K; k >= 0
        t, value = timed(library)
        row[f"finufft {finufft.__version__} (eps 1e-14)"] = [t, float(np.max(np.abs(value - exact)) / scale)]
    t, exact_near = timed(lambda: direct(near, K), 1)
    t, result = timed(lambda: harmonics(near, error, K, grid_tolerance_deg=2e-6))
    value = (result.cos_arcmin - 1j * result.sin_arcmin) * n / np.where(np.arange(K + 1) == 0, 1.0, 2.0)
    row["harmonics, grid within 2e-6 deg: FFT"] = [t, float(np.max(np.abs(value - exact_near)) / scale),
                                                   float(np.max(result.grid_bound_arcmin) * n / 2 / scale)]
    t, _ = timed(lambda: harmonics(near, error, K))
    row["harmonics, same angles, default tolerance (NUFFT + conjugate gradients)"] = [t, None]
    out[K] = row
print(json.dumps(out))
"""


def section_trigsums(sources, folder, quick):
    import json

    n = 10**4 if quick else 10**5
    orders = "100,1000"
    out = json.loads(run_with(sources["after"], sys.executable, "-c", TRIGSUMS_WORKER, str(n), orders).stdout)
    print(f"\n### trigonometric sums of {n} angles, orders 0..K: CPU seconds (best of 3) and the largest "
          "error against the direct products, relative to Σ|y|\n")
    print("| K | method | CPU s | direct / method | error / Σ|y| | stated bound / Σ|y| |")
    print("|---|---|---|---|---|---|")
    for K, row in out.items():
        direct = row["direct"][0]
        for name, values in row.items():
            error = "" if values[1] is None else f"{values[1]:.1e}"
            bound = f"{values[2]:.1e}" if len(values) > 2 else ""
            print(f"| {K} | {name} | {values[0]:.4f} | {direct / values[0]:.1f} | {error} | {bound} |")


# -- encal demo -------------------------------------------------------------------------------

def section_demo(sources, folder, quick):
    import resource
    import time

    option = ["--quick"] if quick else []
    print(f"\n### `encal demo {' '.join(option)}`: wall and CPU seconds (the process and its workers)\n")
    rows = {}
    for label, source in sources.items():
        out = folder / f"demo-{label}"
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        printed = run_with(source, sys.executable, "-m", "encal", "demo", *option, "--no-progress",
                           "--out", str(out)).stdout
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        rows[label] = (wall, cpu, printed, out)
    print("| | wall s | CPU s |")
    print("|---|---|---|")
    for label, (wall, cpu, _, _) in rows.items():
        print(f"| {label} | {wall:.1f} | {cpu:.1f} |")
    if len(rows) == 2:
        (_, _, printed_a, out_a), (_, _, printed_b, out_b) = rows.values()
        tables = sorted(p.name for p in (out_a / "tables").glob("*.csv"))
        same = [name for name in tables if _without_times(out_a / "tables" / name)
                == _without_times(out_b / "tables" / name)]
        print(f"\nCSV tables identical before and after (but for their CPU-time column): "
              f"{len(same)} of {len(tables)}"
              + ("" if len(same) == len(tables) else f" (differ: {sorted(set(tables) - set(same))})"))


def _without_times(path):
    """The rows of a CSV table without its ``cpu_s`` column (a measured time, never the same twice)."""
    rows = [line.split(",") for line in path.read_text().splitlines()]
    keep = [i for i, name in enumerate(rows[0]) if name != "cpu_s"] if rows else []
    return [[row[i] for i in keep if i < len(row)] for row in rows]


# -- encal correct ---------------------------------------------------------------------------

PLAIN_SCRIPT = """\
import sys
import numpy as np
from encal.deploy import Compensator
compensator = Compensator(sys.argv[1])
with open(sys.argv[2], "rb") as handle:
    values = np.array(handle.read().split(), dtype=float)
sys.stdout.write("\\n".join(map(repr, compensator.correct(values).tolist())) + "\\n")
"""


def _cpu_seconds(command, env, stdin=None):
    """CPU seconds (user + system) of one process running ``command``, its output discarded."""
    with subprocess.Popen(command, env=env, stdin=stdin, stdout=subprocess.DEVNULL) as process:
        _, status, usage = os.wait4(process.pid, 0)
        process.returncode = os.waitstatus_to_exitcode(status)
    if process.returncode != 0:
        raise RuntimeError(f"{command} failed with status {process.returncode}")
    return usage.ru_utime + usage.ru_stime


def section_stream(sources, folder, quick, lines=None):
    n = lines or (10**5 if quick else 10**6)
    lines = folder / "angles.txt"
    angles = np.random.default_rng(1).uniform(0.0, 360.0, n)
    lines.write_text("".join(f"{a!r}\n" for a in angles.tolist()))
    table = folder / "angles.csv"  # the same angles as a CSV column between two others
    table.write_text("time_s,encoder_deg,temp_C\n"
                     + "".join(f"{i * 1e-3:.3f},{a!r},{20 + i % 7}\n" for i, a in enumerate(angles.tolist())))
    empty = folder / "empty.txt"
    empty.write_text("")
    print(f"\n### `encal correct` on {n} angles (repr of uniform doubles): CPU seconds of the one process, "
          "best of 3, start-up included; lines/s without start-up = lines / (CPU - CPU on an empty file)\n")
    print("| model | command | CPU s | lines/s | lines/s without start-up | / plain script (CPU) |")
    print("|---|---|---|---|---|---|")
    for model_name in ("lut", "fourier"):
        model = str(DATA / f"model_v1_{model_name}.json")
        runs = {}
        for label, source in sources.items():
            encal = [sys.executable, "-m", "encal", "correct", model]
            runs[f"encal correct FILE ({label})"] = (source, encal + [str(lines)], None)
            if label == "after":
                runs["encal correct --exact FILE (after)"] = (source, encal + ["--exact", str(lines)], None)
                runs["cat FILE | encal correct (after)"] = (source, encal, "pipe")
                runs["encal correct CSV (time_s,encoder_deg,temp_C) (after)"] = (source, encal + [str(table)], None)
                runs["start-up: encal correct EMPTY (after)"] = (source, encal + [str(empty)], None)
        runs["plain NumPy script (read all, correct, repr)"] = (sources["after"], [sys.executable, "-c", PLAIN_SCRIPT,
                                                                                   model, str(lines)], None)
        best = {name: np.inf for name in runs}
        for _ in range(3):
            for name, (source, command, stdin) in runs.items():
                env = {**os.environ, "PYTHONPATH": str(source), "OPENBLAS_NUM_THREADS": "1"}
                if stdin == "pipe":
                    with subprocess.Popen(["cat", str(lines)], stdout=subprocess.PIPE) as cat:
                        seconds = _cpu_seconds(command, env, stdin=cat.stdout)
                        cat.stdout.close()
                else:
                    seconds = _cpu_seconds(command, env)
                best[name] = min(best[name], seconds)
        startup = best["start-up: encal correct EMPTY (after)"]
        peer = best["plain NumPy script (read all, correct, repr)"]
        for name, seconds in best.items():
            if name.startswith("start-up"):
                print(f"| {model_name} | {name} | {seconds:.2f} | | | |")
                continue
            steady = f"{n / (seconds - startup):.3g}" if seconds > startup else "-"
            print(f"| {model_name} | {name} | {seconds:.2f} | {n / seconds:.3g} | {steady} | {seconds / peer:.2f} |",
                  flush=True)


def _timed(command, env, stdin=None):
    """(wall, CPU) seconds of one process running ``command``, its output discarded; ``stdin`` a file to
    read or, as ``("pipe", path)``, a file that ``cat`` pipes in (its own time not counted as CPU)."""
    start = time.perf_counter()
    if isinstance(stdin, tuple):
        with subprocess.Popen(["cat", str(stdin[1])], stdout=subprocess.PIPE) as cat:
            with subprocess.Popen(command, env=env, stdin=cat.stdout, stdout=subprocess.DEVNULL) as process:
                cat.stdout.close()
                _, status, usage = os.wait4(process.pid, 0)
                process.returncode = os.waitstatus_to_exitcode(status)
    else:
        with subprocess.Popen(command, env=env, stdin=stdin, stdout=subprocess.DEVNULL) as process:
            _, status, usage = os.wait4(process.pid, 0)
            process.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - start
    if process.returncode != 0:
        raise RuntimeError(f"{command} failed with status {process.returncode}")
    return wall, usage.ru_utime + usage.ru_stime


def section_startup(sources, folder, quick, lines=None):
    sizes = [10**5] if quick else ([lines] if lines else [10**6, 10**7])
    rng = np.random.default_rng(1)
    files = {}
    for n in sizes:
        files[n] = folder / f"angles_{n}.txt"
        with open(files[n], "w") as handle:
            for start in range(0, n, 10**6):
                block = rng.uniform(0.0, 360.0, min(10**6, n - start))
                handle.write("".join(f"{a!r}\n" for a in block.tolist()))
    empty = folder / "empty.txt"
    empty.write_text("")
    print("\n### Start-up and `encal correct` lines/s with the start-up counted: best of 3 of the one process, "
          "wall and CPU seconds, before and after interleaved\n")
    runs = {}  # (what, model, lines, source) -> (command, stdin)
    for label, source in sources.items():
        runs[("`encal --help`", "-", 0, label)] = ([sys.executable, "-m", "encal", "--help"], None)
        for model_name in ("lut", "fourier"):
            model = str(DATA / f"model_v1_{model_name}.json")
            encal = [sys.executable, "-m", "encal", "correct", model]
            runs[("`encal correct MODEL EMPTY`", model_name, 0, label)] = (encal + [str(empty)], None)
            for n in sizes:
                runs[("`encal correct MODEL FILE`", model_name, n, label)] = (encal + [str(files[n])], None)
                runs[("`cat FILE \\| encal correct MODEL`", model_name, n, label)] = (encal, ("pipe", files[n]))
    best = {key: (np.inf, np.inf) for key in runs}
    for _ in range(3):
        for key, (command, stdin) in runs.items():
            env = {**os.environ, "PYTHONPATH": str(sources[key[3]]), "OPENBLAS_NUM_THREADS": "1"}
            wall, cpu = _timed(command, env, stdin)
            best[key] = (min(best[key][0], wall), min(best[key][1], cpu))
    labels = list(sources)
    print("| command | model | lines | " + " | ".join(f"{label} wall s | {label} CPU s" for label in labels)
          + " | " + " | ".join(f"{label} lines/s (wall / CPU)" for label in labels) + " |")
    print("|---|---|---|" + "---|---|" * len(labels) + "---|" * len(labels))
    for key in dict.fromkeys(key[:3] for key in runs):
        what, model_name, n = key
        times = [best[(*key, label)] for label in labels]
        rates = [f"{n / wall:.3g} / {n / cpu:.3g}" if n else "" for wall, cpu in times]
        print(f"| {what} | {model_name} | {n or ''} | "
              + " | ".join(f"{wall:.3f} | {cpu:.3f}" for wall, cpu in times) + " | " + " | ".join(rates) + " |",
              flush=True)


# -- a Fourier series: direct form against addition chains ----------------------------------

SERIES_WORKER = """\
import json, sys, time
import numpy as np
from encal.numerics.trigsums import SeriesEvaluator
from encal.numerics.harmonic_series import HarmonicSeries, plan_products
ORDER_SETS = json.loads(sys.argv[1])
theta = np.radians(np.random.default_rng(0).uniform(0.0, 360.0, 8192))
rounds = int(sys.argv[2])
rows = {}
for name, orders in ORDER_SETS.items():
    orders = np.asarray(orders)
    rng = np.random.default_rng(1)
    a, b = rng.standard_normal(orders.size), rng.standard_normal(orders.size)
    positive = [int(k) for k in orders if k > 0]
    chains = {"every order": [(k, k - 1, 1) for k in range(2, max(positive) + 1)] if max(positive) <= 2000 else None,
              "squaring": plan_products(positive, routes=("squaring",)),
              "difference": plan_products(positive, routes=("difference",)),
              "planned": plan_products(positive)}
    forms = {"direct": HarmonicSeries(orders, a, b, method="direct")}
    forms.update((label, HarmonicSeries(orders, a, b, method="recurrence", chain=chain))
                 for label, chain in chains.items() if chain is not None)
    complex_coefficients = np.zeros(orders.max() + 1, dtype=complex)
    complex_coefficients[orders] = a - 1j * b
    forms["spectral's evaluator"] = SeriesEvaluator(complex_coefficients)  # as SpectralModel makes it
    best = dict.fromkeys(forms, np.inf)
    for _ in range(3):
        for label, series in forms.items():
            start = time.process_time()
            for _ in range(rounds):
                series(theta)
            best[label] = min(best[label], (time.process_time() - start) / rounds / theta.size * 1e9)
    rows[name] = {"ns": best, "products": {label: len(chain) for label, chain in chains.items() if chain is not None},
                  "chosen": HarmonicSeries(orders, a, b).method}
print(json.dumps(rows))
"""

SERIES_ORDER_SETS = {
    "stored model: 9 orders up to 97": [0, 1, 2, 3, 4, 8, 16, 50, 97],
    "0..10": list(range(11)),
    "0..200": list(range(201)),
    "1, 2, 3 and 1000, 5000, 32767": [1, 2, 3, 1000, 5000, 32767],
    "300 random up to 32767": sorted(np.random.default_rng(7).choice(32768, 300, replace=False).tolist()),
    "1, 97": [1, 97],
    "0, 12345": [0, 12345],
    "32766, 32767": [32766, 32767],
}


EVALUATOR = "spectral's evaluator"


def section_series(sources, folder, quick):
    import json

    rounds = 5 if quick else 40

    def measured(label):
        return json.loads(run_with(sources[label], sys.executable, "-c", SERIES_WORKER,
                                   json.dumps(SERIES_ORDER_SETS), str(rounds)).stdout)

    rows = measured("after")
    before = measured("before") if "before" in sources else None  # (one process each, one after the other)
    labels = ["every order", "squaring", "difference", "planned"]
    print("\n### A Fourier series on 8,192 angles: ns per angle (best of 3 CPU times) and products of each chain\n")
    print("| orders | direct ns | " + " | ".join(f"{label} ns (products)" for label in labels)
          + " | spectral's evaluator ns" + (" | the evaluator before ns" if before else "")
          + " | chosen | chosen / direct |")
    print("|---|---|" + "---|" * len(labels) + "---|---|---|" + ("---|" if before else ""))
    for name, row in rows.items():
        chosen = row["ns"][{"recurrence": "planned", "taylor": "spectral's evaluator"}.get(row["chosen"], "direct")]
        spectral = row["ns"][EVALUATOR]
        earlier = f" | {before[name]['ns'][EVALUATOR]:.1f}" if before else ""
        print(f"| {name} | {row['ns']['direct']:.1f} | "
              + " | ".join(f"{row['ns'][label]:.1f} ({row['products'][label]})" if label in row["ns"] else "-"
                           for label in labels)
              + f" | {spectral:.1f}{earlier} | {row['chosen']} | {chosen / row['ns']['direct']:.2f} |", flush=True)


SECTIONS = {"c": section_c, "correct": section_correct, "trainlm": section_trainlm, "fits": section_fits,
            "harmonics": section_harmonics, "trigsums": section_trigsums, "demo": section_demo,
            "stream": section_stream, "startup": section_startup, "series": section_series}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", help="git revision to measure side by side with the current src")
    parser.add_argument("--only", default=",".join(SECTIONS), help="comma-separated sections")
    parser.add_argument("--quick", action="store_true", help="smaller sizes, for a smoke test")
    parser.add_argument("--lines", type=int, help="lines of the stream section (default 10^6)")
    args = parser.parse_args()
    print(f"machine: {machine()}")
    print(f"load average at start: {load()}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        sources = {}
        if args.before:
            (folder / "before").mkdir()
            sources["before"] = extract_source(args.before, folder / "before")
        sources["after"] = ROOT / "src"
        for name in args.only.split(","):
            options = {"lines": args.lines} if name in ("stream", "startup") and args.lines else {}
            SECTIONS[name](sources, folder, args.quick, **options)
    print(f"\nload average at end: {load()}")


if __name__ == "__main__":
    main()

"""Deployment speed and sizes: how fast each deployed form corrects encoder angles.

    python benchmarks/bench_deploy.py [--quick]

Prints, per model kind, corrections per second of

- the NumPy model (``Compensator.correct`` on 10^6 angles),
- the dense 16-bit table (``CorrectionTable.correct_counts`` on 10^7 codes: NumPy fancy indexing),
- the standalone runtime (``encal.runtime``, one angle per call),
- ``encal correct`` streaming a file of angles (lines per second, process start included),
- the exported C (ns per angle, built with ``gcc -O2`` in a temporary folder),

and the sizes of the model file, the table file and the C source. Every timing
is the best of several repeats and counts CPU time (of this process, of the
``encal correct`` child, of the C program), so that other work sharing the
machine slows the figures down little; wall-clock time on an idle machine is
about the same. The models: the stored version-1 test files
(hand-made, realistic sizes) and the paper's 1:80:1 network trained for 30
epochs on a synthetic profile.
"""

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _ctiming import machine, timing_driver  # benchmarks/_ctiming.py
from encal.deploy import Compensator, compile_table, runtime, save_model, save_table, write_c
from encal.models.ann import fit_ann

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
STORED = {"fourier (9 orders)": "model_v1_fourier.json",
          "lut (cubic, 180 points)": "model_v1_lut.json",
          "ann (periodic 1:8:1)": "model_v1_ann.json",
          "hybrid (3 orders + 1:5:1)": "model_v1_hybrid.json",
          "stack (4 orders + cubic lut + 1:4:1)": "model_v1_stack.json"}



def best_time(function, repeat=3):
    """Least CPU time (seconds) of ``repeat`` calls, this process and its children."""
    best = np.inf
    for _ in range(repeat):
        start = _cpu_seconds()
        function()
        best = min(best, _cpu_seconds() - start)
    return best


def _cpu_seconds():
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def paper_network(folder):
    theta = np.arange(0.0, 360.0, 2.0)
    r = np.radians(theta)
    error = 4.0 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r) - 0.6 * np.sin(4 * r)
    model = fit_ann(theta, error, hidden=80, encoding="raw", rng=0, epochs=30)
    model.encoder = {"name": "paper-1:80:1", "resolution_bits": 16}
    return save_model(model, folder / "paper_ann.json", reproducible=True)


def numpy_rate(comp, n):
    theta = np.random.default_rng(0).uniform(0.0, 360.0, n)
    return n / best_time(lambda: comp.correct(theta))


def table_rate(table, n):
    codes = np.random.default_rng(0).integers(0, 2**table.bits, n).astype(np.uint16)
    return n / best_time(lambda: table.correct_counts(codes))


def runtime_rate(path, n):
    model = runtime.load(path)
    theta = np.random.default_rng(0).uniform(0.0, 360.0, n).tolist()
    correct = model.correct_deg
    return n / best_time(lambda: [correct(t) for t in theta])


def stream_rate(path, lines_file, n):
    command = [sys.executable, "-m", "encal", "correct", str(path), str(lines_file)]
    return n / best_time(lambda: subprocess.run(command, stdout=subprocess.DEVNULL, check=True),
                         repeat=2)


def c_ns_per_angle(comp, folder, n, table=None):
    gcc = shutil.which("gcc")
    if gcc is None:
        return None
    prefix = "bench"
    write_c(comp, folder, prefix=prefix, table=table)
    rows = {}
    for function, argument in (("correct_deg", "(float)(k % 65536u) * (360.0f / 65536.0f)"),
                               ("correct_counts", "k & 0xFFFFu")):
        source = folder / f"bench_{function}.c"
        source.write_text(timing_driver(f"{prefix}_{function}({argument})", n=n,
                                        header=f'#include "{prefix}.h"'))
        program = folder / f"bench_{function}"
        subprocess.run([gcc, "-std=c99", "-O2", "-I", str(folder), str(source),
                        str(folder / f"{prefix}.c"), "-lm", "-o", str(program)], check=True)
        output = subprocess.run([str(program)], capture_output=True, text=True, check=True).stdout
        rows[function] = float(output.split()[0])
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="smaller sizes, for a smoke test")
    args = parser.parse_args()
    scale = 10 if args.quick else 1
    n_numpy, n_table, n_runtime = 10**6 // scale, 10**7 // scale, 20_000 // scale
    n_stream, n_c = 10**6 // scale, 10**7 // scale

    print(f"machine: {machine()}")
    print(f"load average at start: {os.getloadavg()[0]:.2f}\n")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        models = {name: DATA / file for name, file in STORED.items()}
        models["ann (paper, raw 1:80:1)"] = paper_network(folder)
        lines_file = folder / "angles.txt"
        angles = np.random.default_rng(1).uniform(0.0, 360.0, n_stream)
        lines_file.write_text("".join(f"{a!r}\n" for a in angles.tolist()))

        print("| model | NumPy model /s | table /s | runtime /s | `encal correct` lines/s "
              "| C formula ns (deg / counts) | C int16 table ns | model file B |")
        print("|---|---|---|---|---|---|---|---|")
        for name, path in models.items():
            comp = Compensator(path)
            table = compile_table(comp, 16)
            c_formula = c_ns_per_angle(comp, folder / "formula", n_c)
            c_table = c_ns_per_angle(comp, folder / "table", n_c, table="int16")
            formula = (f"{c_formula['correct_deg']:.1f} / {c_formula['correct_counts']:.1f}"
                       if c_formula else "n/a")
            tabled = f"{c_table['correct_counts']:.1f}" if c_table else "n/a"
            print(f"| {name} | {numpy_rate(comp, n_numpy):.3g} | {table_rate(table, n_table):.3g} "
                  f"| {runtime_rate(path, n_runtime):.3g} | "
                  f"{stream_rate(path, lines_file, n_stream):.3g} | {formula} | {tabled} "
                  f"| {path.stat().st_size} |", flush=True)

        comp = Compensator(models["fourier (9 orders)"])
        print("\n| artefact (16-bit encoder) | bytes |")
        print("|---|---|")
        for dtype in ("int16", "float32"):
            path = save_table(compile_table(comp, 16, dtype=dtype), folder / f"t_{dtype}.tab")
            print(f"| table file, {dtype} | {path.stat().st_size} |")
        for name, path in models.items():
            sources = write_c(Compensator(path), folder / "size", prefix="size")
            print(f"| C source, {name} | {sum(p.stat().st_size for p in sources)} |")
        sources = write_c(comp, folder / "size", prefix="size", table="int16")
        print(f"| C source, int16 table | {sum(p.stat().st_size for p in sources)} |")
    print(f"\nload average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

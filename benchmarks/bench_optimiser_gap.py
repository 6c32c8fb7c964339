"""How far below its maximum the evidence's optimiser stops, and whether any result depends on it.

Usage::

    PYTHONPATH=src python benchmarks/bench_optimiser_gap.py [--rows 10000,100000,1000000] [--real 6]

For every call of ``encal.models._evidence._optimise`` (L-BFGS-B on minus the log evidence) in ``fit_spectral``
of each file: its evaluations of the evidence and its gap, the log evidence (nats) that L-BFGS-B gains when
continued from its result on minus the log evidence in nats with tight tolerances (``gtol`` 1e-14, ``ftol``
1e-15), restarted until a restart gains less than 1e-7 nats. Then the same fit with every optimisation
continued that way ("converged"), against the fit as it is: the lines admitted and dropped on the way (the
sequence of line sets optimised) and at the end, the noise, the log evidence, the profile at 3,601 angles (max
|difference| in arcmin and in units of the posterior std there) and the posterior std (ratio, min-max).

Files: those of ``benchmarks/bench_dense_read.py`` (a 5-revolution sweep and random angles, ``--rows`` each),
the sweep of ``benchmarks/dense_sweep.py`` (10^6 rows, and 10^6 of its noise alone) and the first ``--real``
real calibrations of shared/data/real/mechaduino (small: a control).
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy.optimize  # noqa: E402

import encal  # noqa: E402
from encal.models import _evidence  # noqa: E402
from encal.models.spectral import fit_spectral  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from bench_dense_read import write_files  # noqa: E402

REAL = HERE.parents[1] / "shared" / "data" / "real" / "mechaduino"
TIGHT = {"maxiter": 5000, "ftol": 1e-15, "gtol": 1e-14}
_minimize = scipy.optimize.minimize
_optimise = _evidence._optimise


def _bounds(design, hyper, line_orders):
    """The bounds of ``_evidence._optimise``'s search."""
    log_scale = np.log(design.scale)
    bounds = [(log_scale - 40.0, log_scale + 14.0), _evidence.EXPONENT_BOUNDS]
    if not hyper.noise_fixed:
        bounds.append((log_scale - 32.0, log_scale + 3.0))
    return bounds + [(log_scale - 30.0, log_scale + 14.0)] * len(line_orders)


def polish(design, hyper):
    """``hyper`` continued by L-BFGS-B on minus the log evidence in nats with tight tolerances, restarted until a
    restart gains less than 1e-7 nats (at most 20 times), and how many restarts that took."""
    line_orders = sorted(hyper.lines)
    log_orders = np.log(np.maximum(design.orders, 1).astype(float))

    def log_evidence(x):
        trial = _evidence._unpack(x, hyper, line_orders)
        return _evidence.evidence(design, trial.variances(design), trial.noise_var, covariance=False).log_evidence

    x = _evidence._pack(hyper, line_orders)
    # the module's objective in nats, whatever its scale (per reading before the change)
    per = abs(_objective(x, design, hyper, line_orders, log_orders)[0] / log_evidence(x))

    def absolute(y):
        value, gradient = _objective(y, design, hyper, line_orders, log_orders)
        return value / per, gradient / per

    restarts = 0
    while restarts < 20:
        again = _minimize(absolute, x, jac=True, method="L-BFGS-B", bounds=_bounds(design, hyper, line_orders),
                          options=dict(TIGHT, maxcor=_evidence._memory(x.size)))
        restarts += 1
        gained = log_evidence(again.x) - log_evidence(x)
        if gained > 0:
            x = again.x
        if gained < 1e-7:
            break
    return _evidence._unpack(x, hyper, line_orders), restarts


class Recorder:
    """Wraps ``_evidence._optimise``: records each call, its evaluations of the objective and its gap; with
    ``converge`` returns the polished result instead of the one it stopped at."""

    def __init__(self, converge):
        self.converge, self.calls, self.evaluations = converge, [], 0

    def objective(self, *args, **kwargs):
        self.evaluations += 1
        return _objective(*args, **kwargs)

    def __call__(self, design, hyper):
        before = self.evaluations
        result = _optimise(design, hyper)
        evaluations = self.evaluations - before
        polished, restarts = polish(design, result)

        def log_evidence(h):
            return _evidence.evidence(design, h.variances(design), h.noise_var, covariance=False).log_evidence

        moved = np.abs(_evidence._pack(polished, sorted(result.lines)) - _evidence._pack(result, sorted(result.lines)))
        self.calls.append({"n": design.n, "parameters": len(result.lines) + 2 + (not hyper.noise_fixed),
                           "lines": tuple(sorted(hyper.lines)), "noise_fixed": hyper.noise_fixed,
                           "evaluations": evaluations, "gap": log_evidence(polished) - log_evidence(result),
                           "restarts": restarts, "moved": float(moved.max())})
        return polished if self.converge else result


_objective = _evidence._objective


def fit(theta, error, converge):
    recorder = Recorder(converge)
    _evidence._optimise, _evidence._objective = recorder, recorder.objective
    try:
        start = time.process_time()
        model = fit_spectral(theta, error)
        return model, recorder.calls, time.process_time() - start
    finally:
        _evidence._optimise, _evidence._objective = _optimise, _objective


def compare(name, theta, error, out):
    model, calls, seconds = fit(theta, error, converge=False)
    converged, calls_converged, seconds_converged = fit(theta, error, converge=True)
    grid = np.linspace(0.0, 360.0, 3601)
    profile, std = model.predict(grid, return_std=True, include_noise=False)
    profile2, std2 = converged.predict(grid, return_std=True, include_noise=False)
    moved = np.abs(profile - profile2)
    t, t2 = model.training, converged.training
    gaps = np.array([c["gap"] for c in calls])
    for i, c in enumerate(calls):
        out.append(f"| {name} | {i} | {c['parameters']} | {len(c['lines'])} | {'fixed' if c['noise_fixed'] else 'free'}"
                   f" | {c['evaluations']} | {c['gap']:.3g} | {c['moved']:.2g} |")
    sequence = [c["lines"] for c in calls]
    sequence2 = [c["lines"] for c in calls_converged]
    summary = {
        "file": name, "n": theta.size, "calls": len(calls), "evaluations": sum(c["evaluations"] for c in calls),
        "max_gap": float(gaps.max()), "total_gap": float(gaps.sum()),
        "calls_converged": len(calls_converged),
        "same_line_path": sequence == sequence2,
        "lines": t["lines"], "lines_converged": t2["lines"],
        "above_cap": t.get("orders_above_cap", {}).get("orders"),
        "above_cap_converged": t2.get("orders_above_cap", {}).get("orders"),
        "noise": t["noise"]["std_arcmin"], "noise_converged": t2["noise"]["std_arcmin"],
        "log_evidence": t["log_evidence_nats"], "log_evidence_converged": t2["log_evidence_nats"],
        "max_moved_arcmin": float(moved.max()), "max_moved_std": float(np.max(moved / std)),
        "std_ratio": (float(np.min(std2 / std)), float(np.max(std2 / std))),
        "cpu": seconds, "cpu_converged": seconds_converged,
    }
    return summary


def dense_files(folder, rows):
    files = {}
    for count in rows:
        (Path(folder) / str(count)).mkdir()
        for kind, path in write_files(Path(folder) / str(count), count).items():
            files[f"{kind} 1e{round(np.log10(count))}"] = path
    for label, extra in (("dense_sweep 1e6", []), ("dense_sweep noise 1e6", ["--noise-only"])):
        path = Path(folder) / (label.replace(" ", "_") + ".csv")
        subprocess.run([sys.executable, str(HERE / "dense_sweep.py"), "1000000", str(path), *extra], check=True)
        files[label] = path
    return files


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", default="10000,100000,1000000")
    parser.add_argument("--real", type=int, default=6, help="how many real files (the first in name order)")
    parser.add_argument("--only", default=None, help="only the files whose label contains this")
    args = parser.parse_args()
    rows = [int(r) for r in args.rows.split(",") if r]
    calls_table = ["| file | call | parameters | lines | noise | evaluations | gap (nats) | max |Δx| |",
                   "|---|---|---|---|---|---|---|---|"]
    summaries = []
    with tempfile.TemporaryDirectory() as folder:
        files = dense_files(folder, rows)
        real = sorted(p for p in REAL.glob("*.csv") if p.name != "index.csv")[: args.real]
        files.update({p.stem[:28]: p for p in real})
        for label, path in files.items():
            if args.only and args.only not in label:
                continue
            cal = encal.read_calibration(path)
            summaries.append(compare(label, np.asarray(cal.encoder_deg), np.asarray(cal.errors_arcmin), calls_table))
            s = summaries[-1]
            print(f"{label}: n {s['n']}, {s['calls']} optimisations, {s['evaluations']} evaluations, max gap "
                  f"{s['max_gap']:.3g} nats, lines {'same' if s['lines'] == s['lines_converged'] else 'CHANGED'}, "
                  f"path {'same' if s['same_line_path'] else 'CHANGED'}, profile moved {s['max_moved_arcmin']:.2g} "
                  f"arcmin = {s['max_moved_std']:.2g} std; CPU {s['cpu']:.2f} -> {s['cpu_converged']:.2f} s",
                  flush=True)
    print("\n".join(["", *calls_table, ""]))
    print("| file | n | optimisations | evaluations | max gap | sum of gaps | lines (converged) | orders above cap "
          "(converged) | noise arcmin (converged) | log evidence change | profile max |Δ| arcmin | / std | "
          "std ratio | CPU s (converged) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for s in summaries:
        lines = str(s["lines"]) if s["lines"] == s["lines_converged"] else f"{s['lines']} ({s['lines_converged']})"
        cap = str(s["above_cap"]) if s["above_cap"] == s["above_cap_converged"] else \
            f"{s['above_cap']} ({s['above_cap_converged']})"
        print(f"| {s['file']} | {s['n']} | {s['calls']} ({s['calls_converged']}) | {s['evaluations']} | "
              f"{s['max_gap']:.3g} | {s['total_gap']:.3g} | {lines} | {cap} | {s['noise']:.6g} "
              f"({s['noise_converged']:.6g}) | {s['log_evidence_converged'] - s['log_evidence']:.3g} | "
              f"{s['max_moved_arcmin']:.2g} | {s['max_moved_std']:.2g} | {s['std_ratio'][0]:.6f}-"
              f"{s['std_ratio'][1]:.6f} | {s['cpu']:.2f} ({s['cpu_converged']:.2f}) |")


if __name__ == "__main__":
    main()

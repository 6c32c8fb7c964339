"""Every suite of both simulated worlds in one table: the blind default against the best plain baseline.

Usage::

    python benchmarks/bench_worlds.py                        # every suite, about 10 minutes on one core
    python benchmarks/bench_worlds.py --suites resolver 12bit-physics
    python benchmarks/bench_worlds.py --write benchmarks/results/worlds.md   # the tables README/RESULTS cite
    python benchmarks/bench_worlds.py --blind uniform       # another blind split (see --help)

Suites: the project's own world (``fleet``, ``fleet+``, ``rough``, ``12bit``, ``jitter``, ``epoch`` of
benchmarks/bench_spectral.py, made with ``encal.simulate``) and the physics world of
benchmarks/_physics_world.py, written from the physics references without reading
``encal.simulate`` (issue 27): resolvers on the paper's grid, at a later epoch, on 36 points, with a
flat roughness; magnetic encoders on a motor (14 and 12 bits); dense sweeps behind a 200-step stepper.

Per encoder: test RMS of ``np.interp`` of the training points, the CV-chosen Fourier series and the
top-10 series (the plain baselines; "best plain" is the lowest of the three), the spectral model
blind (the default of ``fit(method='auto')``) and with the noise supplied (the training run's noise
and rounding standard deviation), and where the run has at most 400 readings the informed estimator
(told the true power of every order and the noise). Ratios are test RMS over the best plain
baseline's; coverage is the fraction of test readings within ±2σ of the blind model's predictive
band. Per suite: the median and worst ratio and the coverage.
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from encal.models import spectral  # noqa: E402
from encal.models.fourier import fit_fourier  # noqa: E402
from encal.models.spectral import fit_spectral  # noqa: E402

from _physics_world import PHYSICS_SUITES, physics_cases  # noqa: E402
from bench_floor_bound import informed_estimate  # noqa: E402
from bench_spectral import cases as own_cases  # noqa: E402
from bench_spectral import interp_model  # noqa: E402

OWN_SUITES = ("fleet", "fleet+", "rough", "12bit", "jitter", "epoch")
SUITES = OWN_SUITES + PHYSICS_SUITES
PLAIN = ("interp", "fourier cv", "fourier top10")
#: Highest order of the CV Fourier baseline on runs of more than 20,000 readings (see ``evaluate``).
DENSE_CV_ORDER = 1024
#: The informed estimator costs O(n³): computed on runs of at most this many readings.
INFORMED_LIMIT = 400


def rms(values):
    return float(np.sqrt(np.mean(np.square(values))))


FRESH = 0  # --fresh: other encoders of the physics world


def suite_cases(name):
    if name in OWN_SUITES:
        for _, encoder, case in own_cases([name]):
            yield encoder, case
    else:
        yield from physics_cases(name, FRESH)


def evaluate(case):
    theta, y, theta_test, y_test = case["theta"], case["y"], case["theta_test"], case["y_test"]
    result, seconds = {}, {}

    def run(label, fit):
        start = time.process_time()
        model = fit()
        seconds[label] = time.process_time() - start
        predict = model.predict if hasattr(model, "predict") else model
        result[label] = rms(y_test - predict(theta_test))
        return model

    run("interp", lambda: interp_model(theta, y))
    # On a dense sweep the CV over every identifiable order (past 4000 at 10^5 readings) takes minutes:
    # the baseline is capped at order DENSE_CV_ORDER there, above every order the dense suite's profile has.
    dense_cap = DENSE_CV_ORDER if theta.size > 20_000 else None
    run("fourier cv", lambda: fit_fourier(theta, y, select="cv", max_order=dense_cap))
    run("fourier top10", lambda: fit_fourier(theta, y, select="top", n_orders=10))
    blind = run("blind", lambda: fit_spectral(theta, y))
    run("noise", lambda: fit_spectral(theta, y, noise_arcmin=case["sigma"]))
    if theta.size <= INFORMED_LIMIT and case.get("truth") is not None:
        result["informed"] = rms(y_test - informed_estimate(theta, y, theta_test, case["truth"], case["sigma"]))
    mean, std = blind.predict(theta_test, return_std=True)
    result["coverage"] = float(np.mean(np.abs(y_test - mean) <= 2.0 * std))
    result["best plain"] = min(result[name] for name in PLAIN)
    result["lines"] = len(blind.training["lines"])
    result["max order"] = blind.training["max_order"]
    return result, seconds


def _cell(value, digits=3):
    return "-" if value is None else f"{value:.{digits}f}"


def run_suites(names, out):
    """Evaluate every suite, print the tables to ``out``; return the per-suite figures for the docs."""
    rows, summary, figures = [], [], []
    for suite in names:
        entries = []
        for encoder, case in suite_cases(suite):
            result, seconds = evaluate(case)
            entries.append((encoder, case, result, seconds))
            best = result["best plain"]
            rows.append(f"| {suite} | {encoder} | {case['theta'].size} | {case['floor']:.4g} | "
                        f"{result['interp'] / best:.3f} | {result['fourier cv'] / best:.3f} | "
                        f"{result['fourier top10'] / best:.3f} | **{result['blind'] / best:.3f}** | "
                        f"{result['noise'] / best:.3f} | "
                        f"{_cell(result['informed'] / best if 'informed' in result else None)} | "
                        f"{result['lines']} | {result['max order']} | {result['coverage']:.3f} | "
                        f"{seconds['blind']:.2f} | {seconds['noise']:.2f} |")
            print(rows[-1], file=sys.stderr, flush=True)
        blind = np.array([r["blind"] / r["best plain"] for _, _, r, _ in entries])
        noise = np.array([r["noise"] / r["best plain"] for _, _, r, _ in entries])
        informed = [r["blind"] / r["informed"] for _, _, r, _ in entries if "informed" in r]
        coverage = np.array([r["coverage"] for _, _, r, _ in entries])
        worst_time = max(s["blind"] for *_, s in entries)
        worst_noise_time = max(s["noise"] for *_, s in entries)
        figures.append({"suite": suite, "encoders": len(entries), "median": float(np.median(blind)),
                        "worst": float(blind.max()), "over_2": int(np.sum(blind > 1.02)),
                        "noise_median": float(np.median(noise)), "coverage": float(coverage.mean()),
                        "coverage_min": float(coverage.min()), "coverage_max": float(coverage.max())})
        summary.append(f"| {suite} | {len(entries)} | {np.median(blind):.3f} | {blind.max():.3f} | "
                       f"{int(np.sum(blind > 1.02))} | {int(np.sum(blind > 1.05))} | {np.median(noise):.3f} | "
                       f"{noise.max():.3f} | {_cell(np.median(informed) if informed else None)} | "
                       f"{coverage.mean():.3f} | {coverage.min():.3f}..{coverage.max():.3f} | {worst_time:.2f} | "
                       f"{worst_noise_time:.2f} |")
    table = ("| suite | encoders | blind / best plain, median | worst | encoders > 1.02 | > 1.05 | "
             "noise supplied / best plain, median | worst | blind / informed, median | ±2σ coverage, mean | "
             "range | slowest blind fit (CPU s) | slowest fit, noise supplied (CPU s) |\n"
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
             + "\n".join(summary) + "\n")
    print("## Per suite: blind default and noise supplied against the best plain baseline\n", file=out)
    print(table, file=out)
    print("\n## Every encoder: test RMS / best plain baseline\n", file=out)
    print("| suite | encoder | readings | floor (arcmin) | interp | fourier cv | fourier top10 | blind | "
          "noise supplied | informed | lines | highest order | ±2σ coverage | blind CPU (s) | "
          "noise supplied CPU (s) |", file=out)
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|", file=out)
    print("\n".join(rows), file=out)
    return table, figures


def readme_lines(figures, table_path):
    """The README's figures, one line per suite, each with the suite it holds on."""
    own = [f for f in figures if f["suite"] in OWN_SUITES]
    physics = [f for f in figures if f["suite"] not in OWN_SUITES]
    lines = [f"Measured by `python benchmarks/bench_worlds.py --write {table_path} --docs` (every encoder in "
             f"[{table_path}]({table_path})); test RMS of the default (blind) over the best plain baseline's "
             "(the best of np.interp, a CV-chosen Fourier series and a top-10 series), median (worst), "
             "and the ±2σ band's coverage of new readings (mean, range):", ""]
    for title, group in (("the project's own simulated world (encal.simulate)", own),
                         ("a second world written from the physics, not tuned to", physics)):
        if not group:
            continue
        lines.append(f"- on {title}:")
        for f in group:
            lines.append(f"  - `{f['suite']}` ({f['encoders']} encoders): {f['median']:.3f} ({f['worst']:.3f}); "
                         f"{f['over_2']} above 1.02; with the noise supplied {f['noise_median']:.3f}; "
                         f"coverage {100 * f['coverage']:.1f} % ({100 * f['coverage_min']:.1f}–"
                         f"{100 * f['coverage_max']:.1f} %)")
    return "\n".join(lines) + "\n"


def replace_block(path, name, text):
    """Replace what stands between ``<!-- name:begin -->`` and ``<!-- name:end -->`` in ``path``."""
    from encal._core.atomic import atomic_write

    content = path.read_text(encoding="utf-8")
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    if begin not in content or end not in content:
        raise SystemExit(f"{path} has no {begin} ... {end} block to write the tables into")
    head, rest = content.split(begin, 1)
    _, tail = rest.split(end, 1)
    atomic_write(path, f"{head}{begin}\n{text}{end}{tail}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suites", nargs="+", default=list(SUITES), choices=SUITES)
    parser.add_argument("--write", type=Path, help="also write the tables to this Markdown file")
    parser.add_argument("--blind", choices=spectral.BLIND_SPLITS, default=None,
                        help=f"the blind split of the flat level (default {spectral.BLIND_SPLIT!r})")
    parser.add_argument("--docs", action="store_true",
                        help="with --write: also rewrite the generated blocks of README.md and RESULTS.md")
    parser.add_argument("--fresh", type=int, default=0, metavar="K",
                        help="other encoders of the physics world (its seeds moved; K > 0), to check a rule "
                             "on encoders it was not chosen on; not with --docs")
    args = parser.parse_args()
    if args.fresh and args.docs:
        parser.error("--fresh is a check on other encoders; the README and RESULTS cite the standard ones")
    global FRESH
    FRESH = args.fresh
    if args.docs and not args.write:
        parser.error("--docs needs --write PATH (the file the README's figures cite)")
    if args.blind:
        spectral.BLIND_SPLIT = args.blind
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).parent).stdout.strip()
    command = "python benchmarks/bench_worlds.py" + (f" --blind {args.blind}" if args.blind else "") \
        + (f" --fresh {args.fresh}" if args.fresh else "") \
        + (f" --suites {' '.join(args.suites)}" if args.suites != list(SUITES) else "") \
        + (f" --write {args.write.as_posix()}" if args.write else "") + (" --docs" if args.docs else "")
    body = (f"Written by `{command}` ({time.strftime('%Y-%m-%d', time.gmtime())}, commit {commit}; blind split "
            f"{spectral.BLIND_SPLIT!r}; python {platform.python_version()}, numpy {np.__version__}; one process, "
            "one BLAS thread). Ratios are test RMS over the best plain baseline's (the best of np.interp, the "
            "CV-chosen Fourier series and the top-10 series); below 1 the default wins. Suites fleet..epoch are "
            "the project's own world (encal.simulate); the others the physics world of "
            "benchmarks/_physics_world.py, written from the physics references, which the default was not "
            "tuned to.\n")
    header = "# Both simulated worlds: the blind default against the best plain baseline\n\n" + body

    class Tee:
        def __init__(self):
            self.parts = [header]

        def write(self, text):
            self.parts.append(text)
            sys.stdout.write(text)

    out = Tee()
    print(header)
    table, figures = run_suites(args.suites, out)
    if args.write:
        from encal._core.atomic import atomic_write

        args.write.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(args.write, "".join(out.parts))
    if args.docs:
        root = Path(__file__).resolve().parents[1]
        table_path = args.write.resolve().relative_to(root).as_posix()
        replace_block(root / "README.md", "bench_worlds", readme_lines(figures, table_path))
        replace_block(root / "RESULTS.md", "bench_worlds",
                      f"{body}\n{table}\nEvery encoder: [{table_path}]({table_path}).\n")


if __name__ == "__main__":
    main()

"""The blind model at a fixed split of the flat level: the best any split rule blind to the suite can do.

Usage::

    python benchmarks/bench_split.py                          # the twelve 180/72/36-point suites, 11 fractions
    python benchmarks/bench_split.py --suites magnetic rough --fractions 0 0.5 1
    python benchmarks/bench_split.py --json split.json          # also keep every ratio

On a uniform grid one run cannot split the flat level of the spectrum between profile and noise
(docs/model-selection.md, "The blind split"). A rule that cannot tell the suites apart picks, in
effect, a split fraction ``f`` per encoder from what the run shows; the best fixed fraction bounds
what such a rule gains on the worst encoder only when it picks the same ``f`` everywhere. Per encoder
of bench_worlds.py's suites (all but the dense sweeps) this fits the spectral model blind with the
fraction ``f`` held fixed (``BLIND_SPLIT = 'fNN'``) for every ``f`` asked, and prints the ratio to the
best plain baseline: per fraction the worst encoder and the suite medians, then ``min over f of (max
over encoders)``, the same for the best fixed mixture of the fractions' predictions (weights that do not
depend on the run), and, per encoder, the best fraction (the oracle no single run can choose).
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402

import numpy as np  # noqa: E402

from encal.models import spectral  # noqa: E402
from encal.models.fourier import fit_fourier  # noqa: E402
from encal.models.spectral import fit_spectral  # noqa: E402

from bench_spectral import interp_model  # noqa: E402
from bench_worlds import SUITES, rms, suite_cases  # noqa: E402

#: The suites of at most a few hundred readings (the dense sweeps have no flat level to split).
SPLIT_SUITES = tuple(s for s in SUITES if s != "stepper-dense")


def ratios(case, fractions):
    """Test RMS over the best plain baseline's, per fraction (and for the default 'uniform'); the test
    residuals of each fixed fraction scaled by that baseline's RMS, for :func:`minimax_mixture`."""
    theta, y, theta_test, y_test = case["theta"], case["y"], case["theta_test"], case["y_test"]
    plain = [rms(y_test - interp_model(theta, y)(theta_test)),
             rms(y_test - fit_fourier(theta, y, select="cv").predict(theta_test)),
             rms(y_test - fit_fourier(theta, y, select="top", n_orders=10).predict(theta_test))]
    best = min(plain)
    out, residuals = {}, []
    default = spectral.BLIND_SPLIT
    for rule in list(dict.fromkeys([default, "uniform"])) + [f"f{round(100 * f)}" for f in fractions]:
        spectral.BLIND_SPLIT = rule
        try:
            residual = (y_test - fit_spectral(theta, y).predict(theta_test)) / best
        finally:
            spectral.BLIND_SPLIT = default
        out[rule] = rms(residual)
        if not _is_mixture(rule):
            residuals.append(residual)
    return out, np.array(residuals)


def _is_mixture(rule):
    """Whether ``rule`` mixes several fractions (the default and the uniform prior) rather than fixing one."""
    return not rule.startswith("f")


def _label(rule):
    if rule == "uniform":
        return "uniform on [0, 1]"
    if rule.startswith("b"):
        return "two points " + " and ".join(f"{int(part) / 100:.1f}" for part in rule[1:].split("-"))
    return f"f = {int(rule[1:]) / 100:.1f}"


def minimax_mixture(residuals):
    """Weights ``w`` on the fixed fractions (``w >= 0``, ``Σ w = 1``) whose mean prediction has the lowest
    worst ratio over the encoders: ``min_w max_e rms(Σ_f w_f r_ef)`` (convex; SLSQP on its epigraph).

    Parameters
    ----------
    residuals : list of ndarray of shape (F, n_e)
        Per encoder, the scaled test residuals of each fixed fraction.
    """
    from scipy.optimize import minimize

    count = residuals[0].shape[0]

    def worst(w):
        return [rms(w @ r) for r in residuals]

    start = np.append(np.full(count, 1.0 / count), max(worst(np.full(count, 1.0 / count))))
    result = minimize(lambda v: v[-1], start, method="SLSQP", bounds=[(0.0, 1.0)] * count + [(0.0, None)],
                      constraints=[{"type": "eq", "fun": lambda v: np.sum(v[:-1]) - 1.0},
                                   {"type": "ineq", "fun": lambda v: v[-1] - np.array(worst(v[:-1]))}],
                      options={"maxiter": 500, "ftol": 1e-10})
    weights = np.clip(result.x[:-1], 0.0, None)
    weights /= weights.sum()
    return weights, max(worst(weights))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suites", nargs="+", default=list(SPLIT_SUITES), choices=SPLIT_SUITES)
    parser.add_argument("--fractions", nargs="+", type=float, default=[round(0.1 * i, 1) for i in range(11)])
    parser.add_argument("--json", help="also write every ratio to this JSON file")
    args = parser.parse_args()
    if any(not 0.0 <= f <= 1.0 for f in args.fractions):
        parser.error("--fractions must lie in [0, 1]")
    table, residuals = [], []  # (suite, encoder, {rule: ratio}); per encoder, the fixed fractions' residuals
    for suite in args.suites:
        for encoder, case in suite_cases(suite):
            ratio, residual = ratios(case, args.fractions)
            table.append((suite, encoder, ratio))
            residuals.append(residual)
            print(suite, encoder, " ".join(f"{k}={v:.3f}" for k, v in table[-1][2].items()), file=sys.stderr,
                  flush=True)
    if args.json:
        from encal._core.atomic import atomic_write

        atomic_write(args.json, json.dumps([{"suite": s, "encoder": e, "ratios": r} for s, e, r in table], indent=1))
    rules = list(table[0][2])
    suites = list(dict.fromkeys(s for s, _, _ in table))
    print(f"| split | worst encoder | encoders > 1.02 / > 1.05 | {' | '.join(suites)} |")
    print("|---|---|---|" + "---|" * len(suites))
    worst = {}
    for rule in rules:
        values = np.array([r[rule] for _, _, r in table])
        k = int(np.argmax(values))
        worst[rule] = values[k]
        medians = [np.median([r[rule] for s, _, r in table if s == suite]) for suite in suites]
        label = _label(rule) + (" (the default)" if rule == spectral.BLIND_SPLIT else "")
        print(f"| {label} | {values[k]:.3f} ({table[k][0]} {table[k][1]}) | {int(np.sum(values > 1.02))} / "
              f"{int(np.sum(values > 1.05))} | " + " | ".join(f"{m:.3f}" for m in medians) + " |")
    fixed = [rule for rule in rules if not _is_mixture(rule)]
    best_rule = min(fixed, key=worst.get)
    print(f"\nmin over f of (max over encoders): {worst[best_rule]:.3f} at f = {int(best_rule[1:]) / 100:.1f}")
    oracle = np.array([min(r[rule] for rule in fixed) for _, _, r in table])
    print(f"oracle (each encoder at its own best f): worst {oracle.max():.3f}, "
          f"above 1.05: {int(np.sum(oracle > 1.05))}")
    weights, bound = minimax_mixture(residuals)
    print(f"min over fixed mixtures of the fractions' predictions (max over encoders): {bound:.3f}, weights "
          + ", ".join(f"{f:.1f}: {w:.2f}" for f, w in zip(args.fractions, weights) if w > 0.005))


if __name__ == "__main__":
    main()

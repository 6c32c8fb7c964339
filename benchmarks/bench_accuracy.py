"""Accuracy of every model family on the demo fleet, against the measurement floor.

Usage::

    python benchmarks/bench_accuracy.py              # 3 seeds, about 10 s (2026-11-28)
    python benchmarks/bench_accuracy.py --seeds 1    # quicker
    python benchmarks/bench_accuracy.py --cv-choice  # only the cross-validated choice (--folds 5), with and
                                                     # without stacking, auto's default before 2026-11-24
    python benchmarks/bench_accuracy.py --known-truth  # only docs/statistics.md's known-truth table (seconds)

Every method is fitted to each demo encoder's training run (0:2:358 degrees) and
evaluated on its test run (1:2:359 degrees, between the training points, read
with fresh noise). The measurement floor of the test run is the RMS of its
measured minus its noise-free error: what a model that knew the systematic error
exactly would leave. A ratio RMS / floor of 1.00 is perfect.

Table 1: test RMS (arcmin) and RMS / floor per encoder and method, averaged over
the seeds (only the networks, the hybrid and auto depend on the seed).

Table 2: what auto chose for each encoder and seed, and how the choice compares
with the candidate that would have been best on the test run (the "oracle",
every default candidate refitted on all training points and tested): this
measures what choosing by cross-validation costs.

Table 3: CPU time of each fit (seconds, mean over encoders and seeds).
"""

import os

# One BLAS thread: the matrices are small and a threaded BLAS contends on 2 cores.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import encal  # noqa: E402
from _methods import METHODS, RANDOMISED  # noqa: E402  (benchmarks/_methods.py)
from encal.models.select import DEFAULT_CANDIDATES  # noqa: E402
from encal.simulate import demo_fleet, measurement_floor  # noqa: E402


def fit_and_test(cal, test_cal, method, options, seed):
    """Fit on ``cal``; return (model, test RMS in arcmin, CPU seconds of the fit)."""
    start = time.process_time()
    model = encal.fit(cal, method=method, rng=seed if method in RANDOMISED else None, **options)
    elapsed = time.process_time() - start
    return model, encal.evaluate(model, test_cal).after.rms, elapsed


def oracle(cal, test_cal, seed):
    """Test RMS of every default auto candidate refitted on all training points: label -> RMS."""
    result = {}
    for candidate in DEFAULT_CANDIDATES:
        model = candidate.fit(cal.encoder_deg, cal.errors_arcmin, rng=np.random.default_rng(seed))
        result[candidate.label] = encal.evaluate(model, test_cal).after.rms
    return result


def cv_choice(seeds):
    """The cross-validated choice (``folds=5``) with and without stacking: test RMS per encoder (mean over the
    seeds; its networks depend on them), RMS / floor, and the mean CPU of a fit."""
    fleet = demo_fleet()
    print(f"# the cross-validated choice on the demo fleet, seeds 0..{len(seeds) - 1}; load "
          f"{open('/proc/loadavg').read().split()[0]}\n")
    print("| choice | " + " | ".join(m.name for m in fleet) + " | CPU per fit, s |")
    print("|---|" + "---|" * (len(fleet) + 1))
    chosen = []
    for label, options in (("with stacking", {}), ("one family (no stack)", {"stack": False})):
        cells, cpu = [], []
        for member in fleet:
            floor = measurement_floor(member.test)
            tested = []
            for seed in seeds:
                model, test_rms, elapsed = fit_and_test(member.train.calibration, member.test.calibration, "auto",
                                                        {"folds": 5, **options}, seed)
                tested.append(test_rms)
                cpu.append(elapsed)
                chosen.append(f"{label}, {member.name}, seed {seed}: {model.training['selection']['chosen']}")
            cells.append(f"{np.mean(tested):.4f} ({np.mean(tested) / floor:.2f})")
        print(f"| {label} | " + " | ".join(cells) + f" | {np.mean(cpu):.2f} |")
    print("\n" + "\n".join(chosen))


def known_truth(seeds=range(20)):
    """docs/statistics.md: six orders and white noise of 0.1 arcmin on 0:2:358 (``noisy_profile`` of
    tests/models/test_fourier.py), seeds 0-19; RMS of the fitted curve against the truth on 3601 points."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests.models.test_fourier import TRAIN, noisy_profile, series

    from encal.models.fourier import fit_fourier
    from encal.models.lut import fit_lut

    dense = np.linspace(0.0, 360.0, 3601)
    methods = {"fourier top 10": (fit_fourier, {}), "fourier cv": (fit_fourier, {"select": "cv"}),
               "lut linear": (fit_lut, {}), "lut cubic": (fit_lut, {"interpolation": "cubic"})}
    print("| method | mean | max | orders kept (mean) |")
    print("|---|---|---|---|")
    for name, (fit, options) in methods.items():
        errors, kept = [], []
        for seed in seeds:
            orders, cos, sin, noise = noisy_profile(seed)
            model = fit(TRAIN, series(TRAIN, orders, cos, sin) + noise, **options)  # the angles on the grid
            errors.append(np.sqrt(np.mean((model.predict(dense) - series(dense, orders, cos, sin)) ** 2)))
            kept.append(len(model.orders) if fit is fit_fourier else None)
        orders_kept = f"{np.mean(kept):.3g}" if fit is fit_fourier else "–"
        print(f"| {name} | {np.mean(errors):.3f} | {np.max(errors):.3f} | {orders_kept} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=3, help="number of seeds 0..N-1 (default 3)")
    parser.add_argument("--cv-choice", action="store_true",
                        help="only the cross-validated choice (folds=5), with and without stacking")
    parser.add_argument("--known-truth", action="store_true", help="only docs/statistics.md's known-truth table")
    args = parser.parse_args()
    seeds = range(args.seeds)
    if args.known_truth:
        known_truth()
        return
    if args.cv_choice:
        cv_choice(seeds)
        return

    fleet = demo_fleet()
    rms = {name: {m.name: [] for m in fleet} for name in METHODS}
    seconds = {name: [] for name in METHODS}
    choices = []
    floors = {}
    for member in fleet:
        cal, test_cal = member.train.calibration, member.test.calibration
        floors[member.name] = measurement_floor(member.test)
        for seed in seeds:
            for name, (method, options) in METHODS.items():
                if seed > 0 and method not in RANDOMISED:
                    rms[name][member.name].append(rms[name][member.name][0])
                    continue
                model, test_rms, elapsed = fit_and_test(cal, test_cal, method, options, seed)
                rms[name][member.name].append(test_rms)
                seconds[name].append(elapsed)
                if method == "auto":
                    tested = oracle(cal, test_cal, seed)
                    best_label = min(tested, key=tested.get)
                    choices.append((member.name, seed, model.training["selection"]["chosen"], test_rms,
                                    best_label, tested[best_label]))

    print(f"# Accuracy on the demo fleet (test runs), seeds 0..{args.seeds - 1}")
    print(f"python {platform.python_version()}, numpy {np.__version__}, {os.cpu_count()} cores, "
          f"{platform.machine()}\n")
    print("## Table 1: test RMS in arcmin (RMS / measurement floor)\n")
    names = [m.name for m in fleet]
    print("| method | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    print("| measurement floor | " + " | ".join(f"{floors[n]:.4f}" for n in names) + " |")
    for name in METHODS:
        cells = [f"{np.mean(rms[name][n]):.4f} ({np.mean(rms[name][n]) / floors[n]:.2f})" for n in names]
        print(f"| {name} | " + " | ".join(cells) + " |")

    print("\n## Goals\n")
    auto_ratio = {n: np.mean(rms["auto"][n]) / floors[n] for n in names}
    ann_ratio = {n: np.mean(rms["ann periodic"][n]) / floors[n] for n in names}
    worst_auto, worst_ann = max(auto_ratio.values()), max(ann_ratio.values())
    print(f"- auto within 1.05x the floor on every encoder: {'MET' if worst_auto <= 1.05 else 'NOT MET'} "
          f"(worst {worst_auto:.2f}x)")
    print(f"- network alone (ann periodic) within 1.15x: {'MET' if worst_ann <= 1.15 else 'NOT MET'} "
          f"(worst {worst_ann:.2f}x)")
    best_other = {n: min(np.mean(rms[m][n]) for m in METHODS if m != "auto") for n in names}
    print("- auto / best single method per encoder: "
          + ", ".join(f"{n} {np.mean(rms['auto'][n]) / best_other[n]:.3f}" for n in names))

    print("\n## Table 2: auto's choice against the best candidate on the test run\n")
    print("| encoder | seed | auto chose | its test RMS | best candidate on test | its test RMS | ratio |")
    print("|---|---|---|---|---|---|---|")
    for name, seed, chosen, chosen_rms, best_label, best_rms in choices:
        print(f"| {name} | {seed} | {chosen} | {chosen_rms:.4f} | {best_label} | {best_rms:.4f} | "
              f"{chosen_rms / best_rms:.3f} |")

    print("\n## Table 3: CPU seconds per fit (mean)\n")
    print("| method | seconds |")
    print("|---|---|")
    for name in METHODS:
        print(f"| {name} | {np.mean(seconds[name]):.3f} |")


if __name__ == "__main__":
    main()

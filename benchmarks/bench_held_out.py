"""How close is the held-out estimate `encal fit --method X` prints to the model's test RMS?

For every encoder of the demo fleet and of ``simulate_fleet(4, 7)`` (the first four of
``encal simulate --encoders 8 --seed 7``), every method and seed: fit on the training run (0:2:358), compute
the held-out estimate exactly as ``encal fit`` does (``encal.cli._fit_report.held_out``), and test the model on
the test run (1:2:359, same epoch). Prints one row per fit (the estimate, the pooled RMS of the folds, the
test RMS and their ratios) and, per method, the range of estimate / test RMS.

``--fold-bend``: why a network's folds can miss by far more than the network fitted on all points. On the
first demo encoder, for 2, 3, 5 and 10 interleaved folds, the hybrid (``fit_hybrid``) is fitted on every
fold's training part with 6 seeds, and on all points with 10; printed per seed: the largest |network part|
on a 0.1-degree grid over the folds (arcmin), the bend between the points a fold's holes let it make.

Run:  .venv/bin/python benchmarks/bench_held_out.py [--methods fourier lut ann hybrid] [--seeds 5]
      .venv/bin/python benchmarks/bench_held_out.py --fold-bend
"""

import argparse

import numpy as np

from encal.cli._fit_report import held_out
from encal.models.fitting import fit
from encal.models.hybrid import fit_hybrid
from encal.models.validation import interleaved_folds
from encal.simulate import demo_fleet, simulate_fleet


def fold_bend():
    """Largest |network part| of the hybrid fitted on one fold's training part, against the number of folds."""
    train = demo_fleet()[0].train.calibration
    theta, error = train.encoder_deg, train.errors_arcmin
    grid = np.arange(0.0, 360.0, 0.1)
    for folds in (2, 3, 5, 10, None):
        parts = [np.ones(theta.size, bool)] if folds is None else [
            interleaved_folds(theta, folds) != k for k in range(folds)]
        seeds = range(10 if folds is None else 6)
        bends = [max(float(np.max(np.abs(fit_hybrid(theta[keep], error[keep], rng=seed).ann.predict(grid))))
                     for keep in parts) for seed in seeds]
        label = "all points" if folds is None else f"{folds} folds, the largest of its fits"
        print(f"{label:32s} largest |network part| {min(bends):.2f}-{max(bends):.2f} arcmin over "
              f"{len(bends)} seeds: " + " ".join(f"{b:.2f}" for b in bends), flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", nargs="+", default=["fourier", "lut", "ann", "hybrid"])
    parser.add_argument("--seeds", type=int, default=5, help="seeds of the randomised methods (default 5)")
    parser.add_argument("--fold-bend", action="store_true", help="the hybrid's bend against the number of folds")
    args = parser.parse_args()
    if args.fold_bend:
        fold_bend()
        return
    fleet = [*demo_fleet(), *simulate_fleet(4, 7)]
    for method in args.methods:
        ratios = []
        for index, encoder in enumerate(fleet):
            train, test = encoder.train.calibration, encoder.test.calibration
            for seed in range(args.seeds if method in ("ann", "hybrid") else 1):
                options = {"rng": seed} if method in ("ann", "hybrid") else {}
                model = fit(train, method=method, **options)
                estimate = held_out(model, train, method, options)
                residual = test.errors_arcmin - model.predict(test.encoder_deg)
                test_rms = float(np.sqrt(np.mean(residual**2)))
                ratios.append(estimate["rms_arcmin"] / test_rms)
                print(f"{method:8s} encoder {index} seed {seed}: estimate {estimate['rms_arcmin']:.3f} "
                      f"pooled {estimate['pooled_rms_arcmin']:.3f} test {test_rms:.3f} arcmin; estimate/test "
                      f"{ratios[-1]:.2f}, pooled/test {estimate['pooled_rms_arcmin'] / test_rms:.2f}; bend "
                      f"{estimate.get('bend_between_points_arcmin', float('nan')):.3g}", flush=True)
        print(f"{method}: estimate / test RMS {min(ratios):.2f}-{max(ratios):.2f}, median {np.median(ratios):.2f} "
              f"over {len(ratios)} fits", flush=True)


if __name__ == "__main__":
    main()

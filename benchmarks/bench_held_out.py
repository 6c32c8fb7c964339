"""How close is the held-out estimate `encal fit --method X` prints to the model's test RMS?

For every encoder of the demo fleet and of ``simulate_fleet(4, 7)`` (the first four of
``encal simulate --encoders 8 --seed 7``), every method and seed: fit on the training run (0:2:358), compute
the held-out estimate exactly as ``encal fit`` does (``encal.cli._fit_report.held_out``), and test the model on
the test run (1:2:359, same epoch). Prints one row per fit (the estimate, the pooled RMS of the folds, the
test RMS and their ratios) and, per method, the range of estimate / test RMS.

Run:  .venv/bin/python benchmarks/bench_held_out.py [--methods fourier lut ann hybrid] [--seeds 5]
"""

import argparse

import numpy as np

from encal.cli._fit_report import held_out
from encal.fitting import fit
from encal.simulate import demo_fleet, simulate_fleet


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", nargs="+", default=["fourier", "lut", "ann", "hybrid"])
    parser.add_argument("--seeds", type=int, default=5, help="seeds of the randomised methods (default 5)")
    args = parser.parse_args()
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

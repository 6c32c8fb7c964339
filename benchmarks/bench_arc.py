"""Calibration over an arc (issue 31): the arc model's test RMS against the measurement floor.

Usage::

    python benchmarks/bench_arc.py               # 4 simulated encoders x arcs of 30, 90, 180 deg, ~1 minute
    python benchmarks/bench_arc.py --encoders 2  # quicker

Each simulated encoder (encal.simulate.draw_encoder) is calibrated on an arc starting at a random angle:
training readings every 0.25 deg, test readings between them (offset by 0.125 deg) with fresh noise. The
measurement floor is the test run's RMS of measured minus noise-free error (what a model that knew the
systematic error exactly would leave). Compared: ``encal.fit`` (the default on an arc: the arc kind, a
penalised spline with its smoothing chosen by evidence), ``np.interp`` of the training errors, and a Legendre
polynomial whose degree (1..40) is chosen by 5-fold cross-validation. Goal: test RMS <= 1.1x the floor.
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from numpy.polynomial import legendre  # noqa: E402

import encal  # noqa: E402
from encal.fitting import evaluate  # noqa: E402
from encal.simulate import calibration_run, draw_encoder, measurement_floor  # noqa: E402

STEP_DEG = 0.25


def polynomial_cv(x, y, x_new, degrees=range(1, 41), folds=5):
    """Legendre polynomial on the arc, degree chosen by 5-fold CV (interleaved folds)."""
    low, high = x.min(), x.max()
    scaled = 2.0 * (x - low) / (high - low) - 1.0
    best, best_degree = np.inf, 1
    for degree in degrees:
        if degree >= x.size // 2:
            break
        errors = []
        for fold in range(folds):
            test = np.arange(x.size) % folds == fold
            coef = legendre.legfit(scaled[~test], y[~test], degree)
            errors.append(np.mean((legendre.legval(scaled[test], coef) - y[test]) ** 2))
        if np.mean(errors) < best:
            best, best_degree = float(np.mean(errors)), degree
    coef = legendre.legfit(scaled, y, best_degree)
    return legendre.legval(2.0 * (x_new - low) / (high - low) - 1.0, coef), best_degree


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--encoders", type=int, default=4)
    args = parser.parse_args()
    rows = []
    print(f"{'arc':>5} {'encoder':>8} {'floor':>7} {'encal/floor':>12} {'interp/floor':>13} {'poly-CV/floor':>14} "
          f"{'(deg)':>6} {'fit s':>6}")
    for span in (30.0, 90.0, 180.0):
        for seed in range(args.encoders):
            rng = np.random.default_rng(1000 + seed)
            encoder = draw_encoder(seed)
            start = float(rng.uniform(0.0, 360.0))
            train_angles = np.mod(start + np.arange(0.0, span + 1e-9, STEP_DEG), 360.0)
            test_angles = np.mod(start + np.arange(STEP_DEG / 2, span, STEP_DEG), 360.0)
            train = calibration_run(encoder, train_angles, rng=rng)
            test = calibration_run(encoder, test_angles, rng=rng)
            floor = measurement_floor(test)
            began = time.process_time()
            model = encal.fit(train.calibration)
            elapsed = time.process_time() - began
            assert model.kind == "arc"
            result = evaluate(model, test.calibration)
            encal_rms = result.after.rms
            # baselines on the unwrapped arc
            middle = start + span / 2.0  # unwrapped about the arc's middle: a reading just below start stays there
            x = np.mod(train.calibration.encoder_deg - middle + 180.0, 360.0) - 180.0
            x_new = np.mod(test.calibration.encoder_deg - middle + 180.0, 360.0) - 180.0
            order = np.argsort(x)
            interp = np.interp(x_new, x[order], train.errors_arcmin[order])
            interp_rms = float(np.sqrt(np.mean((test.errors_arcmin - interp) ** 2)))
            poly, degree = polynomial_cv(x, train.errors_arcmin, x_new)
            poly_rms = float(np.sqrt(np.mean((test.errors_arcmin - poly) ** 2)))
            rows.append((span, encal_rms / floor, interp_rms / floor, poly_rms / floor))
            print(f"{span:5.0f} {encoder.name + str(seed):>8} {floor:7.4f} {encal_rms / floor:12.3f} "
                  f"{interp_rms / floor:13.3f} {poly_rms / floor:14.3f} {degree:6d} {elapsed:6.2f}")
    data = np.array(rows)
    print("\nmean ratio to the floor (goal <= 1.1 for encal)")
    for span in (30.0, 90.0, 180.0):
        part = data[data[:, 0] == span]
        print(f"  arc {span:5.0f} deg: encal {part[:, 1].mean():.3f} (max {part[:, 1].max():.3f}), "
              f"np.interp {part[:, 2].mean():.3f}, polynomial by CV {part[:, 3].mean():.3f}")


if __name__ == "__main__":
    main()

"""encal's default network fit against scikit-learn's MLPRegressor (L-BFGS) on the demo fleet.

Usage::

    python benchmarks/bench_vs_sklearn.py        # 3-4 minutes on 2 cores

For each demo-fleet encoder, each network size and three seeds, both
libraries fit a 1:N:1 tanh network to the training run (0:2:358°) and are
scored by the RMS of the residual on the interleaved test run (1:2:359°).
Both get the same inputs: the encoded angle (``periodic``: cos θ, sin θ;
``raw``: degrees) and the error, both mapminmax'ed to [-1, 1] as encal does.
Networks: 1:30:1 periodic (encal's default), 1:80:1 periodic, and the
paper's 1:80:1 raw.

- encal: :func:`encal.models.ann.fit_ann` with its defaults: trainlm stopped
  by the paper's rule (RMS error down by less than 1 % over 20 epochs, at
  most 1000 epochs; ``encal.models.ann.DEFAULT_STOPPING``). A callback stamps
  the time of every epoch, so the table also gives the time encal took to
  first reach the test RMS sklearn ended with. For reference the first table
  also gives trainlm with MATLAB's rule (``plateau_patience=None``: 1000
  epochs on these profiles), encal's default before the plateau stop.
- sklearn "default": ``MLPRegressor(solver='lbfgs', activation='tanh',
  max_iter=1000)``, other parameters at their defaults (``tol=1e-4`` ends
  L-BFGS early; L2 penalty ``alpha=1e-4``).
- sklearn "converged": the same with ``tol=0``, ``max_iter=20000``,
  ``max_fun=10**6``: L-BFGS runs until it stalls.

Times are wall-clock seconds of the fit call. Means over encoders and seeds.
Ratios: "RMS ratio" is sklearn's test RMS over encal's (> 1: encal more
accurate); "speed-up" is sklearn's time over the time of encal's whole
default fit (≥ 5 is the goal); "speed-up to reach" is sklearn's time over
encal's time to first reach sklearn's test RMS (picked with the test data,
so a measure of how fast trainlm converges, not a stopping rule; encal's full
time for the runs that never reach it, counted in "reached"). "speed-up to
sklearn's training RMS" is the usual comparison of two optimisers on one
problem: sklearn's time over encal's time to first fit the training points
as closely as sklearn's final fit does, with trainlm run without an early
stop (MATLAB's 1000 epochs; no test data involved; its full time when it
never gets there).
"""

import os
import platform
import time
import warnings

import numpy as np
from sklearn.exceptions import ConvergenceWarning
from sklearn.neural_network import MLPRegressor

from encal.models.ann import ANNModel, fit_ann
from encal.simulate._fleet import demo_fleet
from encal.training.network import MapMinMax, encode_angles, unpack_weights

CONFIGS = (("periodic", 30), ("periodic", 80), ("raw", 80))
SEEDS = (0, 1, 2)


def rms(values):
    return float(np.sqrt(np.mean(np.square(values))))


def fit_sklearn(theta, error, theta_test, encoding, hidden, seed, converged):
    inputs = encode_angles(theta, encoding)
    input_scaling, target_scaling = MapMinMax.fit(inputs), MapMinMax.fit(error)
    options = {"tol": 0.0, "max_iter": 20000, "max_fun": 10**6} if converged else {"max_iter": 1000}
    regressor = MLPRegressor(hidden_layer_sizes=(hidden,), activation="tanh", solver="lbfgs",
                             random_state=seed, **options)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        regressor.fit(input_scaling.apply(inputs), target_scaling.apply(error))
    seconds = time.perf_counter() - start
    predicted = regressor.predict(input_scaling.apply(encode_angles(theta_test, encoding)))
    fitted = target_scaling.reverse(regressor.predict(input_scaling.apply(inputs)))
    return target_scaling.reverse(predicted), seconds, rms(error - fitted)


def fit_encal(theta, error, theta_test, error_test, encoding, hidden, seed, **options):
    """``(final test RMS, seconds, [(seconds, weights) per epoch], model)``."""
    stamps = []
    start = time.perf_counter()
    model = fit_ann(theta, error, hidden=hidden, encoding=encoding, rng=seed,
                    callback=lambda epoch, w, mse: stamps.append((time.perf_counter(), w.copy())), **options)
    seconds = time.perf_counter() - start
    return rms(error_test - model.predict(theta_test)), seconds, [(t - start, w) for t, w in stamps], model


def time_to_reach(target_rms, stamps, model, theta_test, error_test):
    """Seconds until encal's RMS on ``(theta_test, error_test)`` first fell to ``target_rms``, or None."""
    for seconds, w in stamps:
        W1, b1, W2, b2 = unpack_weights(w, model.W1.shape[1], model.hidden)
        candidate = ANNModel(W1, b1, W2, b2, encoding=model.encoding, activation=model.activation,
                             input_offset=model.input_scaling.offset, input_gain=model.input_scaling.gain,
                             target_offset=model.target_scaling.offset,
                             target_gain=model.target_scaling.gain)
        if rms(error_test - candidate.predict(theta_test)) <= target_rms:
            return seconds
    return None


def main():
    fleet = demo_fleet()
    threads = os.environ.get("OPENBLAS_NUM_THREADS", "default")
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, OPENBLAS_NUM_THREADS={threads}, "
          f"load average {', '.join(f'{v:.1f}' for v in os.getloadavg())}")
    print(f"{len(fleet)} demo encoders x {len(SEEDS)} seeds; test RMS on the interleaved grid (arcmin), "
          "fit time (s); means\n")
    runs = [(member, seed) for member in fleet for seed in SEEDS]
    stops = (("MATLAB (1000)", {"plateau_patience": None}), ("default", {}))
    rows = []
    for encoding, hidden in CONFIGS:
        encal = {label: [] for label, _ in stops}
        sklearn = {False: [], True: []}
        # One run at a time, every fitter in turn, so that a change in the machine's load falls on all.
        for member, seed in runs:
            train_cal, test_cal = member.train.calibration, member.test.calibration
            data = (train_cal.encoder_deg, train_cal.errors_arcmin, test_cal.encoder_deg)
            for label, options in stops:
                encal[label].append(fit_encal(*data, test_cal.errors_arcmin, encoding, hidden, seed, **options))
            _, seconds, stamps, model = encal["default"][-1]
            # The optimisers compared on the training objective: trainlm without an early stop.
            _, full_seconds, full_stamps, full_model = encal["MATLAB (1000)"][-1]
            for converged in (False, True):
                predicted, sk_seconds, sk_train_rms = fit_sklearn(*data, encoding, hidden, seed, converged)
                sk_rms = rms(test_cal.errors_arcmin - predicted)
                reach = time_to_reach(sk_rms, stamps, model, test_cal.encoder_deg, test_cal.errors_arcmin)
                fit_reach = time_to_reach(sk_train_rms, full_stamps, full_model, *data[:2])
                sklearn[converged].append((sk_rms, sk_seconds, seconds if reach is None else reach,
                                           reach is not None, full_seconds if fit_reach is None else fit_reach,
                                           fit_reach is not None))
        rows.append((encoding, hidden, encal, sklearn))

    print(f"{'network':<17} {'encal stop':<15} {'RMS':>7} {'s':>6} {'epochs':>9}")
    for encoding, hidden, encal, _ in rows:
        for label, fits in encal.items():
            epochs = [fit[3].training["epochs"] for fit in fits]
            print(f"1:{hidden}:1 {encoding:<9} {label:<15} {np.mean([f[0] for f in fits]):>6.4f}' "
                  f"{np.mean([f[1] for f in fits]):>6.3f} {min(epochs):>4d}-{max(epochs):<4d}")
    print(f"\n{'network':<17} {'sklearn':<9} {'RMS':>7} {'s':>6} | {'encal RMS':>9} {'s':>6} "
          f"{'s to reach':>10} {'reached':>7} | {'RMS ratio':>9} {'speed-up':>8} {'to reach':>8} | "
          f"{'s to train RMS':>14} {'reached':>7} {'speed-up':>8}")
    for encoding, hidden, encal, sklearn in rows:
        e_rms = np.mean([fit[0] for fit in encal["default"]])
        e_time = np.mean([fit[1] for fit in encal["default"]])
        for converged, results in sklearn.items():
            sk_rms, sk_time, reach, reached, fit_reach, fit_reached = (np.array(c) for c in zip(*results))
            print(f"1:{hidden}:1 {encoding:<9} {'converged' if converged else 'default':<9} "
                  f"{sk_rms.mean():>6.4f}' {sk_time.mean():>6.3f} | {e_rms:>8.4f}' {e_time:>6.3f} "
                  f"{reach.mean():>10.3f} {int(reached.sum()):>3d}/{len(runs):<3d} | "
                  f"{sk_rms.mean() / e_rms:>8.2f}x {sk_time.mean() / e_time:>7.2f}x "
                  f"{sk_time.mean() / reach.mean():>7.1f}x | {fit_reach.mean():>14.3f} "
                  f"{int(fit_reached.sum()):>3d}/{len(runs):<3d} {sk_time.mean() / fit_reach.mean():>7.1f}x")
    print(f"\nload average at the end {', '.join(f'{v:.1f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()

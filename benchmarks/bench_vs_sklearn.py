"""encal's trainlm network against scikit-learn's MLPRegressor (L-BFGS) on the demo fleet.

Usage::

    python benchmarks/bench_vs_sklearn.py        # a few minutes on 2 cores

For each demo-fleet encoder, each network size and three seeds, both
libraries fit a 1:N:1 tanh network to the training run (0:2:358°) and are
scored by the RMS of the residual on the interleaved test run (1:2:359°).
Both get the same inputs: the encoded angle (``periodic``: cos θ, sin θ;
``raw``: degrees) and the error, both mapminmax'ed to [-1, 1] as encal does.

- encal: :func:`encal.models.ann.fit_ann`, trainlm with MATLAB's defaults
  (1000 epochs). A callback stamps the time of every epoch, so the table also
  gives the time encal took to first reach the test RMS sklearn ended with.
- sklearn "default": ``MLPRegressor(solver='lbfgs', activation='tanh',
  max_iter=1000)``, other parameters at their defaults (``tol=1e-4`` ends
  L-BFGS early; L2 penalty ``alpha=1e-4``).
- sklearn "converged": the same with ``tol=0``, ``max_iter=20000``,
  ``max_fun=10**6``: L-BFGS runs until it stalls.

Times are wall-clock seconds of the fit call. Means over encoders and seeds.
"speed-up to reach": sklearn's time over encal's time to first reach
sklearn's test RMS (picked with the test data, so a measure of how fast
trainlm converges, not a stopping rule; encal's full time for the runs that
never reach it, counted in "reached"). "full run": sklearn's time over the
time of encal's whole 1000-epoch fit.
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
    return target_scaling.reverse(predicted), seconds


def fit_encal(theta, error, theta_test, error_test, encoding, hidden, seed):
    """``(final test RMS, seconds, [(seconds, weights) per epoch], model)``."""
    stamps = []
    start = time.perf_counter()
    model = fit_ann(theta, error, hidden=hidden, encoding=encoding, rng=seed,
                    callback=lambda epoch, w, mse: stamps.append((time.perf_counter(), w.copy())))
    seconds = time.perf_counter() - start
    return rms(error_test - model.predict(theta_test)), seconds, [(t - start, w) for t, w in stamps], model


def time_to_reach(target_rms, stamps, model, theta_test, error_test):
    """Seconds until encal's test RMS first fell to ``target_rms``, or None."""
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
          "fit time (s)\n")
    print(f"{'network':<16} {'sklearn':<9} {'RMS':>7} {'s':>6} | {'encal RMS':>9} {'s':>6} "
          f"{'s to reach':>10} {'reached':>7} | {'speed-up to reach':>17} {'full run':>8}")
    for encoding, hidden in CONFIGS:
        runs = [(member, seed) for member in fleet for seed in SEEDS]
        encal = []
        for member, seed in runs:
            train_cal, test_cal = member.train.calibration, member.test.calibration
            encal.append(fit_encal(train_cal.encoder_deg, train_cal.errors_arcmin, test_cal.encoder_deg,
                                   test_cal.errors_arcmin, encoding, hidden, seed))
        for converged in (False, True):
            sk_rms, sk_time, reach, reached = [], [], [], 0
            for (member, seed), (_, e_time, stamps, model) in zip(runs, encal):
                train_cal, test_cal = member.train.calibration, member.test.calibration
                predicted, seconds = fit_sklearn(train_cal.encoder_deg, train_cal.errors_arcmin,
                                                 test_cal.encoder_deg, encoding, hidden, seed, converged)
                sk_rms.append(rms(test_cal.errors_arcmin - predicted))
                sk_time.append(seconds)
                t = time_to_reach(sk_rms[-1], stamps, model, test_cal.encoder_deg, test_cal.errors_arcmin)
                reached += t is not None
                reach.append(e_time if t is None else t)
            e_rms = np.mean([run[0] for run in encal])
            e_time = np.mean([run[1] for run in encal])
            print(f"1:{hidden}:1 {encoding:<9} {'converged' if converged else 'default':<9} "
                  f"{np.mean(sk_rms):>6.4f}' {np.mean(sk_time):>6.3f} | {e_rms:>8.4f}' {e_time:>6.3f} "
                  f"{np.mean(reach):>10.3f} {reached:>3d}/{len(runs):<3d} | "
                  f"{np.mean(sk_time) / np.mean(reach):>16.1f}x {np.mean(sk_time) / e_time:>7.1f}x")


if __name__ == "__main__":
    main()

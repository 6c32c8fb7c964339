"""How close to the measurement floor can any model of 180 noisy points come?

Usage::

    python benchmarks/bench_floor_bound.py            # a few seconds

The accuracy goals of the demo fleet are stated against the measurement floor:
the RMS a model that knew the noise-free error exactly would leave on the test
run (``encal.simulate.measurement_floor``). A model fitted to the training run
cannot know it exactly: every coefficient it estimates carries the training
run's noise. This script computes what the best *informed* estimator reaches,
to show which ratios to the floor are reachable at all.

The estimator is given what no real fit has: the size of every harmonic of the
true (noise-free) profile, and the noise variance. It takes the harmonic
analysis of the training run (180 points, 0:2:358 degrees; orders 0..90) and
shrinks each order ν by the Wiener factor ``λ_ν = P_ν / (P_ν + V)``, where
``P_ν`` is the true power of order ν and ``V`` the variance the training noise
adds to its estimate (``2σ²/n`` per real coefficient). Among all estimators
that scale the harmonic analysis order by order, this one has the lowest
expected error; for a Gaussian profile prior with those powers it is the
Bayes estimator, which no estimator beats on average.

For each demo encoder the script prints:

- the floor of the test run (arcmin);
- ``oracle (expected)``: the expected test RMS of the Wiener estimator,
  ``sqrt(floor² + Σ_ν P_ν V / (P_ν + V) + aliased power)``, and its ratio to
  the floor;
- ``oracle (this run)``: the same estimator applied to the actual training run
  and scored on the actual test run;
- ``all 90 orders, no shrinkage``: the unregularised least-squares fit of
  every order the grid identifies (interpolation of the training points).

The true profile comes from the simulator's noise-free errors of the training
and test runs together (360 points at 1 degree, orders 0..180).
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import platform  # noqa: E402

import numpy as np  # noqa: E402

from encal.simulate import demo_fleet, measurement_floor  # noqa: E402


def rms(values):
    return float(np.sqrt(np.mean(np.square(values))))


def harmonic_coefficients(values):
    """One-sided complex Fourier coefficients of values on a uniform grid: f = Re Σ c_ν e^{iνθ}."""
    n = values.size
    c = np.fft.rfft(values) / n
    c[1:] *= 2.0
    if n % 2 == 0:
        c[-1] /= 2.0  # the Nyquist order is counted once
    return c


def synthesise(coefficients, theta_deg):
    orders = np.arange(coefficients.size)
    phase = np.exp(1j * np.outer(np.radians(theta_deg), orders))
    return (phase @ coefficients).real


def order_power(coefficients):
    """Mean-square contribution of each order (arcmin²): |c|² for order 0, |c|²/2 above."""
    power = np.abs(coefficients) ** 2 / 2.0
    power[0] *= 2.0
    return power


def informed_estimate(theta_deg, errors_arcmin, theta_test_deg, truth, sigma_arcmin, max_order=180):
    """The informed (Bayes) estimate at ``theta_test_deg`` from a run on any grid.

    The estimator is told the size of every harmonic of the true profile (orders 0..``max_order``,
    taken from ``truth``, a function of the angle in degrees) and the noise standard deviation; it
    does not know their phases. Under the Gaussian prior with those powers (each cosine and sine
    coefficient of order ν has variance ``P_ν``, the order's mean-square contribution) and white
    noise, the posterior mean is the estimator with the lowest expected error, aliased orders
    included: on a uniform grid without aliasing it is the order-by-order Wiener shrinkage of
    :func:`bound`, on a jittered grid it is what that shrinkage becomes there.
    """
    grid = np.arange(4 * max_order) * (360.0 / (4 * max_order))
    power = order_power(harmonic_coefficients(truth(grid)))[: max_order + 1]
    orders = np.arange(1, max_order + 1)

    def features(angles):
        r = np.radians(np.asarray(angles, dtype=float))[:, None]
        return np.hstack([np.ones((r.shape[0], 1)), np.cos(orders * r), np.sin(orders * r)])

    prior = np.concatenate([power[:1], power[1:], power[1:]])
    phi = features(theta_deg) * prior
    gram = features(theta_deg) @ phi.T + sigma_arcmin**2 * np.eye(len(theta_deg))
    weights = np.linalg.solve(gram, np.asarray(errors_arcmin, dtype=float))
    return features(theta_test_deg) @ (phi.T @ weights)


def bound(member):
    train, test = member.train, member.test
    theta_train = np.round(train.calibration.reference_deg, 6)
    theta_test = np.round(test.calibration.reference_deg, 6)
    # The true profile on the 1-degree grid, from both runs' noise-free errors.
    grid = np.concatenate([theta_train, theta_test])
    truth = np.concatenate([train.noise_free_error_arcmin, test.noise_free_error_arcmin])[np.argsort(grid)]
    true_coefficients = harmonic_coefficients(truth)  # orders 0..180
    n = theta_train.size
    nyquist = n // 2
    noise = train.errors_arcmin - train.noise_free_error_arcmin
    sigma2 = float(np.mean(noise**2))
    # Orders above the training grid's Nyquist order cannot be told apart from lower ones.
    power = order_power(true_coefficients)
    represented, aliased = power[: nyquist + 1], float(power[nyquist + 1:].sum())
    # Noise variance of each order's mean-square contribution: 2σ²/n per real coefficient,
    # two real coefficients per order ν ≥ 1 (each contributing half its square): σ²·2/n.
    variance = np.full(nyquist + 1, 2.0 * sigma2 / n)
    variance[0] = sigma2 / n
    variance[nyquist] = sigma2 / n
    wiener = represented / (represented + variance)
    floor = measurement_floor(test)
    expected_model_mse = float(np.sum(represented * variance / (represented + variance))) + aliased
    expected = np.sqrt(floor**2 + expected_model_mse)
    # The same estimator on this run's noisy training data.
    measured = harmonic_coefficients(train.errors_arcmin[np.argsort(theta_train)])
    this_run = rms(test.errors_arcmin - synthesise(wiener * measured, theta_test))
    unshrunk = rms(test.errors_arcmin - synthesise(measured, theta_test))
    small = represented < variance
    return {
        "floor": floor,
        "expected": expected,
        "this_run": this_run,
        "unshrunk": unshrunk,
        "hidden_rms": float(np.sqrt(represented[small].sum() + aliased)),
        "hidden_orders": int(small.sum()),
        "sigma": float(np.sqrt(sigma2)),
    }


def main():
    fleet = demo_fleet()
    print("# The informed-estimator bound on the demo fleet (test RMS, arcmin; ratio to the floor)")
    print(f"python {platform.python_version()}, numpy {np.__version__}\n")
    print("| encoder | floor | training noise σ | orders below their noise (their RMS) "
          "| oracle, expected | oracle, this run | all 90 orders, no shrinkage |")
    print("|---|---|---|---|---|---|---|")
    for member in fleet:
        b = bound(member)
        f = b["floor"]
        print(f"| {member.name} | {f:.4f} | {b['sigma']:.4f} | {b['hidden_orders']} ({b['hidden_rms']:.3f}) "
              f"| {b['expected']:.4f} ({b['expected'] / f:.2f}) | {b['this_run']:.4f} ({b['this_run'] / f:.2f}) "
              f"| {b['unshrunk']:.4f} ({b['unshrunk'] / f:.2f}) |")


if __name__ == "__main__":
    main()

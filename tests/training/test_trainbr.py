"""trainbr: Bayesian regularisation on known-answer problems and MacKay's fixed point."""

import inspect

import numpy as np
import pytest
from numpy.testing import assert_allclose

from encal.training import ALGORITHMS, LinearLeastSquares, train
from encal.training.network import NetworkProblem
from encal.training.trainbr import effective_parameters
from encal.training.trainlm import DampedGaussNewton

SEEDS = range(5)
TRAINING_GRID = np.arange(0.0, 360.0, 2.0)
TEST_GRID = TRAINING_GRID + 1.0


def linear_problem(seed, noise, m=60, n=6):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((m, n))
    return LinearLeastSquares(A, A @ rng.standard_normal(n) + noise * rng.standard_normal(m))


def few_harmonics(theta_deg):
    t = np.radians(theta_deg)
    return 3.0 * np.sin(t + 0.3) + 1.5 * np.cos(2 * t) + 0.5 * np.sin(4 * t + 1.0)


def test_matlab_defaults():
    backend, _ = ALGORITHMS["trainbr"]
    defaults = {name: p.default for name, p in inspect.signature(backend).parameters.items()
                if p.default is not inspect.Parameter.empty}
    assert defaults == {"mu": 0.005, "mu_dec": 0.1, "mu_inc": 10.0, "mu_max": 1e10}


@pytest.mark.parametrize("dual", [False, True])
def test_effective_parameters_is_mackays_gamma(dual):
    rng = np.random.default_rng(0)
    m, n = (8, 20) if dual else (20, 8)
    J = rng.standard_normal((m, n))
    beta, alpha = 2.0, 3.0
    hessian = 2 * beta * J.T @ J + 2 * alpha * np.eye(n)
    expected = n - 2 * alpha * np.trace(np.linalg.inv(hessian))
    assert effective_parameters(DampedGaussNewton(J, np.zeros(m)), beta, alpha) == pytest.approx(expected,
                                                                                               rel=1e-12)


@pytest.mark.parametrize("seed", SEEDS)
def test_noise_free_linear_problem_reaches_lstsq_solution(seed):
    # Without noise β grows without bound and the regularisation vanishes.
    problem = linear_problem(seed, noise=0.0)
    result = train(problem, "trainbr", x0=np.zeros(6))
    assert_allclose(result.x, problem.solution(), rtol=1e-8, atol=1e-8)


@pytest.mark.parametrize("seed", SEEDS)
def test_noisy_linear_problem_ends_at_mackays_fixed_point(seed):
    problem = linear_problem(seed, noise=0.5)
    result = train(problem, "trainbr", x0=np.zeros(6))
    alpha, beta, gamma = (result.history[k][-1] for k in ("alpha", "beta", "gamma"))
    A, b, x = problem.A, problem.b, result.x
    # x is the ridge solution of the final α, β ...
    assert_allclose(x, np.linalg.solve(beta * A.T @ A + alpha * np.eye(6), beta * A.T @ b), rtol=1e-5)
    # ... and α, β are re-estimated from it by the evidence rules.
    eigenvalues = np.linalg.eigvalsh(A.T @ A)
    assert gamma == pytest.approx(np.sum(beta * eigenvalues / (beta * eigenvalues + alpha)), rel=1e-4)
    assert alpha == pytest.approx(gamma / (2 * x @ x), rel=1e-4)
    assert beta == pytest.approx((problem.n_samples - gamma) / (2 * problem.mse(x) * problem.n_samples),
                                 rel=1e-4)


@pytest.mark.parametrize("seed", range(3))
def test_shrinks_effective_parameters_of_an_oversized_network_on_noisy_data(seed):
    rng = np.random.default_rng(seed)
    error = few_harmonics(TRAINING_GRID) + 0.1 * rng.standard_normal(TRAINING_GRID.size)
    problem = NetworkProblem.from_angles(TRAINING_GRID, error, 30)
    result = train(problem, "trainbr", x0=problem.initial_weights(seed), epochs=300)
    gamma = result.history["gamma"]
    assert gamma[0] == problem.n_params == 121
    assert gamma[-1] < 0.4 * problem.n_params
    # The regularised network generalises between the training points: below the noise level.
    validation = NetworkProblem.from_angles(TEST_GRID, few_harmonics(TEST_GRID), 30,
                                            input_scaling=problem.input_scaling,
                                            target_scaling=problem.target_scaling)
    test_rms_arcmin = np.sqrt(validation.mse(result.x)) / problem.target_scaling.gain
    assert test_rms_arcmin < 0.06


def test_records_mu_gamma_alpha_beta_every_epoch():
    problem = linear_problem(0, noise=0.5)
    result = train(problem, "trainbr", x0=np.zeros(6), epochs=3)
    for name in ("mu", "gamma", "alpha", "beta"):
        assert result.history[name].size == result.epochs + 1 == 4
        assert np.all(result.history[name][1:] > 0)
    # Foresee & Hagan's start: γ = N_w, α = 0, β = 1.
    assert [result.history[name][0] for name in ("mu", "gamma", "alpha", "beta")] == [0.005, 6, 0, 1]


def test_first_step_is_plain_levenberg_marquardt():
    # With α = 0 and β = 1 the first step is trainlm's with trainbr's μ.
    rng = np.random.default_rng(0)
    error = few_harmonics(TRAINING_GRID) + 0.1 * rng.standard_normal(TRAINING_GRID.size)
    problem = NetworkProblem.from_angles(TRAINING_GRID, error, 6)
    x0 = problem.initial_weights(0)
    bayesian = train(problem, "trainbr", x0=x0, epochs=1)
    levenberg_marquardt = train(problem, "trainlm", x0=x0, epochs=1, mu=0.005)
    assert_allclose(bayesian.x, levenberg_marquardt.x, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("hidden", [6, 80])
def test_evidence_update_uses_the_accepted_weights(hidden):
    # MacKay's rules hold at one point: γ from the Jacobian at the accepted weights (with the α, β
    # that took the step), α from their E_W, β from their E_D. 1:80:1 has more weights than points.
    rng = np.random.default_rng(1)
    error = few_harmonics(TRAINING_GRID) + 0.1 * rng.standard_normal(TRAINING_GRID.size)
    problem = NetworkProblem.from_angles(TRAINING_GRID, error, hidden)
    weights = []
    result = train(problem, "trainbr", x0=problem.initial_weights(1), epochs=8,
                   callback=lambda epoch, w, mse: weights.append(w.copy()))
    gamma, alpha, beta = (result.history[name] for name in ("gamma", "alpha", "beta"))
    m = problem.n_samples
    assert gamma[1] == pytest.approx(min(m, problem.n_params))  # after the step with α = 0: rank J
    for k in range(1, len(weights)):
        w = weights[k]
        e, J = problem.residuals_and_jacobian(w)
        if k > 1:
            eigenvalues = np.clip(np.linalg.eigvalsh(J @ J.T if J.shape[0] < J.shape[1] else J.T @ J), 0, None)
            expected = np.sum(beta[k - 1] * eigenvalues / (beta[k - 1] * eigenvalues + alpha[k - 1]))
            assert gamma[k] == pytest.approx(expected, rel=1e-6, abs=1e-6)
        assert alpha[k] == pytest.approx(gamma[k] / (2 * w @ w), rel=1e-12)
        if gamma[k] < m:
            assert beta[k] == pytest.approx((m - gamma[k]) / (2 * e @ e), rel=1e-12)


def strong_low_harmonics(theta_deg):
    t = np.radians(theta_deg)
    return 17.0 * np.sin(4 * t + 0.4) + 11.5 * np.sin(2 * t + 1.1) + 1.8 * np.sin(t + 2.0)


# The first five seeds in 0..199 at which trainbr with γ from the Jacobian at the start of the epoch and
# α, β from the initial weights (trainbr.m's start) fell to a constant: γ ≈ 1, test RMS 14.6'.
# That happened at 14 of the 200 seeds; the current update order and start: none, worst 0.91'.
COLLAPSED_SEEDS = (16, 18, 33, 36, 44)


@pytest.mark.parametrize("seed", COLLAPSED_SEEDS)
def test_does_not_collapse_to_a_constant_on_a_strong_periodic_profile(seed):
    grid = np.arange(0.0, 360.0, 1.8)  # an AS5047D calibration's full steps
    error = strong_low_harmonics(grid) + 2.0 * np.random.default_rng(seed).standard_normal(grid.size)
    problem = NetworkProblem.from_angles(grid, error, 12)
    result = train(problem, "trainbr", x0=problem.initial_weights(seed))
    test = NetworkProblem.from_angles(grid + 0.9, strong_low_harmonics(grid + 0.9), 12,
                                      input_scaling=problem.input_scaling,
                                      target_scaling=problem.target_scaling)
    test_rms_arcmin = np.sqrt(test.mse(result.x)) / problem.target_scaling.gain
    assert result.history["gamma"][-1] > 10
    assert test_rms_arcmin < 1.0  # below half the noise (2'); the profile's RMS is 14.6'


def test_stops_after_epochs_and_at_goal():
    problem = linear_problem(0, noise=0.5)
    assert train(problem, "trainbr", x0=np.zeros(6), epochs=2).reason == "epochs"
    goal = 1.5 * problem.mse(problem.solution())
    result = train(problem, "trainbr", x0=np.zeros(6), goal=goal)
    assert result.reason == "goal" and result.mse <= goal


def test_stops_at_mu_max_when_no_step_lowers_the_performance():
    problem = LinearLeastSquares(np.zeros((5, 3)), np.ones(5))
    result = train(problem, "trainbr", x0=np.zeros(3), min_grad=0.0)
    assert result.reason == "mu_max"
    assert np.all(result.x == 0)


def test_network_with_more_weights_than_points():
    # 321 weights on 180 points: the step and γ come from the 180 × 180 system JJᵀ.
    rng = np.random.default_rng(0)
    error = few_harmonics(TRAINING_GRID) + 0.1 * rng.standard_normal(TRAINING_GRID.size)
    problem = NetworkProblem.from_angles(TRAINING_GRID, error, 80)
    result = train(problem, "trainbr", x0=problem.initial_weights(0), epochs=20)
    assert problem.n_params == 321
    assert np.all(np.isfinite(result.x))
    assert np.all(result.history["gamma"][1:] <= problem.n_samples)  # γ <= rank J <= 180
    assert result.history["mse"][-1] < 0.05 * result.history["mse"][0]

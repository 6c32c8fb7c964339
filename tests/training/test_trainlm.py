"""trainlm: Levenberg-Marquardt on known-answer problems, its μ schedule and every stopping reason."""

import inspect
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from encal._core.errors import InputError
from encal.training import ALGORITHMS, LinearLeastSquares, train
from encal.training.network import MapMinMax, NetworkProblem, encode_angles, nguyen_widrow
from encal.training.trainlm import MU_FLOOR, DampedGaussNewton

SEEDS = range(5)
TRAINING_GRID = np.arange(0.0, 360.0, 2.0)


def noisy_linear_problem(seed, m=60, n=6):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((m, n))
    return LinearLeastSquares(A, A @ rng.standard_normal(n) + 0.5 * rng.standard_normal(m))


def teacher_problem(seed, encoding, activation, hidden):
    """Targets made by a random network of the same size: the answer is zero error."""
    rng = np.random.default_rng(100 + seed)
    raw_inputs = encode_angles(TRAINING_GRID, encoding)
    inputs = MapMinMax.fit(raw_inputs).apply(raw_inputs)
    teacher = nguyen_widrow(inputs.shape[1], hidden, activation, rng)
    targets = NetworkProblem(inputs, np.zeros(inputs.shape[0]), hidden, activation).outputs(teacher)
    return NetworkProblem(inputs, targets, hidden, activation), teacher


def test_matlab_defaults():
    backend, stopping = ALGORITHMS["trainlm"]
    defaults = {name: p.default for name, p in inspect.signature(backend).parameters.items()
                if p.default is not inspect.Parameter.empty}
    assert defaults == {"mu": 0.001, "mu_dec": 0.1, "mu_inc": 10.0, "mu_max": 1e10}
    result = train(noisy_linear_problem(0), "trainlm", x0=np.zeros(6), epochs=1)
    assert result.history["mu"][0] == 0.001


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("shape", [(60, 6), (6, 15)])
def test_linear_least_squares_reaches_lstsq_solution(seed, shape):
    # From x0 = 0 every step lies in the row space of A, so the underdetermined
    # problem converges to the minimum-norm solution that lstsq returns.
    problem = noisy_linear_problem(seed, *shape)
    result = train(problem, "trainlm", x0=np.zeros(shape[1]), min_grad=1e-12)
    assert result.success
    assert_allclose(result.x, problem.solution(), rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("activation", ["tansig", "logsig"])
def test_network_fits_targets_of_a_same_size_network_from_nguyen_widrow(seed, activation):
    problem, _ = teacher_problem(seed, "raw", activation, hidden=4)
    result = train(problem, "trainlm", x0=problem.initial_weights(seed))
    assert result.mse < 1e-10


@pytest.mark.parametrize("seed", range(8))
def test_periodic_network_converges_to_the_teacher_from_nearby(seed):
    problem, teacher = teacher_problem(seed, "periodic", "tansig", hidden=4)
    start = teacher + 0.1 * np.random.default_rng(seed).standard_normal(teacher.size)
    # min_grad=0: run to machine precision, where no step lowers the error any more.
    result = train(problem, "trainlm", x0=start, min_grad=0.0)
    assert result.reason == "mu_max"
    assert result.mse < 1e-28


@pytest.mark.parametrize("encoding", ["raw", "periodic"])
def test_paper_network_with_more_weights_than_points(encoding):
    rng = np.random.default_rng(1)
    error = np.sin(np.radians(TRAINING_GRID)) + 0.05 * rng.standard_normal(TRAINING_GRID.size)
    problem = NetworkProblem.from_angles(TRAINING_GRID, error, 80, encoding=encoding)
    assert problem.n_params > problem.n_samples
    result = train(problem, "trainlm", x0=problem.initial_weights(0), epochs=15)
    mse = result.history["mse"]
    assert np.all(np.diff(mse) < 0)  # every accepted step lowers the error
    assert mse[-1] < 0.1 * mse[0]
    assert np.all(np.isfinite(result.x))


def test_mu_history_follows_the_schedule():
    problem, _ = teacher_problem(0, "raw", "tansig", hidden=4)
    result = train(problem, "trainlm", x0=problem.initial_weights(0), epochs=30)
    mu = result.history["mu"]
    assert mu.size == result.epochs + 1 == result.history["mse"].size
    assert np.all(mu >= MU_FLOOR)
    # μ moves by whole powers of mu_dec = 0.1 and mu_inc = 10 from 0.001
    exponents = np.log10(np.maximum(mu, MU_FLOOR))
    assert_allclose(exponents, np.round(exponents), atol=1e-9)


@pytest.mark.parametrize("dual", [False, True])
@pytest.mark.parametrize(("mu", "beta", "alpha"), [(1e-3, 1.0, 0.0), (0.5, 3.0, 0.7)])
def test_damped_step_solves_the_normal_equations(dual, mu, beta, alpha):
    rng = np.random.default_rng(0)
    m, n = (8, 20) if dual else (20, 8)
    J, e, x = rng.standard_normal((m, n)), rng.standard_normal(m), rng.standard_normal(n)
    system = DampedGaussNewton(J, e)
    assert system.dual is dual
    expected = -np.linalg.solve(beta * J.T @ J + (alpha + mu) * np.eye(n), beta * J.T @ e + alpha * x)
    assert_allclose(system.step(mu, beta, alpha, x), expected, rtol=1e-9, atol=1e-12)


class NaNBeyondUnitBall(LinearLeastSquares):
    """A problem whose residuals are NaN outside |w| <= 1: trial steps there must be rejected."""

    def residuals(self, w):
        r = super().residuals(w)
        return r if np.linalg.norm(w) <= 1.0 else np.full_like(r, np.nan)


def test_non_finite_trial_steps_are_rejected():
    A = np.eye(3)
    problem = NaNBeyondUnitBall(A, np.array([10.0, 0.0, 0.0]))
    result = train(problem, "trainlm", x0=np.zeros(3), epochs=50)
    assert np.all(np.isfinite(result.x))
    assert np.linalg.norm(result.x) <= 1.0
    assert result.mse < problem.mse(np.zeros(3))


# Stopping reasons -----------------------------------------------------------------------------


def test_stops_at_goal():
    problem = noisy_linear_problem(0)
    goal = 1.01 * problem.mse(problem.solution())
    result = train(problem, "trainlm", x0=np.zeros(6), goal=goal)
    assert result.reason == "goal" and result.success
    assert result.mse <= goal


def test_stops_after_epochs():
    problem, _ = teacher_problem(0, "raw", "tansig", hidden=4)
    result = train(problem, "trainlm", x0=problem.initial_weights(0), epochs=3)
    assert result.reason == "epochs" and result.epochs == 3


def test_stops_at_min_grad():
    result = train(noisy_linear_problem(0), "trainlm", x0=np.zeros(6))
    assert result.reason == "min_grad"
    assert result.history["grad_norm"][-1] < 1e-7


def test_stops_at_mu_max_when_no_step_lowers_the_error():
    # Residuals that do not depend on the weights: every step fails, μ climbs to mu_max.
    problem = LinearLeastSquares(np.zeros((5, 3)), np.ones(5))
    result = train(problem, "trainlm", x0=np.zeros(3), min_grad=0.0)
    assert result.reason == "mu_max" and result.epochs == 0


@pytest.mark.parametrize("seed", SEEDS)
def test_stops_at_max_fail_and_keeps_best_validation_weights(seed):
    # Start at the validation optimum: every training step makes validation worse.
    # A large constant μ keeps the steps small, so training itself goes on.
    train_problem = noisy_linear_problem(seed)
    validation = noisy_linear_problem(seed + 100)
    validation.A = train_problem.A
    start = validation.solution()
    result = train(train_problem, "trainlm", x0=start, validation=validation, mu=1e4, mu_dec=0.999)
    assert result.reason == "max_fail" and result.epochs == 6
    assert_allclose(result.x, start)
    assert result.val_mse == pytest.approx(validation.mse(start))


@pytest.mark.parametrize("seed", SEEDS)
def test_stops_at_the_papers_plateau_rule(seed):
    # Slow, steady convergence (large μ, barely decreasing) to a non-zero minimum.
    problem = noisy_linear_problem(seed)
    result = train(problem, "trainlm", x0=np.zeros(6), mu=1e3, mu_dec=0.999, min_grad=0.0,
                   plateau_patience=5, plateau_tol=1e-3)
    assert result.reason == "plateau" and result.success
    rms = np.sqrt(result.history["mse"])
    assert rms[-1] > rms[-6] * (1 - 1e-3)
    assert rms[-2] <= rms[-7] * (1 - 1e-3)
    assert result.epochs < 1000


@pytest.mark.parametrize(("option", "value", "message"), [
    ("mu", -1.0, "mu of trainlm must be a float > 0. Got -1.0 instead."),
    ("mu_dec", 1.5, "mu_dec of trainlm must be a float in (0, 1). Got 1.5 instead."),
    ("mu_inc", 0.5, "mu_inc of trainlm must be a float > 1. Got 0.5 instead."),
    ("mu_max", "big", "mu_max of trainlm must be a float > 0. Got 'big' instead."),
    ("mu", math.nan, "mu of trainlm must be a float > 0. Got nan instead."),
])
def test_invalid_options_are_rejected_in_one_sentence(option, value, message):
    with pytest.raises(InputError) as info:
        train(noisy_linear_problem(0), "trainlm", x0=np.zeros(6), **{option: value})
    assert str(info.value) == message

"""The train() front end: option checks, history, stopping reasons, validation and blow-ups.

Contract checks run over every registered algorithm, so that a new back end
is held to them too.
"""

import math
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

from encal._core.errors import EncalWarning, InputError, TrainingLimitWarning
from encal.training import ALGORITHMS, STOP_REASONS, LinearLeastSquares, train

EVERY_ALGORITHM = sorted(ALGORITHMS)
LINE_SEARCH_METHODS = ("traincgf", "traincgp", "trainoss", "trainbfg")


def linear_problem(seed=0, n=5, m=20):
    """A well-conditioned least-squares problem and a starting point."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((m, n)) + 3.0 * np.eye(m, n)
    return LinearLeastSquares(A, rng.standard_normal(m)), rng.standard_normal(n)


def scalar_problem(target):
    """mse(w) = (w − target)², one unknown."""
    return LinearLeastSquares([[1.0]], [target])


class WrongGradient(LinearLeastSquares):
    """Reports the gradient with the wrong sign: no step along -grad lowers the error."""

    def mse_and_gradient(self, w):
        mse, grad = super().mse_and_gradient(w)
        return mse, -grad


class BlowsUp:
    """``r = [exp(10·w1) − e^20, w2 − 1]``: gradient ~1e18 at w1 = 1.9; long steps overflow."""

    n_params, n_samples = 2, 2

    def residuals(self, w):
        return np.array([np.exp(10.0 * w[0]) - np.exp(20.0), w[1] - 1.0])

    def residuals_and_jacobian(self, w):
        return self.residuals(w), np.array([[10.0 * np.exp(10.0 * w[0]), 0.0], [0.0, 1.0]])

    def mse(self, w):
        r = self.residuals(w)
        return float(r @ r) / 2.0

    def mse_and_gradient(self, w):
        r, J = self.residuals_and_jacobian(w)
        return float(r @ r) / 2.0, J.T @ r


# --------------------------------------------------------------------------- refused input


def test_unknown_algorithm_lists_the_known_ones():
    problem, x0 = linear_problem()
    with pytest.raises(InputError, match="unknown training algorithm 'trainxyz'") as info:
        train(problem, "trainxyz", x0=x0)
    for name in ("traingd", "trainscg", "trainbfg"):
        assert name in str(info.value)


@pytest.mark.parametrize("algorithm", EVERY_ALGORITHM)
def test_unknown_option_is_named(algorithm):
    problem, x0 = linear_problem()
    with pytest.raises(InputError, match=f"{algorithm} does not take the option.* learning_rate"):
        train(problem, algorithm, x0=x0, learning_rate=0.1)


@pytest.mark.parametrize("size", [4, 6, 0])
def test_x0_of_the_wrong_size(size):
    problem, _ = linear_problem()
    with pytest.raises(InputError, match=f"x0 has {size} values; the problem has 5 parameters"):
        train(problem, "traingd", x0=np.zeros(size))


@pytest.mark.parametrize("option, message", [
    ({"epochs": -1}, "The 'epochs' parameter of train must be an int >= 0. Got -1 instead."),
    ({"epochs": 2.5}, "The 'epochs' parameter of train must be an int >= 0. Got 2.5 instead."),
    ({"goal": -1.0}, "The 'goal' parameter of train must be a finite number >= 0 (a mean squared error). "
                     "Got -1.0 instead."),
    ({"max_fail": 0}, "The 'max_fail' parameter of train must be an int >= 1. Got 0 instead."),
    ({"time": "1 s"}, "The 'time' parameter of train must be a finite number >= 0 (seconds, or math.inf). "
                      "Got '1 s' instead."),
    ({"plateau_patience": 0}, "The 'plateau_patience' parameter of train must be an int >= 1 (epochs, or None). "
                              "Got 0 instead."),
    ({"plateau_tol": 1.5}, "The 'plateau_tol' parameter of train must be a finite number in [0, 1]. "
                           "Got 1.5 instead."),
])
def test_bad_stopping_parameters_are_refused_in_one_sentence(option, message):
    problem, x0 = linear_problem()
    with pytest.raises(InputError) as info:
        train(problem, "trainscg", x0=x0, **option)
    assert str(info.value) == message


def test_x0_is_not_modified():
    problem, x0 = linear_problem()
    before = x0.copy()
    train(problem, "trainbfg", x0=x0, epochs=5)
    assert_allclose(x0, before, rtol=0, atol=0)


# --------------------------------------------------------------------------- history


@pytest.mark.parametrize("algorithm", EVERY_ALGORITHM)
def test_history_has_one_entry_per_epoch_from_epoch_zero(algorithm):
    problem, x0 = linear_problem()
    validation, _ = linear_problem(seed=1)
    calls = []
    result = train(problem, algorithm, x0=x0, epochs=3, min_grad=0.0, max_fail=100,
                   validation=validation, callback=lambda epoch, w, mse: calls.append(epoch))
    n = result.epochs + 1
    assert result.epochs <= 3
    assert {"mse", "grad_norm", "val_mse"} <= set(result.history)
    for name, values in result.history.items():
        assert values.shape == (n,), name
    assert calls == list(range(n))
    assert result.history["mse"][0] == pytest.approx(problem.mse(x0), rel=1e-12)
    # With a validation problem the weights of the best validation epoch are returned, as in MATLAB.
    best = int(np.argmin(result.history["val_mse"]))
    assert result.history["mse"][best] == pytest.approx(result.mse, rel=1e-12)
    assert result.val_mse == pytest.approx(validation.mse(result.x), rel=1e-12)
    assert result.val_mse == pytest.approx(result.history["val_mse"].min(), rel=1e-12)
    assert result.nfev >= n


def test_no_validation_no_val_mse():
    problem, x0 = linear_problem()
    result = train(problem, "traingdx", x0=x0, epochs=2)
    assert "val_mse" not in result.history and result.val_mse is None


@pytest.mark.parametrize("algorithm", EVERY_ALGORITHM)
def test_zero_epochs_returns_x0(algorithm):
    problem, x0 = linear_problem()
    result = train(problem, algorithm, x0=x0, epochs=0)
    assert result.reason == "epochs" and result.epochs == 0
    assert_allclose(result.x, x0, rtol=0, atol=0)
    assert result.history["mse"].shape == (1,)


# --------------------------------------------------------------------------- stop reasons


@pytest.mark.parametrize("algorithm", EVERY_ALGORITHM)
def test_stops_at_the_epoch_limit(algorithm):
    problem, x0 = linear_problem()
    result = train(problem, algorithm, x0=x0, epochs=3, min_grad=0.0)
    assert (result.reason, result.epochs) == ("epochs", 3)
    assert (result.success, result.status) == (False, 0)
    assert result.message == STOP_REASONS["epochs"][2]


@pytest.mark.parametrize("algorithm", EVERY_ALGORITHM)
def test_stops_at_the_goal(algorithm):
    problem, x0 = linear_problem()
    best = problem.mse(problem.solution())
    goal = best + 0.01 * (problem.mse(x0) - best)
    result = train(problem, algorithm, x0=x0, goal=goal, epochs=10000)
    mse = result.history["mse"]
    assert result.reason == "goal" and result.success
    assert mse[-1] <= goal and np.all(mse[:-1] > goal)


@pytest.mark.parametrize("algorithm", EVERY_ALGORITHM)
def test_stops_at_min_grad(algorithm):
    problem, x0 = linear_problem()
    result = train(problem, algorithm, x0=x0, min_grad=1e-3, epochs=10000)
    grad_norm = result.history["grad_norm"]
    assert result.reason == "min_grad"
    assert grad_norm[-1] < 1e-3 and np.all(grad_norm[:-1] >= 1e-3)


def test_stops_at_the_time_limit_and_warns():
    problem, x0 = linear_problem()
    with pytest.warns(TrainingLimitWarning) as caught:
        result = train(problem, "traingd", x0=x0, time=0.0)
    assert result.reason == "time" and result.epochs == 0 and not result.success
    assert [str(w.message) for w in caught] == [
        "Training with traingd stopped on its time limit of 0 s after 0 epochs, before its error could fall, "
        "so the result depends on this machine's speed (give epochs instead of time for a repeatable fit)."]


# --------------------------------------------------------------------------- the training-limit warning
# traingd on mse(w) = (w - 1)^2 from w = 0 multiplies the error by (1 - 2 lr) every epoch: with lr = 5e-4
# the RMS error falls by 1 - 0.999^20 = 1.98 % over any 20 epochs, with lr = 1e-4 by 0.40 %.

def _slow_descent(lr, **options):
    return train(scalar_problem(1.0), "traingd", x0=[0.0], lr=lr, **options)


def test_warns_when_the_default_epoch_limit_cuts_training_short():
    with pytest.warns(TrainingLimitWarning) as caught:
        result = _slow_descent(5e-4)
    assert (result.reason, result.epochs) == ("epochs", 1000)
    assert [str(w.message) for w in caught] == [
        "Training with traingd stopped at the default limit of 1000 epochs while its error was still falling "
        "(the RMS error fell by 2 % over the last 20 epochs); give epochs (encal fit --epochs) to train longer "
        "or to fix the budget."]
    assert issubclass(TrainingLimitWarning, EncalWarning) and issubclass(TrainingLimitWarning, UserWarning)


def test_warns_with_the_plateau_rule_when_the_default_limit_comes_first():
    with pytest.warns(TrainingLimitWarning, match=r"fell by 2 % over the last 20 epochs"):
        result = _slow_descent(5e-4, plateau_patience=20, plateau_tol=0.01)
    assert result.reason == "epochs"


@pytest.mark.parametrize("options", [
    {"epochs": 1000},                                    # a budget the caller set: the paper's fixed runs
    {"epochs": 5},
    {"lr": 1e-4},                                        # 0.40 % per 20 epochs: no longer improving
    {"lr": 1e-4, "plateau_patience": 20, "plateau_tol": 0.01},  # the plateau rule stops it first
])
def test_no_warning_when_a_chosen_limit_or_a_criterion_ends_training(options):
    options = {"lr": 5e-4, **options}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = _slow_descent(**options)
    assert result.reason in ("epochs", "plateau")


def test_stops_on_a_plateau():
    problem, x0 = linear_problem()
    result = train(problem, "traingd", x0=x0, lr=1e-12, plateau_patience=5, plateau_tol=1e-4)
    assert (result.reason, result.epochs) == ("plateau", 5)


@pytest.mark.parametrize("algorithm", LINE_SEARCH_METHODS)
def test_line_search_methods_stop_without_progress(algorithm):
    problem, x0 = linear_problem()
    wrong = WrongGradient(problem.A, problem.b)
    result = train(wrong, algorithm, x0=x0)
    assert result.reason == "no_progress" and result.epochs == 0
    assert_allclose(result.x, x0, rtol=0, atol=0)


# --------------------------------------------------------------------------- validation


@pytest.mark.parametrize("algorithm", EVERY_ALGORITHM)
def test_max_fail_keeps_the_starting_weights_when_they_validate_best(algorithm):
    """Training from the validation optimum: validation only gets worse, so x0 comes back."""
    problem, _ = linear_problem()
    validation, _ = linear_problem(seed=1)
    x0 = validation.solution()
    result = train(problem, algorithm, x0=x0, validation=validation, max_fail=2, min_grad=0.0)
    assert (result.reason, result.epochs) == ("max_fail", 2)
    assert_allclose(result.x, x0, rtol=0, atol=0)
    assert result.val_mse == pytest.approx(validation.mse(x0), rel=1e-12)


@pytest.mark.parametrize("algorithm", ["traingd", "trainrp"])
def test_max_fail_returns_the_weights_of_the_best_validation_epoch(algorithm):
    """Training goes from 10 to 0; validation is best at 5, passed half way."""
    weights = []
    options = {"lr": 0.05} if algorithm == "traingd" else {}
    result = train(scalar_problem(0.0), algorithm, x0=[10.0], validation=scalar_problem(5.0),
                   max_fail=6, min_grad=0.0, **options,
                   callback=lambda epoch, w, mse: weights.append(float(w[0])))
    val = result.history["val_mse"]
    best = int(np.argmin(val))
    assert 0 < best < result.epochs
    assert (result.reason, result.epochs) == ("max_fail", best + 6)
    assert result.x[0] == weights[best]
    assert result.val_mse == val[best] == pytest.approx((weights[best] - 5.0) ** 2)
    assert abs(weights[best] - 5.0) < abs(weights[0] - 5.0)


# --------------------------------------------------------------------------- blow-ups


@pytest.mark.parametrize("algorithm", EVERY_ALGORITHM)
def test_no_non_finite_weights_on_a_problem_that_blows_up(algorithm):
    """Steps of the default size overflow here; no warning may escape and the result is finite."""
    result = train(BlowsUp(), algorithm, x0=[1.9, 0.0], epochs=50)
    assert np.all(np.isfinite(result.x)) and math.isfinite(result.mse)
    for name, values in result.history.items():
        assert np.all(np.isfinite(values)), name
    assert result.mse <= result.history["mse"][0]


def test_diverging_gradient_descent_stops_with_the_last_finite_weights():
    problem, x0 = linear_problem()
    weights = []
    result = train(problem, "traingd", x0=x0, lr=10.0, epochs=10000,
                   callback=lambda epoch, w, mse: weights.append(np.copy(w)))
    assert result.reason == "non_finite" and not result.success
    assert result.epochs < 10000
    assert np.all(np.isfinite(result.x)) and math.isfinite(result.mse)
    assert_allclose(result.x, weights[-1], rtol=0, atol=0)
    assert result.mse == pytest.approx(result.history["mse"][-1], rel=1e-12)

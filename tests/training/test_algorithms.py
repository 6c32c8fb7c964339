"""Eight of MATLAB's training algorithms on problems with known answers, and their line searches.

The shared checks run every algorithm on the same known-answer problems with a
stated tolerance and epoch budget; first-order methods (traingd, traingdx,
trainrp) get more epochs and looser tolerances than the methods that use
curvature (trainscg, traincgf, traincgp, trainoss, trainbfg). Errors in the
weights are relative: ``‖x − x*‖ ≤ tol · max(1, ‖x*‖)``.
"""

import inspect
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from encal._core.errors import InputError
from encal.training import ALGORITHMS, LinearLeastSquares, train
from encal.training.conjugate_gradient import ConjugateDirections
from encal.training.linesearch import LineSearch
from encal.training.network import NetworkProblem
from encal.training.quasi_newton import InverseBFGS, OneStepSecant

FIRST_ORDER = ("traingd", "traingdx", "trainrp")
CURVATURE = ("trainscg", "traincgf", "traincgp", "trainoss", "trainbfg")
ALGORITHMS_HERE = FIRST_ORDER + CURVATURE
LINE_SEARCH_METHODS = ("traincgf", "traincgp", "trainoss", "trainbfg")
SEEDS = range(5)


# --------------------------------------------------------------------------- problems


def linear_problem(seed, hessian_range, n=6, m=30, noise=0.1):
    """``(problem, x0)``: least squares whose MSE Hessian ``2AᵀA/m`` has its eigenvalues
    spread geometrically over ``hessian_range``."""
    rng = np.random.default_rng(seed)
    U, _ = np.linalg.qr(rng.standard_normal((m, n)))
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    singular_values = np.sqrt(np.geomspace(*hessian_range, n) * m / 2.0)
    A = (U * singular_values) @ V.T
    b = A @ rng.standard_normal(n) + noise * rng.standard_normal(m)
    return LinearLeastSquares(A, b), 2.0 * rng.standard_normal(n)


class ExpSine:
    """Zero-residual fit of ``y = a·exp(-b·t) + c·sin(d·t)`` to data from known parameters."""

    TRUTH = np.array([2.0, 0.8, 0.5, 3.0])

    def __init__(self):
        self.t = np.linspace(0.0, 5.0, 50)
        self.y = self.model(self.TRUTH)
        self.n_params, self.n_samples = 4, self.t.size

    def model(self, p):
        a, b, c, d = p
        return a * np.exp(-b * self.t) + c * np.sin(d * self.t)

    def residuals(self, p):
        return self.model(p) - self.y

    def residuals_and_jacobian(self, p):
        a, b, c, d = p
        decay = np.exp(-b * self.t)
        J = np.column_stack([decay, -a * self.t * decay, np.sin(d * self.t),
                             c * self.t * np.cos(d * self.t)])
        return self.residuals(p), J

    def mse(self, p):
        r = self.residuals(p)
        return float(r @ r) / self.n_samples

    def mse_and_gradient(self, p):
        r, J = self.residuals_and_jacobian(p)
        return float(r @ r) / self.n_samples, 2.0 * (J.T @ r) / self.n_samples


class Rosenbrock:
    """Rosenbrock's function as residuals ``[10(x2 − x1²), 1 − x1]``; minimum at (1, 1)."""

    n_params = n_samples = 2
    STARTS = [(-1.2, 1.0), (0.5, -0.5), (2.0, 2.0), (-0.5, 0.5), (0.0, 0.0)]

    def residuals(self, x):
        return np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]])

    def residuals_and_jacobian(self, x):
        return self.residuals(x), np.array([[-20.0 * x[0], 10.0], [-1.0, 0.0]])

    def mse(self, x):
        r = self.residuals(x)
        return float(r @ r) / 2.0

    def mse_and_gradient(self, x):
        r, J = self.residuals_and_jacobian(x)
        return float(r @ r) / 2.0, J.T @ r


def relative_error(x, truth):
    return np.linalg.norm(x - truth) / max(1.0, np.linalg.norm(truth))


# --------------------------------------------------------------------------- MATLAB's defaults

MATLAB_DEFAULTS = {
    "traingd": (1e-5, {"lr": 0.01}),
    "traingdx": (1e-5, {"lr": 0.01, "lr_inc": 1.05, "lr_dec": 0.7, "max_perf_inc": 1.04,
                        "mc": 0.9}),
    "trainrp": (1e-5, {"delt_inc": 1.2, "delt_dec": 0.5, "delta0": 0.07, "deltamax": 50.0}),
    "trainscg": (1e-6, {"sigma": 5e-5, "lambda_": 5e-7}),
    "traincgf": (1e-10, {"line_search": "wolfe", "alpha": 0.001, "beta": 0.1, "low_lim": 0.1,
                         "up_lim": 0.5, "minstep": 1e-6, "maxstep": 100.0}),
    "traincgp": (1e-10, {"line_search": "wolfe", "alpha": 0.001, "beta": 0.1, "low_lim": 0.1,
                         "up_lim": 0.5, "minstep": 1e-6, "maxstep": 100.0}),
    "trainoss": (1e-10, {"line_search": "backtracking", "alpha": 0.001, "beta": 0.1, "low_lim": 0.1,
                         "up_lim": 0.5, "minstep": 1e-6, "maxstep": 100.0}),
    "trainbfg": (1e-6, {"line_search": "backtracking", "alpha": 0.001, "beta": 0.1, "low_lim": 0.1,
                        "up_lim": 0.5, "minstep": 1e-6, "maxstep": 100.0}),
}


@pytest.mark.parametrize("algorithm", ALGORITHMS_HERE)
def test_registered_with_matlab_defaults(algorithm):
    backend, stopping = ALGORITHMS[algorithm]
    min_grad, options = MATLAB_DEFAULTS[algorithm]
    # epochs=1000, goal=0, max_fail=6 and time=inf are train()'s defaults for every algorithm.
    assert stopping == {"min_grad": min_grad}
    parameters = inspect.signature(backend).parameters
    defaults = {name: p.default for name, p in parameters.items()
                if name not in ("problem", "x0", "monitor")}
    assert defaults == options


# --------------------------------------------------------------------------- known answers

# algorithm -> (options, epochs, tolerance on the weights)
WELL_CONDITIONED = {
    "traingd": ({"lr": 0.1}, 500, 1e-4),  # lr = 1/λmax of the MSE Hessian
    "traingdx": ({}, 1000, 1e-4),
    "trainrp": ({}, 500, 1e-4),
    **{name: ({}, 50, 1e-6) for name in CURVATURE},
}


@pytest.mark.parametrize("algorithm", ALGORITHMS_HERE)
def test_well_conditioned_least_squares(algorithm):
    """Hessian spectrum [1, 10], 6 unknowns, 30 noisy samples: the lstsq answer."""
    options, epochs, tol = WELL_CONDITIONED[algorithm]
    for seed in SEEDS:
        problem, x0 = linear_problem(seed, (1.0, 10.0))
        result = train(problem, algorithm, x0=x0, epochs=epochs, **options)
        assert relative_error(result.x, problem.solution()) <= tol, (seed, result)


# Condition number 1e4: methods using curvature find the weights; first-order methods are
# only expected to remove most of the excess error in 2000 epochs.
ILL_CONDITIONED = {
    "trainscg": ({}, 100),
    "trainbfg": ({}, 100),
    "traincgf": ({}, 500),
    "traincgp": ({}, 500),
    "trainoss": ({"minstep": 1e-12}, 1000),  # memoryless: slow; steps near the answer are < 1e-6
}


@pytest.mark.parametrize("algorithm", CURVATURE)
def test_ill_conditioned_least_squares_weights(algorithm):
    """Hessian spectrum [0.01, 100]: weights within 1e-4 of lstsq."""
    options, epochs = ILL_CONDITIONED[algorithm]
    for seed in SEEDS:
        problem, x0 = linear_problem(seed, (1e-2, 1e2))
        result = train(problem, algorithm, x0=x0, epochs=epochs, **options)
        assert relative_error(result.x, problem.solution()) <= 1e-4, (seed, result)


@pytest.mark.parametrize("algorithm", FIRST_ORDER)
def test_ill_conditioned_least_squares_excess_error(algorithm):
    """Hessian spectrum [0.01, 100]: the MSE above the minimum shrinks 100-fold in 2000 epochs."""
    options = {"lr": 0.01} if algorithm == "traingd" else {}  # traingd: lr = 1/λmax
    for seed in SEEDS:
        problem, x0 = linear_problem(seed, (1e-2, 1e2))
        best = problem.mse(problem.solution())
        result = train(problem, algorithm, x0=x0, epochs=2000, **options)
        assert result.mse - best <= 1e-2 * (problem.mse(x0) - best), (seed, result)


NONLINEAR = {
    "traingd": ({"lr": 0.1}, 3000, 1e-3),
    "traingdx": ({}, 3000, 1e-3),
    "trainrp": ({}, 3000, 1e-3),
    **{name: ({}, 100, 1e-5) for name in CURVATURE},
}


@pytest.mark.parametrize("algorithm", ALGORITHMS_HERE)
def test_zero_residual_exponential_plus_sine(algorithm):
    """Started within ±10 % of the true parameters, each algorithm finds them."""
    options, epochs, tol = NONLINEAR[algorithm]
    problem = ExpSine()
    for seed in SEEDS:
        rng = np.random.default_rng(seed)
        x0 = ExpSine.TRUTH * (1.0 + 0.1 * rng.uniform(-1.0, 1.0, 4))
        result = train(problem, algorithm, x0=x0, epochs=epochs, **options)
        assert relative_error(result.x, ExpSine.TRUTH) <= tol, (seed, result)


# algorithm -> (epochs, tolerance, number of starting points). traingd is left out: in
# Rosenbrock's curved valley it needs ~1e5 epochs; trainrp needs ~6000 for 1e-2.
ROSENBROCK = {
    "traingdx": (5000, 1e-3, 5),
    "trainrp": (10000, 1e-2, 3),
    **{name: (300, 1e-5, 5) for name in CURVATURE},
}


@pytest.mark.parametrize("algorithm", sorted(ROSENBROCK))
def test_rosenbrock(algorithm):
    epochs, tol, n_starts = ROSENBROCK[algorithm]
    for start in Rosenbrock.STARTS[:n_starts]:
        # mse >= 0.0998·‖x − x*‖² near the minimum: this goal only stops runs that are done.
        result = train(Rosenbrock(), algorithm, x0=start, epochs=epochs, goal=0.01 * tol**2)
        assert relative_error(result.x, np.ones(2)) <= tol, (start, result)


# --------------------------------------------------------------------------- shared properties


@pytest.mark.parametrize("algorithm", CURVATURE)
@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_curvature_methods_never_raise_the_error(algorithm, seed):
    """Line searches demand sufficient decrease and trainscg keeps only steps with Δ >= 0."""
    problem, x0 = linear_problem(seed, (1e-2, 1e2))
    result = train(problem, algorithm, x0=x0, epochs=60)
    mse = result.history["mse"]
    assert np.all(np.isfinite(mse))
    assert np.all(np.diff(mse) <= 1e-12 * mse[:-1])


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_traingd_with_small_learning_rate_lowers_the_error_every_epoch(seed):
    problem, x0 = linear_problem(seed, (1e-2, 1e2))
    result = train(problem, "traingd", x0=x0, lr=0.001, epochs=200)  # lr = 0.1/λmax
    assert result.epochs == 200
    assert np.all(np.diff(result.history["mse"]) < 0.0)


RECORDED = {
    "traingd": set(),
    "traingdx": {"lr"},
    "trainrp": {"step_min", "step_max"},
    "trainscg": {"lambda"},
    **{name: {"step"} for name in LINE_SEARCH_METHODS},
}


@pytest.mark.parametrize("algorithm", ALGORITHMS_HERE)
def test_records_its_own_history_each_epoch(algorithm):
    problem, x0 = linear_problem(0, (1.0, 10.0))
    result = train(problem, algorithm, x0=x0, epochs=4, min_grad=0.0)
    assert set(result.history) == {"mse", "grad_norm"} | RECORDED[algorithm]
    for values in result.history.values():
        assert values.shape == (5,)
        assert np.all(np.isfinite(values))


BAD_OPTIONS = [
    ("traingd", "lr", -1),
    ("traingd", "lr", float("nan")),
    ("traingdx", "lr_inc", 0.9),
    ("traingdx", "lr_dec", 1.0),
    ("traingdx", "max_perf_inc", 0.5),
    ("traingdx", "mc", 1.0),
    ("trainrp", "delt_inc", 0.5),
    ("trainrp", "delt_dec", 0.0),
    ("trainrp", "delta0", 0.0),
    ("trainrp", "deltamax", -50.0),
    ("trainscg", "sigma", 0.0),
    ("trainscg", "lambda_", "big"),
    ("traincgf", "beta", 0.0005),  # must exceed alpha
    ("traincgp", "alpha", 1.0),
    ("trainoss", "up_lim", 1.0),
    ("trainoss", "low_lim", 0.6),  # must not exceed up_lim
    ("trainbfg", "minstep", 0.0),
    ("trainbfg", "maxstep", 1e-7),  # must exceed minstep
]


@pytest.mark.parametrize(("algorithm", "option", "value"), BAD_OPTIONS)
def test_bad_option_values_are_refused_in_one_sentence(algorithm, option, value):
    problem, x0 = linear_problem(0, (1.0, 10.0))
    message = rf"^{option} of {algorithm} must be .*\. Got .* instead\.$"
    with pytest.raises(InputError, match=message):
        train(problem, algorithm, x0=x0, **{option: value})


@pytest.mark.parametrize("algorithm", LINE_SEARCH_METHODS)
def test_unknown_line_search_is_refused(algorithm):
    problem, x0 = linear_problem(0, (1.0, 10.0))
    message = "line_search of .* must be one of 'backtracking', 'wolfe'"
    with pytest.raises(InputError, match=message):
        train(problem, algorithm, x0=x0, line_search="srchcha")


@pytest.mark.parametrize("algorithm", LINE_SEARCH_METHODS)
@pytest.mark.parametrize("line_search", ["backtracking", "wolfe"])
def test_both_line_searches_solve_the_nonlinear_problem(algorithm, line_search):
    problem = ExpSine()
    for seed in SEEDS:
        rng = np.random.default_rng(seed)
        x0 = ExpSine.TRUTH * (1.0 + 0.1 * rng.uniform(-1.0, 1.0, 4))
        result = train(problem, algorithm, x0=x0, epochs=200, line_search=line_search)
        assert relative_error(result.x, ExpSine.TRUTH) <= 1e-5, (seed, result)


# --------------------------------------------------------------------------- traingd, traingdx


def test_traingd_step_is_learning_rate_times_gradient():
    problem, x0 = linear_problem(0, (1.0, 10.0))
    result = train(problem, "traingd", x0=x0, lr=0.05, epochs=1)
    assert_allclose(result.x, x0 - 0.05 * problem.mse_and_gradient(x0)[1], rtol=1e-14)


def test_traingdx_adapts_the_learning_rate_as_matlab_documents():
    """lr grows by lr_inc after a step that lowers the error; a step raising it > 4 % is undone."""
    for seed in SEEDS:
        problem, x0 = linear_problem(seed, (1.0, 10.0))
        weights = []
        result = train(problem, "traingdx", x0=x0, epochs=300, min_grad=0.0,
                       callback=lambda epoch, w, mse: weights.append(np.copy(w)))
        lr, mse = result.history["lr"], result.history["mse"]
        assert lr[0] == 0.01
        ratio = lr[1:] / lr[:-1]
        fell, rejected = mse[1:] < mse[:-1], ratio < 1.0
        assert_allclose(ratio[fell], 1.05)
        assert_allclose(ratio[rejected], 0.7)
        assert np.all(fell | rejected | (ratio == 1.0))
        assert rejected.any(), "the run should overshoot at least once"
        moves = np.array([np.any(b != a) for a, b in zip(weights[:-1], weights[1:])])
        assert not moves[rejected].any()
        assert np.all(mse[1:] <= 1.04 * mse[:-1])


def test_traingdx_without_momentum_or_adaptation_is_traingd():
    problem, x0 = linear_problem(1, (1.0, 10.0))
    plain = train(problem, "traingd", x0=x0, lr=0.05, epochs=30)
    same = train(problem, "traingdx", x0=x0, lr=0.05, mc=0.0, lr_inc=1.0, max_perf_inc=1e9,
                 epochs=30)
    assert_allclose(same.x, plain.x, rtol=1e-12)


# --------------------------------------------------------------------------- trainrp


@pytest.mark.parametrize("deltamax", [50.0, 0.3])
def test_trainrp_step_sizes_stay_within_zero_and_deltamax(deltamax):
    for seed in SEEDS:
        problem, x0 = linear_problem(seed, (1e-2, 1e2))
        result = train(problem, "trainrp", x0=10.0 * x0, epochs=300, deltamax=deltamax,
                       min_grad=0.0)
        low, high = result.history["step_min"], result.history["step_max"]
        assert np.all(low > 0.0) and np.all(high <= deltamax)
        if deltamax < 1.0:
            assert np.any(high == deltamax), "far from the answer the cap should bind"


def test_trainrp_first_step_moves_every_weight_by_delta0_times_delt_inc():
    problem, x0 = linear_problem(0, (1.0, 10.0))
    grad = problem.mse_and_gradient(x0)[1]
    result = train(problem, "trainrp", x0=x0, epochs=1)
    assert_allclose(result.x, x0 - 0.07 * 1.2 * np.sign(grad), rtol=1e-14)


def test_trainrp_ignores_gradient_magnitude():
    """Scaling the error by 1000 changes nothing: Rprop uses only gradient signs."""
    problem, x0 = linear_problem(2, (1.0, 10.0))
    scaled = LinearLeastSquares(np.sqrt(1000.0) * problem.A, np.sqrt(1000.0) * problem.b)
    a = train(problem, "trainrp", x0=x0, epochs=40, min_grad=0.0)
    b = train(scaled, "trainrp", x0=x0, epochs=40, min_grad=0.0)
    assert_allclose(a.x, b.x, rtol=1e-12, atol=1e-12)


# --------------------------------------------------------------------------- trainscg, CG


def test_trainscg_solves_an_n_dimensional_quadratic_in_about_n_epochs():
    """Møller's SCG is conjugate gradients on a quadratic (λ only perturbs it by ~1e-7)."""
    n = 8
    for seed in SEEDS:
        problem, x0 = linear_problem(seed, (1.0, 4.0), n=n, m=n + 5)
        result = train(problem, "trainscg", x0=x0, epochs=n + 1, min_grad=0.0)
        assert relative_error(result.x, problem.solution()) <= 1e-6, seed


def test_trainscg_raises_lambda_after_a_failed_step():
    """A huge λ makes tiny steps, which succeed, so λ falls by 4 each epoch; a tiny λ on
    Rosenbrock overshoots at some epoch, and λ then grows."""
    problem, x0 = linear_problem(0, (1.0, 10.0))
    lam = train(problem, "trainscg", x0=x0, epochs=5, lambda_=1e6).history["lambda"]
    assert_allclose(lam[1:] / lam[:-1], 0.25)
    lam = train(Rosenbrock(), "trainscg", x0=(-1.2, 1.0), epochs=100).history["lambda"]
    assert np.any(lam[1:] > lam[:-1])


@pytest.mark.parametrize("update", ["fletcher-reeves", "polak-ribiere"])
def test_conjugate_directions_formulas_and_restart(update):
    rng = np.random.default_rng(0)
    g0, g1, g2 = rng.standard_normal((3, 5))
    rule = ConjugateDirections(update, restart_every=2)
    d0 = rule.restart(g0)
    assert_allclose(d0, -g0)
    d1 = rule.next(None, g1 - g0, g1)
    beta = g1 @ g1 / (g0 @ g0) if update == "fletcher-reeves" else (g1 - g0) @ g1 / (g0 @ g0)
    assert_allclose(d1, -g1 + beta * d0)
    assert_allclose(rule.next(None, g2 - g1, g2), -g2)  # second direction since the restart


@pytest.mark.parametrize("algorithm", ["traincgf", "traincgp", "trainbfg"])
def test_exact_line_search_solves_a_quadratic_in_n_epochs(algorithm):
    """With a near-exact line search (strong Wolfe, beta=1e-4) CG and BFGS terminate in n steps."""
    n = 8
    for seed in SEEDS:
        problem, x0 = linear_problem(seed, (1.0, 4.0), n=n, m=n + 5)
        result = train(problem, algorithm, x0=x0, epochs=n, min_grad=0.0, line_search="wolfe",
                       beta=1e-4, alpha=1e-5)
        assert relative_error(result.x, problem.solution()) <= 1e-10, seed


# --------------------------------------------------------------------------- trainbfg, trainoss


def test_bfgs_update_satisfies_the_secant_equation_and_stays_symmetric_positive_definite():
    rng = np.random.default_rng(3)
    rule = InverseBFGS(6)
    rule.restart(rng.standard_normal(6))
    M = rng.standard_normal((6, 6))
    hessian = M @ M.T + 6.0 * np.eye(6)
    for _ in range(4):
        step = rng.standard_normal(6)
        grad_change = hessian @ step
        rule.next(step, grad_change, rng.standard_normal(6))
        H = rule.inverse_hessian
        assert_allclose(H @ grad_change, step, rtol=1e-10)
        assert_allclose(H, H.T, atol=1e-12)
        assert np.all(np.linalg.eigvalsh(H) > 0.0)


def test_bfgs_skips_an_update_without_positive_curvature():
    rule = InverseBFGS(3)
    rule.restart(np.ones(3))
    grad = np.array([1.0, -2.0, 0.5])
    assert_allclose(rule.next(np.ones(3), -np.ones(3), grad), -grad)


def test_one_step_secant_is_memoryless_bfgs():
    """Battiti's d = -g + A s + B y equals -H g for H the BFGS update of the identity."""
    rng = np.random.default_rng(4)
    for _ in range(5):
        step, grad, grad_change = rng.standard_normal((3, 7))
        grad_change += 3.0 * step  # positive curvature
        rho = 1.0 / (step @ grad_change)
        left = np.eye(7) - rho * np.outer(step, grad_change)
        H = left @ left.T + rho * np.outer(step, step)
        assert_allclose(OneStepSecant().next(step, grad_change, grad), -H @ grad, rtol=1e-10)


# --------------------------------------------------------------------------- line searches


class Quadratic1D:
    """mse(x) = curvature · (x − minimum)² in one unknown."""

    n_params = n_samples = 1

    def __init__(self, minimum, curvature=1.0):
        self.minimum, self.curvature = minimum, curvature

    def mse_and_gradient(self, x):
        e = float(x[0]) - self.minimum
        return self.curvature * e * e, np.array([2.0 * self.curvature * e])

    def mse(self, x):
        return self.mse_and_gradient(x)[0]


class OverflowsBeyond(Quadratic1D):
    """A quadratic whose error overflows (inf) beyond x = ``wall``."""

    def __init__(self, minimum, wall):
        super().__init__(minimum)
        self.wall = wall

    def mse_and_gradient(self, x):
        if float(x[0]) > self.wall:
            return math.inf, np.array([math.nan])
        return super().mse_and_gradient(x)


def search_from_zero(problem, direction, **settings):
    search = LineSearch(**settings)
    x = np.zeros(1)
    mse, grad = problem.mse_and_gradient(x)
    return search(problem, x, mse, grad, np.array([direction])), mse, grad


def assert_wolfe(found, mse0, slope0, direction, alpha=0.001, beta=0.1, strong=False):
    slope = float(found.grad[0] * direction)
    assert found.mse <= mse0 + alpha * found.step * slope0
    assert slope >= beta * slope0
    if strong:
        assert abs(slope) <= beta * abs(slope0)


@pytest.mark.parametrize("method", ["backtracking", "wolfe"])
@pytest.mark.parametrize("minimum", [1e-3, 0.3, 1.0, 7.0, 80.0])
def test_line_search_meets_sufficient_decrease_and_curvature(method, minimum):
    """Whether step 1 along d is far too long, about right, or far too short."""
    problem = Quadratic1D(minimum, curvature=2.0)
    found, mse0, grad0 = search_from_zero(problem, 1.0, method=method)
    assert_wolfe(found, mse0, float(grad0[0]), 1.0, strong=method == "wolfe")


def test_backtracking_takes_the_full_step_when_it_is_good():
    found, _, _ = search_from_zero(Quadratic1D(1.0), 1.0, method="backtracking")
    assert found.step == 1.0
    assert found.mse == 0.0


@pytest.mark.parametrize("method", ["backtracking", "wolfe"])
def test_line_search_backs_off_from_overflow(method):
    problem = OverflowsBeyond(minimum=5.0, wall=6.0)
    found, mse0, grad0 = search_from_zero(problem, 1000.0, method=method)
    assert math.isfinite(found.mse) and found.mse < mse0
    assert found.x[0] <= 6.0


@pytest.mark.parametrize("method", ["backtracking", "wolfe"])
def test_line_search_longest_step_is_maxstep(method):
    found, _, _ = search_from_zero(Quadratic1D(1e6), 1.0, method=method, maxstep=100.0)
    assert 0.0 < found.x[0] <= 100.0 * (1.0 + 1e-12)


@pytest.mark.parametrize("method", ["backtracking", "wolfe"])
def test_line_search_returns_none_uphill(method):
    assert search_from_zero(Quadratic1D(1.0), -1.0, method=method)[0] is None
    assert search_from_zero(Quadratic1D(0.0), 1.0, method=method)[0] is None  # at the minimum


def test_backtracking_gives_up_below_minstep():
    # Only steps below 1e-9 lower the error: a wall of overflow right after the start.
    problem = OverflowsBeyond(minimum=5.0, wall=1e-9)
    assert search_from_zero(problem, 1.0, method="backtracking", minstep=1e-6)[0] is None
    found, _, _ = search_from_zero(problem, 1.0, method="backtracking", minstep=1e-15)
    assert 0.0 < found.x[0] <= 1e-9


# --------------------------------------------------------------------------- the 1:10:1 network


# algorithm -> least factor by which 100 epochs lower the MSE (measured minimum over the six
# seeds: traingd 4, traingdx 77, trainrp 1.4e3, the others 1.6e3 to 1.6e4).
NETWORK_FACTOR = {
    "traingd": 2.0,
    "traingdx": 20.0,
    "trainrp": 300.0,
    **{name: 300.0 for name in CURVATURE},
}


@pytest.mark.parametrize("algorithm", ALGORITHMS_HERE)
def test_lowers_the_error_of_a_1_10_1_network_on_a_smooth_periodic_profile(algorithm):
    theta = np.arange(0.0, 360.0, 4.0)
    radians = np.radians(theta)
    error = 3.0 * np.sin(radians) + 1.5 * np.cos(2.0 * radians) + 0.5 * np.sin(3.0 * radians + 1.0)
    problem = NetworkProblem.from_angles(theta, error, 10, encoding="periodic")
    for seed in range(6):
        x0 = problem.initial_weights(seed)
        result = train(problem, algorithm, x0=x0, epochs=100)
        assert problem.mse(x0) / result.mse >= NETWORK_FACTOR[algorithm], (seed, result)

"""The 1:N:1 network as a training problem: scaling, initialisation, weight layout, derivatives."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

from encal._core.errors import InputError
from encal.training.network import (
    ACTIVATIONS,
    ENCODINGS,
    MapMinMax,
    NetworkProblem,
    encode_angles,
    forward,
    n_weights,
    nguyen_widrow,
    pack_weights,
    unpack_weights,
)

SEEDS = range(5)
TRAINING_GRID = np.arange(0.0, 360.0, 2.0)


def random_problem(seed, encoding, activation, hidden=5, m=40):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.0, 360.0, m)
    error = rng.normal(0.0, 2.0, m)
    problem = NetworkProblem.from_angles(theta, error, hidden, encoding=encoding, activation=activation)
    # Nguyen-Widrow weights moved off their structured values, so no derivative is special.
    w = problem.initial_weights(rng) + 0.3 * rng.standard_normal(problem.n_params)
    return problem, w


def central_differences(function, w, step=1e-6):
    columns = []
    for j in range(w.size):
        dw = np.zeros_like(w)
        dw[j] = step
        columns.append((np.asarray(function(w + dw)) - np.asarray(function(w - dw))) / (2 * step))
    return np.stack(columns, axis=-1)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("activation", sorted(ACTIVATIONS))
@pytest.mark.parametrize("encoding", sorted(ENCODINGS))
def test_jacobian_matches_finite_differences(seed, activation, encoding):
    problem, w = random_problem(seed, encoding, activation)
    r, J = problem.residuals_and_jacobian(w)
    assert J.shape == (problem.n_samples, problem.n_params)
    assert_allclose(r, problem.residuals(w), rtol=0, atol=1e-15)
    assert_allclose(J, central_differences(problem.residuals, w), rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("activation", sorted(ACTIVATIONS))
@pytest.mark.parametrize("encoding", sorted(ENCODINGS))
def test_gradient_matches_finite_differences_and_jacobian(seed, activation, encoding):
    problem, w = random_problem(seed, encoding, activation)
    mse, grad = problem.mse_and_gradient(w)
    r, J = problem.residuals_and_jacobian(w)
    assert mse == pytest.approx(np.mean(r**2), rel=1e-14)
    assert_allclose(grad, 2.0 * J.T @ r / problem.n_samples, rtol=1e-10, atol=1e-14)
    assert_allclose(grad, central_differences(problem.mse, w), rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("activation", sorted(ACTIVATIONS))
@pytest.mark.parametrize("encoding", sorted(ENCODINGS))
def test_jacobian_outer_is_j_j_transpose(encoding, activation):
    problem, w = random_problem(0, encoding, activation)
    J = problem.residuals_and_jacobian(w)[1]
    assert_allclose(np.tril(problem.jacobian_outer(w)), np.tril(J @ J.T), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(("encoding", "expected"), [("raw", 241), ("periodic", 321)])
def test_paper_network_sizes(encoding, expected):
    problem = NetworkProblem.from_angles(TRAINING_GRID, np.sin(np.radians(TRAINING_GRID)), 80,
                                         encoding=encoding)
    assert problem.n_params == expected == n_weights(ENCODINGS[encoding], 80)
    assert problem.n_samples == 180


def test_weight_layout_is_documented_one():
    hidden, n_inputs = 3, 2
    w = np.arange(n_weights(n_inputs, hidden), dtype=float)
    W1, b1, W2, b2 = unpack_weights(w, n_inputs, hidden)
    for j in range(hidden):
        for k in range(n_inputs):
            assert W1[j, k] == w[k * hidden + j]
    assert_array_equal(b1, [6, 7, 8])
    assert_array_equal(W2, [9, 10, 11])
    assert b2 == 12
    assert_array_equal(pack_weights(W1, b1, W2, b2), w)


def test_forward_is_the_documented_formula():
    problem, w = random_problem(0, "periodic", "logsig")
    W1, b1, W2, b2 = problem.unpack(w)
    z = problem.inputs @ W1.T + b1
    expected = (1.0 / (1.0 + np.exp(-z))) @ W2 + b2
    assert_allclose(problem.outputs(w), expected, rtol=1e-13)
    assert_allclose(forward(problem.inputs, W1, b1, W2, b2, "logsig"), expected, rtol=1e-13)


def test_mapminmax_settings_are_matlabs():
    values = np.array([[2.0, 5.0], [4.0, 5.0], [3.0, 5.0]])
    scaling = MapMinMax.fit(values)
    assert_array_equal(scaling.offset, [2.0, 5.0])
    assert_array_equal(scaling.gain, [1.0, 1.0])  # 2 / (4 - 2), and 1 for the constant column
    assert_array_equal(scaling.apply(values), [[-1.0, -1.0], [1.0, -1.0], [0.0, -1.0]])
    target = MapMinMax.fit(np.array([-3.0, 1.0]))
    assert target.offset == -3.0 and target.gain == 0.5


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6), min_size=2, max_size=30))
def test_mapminmax_maps_onto_minus_one_one_and_back(values):
    values = np.array(values)
    scaling = MapMinMax.fit(values)
    scaled = scaling.apply(values)
    if np.ptp(values) > 1e-300:  # narrower ranges overflow the gain, which is then 1 (MATLAB's rule)
        assert scaled.min() == -1.0
        assert scaled.max() == pytest.approx(1.0, abs=1e-12)
    # absolute tolerance relative to 1 at least: with a zero range the gain is 1 and tiny values round off
    assert_allclose(scaling.reverse(scaled), values, rtol=1e-12, atol=1e-9 * max(1.0, np.abs(values).max()))


def test_encodings():
    theta = np.array([0.0, 90.0, 180.0])
    assert_array_equal(encode_angles(theta, "raw"), theta[:, None])
    assert_allclose(encode_angles(theta, "periodic"), [[1, 0], [0, 1], [-1, 0]], atol=1e-15)
    with pytest.raises(InputError, match="encoding must be one of"):
        encode_angles(theta, "sincos")


@pytest.mark.parametrize("activation", sorted(ACTIVATIONS))
@pytest.mark.parametrize("n_inputs", [1, 2])
def test_nguyen_widrow_is_reproducible_and_scaled_like_initnw(n_inputs, activation):
    hidden = 10
    w = nguyen_widrow(n_inputs, hidden, activation, rng=3)
    assert_array_equal(w, nguyen_widrow(n_inputs, hidden, activation, rng=np.random.default_rng(3)))
    assert not np.array_equal(w, nguyen_widrow(n_inputs, hidden, activation, rng=4))
    W1, b1, W2, b2 = unpack_weights(w, n_inputs, hidden)
    half_width = {"tansig": 2.0, "logsig": 4.0}[activation]
    magnitude = half_width * 0.7 * hidden ** (1.0 / n_inputs)
    assert_allclose(np.linalg.norm(W1, axis=1), magnitude, rtol=1e-12)
    assert_allclose(np.abs(b1), magnitude * np.abs(np.linspace(-1, 1, hidden)), rtol=1e-12)
    assert np.all(np.abs(W2) <= 1.0) and abs(b2) <= 1.0


def test_initial_weights_follow_the_seed_bit_for_bit():
    problem = NetworkProblem.from_angles(TRAINING_GRID, np.cos(np.radians(TRAINING_GRID)), 80)
    assert_array_equal(problem.initial_weights(11), problem.initial_weights(11))


def test_inputs_and_targets_must_match():
    with pytest.raises(InputError, match="inputs must have shape"):
        NetworkProblem(np.zeros((5, 2)), np.zeros(4), hidden=3)

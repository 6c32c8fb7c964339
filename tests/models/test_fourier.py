"""Fourier-series error model (encal.models.fourier)."""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

import encal
from encal._core.errors import InputError, ModelFileError
from encal.models import model_kind
from encal.models.fourier import FourierModel, cross_validate_order_count, fit_fourier

TRAIN = np.arange(0.0, 360.0, 2.0)  # the paper's training grid
TEST = np.arange(1.0, 360.0, 2.0)  # the paper's test grid


def series(theta_deg, orders, cos, sin):
    """The Fourier series of docs/model-file.md, written out independently."""
    theta = np.radians(np.asarray(theta_deg, dtype=float))
    return sum(a * np.cos(k * theta) + b * np.sin(k * theta) for k, a, b in zip(orders, cos, sin))


def random_profile(rng, orders):
    cos = rng.normal(size=len(orders)) * 2.0
    sin = np.where(np.asarray(orders) == 0, 0.0, rng.normal(size=len(orders)) * 2.0)
    return cos, sin


@pytest.mark.parametrize("seed", range(5))
def test_noise_free_profile_is_recovered_exactly(seed):
    rng = np.random.default_rng(seed)
    orders = [0, 1, 2, 4, 14, 16, 32, 48, 84]
    cos, sin = random_profile(rng, orders)
    model = fit_fourier(TRAIN, series(TRAIN, orders, cos, sin), orders=orders)
    assert model.orders.tolist() == orders
    assert_allclose(model.cos, cos, rtol=0, atol=1e-10)
    assert_allclose(model.sin, sin, rtol=0, atol=1e-10)
    anywhere = rng.uniform(-720.0, 720.0, 500)
    assert_allclose(model.predict(anywhere), series(anywhere, orders, cos, sin), rtol=0, atol=1e-10)


@pytest.mark.parametrize("seed", range(5))
def test_top_rule_finds_the_orders_of_a_noise_free_profile(seed):
    rng = np.random.default_rng(seed)
    orders = [0, 1, 2, 3, 4, 14, 16, 32, 48, 84]
    cos, sin = random_profile(rng, orders)
    cos = np.sign(cos) * (0.5 + np.abs(cos))  # every order clearly present
    model = fit_fourier(TRAIN, series(TRAIN, orders, cos, sin))  # select='top', n_orders=10
    assert sorted(model.orders.tolist()) == orders
    assert_allclose(model.predict(TEST), series(TEST, orders, cos, sin), rtol=0, atol=1e-10)
    assert model.training == {"select": "top", "n_orders": 10, "orders": model.orders.tolist(),
                              "max_order": 90}


def test_noise_free_profile_is_recovered_from_irregular_angles():
    rng = np.random.default_rng(11)
    theta = rng.uniform(0.0, 360.0, 150)
    orders = [0, 1, 2, 5, 16, 40]
    cos, sin = random_profile(rng, orders)
    model = fit_fourier(theta, series(theta, orders, cos, sin), orders=orders)
    assert_allclose(model.cos, cos, atol=1e-10)
    assert_allclose(model.sin, sin, atol=1e-10)


@pytest.mark.parametrize("grid, phase_deg", [(TRAIN, 0.0), (TEST, 1.0)])
def test_nyquist_order_keeps_the_term_the_grid_can_see(grid, phase_deg):
    # Two samples per period: only the term locked to the grid is identifiable.
    truth = 1.5 * np.cos(np.radians(90 * (grid - phase_deg))) + np.sin(np.radians(grid))
    model = fit_fourier(grid, truth, orders=[1, 90])
    assert_allclose(model.predict(grid), truth, atol=1e-10)
    a, b = model.cos[1], model.sin[1]
    assert_allclose([a, b], 1.5 * np.array([np.cos(np.radians(90 * phase_deg)),
                                            np.sin(np.radians(90 * phase_deg))]), atol=1e-10)
    assert model.training["max_order"] == 90


def test_top_rule_picks_the_per_step_pattern_at_the_nyquist_order():
    steps = np.arange(0.0, 360.0, 3.6)  # 100 full steps pairs: order 50 is the Nyquist order
    error = 20.0 * np.cos(np.radians(2 * steps)) + 3.0 * (-1.0) ** np.arange(100)
    model = fit_fourier(steps, error, n_orders=2)
    assert model.orders.tolist() == [2, 50]
    assert_allclose(model.predict(steps), error, atol=1e-10)


def noisy_profile(seed):
    """Orders 0, 1, 2, 16, 14 and 48 (cosines at least 0.5 arcmin) and white noise of 0.1 arcmin on :data:`TRAIN`:
    (orders, cos, sin, noise). benchmarks/bench_accuracy.py --known-truth fits it over seeds 0-19."""
    rng = np.random.default_rng(seed)
    orders = [0, 1, 2, 16, 14, 48]
    cos, sin = random_profile(rng, orders)
    cos = np.sign(cos) * (0.5 + np.abs(cos))  # amplitudes >= 0.5 arcmin, far above the noise
    return orders, cos, sin, rng.normal(0.0, 0.1, TRAIN.size)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("select", ["top", "cv"])
def test_noisy_profile_is_recovered_within_the_noise(seed, select):
    """White noise on 180 points: the fitted curve is nearer the truth than the noise is.

    When the chosen orders include the true ones, the fit at the samples is
    the truth plus the projection of the noise onto the chosen terms, and a
    projection never lengthens a vector; on a uniform grid the RMS over the
    whole circle of a series below the Nyquist order equals its RMS at the
    samples. So both errors are bounded by the RMS of the noise drawn,
    whatever the seed.
    """
    orders, cos, sin, noise = noisy_profile(seed)
    observed = series(TRAIN, orders, cos, sin) + noise
    model = fit_fourier(TRAIN, observed, select=select)
    assert set(orders) <= set(model.orders.tolist())
    assert 90 not in model.orders.tolist()  # the one order whose continuous RMS differs
    noise_rms = np.sqrt(np.mean(noise**2))
    dense = np.linspace(0.0, 360.0, 3601)
    error = model.predict(dense) - series(dense, orders, cos, sin)
    assert np.sqrt(np.mean(error**2)) <= noise_rms
    residual = observed - model.predict(TRAIN)
    assert np.sqrt(np.mean(residual**2)) <= noise_rms


def test_cross_validation_follows_the_one_standard_error_rule():
    rng = np.random.default_rng(0)
    truth = 3.0 * np.cos(np.radians(TRAIN)) + 1.0 * np.sin(np.radians(2 * TRAIN))
    observed = truth + rng.normal(0.0, 0.1, TRAIN.size)
    model = fit_fourier(TRAIN, observed, select="cv")
    counts, rms, se = cross_validate_order_count(TRAIN, observed)
    assert model.training["select"] == "cv" and model.training["folds"] == 5
    assert model.training["cv_rms_arcmin"] == pytest.approx(rms.tolist())
    chosen = len(model.orders)
    best = int(np.argmin(rms))
    assert rms[chosen - 1] <= rms[best] + se[best]
    assert np.all(rms[: chosen - 1] > rms[best] + se[best])
    assert {1, 2} <= set(model.orders.tolist())
    assert chosen <= best + 1


def test_cross_validation_curve_is_exact_for_noise_free_data():
    truth = 2.0 + np.cos(np.radians(3 * TRAIN))
    counts, rms, se = cross_validate_order_count(TRAIN, truth, folds=4)
    assert counts[0] == 1 and rms.size == counts.size == se.size
    assert rms[1] < 1e-10 and rms[0] > 0.5  # two orders (0 and 3) describe it exactly
    assert fit_fourier(TRAIN, truth, select="cv").orders.tolist() == [0, 3]


def test_cross_validation_sees_the_nyquist_term():
    steps = np.arange(0.0, 360.0, 3.6)
    error = 20.0 * np.cos(np.radians(2 * steps)) + 3.0 * (-1.0) ** np.arange(100)
    model = fit_fourier(steps, error, select="cv")
    assert model.orders.tolist() == [2, 50]


def test_cross_validation_keeps_repeated_angles_in_one_fold():
    # Two identical epochs: with the twin of a held-out point in training, CV would
    # reward interpolating the noise. Kept together, the CV is that of one epoch.
    rng = np.random.default_rng(5)
    grid = np.arange(0.0, 360.0, 4.0)
    observed = np.cos(np.radians(grid)) + rng.normal(0.0, 0.2, grid.size)
    once = cross_validate_order_count(grid, observed)
    twice = cross_validate_order_count(np.r_[grid, grid], np.r_[observed, observed])
    for single, double in zip(once, twice):
        assert_allclose(double, single, rtol=1e-9, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(theta=st.floats(-1e4, 1e4, allow_nan=False), turns=st.integers(-5, 5))
def test_prediction_is_periodic(theta, turns):
    model = FourierModel([0, 1, 2, 16, 90], [0.3, 2.0, -1.0, 0.5, 0.2], [0.0, 1.0, 0.4, -0.3, 0.0])
    # θ + 360 k and θ round differently; the series' slope is at most Σ k |coef| arcmin/rad.
    slope_per_deg = math.radians(sum(k * (abs(a) + abs(b)) for k, a, b in
                                     zip(model.orders, model.cos, model.sin)))
    tolerance = slope_per_deg * 1e-10 * max(1.0, abs(theta))
    assert model.predict(theta + 360.0 * turns) == pytest.approx(float(model.predict(theta)), abs=tolerance)


def test_prediction_is_continuous_at_zero():
    model = fit_fourier(TRAIN, np.random.default_rng(2).normal(size=180))
    assert model.predict(360.0 - 1e-9) == pytest.approx(float(model.predict(0.0)), abs=1e-3)
    assert model.predict(360.0) == model.predict(0.0)


def test_parameters_follow_the_model_file_layout_and_round_trip():
    rng = np.random.default_rng(4)
    model = fit_fourier(TRAIN, rng.normal(size=180), select="top")
    parameters = json.loads(json.dumps(model.parameters()))
    assert set(parameters) == {"orders", "cos", "sin"}
    assert all(type(k) is int for k in parameters["orders"])
    assert parameters["sin"][parameters["orders"].index(0)] == 0.0 if 0 in parameters["orders"] else True
    angles = rng.uniform(0.0, 360.0, 100)
    assert_allclose(series(angles, **parameters), model.predict(angles), rtol=0, atol=1e-12)
    again = FourierModel.from_parameters(parameters)
    assert np.array_equal(again.predict(angles), model.predict(angles))
    assert model_kind("fourier").model_class is FourierModel


def test_predict_and_correct_keep_the_shape_of_the_input():
    model = FourierModel([1], [60.0], [0.0])  # one degree at 0°
    assert np.shape(model.predict(np.zeros((2, 3)))) == (2, 3)
    assert isinstance(model.predict(10.0), float)
    assert model.correct(0.5) == pytest.approx(359.5)


def test_fit_checks_its_options():
    errors = np.zeros(TRAIN.size)
    with pytest.raises(InputError, match="'select' parameter of fit_fourier"):
        fit_fourier(TRAIN, errors, select="best")
    with pytest.raises(InputError, match="'n_orders' parameter"):
        fit_fourier(TRAIN, errors, n_orders=0)
    with pytest.raises(InputError, match="'folds' parameter"):
        fit_fourier(TRAIN, errors, select="cv", folds=1)
    with pytest.raises(InputError, match="'orders' parameter of fit_fourier must hold distinct ints >= 0 up"):
        fit_fourier(TRAIN, errors, orders=[1, 91], max_order=90)
    with pytest.raises(InputError, match="cannot identify"):
        fit_fourier(TRAIN, errors, orders=[89, 91])  # on 180 points 91 aliases to 89
    with pytest.raises(InputError, match="'orders' parameter"):
        fit_fourier(TRAIN, errors, orders=[-1])
    with pytest.raises(InputError, match="'orders' parameter"):
        fit_fourier(TRAIN, errors, orders=[1, 1])
    with pytest.raises(InputError, match="cannot identify"):
        fit_fourier(TRAIN, errors, orders=[1, 179], max_order=179)  # 179 aliases to 1
    with pytest.raises(InputError, match="one error per encoder angle"):
        fit_fourier(TRAIN, errors[:-1])


def test_few_points_keep_as_many_orders_as_they_identify():
    theta = np.arange(0.0, 360.0, 45.0)  # 8 points: orders 0..4
    model = fit_fourier(theta, np.random.default_rng(0).normal(size=8))
    assert sorted(model.orders.tolist()) == [0, 1, 2, 3, 4]


def test_invalid_parameters_are_a_model_file_error():
    with pytest.raises(ModelFileError, match="fourier model parameters"):
        FourierModel.from_parameters({"orders": [1], "cos": [1.0]})
    with pytest.raises(ModelFileError, match="fourier model parameters"):
        FourierModel.from_parameters({"orders": [1, 2], "cos": [1.0], "sin": [0.0]})
    with pytest.raises(ModelFileError):
        FourierModel.from_parameters({"orders": [-1], "cos": [1.0], "sin": [0.0]})


def test_save_and_load_give_the_same_model(tmp_path):
    model = fit_fourier(TRAIN, np.random.default_rng(8).normal(size=180), select="cv")
    model.encoder = {"name": "enc1", "resolution_bits": 16}
    model.save(tmp_path / "enc1.json")
    again = encal.load_model(tmp_path / "enc1.json")
    angles = np.random.default_rng(0).uniform(-720.0, 720.0, 500)
    assert type(again) is type(model)
    assert np.array_equal(again.predict(angles), model.predict(angles))
    assert again.parameters() == model.parameters()


def test_orders_that_alias_on_a_slightly_irregular_grid_are_refused():
    """Encoder readings of the 2-degree grid: 179 is not rank-deficient with 1 there, but aliases it."""
    encoder = TRAIN + 2.0 / 60.0 * np.sin(np.radians(TRAIN) + 0.3)
    error = 2.0 * np.sin(np.radians(TRAIN) + 0.3)
    with pytest.raises(InputError, match=r"fit_fourier cannot identify harmonic order 179 .* highest order they "
                                         r"determine is 90, .* order 179 looks like order 1"):
        fit_fourier(encoder, error, orders=[0, 1, 179])
    assert fit_fourier(encoder, error, orders=[0, 1, 90]).orders.tolist() == [0, 1, 90]


# --------------------------------------------------------------------------- grid of the whole calibration

STEPS = np.arange(200) * 1.8  # a stepper's 200 full steps: the Nyquist order is 100


def stepped_profile(rng, sigma=0.05, parity=2.0):
    """Readings near 200 full steps (within 0.02°, 1 % of a step); low orders + a ±parity
    alternation (-1)^k + white noise of sigma, arcmin. Returns (angles, errors, noise-free errors)."""
    theta = STEPS + rng.normal(0.0, 0.02, STEPS.size)
    r = np.radians(STEPS)
    truth = 3.0 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r) + 0.7 * np.sin(16 * r) + parity * (-1.0) ** np.arange(200)
    return theta, truth + rng.normal(0.0, sigma, STEPS.size), truth


@pytest.mark.parametrize("seed", range(3))
def test_a_fold_told_its_grid_fits_the_per_step_pattern_it_cannot_see_alone(seed):
    # A cross-validation fold's training part: every fifth step missing. Alone, its largest gap
    # (3.6°) allows orders up to 49; told it lies on the 200-step grid, it may use order 100,
    # and predicts the held-out steps' alternation.
    theta, observed, truth = stepped_profile(np.random.default_rng(seed))
    held_out = np.arange(200) % 5 == 0
    told = fit_fourier(theta[~held_out], observed[~held_out], select="cv", grid_points=200)
    alone = fit_fourier(theta[~held_out], observed[~held_out], select="cv")
    assert sorted(told.orders.tolist()) == [1, 2, 16, 100]
    assert told.training["max_order"] == 100 and told.training["grid_points"] == 200
    assert alone.training["max_order"] == 49 and 100 not in alone.orders.tolist()
    # The fit of 7 terms to 160 points with noise 0.05: within 0.05 of the truth at the held-out steps
    # (the projected noise is 0.05 * sqrt(7/160) = 0.01 RMS); alone it misses the ±2 alternation.
    assert np.sqrt(np.mean((told.predict(theta[held_out]) - truth[held_out]) ** 2)) < 0.05
    assert np.sqrt(np.mean((alone.predict(theta[held_out]) - truth[held_out]) ** 2)) > 1.5


def test_the_top_rule_on_a_grid_subset_is_not_misled_by_leakage():
    # With a fifth of the nodes missing, the zero-filled DFT leaks a 20-arcmin order 1 into
    # orders 39, 41, 79 and 81 at 4 arcmin, above the 1-arcmin orders 5 and 100 that are there.
    # Forward selection fits order 1 first, so its leakage never competes.
    r = np.radians(STEPS)
    truth = 20.0 * np.cos(r) + np.sin(5 * r) + 1.0 * (-1.0) ** np.arange(200)
    keep = np.arange(200) % 5 != 2
    model = fit_fourier(STEPS[keep], truth[keep], n_orders=3, grid_points=200)
    assert sorted(model.orders.tolist()) == [1, 5, 100]
    assert_allclose(model.predict(STEPS), truth, atol=1e-9)


def test_orders_that_the_occupied_nodes_cannot_identify_are_refused():
    # With every fifth step missing, the terms of orders 20, 60 and the Nyquist order 100 are five
    # functions of the step index that all vanish on the missing steps up to one combination: at the
    # 160 nodes they are linearly dependent. Readings 0.02° off the nodes make the design full-rank,
    # but a fit there would follow the offsets, not the profile; it is refused.
    theta = STEPS + np.random.default_rng(1).normal(0.0, 0.02, STEPS.size)
    keep = np.arange(200) % 5 != 0
    errors = np.cos(np.radians(20 * STEPS))[keep]
    with pytest.raises(InputError, match="rank-deficient"):
        fit_fourier(theta[keep], errors, orders=[20, 60, 100], grid_points=200)
    fit_fourier(theta[keep], errors, orders=[20, 60], grid_points=200)  # two of them are identified


def test_cross_validation_leaves_out_orders_a_fold_cannot_identify():
    # The whole grid identifies [20, 60, 100]; each fold (every fifth step missing) does not, and
    # leaves the last of them out of its fits instead of extrapolating an undetermined combination.
    theta = STEPS + np.random.default_rng(2).normal(0.0, 0.02, STEPS.size)
    truth = np.cos(np.radians(20 * STEPS)) + 0.5 * np.cos(np.radians(60 * STEPS)) + 0.8 * (-1.0) ** np.arange(200)
    predicted = encal.analysis.profile.nested_harmonic_predictions(
        theta[np.arange(200) % 5 != 0], truth[np.arange(200) % 5 != 0], [20, 100, 60],
        theta[::5], grid_deg=STEPS)
    assert np.all(np.isfinite(predicted)) and np.max(np.abs(predicted)) < 3.0
    assert_allclose(predicted[2], predicted[1])  # order 60 left out of the fold's fit


def test_a_grid_of_the_even_steps_is_its_own_grid():
    # The 100 even rows of a 200-step calibration lie on a 100-point grid (3.6°): the alternation
    # of the full steps is a constant there, and the Nyquist order is 50, not 100.
    theta, observed, _ = stepped_profile(np.random.default_rng(3))
    even = np.arange(200) % 2 == 0
    model = fit_fourier(theta[even], observed[even], select="cv")
    assert model.training["max_order"] == 50
    assert 0 in model.orders.tolist() and abs(model.cos[model.orders.tolist().index(0)] - 2.0) < 0.05
    with pytest.raises(InputError, match="uniform grid of 100"):  # one odd row: half a spacing off
        fit_fourier(np.r_[theta[even], theta[1]], np.r_[observed[even], observed[1]], grid_points=100)


def test_irregular_angles_keep_the_identifiable_order_and_refuse_a_grid():
    rng = np.random.default_rng(4)
    theta = np.sort(rng.uniform(0.0, 360.0, 150))
    observed = np.cos(np.radians(theta)) + rng.normal(0.0, 0.05, theta.size)
    model = fit_fourier(theta, observed, select="cv")
    assert model.training["max_order"] == encal.analysis.profile.identifiable_order(theta)
    with pytest.raises(InputError, match="uniform grid"):
        fit_fourier(theta, observed, grid_points=200)


def test_the_count_range_grows_only_while_the_curve_needs_it():
    # 3 orders + noise on the 2° grid: the first 64 counts hold the minimum, and the curve is the
    # prefix of the one over every count (each count's fold fits do not depend on later orders).
    rng = np.random.default_rng(0)
    observed = 3.0 * np.cos(np.radians(TRAIN)) + np.sin(np.radians(2 * TRAIN)) + rng.normal(0.0, 0.1, TRAIN.size)
    counts, rms, se = cross_validate_order_count(TRAIN, observed)
    assert counts.size == 64
    full = encal.models.fourier._cv_curve(TRAIN, observed, np.arange(TRAIN.size) % 5,
                                          encal.analysis.profile.rank_orders(TRAIN, observed), TRAIN)
    assert_allclose(rms, full[0][:64], rtol=1e-12)

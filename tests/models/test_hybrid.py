"""The hybrid model (encal.models.hybrid): Fourier series of the dominant orders + a network on the rest."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import encal
from encal import runtime
from encal._core.errors import InputError, ModelFileError
from encal.models.ann import fit_ann
from encal.models.fourier import fit_fourier
from encal.models.hybrid import HybridModel, fit_hybrid

GRID = np.arange(0.0, 360.0, 2.0)  # training grid
TEST_GRID = GRID + 1.0  # the paper's test grid, between the training points


def harmonic_profile(theta_deg):
    """Resolver-like harmonics, orders 0, 1, 2 and 16, in arcmin."""
    r = np.radians(theta_deg)
    return 0.4 + 3.0 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r) + 0.7 * np.sin(16 * r + 1.0)


def bump(theta_deg, centre=100.0, width=4.0, height=2.0):
    """A local defect: a Gaussian bump, ``width`` degrees (sigma), ``height`` arcmin."""
    distance = (np.asarray(theta_deg) - centre + 180.0) % 360.0 - 180.0
    return height * np.exp(-0.5 * (distance / width) ** 2)


def rms(values):
    return float(np.sqrt(np.mean(np.square(values))))


@pytest.fixture(scope="module")
def defect_model():
    error = harmonic_profile(GRID) + bump(GRID) + 0.03 * np.random.default_rng(0).normal(size=GRID.size)
    return fit_hybrid(GRID, error, rng=0), error


def test_prediction_is_the_sum_of_the_two_parts(defect_model):
    model, _ = defect_model
    theta = np.linspace(-720.0, 720.0, 997)
    np.testing.assert_allclose(model.predict(theta), model.fourier.predict(theta) + model.ann.predict(theta),
                               rtol=0, atol=1e-12)


def test_the_fourier_part_holds_the_dominant_orders(defect_model):
    model, _ = defect_model
    assert {0, 1, 2, 16} <= set(model.fourier.orders.tolist())
    assert model.fourier.orders.size == 10
    assert model.ann.encoding == "periodic" and model.ann.hidden == 8


def test_a_noise_free_harmonic_profile_is_recovered():
    model = fit_hybrid(GRID, harmonic_profile(GRID), n_orders=4, hidden=3, epochs=20, rng=1)
    dense = np.linspace(0.0, 360.0, 1441)
    # The Fourier part is exact; the network's share is a fit to a residual of rounding size.
    np.testing.assert_allclose(model.predict(dense), harmonic_profile(dense), rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_the_network_follows_a_local_defect_that_the_series_misses(seed):
    error = harmonic_profile(GRID) + bump(GRID) + 0.03 * np.random.default_rng(seed).normal(size=GRID.size)
    truth = harmonic_profile(TEST_GRID) + bump(TEST_GRID)
    hybrid = fit_hybrid(GRID, error, rng=seed)
    fourier = fit_fourier(GRID, error, n_orders=10)
    # Ten harmonics leave about 0.17 arcmin RMS of the 2-arcmin bump; the hybrid about 0.05.
    assert rms(fourier.predict(TEST_GRID) - truth) > 0.15
    assert rms(hybrid.predict(TEST_GRID) - truth) < 0.09


def test_more_restarts_never_fit_the_residual_worse():
    error = harmonic_profile(GRID) + bump(GRID)
    residual = error - fit_fourier(GRID, error, n_orders=10).predict(GRID)
    one = fit_hybrid(GRID, error, restarts=1, rng=3)
    three = fit_hybrid(GRID, error, restarts=3, rng=3)
    # The first start of both is the same network; three starts keep the best of three.
    assert rms(residual - three.ann.predict(GRID)) <= rms(residual - one.ann.predict(GRID))


@settings(max_examples=30, deadline=None)
@given(theta=st.floats(-1e4, 1e4), turns=st.integers(-5, 5))
def test_the_model_is_periodic(defect_model, theta, turns):
    model, _ = defect_model
    np.testing.assert_allclose(model.predict(theta + 360.0 * turns), model.predict(theta), rtol=0, atol=1e-9)


def test_the_same_seed_gives_the_same_model():
    error = harmonic_profile(GRID) + bump(GRID)
    first, second = (fit_hybrid(GRID, error, epochs=50, rng=11) for _ in range(2))
    assert first.parameters() == second.parameters()
    assert first.training["seed"] == 11


def test_training_records_the_options_and_both_parts():
    model = fit_hybrid(GRID, harmonic_profile(GRID) + bump(GRID), n_orders=6, hidden=5, epochs=40, rng=2)
    training = model.training
    assert training["options"]["n_orders"] == 6 and training["options"]["hidden"] == 5
    assert training["algorithm"] == "trainlm"
    assert training["fourier"]["orders"] == model.fourier.orders.tolist()
    assert training["ann"]["hidden"] == 5


def test_parameters_follow_the_model_file_layout_and_rebuild_exactly(defect_model):
    model, _ = defect_model
    parameters = model.parameters()
    assert set(parameters) == {"fourier", "ann"}
    assert parameters["fourier"] == model.fourier.parameters()
    assert parameters["ann"] == model.ann.parameters()
    rebuilt = HybridModel.from_parameters(parameters)
    theta = np.linspace(0.0, 360.0, 361)
    assert np.array_equal(rebuilt.predict(theta), model.predict(theta))


def test_save_load_and_the_standalone_runtime_agree(defect_model, tmp_path):
    model, _ = defect_model
    path = model.save(tmp_path / "hybrid.json")
    loaded = encal.load_model(path)
    theta = np.linspace(0.0, 359.5, 720)
    assert loaded.kind == "hybrid"
    assert np.array_equal(loaded.predict(theta), model.predict(theta))
    standalone = runtime.load(str(path))
    np.testing.assert_allclose([standalone.predict_arcmin(t) for t in theta[::37]], model.predict(theta[::37]),
                               rtol=0, atol=1e-9)


def test_fit_with_method_hybrid_passes_the_options():
    cal = encal.Calibration(GRID, GRID + (harmonic_profile(GRID) + bump(GRID)) / 60.0, name="enc")
    model = encal.fit(cal, method="hybrid", rng=5, n_orders=8, hidden=4, epochs=30)
    assert model.kind == "hybrid" and model.fourier.orders.size == 8 and model.ann.hidden == 4
    assert model.training["method"] == "hybrid" and model.training["seed"] == 5


@pytest.mark.parametrize("parameters", [
    {"fourier": {"orders": [1], "cos": [1.0], "sin": [0.0]}},
    [1, 2],
    {"fourier": [], "ann": {}},
])
def test_malformed_parameters_are_a_model_file_error(parameters):
    with pytest.raises(ModelFileError, match="hybrid model parameters"):
        HybridModel.from_parameters(parameters)


def test_a_malformed_part_is_a_model_file_error(defect_model):
    model, _ = defect_model
    parameters = model.parameters()
    del parameters["ann"]["W2"]
    with pytest.raises(ModelFileError, match="ann model parameters"):
        HybridModel.from_parameters(parameters)


@pytest.mark.parametrize("options, message", [
    ({"restarts": 0}, "'restarts' parameter of fit_hybrid"),
    ({"rng": -1}, "'rng' parameter of fit_hybrid must be None, an int >= 0"),
    ({"hidden": 0}, "'hidden' parameter of fit_ann must be an int from 1 to 1000"),
    ({"n_orders": 0}, "n_orders"),
])
def test_bad_options_are_refused(options, message):
    with pytest.raises(InputError, match=message):
        fit_hybrid(GRID, harmonic_profile(GRID), **options)


def test_the_network_part_is_an_ordinary_ann_model(defect_model):
    model, error = defect_model
    residual = error - model.fourier.predict(GRID)
    network = fit_ann(GRID, residual, hidden=8, epochs=300, rng=0)
    # Both fit the residual far better than zero does: the part is a working network.
    assert rms(residual - model.ann.predict(GRID)) < 0.5 * rms(residual)
    assert rms(residual - network.predict(GRID)) < 0.5 * rms(residual)

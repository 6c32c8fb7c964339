"""The 'ann' model: fit_ann, its parameters (docs/model-file.md), periodicity and reproducibility."""

import json
import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

from encal._core.errors import InputError, ModelFileError, TrainingLimitWarning
from encal.models.ann import DEFAULT_HIDDEN, DEFAULT_STOPPING, ANNModel, fit_ann
from encal.models import model_kind
from encal.training import TrainResult, train
from encal.training.network import NetworkProblem

TRAINING_GRID = np.arange(0.0, 360.0, 2.0)
TEST_GRID = TRAINING_GRID + 1.0


def smooth_profile(theta_deg):
    """A noise-free error profile of a few harmonics, arc-minutes."""
    t = np.radians(theta_deg)
    return (3.0 * np.sin(t + 0.3) + 1.5 * np.cos(2 * t) + 0.5 * np.sin(4 * t + 1.0)
            + 0.3 * np.cos(7 * t))


def rms(values):
    return float(np.sqrt(np.mean(np.square(values))))


#: 0.1 arcmin of white measurement noise on the training grid (fixed draw).
NOISE_ARCMIN = np.random.default_rng(2024).normal(0.0, 0.1, TRAINING_GRID.size)


@pytest.fixture(scope="module")
def periodic_model():
    return fit_ann(TRAINING_GRID, smooth_profile(TRAINING_GRID), hidden=12, rng=0)


@pytest.fixture(scope="module")
def raw_model():
    return fit_ann(TRAINING_GRID, smooth_profile(TRAINING_GRID), hidden=10, encoding="raw",
                   activation="logsig", rng=0, epochs=50)


@pytest.mark.parametrize("seed", range(3))
def test_smooth_periodic_profile_is_fitted_between_training_points(seed):
    # A noise-free profile can still be improving at the default 1000 epochs, and then fit_ann says so
    # (TrainingLimitWarning, tested in test_training_frontend.py); this test is about the accuracy reached.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TrainingLimitWarning)
        model = fit_ann(TRAINING_GRID, smooth_profile(TRAINING_GRID), hidden=12, rng=seed)
    assert rms(model.predict(TEST_GRID) - smooth_profile(TEST_GRID)) < 0.01


def test_a_time_limit_stops_fit_ann_with_a_warning():
    with pytest.warns(TrainingLimitWarning, match=r"^Training with trainlm stopped on its time limit of 0 s "
                                                  r"after 0 epochs"):
        model = fit_ann(TRAINING_GRID, smooth_profile(TRAINING_GRID), hidden=4, rng=0, time=0.0)
    assert (model.training["stop_reason"], model.training["epochs"]) == ("time", 0)


def test_default_hidden_depends_on_encoding():
    assert DEFAULT_HIDDEN["raw"] == 80  # the paper's 1:80:1
    model = fit_ann(TRAINING_GRID, smooth_profile(TRAINING_GRID), rng=0, epochs=2)
    assert model.hidden == DEFAULT_HIDDEN["periodic"]


@settings(max_examples=40, deadline=None)
@given(theta=st.floats(-720.0, 720.0), turns=st.integers(-3, 3))
def test_predict_is_periodic(periodic_model, raw_model, theta, turns):
    assert_allclose(periodic_model.predict(theta + 360.0 * turns), periodic_model.predict(theta),
                    rtol=0, atol=1e-9)
    # The raw network jumps at 0/360, where rounding may put θ and θ + 360k on either side.
    if 1e-9 < np.mod(theta, 360.0) < 360.0 - 1e-9:
        assert_allclose(raw_model.predict(theta + 360.0 * turns), raw_model.predict(theta), rtol=0, atol=1e-9)


def test_periodic_encoding_is_continuous_across_zero(periodic_model):
    below, above = periodic_model.predict([360.0 - 1e-9, -1e-9]), periodic_model.predict([0.0, 1e-9])
    assert_allclose(below, above, rtol=0, atol=1e-6)


def test_parameters_have_the_documented_layout_and_formula(periodic_model):
    p = periodic_model.parameters()
    assert set(p) == {"encoding", "activation", "input_offset", "input_gain", "target_offset",
                      "target_gain", "W1", "b1", "W2", "b2"}
    assert (p["encoding"], p["activation"]) == ("periodic", "tansig")
    assert np.shape(p["W1"]) == (12, 2) and len(p["b1"]) == len(p["W2"]) == 12
    # docs/model-file.md, evaluated independently of the package
    theta = np.radians(TEST_GRID)
    u = np.column_stack((np.cos(theta), np.sin(theta)))
    x = np.asarray(p["input_gain"]) * (u - np.asarray(p["input_offset"])) - 1
    y = np.tanh(x @ np.asarray(p["W1"]).T + p["b1"]) @ p["W2"] + p["b2"]
    expected = (y + 1) / p["target_gain"] + p["target_offset"]
    assert_allclose(periodic_model.predict(TEST_GRID), expected, rtol=1e-12, atol=1e-12)


def test_raw_encoding_maps_degrees_with_mapminmax(raw_model):
    p = raw_model.parameters()
    assert p["input_offset"] == [0.0] and p["input_gain"] == [2.0 / 358.0]
    assert np.shape(p["W1"]) == (10, 1)


def test_parameters_survive_json_exactly(periodic_model, raw_model):
    for model in (periodic_model, raw_model):
        copy = model_kind("ann").read(json.loads(json.dumps(model.parameters())))
        assert_array_equal(copy.predict(TEST_GRID), model.predict(TEST_GRID))
        assert copy.parameters() == model.parameters()


def test_save_and_load_round_trip(periodic_model, tmp_path):
    from encal.deploy import load_model

    path = tmp_path / "enc.json"
    periodic_model.save(path)
    loaded = load_model(path)
    assert isinstance(loaded, ANNModel)
    assert_array_equal(loaded.predict(TEST_GRID), periodic_model.predict(TEST_GRID))


def test_training_record(periodic_model):
    t = periodic_model.training
    result = periodic_model.train_result
    assert isinstance(result, TrainResult)
    assert t["method"] == "ann" and t["algorithm"] == "trainlm"
    assert t["epochs"] == result.epochs and t["stop_reason"] == result.reason
    assert (t["seed"], t["hidden"], t["encoding"], t["activation"]) == (0, 12, "periodic", "tansig")
    fitted = periodic_model.predict(TRAINING_GRID)
    assert t["train_mse_arcmin2"] == pytest.approx(np.mean((fitted - smooth_profile(TRAINING_GRID)) ** 2),
                                                    rel=1e-6)
    json.dumps(t)


def test_same_seed_same_model_and_recorded_seed_reproduces():
    error = smooth_profile(TRAINING_GRID)
    first = fit_ann(TRAINING_GRID, error, hidden=5, rng=7, epochs=20)
    assert fit_ann(TRAINING_GRID, error, hidden=5, rng=7, epochs=20).parameters() == first.parameters()
    drawn = fit_ann(TRAINING_GRID, error, hidden=5, epochs=20)
    assert isinstance(drawn.training["seed"], int)
    again = fit_ann(TRAINING_GRID, error, hidden=5, rng=drawn.training["seed"], epochs=20)
    assert again.parameters() == drawn.parameters()
    from_generator = fit_ann(TRAINING_GRID, error, hidden=5, rng=np.random.default_rng(7), epochs=20)
    assert from_generator.training["seed"] is None


def test_trainbr_and_validation_stopping():
    error = smooth_profile(TRAINING_GRID)
    model = fit_ann(TRAINING_GRID, error, hidden=6, algorithm="trainbr", rng=0, epochs=30)
    assert model.training["algorithm"] == "trainbr"
    assert "gamma" in model.train_result.history
    validated = fit_ann(TRAINING_GRID, error, hidden=6, rng=0,
                        validation=(TEST_GRID, smooth_profile(TEST_GRID) + 1.0))
    assert validated.training["stop_reason"] == "max_fail"


# --------------------------------------------------------------------------- default stop

PAPER_RULE = {"plateau_patience": 20, "plateau_tol": 0.01}


def test_default_stop_of_trainlm_is_the_papers_plateau_rule():
    assert DEFAULT_STOPPING == {"trainlm": PAPER_RULE}


@pytest.mark.parametrize("seed", range(4))
def test_default_fit_stops_at_the_first_plateau_on_a_noisy_profile(seed):
    # Known truth plus 0.1' of noise: the training RMS levels off near the noise within a few hundred
    # epochs (measured: 28-112 epochs over seeds 0-5), and the network stopped there is nearer the truth
    # between the training points than the noise (measured 0.057-0.064'), where 1000 epochs give 0.08-0.10'.
    model = fit_ann(TRAINING_GRID, smooth_profile(TRAINING_GRID) + NOISE_ARCMIN, rng=seed)
    t, result = model.training, model.train_result
    assert model.hidden == DEFAULT_HIDDEN["periodic"]
    assert t["stop_reason"] == "plateau" and t["epochs"] < 300
    assert t["options"] == PAPER_RULE
    train_rms = np.sqrt(result.history["mse"])  # epoch 0 first
    k = PAPER_RULE["plateau_patience"]
    holds = train_rms[k:] > train_rms[:-k] * (1.0 - PAPER_RULE["plateau_tol"])
    assert holds[-1] and not holds[:-1].any()  # stopped at the first epoch the rule held
    assert len(train_rms) == t["epochs"] + 1
    assert rms(model.predict(TEST_GRID) - smooth_profile(TEST_GRID)) < 0.075


def test_default_stop_is_deterministic_and_equals_the_explicit_rule():
    error = smooth_profile(TRAINING_GRID) + NOISE_ARCMIN
    default = fit_ann(TRAINING_GRID, error, hidden=12, rng=3)
    assert fit_ann(TRAINING_GRID, error, hidden=12, rng=3).parameters() == default.parameters()
    explicit = fit_ann(TRAINING_GRID, error, hidden=12, rng=3, **PAPER_RULE)
    assert explicit.parameters() == default.parameters()
    assert explicit.training["epochs"] == default.training["epochs"]


@pytest.mark.parametrize(("options", "recorded"), [
    ({"epochs": 150}, {"epochs": 150}),
    ({"plateau_patience": None}, {"plateau_patience": None}),
    ({"goal": 0.0}, {"goal": 0.0}),
    ({"plateau_patience": 5, "plateau_tol": 1.0}, {"plateau_patience": 5, "plateau_tol": 1.0}),
])
def test_any_stopping_parameter_replaces_the_default_stop(options, recorded):
    error = smooth_profile(TRAINING_GRID) + NOISE_ARCMIN
    model = fit_ann(TRAINING_GRID, error, hidden=12, rng=0, **options)
    assert model.training["options"] == recorded
    history = model.train_result.history["mse"]
    if "plateau_patience" in options and options["plateau_patience"] is not None:
        # tol 1: any RMS counts as not falling enough, so the rule holds as soon as 5 epochs have run
        assert model.training["stop_reason"] == "plateau" and model.training["epochs"] == 5
    else:  # MATLAB's rule: no plateau stop (the default stops seed 0 after 63 epochs)
        assert model.training["stop_reason"] in ("epochs", "min_grad")
        assert model.training["epochs"] == options.get("epochs", model.training["epochs"])
        assert len(history) > 100


def test_algorithm_options_alone_keep_the_default_stop():
    error = smooth_profile(TRAINING_GRID) + NOISE_ARCMIN
    model = fit_ann(TRAINING_GRID, error, hidden=12, rng=0, mu=0.01)
    assert model.training["options"] == {**PAPER_RULE, "mu": 0.01}
    assert model.training["stop_reason"] == "plateau"


def test_other_algorithms_keep_matlabs_stopping_rule():
    error = smooth_profile(TRAINING_GRID) + NOISE_ARCMIN
    model = fit_ann(TRAINING_GRID, error, hidden=6, algorithm="trainrp", rng=0)
    assert model.training["options"] == {}
    assert (model.training["stop_reason"], model.training["epochs"]) == ("epochs", 1000)


@pytest.mark.parametrize("seed", range(2))
def test_train_keeps_matlabs_1000_epoch_default(seed):
    # The same problem and initial weights as the default fit_ann, which stops by the plateau rule;
    # encal.training.train itself keeps MATLAB's documented defaults and runs all 1000 epochs.
    error = smooth_profile(TRAINING_GRID) + NOISE_ARCMIN
    hidden = DEFAULT_HIDDEN["periodic"]
    problem = NetworkProblem.from_angles(TRAINING_GRID, error, hidden, encoding="periodic")
    result = train(problem, "trainlm", x0=problem.initial_weights(np.random.default_rng(seed)))
    assert (result.reason, result.epochs) == ("epochs", 1000)
    stopped = fit_ann(TRAINING_GRID, error, rng=seed)
    assert stopped.training["stop_reason"] == "plateau"
    assert_array_equal(stopped.train_result.history["mse"],
                       result.history["mse"][:stopped.training["epochs"] + 1])


def test_constant_profile_gives_a_finite_constant_model():
    model = fit_ann(TRAINING_GRID, np.full(TRAINING_GRID.size, 2.5), hidden=3, rng=0)
    assert np.all(np.isfinite(model.weights))
    assert_allclose(model.predict(TEST_GRID), 2.5, atol=1e-6)


@pytest.mark.parametrize("constant", [0.0, 30.0, -4.25])
@pytest.mark.parametrize("encoding", ["periodic", "raw"])
def test_few_points_of_a_constant_profile_give_that_constant_everywhere(constant, encoding):
    # Trained, a 1:30:1 network met the 8 points and swung by 1.7 arcmin between them.
    theta = np.arange(8) * 45.0
    model = fit_ann(theta, np.full(8, constant), encoding=encoding, rng=0)
    assert_allclose(model.predict(np.linspace(0.0, 360.0, 3601)), constant, rtol=0, atol=1e-12)
    assert model.training["train_mse_arcmin2"] == 0.0


@pytest.mark.parametrize(("options", "message"), [
    ({"hidden": 0}, ("The 'hidden' parameter of fit_ann must be an int from 1 to 1000 (", "Got 0 instead.")),
    ({"hidden": 2.5}, ("The 'hidden' parameter of fit_ann must be an int from 1 to 1000 (", "Got 2.5 instead.")),
    ({"hidden": True}, ("The 'hidden' parameter of fit_ann must be an int from 1 to 1000 (", "Got True instead.")),
    ({"hidden": 10**9}, ("The 'hidden' parameter of fit_ann must be an int from 1 to 1000 (",
                         "Got 1000000000 instead.")),
    ({"epochs": 10**9}, ("The 'epochs' parameter of fit_ann must be an int from 1 to 1000000 (",
                         "Got 1000000000 instead.")),
    ({"encoding": "sincos"},
     "The 'encoding' parameter of fit_ann must be one of 'periodic', 'raw'. Got 'sincos' instead."),
    ({"activation": "relu"},
     "The 'activation' parameter of fit_ann must be one of 'logsig', 'tansig'. Got 'relu' instead."),
    ({"rng": -1}, "The 'rng' parameter of fit_ann must be None, an int >= 0 or a numpy.random.Generator. "
                  "Got -1 instead."),
])
def test_invalid_options_are_rejected_in_one_sentence(options, message):
    with pytest.raises(InputError) as info:
        fit_ann(TRAINING_GRID, smooth_profile(TRAINING_GRID), **options)
    if isinstance(message, tuple):  # a size: its bound, why, and the value
        assert str(info.value).startswith(message[0]) and str(info.value).endswith(message[1])
    else:
        assert str(info.value) == message


def test_invalid_algorithm_and_data_are_rejected():
    with pytest.raises(InputError, match="The 'algorithm' parameter of fit_ann must be one of"):
        fit_ann(TRAINING_GRID, smooth_profile(TRAINING_GRID), algorithm="adam")
    with pytest.raises(InputError, match="one error per encoder angle"):
        fit_ann(TRAINING_GRID, np.zeros(3))
    with pytest.raises(InputError, match="finite"):
        fit_ann(TRAINING_GRID, np.full(TRAINING_GRID.size, math.nan))


def test_malformed_parameters_raise_model_file_error(periodic_model):
    p = periodic_model.parameters()
    del p["b2"]
    with pytest.raises(ModelFileError, match="must be an object with the keys"):
        ANNModel.from_parameters(p)
    p = periodic_model.parameters()
    p["W2"] = p["W2"][:-1]
    with pytest.raises(ModelFileError, match="W2 of a periodic 1:N:1 network"):
        ANNModel.from_parameters(p)

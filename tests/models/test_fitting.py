"""encal.fit and encal.evaluate: dispatch, metadata, and the residual convention."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

import encal
from encal._core.errors import InputError
from encal.models.fitting import calibration_sha256


def _calibration(error_arcmin, step=2.0, offset=0.0, name="enc"):
    ref = np.arange(0.0, 360.0, step) + offset
    return encal.Calibration(ref, ref + error_arcmin(ref) / 60.0, name=name, resolution_bits=16)


def harmonic_profile(ref_deg):
    theta = np.radians(ref_deg)
    return 0.4 + 1.5 * np.sin(theta + 0.3) + 0.7 * np.cos(2 * theta) + 0.3 * np.sin(16 * theta + 1.0)


def test_fit_records_encoder_and_provenance():
    cal = _calibration(harmonic_profile, name="enc7")
    model = encal.fit(cal, method="fourier", orders=[0, 1, 2, 16])
    assert model.encoder == {"name": "enc7", "resolution_bits": 16}
    assert model.training["method"] == "fourier"
    assert model.training["n_points"] == 180
    assert model.training["data_sha256"] == calibration_sha256(cal)
    assert model.training["fit_options"] == {"orders": [0, 1, 2, 16]}


def test_evaluate_residual_is_observed_minus_predicted():
    train = _calibration(harmonic_profile)
    test = _calibration(harmonic_profile, offset=1.0)
    model = encal.fit(train, method="fourier", orders=[0, 1, 2, 16])
    result = encal.evaluate(model, test)
    # The profile is exactly a Fourier series of those orders: the correction is exact on the test grid,
    # where the error depends on the reference angle but the model on the encoder angle.
    assert result.after.rms < 0.05
    assert result.before.rms > 1.0
    assert_allclose(result.residual_arcmin, test.errors_arcmin - model.predict(test.encoder_deg), atol=1e-9)
    as_dict = result.as_dict()
    for key in ("n", "mae_arcmin", "rms_arcmin", "max_abs_arcmin", "min_arcmin", "max_arcmin"):
        assert key in as_dict and key in as_dict["before"]


def test_corrected_angle_error_is_the_residual():
    train = _calibration(harmonic_profile)
    model = encal.fit(train, method="lut", interpolation="cubic")
    test = _calibration(harmonic_profile, offset=1.0)
    corrected = model.correct(test.encoder_deg)
    error = encal.angle_difference(corrected, test.reference_deg) * 60.0
    assert_allclose(error, encal.evaluate(model, test).residual_arcmin, atol=1e-9)


@pytest.mark.parametrize("method, options", [("fourier", {}), ("lut", {}), ("ann", {"hidden": 6, "epochs": 50})])
def test_every_method_lowers_the_error(method, options):
    cal = _calibration(harmonic_profile)
    model = encal.fit(cal, method=method, **options, **({"rng": 0} if method == "ann" else {}))
    result = encal.evaluate(model, _calibration(harmonic_profile, offset=1.0))
    assert result.after.rms < 0.5 * result.before.rms


def test_large_offset_near_180_degrees_is_modelled():
    cal = _calibration(lambda r: 179.5 * 60 + 3.0 * np.sin(np.radians(r)))
    model = encal.fit(cal, method="fourier", orders=[0, 1])
    result = encal.evaluate(model, _calibration(lambda r: 179.5 * 60 + 3.0 * np.sin(np.radians(r)), offset=1))
    assert result.after.max_abs < 0.01


def test_unknown_method_and_wrong_arguments():
    cal = _calibration(harmonic_profile)
    with pytest.raises(InputError, match="The 'method' parameter of fit must be one of fourier, spectral, lut, "
                                         "hybrid, ann, stack, arc, auto. Got 'spline' instead"):
        encal.fit(cal, method="spline")
    # a deterministic method ignores the seed, as scikit-learn's random_state is ignored where unused
    np.testing.assert_array_equal(encal.fit(cal, method="fourier", rng=1).predict(np.arange(360.0)),
                                  encal.fit(cal, method="fourier").predict(np.arange(360.0)))


@pytest.mark.parametrize("call, message", [
    (lambda cal: encal.fit(np.zeros(10), method="fourier"),
     "The 'cal' parameter of fit must be a Calibration. Got an object of type ndarray instead."),
    (lambda cal: encal.fit(cal, method="ann", rng=-1),
     "The 'rng' parameter of fit must be None, an int >= 0 or a numpy.random.Generator. Got -1 instead."),
    (lambda cal: encal.fit(cal, method="fourier", uncertainty="yes"),
     "The 'uncertainty' parameter of fit must be True or False. Got 'yes' instead."),
    (lambda cal: encal.fit(cal, method="fourier", bidirectional="both"),
     "The 'bidirectional' parameter of fit must be one of 'per-direction', 'mean'. Got 'both' instead."),
    (lambda cal: encal.evaluate(encal.fit(cal, method="lut"), [1, 2, 3]),
     "The 'cal' parameter of evaluate must be a Calibration. Got an object of type list instead."),
    (lambda cal: encal.evaluate("model.json", cal),
     "The 'model' parameter of evaluate must be a Model. Got an object of type str instead."),
    (lambda cal: encal.evaluate(encal.fit(cal, method="lut"), cal, zero="none"),
     "The 'zero' parameter of evaluate must be one of 'auto', 'arbitrary', 'fixed'. Got 'none' instead."),
    (lambda cal: encal.error_stats(cal, zero=0),
     "The 'zero' parameter of error_stats must be one of 'auto', 'arbitrary', 'fixed'. Got 0 instead."),
    (lambda cal: encal.fit(cal, method="lut", noise_arcmin=0.1),
     "method 'lut' does not take the option(s) noise_arcmin; it takes: interpolation, max_entries"),
    (lambda cal: encal.fit(cal, method="spectral", noise=0.1),
     "method 'spectral' does not take the option(s) noise; it takes: noise_arcmin, max_order, threshold_nats, "
     "path, progress"),
])
def test_fit_and_evaluate_refuse_bad_parameters_in_one_sentence(call, message):
    with pytest.raises(InputError) as info:
        call(_calibration(harmonic_profile))
    assert str(info.value) == message


def test_ann_fit_defaults_to_the_papers_stop_and_records_it():
    # 0.05' of noise on the profile: the training RMS levels off, and the default trainlm run stops by
    # the paper's plateau rule well before MATLAB's 1000 epochs (measured: 41-97 epochs, seeds 0-5).
    noise = np.random.default_rng(7).normal(0.0, 0.05, 180)
    ref = np.arange(0.0, 360.0, 2.0)
    cal = encal.Calibration(ref, ref + (harmonic_profile(ref) + noise) / 60.0, name="enc")
    model = encal.fit(cal, method="ann", rng=0)
    assert model.training["fit_options"] == {}
    assert model.training["options"] == {"plateau_patience": 20, "plateau_tol": 0.01}
    assert model.training["stop_reason"] == "plateau" and model.training["epochs"] < 1000
    capped = encal.fit(cal, method="ann", rng=0, epochs=1000)
    assert capped.training["options"] == {"epochs": 1000}
    assert capped.training["stop_reason"] != "plateau"


# --------------------------------------------------------------------------- a direction column

REVERSAL_ARCMIN = 0.3


def _bidirectional(step=3.0):
    """Both directions over the same targets: a first harmonic and a 0.3 arcmin reversal (+0.15 forward)."""
    ref = np.tile(np.arange(0.0, 360.0, step), 2)
    direction = np.repeat([1, -1], ref.size // 2)
    error = np.sin(np.radians(ref)) + 0.5 * REVERSAL_ARCMIN * direction
    return encal.Calibration(ref, ref + error / 60.0, direction=direction, name="bi")


def test_fit_keeps_the_reversal_of_a_direction_column_out_of_the_residual():
    cal = _bidirectional()
    model = encal.fit(cal, method="fourier", orders=[0, 1])
    assert model.kind == "directional"
    # The profile is a first harmonic of the reference angle, nearly one of the encoder angle: 1e-6 arcmin.
    assert float(model.predict(90.0, direction=1)) == pytest.approx(1.15, abs=1e-6)
    assert float(model.predict(90.0, direction=-1)) == pytest.approx(0.85, abs=1e-6)
    assert float(model.predict(90.0)) == pytest.approx(1.0, abs=1e-6)
    assert encal.evaluate(model, cal).after.rms < 1e-3                # pooled: 0.15
    # Pooling both directions into one profile leaves half the reversal in every residual.
    pooled = encal.fit(encal.Calibration(cal.reference_deg, cal.encoder_deg), method="fourier", orders=[0, 1])
    assert encal.evaluate(pooled, cal).after.rms == pytest.approx(REVERSAL_ARCMIN / 2, abs=1e-3)
    assert model.training["mean_reversal_value_arcmin"] == pytest.approx(REVERSAL_ARCMIN, abs=1e-12)


def _afresh(tolerance_deg, jitter_deg=1e-3, spacing_deg=10.0):
    """A bidirectional run whose reference is read afresh at every approach (within ``jitter_deg`` of the target),
    a reversal of REVERSAL_ARCMIN at every target, with a target tolerance."""
    rng = np.random.default_rng(0)
    target = np.tile(np.arange(0.0, 360.0, spacing_deg), 2)
    direction = np.repeat([1, -1], target.size // 2)
    ref = target + rng.uniform(-jitter_deg, jitter_deg, target.size)
    error = np.sin(np.radians(target)) + direction * REVERSAL_ARCMIN / 2
    return encal.Calibration(ref, ref + error / 60.0, direction=direction, target_tolerance_deg=tolerance_deg)


def test_a_target_tolerance_that_joins_or_matches_no_target_is_refused_in_the_per_direction_fit_too():
    # fuzz6: the default per-direction fit swallowed the refusal, recorded the tolerance and no reversal, exit 0
    model = encal.fit(_afresh(0.01), method="fourier", orders=[0, 1])
    assert model.training["reversal_value_arcmin"] == pytest.approx(REVERSAL_ARCMIN, abs=1e-4)
    with pytest.raises(encal.CalibrationError, match="span .* as one target"):
        encal.fit(_afresh(10.0), method="fourier", orders=[0, 1])      # every target joined
    with pytest.raises(encal.CalibrationError, match="no reference angle was approached in both directions within"):
        encal.fit(_afresh(1e-6), method="fourier", orders=[0, 1])      # below the reference's scatter
    # without a tolerance the reversal is left out, as before
    afresh = _afresh(0.01)
    untoleranced = encal.Calibration(afresh.reference_deg, afresh.encoder_deg, direction=afresh.direction)
    assert encal.fit(untoleranced, method="fourier", orders=[0, 1]).training["reversal_value_arcmin"] is None


def test_fit_of_the_mean_of_both_directions_on_request():
    model = encal.fit(_bidirectional(), method="fourier", orders=[0, 1], bidirectional="mean")
    assert model.kind == "fourier" and model.training["bidirectional"] == "mean"
    assert float(model.predict(90.0)) == pytest.approx(1.0, abs=1e-6)


def test_the_bidirectional_option_needs_both_directions():
    with pytest.raises(InputError, match=r"^The 'bidirectional' parameter of fit applies to a calibration with "
                                         r"both directions of travel in its direction column\. Got 'mean' for "
                                         r"enc, which has one direction\.$"):
        encal.fit(_calibration(lambda ref: np.sin(np.radians(ref))), method="lut", bidirectional="mean")


def test_a_progress_callback_is_not_recorded_and_the_model_saves(tmp_path):
    calls = []
    model = encal.fit(_calibration(harmonic_profile), method="spectral", progress=lambda: calls.append(1))
    assert len(calls) == 3 and "progress" not in model.training["fit_options"]
    assert encal.load_model(model.save(tmp_path / "m.json")).kind == "spectral"

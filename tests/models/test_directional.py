"""Bidirectional calibrations: ISO 230-2 reversal analysis, per-direction and mean models."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

import encal
from encal import Calibration, CalibrationError, InputError
from encal.data.reversal import mean_calibration, reversal
from encal.models.fitting import fit_bidirectional
from encal.models.directional import DirectionalModel
from encal.models.fourier import FourierModel
from encal.models.uncertainty import add_uncertainty, coverage

REVERSAL = 0.4  # arcmin: forward readings exceed reverse ones by this much
ORDERS = [0, 1, 2, 3]


def profile(theta_deg):
    """Mean error of both directions, arcmin, a Fourier series of orders 1..3."""
    r = np.radians(theta_deg)
    return 1.5 * np.sin(r) + 0.6 * np.cos(2 * r) - 0.3 * np.sin(3 * r + 1.0)


def bidirectional(grid_deg, rng=None, noise=0.0, reversal_arcmin=REVERSAL):
    """A forward and a reverse pass over the target angles ``grid_deg``, errors in arcmin."""
    rng = np.random.default_rng(rng)
    reference = np.concatenate([grid_deg, grid_deg[::-1]])
    direction = np.repeat([1, -1], grid_deg.size)
    error = profile(reference) + direction * reversal_arcmin / 2 + rng.normal(0.0, noise, reference.size)
    return Calibration(reference, reference + error / 60.0, direction=direction, resolution_bits=16)


#: Models are functions of the encoder angle, which differs from the reference by the error (a few
#: arcmin): a profile given at reference angles is recovered to its slope times that, below 0.005 arcmin.
SHIFT_ATOL = 0.005


def on_reference_grid(grid_deg, forward_arcmin, reverse_arcmin, **kwargs):
    reference = np.concatenate([grid_deg, grid_deg])
    error = np.concatenate([forward_arcmin, reverse_arcmin])
    direction = np.repeat([1, -1], grid_deg.size)
    return Calibration(reference, reference + error / 60.0, direction=direction, **kwargs)


GRID = np.arange(0.0, 360.0, 10.0)


# ---------------------------------------------------------------- ISO 230-2 values


def test_reversal_values_follow_iso_230_2():
    forward = np.sin(np.radians(GRID)) + 0.3
    reverse = np.sin(np.radians(GRID)) - 0.1 + 0.05 * np.cos(np.radians(GRID))
    analysis = reversal(on_reference_grid(GRID, forward, reverse))
    b = forward - reverse
    assert_allclose(analysis.target_deg, GRID)
    assert_allclose(analysis.reversal_arcmin, b, atol=1e-9)
    assert analysis.mean_reversal_value == pytest.approx(b.mean(), abs=1e-9)
    assert analysis.reversal_value == pytest.approx(np.abs(b).max(), abs=1e-9)
    assert analysis.systematic_deviation_forward == pytest.approx(np.ptp(forward), abs=1e-9)
    assert analysis.systematic_deviation_reverse == pytest.approx(np.ptp(reverse), abs=1e-9)
    both = np.concatenate([forward, reverse])
    assert analysis.systematic_deviation == pytest.approx(both.max() - both.min(), abs=1e-9)
    assert analysis.mean_bidirectional_deviation == pytest.approx(np.ptp((forward + reverse) / 2), abs=1e-9)
    assert analysis.repeatability is None and analysis.accuracy is None


def test_a_known_reversal_value_is_recovered_from_noisy_readings():
    grid = np.arange(0.0, 360.0, 2.0)
    analysis = reversal(bidirectional(grid, rng=0, noise=0.15))
    # B_i = x_up - x_down has noise 0.15 * sqrt(2); its mean over 180 targets has 0.016 standard error.
    assert analysis.mean_reversal_value == pytest.approx(REVERSAL, abs=0.06)
    assert analysis.as_dict()["mean_reversal_value_lsb"] == pytest.approx(REVERSAL / encal.lsb_arcmin(16),
                                                                           abs=0.2)


def test_repeatability_and_accuracy_with_repeated_approaches():
    forward = [np.sin(np.radians(GRID)) + d for d in (0.2, 0.4, 0.3)]
    reverse = [np.sin(np.radians(GRID)) + d for d in (-0.1, 0.1, 0.0)]
    cals = [on_reference_grid(GRID, f, r) for f, r in zip(forward, reverse)]
    cal = Calibration(np.concatenate([c.reference_deg for c in cals]),
                      np.concatenate([c.encoder_deg for c in cals]),
                      direction=np.concatenate([c.direction for c in cals]))
    analysis = reversal(cal)
    assert_array_equal(analysis.n_forward, 3)
    s = 0.1  # sample standard deviation of (0.2, 0.4, 0.3) and of (-0.1, 0.1, 0.0)
    assert_allclose(analysis.std_forward_arcmin, s, atol=1e-9)
    assert analysis.mean_reversal_value == pytest.approx(0.3, abs=1e-9)
    assert analysis.repeatability == pytest.approx(max(2 * s + 2 * s + 0.3, 4 * s), abs=1e-9)
    mean_up, mean_down = np.sin(np.radians(GRID)) + 0.3, np.sin(np.radians(GRID))
    high = max((mean_up + 2 * s).max(), (mean_down + 2 * s).max())
    low = min((mean_up - 2 * s).min(), (mean_down - 2 * s).min())
    assert analysis.accuracy == pytest.approx(high - low, abs=1e-9)


def test_targets_of_one_direction_only_are_counted_and_left_out():
    cal = on_reference_grid(GRID, np.zeros(GRID.size), np.zeros(GRID.size))
    keep = ~((cal.direction == -1) & (cal.reference_deg == 50.0))
    analysis = reversal(cal.subset(keep))
    assert analysis.target_deg.size == GRID.size - 1
    assert analysis.n_unmatched == 1


def test_mean_calibration_is_the_mean_of_both_directions():
    forward, reverse = np.full(GRID.size, 0.5), np.full(GRID.size, -0.1)
    mean = mean_calibration(on_reference_grid(GRID, forward, reverse, name="enc9"))
    assert mean.direction is None and mean.name == "enc9"
    assert_allclose(mean.errors_arcmin, 0.2, atol=1e-9)


@pytest.mark.parametrize("direction, match", [
    (None, "direction column"),
    (np.ones(GRID.size * 2), "at least 8 points in each direction"),
])
def test_a_calibration_without_both_directions_is_refused(direction, match):
    reference = np.concatenate([GRID, GRID])
    with pytest.raises(CalibrationError, match=match):
        reversal(Calibration(reference, reference, direction=direction))


def test_no_common_target_is_refused():
    reference = np.concatenate([GRID, GRID + 5.0])
    cal = Calibration(reference, reference, direction=np.repeat([1, -1], GRID.size))
    with pytest.raises(CalibrationError, match="both directions"):
        reversal(cal)


def test_simulated_converter_hysteresis_is_about_one_lsb():
    from encal.simulate import TRAINING_GRID_DEG, calibration_run, draw_encoder

    grid = TRAINING_GRID_DEG
    # Forward over the grid, one degree past the end, then back: every point is approached from its side.
    run = calibration_run(draw_encoder(np.random.default_rng(11), name="enc"),
                          np.concatenate([grid, [grid[-1] + 1.0], grid[::-1]]), rng=1)
    keep = np.arange(run.calibration.reference_deg.size) != grid.size
    direction = np.concatenate([np.ones(grid.size), [1.0], -np.ones(grid.size)])[keep]
    cal = Calibration(run.calibration.reference_deg[keep], run.calibration.encoder_deg[keep],
                      direction=direction, resolution_bits=16)
    # The register truncates towards where the shaft came from: forward reads about 1 LSB low.
    assert reversal(cal).as_dict()["mean_reversal_value_lsb"] == pytest.approx(-1.0, abs=0.25)


# ---------------------------------------------------------------- models


def test_per_direction_models_recover_each_direction():
    grid = np.arange(0.0, 360.0, 3.0)
    model = fit_bidirectional(bidirectional(grid), method="fourier", orders=ORDERS)
    assert isinstance(model, DirectionalModel) and model.kind == "directional"
    theta = np.linspace(0.0, 360.0, 97)
    assert_allclose(model.predict(theta, direction=1), profile(theta) + REVERSAL / 2, atol=SHIFT_ATOL)
    assert_allclose(model.predict(theta, direction=-1), profile(theta) - REVERSAL / 2, atol=SHIFT_ATOL)
    assert_allclose(model.predict(theta), profile(theta), atol=SHIFT_ATOL)
    mixed = np.where(np.arange(theta.size) % 2, 1, -1)
    assert_allclose(model.predict(theta, direction=mixed), profile(theta) + mixed * REVERSAL / 2,
                    atol=SHIFT_ATOL)
    assert_allclose(model.predict(theta, direction=mixed),
                    np.where(mixed > 0, model.forward.predict(theta), model.reverse.predict(theta)))
    assert model.training["bidirectional"] == "per-direction"
    assert model.training["mean_reversal_value_arcmin"] == pytest.approx(REVERSAL, abs=0.01)


def test_correct_uses_the_direction():
    model = fit_bidirectional(bidirectional(np.arange(0.0, 360.0, 3.0)), method="fourier", orders=ORDERS)
    theta = np.array([10.0, 200.0])
    expected = theta - (profile(theta) + REVERSAL / 2) / 60.0
    assert_allclose(model.correct(theta, direction=1), expected, atol=SHIFT_ATOL / 60)
    assert_allclose(model.correct(theta, direction=1), theta - model.forward.predict(theta) / 60.0, atol=1e-12)
    assert_allclose(model.correct(theta), theta - profile(theta) / 60.0, atol=SHIFT_ATOL / 60)


def test_mean_mode_gives_a_plain_model_of_the_mean():
    model = fit_bidirectional(bidirectional(np.arange(0.0, 360.0, 3.0)), mode="mean", method="fourier",
                              orders=ORDERS)
    assert model.kind == "fourier" and model.training["bidirectional"] == "mean"
    theta = np.linspace(0.0, 360.0, 50)
    assert_allclose(model.predict(theta), profile(theta), atol=SHIFT_ATOL)


@pytest.mark.parametrize("direction", [0, 2, "cw", [1, -1, 1]])
def test_bad_directions_are_refused(direction):
    model = DirectionalModel(FourierModel([0], [1.0], [0.0]), FourierModel([0], [-1.0], [0.0]))
    with pytest.raises(InputError, match="direction"):
        model.predict([1.0, 2.0], direction=direction)


def test_bad_mode_is_refused():
    with pytest.raises(InputError, match="mode"):
        fit_bidirectional(bidirectional(GRID), mode="both", method="fourier")


def test_parts_must_be_one_direction_models():
    part = FourierModel([0], [1.0], [0.0])
    with pytest.raises(InputError, match="one-direction"):
        DirectionalModel(DirectionalModel(part, part), part)


@settings(max_examples=30, deadline=None)
@given(st.floats(-720.0, 720.0), st.sampled_from([None, 1, -1]))
def test_directional_model_is_periodic(theta, direction):
    model = fit_bidirectional(bidirectional(np.arange(0.0, 360.0, 10.0)), method="fourier", orders=ORDERS)
    assert_allclose(model.predict(theta + 360.0, direction=direction), model.predict(theta, direction=direction),
                    atol=1e-9)


def test_parameters_round_trip_with_uncertainty():
    cal = bidirectional(np.arange(0.0, 360.0, 4.0), rng=2, noise=0.1)
    model = add_uncertainty(fit_bidirectional(cal, method="lut"), cal, rng=0)
    parameters = model.parameters()
    assert set(parameters) == {"forward", "reverse"}
    assert parameters["forward"]["kind"] == "lut" and "uncertainty" in parameters["reverse"]
    rebuilt = DirectionalModel.from_parameters(parameters)
    theta = np.linspace(0.0, 359.0, 41)
    for direction in (None, 1, -1):
        assert_allclose(rebuilt.predict(theta, return_std=True, direction=direction),
                        model.predict(theta, return_std=True, direction=direction))


# ---------------------------------------------------------------- uncertainty


def test_unknown_direction_adds_half_the_reversal():
    cal = bidirectional(np.arange(0.0, 360.0, 2.0), rng=3, noise=0.1)
    model = add_uncertainty(fit_bidirectional(cal, method="fourier", orders=ORDERS), cal,
                            options={"orders": ORDERS}, rng=0)
    theta = np.linspace(0.0, 359.0, 30)
    _, forward = model.predict(theta, return_std=True, direction=1)
    _, reverse = model.predict(theta, return_std=True, direction=-1)
    _, unknown = model.predict(theta, return_std=True)
    half_reversal = (model.forward.predict(theta) - model.reverse.predict(theta)) / 2
    assert_allclose(unknown, np.sqrt((forward**2 + reverse**2) / 2 + half_reversal**2), rtol=1e-12)
    assert_allclose(unknown, np.sqrt((forward**2 + reverse**2) / 2 + (REVERSAL / 2) ** 2), rtol=0.15)


def coverage_of_fresh_bidirectional_readings(seed):
    """The ±2σ share of fresh bidirectional residuals (1:2:359) of a fit on 0:2:358 (noise 0.15 arcmin), per mode,
    and the per-direction model's mean reversal value; benchmarks/bench_uncertainty.py --known-noise runs 120."""
    rng = np.random.default_rng(seed)
    train = bidirectional(np.arange(0.0, 360.0, 2.0), rng=rng, noise=0.15)
    test = bidirectional(np.arange(1.0, 360.0, 2.0), rng=rng, noise=0.15)
    shares, reversal_arcmin = {}, None
    for mode in ("per-direction", "mean"):
        model = fit_bidirectional(train, mode=mode, method="fourier", orders=ORDERS)
        shares[mode] = coverage(add_uncertainty(model, train, rng=seed), test)
        if mode == "per-direction":
            reversal_arcmin = model.training["mean_reversal_value_arcmin"]
    return shares, reversal_arcmin


def test_coverage_on_fresh_bidirectional_readings():
    shares = {"per-direction": [], "mean": []}
    for seed in range(6):
        for mode, share in coverage_of_fresh_bidirectional_readings(seed)[0].items():
            shares[mode].append(share)
    # per direction: 95 % nominal; mean: the unknown direction's +-B/2 makes the residual two-valued,
    # not Gaussian, so two sigma covers more than 95 %.
    assert 0.92 <= np.mean(shares["per-direction"]) <= 0.98
    assert 0.93 <= np.mean(shares["mean"]) <= 1.0


def test_mean_model_uncertainty_includes_the_half_reversal():
    cal = bidirectional(np.arange(0.0, 360.0, 2.0), rng=4, noise=0.05)
    model = add_uncertainty(fit_bidirectional(cal, mode="mean", method="fourier", orders=ORDERS), cal, rng=0)
    assert model.uncertainty["half_reversal_rms_arcmin"] == pytest.approx(REVERSAL / 2, rel=0.1)
    assert model.uncertainty["noise_std_arcmin"] >= REVERSAL / 2


def test_directional_uncertainty_needs_a_bidirectional_calibration():
    cal = bidirectional(np.arange(0.0, 360.0, 4.0))
    model = fit_bidirectional(cal, method="lut")
    one_way = Calibration(cal.reference_deg, cal.encoder_deg)
    with pytest.raises(CalibrationError, match="direction column"):
        add_uncertainty(model, one_way)


def test_directional_model_survives_save_and_load(tmp_path):
    cal = bidirectional(np.arange(0.0, 360.0, 4.0), rng=5, noise=0.1)
    model = add_uncertainty(fit_bidirectional(cal, method="fourier", orders=ORDERS), cal, rng=0)
    loaded = encal.load_model(model.save(tmp_path / "enc.json"))
    assert loaded.kind == "directional"
    theta = np.linspace(0.0, 359.0, 41)
    for direction in (None, 1, -1):
        assert_allclose(loaded.predict(theta, return_std=True, direction=direction),
                        model.predict(theta, return_std=True, direction=direction), rtol=1e-12)


# ---------------------------------------------------------------- the spectral model's posterior


def test_auto_keeps_each_directions_posterior_with_uncertainty_true():
    # encal.fit(..., uncertainty=True) on a bidirectional calibration used to stop with StopIteration:
    # the evidence scheme's selection has no table row to refit from.
    cal = bidirectional(np.arange(0.0, 360.0, 2.0), rng=6, noise=0.1)
    model = encal.fit(cal, uncertainty=True, rng=0)
    for part in (model.forward, model.reverse):
        assert part.uncertainty["method"] == "posterior"
        assert part.uncertainty["noise_std_arcmin"] == pytest.approx(0.1, rel=0.35)


def test_spectral_mean_model_adds_the_half_reversal_once():
    cal = bidirectional(np.arange(0.0, 360.0, 2.0), rng=7, noise=0.1)
    model = encal.fit(cal, bidirectional="mean")
    posterior_noise = encal.fit(mean_calibration(cal)).uncertainty["noise_std_arcmin"]
    half = model.uncertainty["half_reversal_rms_arcmin"]
    assert model.uncertainty["method"] == "posterior"
    assert half == pytest.approx(REVERSAL / 2, rel=0.1)
    assert model.uncertainty["noise_std_arcmin"] == pytest.approx(np.hypot(posterior_noise, half), rel=1e-12)
    again = add_uncertainty(model, cal, rng=0)
    assert again.uncertainty["noise_std_arcmin"] == pytest.approx(np.hypot(posterior_noise, half), rel=1e-12)
    assert encal.fit(cal, bidirectional="mean", uncertainty=True, rng=0).uncertainty == model.uncertainty


# ---------------------------------------------------------------- one direction through fit (issue 29)


@pytest.mark.parametrize("mode, splitter, splits", [("per-direction", "direction_subset", 2),
                                                     ("mean", "mean_calibration", 1)])
def test_fit_splits_a_calibration_once_and_estimates_each_part_on_its_own_points(monkeypatch, mode, splitter,
                                                                                 splits):
    import encal.data.reversal as reversal_module
    import encal.models.fitting as fitting_module
    import encal.models.uncertainty as uncertainty_module

    calls = []
    original = getattr(reversal_module, splitter)

    def counted(*args, **kwargs):
        calls.append(splitter)
        return original(*args, **kwargs)

    for module in (fitting_module, uncertainty_module):
        monkeypatch.setattr(module, splitter, counted)
    cal = bidirectional(np.arange(0.0, 360.0, 4.0), rng=5, noise=0.1)
    model = encal.fit(cal, method="fourier", orders=ORDERS, bidirectional=mode, uncertainty=True, rng=0)
    assert len(calls) == splits  # was twice as many: fit split it, then add_uncertainty split it again
    # the same numbers as the fit followed by add_uncertainty of the same seed, which splits again
    monkeypatch.undo()
    again = add_uncertainty(fit_bidirectional(cal, mode, method="fourier", orders=ORDERS, rng=0), cal,
                            options={"orders": ORDERS}, rng=0)
    theta = np.linspace(0.0, 359.0, 37)
    for direction in (None, 1, -1):
        assert_array_equal(model.predict(theta, return_std=True, direction=direction),
                           again.predict(theta, return_std=True, direction=direction))

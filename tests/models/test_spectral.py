"""The empirical-Bayes spectral model: known-truth recovery, noise supplied or blind, both paths, deployment."""

import math

import numpy as np
import pytest

import encal
from encal.deploy import runtime
from encal._core.errors import InputError
from encal.models import _evidence
from encal.models import spectral
from encal.numerics.trigsums import trig_moments, trig_series
from encal.models.spectral import (
    BLIND_PRIOR,
    SpectralModel,
    _columns,
    _fft_design,
    _general_design,
    _alias_coherence,
    _uniform_nodes,
    fit_spectral,
    repeat_noise,
)

GRID = np.arange(0.0, 360.0, 2.0)
MIDPOINTS = GRID + 1.0
LINES = {1: (3.0, 0.4), 3: (0.8, -1.1), 16: (0.5, 0.2), 40: (0.3, 2.0)}  # order: (amplitude arcmin, phase rad)


def line_profile(theta_deg, lines=LINES):
    r = np.radians(theta_deg)
    return sum(a * np.cos(k * r + p) for k, (a, p) in lines.items())


def rms(values):
    return float(np.sqrt(np.mean(np.square(values))))


# -- trigonometric sums -------------------------------------------------------------------------

@pytest.mark.parametrize("n, highest", [(50, 7), (30_000, 300), (100_000, 60), (5_000, 1200)])
def test_trigonometric_sums_match_direct_evaluation(n, highest):
    """Direct sums; the NUFFT's moments in one block of angles, in several (100,000), and term by term (a fine grid
    too large to bin every term at once, order 1200)."""
    rng = np.random.default_rng(n)
    theta = rng.uniform(-10.0, 10.0, n)
    weights = rng.normal(size=n)
    direct = np.exp(1j * np.outer(np.arange(highest + 1), theta)) @ weights
    assert np.abs(trig_moments(theta, weights, highest) - direct).max() <= 1e-12 * np.abs(direct).max()
    c = rng.normal(size=highest + 1) + 1j * rng.normal(size=highest + 1)
    series = np.real(np.exp(1j * np.outer(theta, np.arange(highest + 1))) @ c)
    assert np.abs(trig_series(c, theta) - series).max() <= 1e-12 * np.abs(series).max()


# -- known truth ----------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(5))
def test_a_pure_line_spectrum_is_recovered(seed):
    rng = np.random.default_rng(seed)
    error = line_profile(GRID) + rng.normal(0.0, 0.05, GRID.size)
    model = fit_spectral(GRID, error)
    assert model.training["lines"] == sorted(LINES)
    assert model.training["path"] == "fft"
    noise = model.training["noise"]
    assert abs(noise["std_arcmin"] - 0.05) < 0.012  # the flat level: here all of it noise
    assert noise["split"]["floor_arcmin"] <= noise["split"]["mean_noise_std_arcmin"] < noise["std_arcmin"]
    # Only the 4 lines' 8 coefficients carry the truth; noise at 180 points leaves about 0.05 * sqrt(8/180)
    # when the noise is known. Blind, the split keeps on average a third of the noise power in the other
    # orders (a flat profile would look the same): 0.05 * sqrt(1/3) at most.
    assert rms(model.predict(MIDPOINTS) - line_profile(MIDPOINTS)) < 0.05 * math.sqrt(1 / 3)
    known = fit_spectral(GRID, error, noise_arcmin=0.05)
    assert rms(known.predict(MIDPOINTS) - line_profile(MIDPOINTS)) < 0.02


def test_a_noise_free_line_spectrum_is_recovered_closely():
    model = fit_spectral(GRID, line_profile(GRID))
    assert {16, 40} <= set(model.training["lines"])  # orders 1 and 3 may sit in the background instead
    assert rms(model.predict(MIDPOINTS) - line_profile(MIDPOINTS)) < 1e-5


def test_fft_and_fourier_feature_paths_agree():
    rng = np.random.default_rng(3)
    error = line_profile(GRID) + 0.1 * rng.normal(size=GRID.size) + 0.05 * np.cos(np.radians(77 * GRID))
    theta = np.radians(GRID)
    orders, shifts, lineable = _columns(90, 180, 0.0)
    fft = _fft_design(error, _uniform_nodes(GRID), orders, shifts, lineable)
    general = _general_design(theta, error, orders, shifts, lineable)
    hyper = _evidence.Hyper(0.01, 1.7, 0.012, {1: 4.0, 16: 0.1}, False)
    a = _evidence.evidence(fft, hyper.variances(fft), hyper.noise_var)
    b = _evidence.evidence(general, hyper.variances(general), hyper.noise_var)
    assert a.log_evidence == pytest.approx(b.log_evidence, rel=1e-12, abs=1e-9)
    np.testing.assert_allclose(a.mean, b.mean, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.grad_log_variance, b.grad_log_variance, rtol=0, atol=1e-9)
    assert a.grad_log_noise == pytest.approx(b.grad_log_noise, abs=1e-9)
    # With a rounding variance per column (issue 27) the profile's part agrees too: exact on both paths.
    fft.rounding = general.rounding = np.where(np.isin(orders, [28, 60]), 0.02, 0.0)
    a, b = (_evidence.signal_part(d, hyper.variances(d), hyper.noise_var,
                                  _evidence.evidence(d, hyper.variances(d), hyper.noise_var)) for d in (fft, general))
    np.testing.assert_allclose(a.mean, b.mean, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.covariance, np.diag(b.covariance), rtol=0, atol=1e-9)
    whole = _evidence.evidence(fft, hyper.variances(fft), hyper.noise_var)
    rounded = np.isin(orders, [28, 60])
    assert np.all(np.abs(a.mean[rounded]) < np.abs(whole.mean[rounded]))  # the rounding's share left out
    np.testing.assert_array_equal(a.mean[~rounded], whole.mean[~rounded])
    fft.rounding = general.rounding = None
    # The whole fit, hyperparameter search and line admission included: the two paths' rounding
    # differs by 1e-13, the optimiser stops within its tolerance, so the fits agree to about 1e-8.
    by_fft = fit_spectral(GRID, error, path="fft")
    by_features = fit_spectral(GRID, error, path="features")
    assert by_fft.training["path"] == "fft" and by_features.training["path"] == "fourier-features"
    assert by_fft.training["lines"] == by_features.training["lines"]
    angles = np.linspace(0.0, 360.0, 1001)
    np.testing.assert_allclose(by_fft.predict(angles), by_features.predict(angles), rtol=0, atol=1e-7)
    np.testing.assert_allclose(by_fft.predict(angles, return_std=True)[1],
                               by_features.predict(angles, return_std=True)[1], rtol=0, atol=1e-7)


def test_the_nyquist_order_the_grid_cannot_see_counts_in_the_uncertainty():
    # A pattern of order 90 on 180 stops at 1, 3, 5 ... degrees: its cosine is the alternation at the
    # nodes (estimated, left out of the correction), its sine is zero at every node and ±0.4 at the
    # midpoints, where a new reading meets it. The uncertainty holds both: the left-out cosine at the
    # nodes, the sine's prior (the column's line) between them. It used to say 0.02 arcmin there.
    theta = GRID + 1.0
    phase = np.radians(90.0 * (theta - 1.0))
    rng = np.random.default_rng(4)
    error = line_profile(theta) + 0.5 * np.cos(phase) + rng.normal(0.0, 0.02, GRID.size)
    model = fit_spectral(theta, error)
    _, at_nodes = model.predict(theta, return_std=True, include_noise=False)
    midpoints = theta + 1.0
    _, between = model.predict(midpoints, return_std=True, include_noise=False)
    assert np.all((at_nodes > 0.49) & (at_nodes < 0.53))
    assert np.all((between > 0.4) & (between < 0.7))
    fresh = line_profile(midpoints) + 0.4 * np.sin(np.radians(90.0 * (midpoints - 1.0)))
    mean, std = model.predict(midpoints, return_std=True)
    assert np.all(np.abs(fresh - mean) <= 2.0 * std)


def test_the_nyquist_term_is_estimated_but_left_out_of_the_correction():
    # A step alternation (-1)^j at the nodes of a grid starting at 1 degree (a stepper's alternate full
    # steps): only cos(90 (θ - 1°)) can hold it, and between the nodes its value is unknown. It gets a
    # line of its own, so it is not counted as noise, and the correction leaves it out.
    theta = GRID + 1.0
    alternation = 0.5 * (-1.0) ** np.arange(GRID.size)
    rng = np.random.default_rng(3)
    error = line_profile(theta) + alternation + rng.normal(0.0, 0.02, GRID.size)
    model = fit_spectral(theta, error)
    assert 90 in model.training["lines"]
    assert model.training["nyquist_term_arcmin"] == pytest.approx(0.5, abs=0.01)
    assert model.training["noise"]["std_arcmin"] < 0.03  # not the 0.5 of the alternation
    k = list(model.orders).index(90)
    assert model.cos[k] == 0.0 and model.sin[k] == 0.0
    assert "Nyquist order 90 (the alternation from one stop to the next): amplitude 0.5" in model.report()
    assert "left out of the correction" in model.report()
    # Between the nodes the model is the profile, whose alternation a new reading does not share.
    assert rms(model.predict(theta + 1.0) - line_profile(theta + 1.0)) < 0.02
    assert SpectralModel([90], [0.0], [0.0]).predict(theta).max() == 0.0


CODE_12_BIT_DEG = 360.0 / 4096


def small_profile(theta_deg, scale=1.0):
    r = np.radians(theta_deg)
    return scale * (1.2 * np.cos(r + 0.3) + 0.4 * np.sin(2 * r) + 0.15 * np.cos(16 * r + 1.0))


def read_12_bit(reference_deg, seed, scale=1.0):
    """Readings of a 12-bit encoder (5.27 arcmin codes) with 0.05 arcmin of noise before the rounding."""
    rng = np.random.default_rng(seed)
    exact = reference_deg + (small_profile(reference_deg, scale) + rng.normal(0.0, 0.05, reference_deg.size)) / 60.0
    reading = np.round(exact / CODE_12_BIT_DEG) * CODE_12_BIT_DEG
    return reading, (reading - reference_deg) * 60.0


@pytest.mark.parametrize("seed", range(3))
def test_the_rounding_of_a_coarse_encoder_on_a_grid_gets_no_line(seed, monkeypatch):
    # A profile of 1.5 codes read at 2-degree steps: the rounding error is a sawtooth advancing
    # 4096 / 180 = 22.76 codes per stop, so at the stops it is a pattern of order 4096 mod 180 = 136,
    # folded to 44 (and 88, 48 for its harmonics), with another phase at the midpoints.
    theta, error = read_12_bit(GRID, seed)
    model = fit_spectral(theta, error)
    assert model.training["rounding_orders"] == [*range(42, 51), *range(86, 91)]
    assert not set(model.training["lines"]) & set(model.training["rounding_orders"])
    assert "orders 42-50, 86-90: no line (where the rounding of the readings to whole codes lands" in model.report()
    # Near what the three real orders' noise leaves (rounding noise 1.52 arcmin over 180 points, 6
    # coefficients: 0.28); with lines allowed there, the fit follows the stops' rounding pattern.
    assert rms(model.predict(MIDPOINTS) - small_profile(MIDPOINTS)) < 0.4
    monkeypatch.setattr(spectral, "COHERENT_SWING_CODES", 0.0)
    # The rounding's expected power per order (issue 27) also keeps the lines away on its own ...
    alone = fit_spectral(theta, error)
    assert alone.training["rounding_orders"] == []
    assert not set(alone.training["lines"]) & set(range(42, 51))
    # ... and without either, the fit follows the stops' rounding pattern.
    monkeypatch.setattr(spectral, "ROUNDING_SPECTRUM", False)
    following = fit_spectral(theta, error)
    assert following.training["rounding_orders"] == []
    assert {43, 44, 45} <= set(following.training["lines"])
    assert rms(following.predict(MIDPOINTS) - small_profile(MIDPOINTS)) > 0.8


def read_12_bit_modulated(seed):
    """A 12-bit encoder whose profile has a 1.6 arcmin order 16: the rounding's pattern (order 44 at
    2-degree stops) is phase-modulated by it, with sidebands at 44 ± 16 and 44 ± 32 (issue 27)."""
    rng = np.random.default_rng(seed)
    reading = np.round((GRID + (modulated_profile(GRID) + rng.normal(0.0, 0.15, GRID.size)) / 60.0)
                       / CODE_12_BIT_DEG) * CODE_12_BIT_DEG
    return reading, (reading - GRID) * 60.0


def modulated_profile(theta_deg):
    r = np.radians(theta_deg)
    return 1.2 * np.cos(r + 0.3) + 0.4 * np.sin(2 * r) + 1.6 * np.cos(16 * r + 1.0)


def test_the_sidebands_of_the_rounding_pattern_get_no_line(monkeypatch):
    def false_lines_and_error():
        count, errors, true_line = 0, [], True
        for seed in range(8):
            model = fit_spectral(*read_12_bit_modulated(seed))
            count += len(set(model.training["lines"]) - {1, 2, 16})
            true_line &= 16 in model.training["lines"]
            errors.append(rms(model.predict(MIDPOINTS) - modulated_profile(MIDPOINTS)))
        return count, max(errors), true_line

    # measured: with the realised pattern 0 false lines over the 8 encoders and the true order 16
    # (where the third harmonic's carrier 48 has a sideband, 48 - 2 x 16) on all 8, profile error at
    # the midpoints at most 0.243 arcmin; with the expected pattern alone 7 and 0.514; with neither 32
    assert false_lines_and_error() == (0, pytest.approx(0.243, abs=0.03), True)
    model = fit_spectral(*read_12_bit_modulated(7))
    assert model.training["rounding_lines"] == [12, 28, 30]  # measured: the first fit's false lines
    assert "orders 12, 28, 30: taken as the rounding's pattern" in model.report()
    monkeypatch.setattr(spectral, "REALISED_ROUNDING", False)
    expected_only, worst, _ = false_lines_and_error()
    assert 3 <= expected_only <= 10 and worst > 0.4
    monkeypatch.setattr(spectral, "ROUNDING_SPECTRUM", False)
    assert false_lines_and_error()[0] >= 20


@pytest.mark.parametrize("ratio, shows_codes, start", [
    # blind, a resolution declared that the readings do not show: smoother than whole codes (a self-calibration)
    (0.001, False, "below the quantisation: these readings vary less than whole codes would make them"),
    (0.85, False, "consistent with the encoder's quantisation alone"),
    # readings in whole codes: a smooth profile's rounding over a few codes left a flat level of 0.80 of it
    (0.80, True, "consistent with the encoder's quantisation alone"),
])
def test_a_blind_noise_below_the_quantisation_says_whether_the_readings_are_whole_codes(ratio, shows_codes, start):
    assert spectral._noise_meaning(ratio, "blind", shows_codes).startswith(start)


def test_fit_of_a_self_calibration_output_says_its_noise_is_not_a_new_readings(tmp_path, capsys):
    from encal.cli import main

    grid = np.arange(360) * 1.0
    error = 2.0 * np.sin(np.radians(3 * grid))  # a smoothed curve: no noise, readings not whole codes
    path = write_run(tmp_path / "s.csv", grid, error)
    path.write_text("# resolution_bits: 14\n" + path.read_text())
    assert main(["fit", str(path), "-o", str(tmp_path / "m.json")]) == 0
    out = capsys.readouterr().out
    assert "(14-bit encoder): below the quantisation: these readings vary less than whole codes" in out


def test_the_rounding_of_a_profile_over_many_codes_is_noise():
    theta, error = read_12_bit(GRID, 0, scale=8.0)  # about 11 codes from peak to peak
    model = fit_spectral(theta, error)
    assert model.training["rounding_orders"] == []
    assert "rounding" not in model.report()
    theta, error = read_12_bit(GRID + 0.37 * np.sin(np.radians(7 * GRID)), 0)  # no regular grid
    assert fit_spectral(theta, error).training["rounding_orders"] == []


def four_arcmin_profile(theta_deg):
    r = np.radians(theta_deg)
    return 4.0 * np.sin(r) + 2.0 * np.cos(2 * r + 0.3) + 0.8 * np.sin(3 * r) + 0.3 * np.cos(7 * r)


@pytest.mark.parametrize("step_deg", [0.5, 0.25])
def test_the_rounding_on_a_dense_grid_of_stops_the_readings_leave_gets_no_line(step_deg):
    """Task edge5: a 12-bit encoder read without noise at 0.5 or 0.25-degree stops, a profile of 4 arcmin. The
    readings stray up to a quarter of a spacing from the stops' grid, which was then not found, and the
    rounding's pattern (order 4096 mod 720 = 496, folded to 224, and its sidebands) was fitted as 24-25 lines
    at orders 213-283: a profile 1.07-1.17 arcmin RMS off the truth between the stops. The reference's grid
    places the pattern."""
    reference = np.arange(0.0, 360.0, step_deg)
    theta = np.round((reference + four_arcmin_profile(reference) / 60.0) / CODE_12_BIT_DEG) * CODE_12_BIT_DEG
    model = fit_spectral(theta, (theta - reference) * 60.0)
    assert model.training["lines"] == [1, 2, 3, 7]  # were 28-29 lines
    between = np.arange(0.05, 360.0, 0.1)
    gap = model.predict(between + four_arcmin_profile(between) / 60.0) - four_arcmin_profile(between)
    assert rms(gap) < 0.1  # measured 0.026 and 0.025 arcmin; were 1.12 and 1.07
    assert 222 in model.training["rounding_orders"]


def low_harmonics(theta_deg, scale=1.0):
    """A motor encoder's profile of a few low harmonics (orders 1, 2, 4, 14; 6, 3, 1.5 and 1 arcmin)."""
    r = np.radians(theta_deg)
    return scale * (6.0 * np.cos(r - 0.3) + 3.0 * np.cos(2 * r - 1.1) + 1.5 * np.cos(4 * r - 2.0)
                    + 1.0 * np.cos(14 * r - 0.7))


def quantised_sweep(bits, stops, jitter, scale, seed=0):
    """One reading per stop of a ``bits``-bit encoder with the profile :func:`low_harmonics` times ``scale``, no noise
    but the rounding to whole codes, the reference exact: stops uniform (or each moved by up to 0.4 of the spacing
    with ``jitter``) from a random phase. Returns the readings (degrees) and their errors (arc-minutes);
    benchmarks/bench_quantised_sweeps.py runs 48 of them."""
    rng = np.random.default_rng(seed)
    spacing = 360.0 / stops
    reference = np.arange(stops) * spacing
    if jitter:
        reference = reference + rng.uniform(-0.4, 0.4, stops) * spacing
    reference = np.mod(reference + rng.uniform(0.0, spacing), 360.0)
    code = 360.0 / 2**bits
    reading = np.mod(np.round((reference + low_harmonics(reference, scale) / 60.0) / code) * code, 360.0)
    return reading, (np.mod(reading - reference + 180.0, 360.0) - 180.0) * 60.0


def low_harmonics_at_encoder_angles(encoder_deg, scale=1.0):
    """:func:`low_harmonics` at encoder angles (degrees): the reference angle under each by fixed-point iteration."""
    under = np.array(encoder_deg, dtype=float)
    for _ in range(30):
        under = encoder_deg - low_harmonics(under, scale) / 60.0
    return low_harmonics(under, scale)


@pytest.mark.parametrize("bits, stops, jitter, scale, bound", [
    (12, 3600, False, 1.0, 0.08),  # before: 41 false lines at 459-1023, 0.297 arcmin RMS off the truth
    (12, 3600, True, 1.0, 0.08),   # before: 3 false lines at 490-506, 0.231
    (12, 1800, False, 0.3, 0.08),  # before: 9 false lines at 175-190 (the 4th harmonic) and 482, 0.135
    (14, 1800, False, 1.0, 0.03),  # before: false lines at 104 and 233, 0.041
])
def test_a_dense_noise_free_sweep_of_a_quantised_encoder_gets_no_false_line(bits, stops, jitter, scale, bound):
    """Task quant6: one reading per stop, no noise but the rounding to whole codes, the reference exact. The
    rounding's share per column was taken over the highest order fitted rather than the stops' Nyquist order, the
    orders the scan above the cap picked had that share taken out although the noise there held almost none of it,
    the 4th and higher harmonics were not modelled, and off a grid nothing was: the rounding's bands came out as
    lines. Measured after: no false line; 0.057, 0.064, 0.040 and 0.019 arcmin RMS (a least-squares fit of the
    true orders: 0.051, 0.060, 0.038 and 0.019)."""
    reading, error = quantised_sweep(bits, stops, jitter, scale)
    model = fit_spectral(reading, error)
    assert set(model.training["lines"]) <= {1, 2, 4, 14}
    encoder = np.arange(0.0, 360.0, 0.05)
    assert rms(model.predict(encoder) - low_harmonics_at_encoder_angles(encoder, scale)) < bound


def jittered_power_law(seed, noise_arcmin=0.05):
    """72 stops of a 5° grid, each moved by up to ±1°, on a profile with a ν^-2 spectrum to order 120.

    Returns the encoder angles, the errors and the noise-free profile (a function of degrees).
    """
    rng = np.random.default_rng(seed)
    orders = np.arange(1, 121)
    a, b = rng.normal(0.0, np.sqrt(2.0 / orders**2), (2, orders.size))

    def truth(theta_deg):
        r = np.radians(np.asarray(theta_deg, dtype=float))[:, None] * orders
        return np.cos(r) @ a + np.sin(r) @ b

    reference = np.arange(0.0, 360.0, 5.0) + rng.uniform(-1.0, 1.0, 72)
    error = truth(reference) + rng.normal(0.0, noise_arcmin, reference.size)
    return reference + error / 60.0, error, truth


def test_alias_coherence_is_one_on_a_grid_of_stops_however_far_the_readings_stray():
    assert _alias_coherence(GRID) == pytest.approx(1.0, abs=1e-12)
    fold = np.delete(GRID, np.arange(0, GRID.size, 5))  # a cross-validation fold: every fifth node missing
    assert _alias_coherence(fold) == pytest.approx(1.0, abs=1e-12)
    error = line_profile(fold) + np.random.default_rng(2).normal(0.0, 0.05, fold.size)
    assert fit_spectral(fold + error / 60.0, error, noise_arcmin=0.05).training["max_order"] == 72
    error = 20.0 * line_profile(GRID)  # readings up to 1.2° off the 2° grid: the stops are what count
    assert fit_spectral(GRID + error / 60.0, error, noise_arcmin=0.1).training["alias_coherence"] \
        == pytest.approx(1.0, abs=1e-9)
    theta, error, _ = jittered_power_law(0)
    # E cos(72 δ) for δ uniform in ±1°: sin(1.2566) / 1.2566 = 0.76
    assert 0.65 < fit_spectral(theta, error).training["alias_coherence"] < 0.87


@pytest.mark.parametrize("seed", range(3))
def test_off_a_grid_the_series_runs_beyond_the_nyquist_order(seed):
    theta, error, truth = jittered_power_law(seed)
    model = fit_spectral(theta, error, noise_arcmin=0.05)
    assert model.training["max_order"] == 72
    assert model.training["beyond_nyquist"] == {"from_order": 37, "line_nats": 6.0}
    assert max(model.training["lines"], default=0) <= 36  # a smooth spectrum: no line up there
    assert "orders 37-72: past the Nyquist order, a line needs 6 nats (the stops are off a regular grid" \
        in model.report()
    cut = fit_spectral(theta, error, noise_arcmin=0.05, max_order=36)  # a named order is kept
    assert cut.training["max_order"] == 36 and "beyond_nyquist" not in cut.training
    test = np.arange(0.0, 360.0, 0.5)
    # 30 seeds: 0.80-0.96 of the profile error of the series cut at Nyquist
    assert rms(model.predict(test) - truth(test)) < 0.97 * rms(cut.predict(test) - truth(test))
    # Blind: the noise is the blind split's mean noise of the series up to Nyquist, then held fixed.
    blind = fit_spectral(theta, error)
    blind_cut = fit_spectral(theta, error, max_order=36)
    assert blind.training["max_order"] == 72 and "beyond_nyquist" in blind.training
    assert blind.training["prior"] == BLIND_PRIOR + spectral.BLIND_BEYOND_NYQUIST
    assert blind.training["noise"] == blind_cut.training["noise"]  # σ̂ (the flat level) and the split
    assert blind.uncertainty["noise_std_arcmin"] == pytest.approx(
        blind_cut.training["noise"]["split"]["mean_noise_std_arcmin"], rel=1e-12)
    # 30 seeds: 0.90-1.06 of the profile error of the blind series cut at Nyquist, median 0.98
    assert rms(blind.predict(test) - truth(test)) < 1.1 * rms(blind_cut.predict(test) - truth(test))


def test_off_a_grid_a_line_above_the_nyquist_order_is_found_rather_than_its_alias():
    # A resolver's third pole-pair harmonic (order 48) on 72 stops moved by up to ±1°: cut at order 36,
    # the fit puts it on its alias 72 - 48 = 24, which is wrong between the stops.
    lines = {1: (3.0, 0.4), 2: (0.9, 0.0), 16: (0.3, 1.0), 48: (0.2, -0.7)}
    test = np.arange(0.0, 360.0, 0.25)
    found, ratios = 0, []
    for seed in range(6):  # measured: 48 found on 5 of 6 (11 of 12 seeds), 0.02-0.05 arcmin against 0.17-0.22
        rng = np.random.default_rng(seed)
        reference = np.arange(0.0, 360.0, 5.0) + rng.uniform(-1.0, 1.0, 72)
        error = line_profile(reference, lines) + rng.normal(0.0, 0.1, 72)
        model = fit_spectral(reference + error / 60.0, error, noise_arcmin=0.1)
        cut = fit_spectral(reference + error / 60.0, error, noise_arcmin=0.1, max_order=36)
        found += 48 in model.training["lines"] and 24 not in model.training["lines"]
        ratios.append(rms(model.predict(test) - line_profile(test, lines))
                      / rms(cut.predict(test) - line_profile(test, lines)))
    assert found >= 4
    assert max(ratios) < 1.05 and np.median(ratios) < 0.4


def test_on_a_grid_of_stops_the_series_ends_at_the_nyquist_order_even_with_the_noise_known():
    rng = np.random.default_rng(5)
    error = line_profile(GRID) + rng.normal(0.0, 0.05, GRID.size)
    model = fit_spectral(GRID + error / 60.0, error, noise_arcmin=0.05)
    assert model.training["max_order"] == 90 and "beyond_nyquist" not in model.training


def test_lines_started_by_leakage_off_a_grid_are_all_dropped():
    # 180 and 360 stops each moved by up to ±0.2 spacings, the noise known: the periodogram's leakage
    # from the 3 arcmin order 1 starts dozens of lines; dropped one per round, false ones stayed (42 on the
    # 360 stops with the code of 88c3561, docs/model-selection.md), and the profile was up to twice as far off.
    rng = np.random.default_rng(0)
    test = np.arange(0.0, 360.0, 0.25)
    truth = {1: (3.0, -0.5 * math.pi), 2: (0.9, 0.0), 16: (0.3, -0.5 * math.pi), 40: (0.1, 0.0)}
    for m in (180, 360):
        reference = (np.arange(m) + rng.uniform(-0.2, 0.2, m)) * 360.0 / m
        error = line_profile(reference, truth) + rng.normal(0.0, 0.1, m)
        model = fit_spectral(reference + error / 60.0, error, noise_arcmin=0.1)
        # seeds 0-5: the four found every time, one false line in 2 of 12 fits, profile RMS 0.009-0.029
        assert {1, 2, 16, 40} <= set(model.training["lines"])
        assert len(model.training["lines"]) <= 5
        assert rms(model.predict(test) - line_profile(test, truth)) < 0.035


def test_a_strong_order_off_a_grid_starts_one_line_not_its_leakage():
    # 180 stops moved by up to ±0.2 spacings: order 1 at 3 arcmin leaks into every other order's
    # periodogram far above the 0.1 arcmin noise; taken out first, it starts no other line.
    rng = np.random.default_rng(3)
    reference = (np.arange(180) + rng.uniform(-0.2, 0.2, 180)) * 2.0
    error = 3.0 * np.sin(np.radians(reference)) + 0.3 * np.cos(np.radians(16 * reference)) \
        + rng.normal(0.0, 0.1, 180)
    theta = np.radians(reference + error / 60.0)
    orders, shifts, lineable = _columns(90, None, 0.0)
    design = _general_design(theta, error - error.mean(), orders, shifts, lineable)
    assert set(_evidence._initial(design, 0.01, 3.0).lines) == {1, 16}
    diagonal = np.diag(design.gram)
    power = (design.projection / diagonal) ** 2  # the plain periodogram, per column
    assert np.sum(power[orders > 20] > 0.01 / 90 * 8.0) > 20  # what started lines before


def test_a_search_can_start_from_a_fit_of_fewer_orders():
    rng = np.random.default_rng(4)
    error = line_profile(GRID) + rng.normal(0.0, 0.05, GRID.size)
    theta = np.radians(GRID + error / 60.0)
    design = _general_design(theta, error - error.mean(), *_columns(90, 180, 0.0))
    hyper, _ = _evidence.fit_hyperparameters(design, noise_var=0.0025)
    again, _ = _evidence.fit_hyperparameters(design, noise_var=0.0025, start=hyper)
    assert sorted(again.lines) == sorted(hyper.lines) == [1, 3, 16, 40]
    assert again.amplitude == pytest.approx(hyper.amplitude, rel=1e-3)


@pytest.mark.parametrize("seed", [9, 28])
def test_a_search_collapsed_into_lines_at_every_order_is_repeated_from_the_power_law(seed, monkeypatch):
    # With the noise known and small, nearly every order starts as a line; on these seeds the background
    # then shrinks under them (to nothing above Nyquist) and no line can leave. From a power law through
    # the periodogram there are none, and the profile is closer (1.55 and 1.73 times, measured).
    theta, error, truth = jittered_power_law(seed)
    test = np.arange(0.0, 360.0, 0.5)
    model = fit_spectral(theta, error, noise_arcmin=0.05)
    assert len(model.training["lines"]) <= 3
    monkeypatch.setattr(_evidence, "COLLAPSE_LINE_FRACTION", 1.0)
    collapsed = fit_spectral(theta, error, noise_arcmin=0.05)
    assert len(collapsed.training["lines"]) > 30
    assert rms(model.predict(test) - truth(test)) < 0.9 * rms(collapsed.predict(test) - truth(test))


# -- noise supplied, estimated, or blind -----------------------------------------------------------

def roughness_case(seed, per_order_power=1.5):
    """Lines plus a flat "roughness" spectrum up to order 90 of ``per_order_power`` times the noise's."""
    rng = np.random.default_rng(seed)
    sigma = 0.1
    coefficient_std = math.sqrt(per_order_power * 2.0 * sigma**2 / GRID.size)
    orders = np.arange(1, 91)
    a, b = rng.normal(0.0, coefficient_std, (2, orders.size))

    def truth(theta):
        r = np.radians(theta)[:, None]
        return line_profile(theta) + np.cos(orders * r) @ a + np.sin(orders * r) @ b

    return truth, truth(GRID) + rng.normal(0.0, sigma, GRID.size), sigma


def test_supplied_noise_is_used_and_the_blind_split_keeps_part_of_a_flat_spectrum():
    blind_errors, supplied_errors, all_noise_errors = [], [], []
    for seed in range(6):
        truth, error, sigma = roughness_case(seed)
        blind = fit_spectral(GRID, error)
        supplied = fit_spectral(GRID, error, noise_arcmin=sigma)
        assert supplied.training["noise"] == {"source": "supplied", "std_arcmin": sigma}
        assert blind.training["noise"]["source"] == "blind"
        assert blind.training["prior"] == BLIND_PRIOR
        # The flat level holds the roughness as well as the noise: one run cannot split them.
        flat_level = blind.training["noise"]["std_arcmin"]
        assert flat_level > 1.15 * sigma
        # "All noise" is the end of the ridge the blind prior no longer takes.
        all_noise = fit_spectral(GRID, error, noise_arcmin=flat_level)
        blind_errors.append(rms(blind.predict(MIDPOINTS) - truth(MIDPOINTS)))
        supplied_errors.append(rms(supplied.predict(MIDPOINTS) - truth(MIDPOINTS)))
        all_noise_errors.append(rms(all_noise.predict(MIDPOINTS) - truth(MIDPOINTS)))
    # Averaged over the split, the blind fit follows part of the roughness between the points;
    # knowing the noise does too. Calling it all noise smooths it away.
    assert np.mean(blind_errors) < 0.8 * np.mean(all_noise_errors)
    assert np.mean(supplied_errors) < 0.9 * np.mean(all_noise_errors)


def test_blind_noise_estimate_on_a_line_spectrum():
    estimates = [fit_spectral(GRID, line_profile(GRID) + np.random.default_rng(s).normal(0, 0.2, 180))
                 .training["noise"]["std_arcmin"] for s in range(5)]
    assert np.mean(estimates) == pytest.approx(0.2, rel=0.08)


def test_noise_from_two_passes_over_the_same_grid():
    rng = np.random.default_rng(7)
    reference = np.r_[GRID, GRID]
    error = line_profile(reference) + rng.normal(0.0, 0.1, reference.size)
    std, dof = repeat_noise(reference, error)
    assert dof == 180 and std == pytest.approx(0.1 * math.sqrt(0.5) * math.sqrt(2), rel=0.15)
    model = fit_spectral(reference + error / 60.0, error)
    assert model.training["noise"]["source"] == "repeated readings"
    assert model.training["noise"]["std_arcmin"] == pytest.approx(std, rel=1e-12)
    assert model.training["stops"] == 180
    assert model.training["max_order"] == 90


def prior_draw_coverage(**options):
    """±2σ coverage at the midpoints, with and without the noise, over 8 profiles drawn from a ν^-2 prior."""
    covered, without_noise = [], []
    orders = np.arange(1, 91)
    for seed in range(8):
        rng = np.random.default_rng(100 + seed)
        coefficient_std = np.sqrt(0.5 * orders**-2.0)
        a, b = rng.normal(0.0, 1.0, (2, orders.size)) * coefficient_std

        def truth(theta):
            r = np.radians(theta)[:, None]
            return np.cos(orders * r) @ a + np.sin(orders * r) @ b

        model = fit_spectral(GRID, truth(GRID) + rng.normal(0.0, 0.1, GRID.size), **options)
        test = truth(MIDPOINTS) + rng.normal(0.0, 0.1, GRID.size)
        mean, std = model.predict(MIDPOINTS, return_std=True)
        covered.append(np.mean(np.abs(test - mean) <= 2.0 * std))
        _, profile_std = model.predict(MIDPOINTS, return_std=True, include_noise=False)
        assert np.all(profile_std < std)
        without_noise.append(np.mean(np.abs(truth(MIDPOINTS) - mean) <= 2.0 * profile_std))
    return np.mean(covered), np.mean(without_noise)


def test_posterior_intervals_cover_draws_from_the_prior_when_the_noise_is_known():
    covered, without_noise = prior_draw_coverage(noise_arcmin=0.1)
    assert 0.92 <= covered <= 0.98
    assert 0.92 <= without_noise <= 0.98


def test_blind_intervals_under_cover_when_the_flat_level_is_all_noise():
    # Documented (docs/model-selection.md): the blind split keeps part of the flat level as profile; where
    # it is in truth all noise, the mean keeps part of it and the intervals cover less than 95 %.
    covered, without_noise = prior_draw_coverage()
    assert 0.78 <= covered <= 0.93
    assert 0.75 <= without_noise <= 0.93


def test_irregular_angles_use_the_fourier_feature_path():
    rng = np.random.default_rng(11)
    theta = np.sort(rng.uniform(0.0, 360.0, 240))
    model = fit_spectral(theta, line_profile(theta) + rng.normal(0.0, 0.05, theta.size))
    assert model.training["path"] == "fourier-features"
    assert model.training["max_order"] == 200  # past the Nyquist order 120: the stops are random (safeguard 5)
    assert model.training["beyond_nyquist"]["from_order"] == 121
    assert rms(model.predict(MIDPOINTS) - line_profile(MIDPOINTS)) < 0.04


@pytest.mark.parametrize("options, message", [
    ({"noise_arcmin": -1.0}, "noise_arcmin"), ({"noise_arcmin": float("nan")}, "noise_arcmin"),
    ({"max_order": 0}, "max_order"), ({"path": "fast"}, "path"), ({"threshold_nats": -1}, "threshold_nats")])
def test_invalid_options_are_refused_in_one_sentence(options, message):
    with pytest.raises(InputError, match=message):
        fit_spectral(GRID, line_profile(GRID), **options)


def test_two_stops_are_too_few():
    with pytest.raises(InputError, match="3 or more distinct reference angles"):
        fit_spectral([0.0, 180.0, 0.0], [1.0, 2.0, 1.0])


def test_fft_path_refuses_irregular_angles():
    with pytest.raises(InputError, match="uniform grid"):
        fit_spectral(GRID + np.r_[0.3, np.zeros(179)], line_profile(GRID), path="fft")


# -- deployment -------------------------------------------------------------------------------------

def fitted_calibration_model(**options):
    rng = np.random.default_rng(5)
    error = line_profile(GRID) + rng.normal(0.0, 0.05, GRID.size)
    cal = encal.Calibration(GRID, GRID + error / 60.0, name="enc", resolution_bits=16)
    return encal.fit(cal, method="spectral", **options)


def test_model_file_round_trip_and_standalone_runtime(tmp_path):
    model = fitted_calibration_model(noise_arcmin=0.05)
    assert model.training["method"] == "spectral"
    path = model.save(tmp_path / "enc.json")
    loaded = encal.load_model(path)
    assert isinstance(loaded, SpectralModel)
    angles = np.linspace(-10.0, 370.0, 777)
    np.testing.assert_array_equal(loaded.predict(angles), model.predict(angles))
    np.testing.assert_array_equal(loaded.predict(angles, return_std=True)[1], model.predict(angles, return_std=True)[1])
    standalone = runtime.load(path)
    assert max(abs(standalone.predict_arcmin(a) - float(model.predict(a))) for a in angles) < 1e-11


def test_uncertainty_option_keeps_the_posterior():
    model = fitted_calibration_model(uncertainty=True)
    assert model.uncertainty["method"] == "posterior"


def test_dense_table_and_c_export_evaluate_the_series(tmp_path):
    from encal.deploy import compile_table, export_c

    model = fitted_calibration_model()
    table = compile_table(model, 12, dtype="float32")
    codes = np.arange(4096)
    np.testing.assert_allclose(table.predict_counts(codes), model.predict(codes * 360.0 / 4096), atol=1e-5)
    files = export_c(model, prefix="enc", bits=12)
    assert "enc_predict_arcmin" in files["enc.h"] and "model_order[91]" in files["enc.c"]


# -- auto and the command line ----------------------------------------------------------------------

def test_auto_is_the_spectral_model_and_a_network_asked_for_must_cross_validate_clearly_better():
    from encal.models.auto import fit_auto

    error = line_profile(GRID) + np.random.default_rng(1).normal(0.0, 0.05, GRID.size)
    model = fit_auto(GRID, error, rng=0)
    selection = model.training["selection"]
    assert model.kind == "spectral" and selection["scheme"] == "evidence" and selection["chosen"] == "spectral"
    assert selection["table"] == [] and selection["reason"] == "the spectral model (evidence)"
    model = fit_auto(GRID, error, rng=0, networks=True)
    selection = model.training["selection"]
    assert [row["family"] for row in selection["table"]] == ["spectral", "hybrid", "ann", "ann"]
    # A local bump a decaying spectrum shrinks: a network may take over, never by less than the margin.
    bump = 4.0 * np.exp(-0.5 * ((GRID - 100.0) / 3.0) ** 2)
    model = fit_auto(GRID, error + bump, rng=0, networks=True)
    rows = {row["label"]: row["cv_rms_arcmin"] for row in model.training["selection"]["table"]}
    spectral_cv = next(v for k, v in rows.items() if k.startswith("spectral"))
    if model.kind != "spectral":
        assert rows[model.training["selection"]["chosen"]] < 0.97 * spectral_cv


def test_auto_skips_the_networks_on_large_calibrations():
    from encal.models.auto import fit_auto

    theta = np.arange(0.0, 360.0, 0.5)
    model = fit_auto(theta, line_profile(theta) + np.random.default_rng(2).normal(0.0, 0.05, theta.size),
                     networks=True)
    assert model.kind == "spectral" and model.training["selection"]["table"] == []
    assert "networks not tried on 720 stops" in model.training["selection"]["reason"]


def test_auto_with_candidates_is_the_cross_validated_choice():
    from encal.models.auto import fit_auto

    model = fit_auto(GRID, line_profile(GRID), candidates=[{"family": "fourier", "options": {}}], stack=False)
    assert model.kind == "fourier" and model.training["selection"]["folds"] == 5


def write_run(path, reference, error, header="reference_deg,encoder_deg"):
    rows = "\n".join(f"{float(r)!r},{float((r + e / 60.0) % 360.0)!r}" for r, e in zip(reference, error))
    path.write_text(f"{header}\n{rows}\n")
    return path


def test_cli_fit_spectral_with_noise_and_with_a_repeat_pass(tmp_path, capsys):
    from encal.cli import main

    rng = np.random.default_rng(4)
    first = write_run(tmp_path / "a.csv", GRID, line_profile(GRID) + rng.normal(0.0, 0.1, GRID.size))
    second = write_run(tmp_path / "b.csv", GRID, line_profile(GRID) + rng.normal(0.0, 0.1, GRID.size))
    assert main(["fit", str(first), "-o", str(tmp_path / "m.json"), "--method", "spectral", "--noise", "0.1"]) == 0
    out = capsys.readouterr().out
    assert "noise: sigma 0.1 arcmin; prior: noise supplied by the user" in out
    assert "held-out estimate (posterior" in out
    assert main(["fit", str(first), "-o", str(tmp_path / "r.json"), "--method", "spectral",
                 "--repeat", str(second)]) == 0
    out = capsys.readouterr().out
    assert "prior: noise from repeated readings" in out
    sigma = encal.load_model(tmp_path / "r.json").training["noise"]["std_arcmin"]
    assert sigma == pytest.approx(0.1, rel=0.2)
    assert main(["fit", str(first), "-o", str(tmp_path / "l.json"), "--method", "lut"]) == 0
    assert "held-out estimate: RMS" in capsys.readouterr().out
    with pytest.raises(SystemExit) as info:  # a usage error
        main(["fit", str(first), "-o", str(tmp_path / "x.json"), "--method", "lut", "--noise", "0.1"])
    assert info.value.code == 2
    assert "--noise applies to --method spectral or auto" in capsys.readouterr().err


def test_cli_blind_fit_states_the_prior_and_sigma_against_the_quantisation(tmp_path, capsys):
    from encal.cli import main

    error = line_profile(GRID) + np.random.default_rng(6).normal(0.0, 0.1, GRID.size)
    path = write_run(tmp_path / "a.csv", GRID, error)
    text = path.read_text()
    path.write_text("# resolution_bits: 16\n" + text)
    assert main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--method", "spectral"]) == 0
    out = capsys.readouterr().out
    assert f"prior: {BLIND_PRIOR}" in out
    assert "sigma / (LSB/sqrt(12)) = " in out and "(16-bit encoder)" in out
    sigma = encal.load_model(tmp_path / "m.json").training["noise"]["std_arcmin"]
    ratio = sigma / (21600.0 / 2**16 / math.sqrt(12.0))
    assert ratio == pytest.approx(1.06, abs=0.01)  # 0.1 arcmin of noise against 0.095 of a 16-bit encoder's rounding
    assert f"= {ratio:.2f} (16-bit encoder): consistent with the encoder's quantisation alone;" in out


@pytest.mark.parametrize("ratio, source, start", [
    (1.05, "blind", "consistent with the encoder's quantisation alone"),
    (1.19, "repeated readings", "consistent with the encoder's quantisation alone"),
    # the simulator's reading noise (0.099 arcmin) is about its quantisation noise (0.095): both count
    (1.44, "repeated readings", "comparable to the quantisation: reading noise of about 1.0 LSB/sqrt(12)"),
    (1.25, "supplied", "comparable to the quantisation: reading noise of about 0.8 LSB/sqrt(12)"),
    (1.81, "blind", "comparable to the quantisation: a part of about 1.5 LSB/sqrt(12) adds to the rounding"),
    (2.0, "repeated readings", "well above the quantisation: the reading noise"),
    (4.05, "blind", "well above the quantisation: reading noise, or structure finer"),
    (0.6, "repeated readings", "below the quantisation alone: the scatter of the repeated readings leaves out"),
    (0.6, "supplied", "below the quantisation alone: the noise given leaves out"),
])
def test_the_noise_verdict_says_what_the_ratio_to_the_quantisation_allows(ratio, source, start):
    meaning = spectral._noise_meaning(ratio, source)
    assert meaning.startswith(start)
    assert ("--repeat" in meaning) == (source == "blind" and ratio >= 1.2)
    assert "nothing finer" not in meaning


def test_a_multi_revolution_log_is_read_as_repeated_readings(tmp_path):
    rng = np.random.default_rng(9)
    turns = 3
    reference = np.tile(np.arange(0.0, 360.0, 0.5), turns) + 360.0 * np.repeat(np.arange(turns), 720)
    error = line_profile(reference) + rng.normal(0.0, 0.1, reference.size)
    path = write_run(tmp_path / "log.csv", reference, error)
    cal = encal.read_calibration(path)  # no --average-duplicates needed
    assert len(cal) == 3 * 720
    model = encal.fit(cal, method="spectral")
    assert model.training["noise"]["source"] == "repeated readings"
    assert model.training["stops"] == 720
    assert model.training["noise"]["std_arcmin"] == pytest.approx(0.1, rel=0.1)
    # One pass with conflicting repeats in no particular order is still refused.
    shuffled = write_run(tmp_path / "rows.csv", np.r_[GRID, GRID[::-1]],
                         np.r_[line_profile(GRID), line_profile(GRID) + 1])
    with pytest.raises(encal._core.errors.CalibrationError, match="appears more than once"):
        encal.read_calibration(shuffled)


def test_a_lookup_table_of_a_dense_sweep_is_binned():
    from encal.models.lut import DENSE_ENTRIES, fit_lut

    rng = np.random.default_rng(12)
    theta = np.sort(rng.uniform(0.0, 360.0, 50_000))
    error = line_profile(theta) + rng.normal(0.0, 0.1, theta.size)
    model = fit_lut(theta, error)
    assert model.training["n_entries"] == DENSE_ENTRIES and model.training["binned_from_angles"] == 50_000
    test = np.linspace(0.0, 360.0, 997, endpoint=False)
    assert rms(model.predict(test) - line_profile(test)) < 0.04  # about 12 readings averaged per entry
    assert fit_lut(theta[:300], error[:300]).training["n_entries"] == 300


def test_two_passes_in_one_file_with_an_epoch_column_give_the_noise(tmp_path):
    rng = np.random.default_rng(13)
    rows = ["reference_deg,encoder_deg,epoch"]
    for epoch in ("a", "b"):
        error = line_profile(GRID) + rng.normal(0.0, 0.1, GRID.size)
        rows += [f"{float(r)!r},{float((r + e / 60.0) % 360.0)!r},{epoch}" for r, e in zip(GRID, error)]
    path = tmp_path / "passes.csv"
    path.write_text("\n".join(rows) + "\n")
    model = encal.fit(encal.read_calibration(path), method="spectral")
    assert model.training["noise"]["source"] == "repeated readings"
    assert model.training["noise"]["std_arcmin"] == pytest.approx(0.1, rel=0.2)


def test_cli_json_states_the_posterior_held_out_estimate(tmp_path, capsys):
    import json

    from encal.cli import main

    path = write_run(tmp_path / "a.csv", GRID, line_profile(GRID) + np.random.default_rng(8).normal(0, 0.1, 180))
    assert main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--method", "spectral", "--json"]) == 0
    note = json.loads(capsys.readouterr().out)["held_out_note"]
    assert note.startswith("held-out estimate (posterior") and "arcmin after correction" in note


def test_cli_networks_option_cross_validates_them_and_applies_to_auto_only(tmp_path, capsys):
    from encal.cli import main

    grid = np.arange(0.0, 360.0, 5.0)
    path = write_run(tmp_path / "a.csv", grid, line_profile(grid) + np.random.default_rng(4).normal(0, 0.05, grid.size))
    assert main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--networks", "--seed", "0"]) == 0
    out = capsys.readouterr().out
    assert "spectral model against the networks, " in out and "hybrid" in out
    selection = encal.load_model(tmp_path / "m.json").training["selection"]
    assert [row["family"] for row in selection["table"]] == ["spectral", "hybrid", "ann", "ann"]
    with pytest.raises(SystemExit) as info:  # a usage error
        main(["fit", str(path), "-o", str(tmp_path / "s.json"), "--method", "spectral", "--networks"])
    assert info.value.code == 2
    assert "--networks applies to --method auto, not spectral" in capsys.readouterr().err


def test_the_noise_line_says_which_noise_a_new_reading_gets_when_the_split_is_below_the_flat_level():
    """Issue 28: a held-out estimate printed below the stated noise (the flat level), with nothing said."""
    rng = np.random.default_rng(0)
    theta = np.arange(0.0, 360.0, 2.0)
    rough = sum(0.05 * np.cos(np.radians(k * theta) + rng.uniform(0.0, 2 * np.pi)) for k in range(1, 91))
    model = fit_spectral(theta, rough + 2.0 * np.sin(np.radians(theta)) + rng.normal(0.0, 0.05, theta.size))
    sigma = model.training["noise"]["std_arcmin"]
    new_reading = model.training["noise"]["split"]["mean_noise_std_arcmin"]
    assert new_reading < sigma
    line = next(line for line in model.report().splitlines() if line.startswith("noise:"))
    assert f"a new reading's noise is taken as {new_reading:.4g} arcmin" in line
    assert model.expected_rms_between_points() >= new_reading
@pytest.mark.slow
def test_orders_above_the_cap_of_dense_irregular_data_follow_the_data(monkeypatch):
    # Issue 27: a dense sweep off a uniform grid (10,000 readings at random angles, which identify orders
    # past 500) of a profile with orders 200 and 250, such as a 200-step stepper's detent seen through the
    # reference. The Fourier-feature path is capped at order 200 for its cost; the residual's periodogram
    # brings the orders above it that the data show into the fit.
    rng = np.random.default_rng(0)
    reference = np.sort(rng.uniform(0.0, 360.0, 10_000))

    def profile(theta_deg):
        r = np.radians(theta_deg)
        return 3.0 * np.sin(r) + 1.0 * np.cos(200 * r) + 0.8 * np.sin(250 * r + 0.4)

    error = profile(reference) + rng.normal(0.0, 0.2, reference.size)
    theta = reference + error / 60.0
    test = rng.uniform(0.0, 360.0, 2000)
    model = fit_spectral(theta, error)
    assert model.training["max_order"] > 250
    assert {249, 250, 251} <= set(model.training["orders_above_cap"]["orders"])
    assert "above the cap of 200 (off a uniform grid), carried because the residual's periodogram" in model.report()
    assert rms(model.predict(test) - profile(test)) < 0.2  # measured 0.128
    monkeypatch.setattr(spectral, "MAX_EXTRA_ORDERS", 0)
    capped = fit_spectral(theta, error)
    assert capped.training["max_order"] == 200
    assert rms(capped.predict(test) - profile(test)) > 0.5  # measured 0.576: order 250 missing


def test_the_blind_split_rules_the_benchmark_compares():
    # Issue 27: bench_worlds.py --blind RULE measures other priors on the split of the flat level; the
    # default is the two-point prior 0.1 / 0.8, chosen for its worst encoder (docs/model-selection.md).
    rng = np.random.default_rng(5)
    error = line_profile(GRID) + rng.normal(0.0, 0.1, GRID.size)
    orders, shifts, lineable = _columns(90, 180, 0.0)
    design = _fft_design(error - error.mean(), _uniform_nodes(GRID), orders, shifts, lineable)
    hyper, _ = _evidence.fit_hyperparameters(design)
    noise = {rule: _evidence.split_average(design, hyper, rule=rule)[1] for rule in spectral.BLIND_SPLITS}
    assert noise["noise"] == pytest.approx(hyper.noise_var)  # all of the flat level noise
    assert noise["uniform"] == pytest.approx(0.5 * hyper.noise_var, rel=0.05)  # half of it, on average
    assert noise["uniform"] < noise["u80"] < noise["u70"] < noise["u60"] < noise["half"] < noise["noise"]
    assert any(noise["gcv"] == pytest.approx((1.0 - k / 9) * hyper.noise_var) for k in range(9))
    # a fixed fraction f (benchmarks/bench_split.py): the noise is (1 - f) of the flat level
    assert _evidence.split_average(design, hyper, rule="f0")[1] == pytest.approx(noise["noise"])
    assert _evidence.split_average(design, hyper, rule="f30")[1] == pytest.approx(0.7 * hyper.noise_var)
    # the default: the noise is 0.9 or 0.2 of the flat level, averaged by the two splits' evidence
    assert spectral.BLIND_SPLIT == "b10-80"
    assert _evidence.split_fractions("b10-80").tolist() == [0.1, 0.8]
    assert 0.2 * hyper.noise_var < noise["b10-80"] < 0.9 * hyper.noise_var


# -- the optimiser's stopping rule on dense fits (optim7) --------------------------------------------

def _background_design(n, seed, highest=2000, amplitude=1e-7, exponent=4.0, noise_var=0.01):
    """Sufficient statistics of ``n`` readings on a uniform grid: a weak ``A ν^-β`` profile under white noise."""
    rng = np.random.default_rng(seed)
    orders = np.repeat(np.arange(1, highest + 1), 2)
    gram = np.full(orders.size, n / 2.0)
    coefficients = rng.normal(0.0, np.sqrt(amplitude * orders.astype(float) ** -exponent))
    projection = gram * coefficients + rng.normal(0.0, np.sqrt(gram * noise_var))
    yy = float(np.sum(projection**2 / gram)) + (n - orders.size) * noise_var
    return _evidence.Design(orders, np.tile([0.0, math.pi / 2], highest), gram, projection, yy, n,
                            np.ones(orders.size, dtype=bool))


@pytest.mark.parametrize("seed", range(6))
def test_the_optimiser_reaches_the_maximum_of_a_dense_fit(seed):
    # 10^6 readings; the search starts from a background 50 times below the truth (a periodogram's start on a dense
    # sweep is below the noise). Of minus the evidence per reading, L-BFGS-B's first step (minus the gradient) is
    # 10^6 times too short; it gained less than ftol and the search stopped where it started, 0.05 nats below the
    # maximum on seed 0, 1.5-1.7 on seeds 2, 4 and 5, until such a search went on in nats. Truth: the best of a grid
    # over (log A, β), a lower bound of the maximum.
    design = _background_design(10**6, seed)
    noise_var = 0.01

    def log_evidence(amplitude, exponent):
        hyper = _evidence.Hyper(amplitude, exponent, noise_var, {}, True)
        return _evidence.evidence(design, hyper.variances(design), noise_var).log_evidence

    grid_best = max(log_evidence(math.exp(a), b) for a in np.arange(-22.0, -8.0, 0.25)
                    for b in np.arange(1.0, 8.01, 0.25))
    found = _evidence._optimise(design, _evidence.Hyper(2e-9, 2.0, noise_var, {}, True))
    assert log_evidence(found.amplitude, found.exponent) > grid_best - 0.02


def test_a_noise_free_series_off_a_grid_is_predicted_between_its_points():
    """A self-calibration's output is a smooth series with no noise; a cross-validation fold of it (288 of 360
    degrees) was predicted 1e5-5e7 arcmin off between its points (the noise at a floor of exp(-32) of the data's
    mean square put the posterior precision's condition near 1e20), after about 2,000 evaluations of the evidence."""
    calls = []
    original = _evidence._evidence

    def counted(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    orders = np.arange(1, 17)
    rng = np.random.default_rng(4)  # one of the draws that failed; every draw of 0-5 passes
    amplitude, phase = 20.0 / orders**1.5 * rng.uniform(0.5, 1.5, orders.size), rng.uniform(0, 2 * np.pi, orders.size)

    def series(theta_deg):
        return (amplitude[:, None] * np.cos(orders[:, None] * np.radians(theta_deg)[None, :] + phase[:, None])).sum(0)

    grid = np.arange(360.0)
    fold = np.arange(360) % 5 == 2
    _evidence._evidence = counted
    try:
        model = fit_spectral(grid[~fold], series(grid[~fold]))
    finally:
        _evidence._evidence = original
    mean, std = model.predict(grid[fold], return_std=True)
    assert np.max(np.abs(mean - series(grid[fold]))) < 1e-6
    assert np.max(std) < 0.01 and len(calls) < 100
    assert model.training["lines"] == list(range(1, 17))

"""A reference with an uncertainty of its own (a self-calibration's ``sigma_arcmin``) in a model's uncertainty.

Known truth: the encoder's error is ``3 sin θ``; the reference the calibration holds is off by a smooth error ``r(θ)``
of RMS 0.4 arcmin (five harmonics, shared by neighbouring points, as a self-calibration's error is), which the file
states as ``sigma_arcmin = 0.4``. A fit reproduces ``3 sin θ + r`` and so misses the truth by ``r``: its stated
uncertainty must be at least the reference's, and its 95 % band must hold the truth. Without the column the fit's
posterior, of a smooth noise-free series, states about 1e-6 arcmin and covers nearly nothing.
"""

import json

import numpy as np
import pytest

import encal
from encal.cli import main
from encal.data.calibration import Calibration, read_calibration, write_calibration
from encal.models.uncertainty import predictive_std, with_reference_uncertainty

REFERENCE_STD = 0.4
GRID = np.arange(0.0, 360.0, 1.0)


def truth(theta_deg):
    return 3.0 * np.sin(np.radians(theta_deg))


def reference_error(theta_deg):
    """A smooth reference error of RMS exactly ``REFERENCE_STD`` over the circle (orders 2, 3, 5, 6, 9)."""
    a = np.radians(theta_deg)
    amplitudes = np.array([1.0, -0.7, 0.5, 0.8, -0.4])
    phases = np.array([0.3, 1.9, 4.0, 2.2, 5.1])
    raw = sum(c * np.cos(k * a + p) for c, k, p in zip(amplitudes, (2, 3, 5, 6, 9), phases))
    return raw * REFERENCE_STD / np.sqrt(np.sum(amplitudes**2) / 2.0)


def calibration(with_std=True):
    encoder = np.arange(0.0, 360.0, 1.0)
    reference = encoder - (truth(encoder) + reference_error(encoder)) / 60.0
    std = np.full(encoder.size, REFERENCE_STD) if with_std else None
    return Calibration(reference, encoder, name="selfcal", reference_std_arcmin=std)


def band_coverage(model):
    """The share of a 1-degree grid where the model's 95 % band holds the truth (one smooth realisation of the
    reference's error: 0.947 for this one, where a Gaussian's share is 0.954; 0.9 is asserted)."""
    mean, std = model.predict(GRID, return_std=True)
    return float(np.mean(np.abs(mean - truth(GRID)) <= 2.0 * std))


def test_the_spectral_models_uncertainty_includes_the_references_and_its_band_holds_the_truth():
    model = encal.fit(calibration(), "spectral")
    assert model.uncertainty["reference_std_rms_arcmin"] == pytest.approx(REFERENCE_STD)
    assert REFERENCE_STD <= model.expected_rms_between_points() <= 1.02 * REFERENCE_STD
    assert band_coverage(model) >= 0.9
    # the shape of the claim: without the column the same fit states a tiny uncertainty and misses the truth
    blind = encal.fit(calibration(with_std=False), "spectral")
    assert blind.expected_rms_between_points() < 1e-3
    assert band_coverage(blind) < 0.05


def test_a_bootstrapped_uncertainty_includes_it_too():
    model = encal.fit(calibration(), "fourier", orders=list(range(10)), uncertainty=True, rng=0)
    assert model.uncertainty["reference_std_rms_arcmin"] == pytest.approx(REFERENCE_STD)
    assert np.all(predictive_std(model.uncertainty, GRID) >= REFERENCE_STD)
    assert band_coverage(model) >= 0.9


def test_added_once_in_quadrature_and_only_with_the_column():
    uncertainty = {"method": "given", "grid_step_deg": 90.0, "model_std_arcmin": [0.3, 0.0, 0.3, 0.0],
                   "noise_std_arcmin": 0.1}
    cal = Calibration(np.arange(0.0, 360.0, 10.0), np.arange(0.0, 360.0, 10.0),
                      reference_std_arcmin=np.full(36, 0.4))
    added = with_reference_uncertainty(uncertainty, cal)
    assert added["model_std_arcmin"] == pytest.approx([0.5, 0.4, 0.5, 0.4])
    assert added["noise_std_arcmin"] == 0.1 and added["reference_std_rms_arcmin"] == pytest.approx(0.4)
    assert with_reference_uncertainty(added, cal) is added
    assert with_reference_uncertainty(uncertainty, Calibration(cal.reference_deg, cal.encoder_deg)) is uncertainty
    assert with_reference_uncertainty(None, cal) is None


def test_interpolated_between_the_points_round_the_circle():
    encoder = np.arange(5.0, 360.0, 10.0)  # points at 5, 15, ..., 355 deg: 0 deg lies between 355 and 5
    std = np.where(encoder < 180.0, 0.2, 0.6)
    cal = Calibration(encoder, encoder, reference_std_arcmin=std)
    uncertainty = {"method": "given", "grid_step_deg": 1.0, "model_std_arcmin": [0.0] * 360, "noise_std_arcmin": 0.0}
    table = np.array(with_reference_uncertainty(uncertainty, cal)["model_std_arcmin"])
    assert table[90] == pytest.approx(0.2) and table[270] == pytest.approx(0.6)
    assert table[0] == pytest.approx(0.4)  # halfway between 355 (0.6) and 5 (0.2)


@pytest.mark.parametrize("method, estimator", [("spectral", "posterior"), ("fourier", "interleaved CV")])
def test_encal_fit_states_the_held_out_estimate_with_the_reference(tmp_path, capsys, method, estimator):
    path = tmp_path / "cal.csv"
    write_calibration(path, calibration())
    assert main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--method", method, "--json"]) == 0
    held_out = json.loads(capsys.readouterr().out)["held_out"]
    assert held_out["estimator"] == estimator
    assert held_out["reference_std_rms_arcmin"] == pytest.approx(REFERENCE_STD)
    assert REFERENCE_STD <= held_out["rms_arcmin"] <= 1.1 * REFERENCE_STD
    assert "reference's own uncertainty (its sigma_arcmin column, RMS 0.4 arcmin)" in held_out["text"]


def test_a_selfcal_file_read_back_carries_its_sigma(tmp_path):
    from encal.selfcal.steps import steps

    rng = np.random.default_rng(0)
    reference = np.arange(200) * 1.8
    reading = np.mod(reference + (9.0 * np.sin(np.radians(reference)) + rng.normal(0, 0.3, 200)) / 60.0, 360.0)
    result = steps(Calibration(reference, reading))
    path = tmp_path / "selfcal.csv"
    result.write(path)
    cal = read_calibration(path)
    np.testing.assert_allclose(cal.reference_std_arcmin, result.sigma_arcmin(cal.encoder_deg), rtol=1e-12)
    in_memory = result.calibration()
    np.testing.assert_allclose(in_memory.reference_std_arcmin, result.sigma_arcmin(in_memory.encoder_deg))
    assert encal.fit(cal).expected_rms_between_points() >= (1 - 1e-9) * np.sqrt(np.mean(cal.reference_std_arcmin**2))


def test_readings_of_one_angle_give_it_their_largest_reference_std():
    """Two points read at one encoder angle (repeats kept): the table takes the larger sigma there, not whichever
    np.interp's sort put last (0.1 of 0.1 and 3.0 here; fuzz7)."""
    encoder = np.r_[np.arange(0.0, 360.0, 10.0), 90.0]
    std = np.r_[np.full(36, 0.1), 0.1]
    std[9] = 3.0  # the first reading at 90 deg; the repeat at 90 deg says 0.1
    cal = Calibration(encoder, encoder, reference_std_arcmin=std)
    uncertainty = {"method": "given", "grid_step_deg": 1.0, "model_std_arcmin": [0.0] * 360, "noise_std_arcmin": 0.0}
    table = np.array(with_reference_uncertainty(uncertainty, cal)["model_std_arcmin"])
    assert table[90] == pytest.approx(3.0) and table[85] == pytest.approx(1.55)


def test_a_self_calibrations_reading_noise_makes_the_band_cover_new_readings(tmp_path):
    """noise9: a model of a spin's smoothed curve held no reading noise: its 95 % band covered about a quarter of a
    noisy encoder's new readings. With the noise the spin measured from its log (written with the curve, read back),
    the band covers them as it says, and the held-out estimate is a new reading's."""
    from encal.selfcal.spin import SpinLog, spin
    from encal.selfcal.synthetic import draw_magnetic_encoder, make_motor, simulate_spin

    encoder, motor = draw_magnetic_encoder(3), make_motor(rng=3)
    runs = [simulate_spin(motor, encoder, speed, revolutions=12, sample_rate_hz=1500.0, rng=seed)
            for speed, seed in ((1.0, 30), (3.0, 31))]
    path = tmp_path / "spin_cal.csv"
    spin([SpinLog(run.time_s, run.encoder_deg) for run in runs]).write(path, resolution_bits=14)
    cal = read_calibration(path)
    noise = cal.metadata["reading_noise_arcmin"]
    model = encal.fit(cal, method="auto", rng=0, uncertainty=True)
    assert model.uncertainty["reading_noise_arcmin"] == noise
    rng = np.random.default_rng(7)
    rotor = rng.uniform(0.0, 360.0, 2000)
    reading = encoder.read(rotor, rng)
    zero = float(np.mean(encoder.error_at_reading(np.arange(0.0, 360.0, 0.5))))
    error = ((reading - rotor + 180.0) % 360.0 - 180.0) * 60.0 - zero
    mean, std = model.predict(reading, return_std=True)
    inside = float(np.mean(np.abs(error - mean) <= 1.959964 * std))
    assert 0.92 <= inside <= 0.98  # 0.28 without the reading noise (the metadata removed)
    held_out = float(np.sqrt(np.mean((error - mean) ** 2)))
    assert model.expected_rms_between_points() == pytest.approx(held_out, rel=0.1)  # 2.07 for 2.05; 0.39 without

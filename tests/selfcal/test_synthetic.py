"""The self-calibration simulators: their truth is what they claim."""

import numpy as np
import pytest

from encal.selfcal.synthetic import (MagneticEncoder, draw_magnetic_encoder, draw_stepper, make_motor, simulate_spin,
                                    simulate_steps, simulate_sweep)


def test_error_at_reading_is_the_reading_minus_the_magnet_angle():
    encoder = draw_magnetic_encoder(3, eccentricity_deg=2.0)
    exact = MagneticEncoder(encoder.harmonics, noise_arcmin=0.0, bits=None)
    rotor = np.linspace(0, 360, 1000, endpoint=False)
    reading = exact.read(rotor)
    expected = ((reading - rotor + 180) % 360 - 180) * 60
    np.testing.assert_allclose(exact.error_at_reading(reading), expected, atol=1e-9)


def test_first_harmonic_is_the_eccentricity():
    encoder = draw_magnetic_encoder(3, eccentricity_deg=0.5)
    assert encoder.harmonics[0][:2] == (1, 30.0)
    assert all(amplitude < 30.0 for order, amplitude, _ in encoder.harmonics[1:])


def test_speed_ripple_falls_as_the_inverse_square_of_the_speed():
    motor = make_motor(7, 12, 1, cogging_nm=0.0, irregularity=0.0, unbalance_nm=1e-4)  # order-1 ripple only
    perfect = MagneticEncoder((), noise_arcmin=0.0, bits=None)
    ripple = []
    for speed in (2.0, 4.0):
        run = simulate_spin(motor, perfect, speed, revolutions=8, sample_rate_hz=800.0, rng=0)
        angle = np.unwrap(np.radians(run.rotor_deg))
        deviation = angle - np.polyval(np.polyfit(run.time_s, angle, 2), run.time_s)
        ripple.append(np.ptp(deviation))
    assert ripple[0] / ripple[1] == pytest.approx(4.0, rel=0.05)


def test_sweep_rotor_lags_by_the_friction_angle():
    motor = make_motor(7, 12, 1, cogging_nm=0.0, irregularity=0.0, field_distortion_deg_e=0.0)
    capture = simulate_sweep(motor, MagneticEncoder((), 0.0, None), rng=0)
    commanded = np.unwrap(capture.phase * 2 * np.pi / 65536) / 7
    lag = np.degrees(commanded - np.radians(capture.rotor_deg)) % (360 / 7)
    lag = np.where(lag > 180 / 7, lag - 360 / 7, lag)
    up = np.isin(capture.direction, (1, 3))
    expected = np.degrees(np.arcsin(motor.coulomb_nm / motor.holding_torque_nm)) / 7
    assert np.median(lag[up]) - np.median(lag[~up]) == pytest.approx(2 * expected, rel=1e-6)


def test_stepper_steps_follow_the_pattern_and_the_teeth():
    stepper = draw_stepper(2, pattern_arcmin=4.0, tooth_arcmin=1.0)
    k = np.arange(200)
    assert np.sqrt(np.mean(stepper.pattern_arcmin ** 2)) == pytest.approx(4.0)
    np.testing.assert_allclose(stepper.error_arcmin(k), stepper.pattern_arcmin[k % 4] + stepper.tooth_arcmin[k // 4])
    run = simulate_steps(stepper, MagneticEncoder((), 0.0, None), start_step=7, rng=0)
    np.testing.assert_array_equal(run.physical_step, (k + 7) % 200)
    np.testing.assert_allclose(run.calibration.encoder_deg, stepper.position_deg(k + 7) % 360, atol=1e-9)

"""Full-step self-calibration and the shift method, against the simulator's truth and on the real Mechaduino data."""

import warnings

import numpy as np
import pytest

from encal.data.calibration import Calibration, read_calibration
from encal._core.angles import wrap180
from encal._core.errors import CalibrationError, InputError
from encal.selfcal.synthetic import draw_magnetic_encoder, draw_stepper, simulate_steps
from encal.selfcal.steps import step_errors, steps
from tests.selfcal_truth import GRID, rms, truth_at_orders
from tests._paths import REAL_MECHADUINO as REAL

ENCODER = draw_magnetic_encoder(5, eccentricity_deg=0.5)
STEPPER = draw_stepper(6)


def _pair(turn, start_b=0):
    first = simulate_steps(STEPPER, ENCODER, rng=1)
    second = simulate_steps(STEPPER, ENCODER.turned(turn), start_step=start_b, rng=2)
    return first, second


@pytest.mark.parametrize("turn, start_b, options", [
    (137.5, 0, {}),                          # unknown turn, same start
    (60.0, 2, {}),                           # unknown turn, starts 2 steps apart (found from the 4-step pattern)
    (200.0, 33, {"turn_deg": 200.0}),        # known turn, any start
    (95.0, 150, {"step_shift": 150}),        # known start
])
def test_two_turned_calibrations_separate_encoder_and_stepper(turn, start_b, options):
    first, second = _pair(turn, start_b)
    result = steps(first.calibration, second.calibration, **options)
    assert result.details["turn_deg"] == pytest.approx(((turn + 180) % 360) - 180, abs=0.05)
    assert result.details["step_shift"] == start_b
    truth = truth_at_orders(ENCODER, result.series.orders)
    miss = result.error_arcmin(GRID) - truth
    assert rms(miss) <= 0.1 * rms(truth)
    assert np.mean(np.abs(miss) <= 2 * result.sigma_arcmin(GRID)) >= 0.9
    stepper_truth = first.stepper_error_arcmin - first.stepper_error_arcmin.mean()
    for key in ("stepper_error", "stepper_model"):
        estimate, sigma = result.details[key + "_arcmin"], result.details[key.replace("error", "sigma")
                                                                           .replace("model", "model_sigma")
                                                                           + "_arcmin"]
        assert rms(estimate - stepper_truth) <= 0.2 * rms(stepper_truth)
        assert np.mean(np.abs(estimate - stepper_truth) <= 2 * sigma) >= 0.9


def test_orders_the_turn_cannot_see_are_named():
    first, second = _pair(60.0)
    result = steps(first.calibration, second.calibration)
    assert "cannot see orders 6, 12" in result.confounded


def test_a_repeat_with_the_magnet_not_turned_separates_nothing():
    first, second = _pair(0.0, start_b=44)
    result = steps(first.calibration, second.calibration)
    assert result.details["step_shift"] == 44
    assert "not turned" in result.confounded and "repeats" in result.confounded


def test_one_calibration_removes_the_four_step_pattern():
    first, _ = _pair(0.0)
    result = steps(first.calibration)
    pattern = [float(v) for v in result.details["stepper_pattern_arcmin"].split(",")]
    assert np.allclose(pattern, STEPPER.pattern_arcmin, atol=0.5)
    assert "tooth" in result.confounded
    truth = truth_at_orders(ENCODER, result.series.orders)
    # what is left is the stepper's tooth errors (RMS 1 arcmin) and noise
    assert rms(result.error_arcmin(GRID) - truth) <= 0.1 * rms(truth)


def test_not_full_steps_is_refused():
    cal = Calibration(np.arange(0, 360, 1.8) + 0.3, np.arange(0, 360, 1.8))
    with pytest.raises(InputError, match="not the 200 full steps"):
        step_errors(cal, "x.csv")


def test_repeated_readings_at_the_full_steps_are_named_as_such():
    reference = np.repeat(np.arange(0, 360, 1.8), 2)
    cal = Calibration(reference, reference + np.tile([0.0, 0.01], 200))
    with pytest.raises(InputError, match=r"x.csv: has 400 readings at 200 reference angles; expected one reading per "
                                         r"full step \(--average-duplicates"):
        step_errors(cal, "x.csv")


@pytest.mark.skipif(not REAL.is_dir(), reason="real data not found")
def test_real_repeats_of_one_board_are_recognised_as_repeats():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        first = read_calibration(next(REAL.glob("mech_kaiwol_2016-10-20_b_*.csv")))
        second = read_calibration(next(REAL.glob("mech_kaiwol_2016-10-21_*.csv")))
    result = steps(first, second)
    assert result.details["step_shift"] == 156
    assert "not turned" in result.confounded
    # the two agree to a few arcmin (the README: repeats agree to about 0.02..0.03 deg)
    assert result.details["difference_residual_rms_arcmin"] < 2.0


def test_result_plots_itself_with_its_band():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    first, second = _pair(137.5)
    ax = steps(first.calibration, second.calibration).plot(truth_arcmin=ENCODER.error_at_reading)
    assert [line.get_label() for line in ax.get_lines()] == ["recovered (steps)", "true"]
    assert ax.get_xlabel() == "encoder reading / deg"
    plt.close(ax.figure)


def test_a_turn_that_is_not_a_number_is_refused():
    first, second = _pair(137.5)
    with pytest.raises(InputError, match=r"^The 'turn_deg' parameter of steps must be a finite number \(an angle in "
                                         r"degrees, or None\)\. Got nan instead\.$"):
        steps(first.calibration, second.calibration, turn_deg=float("nan"))


def _reversed_step_csv(path, turn_deg):
    """Full-step calibration (own physics, not encal's simulator) of an encoder counting against the stepper: the
    magnet at ``step + turn`` reads ``-(magnet) + e(-(magnet))``; the stepper's 4-step pattern and tooth errors are
    the same in both calibrations."""
    k = np.arange(200)
    stepper_arcmin = np.array([4.0, -2.0, -3.0, 1.0])[k % 4] + np.repeat(np.random.default_rng(9).normal(0, 1.5, 50), 4)
    shaft = k * 1.8 + stepper_arcmin / 60 + turn_deg
    reading = np.mod(-shaft + _reversed_error(-shaft) / 60, 360.0)
    path.write_text("reference_deg,encoder_deg\n" + "".join(f"{r!r},{e!r}\n" for r, e in
                                                            zip((k * 1.8).tolist(), reading.tolist())))
    return path


def _reversed_error(angle_deg):
    a = np.radians(angle_deg)
    return 9 * np.cos(a + 0.3) + 3 * np.cos(2 * a + 1.1) + 1.2 * np.cos(4 * a - 0.7)


def test_a_reversed_encoder_written_and_fitted_corrects_toward_the_truth(tmp_path):
    # Read with --reverse, the result is of the negated reading; it was written as if of the raw one, so a plain
    # `encal fit` of it took the mirror image: the corrected readings were 12.4 arcmin RMS off, the raw ones 6.8.
    import encal
    from encal.deploy import Compensator

    first = read_calibration(_reversed_step_csv(tmp_path / "a.csv", 0.0), reverse=True)
    second = read_calibration(_reversed_step_csv(tmp_path / "b.csv", 137.5), reverse=True)
    result = steps(first, second)
    result.write(tmp_path / "cal.csv")
    with pytest.raises(CalibrationError, match="--reverse"):  # the raw readings decrease: refused without --reverse
        read_calibration(tmp_path / "cal.csv")
    comp = Compensator(encal.fit(read_calibration(tmp_path / "cal.csv", reverse=True)))
    raw = np.arange(0.0, 360.0, 0.25)
    magnet = -raw
    for _ in range(50):  # the magnet angle whose reading is raw: raw = -magnet + e(-magnet)/60
        magnet = -(raw - _reversed_error(-magnet) / 60)
    gap = (np.mod(comp.correct(raw) - magnet + 180.0, 360.0) - 180.0) * 60
    assert rms(gap - gap.mean()) < 1.0  # 0.22 arcmin: noise-free readings, the tooth errors cancelled
    assert result.reading_sign == -1
    assert "fit the calibration written with --reverse" in result.summary()
    with pytest.raises(InputError, match="reverse"):
        steps(first, Calibration(second.reference_deg, -second.encoder_deg))  # one reversed, one not


def _lookup(export):
    """The 16384 angles of a Mechaduino export, degrees."""
    body = export.text[export.text.index("{") + 1:export.text.rindex("}")]
    return np.array([float(cell) for cell in body.replace("\n", "").split(",")])


@pytest.mark.parametrize("reverse", [False, True])
def test_the_first_calibrations_step_zero_is_stated_in_the_frame_written(tmp_path, reverse):
    # users7: the calibration written has reference = reading - error/60, whose zero is the encoder's, not the
    # stepper's. A Mechaduino table exported from it with --step-zero 0 (right for the stepper's own calibration)
    # was turned by the encoder's zero offset: 49.99 deg, 27.8 full steps, on a real board (its commutation off).
    import encal
    from encal.deploy.firmware.mechaduino import export_mechaduino

    k = np.arange(200)
    shaft = k * 1.8 + 59.3  # the magnet's angle at full step k: the encoder's zero is 59.3 deg from the stepper's
    reading = shaft + _reversed_error(shaft) / 60
    counts = np.round(np.mod(-reading if reverse else reading, 360.0) * 16384 / 360) % 16384
    path = tmp_path / "a.csv"
    path.write_text("reference_deg,encoder_deg\n" + "".join(f"{r!r},{c * 360 / 16384!r}\n"
                                                            for r, c in zip((k * 1.8).tolist(), counts.tolist())))
    first = read_calibration(path, reverse=reverse)
    result = steps(first)
    step_zero = result.details["step_zero_deg"]
    assert step_zero == pytest.approx(59.3, abs=0.005)
    assert f"--step-zero {step_zero:.4f}" in result.summary()
    result.write(tmp_path / "cal.csv")
    assert f"--step-zero {step_zero:.4f}" in (tmp_path / "cal.csv").read_text()
    selfcal_model = encal.fit(read_calibration(tmp_path / "cal.csv", reverse=reverse))
    direct_model = encal.fit(first, method="fourier")  # the stepper's own frame: --step-zero 0
    gap = wrap180(_lookup(export_mechaduino(selfcal_model, step_zero_deg=step_zero))
                  - _lookup(export_mechaduino(direct_model, step_zero_deg=0.0))) * 60
    assert np.sqrt(np.mean(gap ** 2)) < 0.5  # arcmin; 3558 with --step-zero 0


@pytest.mark.parametrize("noise_arcmin", [2.0, 0.5])  # 0.5: 0.38 of a 14-bit code, the rounding 0.38 arcmin
@pytest.mark.parametrize("turn", [137.5, 0.0])  # the magnet turned, and a repeat
def test_two_calibrations_of_single_reads_measure_one_readings_noise(noise_arcmin, turn):
    """sweepnoise: the difference of two calibrations, the stepper's error cancelled in it, measures one
    calibration point's noise; with one read per step (single_reads) that is a new reading's, with the 14-bit
    rounding. Over 24 seeds (turned) the estimate / truth was 0.99 +- 0.055 at 2 and at 0.5 arcmin (mean +- sd; 200
    points): within 18 % each (3.3 sd), 8 % on the mean of 4."""
    ratios = []
    for seed in range(4):
        encoder, stepper = draw_magnetic_encoder(seed, noise_arcmin=noise_arcmin), draw_stepper(seed)
        first = simulate_steps(stepper, encoder, readings_per_step=1, rng=seed).calibration
        second = simulate_steps(stepper, encoder.turned(turn), readings_per_step=1, rng=seed + 100).calibration
        result = steps(first, second, single_reads=True)
        truth = np.hypot(noise_arcmin, 21600.0 / 2**14 / np.sqrt(12.0))
        ratios.append(result.reading_noise_arcmin / truth)
        assert result.calibration().metadata["reading_noise_arcmin"] == result.reading_noise_arcmin
        assert steps(first, second).reading_noise_arcmin is None  # not said to be single reads: not recorded
    assert np.all(np.abs(np.array(ratios) - 1) < 0.18), ratios
    assert abs(np.mean(ratios) - 1) < 0.08, ratios


def test_the_mean_of_several_reads_a_step_is_not_taken_for_one_readings_noise():
    """A Mechaduino's point is the mean of 10 reads: its noise (measured, in the details) is not a new reading's,
    which is not recorded; one calibration cannot measure it (its tooth errors are confounded with its noise)."""
    first, second = _pair(137.5)  # 10 reads a step, 2 arcmin: one read 2.04 arcmin, a point about 0.75
    result = steps(first.calibration, second.calibration)
    assert result.reading_noise_arcmin is None and "reading_noise_arcmin" not in result.calibration().metadata
    assert 0.5 < result.details["calibration_point_noise_arcmin"] < 1.0
    assert "reading noise: not measured: a full-step calibration's point" in result.summary()
    assert steps(first.calibration).reading_noise_arcmin is None
    with pytest.raises(InputError, match="single_reads needs a second calibration"):
        steps(first.calibration, single_reads=True)

"""Isolated points: found where a reading is far off both sides, and nowhere else."""

import warnings

import numpy as np
import pytest

import encal
from encal._core.errors import EncalWarning
from encal.analysis.outliers import ISOLATION_FACTOR, isolated_points
from encal.simulate import demo_fleet

THETA = np.arange(0.0, 360.0, 10.0)


def smooth_profile(seed=1):
    rng = np.random.default_rng(seed)
    return 3.0 * np.sin(np.radians(THETA)) + 0.9 * np.cos(np.radians(2 * THETA)) + rng.normal(0.0, 0.1, THETA.size)


def test_a_misread_point_is_found_with_its_deviation():
    error = smooth_profile()
    error[7] = 500.0
    found = isolated_points(THETA, error)
    assert found.index.tolist() == [7]
    left, right = error[7] - (error[5] + error[6]) / 2, error[7] - (error[8] + error[9]) / 2
    assert found.deviation_arcmin[0] == pytest.approx(min(left, right), abs=1e-12)
    assert found.deviation_arcmin[0] > ISOLATION_FACTOR * found.typical_step_arcmin


def test_points_are_neighbours_by_angle_round_the_circle_whatever_the_order():
    error = smooth_profile()
    error[0] = -200.0  # its neighbours on the left are the last two angles, 340 and 350 degrees
    order = np.random.default_rng(3).permutation(THETA.size)
    found = isolated_points(THETA[order], error[order])
    assert found.index.tolist() == [int(np.flatnonzero(order == 0)[0])]
    assert found.deviation_arcmin[0] < -190.0


def test_a_step_is_not_isolated():
    error = smooth_profile()
    error[10:20] += 40.0  # a 40 arcmin plateau: every point agrees with one side
    assert isolated_points(THETA, error).index.size == 0


def test_the_alternation_of_full_steps_is_not_isolated():
    theta = np.arange(200) * 1.8
    error = 5.0 * np.sin(np.radians(theta)) + 4.0 * (-1.0) ** np.arange(200)
    assert isolated_points(theta, error).index.size == 0


def test_a_one_lsb_blip_on_a_flat_quantised_profile_is_not_isolated():
    lsb = 21600.0 / 2**14
    error = np.zeros(100)
    error[40] = lsb
    assert isolated_points(np.arange(100) * 3.6, error).index.size == 0  # the smallest step is the quantum
    assert isolated_points(np.arange(100) * 3.6, error, quantum_arcmin=lsb).index.size == 0


@pytest.mark.parametrize("theta, error", [(THETA, np.full(THETA.size, 2.0)), (THETA[:7], np.arange(7.0))])
def test_constant_profiles_and_few_points_have_none(theta, error):
    assert isolated_points(theta, error).index.size == 0


def test_the_demo_fleet_has_none():
    for member in demo_fleet():
        for run in (member.train, member.test):
            cal = run.calibration
            assert isolated_points(cal.encoder_deg, cal.errors_arcmin).index.size == 0


def test_no_real_calibration_has_one(real_data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("error", EncalWarning)
        for path in sorted(real_data_dir.glob("mech_*.csv")):
            encal.read_calibration(path)


def write_calibration(path, reference, encoder, direction=None):
    rows = ["reference_deg,encoder_deg" + (",direction" if direction is not None else "")]
    for i, (r, e) in enumerate(zip(reference, encoder)):
        rows.append(f"{float(r)!r},{float(e)!r}" + (f",{int(direction[i]):+d}" if direction is not None else ""))
    path.write_text("# a comment line\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_reading_a_file_warns_with_the_line(tmp_path):
    error = smooth_profile()
    error[7] = 500.0
    path = write_calibration(tmp_path / "cal.csv", THETA - error / 60.0, THETA)
    with pytest.warns(EncalWarning) as caught:
        encal.read_calibration(path)
    (message,) = [str(w.message) for w in caught]
    assert message.startswith(f"{path}: line 10 (encoder 70.000 deg) has an error of 500 arcmin, ")
    assert message.endswith("a misread? It pulls every model towards it, and one that passes through the calibrated "
                            "points (a lookup table with a node at each, a network) follows it; measure it again or "
                            "remove the line")


def test_each_direction_is_judged_on_its_own(tmp_path):
    # Forward and reverse readings interleaved, 3 arcmin of hysteresis apart: no point is isolated.
    theta = np.repeat(THETA, 2)
    direction = np.tile([1, -1], THETA.size)
    error = np.repeat(smooth_profile(), 2) + 1.5 * direction
    path = write_calibration(tmp_path / "bi.csv", theta - error / 60.0, theta, direction)
    with warnings.catch_warnings():
        warnings.simplefilter("error", EncalWarning)
        encal.read_calibration(path)
    error[2 * 7 + 1] = -400.0  # a misread reverse reading at 70 degrees
    path = write_calibration(tmp_path / "bi.csv", theta - error / 60.0, theta, direction)
    with pytest.warns(EncalWarning, match=r"line 18 \(encoder 70\.000 deg\) has an error of -400 arcmin"):
        encal.read_calibration(path)


def test_identical_repeated_rows_are_no_misreads(write_csv):
    """Identical repeated rows are accepted (docs/robustness.md); their zero steps once shrank the typical
    step until smooth points were called misreads (issue 17, item 12)."""
    from tests.conftest import grid_csv

    lines = grid_csv(error=lambda r: (2 * np.sin(np.radians(r)) + 0.3 * np.sin(np.radians(16 * r))) / 60).splitlines()
    rows = [lines[0]] + [line for line in lines[1:121] for _ in range(3)] + lines[121:]
    path = write_csv("\n".join(rows) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", EncalWarning)
        assert len(encal.read_calibration(path)) == 420


def test_a_misread_among_repeated_rows_is_still_found():
    theta = np.repeat(np.arange(0.0, 360.0, 10.0), 2)
    error = np.sin(np.radians(theta))
    error[14:16] = 50.0  # one angle, read twice, both times wrong
    found = isolated_points(theta, error)
    assert found.index.tolist() == [14]


def dense_sweep(revolutions=50, stops=200, noise=0.1, seed=0):
    """A continuous sweep: every stop read once per revolution, with a smooth profile and Gaussian noise."""
    rng = np.random.default_rng(seed)
    reference = np.tile(np.arange(stops) * 360.0 / stops, revolutions)
    error = (3.0 * np.sin(np.radians(reference)) + 0.3 * np.cos(np.radians(16 * reference))
             + rng.normal(0.0, noise, reference.size))
    return reference, error


def test_a_clean_dense_sweep_has_no_misread():
    """Sorted by encoder angle, a stop's 50 readings came in the order of their errors: the typical step
    shrank to 0.008 arcmin and 93 clean readings of 10,000 were called misreads."""
    reference, error = dense_sweep()
    found = isolated_points(reference + error / 60.0, error, reference_deg=reference)
    assert found.index.size == 0
    assert found.typical_step_arcmin == pytest.approx(0.1, rel=0.05)  # the noise's standard deviation


@pytest.mark.parametrize("revolutions, stops", [(50, 200), (5, 2000), (2, 5000), (3, 3000)])
def test_one_wild_reading_among_repeated_readings_is_found(revolutions, stops):
    reference, error = dense_sweep(revolutions, stops)
    error[1234] += 30.0
    found = isolated_points(reference + error / 60.0, error, reference_deg=reference)
    assert found.repeated
    assert found.index.tolist() == [1234]
    # From the median of the stop's readings: of two, their mean (the other is named by the neighbours).
    assert found.deviation_arcmin[0] == pytest.approx(15.0 if revolutions == 2 else 30.0, abs=0.6)


def test_a_wild_reading_at_a_stop_read_once_is_found():
    reference, error = dense_sweep(5, 2000)
    keep = np.ones(reference.size, dtype=bool)
    keep[2000 + 700::2000] = False  # stop 700 read in the first revolution only
    reference, error = reference[keep], error[keep]
    error[700] -= 30.0
    found = isolated_points(reference + error / 60.0, error, reference_deg=reference)
    assert found.index.tolist() == [700]
    assert found.deviation_arcmin[0] == pytest.approx(-30.0, abs=0.6)


def test_a_dense_file_warns_with_the_line_and_what_the_reading_is_off(tmp_path):
    reference, error = dense_sweep()
    path = write_calibration(tmp_path / "dense.csv", reference, reference + error / 60.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", EncalWarning)
        assert len(encal.read_calibration(path)) == reference.size
    error[4321] += 20.0  # a third of a degree: more would fold the encoder back past the next stops
    path = write_calibration(tmp_path / "dense.csv", reference, reference + error / 60.0)
    with pytest.warns(EncalWarning) as caught:
        encal.read_calibration(path)
    (message,) = [str(w.message) for w in caught]
    assert message.startswith(f"{path}: line 4324 (encoder {reference[4321] + error[4321] / 60:.3f} deg) has an "
                              f"error of {error[4321]:.4g} arcmin, ")
    assert " arcmin off the median of the readings at its reference angle, over 10 times the readings' typical " \
           "spread of 0.0994 arcmin: a misread?" in message
    assert "and 1 more" not in message

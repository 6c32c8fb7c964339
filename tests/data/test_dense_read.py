"""Dense files at NumPy speed (issue 30): the checks vectorised around one sort, and "the same stop" decided
by the data's own grid, not by 9 decimals."""

import numpy as np
import pytest

from encal.data.calibration import read_calibration
from encal._core.errors import CalibrationError
from encal.analysis.outliers import _first_of_identical


def _write(path, reference, encoder):
    path.write_text("reference_deg,encoder_deg\n" + "".join(f"{r:.10f},{e:.10f}\n" for r, e in zip(reference, encoder)))
    return path


def _readings(reference, rng):
    return np.mod(reference + 0.05 * np.sin(np.radians(reference)) + rng.normal(0.0, 1e-3, reference.size), 360.0)


def test_two_random_angles_equal_to_ten_decimals_are_no_stop(tmp_path):
    # a continuous reference (random angles): an equal pair is a coincidence of the decimals, kept as it is
    rng = np.random.default_rng(0)
    reference = rng.uniform(0.0, 360.0, 20_000)
    reference[7] = reference[11_000]
    cal = read_calibration(_write(tmp_path / "random.csv", reference, _readings(reference, rng)))
    assert len(cal) == reference.size


def test_a_stray_repeat_on_a_grid_is_still_refused(tmp_path):
    rng = np.random.default_rng(1)
    reference = np.r_[np.arange(0.0, 360.0, 0.5), 90.0]
    with pytest.raises(CalibrationError, match=r"reference angle 90 deg appears more than once"):
        read_calibration(_write(tmp_path / "grid.csv", reference, _readings(reference, rng)))


def test_average_duplicates_vectorised(tmp_path):
    reference = np.r_[np.arange(0.0, 360.0, 10.0), 20.0, 20.0, 350.0]
    encoder = np.r_[np.arange(0.0, 360.0, 10.0), 20.3, 20.6, 349.0]
    cal = read_calibration(_write(tmp_path / "avg.csv", reference, encoder), duplicates="average")
    assert len(cal) == 36 and cal.metadata["averaged_duplicates"] == 3
    np.testing.assert_allclose(cal.encoder_deg[[2, 35]], [20.3, 349.5], atol=1e-9)
    np.testing.assert_array_equal(cal.reference_deg, np.arange(0.0, 360.0, 10.0))


def test_identical_points_across_the_wrap_with_a_shared_sort():
    theta = np.r_[359.99999999996, 0.0, np.arange(10.0, 110.0, 10.0)]
    error = np.r_[1.0, 1.0, np.zeros(10)]
    expected = np.r_[0, np.arange(2, 12)]
    np.testing.assert_array_equal(_first_of_identical(theta, error), expected)
    np.testing.assert_array_equal(_first_of_identical(theta, error, np.argsort(theta, kind="stable")), expected)


@pytest.mark.parametrize("values", [np.random.default_rng(2).uniform(0, 360, 5000),
                                    np.round(np.random.default_rng(3).uniform(0, 360, 5000), 0),
                                    np.repeat([3.0, 1.0, 2.0], 7), np.zeros(5), np.array([1.0])])
def test_stable_argsort_is_numpys_stable_order(values):
    from encal._core.sorting import stable_argsort

    np.testing.assert_array_equal(stable_argsort(values), np.argsort(values, kind="stable"))

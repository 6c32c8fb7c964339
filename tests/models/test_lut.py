"""Lookup-table error model (encal.models.lut)."""

import bisect
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.interpolate import PPoly

import encal
from encal._core.angles import wrap360
from encal._core.errors import InputError, ModelFileError
from encal.models import model_kind
from encal.models.lut import LookupTableModel, fit_lut

INTERPOLATIONS = ["linear", "cubic"]


def evaluate_from_parameters(parameters, theta_deg):
    """docs/model-file.md's recipe, written out independently: map, bisect, Horner."""
    breaks, rows = parameters["breaks_deg"], parameters["coefficients"]
    values = []
    for theta in np.atleast_1d(theta_deg):
        x = breaks[0] + (theta - breaks[0]) % 360.0
        i = min(max(bisect.bisect_right(breaks, x) - 1, 0), len(breaks) - 2)
        value = 0.0
        for row in rows:
            value = value * (x - breaks[i]) + row[i]
        values.append(value)
    return np.array(values)


def scattered_profile(seed, n=90):
    """Noise at n irregular angles, shuffled: a grid of n cells, one angle anywhere in the first half of
    each cell, so neighbours are 0.5 to 1.5 cells apart (never close enough for the cubic table to merge)."""
    rng = np.random.default_rng(seed)
    theta = (np.arange(n) + rng.uniform(0.0, 0.5, n)) * (360.0 / n)
    return rng.permutation(theta), rng.normal(0.0, 2.0, n)


@pytest.mark.parametrize("interpolation", INTERPOLATIONS)
@pytest.mark.parametrize("seed", range(3))
def test_table_reproduces_the_calibration_points_exactly(interpolation, seed):
    theta, errors = scattered_profile(seed)  # unsorted, irregular
    model = fit_lut(theta, errors, interpolation=interpolation)
    assert np.array_equal(model.predict(theta), errors)
    assert model.training == {"interpolation": interpolation, "n_entries": 90}


@pytest.mark.parametrize("interpolation", INTERPOLATIONS)
def test_repeated_angles_become_one_entry_with_their_mean(interpolation):
    theta = [10.0, 100.0, 10.0, 200.0, 370.0]  # 370 wraps onto 10
    errors = [1.0, 5.0, 2.0, -1.0, 6.0]
    model = fit_lut(theta, errors, interpolation=interpolation)
    assert model.table_deg.tolist() == [10.0, 100.0, 200.0]
    assert model.table_arcmin.tolist() == [3.0, 5.0, -1.0]
    assert model.predict(10.0) == 3.0


def test_cubic_table_merges_readings_far_closer_than_their_spacing():
    # A 2° grid plus a second reading 1 LSB of a 24-bit encoder after 90°, 0.5 arcmin apart: through both,
    # the spline would take a slope of 0.5 arcmin per 2e-5° and swing by thousands of arc-minutes.
    theta = np.arange(0.0, 360.0, 2.0)
    errors = np.sin(np.radians(theta))
    extra = 90.0 + 360.0 / 2**24
    cubic = fit_lut(np.r_[theta, extra], np.r_[errors, errors[45] + 0.5], interpolation="cubic")
    assert cubic.training["n_entries"] == 180
    assert cubic.predict((90.0 + extra) / 2) == pytest.approx(errors[45] + 0.25, abs=1e-9)
    dense = np.linspace(0.0, 360.0, 72001)
    assert np.abs(cubic.predict(dense)).max() < 1.3
    linear = fit_lut(np.r_[theta, extra], np.r_[errors, errors[45] + 0.5], interpolation="linear")
    assert linear.training["n_entries"] == 181 and linear.predict(extra) == errors[45] + 0.5


def test_cubic_table_of_dense_random_readings_stays_near_the_data():
    rng = np.random.default_rng(1)  # any seed: 2000 uniform angles always hold pairs 1e-3 of a spacing apart
    theta = rng.uniform(0.0, 360.0, 2000)
    errors = 3.0 * np.sin(np.radians(theta)) + rng.normal(0.0, 0.1, theta.size)
    model = fit_lut(theta, errors, interpolation="cubic")
    assert model.training["n_entries"] < 2000
    assert np.abs(model.predict(np.linspace(0.0, 360.0, 360001))).max() < 2.0 * np.abs(errors).max()


def test_a_run_of_close_readings_across_zero_becomes_one_entry():
    theta = np.r_[359.99995, 0.00001, np.arange(2.0, 360.0, 2.0)]
    errors = np.r_[1.0, 2.0, np.zeros(179)]
    model = fit_lut(theta, errors, interpolation="cubic")
    assert model.training["n_entries"] == 180
    assert model.table_deg[-1] == pytest.approx(359.99998, abs=1e-9)
    assert model.predict(359.99998) == pytest.approx(1.5, abs=1e-9)


def test_linear_table_interpolates_across_the_wrap():
    model = fit_lut([350.0, 10.0, 180.0], [2.0, 4.0, 0.0])
    assert model.predict(0.0) == pytest.approx(3.0)
    assert model.predict(355.0) == pytest.approx(2.5)
    assert model.predict(-5.0) == pytest.approx(2.5)
    assert model.predict(5.0) == pytest.approx(3.5)


@pytest.mark.parametrize("seed", range(5))
def test_linear_table_is_exact_for_piecewise_linear_periodic_data(seed):
    rng = np.random.default_rng(seed)
    knots = np.sort(rng.choice(np.arange(0.0, 360.0, 2.0), size=12, replace=False))
    heights = rng.normal(0.0, 3.0, knots.size)

    def truth(theta):
        return np.interp(np.mod(theta, 360.0), knots, heights, period=360.0)

    grid = rng.permutation(np.arange(0.0, 360.0, 2.0))  # contains every knot; unsorted
    model = fit_lut(grid, truth(grid), interpolation="linear")
    anywhere = rng.uniform(-360.0, 720.0, 2000)
    assert_allclose(model.predict(anywhere), truth(anywhere), rtol=0, atol=1e-12)


def test_cubic_table_recovers_a_smooth_profile_within_the_spline_bound():
    """A periodic cubic spline through samples h apart is within (5/384) h^4 max|f''''| of f."""
    orders = np.array([1, 2, 4, 16])
    cos = np.array([3.0, -1.0, 0.5, 0.2])
    sin = np.array([1.0, 2.0, 0.0, -0.3])

    def truth(theta_deg):
        phase = np.radians(np.multiply.outer(theta_deg, orders))
        return np.cos(phase) @ cos + np.sin(phase) @ sin

    h = 2.0
    fourth_derivative = np.sum(np.hypot(cos, sin) * np.radians(orders) ** 4)  # arcmin / deg^4
    bound = 5.0 / 384.0 * h**4 * fourth_derivative
    grid = np.arange(0.0, 360.0, h)
    model = fit_lut(grid, truth(grid), interpolation="cubic")
    dense = np.linspace(-10.0, 370.0, 20001)
    worst = np.max(np.abs(model.predict(dense) - truth(dense)))
    assert worst <= bound
    assert bound < 0.002  # arcmin: the bound is a meaningful one
    linear = fit_lut(grid, truth(grid), interpolation="linear")
    assert np.max(np.abs(linear.predict(dense) - truth(dense))) > 10 * worst


@pytest.mark.parametrize("interpolation", INTERPOLATIONS)
def test_table_is_continuous_across_zero_and_every_break(interpolation):
    theta, errors = scattered_profile(9, n=40)
    model = fit_lut(theta, errors, interpolation=interpolation)
    slope = 1e3  # arcmin/deg, far above what these tables reach
    for x in np.r_[model.breaks_deg, 0.0, 360.0]:
        assert model.predict(x - 1e-9) == pytest.approx(float(model.predict(x + 1e-9)), abs=slope * 2e-9)


@pytest.mark.parametrize("interpolation", INTERPOLATIONS)
def test_parameters_follow_the_model_file_layout_and_round_trip(interpolation):
    theta, errors = scattered_profile(2, n=30)
    model = fit_lut(theta, errors, interpolation=interpolation)
    parameters = json.loads(json.dumps(model.parameters()))
    assert parameters["interpolation"] == interpolation
    breaks = parameters["breaks_deg"]
    assert breaks == sorted(breaks) and breaks[-1] == breaks[0] + 360.0 and len(breaks) == 31
    assert np.shape(parameters["coefficients"]) == ({"linear": 2, "cubic": 4}[interpolation], 30)
    angles = np.random.default_rng(0).uniform(-400.0, 400.0, 300)
    assert_allclose(evaluate_from_parameters(parameters, angles), model.predict(angles), rtol=0, atol=1e-9)
    again = LookupTableModel.from_parameters(parameters)
    assert np.array_equal(again.predict(angles), model.predict(angles))
    assert model_kind("lut").model_class is LookupTableModel


@settings(max_examples=60, deadline=None)
@given(theta=st.floats(-1e4, 1e4, allow_nan=False), turns=st.integers(-5, 5),
       interpolation=st.sampled_from(INTERPOLATIONS))
def test_prediction_is_periodic(theta, turns, interpolation):
    angles = np.arange(0.0, 360.0, 10.0)
    model = fit_lut(angles, np.cos(np.radians(3 * angles)) * 5.0, interpolation=interpolation)
    # θ + 360 k and θ round differently; the table's slope is below 1 arcmin/deg.
    tolerance = 1e-12 * max(1.0, abs(theta) + 360.0 * abs(turns))
    assert model.predict(theta + 360.0 * turns) == pytest.approx(float(model.predict(theta)), abs=tolerance)


@pytest.mark.parametrize("interpolation", INTERPOLATIONS)
def test_one_or_two_points_make_a_valid_table(interpolation):
    assert fit_lut([42.0], [1.5], interpolation=interpolation).predict([0.0, 200.0]).tolist() == [1.5, 1.5]
    model = fit_lut([0.0, 180.0], [1.0, -1.0], interpolation=interpolation)
    assert model.predict(180.0) == -1.0 and model.predict(360.0) == 1.0


def test_fit_and_model_check_their_inputs():
    with pytest.raises(InputError, match="'interpolation' parameter of fit_lut"):
        fit_lut([0.0, 90.0], [0.0, 1.0], interpolation="quadratic")
    with pytest.raises(InputError, match="fit_lut expects one error per encoder angle"):
        fit_lut([0.0, 90.0], [0.0])
    with pytest.raises(InputError, match="fit_lut expects at least one"):
        fit_lut([], [])
    with pytest.raises(InputError, match="spanning exactly 360"):
        LookupTableModel([0.0, 180.0], [[0.0], [1.0]], "linear")
    with pytest.raises(InputError, match="coefficients of shape"):
        LookupTableModel([0.0, 360.0], [[0.0], [1.0]], "cubic")


def test_invalid_parameters_are_a_model_file_error():
    with pytest.raises(ModelFileError, match="lut model parameters"):
        LookupTableModel.from_parameters({"interpolation": "linear", "breaks_deg": [0.0, 360.0]})
    with pytest.raises(ModelFileError, match="lut model parameters"):
        LookupTableModel.from_parameters({"interpolation": "linear", "breaks_deg": [0.0, 360.0],
                                          "coefficients": [[0.0, 1.0]]})


def test_save_and_load_give_the_same_model(tmp_path):
    model = fit_lut(*scattered_profile(8), interpolation="cubic")
    model.encoder = {"name": "enc1", "resolution_bits": 16}
    model.save(tmp_path / "enc1.json")
    again = encal.load_model(tmp_path / "enc1.json")
    angles = np.random.default_rng(0).uniform(-720.0, 720.0, 500)
    assert type(again) is type(model)
    assert np.array_equal(again.predict(angles), model.predict(angles))
    assert again.parameters() == model.parameters()


# ------------------------------------------------------------------ pieces by index arithmetic

def _tables(seed):
    """Uniform and random breaks (several origins), linear and cubic, with -0.0 among the coefficients."""
    rng = np.random.default_rng(seed)
    for number, first in enumerate([0.0, 0.3, -5.0, 17.25, 359.5]):
        for breaks in (first + np.arange(0.0, 360.0, [2.0, 1.0, 5.0, 0.7, 120.0][number]),
                       first + np.unique(np.concatenate(([0.0], rng.uniform(0.0, 360.0, rng.integers(1, 400)))))):
            breaks = np.append(breaks, breaks[0] + 360.0)
            breaks = breaks[np.concatenate((np.diff(breaks) > 1e-6, [True]))]
            for interpolation, degree in (("linear", 1), ("cubic", 3)):
                coefficients = rng.normal(size=(degree + 1, breaks.size - 1))
                coefficients[:, :2] = -0.0
                yield LookupTableModel(breaks, coefficients, interpolation)


@pytest.mark.parametrize("seed", [0, 1])
def test_pieces_found_by_index_arithmetic_give_ppoly_bit_for_bit(seed):
    """The model's own evaluation equals SciPy's PPoly (the bisection it replaced), to the last bit and the
    sign of zero, at random angles, at every break, one ulp either side of it, and a turn away."""
    rng = np.random.default_rng(seed)
    for model in _tables(seed):
        breaks = model.breaks_deg
        theta = np.concatenate((rng.uniform(-400.0, 760.0, 5000), breaks, np.nextafter(breaks, -np.inf),
                                np.nextafter(breaks, np.inf), breaks + 360.0, breaks - 360.0, [0.0, -0.0]))
        wrapped = wrap360(theta)  # what predict evaluates the table at: PPoly there, as before
        inside = wrapped - 360.0 * np.floor((wrapped - breaks[0]) / 360.0)
        ppoly = PPoly(model.coefficients, breaks, extrapolate=True)
        np.testing.assert_array_equal(model.predict(theta).view(np.int64), ppoly(inside).view(np.int64))
        expected = np.clip(np.searchsorted(breaks, inside, side="right") - 1, 0, breaks.size - 2)
        np.testing.assert_array_equal(model._pieces.locate(inside), expected)


@pytest.mark.parametrize("interpolation", INTERPOLATIONS)
def test_a_dense_sweep_is_binned_the_same_whatever_the_last_bit_of_its_angles(interpolation):
    """A table binned from over 4096 angles has its bins' edges on every 4th code of a 14-bit encoder (every code of
    a 12-bit one). The same code read in radians or from (-180, 180] comes back a hair (1e-14 degree) below its edge:
    it went to the bin below, and the table moved by the readings' scatter (2.7 arcmin here; 0.27 arcmin on a 3-turn
    sweep of a 14-bit encoder in radians, benchmarks/truth_variants.py). An angle within 1e-9 degree of an edge is
    the edge's, as distinct_angles makes it one angle with it."""
    rng = np.random.default_rng(0)
    codes = rng.integers(0, 2**14, 6000)
    codes[:3] = 0  # code 0 too, read as 0.0 and as a hair below 360
    theta = codes * (360.0 / 2**14)
    error = rng.normal(0.0, 1.0, theta.size)
    below = np.where(codes % 4 == 0, theta - 3e-14, theta)
    below[1] = 360.0 - 3e-14
    plain, perturbed = fit_lut(theta, error, interpolation=interpolation), fit_lut(below % 360.0, error,
                                                                                   interpolation=interpolation)
    assert plain.training["binned_from_angles"] == perturbed.training["binned_from_angles"] > 4096
    assert plain.training["n_entries"] == perturbed.training["n_entries"]
    x = np.arange(0.0, 360.0, 0.01)
    assert np.max(np.abs(plain.predict(x) - perturbed.predict(x))) < 1e-9

"""One message template for every bad parameter (encal._core.parameters)."""

import numpy as np
import pytest

import encal
import encal.data.reversal
import encal.reports.encoder
import encal.analysis.outliers
from encal.selfcal import spin, steps, sweep
from encal.data.calibration import write_calibration
from encal._core.errors import InputError
from encal.models.stack import fit_stack
from encal._core.parameters import check_bool, check_choice, check_int, check_number, check_seed, invalid, real_array

GRID = np.arange(0.0, 360.0, 2.0)


@pytest.mark.parametrize(("check", "value", "expected"), [
    (lambda v: check_int(v, "hidden", "fit", low=1), 0, "an int >= 1"),
    (lambda v: check_int(v, "hidden", "fit", low=1), True, "an int >= 1"),
    (lambda v: check_int(v, "folds", "fit_auto", low=2, high=9, note="4 angles per fold"), 10,
     "an int from 2 to 9 (4 angles per fold)"),
    (lambda v: check_number(v, "tolerance", "fit_auto", low=0.0, high=1.0, high_open=True), 1.0,
     "a finite number in [0, 1)"),
    (lambda v: check_number(v, "k", "coverage", low=0.0, low_open=True), float("inf"), "a finite number > 0"),
    (lambda v: check_choice(v, "interpolation", "fit_lut", ("linear", "cubic")), "spline",
     "one of 'linear', 'cubic'"),
    (lambda v: check_choice(v, "interpolation", "fit_lut", {"linear": 1}), ["linear"], "one of 'linear'"),
    (lambda v: check_bool(v, "stack", "fit_auto"), 1, "True or False"),
    (lambda v: check_seed(v, "rng", "fit"), -1, "None, an int >= 0 or a numpy.random.Generator"),
])
def test_every_check_says_parameter_function_expectation_and_value(check, value, expected):
    with pytest.raises(InputError) as info:
        check(value)
    name, caller = str(info.value).split("'")[1], str(info.value).split(" parameter of ")[1].split(" ")[0]
    assert str(info.value) == str(invalid(name, caller, expected, value))
    assert str(info.value).endswith(f"Got {value!r} instead.")


def test_good_values_come_back_in_the_form_the_caller_uses():
    assert check_int(np.int64(3), "n", "f", low=1) == 3 and type(check_int(np.int64(3), "n", "f")) is int
    assert check_number(np.float32(0.5), "x", "f", low=0.0) == 0.5
    generator = np.random.default_rng(0)
    assert check_seed(generator, "rng", "f") is generator and check_seed(None, "rng", "f") is None


@pytest.mark.parametrize(("call", "message"), [
    (lambda cal: encal.fit(cal, method="ann", encoding="sincos"),
     "The 'encoding' parameter of fit_ann must be one of 'periodic', 'raw'. Got 'sincos' instead."),
    (lambda cal: encal.fit(cal, method="auto", folds=1),
     "The 'folds' parameter of fit_auto must be an int from 2 to 45 (at least 4 distinct encoder angles per "
     "fold). Got 1 instead."),
    (lambda cal: encal.fit(cal, method="fourier", n_orders=0),
     "The 'n_orders' parameter of fit_fourier must be an int >= 1. Got 0 instead."),
    (lambda cal: encal.fit(cal, method="spline"),
     "The 'method' parameter of fit must be one of fourier, spectral, lut, hybrid, ann, stack, arc, auto. "
     "Got 'spline' instead."),
])
def test_public_entry_points_use_the_template(call, message):
    cal = encal.Calibration(GRID, GRID + np.sin(np.radians(GRID)) / 60)
    with pytest.raises(InputError) as info:
        call(cal)
    assert str(info.value) == message


@pytest.mark.parametrize(("call", "error", "message"), [
    (lambda path: encal.Calibration(GRID, GRID, resolution_bits=0), encal.CalibrationError,
     "The 'resolution_bits' parameter of Calibration must be an int from 1 to 32 (or None when unknown). "
     "Got 0 instead."),
    (lambda path: encal.Calibration(GRID, GRID, reading_sign=True), encal.CalibrationError,
     "The 'reading_sign' parameter of Calibration must be 1 or -1. Got True instead."),
    (lambda path: encal.read_calibration(path, resolution_bits=2.5), InputError,
     "The 'resolution_bits' parameter of read_calibration must be an int from 1 to 32 (or None: from the file's "
     "comment, if any). Got 2.5 instead."),
    (lambda path: encal.read_calibration(path, duplicates="merge"), InputError,
     "The 'duplicates' parameter of read_calibration must be one of 'refuse', 'average', 'keep'. "
     "Got 'merge' instead."),
    (lambda path: encal.read_calibration(path, allow_gaps="yes"), InputError,
     "The 'allow_gaps' parameter of read_calibration must be True or False. Got 'yes' instead."),
    (lambda path: write_calibration(path, GRID), InputError,
     "The 'cal' parameter of write_calibration must be a Calibration. Got an object of type ndarray instead."),
    (lambda path: fit_stack(GRID, GRID * 0, members=[{"family": "lut"}], weights=[1.0], rng=-2), InputError,
     "The 'rng' parameter of fit_stack must be None, an int >= 0 or a numpy.random.Generator. Got -2 instead."),
])
def test_calibration_and_stack_entry_points_use_the_template(tmp_path, call, error, message):
    path = tmp_path / "cal.csv"
    write_calibration(path, encal.Calibration(GRID, GRID))
    before = path.read_text()
    with pytest.raises(error) as info:
        call(path)
    assert str(info.value) == message
    assert path.read_text() == before


@pytest.mark.parametrize(("call", "message"), [
    (lambda cal: encal.analysis.outliers.isolated_points(GRID, np.sin(np.radians(GRID)), factor=0),
     "The 'factor' parameter of isolated_points must be a finite number > 0. Got 0 instead."),
    (lambda cal: encal.analysis.outliers.isolated_points(GRID, np.sin(np.radians(GRID)), quantum_arcmin=-0.1),
     "The 'quantum_arcmin' parameter of isolated_points must be a finite number >= 0 (arc-minutes, or None). "
     "Got -0.1 instead."),
    (lambda cal: encal.data.reversal.direction_subset(cal, 0),
     "The 'direction' parameter of direction_subset must be 1 (forward) or -1 (reverse). Got 0 instead."),
    (lambda cal: encal.data.reversal.reversal(GRID),
     "The 'cal' parameter of reversal must be a Calibration. Got an object of type ndarray instead."),
    (lambda cal: encal.reports.encoder.encoder_report(cal, [cal, "b.csv"]),
     "The 'tests[1]' parameter of encoder_report must be a Calibration. Got an object of type str instead."),
    (lambda cal: encal.reports.encoder.encoder_report(cal, zero="none"),
     "The 'zero' parameter of encoder_report must be one of 'auto', 'arbitrary', 'fixed'. Got 'none' instead."),
    (lambda cal: encal.reports.encoder.encoder_report(cal, compare=None),
     "The 'compare' parameter of encoder_report must be True or False. Got None instead."),
])
def test_the_analyses_and_the_report_use_the_template(call, message):
    both = np.r_[GRID, GRID]
    cal = encal.Calibration(both, both + 0.01, direction=np.repeat([1, -1], GRID.size))
    with pytest.raises(InputError) as info:
        call(cal)
    assert str(info.value) == message


@pytest.mark.parametrize(("call", "message"), [
    (lambda: spin([object()], max_order=0),
     "The 'max_order' parameter of spin must be an int >= 1. Got 0 instead."),
    (lambda: spin([object()], knot_revolutions=-1.0),
     "The 'knot_revolutions' parameter of spin must be a finite number > 0 (revolutions). Got -1.0 instead."),
    (lambda: sweep(GRID, GRID, np.ones(GRID.size), 0),
     "The 'pole_pairs' parameter of sweep must be an int from 1 to 1000 (pole pairs: no motor has more). "
     "Got 0 instead."),
    (lambda: sweep(GRID, GRID, np.ones(GRID.size), 7, skip=-1),
     "The 'skip' parameter of sweep must be an int >= 0 (samples). Got -1 instead."),
    (lambda: steps(None, turn_deg=float("nan")),
     "The 'turn_deg' parameter of steps must be a finite number (an angle in degrees, or None). Got nan instead."),
])
def test_the_self_calibrations_use_the_template(call, message):
    with pytest.raises(InputError) as info:
        call()
    assert str(info.value) == message


@pytest.mark.parametrize(("direction", "message"), [
    ([0], "The 'direction' parameter of predict must be +1 (forward), -1 (reverse) or None (unknown), one value or "
          "one per reading. Got the values [0] instead."),
    (np.ones(3), "The 'direction' parameter of predict must be +1 (forward), -1 (reverse) or None (unknown), one "
                 "value or one per reading (the shape (2,) of the encoder angles). Got the shape (3,) instead."),
])
def test_predict_checks_the_direction_with_the_template(direction, message):
    model = encal.fit(encal.Calibration(GRID, GRID + np.sin(np.radians(GRID)) / 60), method="fourier")
    with pytest.raises(InputError) as info:
        model.predict([1.0, 2.0], direction=direction)
    assert str(info.value) == message


def test_the_report_checks_its_figures_resolution(tmp_path):
    both = np.r_[GRID, GRID]
    report = encal.reports.encoder.encoder_report(encal.Calibration(GRID, GRID + np.sin(np.radians(GRID)) / 60),
                                                 method="fourier", uncertainty=False, compare=False)
    with pytest.raises(InputError) as info:
        encal.reports.encoder.write_encoder_report(report, tmp_path / "report.html", dpi=0)
    assert str(info.value) == ("The 'dpi' parameter of write_encoder_report must be an int from 1 to 1200 (dots per "
                               "inch). Got 0 instead.")
    with pytest.raises(InputError) as info:
        encal.reports.encoder.render_encoder_figures(both)
    assert str(info.value) == ("The 'report' parameter of render_encoder_figures must be an EncoderReport. "
                               "Got an object of type ndarray instead.")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("values", [["a"], [1 + 2j], np.array([1.0 + 0j]), [[1.0, 2.0], [3.0]], None, {}, 10**400])
def test_real_array_refuses_what_numpy_raises_on_or_casts_with_a_warning(values):
    """Text, complex numbers (NumPy took their real part with a ComplexWarning), ragged lists and None: one
    sentence naming the parameter, never NumPy's ValueError or TypeError (task pyapi)."""
    with pytest.raises(InputError, match=r"^The 'theta' parameter of predict must be real numbers\. Got .* instead\.$"):
        real_array(values, "theta", "predict")


def test_real_array_keeps_what_numpy_reads():
    assert real_array(3, "theta", "predict").shape == ()
    assert real_array(np.arange(6).reshape(2, 3), "theta", "predict").dtype == float
    assert np.isnan(real_array([np.nan], "theta", "predict")[0])  # finiteness is the caller's to judge

"""Compact periodic tables: node fit, quantisation, stated deployed error, cheapest choice."""

import math

import numpy as np
import pytest

from encal.deploy.compact import (BAM_ARCMIN, CompactTable, choose_compact, compile_compact, correction_bam,
                                  model_on_codes, predict_fixed, predict_float32)
from encal._core.errors import InputError
from encal.models.fourier import FourierModel
from encal.models.lut import LookupTableModel
from tests._paths import DATA

BITS = 16


def piecewise_linear_model(nodes, values):
    """A model that is exactly the linear interpolation of ``values`` at i * 360 / nodes (periodic)."""
    breaks = list(np.arange(nodes + 1) * (360.0 / nodes))
    values = list(values) + [values[0]]
    slopes = [(values[i + 1] - values[i]) / (360.0 / nodes) for i in range(nodes)]
    return LookupTableModel.from_parameters(
        {"interpolation": "linear", "breaks_deg": breaks, "coefficients": [slopes, values[:-1]]},
        encoder={"resolution_bits": BITS})


@pytest.mark.parametrize("dtype", ["int16", "float32"])
def test_a_piecewise_linear_profile_is_reproduced_to_its_quantisation(dtype):
    rng = np.random.default_rng(7)
    values = rng.uniform(-5, 5, 64)
    model = piecewise_linear_model(64, values)
    table = compile_compact(model, 64, dtype=dtype, bits=BITS)
    stored = table.error_arcmin
    bound = table.scale_arcmin / 2 if dtype == "int16" else 1e-5
    assert np.max(np.abs(stored - values)) <= bound * (1 + 1e-9)
    # interpolation adds nothing but float32 rounding on top
    assert table.max_error_arcmin <= bound + 1e-5


def test_least_squares_beats_sampling_at_the_nodes():
    model = FourierModel([1, 7], [4.0, 1.0], [0.0, 2.0], encoder={"resolution_bits": BITS})
    table = compile_compact(model, 32, dtype="float32", bits=BITS)
    reference = model_on_codes(model, BITS)
    sampled = CompactTable(reference[:: (1 << BITS) // 32].astype(np.float32), None, BITS, 0.0, 0.0)
    sampled_rms = float(np.sqrt(np.mean((predict_float32(sampled, np.arange(1 << BITS), BITS) - reference) ** 2)))
    assert table.rms_error_arcmin < 0.8 * sampled_rms


def test_stated_error_is_the_rule_against_the_model_on_every_code():
    table = compile_compact(DATA / "model_v1_ann.json", 256, dtype="int8")
    reference = model_on_codes(DATA / "model_v1_ann.json", BITS)
    codes = np.arange(1 << BITS)
    deployed = predict_float32(table, codes, BITS).astype(float)
    assert table.max_error_arcmin == pytest.approx(np.max(np.abs(deployed - reference)), rel=1e-12)
    fixed = predict_fixed(table, codes, BITS)
    assert table.fixed_max_error_arcmin == pytest.approx(np.max(np.abs(fixed - reference)), rel=1e-12)
    assert table.table_bytes == 256 and table.values.dtype == np.int8
    assert np.max(np.abs(table.values)) <= 127
    # the unit is a power of two of a 32-bit binary angle
    assert table.scale_arcmin == math.ldexp(BAM_ARCMIN, table.scale_exponent)


def test_error_falls_with_more_nodes():
    errors = [compile_compact(DATA / "model_v1_fourier.json", n, dtype="float32").max_error_arcmin
              for n in (64, 256, 1024)]
    assert errors[0] > 4 * errors[1] > 16 * errors[2] * 0.9


@pytest.mark.parametrize("tolerance", [0.2, 0.02, 0.005])
def test_choice_is_the_cheapest_within_the_tolerance(tolerance):
    path = DATA / "model_v1_fourier.json"
    table, met = choose_compact(path, tolerance_arcmin=tolerance)
    assert met and table.max_error_arcmin <= tolerance
    # no table of the same dtype with half the nodes meets it, and no other dtype is smaller in bytes
    if table.nodes > 4:
        smaller = compile_compact(path, table.nodes // 2, dtype=table.dtype, interpolation=table.interpolation)
        assert smaller.max_error_arcmin > tolerance
    for interpolation in ("linear", "cubic"):
        for dtype in ("int8", "int16", "float32"):
            itemsize = np.dtype(dtype).itemsize
            nodes = table.table_bytes // itemsize // 2
            if nodes >= 4 and (dtype, interpolation) != (table.dtype, table.interpolation):
                assert compile_compact(path, nodes, dtype=dtype, interpolation=interpolation).max_error_arcmin \
                    > tolerance


def test_an_unreachable_tolerance_says_so():
    table, met = choose_compact(DATA / "model_v1_fourier.json", tolerance_arcmin=1e-9, dtypes=("int8",))
    assert not met and table.dtype == "int8"


@pytest.mark.parametrize(("call", "message"), [
    (lambda path: compile_compact(path, 100),
     "The 'nodes' parameter of compile_compact must be a power of two from 4 to 65536. Got 100 instead."),
    (lambda path: compile_compact(path, 128, bits=6),
     "The 'nodes' parameter of compile_compact must be a power of two from 4 to 64 (for a 6-bit encoder). "
     "Got 128 instead."),
    (lambda path: compile_compact(path, 64, dtype="int32"),
     "The 'dtype' parameter of compile_compact must be one of 'int8', 'int16', 'float32'. Got 'int32' instead."),
    (lambda path: compile_compact(path, 64, interpolation="quadratic"),
     "The 'interpolation' parameter of compile_compact must be one of 'linear', 'cubic'. Got 'quadratic' instead."),
    (lambda path: compile_compact(path, 64, bits=33),
     "The 'bits' parameter of compile_compact must be an int from 2 to 32 (the encoder resolution: a compact table has "
     "at least 4 nodes and at most one per code; or None for the model file's). Got 33 instead."),
    (lambda path: choose_compact(path, tolerance_arcmin=0.0),
     "The 'tolerance_arcmin' parameter of choose_compact must be a finite number > 0 (arc-minutes, or None). "
     "Got 0.0 instead."),
    (lambda path: choose_compact(path, cost="ops"),
     "The 'cost' parameter of choose_compact must be one of 'bytes', 'entries'. Got 'ops' instead."),
    (lambda path: choose_compact(path, target="host"),
     "The 'target' parameter of choose_compact must be one of 'cortex-m4f', 'fixed'. Got 'host' instead."),
    (lambda path: choose_compact(path, interpolations=["linear", "spline"]),
     "The 'interpolations' parameter of choose_compact must be one of 'linear', 'cubic'. Got 'spline' instead."),
    (lambda path: choose_compact(path, dtypes=[]),
     "The 'dtypes' parameter of choose_compact must be a non-empty sequence of 'int8', 'int16', 'float32'. "
     "Got () instead."),
    (lambda path: choose_compact(path, dtypes=["float32"], target="fixed"),
     "The 'dtypes' parameter of choose_compact must be a sequence with 'int8' or 'int16' for the fixed "
     "target. Got ('float32',) instead."),
])
def test_bad_options(call, message):
    with pytest.raises(InputError) as info:
        call(DATA / "model_v1_lut.json")
    assert str(info.value) == message


def test_the_integer_rule_refuses_a_float_table():
    with pytest.raises(InputError, match="int8 or int16 table for the integer rule"):
        correction_bam(compile_compact(DATA / "model_v1_lut.json", 64, dtype="float32"), [0])


def cubic_spline_model(nodes, coefficients):
    """A model that is exactly the periodic uniform cubic B-spline of ``coefficients`` (node i at i * 360 / nodes)."""
    c = np.asarray(coefficients, dtype=float)
    a, b, cc, d = np.roll(c, 1), c, np.roll(c, -1), np.roll(c, -2)
    p = [a + 4 * b + cc, 3 * (cc - a), 3 * (a + cc) - 6 * b, (d - a) + 3 * (b - cc)]
    h = 360.0 / nodes
    ppoly = [p[3] / (6 * h**3), p[2] / (6 * h**2), p[1] / (6 * h), p[0] / 6]  # highest power first
    return LookupTableModel(np.arange(nodes + 1) * h, ppoly, "cubic", encoder={"resolution_bits": BITS})


@pytest.mark.parametrize("dtype", ["int16", "float32"])
def test_a_cubic_b_spline_profile_is_reproduced_to_its_quantisation(dtype):
    rng = np.random.default_rng(11)
    coefficients = rng.uniform(-5, 5, 64)
    table = compile_compact(cubic_spline_model(64, coefficients), 64, dtype=dtype, bits=BITS,
                            interpolation="cubic")
    assert table.interpolation == "cubic"
    # integer nodes are in units of 6 * scale (their run-time sum is six times the spline)
    stored = table.values.astype(float) * 6.0 * table.scale_arcmin + table.offset_arcmin
    bound = 3.0 * table.scale_arcmin if dtype == "int16" else 1e-5
    assert np.max(np.abs(stored - coefficients)) <= bound * (1 + 1e-9)
    # the weights of the four nodes sum to one: the value is off by at most a node's rounding
    assert table.max_error_arcmin <= bound + 1e-5
    if dtype == "int16":  # the integer rule adds the rounding of three products, of the unit and of q8
        q8 = 21600.0 / 2**BITS / 256
        assert table.fixed_max_error_arcmin <= bound + 4 * table.scale_arcmin + BAM_ARCMIN + q8 / 2


@pytest.mark.parametrize("interpolation, low, high", [("linear", 3.5, 4.5), ("cubic", 12.0, 24.0)])
def test_error_falls_with_the_square_or_the_fourth_power_of_the_spacing(interpolation, low, high):
    model = FourierModel([20], [5.0], [0.0], encoder={"resolution_bits": BITS})
    errors = [compile_compact(model, n, dtype="float32", interpolation=interpolation).max_error_arcmin
              for n in (128, 256, 512)]
    assert low < errors[0] / errors[1] < high and low < errors[1] / errors[2] < high


def test_cubic_tables_make_a_high_harmonic_profile_smaller():
    """Orders near 100 (a stepper's full-step pattern): the cubic table needs a quarter of the nodes or fewer."""
    model = FourierModel([1, 50, 100], [10.0, 2.0, 5.0], [3.0, 1.0, -4.0], encoder={"resolution_bits": 14})
    linear, met_linear = choose_compact(model, tolerance_arcmin=0.03, dtypes=("int16",), interpolations=("linear",))
    cubic, met_cubic = choose_compact(model, tolerance_arcmin=0.03, dtypes=("int16",))
    assert met_linear and met_cubic and cubic.interpolation == "cubic"
    assert cubic.nodes * 4 <= linear.nodes and cubic.table_bytes <= 2048
    fixed, met_fixed = choose_compact(model, tolerance_arcmin=0.03, target="fixed")
    assert met_fixed and fixed.interpolation == "cubic" and fixed.fixed_max_error_arcmin <= 0.03


def test_a_large_constant_stays_out_of_the_integer_nodes():
    """A reference with an arbitrary zero adds 1500 arcmin: int16 steps still resolve the 30-arcmin profile."""
    model = FourierModel([0, 1, 5], [1500.0, 30.0, 4.0], [0.0, 10.0, -3.0], encoder={"resolution_bits": BITS})
    table = compile_compact(model, 1024, dtype="int16", bits=BITS)
    assert table.offset_arcmin == pytest.approx(1500.0, abs=1e-3)
    assert table.scale_arcmin < 40.0 / 32767 * 2  # a unit fitted to the profile, not to 1530 arcmin
    assert table.max_error_arcmin < 0.02 and table.fixed_max_error_arcmin < 0.02

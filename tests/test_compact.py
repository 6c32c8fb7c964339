"""Compact periodic tables: node fit, quantisation, stated deployed error, cheapest choice."""

import math
from pathlib import Path

import numpy as np
import pytest

from encal.deploy.compact import (BAM_ARCMIN, CompactTable, choose_compact, compile_compact, model_on_codes,
                                  predict_fixed, predict_float32)
from encal.errors import InputError
from encal.models.fourier import FourierModel
from encal.models.lut import LookupTableModel

DATA = Path(__file__).parent / "data"
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
        smaller = compile_compact(path, table.nodes // 2, dtype=table.dtype)
        assert smaller.max_error_arcmin > tolerance
    for dtype in ("int8", "int16", "float32"):
        itemsize = np.dtype(dtype).itemsize
        nodes = table.table_bytes // itemsize // 2
        if nodes >= 4 and dtype != table.dtype:
            assert compile_compact(path, nodes, dtype=dtype).max_error_arcmin > tolerance


def test_an_unreachable_tolerance_says_so():
    table, met = choose_compact(DATA / "model_v1_fourier.json", tolerance_arcmin=1e-9, dtypes=("int8",))
    assert not met and table.dtype == "int8"


def test_bad_options():
    with pytest.raises(InputError, match="power of two"):
        compile_compact(DATA / "model_v1_lut.json", 100)
    with pytest.raises(InputError, match="at most 2\\^6"):
        compile_compact(DATA / "model_v1_lut.json", 128, bits=6)
    with pytest.raises(InputError, match="node dtype"):
        compile_compact(DATA / "model_v1_lut.json", 64, dtype="int32")
    with pytest.raises(InputError, match="positive tolerance"):
        choose_compact(DATA / "model_v1_lut.json", tolerance_arcmin=0.0)


def test_a_large_constant_stays_out_of_the_integer_nodes():
    """A reference with an arbitrary zero adds 1500 arcmin: int16 steps still resolve the 30-arcmin profile."""
    model = FourierModel([0, 1, 5], [1500.0, 30.0, 4.0], [0.0, 10.0, -3.0], encoder={"resolution_bits": BITS})
    table = compile_compact(model, 1024, dtype="int16", bits=BITS)
    assert table.offset_arcmin == pytest.approx(1500.0, abs=1e-3)
    assert table.scale_arcmin < 40.0 / 32767 * 2  # a unit fitted to the profile, not to 1530 arcmin
    assert table.max_error_arcmin < 0.02 and table.fixed_max_error_arcmin < 0.02

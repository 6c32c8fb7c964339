"""C for the cortex-m4f and fixed targets: compiled on the host, checked on all 2^16 codes.

The generated C is compiled with gcc -std=c99 -Wdouble-promotion -Werror (and, when the
cross-compiler is installed, with arm-none-eabi-gcc for a Cortex-M4F, checking that the object
has no double-precision instruction or helper). The float32 results must equal the Python
emulation of the same arithmetic (encal.deploy.compact, encal.deploy.targets) bit for bit for
the tables, within 4 float32 ulps of the sum of |coefficients| for the Fourier series (sinf and
cosf differ between C libraries); and the deployed error against the model must stay within the
error the export states.
"""

import math
import platform
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from encal.deploy import Compensator
from encal.deploy.compact import correction_bam, correction_lsb_q8, error_lsb_float32, predict_float32_angle
from encal.deploy.series32 import fourier_float32, fourier_terms
from encal.deploy.targets import export_target, write_target
from encal._core.errors import InputError
from encal.models.fourier import FourierModel
from tests._paths import DATA

GCC = shutil.which("gcc")
ARM_GCC = shutil.which("arm-none-eabi-gcc")
ARM_OBJDUMP = shutil.which("arm-none-eabi-objdump")
CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wshadow", "-Wdouble-promotion",
          "-Wconversion", "-O2"]
BITS = 16
N = 1 << BITS
KINDS = ["fourier", "lut", "ann", "hybrid", "stack", "directional"]

needs_gcc = pytest.mark.skipif(GCC is None, reason="gcc is not installed")
#: GCC's default (GNU) dialect, which fuses a * b + c where the CPU can: FMA3 on an x86-64 host.
GNU_FMA_FLAGS = ["-std=gnu11", "-mfma", "-Wall", "-Wextra", "-Werror", "-O2"]
HOST_HAS_FMA = platform.machine() == "x86_64" and Path("/proc/cpuinfo").exists() \
    and " fma " in Path("/proc/cpuinfo").read_text().replace("\n", " ")
needs_arm = pytest.mark.skipif(ARM_GCC is None or ARM_OBJDUMP is None,
                               reason="arm-none-eabi-gcc is not installed (Debian: gcc-arm-none-eabi)")

FLOAT_DRIVER = """\
#include <stdio.h>
#include <stdint.h>
#include "enc.h"
int main(void)
{
    uint32_t k;
    for (k = 0; k < 65536u; ++k) {
        const float theta = (float)k * (360.0f / 65536.0f);
        const float out[4] = {enc_error_lsb(k), (float)enc_correct_code(k), enc_predict_arcmin(theta),
                              enc_correct_deg(theta)};
        fwrite(out, sizeof(float), 4, stdout);
    }
    return 0;
}
"""

FIXED_DRIVER = """\
#include <stdio.h>
#include <stdint.h>
#include "enc.h"
int main(void)
{
    uint32_t k;
    for (k = 0; k < 65536u; ++k) {
        const int32_t out[4] = {enc_error_bam32(k << 16), enc_error_lsb_q8(k), (int32_t)enc_correct_code(k),
                                (int32_t)enc_correct_bam32(k * 65537u)};
        fwrite(out, sizeof(int32_t), 4, stdout);
    }
    return 0;
}
"""


def run_c(folder, driver, dtype, flags=CFLAGS):
    (folder / "driver.c").write_text(driver)
    program = folder / "driver"
    built = subprocess.run([GCC, *flags, "-I", str(folder), str(folder / "driver.c"), str(folder / "enc.c"),
                            "-lm", "-o", str(program)], capture_output=True, text=True, timeout=300)
    assert built.returncode == 0, built.stderr
    raw = subprocess.run([str(program)], capture_output=True, timeout=60, check=True).stdout
    return np.frombuffer(raw, dtype=dtype).reshape(-1, 4)


def assert_float_rule(out, table):
    """The float C's error (LSB), corrected code and error (arcmin) on every code equal the Python
    emulation of its arithmetic bit for bit; returns the float32 angles of the codes."""
    codes = np.arange(N)
    expected_lsb = error_lsb_float32(table, codes, BITS)
    np.testing.assert_array_equal(out[:, 0], expected_lsb)
    np.testing.assert_array_equal(out[:, 1], (codes - np.floor(expected_lsb + np.float32(0.5))) % N)
    theta = codes.astype(np.float32) * np.float32(360.0 / N)
    np.testing.assert_array_equal(out[:, 2], predict_float32_angle(table, theta))
    return theta


def offset_series():
    """A series with a large mean error (1500 arcmin) and orders up to 100, for the cubic tables."""
    return FourierModel([0, 1, 50, 100], [1500.0, 10.0, 2.0, 5.0], [0.0, 3.0, 1.0, -4.0],
                        encoder={"resolution_bits": BITS})


def model_path(kind):
    return DATA / f"model_v1_{kind}.json"


def reference(kind):
    comp = Compensator(model_path(kind))
    return comp.predict(np.arange(N) * (360.0 / N))


@needs_gcc
@pytest.mark.parametrize("kind", KINDS)
def test_cortex_m4f_table_equals_its_python_rule_and_the_model_within_the_stated_error(tmp_path, kind):
    _, summary = write_target(model_path(kind), tmp_path, "cortex-m4f", prefix="enc", bits=BITS)
    table = summary["table"]
    out = run_c(tmp_path, FLOAT_DRIVER, np.float32)
    lsb = 21600.0 / N
    theta = assert_float_rule(out, table)
    deployed = out[:, 0].astype(float) * lsb
    error = np.abs(deployed - reference(kind))
    # stated for the arc-minute function; the LSB function rounds its constants differently (float32)
    assert error.max() <= summary["max_error_arcmin"] + 1e-6
    assert summary["max_error_arcmin"] <= 0.1 * lsb  # the default tolerance, met for these models
    assert math.isclose(np.sqrt(np.mean(error**2)), summary["rms_error_arcmin"], rel_tol=1e-4, abs_tol=1e-7)
    corrected = (theta.astype(float) - out[:, 2].astype(float) / 60.0) % 360.0
    gap = np.abs((out[:, 3].astype(float) - corrected + 180.0) % 360.0 - 180.0)
    assert gap.max() <= 2.0**-15  # float32 rounding of the returned angle


@needs_gcc
@pytest.mark.parametrize("dtype", ["int8", "int16", "float32"])
def test_cortex_m4f_cubic_table_equals_its_python_rule_and_the_model_within_the_stated_error(tmp_path, dtype):
    model = offset_series()
    _, summary = write_target(model, tmp_path, "cortex-m4f", prefix="enc", bits=BITS, nodes=512, dtype=dtype,
                              interpolation="cubic")
    table = summary["table"]
    assert summary["interpolation"] == "cubic" and table.interpolation == "cubic"
    out = run_c(tmp_path, FLOAT_DRIVER, np.float32)
    lsb = 21600.0 / N
    assert_float_rule(out, table)
    truth = Compensator(model).predict(np.arange(N) * (360.0 / N))
    rounding = 2.0**-22 * np.max(np.abs(truth))  # float32 results near 1500 arcmin
    assert np.max(np.abs(out[:, 0].astype(float) * lsb - truth)) <= summary["max_error_arcmin"] + rounding
    assert summary["max_error_arcmin"] < (0.2 if dtype == "int8" else 0.05)


def _fixed_driver_agrees_with_its_python_rule(folder, table):
    """Run the compiled fixed-point driver on every code and the angles between; assert each output equals the
    Python rule's, and return the corrections in LSB/256."""
    out = run_c(folder, FIXED_DRIVER, np.int32)
    codes = np.arange(N, dtype=np.int64)
    np.testing.assert_array_equal(out[:, 0], correction_bam(table, codes << 16))
    q8 = correction_lsb_q8(table, codes, BITS)
    np.testing.assert_array_equal(out[:, 1], q8)
    np.testing.assert_array_equal(out[:, 2], (codes - ((q8 + 128) >> 8)) % N)
    angles = (codes * 65537) & 0xFFFFFFFF
    np.testing.assert_array_equal(out[:, 3].view(np.uint32), (angles - correction_bam(table, angles)) & 0xFFFFFFFF)
    return q8


@needs_gcc
@pytest.mark.parametrize("dtype", ["int8", "int16"])
def test_fixed_cubic_table_equals_its_python_rule_and_the_model_within_the_stated_error(tmp_path, dtype):
    model = offset_series()
    _, summary = write_target(model, tmp_path, "fixed", prefix="enc", bits=BITS, nodes=512, dtype=dtype,
                              interpolation="cubic")
    table = summary["table"]
    assert summary["interpolation"] == "cubic" and table.interpolation == "cubic"
    q8 = _fixed_driver_agrees_with_its_python_rule(tmp_path, table)
    truth = Compensator(model).predict(np.arange(N) * (360.0 / N))
    error = np.abs(q8 / 256.0 * (21600.0 / N) - truth)
    assert error.max() <= summary["max_error_arcmin"] + 1e-12
    assert summary["max_error_arcmin"] < (0.2 if dtype == "int8" else 0.05)
    # an alternating pattern of full-scale nodes: the largest partial sums of Horner's rule, no overflow
    nodes = np.where(np.arange(512) % 2 == 0, 32767, -32767).astype(np.int16)
    nodes[::4] = -32767
    extreme = type(table)(nodes, table.scale_exponent, BITS, 0.0, 0.0, interpolation="cubic")
    p = correction_bam(extreme, np.arange(0, 2**32, 2**14, dtype=np.int64))
    assert np.all(np.abs(p) < 2**31)


@needs_gcc
@pytest.mark.parametrize("kind", KINDS)
def test_fixed_table_equals_its_python_rule_and_the_model_within_the_stated_error(tmp_path, kind):
    _, summary = write_target(model_path(kind), tmp_path, "fixed", prefix="enc", bits=BITS)
    table = summary["table"]
    q8 = _fixed_driver_agrees_with_its_python_rule(tmp_path, table)
    error = np.abs(q8 / 256.0 * (21600.0 / N) - reference(kind))
    assert error.max() <= summary["max_error_arcmin"] + 1e-12
    assert summary["max_error_arcmin"] <= 0.1 * 21600.0 / N


@needs_gcc
def test_cortex_m4f_fourier_formula(tmp_path):
    _, summary = write_target(model_path("fourier"), tmp_path, "cortex-m4f", prefix="enc", bits=BITS,
                              form="formula")
    out = run_c(tmp_path, FLOAT_DRIVER, np.float32)
    orders, cos, sin = fourier_terms(Compensator(model_path("fourier")))
    lsb = 21600.0 / N
    emulated = fourier_float32(orders, cos, sin, np.arange(N, dtype=np.int64) << 16)
    ulps = 4 * np.finfo(np.float32).eps * float(np.sum(np.abs(cos) + np.abs(sin)))
    assert np.max(np.abs(out[:, 0].astype(float) * lsb - emulated)) <= ulps
    error = np.abs(out[:, 0].astype(float) * lsb - reference("fourier"))
    assert error.max() <= summary["max_error_arcmin"] + ulps
    assert summary["max_error_arcmin"] < 1e-4
    assert np.max(np.abs(out[:, 2].astype(float) - reference("fourier"))) < 1e-3


def test_formula_high_orders_keep_their_phase():
    # order 300 at angle 359.99 degrees: k * theta modulo a turn is exact in integers
    model = FourierModel([300], [2.0], [1.0], encoder={"resolution_bits": 20})
    _, summary = export_target(model, "cortex-m4f", form="formula", bits=20)
    assert summary["max_error_arcmin"] < 2e-5


def test_formula_needs_a_fourier_series():
    with pytest.raises(InputError, match="expected a Fourier series"):
        export_target(model_path("lut"), "cortex-m4f", form="formula")
    with pytest.raises(InputError, match="fixed target uses a table"):
        export_target(model_path("fourier"), "fixed", form="formula")


def test_no_double_anywhere_in_cortex_m4f_source():
    for form in ("table", "formula"):
        files, _ = export_target(model_path("fourier"), "cortex-m4f", form=form, prefix="enc")
        for text in files.values():
            assert "double" not in text.replace("no double", "")


def test_unknown_resolution_leaves_out_the_code_functions_with_a_note():
    model = FourierModel([1, 2], [3.0, 0.5], [0.0, 1.0])
    for target in ("cortex-m4f", "fixed"):
        files, summary = export_target(model, target, prefix="enc")
        assert "resolution is unknown" in summary["note"]
        assert "correct_code" not in files["enc.h"] and "BITS" not in files["enc.h"]


def test_explicit_nodes_and_dtype():
    _, summary = export_target(model_path("lut"), "cortex-m4f", nodes=64, dtype="int8")
    assert summary["nodes"] == 64 and summary["dtype"] == "int8" and summary["table_bytes"] == 64
    assert summary["interpolation"] == "linear" and summary["operations"] == 15
    files, summary = export_target(model_path("lut"), "cortex-m4f", nodes=64, dtype="int8", interpolation="cubic")
    assert summary["interpolation"] == "cubic" and summary["operations"] == 40
    assert "cubic B-spline" in files["encal.c"]
    _, summary = export_target(model_path("lut"), "fixed", nodes=64, dtype="int8", interpolation="cubic")
    assert summary["interpolation"] == "cubic" and summary["operations"] == 37


@pytest.mark.parametrize(("options", "message"), [
    ({"target": "fixed", "interpolation": "spline"},
     "The 'interpolation' parameter of export_target must be one of None, 'linear', 'cubic'. Got 'spline' instead."),
    ({"target": "fixed", "dtype": "float32"},
     "The 'dtype' parameter of export_target must be an integer node dtype, 'int8' or 'int16', for the fixed "
     "target (or None). Got 'float32' instead."),
    ({"target": "cortex-m4f", "dtype": "int32"},
     "The 'dtype' parameter of export_target must be one of None, 'int8', 'int16', 'float32'. Got 'int32' instead."),
    ({"target": "fixed", "nodes": 100},
     "The 'nodes' parameter of export_target must be a power of two from 4 to 65536. Got 100 instead."),
    ({"target": "arm"},
     "The 'target' parameter of export_target must be one of 'host', 'cortex-m4f', 'fixed'. Got 'arm' instead."),
    ({"target": "cortex-m4f", "form": "series"},
     "The 'form' parameter of export_target must be one of 'table', 'formula'. Got 'series' instead."),
    ({"target": "cortex-m4f", "cost": "flash"},
     "The 'cost' parameter of export_target must be one of None, 'bytes', 'entries', 'operations'. "
     "Got 'flash' instead."),
    ({"target": "cortex-m4f", "tolerance_arcmin": -0.5},
     "The 'tolerance_arcmin' parameter of export_target must be a finite number > 0 (arc-minutes, or None). "
     "Got -0.5 instead."),
    ({"target": "fixed", "bits": 25},
     "The 'bits' parameter of export_target must be an int from 2 to 24 (the encoder resolution for the fixed "
     "target; a compact table has at least 4 nodes, one per code at most; or None for the model file's). "
     "Got 25 instead."),
    ({"target": "cortex-m4f", "prefix": "int"},
     "The 'prefix' parameter of export_target must be a C identifier (letters, digits, '_', not starting with "
     "a digit, '__' or '_' + capital, not a keyword). Got 'int' instead."),
])
def test_bad_options_use_the_template(options, message):
    with pytest.raises(InputError) as info:
        export_target(model_path("lut"), **options)
    assert str(info.value) == message


@needs_gcc
def test_compiles_on_the_host_without_the_code_functions(tmp_path):
    model = FourierModel([1, 2], [3.0, 0.5], [0.0, 1.0])
    for target in ("cortex-m4f", "fixed"):
        write_target(model, tmp_path / target, target, prefix="enc")
        built = subprocess.run([GCC, *CFLAGS, "-c", str(tmp_path / target / "enc.c"), "-o",
                                str(tmp_path / target / "enc.o")], capture_output=True, text=True, timeout=120)
        assert built.returncode == 0, built.stderr


@needs_gcc
@pytest.mark.skipif(not HOST_HAS_FMA, reason="the host is no x86-64 CPU with fused multiply-add (FMA3)")
@pytest.mark.parametrize("interpolation", ["linear", "cubic"])
def test_cortex_m4f_table_stays_bit_exact_where_the_compiler_may_fuse_multiply_adds(tmp_path, interpolation):
    """GCC's GNU dialects (its default, and most firmware builds') fuse ``a * b + c`` where the CPU can:
    VFMA on a Cortex-M4F, FMA3 here. The generated C turns that off, so the results stay those of the
    arithmetic the deployed error was computed for, bit for bit."""
    model = offset_series()
    _, summary = write_target(model, tmp_path, "cortex-m4f", prefix="enc", bits=BITS, nodes=512, dtype="float32",
                              interpolation=interpolation)
    assert_float_rule(run_c(tmp_path, FLOAT_DRIVER, np.float32, flags=GNU_FMA_FLAGS), summary["table"])


def m4f_object(tmp_path, form, interpolation, flags):
    """The Fourier model's cortex-m4f C compiled for a Cortex-M4F with ``flags``: the object file's path."""
    write_target(model_path("fourier"), tmp_path, "cortex-m4f", prefix="enc", bits=BITS, form=form,
                 interpolation=interpolation)
    obj = tmp_path / "enc.o"
    built = subprocess.run([ARM_GCC, "-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard",
                            *flags, "-c", str(tmp_path / "enc.c"), "-o", str(obj)],
                           capture_output=True, text=True, timeout=120)
    assert built.returncode == 0, built.stderr
    return obj


@needs_arm
@pytest.mark.parametrize("form, interpolation", [("table", "linear"), ("table", "cubic"), ("formula", None)])
def test_cortex_m4f_object_fuses_no_multiply_add_in_a_gnu_dialect(tmp_path, form, interpolation):
    obj = m4f_object(tmp_path, form, interpolation, ["-std=gnu11", "-O2", "-Wall", "-Wextra", "-Werror"])
    listing = subprocess.run([ARM_OBJDUMP, "-d", str(obj)], capture_output=True, text=True, check=True).stdout
    assert "vmul.f32" in listing
    assert not any(f"{op}.f32" in listing for op in ("vfma", "vfms", "vfnma", "vfnms"))


@needs_arm
@pytest.mark.parametrize("form, interpolation", [("table", "linear"), ("table", "cubic"), ("formula", None)])
def test_cortex_m4f_object_has_no_double_precision(tmp_path, form, interpolation):
    obj = m4f_object(tmp_path, form, interpolation, CFLAGS)
    listing = subprocess.run([ARM_OBJDUMP, "-dr", str(obj)], capture_output=True, text=True, check=True).stdout
    assert "vcvt.f32.f64" not in listing and "f64" not in listing
    assert "__aeabi_d" not in listing  # software double helpers


@needs_gcc
@pytest.mark.parametrize("target, form", [("cortex-m4f", "table"), ("cortex-m4f", "formula"), ("fixed", "table")])
def test_an_encoder_counting_against_its_reference(tmp_path, target, form):
    """reading_sign -1: the C maps the raw reading as the Compensator does; corrected codes in the reference's sense."""
    model = FourierModel([1, 3], [4.0, -1.0], [2.0, 0.5], encoder={"resolution_bits": BITS})
    model.reading_sign = -1
    _, summary = write_target(model, tmp_path, target, prefix="enc", bits=BITS, form=form)
    comp = Compensator(model)
    codes = np.arange(N)
    angles = codes * (360.0 / N)
    expected_code = np.round(comp.correct(angles) * N / 360.0) % N
    if target == "fixed":
        out = run_c(tmp_path, FIXED_DRIVER, np.int32)
        error = out[:, 1] / 256.0 * (21600.0 / N)
    else:
        out = run_c(tmp_path, FLOAT_DRIVER, np.float32)
        error = out[:, 0].astype(float) * (21600.0 / N)
        corrected = out[:, 3].astype(float)
        gap = np.abs((corrected - comp.correct(angles) + 180.0) % 360.0 - 180.0)
        assert gap.max() <= summary["max_error_arcmin"] / 60.0 + 2.0**-15
    # the series: plus the C library's sinf/cosf against NumPy's and the float32 result in LSB
    slack = 1e-5 if form == "formula" else 1e-9
    assert np.max(np.abs(error - comp.predict(angles))) <= summary["max_error_arcmin"] + slack
    # the corrected code is the reference-sense code of the Compensator, except where the exact
    # corrected position lies within the deployed error of a half code (rounding may go either way)
    code_column = 2 if target == "fixed" else 1
    code_gap = np.abs((out[:, code_column].astype(np.int64) - expected_code + N // 2) % N - N // 2)
    exact = comp.correct(angles) * N / 360.0
    near_half = np.abs(exact - np.floor(exact) - 0.5) <= (summary["max_error_arcmin"] + slack) / (21600.0 / N) + 1e-6
    assert code_gap.max() <= 1 and np.all(code_gap[~near_half] == 0)
    assert np.mean(near_half) < 0.25


@needs_gcc
@pytest.mark.parametrize("target", ["cortex-m4f", "fixed"])
def test_a_large_zero_offset(tmp_path, target):
    model = FourierModel([0, 1, 5], [1500.0, 30.0, 4.0], [0.0, 10.0, -3.0], encoder={"resolution_bits": BITS})
    _, summary = write_target(model, tmp_path, target, prefix="enc", bits=BITS, nodes=1024, dtype="int16")
    if target == "fixed":
        error = run_c(tmp_path, FIXED_DRIVER, np.int32)[:, 1] / 256.0 * (21600.0 / N)
    else:
        error = run_c(tmp_path, FLOAT_DRIVER, np.float32)[:, 0].astype(float) * (21600.0 / N)
    truth = Compensator(model).predict(np.arange(N) * (360.0 / N))
    rounding = 2.0**-22 * np.max(np.abs(truth))  # float32 results near 1534 arcmin: ulps of 1.2e-4
    assert np.max(np.abs(error - truth)) <= summary["max_error_arcmin"] + rounding < 0.03


@needs_gcc
def test_a_spectral_model_deploys_as_its_fourier_series(tmp_path):
    """The spectral kind predicts a Fourier series: the cortex-m4f formula serves it."""
    from encal.models.spectral import SpectralModel

    orders = np.arange(0, 40)
    rng = np.random.default_rng(3)
    model = SpectralModel(orders, rng.normal(0, 1, 40) / (1 + orders), rng.normal(0, 1, 40) / (1 + orders),
                          encoder={"resolution_bits": BITS})
    _, summary = write_target(model, tmp_path, "cortex-m4f", prefix="enc", bits=BITS, form="formula")
    assert summary["terms"] == 40 and summary["max_error_arcmin"] < 1e-5
    out = run_c(tmp_path, FLOAT_DRIVER, np.float32)
    truth = Compensator(model).predict(np.arange(N) * (360.0 / N))
    assert np.max(np.abs(out[:, 0].astype(float) * (21600.0 / N) - truth)) <= summary["max_error_arcmin"] + 1e-5


def test_the_host_exports_hint_covers_what_cortex_m4f_then_costs():
    # users7: the host C export said "--target cortex-m4f writes a float32 compact table (21 C operations to correct
    # a reading in degrees)", the cost of a linear table; the export then chose a cubic B-spline of 46.
    import re

    from encal.deploy.costs import OPERATIONS
    from encal.deploy.targets import describe

    model = FourierModel([1, 2, 16], [3.0, 0.5, 0.4], [0.0, 1.0, -2.0], encoder={"resolution_bits": BITS})
    hint = re.search(r"compact table \((\d+) to (\d+) C operations to correct a reading in degrees",
                     describe(export_target(model, "host")[1]))
    assert hint is not None
    interpolation = export_target(model, "cortex-m4f")[1]["interpolation"]
    assert interpolation == "cubic"
    assert int(hint[1]) <= OPERATIONS[("cortex-m4f", "cubic", "correct_deg")] <= int(hint[2])

"""C export: the generated code compiles with strict warnings and agrees with Python.

Stated tolerances, on all 65,536 codes of a 16-bit encoder:

- predicted error: the change that float32 constants cause (at most
  FLOAT32_BUDGET_ARCMIN = 1e-4 arcmin, measured by the exporter) plus the
  float32 rounding of the returned value (2^-24 of the error);
- corrected angle: its float32 rounding, at most 2^-16 degrees (0.00092 arcmin)
  below 512 degrees, plus the error tolerance / 60.
A table export is compared with the Python table it was compiled from.
"""

import functools
import json
import re
import shutil
import subprocess

import numpy as np
import pytest

import encal
from encal.deploy import Compensator, compile_table, export_c, write_c
from encal.deploy.cexport import FLOAT32_BUDGET_ARCMIN
from encal._core.errors import InputError
from encal.models.ann import fit_ann
from encal.models.fourier import FourierModel
from encal.models.lut import fit_lut
from tests._paths import DATA

GCC = shutil.which("gcc")
CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wshadow",
          "-Wdouble-promotion", "-Wconversion", "-O2"]
BITS = 16
# Far from 0 a float's spacing (64 degrees at 1e9, 2^36 at 1e15) dwarfs the correction: the angle
# must be wrapped before the correction is subtracted, or the correction is lost.
EXTRA_ANGLES = [-1.0, 360.0, 720.5, -359.75, 1e6, 359.99997, -1e-3, 1e9, 1e15, -3e38]

needs_gcc = pytest.mark.skipif(GCC is None, reason="gcc is not installed")

DRIVER = """\
#include <stdio.h>
#include <stdint.h>
#include "{prefix}.h"

static const float extra[] = {{{extra}}};

int main(void)
{{
    uint32_t k;
    for (k = 0; k < (1u << {bits}); ++k) {{
        const float theta = (float)((double)k * (360.0 / {n}.0));
        const float out[3] = {{{prefix}_predict_arcmin(theta), {prefix}_correct_deg(theta),
                               {prefix}_correct_counts(k)}};
        fwrite(out, sizeof(float), 3, stdout);
    }}
    for (k = 0; k < sizeof(extra) / sizeof(extra[0]); ++k) {{
        const float out[3] = {{{prefix}_predict_arcmin(extra[k]), {prefix}_correct_deg(extra[k]),
                               {prefix}_correct_counts(k + (1u << {bits}))}};
        fwrite(out, sizeof(float), 3, stdout);
    }}
    return 0;
}}
"""


def build_and_run(folder, prefix, bits=BITS):
    driver = folder / "driver.c"
    driver.write_text(DRIVER.format(prefix=prefix, bits=bits, n=2**bits,
                                    extra=", ".join(f"{a!r}f" for a in EXTRA_ANGLES)))
    program = folder / "driver"
    compiled = subprocess.run([GCC, *CFLAGS, "-I", str(folder), str(driver),
                               str(folder / f"{prefix}.c"), "-lm", "-o", str(program)],
                              capture_output=True, text=True, timeout=300)
    assert compiled.returncode == 0, compiled.stderr
    raw = subprocess.run([str(program)], capture_output=True, timeout=60, check=True).stdout
    out = np.frombuffer(raw, dtype=np.float32).reshape(-1, 3).astype(float)
    return out[:2**bits], out[2**bits:]


def inputs(bits=BITS):
    codes = np.arange(2**bits)
    theta = (codes * (360.0 / 2**bits)).astype(np.float32).astype(float)
    return codes, theta


def circular(a, b):
    return np.abs((np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0)


def cases(names, option):
    """Test parameters (model source, option): stored model files and trained models."""
    return [pytest.param(name if name in TRAINED else DATA / f"model_v1_{name}.json", option,
                         id=f"{name}-{option}") for name in names]


EVERY_KIND = ["fourier", "lut", "lut_linear", "directional", "ann", "ann_raw", "hybrid",
              "trained_ann_raw", "trained_ann_periodic", "trained_spectral"]


@functools.lru_cache(maxsize=None)
def trained_ann(encoding):
    """A network trained on a synthetic profile: real weights, as large as training makes them."""
    theta = np.arange(0.0, 360.0, 2.0)
    r = np.radians(theta)
    error = 4.0 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r) - 0.6 * np.sin(4 * r)
    if encoding == "raw":  # the paper's 1:80:1
        model = fit_ann(theta, error, hidden=80, encoding="raw", rng=0, epochs=20)
    else:
        model = fit_ann(theta, error, hidden=12, encoding="periodic", rng=0, epochs=100)
    model.encoder["resolution_bits"] = BITS
    return model


def offgrid_lut():
    """A cubic table through angles that float32 cannot hold, such as a calibration read off its grid."""
    theta = np.sort(np.random.default_rng(5).uniform(0.0, 360.0, 90))
    r = np.radians(theta)
    model = fit_lut(theta, 3.0 * np.sin(r) + 0.5 * np.cos(3 * r), interpolation="cubic")
    model.encoder["resolution_bits"] = BITS
    assert any(float(np.float32(b)) != b for b in model.parameters()["breaks_deg"])
    return model


def trained_spectral():
    """A spectral model (its posterior-mean series up to order 90) of a noisy synthetic profile."""
    from encal.models.spectral import fit_spectral

    theta = np.arange(0.0, 360.0, 2.0)
    r = np.radians(theta)
    error = 3.0 * np.sin(r) + 0.4 * np.cos(16 * r) + np.random.default_rng(2).normal(0.0, 0.1, theta.size)
    model = fit_spectral(theta, error)
    model.encoder["resolution_bits"] = BITS
    return model


TRAINED = {"trained_ann_raw": lambda: trained_ann("raw"), "trained_spectral": trained_spectral,
           "trained_ann_periodic": lambda: trained_ann("periodic"),
           "offgrid_lut": offgrid_lut}


def compensator_of(source):
    return Compensator(TRAINED[source]() if source in TRAINED else source)


@needs_gcc
@pytest.mark.parametrize("path, constants", [
    *cases(EVERY_KIND, "auto"), *cases(["lut", "hybrid", "trained_ann_raw"], "double"),
    *cases(["offgrid_lut"], "float")])
def test_formula_agrees_with_python_on_every_code(tmp_path, path, constants):
    comp = compensator_of(path)
    write_c(comp, tmp_path, prefix="enc", constants=constants)
    at_codes, at_extra = build_and_run(tmp_path, "enc")
    codes, theta = inputs()
    error = comp.predict(theta)
    tolerance = FLOAT32_BUDGET_ARCMIN + 2.0**-23 * np.abs(error).max()
    assert np.abs(at_codes[:, 0] - error).max() <= tolerance
    angle_tolerance = 2.0**-16 + tolerance / 60
    assert circular(at_codes[:, 1], comp.correct(theta)).max() <= angle_tolerance
    by_code = comp.correct(codes * (360.0 / 2**BITS))
    assert circular(at_codes[:, 2], by_code).max() <= angle_tolerance
    assert np.all((at_codes[:, 1:] >= 0) & (at_codes[:, 1:] < 360))
    extra = np.array(EXTRA_ANGLES, dtype=np.float32).astype(float)
    assert np.abs(at_extra[:, 0] - comp.predict(extra)).max() <= tolerance
    assert circular(at_extra[:, 1], comp.correct(extra)).max() <= angle_tolerance
    # codes beyond 16 bits wrap: the high bits are ignored
    assert circular(at_extra[:, 2], at_codes[:len(EXTRA_ANGLES), 2]).max() == 0


@needs_gcc
@pytest.mark.parametrize("path, dtype", [
    *cases(["fourier", "lut_linear", "directional"], "int16"), *cases(["lut"], "float32")])
def test_table_agrees_with_the_python_table(tmp_path, path, dtype):
    comp = compensator_of(path)
    write_c(comp, tmp_path, prefix="tab", table=dtype)
    at_codes, at_extra = build_and_run(tmp_path, "tab")
    codes, theta = inputs()
    table = compile_table(comp, BITS, dtype=dtype)
    expected = table.predict_counts(codes)
    assert np.abs(at_codes[:, 0] - expected).max() <= 2.0**-24 * np.abs(expected).max()
    assert circular(at_codes[:, 2], table.correct_counts(codes)).max() <= 2.0**-16
    assert circular(at_codes[:, 1], table.correct(theta)).max() <= 2.0**-16
    extra = np.array(EXTRA_ANGLES, dtype=np.float32).astype(float)
    assert circular(at_extra[:, 1], table.correct(extra)).max() <= 2.0**-16
    model_error = np.abs(at_codes[:, 0] - comp.predict(theta)).max()
    assert model_error <= table.quantisation_arcmin + 2.0**-23 * np.abs(expected).max()


NON_FINITE_DRIVER = """\
#include <math.h>
#include <stdio.h>
#include "{prefix}.h"

int main(void)
{{
    const float bad[3] = {{NAN, INFINITY, -INFINITY}};
    int k;
    for (k = 0; k < 3; ++k)
        printf("%d %d\\n", isnan({prefix}_predict_arcmin(bad[k])) != 0, isnan({prefix}_correct_deg(bad[k])) != 0);
    return 0;
}}
"""


@needs_gcc
@pytest.mark.parametrize("table", [None, "int16", "float32"])
@pytest.mark.parametrize("name", ["fourier", "lut", "directional"])
def test_a_non_finite_reading_gives_nan_without_undefined_behaviour(tmp_path, name, table):
    # gcc's -fsanitize=undefined leaves out float-cast-overflow: NaN cast to an integer is caught only with it.
    write_c(DATA / f"model_v1_{name}.json", tmp_path, prefix="nf", table=table)
    driver = tmp_path / "driver.c"
    driver.write_text(NON_FINITE_DRIVER.format(prefix="nf"))
    program = tmp_path / "driver"
    sanitize = ["-fsanitize=undefined,float-cast-overflow", "-fno-sanitize-recover=all"]
    compiled = subprocess.run([GCC, *CFLAGS, *sanitize, "-I", str(tmp_path), str(driver),
                               str(tmp_path / "nf.c"), "-lm", "-o", str(program)],
                              capture_output=True, text=True, timeout=300)
    if compiled.returncode != 0 and "sanitize" in compiled.stderr:
        pytest.skip(f"gcc cannot link the sanitizer runtime: {compiled.stderr.strip()[:200]}")
    assert compiled.returncode == 0, compiled.stderr
    run = subprocess.run([str(program)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0 and run.stderr == "", run.stderr
    assert run.stdout.split("\n")[:3] == ["1 1"] * 3


@needs_gcc
def test_high_orders_lose_nothing(tmp_path):
    # k * theta up to 360 * 300 degrees: the phase is reduced in double before cos/sin.
    model = FourierModel([1, 150, 299, 300], [1.0, 0.5, 0.25, 0.125], [0.5, -0.5, 0.25, 0.0625],
                         encoder={"name": "high", "resolution_bits": 16})
    write_c(model, tmp_path, prefix="high", constants="float")
    at_codes, _ = build_and_run(tmp_path, "high")
    codes, theta = inputs()
    assert np.abs(at_codes[:, 0] - model.predict(theta)).max() <= 1e-6


@needs_gcc
def test_the_harmonic_recurrence_agrees_with_python_up_to_the_largest_order(tmp_path):
    # The C builds cos/sin(k theta) from one cos and one sin by the double-angle and angle-addition
    # formulas; with double constants it agrees with NumPy's direct cos/sin(k theta) to the float32
    # rounding of the returned value plus 1e-9 of the coefficients' sum, up to the largest order.
    rng = np.random.default_rng(3)
    orders = [*range(0, 40), 97, 255, 256, 1023, 4097, 32766, 32767]
    model = FourierModel(orders, rng.normal(0.0, 1.0, len(orders)), rng.normal(0.0, 1.0, len(orders)),
                         encoder={"name": "recurrence", "resolution_bits": 16})
    write_c(model, tmp_path, prefix="rec", constants="double")
    at_codes, at_extra = build_and_run(tmp_path, "rec")
    _, theta = inputs()
    scale = np.abs(model.cos).sum() + np.abs(model.sin).sum()
    expected = model.predict(theta)
    assert np.all(np.abs(at_codes[:, 0] - expected) <= 2.0**-24 * np.abs(expected) + 1e-9 * scale)
    extra = np.array(EXTRA_ANGLES, dtype=np.float32).astype(float)
    expected = model.predict(extra)
    assert np.all(np.abs(at_extra[:, 0] - expected) <= 2.0**-24 * np.abs(expected) + 1e-9 * scale)


@needs_gcc
def test_two_models_link_into_one_program(tmp_path):
    write_c(DATA / "model_v1_fourier.json", tmp_path, prefix="axis_a")
    write_c(DATA / "model_v1_lut.json", tmp_path, prefix="axis_b", table="int16")
    main = tmp_path / "main.c"
    main.write_text('#include <stdio.h>\n#include "axis_a.h"\n#include "axis_b.h"\n'
                    'int main(void) { printf("%.6f %.6f\\n", (double)axis_a_correct_deg(10.0f), '
                    '(double)axis_b_correct_counts(1000u)); return 0; }\n')
    program = tmp_path / "main"
    subprocess.run([GCC, *CFLAGS, str(main), str(tmp_path / "axis_a.c"),
                    str(tmp_path / "axis_b.c"), "-lm", "-o", str(program)], check=True,
                   timeout=300)
    a, b = map(float, subprocess.run([str(program)], capture_output=True, text=True,
                                     check=True).stdout.split())
    assert a == pytest.approx(float(Compensator(DATA / "model_v1_fourier.json").correct(10.0)),
                              abs=1e-5)
    table = compile_table(DATA / "model_v1_lut.json", 16)
    assert b == pytest.approx(float(table.correct_counts(1000)), abs=1e-5)


# -- the text ---------------------------------------------------------------------------

def test_banner_names_version_and_checksum():
    files = export_c(DATA / "model_v1_fourier.json")
    sha = json.loads((DATA / "model_v1_fourier.json").read_text())["sha256"]
    assert set(files) == {"encal.h", "encal.c"}
    for text in files.values():
        assert f"encal {encal.__version__}" in text and sha in text
    header = files["encal.h"]
    for signature in ("float encal_predict_arcmin(float theta_deg);",
                      "float encal_correct_deg(float theta_deg);",
                      "float encal_correct_counts(uint32_t code);", "#define ENCAL_BITS 16u"):
        assert signature in header


def test_constants_round_trip_float32():
    path = DATA / "model_v1_fourier.json"
    text = export_c(path, constants="float")["encal.c"]
    block = re.search(r"model_cos\[\d+\] = \{(.*?)\};", text, re.S).group(1)
    printed = [float(v.strip().rstrip("f")) for v in block.replace("\n", " ").split(",")]
    expected = json.loads(path.read_text())["parameters"]["cos"]
    assert np.array_equal(np.float32(printed), np.float32(expected))
    double = export_c(path, constants="double")["encal.c"]
    block = re.search(r"model_cos\[\d+\] = \{(.*?)\};", double, re.S).group(1)
    assert [float(v) for v in block.replace("\n", " ").split(",")] == expected


def unused_huge_weight():
    """A network with one more hidden unit whose input weights and bias are 0 and whose output weight is 1e39.

    tanh(0) = 0, so the unit adds exactly nothing: the model's errors are a few arc-minutes, but float32
    cannot hold one of its constants.
    """
    from encal.models import model_kind

    parameters = trained_ann("periodic").parameters()
    parameters["W1"].append([0.0, 0.0])
    parameters["b1"].append(0.0)
    parameters["W2"].append(1e39)
    model = model_kind("ann").read(parameters)
    model.encoder["resolution_bits"] = BITS
    return model


def test_auto_constants_fall_back_to_double_when_float32_is_not_enough():
    # Large terms: float32 coefficients would move the model by more than the budget.
    model = FourierModel([1, 2], [1e4 + 0.1, 0.0], [0.0, 1e4], encoder={"resolution_bits": 12})
    assert "static const double model_cos" in export_c(model)["encal.c"]
    assert "static const float model_cos" in export_c(DATA / "model_v1_fourier.json")["encal.c"]


def test_the_banner_states_what_float_constants_would_change():
    huge = unused_huge_weight()
    assert "constants stored as double (float32 cannot hold them)" in export_c(huge)["encal.c"]
    with pytest.raises(InputError, match="expected model constants within float32's range"):
        export_c(huge, constants="float")
    cancelling = FourierModel([1, 2], [1e4 + 0.1, 0.0], [0.0, 1e4], encoder={"resolution_bits": 12})
    assert re.search(r"constants stored as double \(float would change the model by at most 0\.0\d+ arcmin",
                     export_c(cancelling)["encal.c"])
    assert re.search(r"constants stored as float \(they change the model by at most \S+ arcmin",
                     export_c(offgrid_lut())["encal.c"])


def test_encoder_names_cannot_end_the_banner_comment():
    model = FourierModel([1], [1.0], [0.0],
                         encoder={"name": "evil */ int x;", "resolution_bits": 8})
    text = export_c(model)["encal.c"]
    banner = text[:text.index("*/")]
    assert "evil" in banner


@pytest.mark.parametrize("prefix", ["9lives", "a-b", "int", "__x", "_Upper", "", "motor axis",
                                    "é", None])
def test_invalid_prefixes_are_refused(prefix):
    with pytest.raises(InputError, match="C identifier"):
        export_c(DATA / "model_v1_fourier.json", prefix=prefix)


@pytest.mark.parametrize("prefix", ["encal", "axis_2", "_lower", "A"])
def test_valid_prefixes(prefix):
    assert f"{prefix}.c" in export_c(DATA / "model_v1_fourier.json", prefix=prefix)


def test_without_a_resolution_the_formula_is_exported_without_the_code_function_and_says_so():
    files = export_c(FourierModel([1], [1.0], [0.0]))
    assert "float encal_correct_counts(" not in files["encal.h"] + files["encal.c"]
    assert "ENCAL_BITS" not in files["encal.h"] and "resolution is unknown" in files["encal.c"]
    assert "#define ENCAL_BITS 12u" in export_c(FourierModel([1], [1.0], [0.0]), bits=12)["encal.h"]
    with pytest.raises(InputError, match="pass bits"):  # a per-code table needs the resolution
        export_c(FourierModel([1], [1.0], [0.0]), table="int16")


@needs_gcc
@pytest.mark.parametrize("name", ["model_v1_fourier.json", "model_v1_directional.json"])
def test_without_a_resolution_the_c_compiles(tmp_path, name):
    model = encal.load_model(DATA / name)
    model.encoder = {**model.encoder, "resolution_bits": None}
    write_c(model, tmp_path, prefix="m")
    built = subprocess.run([GCC, *CFLAGS, "-c", str(tmp_path / "m.c"), "-o", str(tmp_path / "m.o")],
                           capture_output=True, text=True, timeout=120)
    assert built.returncode == 0, built.stderr


@pytest.mark.parametrize("options", [{"bits": 33}, {"bits": 21, "table": "int16"},
                                     {"constants": "half"}, {"table": "int8"}])
def test_invalid_options_are_refused(options):
    with pytest.raises(InputError):
        export_c(DATA / "model_v1_fourier.json", **options)


def test_write_c_creates_the_folder(tmp_path):
    paths = write_c(DATA / "model_v1_fourier.json", tmp_path / "new" / "dir", prefix="m")
    assert [p.name for p in paths] == ["m.h", "m.c"] and all(p.is_file() for p in paths)


DIRECTED_DRIVER = """\
#include <stdio.h>
#include <stdint.h>
#include "dir.h"

int main(void)
{
    uint32_t k;
    for (k = 0; k < 65536u; k += 7u) {
        const float theta = (float)((double)k * (360.0 / 65536.0));
        const float out[4] = {dir_correct_deg_directed(theta, 1),
                              dir_correct_deg_directed(theta, -1),
                              dir_correct_counts_directed(k, 1),
                              dir_correct_deg_directed(theta, 0)};
        fwrite(out, sizeof(float), 4, stdout);
    }
    return 0;
}
"""


@needs_gcc
def test_directional_models_export_directed_functions(tmp_path):
    comp = Compensator(DATA / "model_v1_directional.json")
    write_c(comp, tmp_path, prefix="dir")
    assert "dir_correct_counts_directed" in (tmp_path / "dir.h").read_text()
    (tmp_path / "main.c").write_text(DIRECTED_DRIVER)
    program = tmp_path / "main"
    subprocess.run([GCC, *CFLAGS, "-I", str(tmp_path), str(tmp_path / "main.c"),
                    str(tmp_path / "dir.c"), "-lm", "-o", str(program)], check=True, timeout=300)
    raw = subprocess.run([str(program)], capture_output=True, check=True, timeout=60).stdout
    out = np.frombuffer(raw, dtype=np.float32).reshape(-1, 4).astype(float)
    codes = np.arange(0, 65536, 7)
    theta = (codes * (360.0 / 65536)).astype(np.float32).astype(float)
    tolerance = 2.0**-16 + 1e-4 / 60
    assert circular(out[:, 0], comp.correct(theta, direction=1)).max() <= tolerance
    assert circular(out[:, 1], comp.correct(theta, direction=-1)).max() <= tolerance
    by_code = comp.correct(codes * (360.0 / 65536), direction=1)
    assert circular(out[:, 2], by_code).max() <= tolerance
    assert circular(out[:, 3], comp.correct(theta)).max() <= tolerance
    assert circular(out[:, 0], out[:, 1]).max() > 1e-3  # the two directions differ


def test_only_directional_formulas_have_directed_functions():
    assert "directed" not in export_c(DATA / "model_v1_fourier.json")["encal.h"]
    assert "directed" not in export_c(DATA / "model_v1_directional.json", table="int16")["encal.h"]


def test_constants_beyond_float32_range():
    model = unused_huge_weight()
    assert "static const double model_W2" in export_c(model)["encal.c"]
    with pytest.raises(InputError, match="float32's range"):
        export_c(model, constants="float")


# -- task arcc6: float32 constants move a break where an arc model's export steps -----------------------------------

@needs_gcc
def test_float_constants_are_not_chosen_where_they_move_a_step_of_the_pieces_over_a_code(tmp_path):
    # The clamp export of an arc model steps at the middle of its gap (the end's correction, then the start's).
    # Here the middle lies 1e-6 degree past code 182045 of an 18-bit encoder, and float32 rounds it onto the
    # code: the grid of the float check (2^16 angles) missed it, float constants were chosen, and the code
    # was given the start's correction where encal correct --outside clamp gives the end's.
    from encal._core.arcs import apply_outside_rule, periodic_for_export
    from encal.models.arc import fit_arc

    bits, code = 18, 182045
    step = 360.0 / 2**bits
    middle = code * step + 1e-6
    start, end = 10.0, 2.0 * middle - 370.0
    assert float(np.float32(middle)) == code * step
    theta = np.linspace(start, end, 300)
    model = fit_arc(theta, 3.0 * np.sin(np.radians(theta)) + 1.0, range_deg=[start, end])
    model.encoder["resolution_bits"] = bits
    assert abs(float(model.predict(end)) - float(model.predict(start))) > 1.0  # arcmin: the step
    write_c(Compensator(periodic_for_export(model, "clamp")), tmp_path)
    on_codes, _ = build_and_run(tmp_path, "encal", bits=bits)
    expected = apply_outside_rule(model, np.arange(2**bits) * step, "clamp")
    assert circular(on_codes[:, 2], expected).max() < 2e-5  # degrees: the float return's rounding

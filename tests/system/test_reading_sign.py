"""An encoder that counts against its reference (``--reverse``): every consumer of a model applies it.

Known truth: the encoder reads ``raw = -(ref + delta(ref))`` with a small error ``delta`` (at most
2.5 arcmin), so the calibration read with ``reverse=True`` has the error ``delta`` and a corrected
reading must give back ``ref``. A Fourier model of orders 0..3 fits ``delta`` as a function of the
negated reading to within 1e-3 arcmin (the composition ``delta(ref(theta))`` adds harmonics of about
``delta * delta'`` = 2.5 * 7e-4 arcmin). Without the model file recording the orientation, the
model is applied to the raw reading and the "corrected" angle is near ``-ref``: wrong by up to 360
degrees.
"""

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

import encal
from encal._core.angles import model_input, wrap180
from encal.cli import main
from encal.deploy import Compensator, compile_table, load_table, runtime, save_table, write_c
from encal._core.errors import ModelFileError

GCC = shutil.which("gcc")
TOLERANCE_ARCMIN = 1e-3
BITS = 14


def delta_deg(ref_deg):
    theta = np.radians(ref_deg)
    return (2.0 * np.sin(theta) + 0.5 * np.cos(3 * theta) + 0.3) / 60.0


def raw_reading(ref_deg):
    return encal._core.angles.wrap360(-(ref_deg + delta_deg(ref_deg)))


def off_arcmin(corrected_deg, ref_deg):
    return np.abs(wrap180(np.asarray(corrected_deg) - ref_deg)) * 60.0


@pytest.fixture(scope="module")
def reversed_model(tmp_path_factory):
    folder = tmp_path_factory.mktemp("reverse")
    ref = np.arange(0.0, 360.0, 2.0)
    lines = ["reference_deg,encoder_deg"] + [f"{float(r)!r},{float(e)!r}" for r, e in zip(ref, raw_reading(ref))]
    csv = folder / "train.csv"
    csv.write_text("\n".join(lines) + "\n")
    path = folder / "model.json"
    assert main(["fit", str(csv), "-o", str(path), "--method", "fourier", "--orders", "0,1,2,3",
                 "--reverse"]) == 0
    return path


TEST_REF = np.arange(1.0, 360.0, 2.0)


def test_model_file_records_the_orientation_as_version_2(reversed_model):
    document = json.loads(reversed_model.read_text())
    assert document["reading_sign"] == -1
    assert document["version"] == 2


def test_a_forward_model_file_stays_version_1_without_the_field(tmp_path):
    ref = np.arange(0.0, 360.0, 2.0)
    model = encal.fit(encal.Calibration(ref, ref + delta_deg(ref)), method="fourier", orders=[0, 1])
    document = json.loads(model.save(tmp_path / "m.json").read_text())
    assert document["version"] == 1 and "reading_sign" not in document


def test_api_corrects_raw_readings(reversed_model):
    model = encal.load_model(reversed_model)
    raw = raw_reading(TEST_REF)
    assert off_arcmin(raw, -TEST_REF).max() > 1.0  # the readings themselves are off
    assert model.reading_sign == -1
    assert off_arcmin(model.correct(raw), TEST_REF).max() < TOLERANCE_ARCMIN
    assert off_arcmin(Compensator(reversed_model).correct(raw), TEST_REF).max() < TOLERANCE_ARCMIN
    # predict gives the error of the negated reading, the one the model was fitted on
    np.testing.assert_allclose(model.predict(raw), delta_deg(TEST_REF) * 60, atol=TOLERANCE_ARCMIN)
    # multi-turn readings
    assert off_arcmin(model.correct(raw + 720.0 * 5), TEST_REF).max() < TOLERANCE_ARCMIN


def test_evaluate_reverse_agrees_with_correct(reversed_model, tmp_path, capsys):
    raw = raw_reading(TEST_REF)
    csv = tmp_path / "test.csv"
    csv.write_text("reference_deg,encoder_deg\n"
                   + "".join(f"{float(r)!r},{float(e)!r}\n" for r, e in zip(TEST_REF, raw)))
    assert main(["evaluate", str(reversed_model), str(csv), "--reverse", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["max_abs_arcmin"] < TOLERANCE_ARCMIN
    assert result["before"]["max_abs_arcmin"] > 1.0


def test_encal_correct_command(reversed_model, tmp_path):
    raw = raw_reading(TEST_REF)
    source = tmp_path / "raw.txt"
    source.write_text("".join(f"{float(v)!r}\n" for v in raw))
    run = subprocess.run([sys.executable, "-m", "encal", "correct", str(reversed_model), str(source)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    corrected = np.array([float(line) for line in run.stdout.splitlines()])
    assert off_arcmin(corrected, TEST_REF).max() < TOLERANCE_ARCMIN


def test_standalone_runtime(reversed_model):
    model = runtime.load(reversed_model)
    raw = raw_reading(TEST_REF)
    corrected = np.array([model.correct_deg(float(v)) for v in raw])
    assert off_arcmin(corrected, TEST_REF).max() < TOLERANCE_ARCMIN
    python = encal.load_model(reversed_model)
    np.testing.assert_allclose([model.predict_arcmin(float(v)) for v in raw], python.predict(raw),
                               rtol=0, atol=1e-9)


def test_version_1_reader_refuses_a_reversed_file(reversed_model, monkeypatch):
    monkeypatch.setattr(runtime, "VERSION", 1)
    with pytest.raises(runtime.ModelFileError, match="newer than version 1"):
        runtime.load(reversed_model)


def _resigned(document):
    document = dict(document)
    document["sha256"] = runtime.content_sha256(document)
    return document


@pytest.mark.parametrize("change, message", [
    ({"version": 1}, "version 1 has no 'reading_sign'"),
    ({"reading_sign": 0}, "'reading_sign' to be 1 or -1"),
    ({"reading_sign": -1.0}, "'reading_sign' to be 1 or -1"),
    ({"reading_sign": True}, "'reading_sign' to be 1 or -1"),
    ({"reading_sign": None}, "'reading_sign' to be 1 or -1"),
])
def test_hand_edited_orientation_is_refused(reversed_model, tmp_path, change, message):
    document = _resigned({**json.loads(reversed_model.read_text()), **change})
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(document))
    with pytest.raises(runtime.ModelFileError, match=message):
        runtime.load(path)
    with pytest.raises(ModelFileError, match=message):
        encal.load_model(path)


def test_version_2_without_the_field_is_refused(reversed_model, tmp_path):
    document = json.loads(reversed_model.read_text())
    del document["reading_sign"]
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(_resigned(document)))
    with pytest.raises(ModelFileError, match="got nothing"):
        encal.load_model(path)


def test_dense_table(reversed_model, tmp_path):
    table = compile_table(reversed_model, BITS)
    assert table.reading_sign == -1
    path = save_table(table, tmp_path / "t.bin")
    loaded = load_table(path)
    assert loaded.reading_sign == -1
    assert path.read_bytes()[8] == 2  # version 2: a version-1 reader refuses it
    codes = np.arange(2**BITS)
    exact = Compensator(reversed_model).correct(codes * 360.0 / 2**BITS)
    limit = table.quantisation_arcmin + 1e-9
    assert off_arcmin(loaded.correct_counts(codes), exact).max() <= limit
    raw = raw_reading(TEST_REF)
    assert off_arcmin(loaded.correct(raw), TEST_REF).max() < (
        TOLERANCE_ARCMIN + table.quantisation_arcmin + table.between_codes_arcmin)


DRIVER = """\
#include <stdio.h>
#include <stdint.h>
#include "encal.h"

int main(void)
{
    double theta;
    uint32_t k;
    while (scanf("%lf %u", &theta, &k) == 2) {
        printf("%.9g %.9g %.9g\\n", (double)encal_predict_arcmin((float)theta),
               (double)encal_correct_deg((float)theta), (double)encal_correct_counts(k));
    }
    return 0;
}
"""


@pytest.mark.skipif(GCC is None, reason="gcc is not installed")
@pytest.mark.parametrize("table", [None, "int16"])
def test_compiled_c(reversed_model, tmp_path, table):
    write_c(reversed_model, tmp_path, bits=BITS, table=table)
    (tmp_path / "driver.c").write_text(DRIVER)
    program = tmp_path / "driver"
    subprocess.run([GCC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", "-I", str(tmp_path),
                    str(tmp_path / "driver.c"), str(tmp_path / "encal.c"), "-lm", "-o", str(program)],
                   check=True, timeout=300)
    raw = np.float32(raw_reading(TEST_REF)).astype(float)  # what the C function receives
    codes = np.arange(0, 2**BITS, 37)
    text = "".join(f"{float(theta)!r} {k}\n" for theta, k in zip(raw, codes)) + "".join(
        f"0.0 {k}\n" for k in codes[len(raw):])
    out = subprocess.run([str(program)], input=text, capture_output=True, text=True, check=True,
                         timeout=60).stdout
    values = np.array([[float(x) for x in line.split()] for line in out.splitlines()])
    model = encal.load_model(reversed_model)
    # float32 rounding of the reading (2^-16 deg near 360 = 0.0009 arcmin), of the result, and the table
    limit = 0.003 + (0.0 if table is None else compile_table(reversed_model, BITS).between_codes_arcmin + 0.01)
    assert off_arcmin(values[: len(raw), 1], TEST_REF).max() < limit + TOLERANCE_ARCMIN
    np.testing.assert_allclose(values[: len(raw), 0], model.predict(raw), atol=limit)
    exact = model.correct(codes * 360.0 / 2**BITS)
    assert off_arcmin(values[:, 2], exact).max() < limit


def test_model_input_is_its_own_inverse():
    theta = np.array([0.0, 1.5, 359.25, -720.0 + 3.0])
    np.testing.assert_allclose(model_input(model_input(theta, -1), -1), encal._core.angles.wrap360(theta))


def test_bidirectional_reversed_parts_count_with_the_reference():
    from encal.models.fitting import fit_bidirectional

    ref = np.tile(np.arange(0.0, 360.0, 5.0), 2)
    direction = np.repeat([1, -1], 72)
    delta = (np.sin(np.radians(ref)) + 0.15 * direction) / 60.0
    cal = encal.Calibration(ref, ref + delta, direction=direction, reading_sign=-1)
    model = fit_bidirectional(cal, method="fourier", orders=[0, 1])
    assert model.reading_sign == -1 and model.forward.reading_sign == 1
    raw = encal._core.angles.wrap360(-(ref + delta))
    assert off_arcmin(model.correct(raw, direction=direction), ref).max() < TOLERANCE_ARCMIN

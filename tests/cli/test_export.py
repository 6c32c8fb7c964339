"""`encal export`: dense tables and C source from a model file."""

import json
from pathlib import Path

import numpy as np
import pytest

from encal.cli import main
from encal.deploy import Compensator, compile_table, load_table
from encal.models.fourier import FourierModel
from tests._paths import DATA

MODEL = DATA / "model_v1_lut.json"


def export(capsys, *args):
    status = main(["export", *map(str, args)])
    out, err = capsys.readouterr()
    return status, out, err


@pytest.mark.parametrize("dtype", ["int16", "float32"])
def test_table(tmp_path, capsys, dtype):
    path = tmp_path / "enc.tab"
    status, out, err = export(capsys, MODEL, "--format", "table", "--bits", 12, "--dtype", dtype,
                              "-o", path)
    assert status == 0 and str(path) in out and "arcmin" in out
    assert err == f"encal export: warning: --bits 12 differs from the 16 bits {MODEL} records for its encoder: the " \
                  "export maps 12-bit codes to angles, right only if the encoder on the device has 12 bits\n"
    table = load_table(path)
    assert table.bits == 12 and table.dtype == dtype
    expected = compile_table(MODEL, 12, dtype=dtype)
    np.testing.assert_array_equal(table.values, expected.values)
    assert table.model_sha256 == json.loads(MODEL.read_text())["sha256"]


def test_table_bits_default_to_the_model_file(tmp_path, capsys):
    status, _, _ = export(capsys, MODEL, "--format", "table", "-o", tmp_path / "t.tab")
    assert status == 0 and load_table(tmp_path / "t.tab").bits == 16


def test_c(tmp_path, capsys):
    status, out, _ = export(capsys, MODEL, "--format", "c", "-o", tmp_path / "fw",
                            "--name", "axis1")
    assert status == 0
    header = (tmp_path / "fw" / "axis1.h").read_text()
    source = (tmp_path / "fw" / "axis1.c").read_text()
    assert "float axis1_correct_deg(float theta_deg);" in header
    assert "axis1_correct_counts" in source and "kind lut" in source
    assert str(tmp_path / "fw" / "axis1.c") in out


def test_c_with_a_table(tmp_path, capsys):
    status, _, _ = export(capsys, MODEL, "--format", "c", "-o", tmp_path, "--table", "--bits", 10,
                          "--dtype", "float32")
    source = (tmp_path / "encal.c").read_text()
    assert status == 0 and "static const float error_table[1024]" in source


def test_c_constants_option(tmp_path, capsys):
    export(capsys, DATA / "model_v1_fourier.json", "--format", "c", "-o", tmp_path,
           "--constants", "double")
    assert "static const double model_cos" in (tmp_path / "encal.c").read_text()


def test_table_without_bits_is_a_usage_error_in_command_line_terms(tmp_path, capsys):
    path = FourierModel([1], [1.0], [0.0]).save(tmp_path / "m.json")
    with pytest.raises(SystemExit) as info:
        main(["export", str(path), "--format", "table", "-o", str(tmp_path / "t.tab")])
    err = capsys.readouterr().err
    assert info.value.code == 2
    assert err.strip().splitlines()[-1] == (f"encal export: error: --format table has one entry per code, and {path} "
                                            "records no encoder resolution; pass --bits B")
    assert "bits=" not in err and not (tmp_path / "t.tab").exists()


def test_invalid_prefix_exit_1_and_writes_nothing(tmp_path, capsys):
    status, _, err = export(capsys, MODEL, "--format", "c", "-o", tmp_path / "fw", "--name", "9x")
    assert status == 1 and "C identifier" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "fw").exists()


def test_bad_model_file_exit_1(tmp_path, capsys):
    (tmp_path / "m.json").write_text("[]")
    status, _, err = export(capsys, tmp_path / "m.json", "--format", "c", "-o", tmp_path)
    assert status == 1 and "m.json" in err


def test_table_into_missing_folder_exit_1(tmp_path, capsys):
    status, _, err = export(capsys, MODEL, "--format", "table", "-o", tmp_path / "no" / "t.tab")
    assert status == 1 and "does not exist" in err


@pytest.mark.parametrize("args", [["--format", "c"], ["-o", "x"], ["--format", "onnx", "-o", "x"],
                                  ["--format", "table", "-o", "x", "--dtype", "int8"]])
def test_usage_errors_exit_2(capsys, args):
    with pytest.raises(SystemExit) as info:
        main(["export", str(MODEL), *args])
    assert info.value.code == 2


def test_exported_table_corrects_like_the_model(tmp_path, capsys):
    export(capsys, MODEL, "--format", "table", "-o", tmp_path / "t.tab")
    table = load_table(tmp_path / "t.tab")
    codes = np.arange(0, 2**16, 97)
    expected = Compensator(MODEL).correct(codes * (360.0 / 2**16))
    difference = (table.correct_counts(codes) - expected + 180.0) % 360.0 - 180.0
    assert np.abs(difference).max() <= table.quantisation_arcmin / 60 + 1e-12


def test_c_refuses_to_overwrite_the_model_it_exports(tmp_path, capsys):
    model = tmp_path / "axis.h"
    model.write_bytes((DATA / "model_v1_fourier.json").read_bytes())
    before = model.read_bytes()
    assert main(["export", str(model), "--format", "c", "-o", str(tmp_path), "--name", "axis"]) == 1
    err = capsys.readouterr().err
    assert f"(its axis.h) is the same file as the model file {model}" in err and err.count("\n") == 1
    assert model.read_bytes() == before and not (tmp_path / "axis.c").exists()


def test_json_names_what_was_written(tmp_path, capsys):
    path = tmp_path / "enc.tab"
    status, out, _ = export(capsys, MODEL, "--format", "table", "--bits", 12, "-o", path, "--json")
    record = json.loads(out)
    assert status == 0 and out.count("\n") == 1
    assert record["files"] == [str(path)] and record["bits"] == 12 and record["dtype"] == "int16"
    assert record["bytes"] == path.stat().st_size == 80 + 2 * 2**12
    assert record["quantisation_arcmin"] == pytest.approx(load_table(path).quantisation_arcmin)
    status, out, _ = export(capsys, MODEL, "--format", "c", "-o", tmp_path / "c", "--json")
    record = json.loads(out)
    assert status == 0 and record["format"] == "c"
    assert sorted(Path(p).name for p in record["files"]) == ["encal.c", "encal.h"]
    assert record["bytes"] == sum(Path(p).stat().st_size for p in record["files"])


def test_bits_other_than_the_models_are_said_and_the_host_c_says_what_it_costs(tmp_path, capsys):
    """Issue 28: --bits 16 on a 14-bit model was accepted silently, and --format c --table printed no deviation."""
    import numpy as np

    import encal
    from encal.cli import main

    reference = np.arange(0.0, 360.0, 2.0)
    cal = encal.Calibration(reference, reference + 2.0 * np.sin(np.radians(reference)) / 60.0, resolution_bits=14)
    model = tmp_path / "m.json"
    encal.fit(cal, method="fourier").save(model)
    assert main(["export", str(model), "--format", "c", "--bits", "16", "-o", str(tmp_path / "a")]) == 0
    captured = capsys.readouterr()
    assert "warning: --bits 16 differs from the 14 bits" in captured.err
    assert "--target cortex-m4f writes a float32 compact table (21 to 46 C operations" in captured.out
    assert main(["export", str(model), "--format", "c", "--table", "-o", str(tmp_path / "b")]) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and "14-bit int16 table:" in captured.out and "arcmin from the model at the codes" in \
        captured.out

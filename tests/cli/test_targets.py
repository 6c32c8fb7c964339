"""`encal export --format c --target cortex-m4f|fixed`: compact tables from the command line."""


import numpy as np
import pytest

import encal
from encal.cli import main
from tests._paths import DATA

MODEL = DATA / "model_v1_fourier.json"


def export(capsys, *args):
    status = main(["export", *map(str, args)])
    out, err = capsys.readouterr()
    return status, out, err


@pytest.mark.parametrize("target", ["cortex-m4f", "fixed"])
def test_target_writes_c_and_states_bytes_operations_and_error(tmp_path, capsys, target):
    status, out, err = export(capsys, MODEL, "--format", "c", "--target", target, "-o", tmp_path, "--name", "axis")
    assert status == 0 and err == ""
    assert "bytes" in out and "operations per reading" in out and "deployed error" in out and "RMS" in out
    source = (tmp_path / "axis.c").read_text()
    assert "double" not in source.replace("no double", "") and "axis_correct_code" in source


def test_tolerance_and_nodes(tmp_path, capsys):
    status, out, _ = export(capsys, MODEL, "--format", "c", "--target", "cortex-m4f", "-o", tmp_path,
                            "--nodes", "128", "--dtype", "float32")
    assert status == 0 and "128-node float32 table, 512 bytes" in out
    status, loose, _ = export(capsys, MODEL, "--format", "c", "--target", "cortex-m4f", "-o", tmp_path,
                              "--tolerance", "0.5")
    status, tight, _ = export(capsys, MODEL, "--format", "c", "--target", "cortex-m4f", "-o", tmp_path,
                              "--tolerance", "0.005")
    bytes_of = lambda text: int(text.split(" bytes")[0].rsplit(" ", 1)[1])  # noqa: E731
    assert bytes_of(loose) < bytes_of(tight)


def test_cubic_interpolation(tmp_path, capsys):
    status, out, _ = export(capsys, MODEL, "--format", "c", "--target", "cortex-m4f", "-o", tmp_path,
                            "--nodes", "512", "--dtype", "int16", "--interpolation", "cubic")
    assert status == 0 and "512-node int16 cubic B-spline table, 1024 bytes, 40 operations per reading" in out
    assert "cubic B-spline" in (tmp_path / "encal.c").read_text()
    # the same nodes interpolated linearly are further from the model (its orders reach 97)
    status, linear, _ = export(capsys, MODEL, "--format", "c", "--target", "cortex-m4f", "-o", tmp_path,
                               "--nodes", "512", "--dtype", "int16", "--interpolation", "linear")
    max_of = lambda text: float(text.split("max ")[1].split(",")[0])  # noqa: E731
    assert status == 0 and max_of(out) < max_of(linear) / 4


def test_formula(tmp_path, capsys):
    status, out, _ = export(capsys, MODEL, "--format", "c", "--target", "cortex-m4f", "--form", "formula",
                            "-o", tmp_path)
    assert status == 0 and "9-term Fourier series in float32" in out


@pytest.mark.parametrize("args, message", [
    (["--target", "cortex-m4f", "--table"], "--table and --constants apply to --target host"),
    (["--nodes", "64"], "apply to --target cortex-m4f or fixed"),
    (["--target", "fixed", "--dtype", "float32"], "not --dtype float32"),
    (["--target", "fixed", "--form", "formula"], "not --form formula"),
    (["--dtype", "int8"], "a dense table is int16 or float32"),
    (["--target", "cortex-m4f", "--form", "formula", "--interpolation", "cubic"], "not --form formula"),
    (["--interpolation", "cubic"], "apply to --target cortex-m4f or fixed"),
    (["--target", "cortex-m4f", "--interpolation", "cubic", "--cost", "bytes"], "--cost chooses the deployment"),
])
def test_options_that_do_not_go_together_are_usage_errors(tmp_path, capsys, args, message):
    with pytest.raises(SystemExit) as info:
        export(capsys, MODEL, "--format", "c", "-o", tmp_path, *args)
    err = capsys.readouterr().err
    assert info.value.code == 2 and message in err and err.startswith("usage:")
    assert not (tmp_path / "encal.c").exists()


def test_formula_of_a_model_that_is_not_a_series_is_refused(tmp_path, capsys):
    status, _, err = export(capsys, DATA / "model_v1_lut.json", "--format", "c", "--target", "cortex-m4f",
                            "--form", "formula", "-o", tmp_path)
    assert status == 1 and "expected a Fourier series" in err and "Traceback" not in err


def test_a_library_message_about_an_option_names_the_flag_the_user_gave(tmp_path, capsys):
    from encal.cli import _in_flag_terms, build_parser, main

    model = tmp_path / "m.json"
    encal.save_model(encal.fit(encal.Calibration(np.arange(0.0, 360.0, 2.0),
                                                 np.arange(0.0, 360.0, 2.0) + 0.01), method="fourier"), model)
    assert main(["export", str(model), "--format", "c", "-o", str(tmp_path / "c"), "--target", "fixed",
                 "--bits", "14", "--tolerance", "-1"]) == 1
    err = capsys.readouterr().err
    assert err == ("encal export: error: --tolerance must be a finite number > 0 (arc-minutes, or None). "
                   "Got -1.0 instead.\n")
    # A value the user did not give (from the model file, or a default) keeps the library's wording.
    args = build_parser().parse_args(["export", str(model), "--format", "c", "-o", "x"])
    text = "The 'bits' parameter of export_c must be an int from 1 to 32. Got 0 instead."
    assert _in_flag_terms(text, args) == text
    assert _in_flag_terms("no such file", args) == "no such file"


@pytest.mark.parametrize("interpolation, bits, function", [
    ("cubic", "14", "error_lsb"), ("cubic", None, "correct_deg"), ("linear", "14", "error_lsb"),
    ("linear", None, "correct_deg")])
def test_the_cost_quoted_is_of_a_function_the_export_holds(tmp_path, capsys, interpolation, bits, function):
    """Without a resolution only the angle functions are exported: the cost quoted is correct_deg's, not that of
    the code functions left out (it quoted error_lsb's 40 operations for a cubic table it had no code function of)."""
    from encal.deploy.costs import OPERATIONS

    model = tmp_path / "nobits.json"
    reference = np.arange(0.0, 360.0, 2.0)
    encal.fit(encal.Calibration(reference, reference + np.sin(np.radians(reference)) / 60), "fourier",
              orders=[0, 1]).save(model)
    status, out, _ = export(capsys, model, "--format", "c", "--target", "cortex-m4f", "-o", tmp_path,
                            "--interpolation", interpolation, *(["--bits", bits] if bits else []))
    form = "cubic" if interpolation == "cubic" else "table"
    assert status == 0 and f", {OPERATIONS[('cortex-m4f', form, function)]} operations per reading" in out
    assert ("correct_code" in (tmp_path / "encal.c").read_text()) == (bits is not None)

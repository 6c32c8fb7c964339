"""Files and paths (issue 25): no command writes over its inputs, every path is checked before any work,
``encal correct`` bounds its lines and never leaves part of a line, spreadsheet exports read as they mean,
and the Python API refuses what is no path with encal's errors.

The command-line cases are also in the catalogue (tests/system/test_robustness_cli.py, "issue 25: files and paths");
here are the ones that need a file system trick, a process of their own, or a look at the numbers read.
"""

import errno
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import encal
from encal.cli import main
from encal.cli._common import check_paths
from encal._core.errors import CalibrationError, InputError, ModelFileError

GRID = np.arange(0.0, 360.0, 2.0)


def _calibration_text(separator=",", decimal=".", header=("reference_deg", "encoder_deg"), quote=False):
    encoder = GRID + (2.0 * np.sin(np.radians(GRID) + 0.3) + 0.6 * np.cos(2 * np.radians(GRID))) / 60.0
    names = [f'"{name}"' if quote else name for name in header]
    rows = [separator.join(repr(float(v)).replace(".", decimal) for v in pair) for pair in zip(GRID, encoder)]
    return separator.join(names) + "\n" + "\n".join(rows) + "\n"


@pytest.fixture
def calibration(tmp_path):
    path = tmp_path / "cal.csv"
    path.write_text(_calibration_text(), encoding="utf-8")
    return path


@pytest.fixture
def model(calibration, tmp_path):
    return encal.fit(encal.read_calibration(calibration), method="fourier").save(tmp_path / "m.json")


# --------------------------------------------------------------------------- outputs that are inputs

@pytest.mark.parametrize("how", ["same name", "another path", "symbolic link", "hard link"])
def test_an_output_that_is_an_input_is_refused(how, calibration, tmp_path):
    """The same file under any name is the input: a symbolic link would have replaced the calibration itself."""
    output = {"same name": calibration, "another path": tmp_path / "." / "cal.csv",
              "symbolic link": tmp_path / "link.csv", "hard link": tmp_path / "hard.csv"}[how]
    if how == "symbolic link":
        output.symlink_to(calibration)
    elif how == "hard link":
        os.link(calibration, output)
    with pytest.raises(InputError, match=r"-o .* is the same file as the input calibration .*cal\.csv"):
        check_paths(inputs=[(calibration, "calibration")], outputs=[("-o", output)])


def test_an_input_given_twice_is_refused(calibration, tmp_path, capsys):
    """`fit A.csv --repeat A.csv` took the noise from the differences of identical readings: 1.5e-7 arcmin, exit 0."""
    assert main(["fit", str(calibration), "--repeat", str(tmp_path / "." / "cal.csv"), "-o", str(tmp_path / "m.json"),
                 "--method", "spectral"]) == 1
    assert "the same input given twice" in capsys.readouterr().err
    assert not (tmp_path / "m.json").exists()


def test_two_outputs_that_are_one_file_are_refused(tmp_path):
    """Neither exists yet: compared by their resolved paths."""
    with pytest.raises(InputError, match="--stepper-csv .*s.csv is the same file as the output -o"):
        check_paths(outputs=[("-o", tmp_path / "s.csv"), ("--stepper-csv", tmp_path / "." / "s.csv")])


def test_a_file_a_folder_output_would_write_is_checked(calibration, tmp_path):
    with pytest.raises(InputError, match=r"--out .* \(its cal.csv\) is the same file as the input calibration"):
        check_paths(inputs=[(calibration, "calibration")], folders=[("--out", tmp_path, ["cal.csv"])])
    check_paths(inputs=[(calibration, "calibration")], folders=[("--out", tmp_path, ["other.csv"])])


def test_study_writes_the_files_it_checks(calibration, tmp_path, capsys):
    """check_paths is told which files `study --out` writes (cmd_study._WRITES): the files it does write."""
    from encal.cli.cmd_study import _WRITES

    out = tmp_path / "study"
    assert main(["study", "prune", str(calibration), "--out", str(out), "--hidden", "3", "--epochs", "2"]) == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(_WRITES["prune"])


def test_fit_over_its_repeat_keeps_the_repeat(calibration, tmp_path, capsys):
    """`encal fit A.csv --repeat R.csv -o R.csv` replaced R.csv with a model file and exited 0."""
    repeat = tmp_path / "repeat.csv"
    repeat.write_bytes(calibration.read_bytes())
    before = repeat.read_bytes()
    assert main(["fit", str(calibration), "--repeat", str(repeat), "-o", str(repeat), "--method", "spectral"]) == 1
    assert "is the same file as the input calibration" in capsys.readouterr().err
    assert repeat.read_bytes() == before


def test_report_with_a_model_path_that_cannot_be_written_writes_nothing(calibration, tmp_path, capsys):
    """The page and its PNG files were written, then the model file failed: exit 1 with files left behind."""
    page = tmp_path / "r.html"
    status = main(["report", str(calibration), "-o", str(page), "--model", str(tmp_path / "no" / "m.json"),
                   "--method", "fourier", "--no-uncertainty", "--no-comparison"])
    assert status == 1 and "does not exist" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.csv"]


def test_report_writes_its_model_with_its_page(calibration, tmp_path, capsys):
    page, model = tmp_path / "r.html", tmp_path / "m.json"
    assert main(["report", str(calibration), "-o", str(page), "--model", str(model), "--method", "fourier",
                 "--no-uncertainty", "--no-comparison"]) == 0
    assert page.is_file() and encal.load_model(model).kind == "fourier"


# --------------------------------------------------------------------------- encal correct: lines and a full disk

def test_correct_on_a_full_device_says_so_in_one_line(model, tmp_path):
    """`encal correct M < in > /dev/full`: status 1 and one sentence, no traceback."""
    if not Path("/dev/full").exists():
        pytest.skip("no /dev/full on this system")
    angles = "".join(f"{k * 0.37}\n" for k in range(100_000))
    source = str(Path(encal.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [source, os.environ.get("PYTHONPATH")]))}
    with open("/dev/full", "wb") as full:
        process = subprocess.run([sys.executable, "-m", "encal", "correct", str(model)], input=angles.encode(),
                                 stdout=full, stderr=subprocess.PIPE, timeout=120, env=env)
    err = process.stderr.decode()
    assert process.returncode == 1 and err.count("\n") == 1, err
    assert err.startswith("encal correct: error: cannot write the corrected angles to standard output (No space")


def test_a_write_that_fails_half_way_leaves_whole_lines(model, tmp_path, monkeypatch, capsys):
    """A disk that fills during a write takes part of a line first: the file is cut back to the last whole line."""
    import encal.cli.cmd_correct as cmd_correct

    real_write, budget = os.write, [50_000]

    def write(descriptor, data):
        if budget[0] <= 0:
            raise OSError(errno.ENOSPC, "No space left on device")
        taken = real_write(descriptor, bytes(data[:budget[0]]))
        budget[0] -= taken
        return taken

    angles = tmp_path / "angles.txt"
    angles.write_text("".join(f"{k * 0.37}\n" for k in range(20_000)), encoding="ascii")
    whole, output = tmp_path / "whole.txt", tmp_path / "out.txt"
    for path in (whole, output):
        if path is output:
            monkeypatch.setattr(cmd_correct.os, "write", write)
        with open(path, "wb") as handle:
            monkeypatch.setattr(sys, "stdout", open(handle.fileno(), "w", closefd=False))
            status = main(["correct", str(model), str(angles)])
    err = capsys.readouterr().err
    data = output.read_bytes()
    assert status == 1 and "No space left on device" in err, err
    assert data.endswith(b"\n") and 40_000 < len(data) <= 50_000 and whole.read_bytes().startswith(data)
    answers = data.count(b"\n")
    assert f"the answers to the first {answers} angles are written whole" in err


@pytest.mark.parametrize("from_stdin", [False, True])
def test_correct_appending_to_its_input_is_refused(from_stdin, model, tmp_path):
    """`encal correct M a.txt >> a.txt` read its own answers back as angles, without end (21,141 lines in 3 s)."""
    angles = tmp_path / "a.txt"
    angles.write_text("10\n20\n", encoding="ascii")
    source = str(Path(encal.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [source, os.environ.get("PYTHONPATH")]))}
    argv = [sys.executable, "-m", "encal", "correct", str(model), *([] if from_stdin else [str(angles)])]
    with open(angles, "ab") as output, open(angles, "rb") as stdin:
        process = subprocess.run(argv, stdin=stdin, stdout=output, stderr=subprocess.PIPE, timeout=60, env=env)
    assert process.returncode == 1 and "standard output is the same file as" in process.stderr.decode()
    assert angles.read_text(encoding="ascii") == "10\n20\n"


def test_correct_appending_to_its_model_is_refused(model, tmp_path):
    """`encal correct M.json a.txt >> M.json` appended the answers to the model file."""
    before = model.read_bytes()
    source = str(Path(encal.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [source, os.environ.get("PYTHONPATH")]))}
    with open(model, "ab") as output:
        process = subprocess.run([sys.executable, "-m", "encal", "correct", str(model)], input=b"10\n",
                                 stdout=output, stderr=subprocess.PIPE, timeout=60, env=env)
    assert process.returncode == 1 and "the same file as the model file" in process.stderr.decode()
    assert model.read_bytes() == before


def test_lines_over_64_kib_are_refused_after_the_answers_before_them(model, tmp_path, capsys):
    """The stream let lines of up to 128 KiB through; `0...025` padded to 100 KB is 25 and was answered."""
    angles = tmp_path / "angles.txt"
    angles.write_text("10\n20\n" + "0" * 100_000 + "25\n30\n", encoding="ascii")
    assert main(["correct", str(model), str(angles)]) == 1
    out, err = capsys.readouterr()
    assert len(out.splitlines()) == 2
    assert "line 3 of" in err and "longer than 65536 bytes" in err


# --------------------------------------------------------------------------- spreadsheet exports

@pytest.mark.parametrize("separator,decimal,quote,bom", [
    (";", ",", True, True), (";", ".", False, False), ("\t", ",", True, True), ("\t", ",", False, False),
    ("\t", ".", True, False), (" ", ",", False, False)])
def test_spreadsheet_exports_read_the_same_numbers(separator, decimal, quote, bom, tmp_path):
    """Semicolons, tabs, decimal commas, quoted names, a BOM and CRLF: the same doubles as the comma file."""
    reference = encal.read_calibration(_write(tmp_path / "comma.csv", _calibration_text()))
    text = _calibration_text(separator, decimal, quote=quote).replace("\n", "\r\n")
    other = encal.read_calibration(_write(tmp_path / "export.csv", ("\ufeff" if bom else "") + text))
    np.testing.assert_array_equal(other.reference_deg, reference.reference_deg)
    np.testing.assert_array_equal(other.encoder_deg, reference.encoder_deg)


def test_a_spreadsheet_export_without_header_keeps_its_first_row(tmp_path):
    """`0,0;0,04...` is a row of numbers, not a header: read with --ref-col 1 --enc-col 2, all 180 rows."""
    reference = encal.read_calibration(_write(tmp_path / "comma.csv", _calibration_text()))
    body = "".join(_calibration_text(";", ",").splitlines(keepends=True)[1:])
    other = encal.read_calibration(_write(tmp_path / "rows.csv", body), reference_column=1, encoder_column=2)
    np.testing.assert_array_equal(other.encoder_deg, reference.encoder_deg)


def _write(path, text):
    path.write_text(text, encoding="utf-8", newline="")
    return path


def test_the_fast_and_the_careful_reader_agree_on_blank_separated_files(tmp_path):
    """A plain tab-separated body goes to NumPy; with decimal commas (NumPy refuses them) or after a comment
    line (not plain) to the line-by-line reader: the same numbers, bit for bit."""
    plain = _calibration_text("\t")
    fast = encal.read_calibration(_write(tmp_path / "fast.csv", plain))
    careful = encal.read_calibration(_write(tmp_path / "careful.csv", plain + "# the end\n"))
    commas = encal.read_calibration(_write(tmp_path / "commas.csv", _calibration_text("\t", ",")))
    for other in (careful, commas):
        np.testing.assert_array_equal(other.encoder_deg, fast.encoder_deg)


@pytest.mark.parametrize("cell,words", [("1,080", "decimal comma"), ("1.234,5", "digit grouping")])
def test_a_comma_that_may_group_digits_is_refused(cell, words, tmp_path):
    """`1,080` among `10.5`: a grouping comma (1080) read as a decimal comma would be a wrong number."""
    lines = _calibration_text("\t").splitlines()
    lines[5] = lines[5].split("\t")[0] + "\t" + cell
    with pytest.raises(CalibrationError, match=words):
        encal.read_calibration(_write(tmp_path / "mixed.csv", "\n".join(lines) + "\n"))


def test_a_comma_separated_file_never_reads_a_decimal_comma(tmp_path):
    lines = _calibration_text().splitlines()
    lines[5] = lines[5].split(",")[0] + ',"10,5"'
    with pytest.raises(CalibrationError, match="'10,5', expected a number"):
        encal.read_calibration(_write(tmp_path / "quoted.csv", "\n".join(lines) + "\n"))


# --------------------------------------------------------------------------- the Python API

@pytest.mark.parametrize("path", [None, 5, True, 2.5])
def test_load_model_refuses_what_is_no_path(path):
    """`load_model(5)` read (and closed) file descriptor 5; None raised TypeError."""
    with pytest.raises(ModelFileError, match="expected the path of a model file"):
        encal.load_model(path)


def test_load_model_of_a_folder_or_a_device(tmp_path):
    with pytest.raises(ModelFileError, match="is a folder"):
        encal.load_model(tmp_path)
    if Path("/dev/zero").exists():
        with pytest.raises(ModelFileError, match="NUL byte at offset 0"):
            encal.load_model("/dev/zero")


@pytest.mark.parametrize("path", [None, 5])
def test_read_calibration_refuses_what_is_no_path(path):
    with pytest.raises(CalibrationError, match="path of a calibration CSV"):
        encal.read_calibration(path)


@pytest.mark.parametrize("angles", ["abc", None, {"a": 1}, [[1.0], [1.0, 2.0]], 1 + 2j])
def test_correct_and_predict_refuse_what_is_no_angle(angles, model):
    fitted = encal.load_model(model)
    for method in (fitted.correct, fitted.predict):
        with pytest.raises(InputError, match="encoder angles must be finite numbers of degrees"):
            method(angles)


def test_the_reference_and_the_encoder_in_one_column(calibration):
    with pytest.raises(CalibrationError, match="both column 2"):
        encal.read_calibration(calibration, reference_column=2, encoder_column=2)
    with pytest.raises(CalibrationError, match=r"both column 2 \(encoder_deg\)"):
        encal.read_calibration(calibration, reference_column="2", encoder_column="encoder_deg")


@pytest.mark.parametrize("path", [None, 3])
def test_saving_to_what_is_no_path_is_refused(path, model):
    """`model.save(None)` raised TypeError; `3` would have been taken for a file descriptor by a lower layer."""
    with pytest.raises(InputError, match="expected the path of a file"):
        encal.load_model(model).save(path)

"""`encal export --format <firmware>` and `encal import`: firmware formats from the command line."""

from pathlib import Path

import numpy as np
import pytest

import encal
from encal.cli import main

DATA = Path(__file__).parent / "data"
MODEL = DATA / "model_v1_lut.json"


def run(capsys, *args):
    status = main([*map(str, args)])
    out, err = capsys.readouterr()
    return status, out, err


@pytest.mark.parametrize("fmt, extra, marker", [
    ("moteus", ["--source", "2"], "\nmotor_position.sources.2.compensation_table.0 "),
    ("moteus", ["--source", "2", "--moteus-style", "console"], "conf set motor_position.sources.2.compensation_table.0 "),
    ("simplefoc", [], "float calibrationLut[128]"),
    ("klipper", ["--full-steps", "400"], "calibrate:"),
    ("mechaduino", ["--bits", "14"], "lookup[16384]"),
    ("tinymovr", ["--bits", "13"], "int16_t rec_table[64]"),
])
def test_export_firmware_formats(tmp_path, capsys, fmt, extra, marker):
    path = tmp_path / "out.txt"
    status, out, err = run(capsys, "export", MODEL, "--format", fmt, "-o", path, *extra)
    assert status == 0 and err == "" and marker in path.read_text()
    assert "round trip through its own run-time rule" in out and "arcmin" in out


def test_firmware_formats_refuse_c_options(tmp_path, capsys):
    with pytest.raises(SystemExit) as info:
        run(capsys, "export", MODEL, "--format", "moteus", "--target", "fixed", "-o", tmp_path / "x")
    assert info.value.code == 2


def test_import_round_trips(tmp_path, capsys):
    run(capsys, "export", MODEL, "--format", "moteus", "-o", tmp_path / "m.cfg")
    status, out, _ = run(capsys, "import", "moteus", tmp_path / "m.cfg", "-o", tmp_path / "m.json")
    assert status == 0
    theta = np.arange(0.0, 360.0, 0.5)
    reread = encal.load_model(tmp_path / "m.json")
    assert np.max(np.abs(reread.predict(theta) - encal.load_model(MODEL).predict(theta))) < 0.05
    run(capsys, "export", MODEL, "--format", "klipper", "-o", tmp_path / "k.cfg")
    status, out, _ = run(capsys, "import", "klipper", tmp_path / "k.cfg", "-o", tmp_path / "k.csv")
    assert status == 0 and "200 points" in out and len(encal.read_calibration(tmp_path / "k.csv")) == 200


def test_import_refusals(tmp_path, capsys):
    (tmp_path / "t.c").write_text("int16_t rec_table[64] = {1, 2};")
    with pytest.raises(SystemExit) as info:
        run(capsys, "import", "tinymovr", tmp_path / "t.c", "-o", tmp_path / "t.json")
    assert info.value.code == 2 and "--bits is required" in capsys.readouterr().err
    status, _, err = run(capsys, "import", "tinymovr", tmp_path / "t.c", "-o", tmp_path / "t.json", "--bits", "13")
    assert status == 1 and "rec_table[64] holds 2 values" in err and not (tmp_path / "t.json").exists()
    (tmp_path / "cap.log").write_text("hello\n")
    status, _, err = run(capsys, "import", "moteus-cal", tmp_path / "cap.log", "-o", tmp_path / "c.csv")
    assert status == 1 and "CAL start" in err and not (tmp_path / "c.csv").exists()

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
    ("moteus", ["--source", "2"], "conf set motor_position.sources.2.compensation_table.0 "),
    ("simplefoc", [], "float calibrationLut[128]"),
    ("klipper", ["--full-steps", "400", "--step-zero", "0.9"], "calibrate:"),
    ("mechaduino", ["--bits", "14", "--step-zero", "0"], "lookup[16384]"),
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
    run(capsys, "export", MODEL, "--format", "klipper", "--step-zero", "0", "-o", tmp_path / "k.cfg")
    status, out, _ = run(capsys, "import", "klipper", tmp_path / "k.cfg", "-o", tmp_path / "k.csv")
    assert status == 0 and "200 points" in out and len(encal.read_calibration(tmp_path / "k.csv")) == 200


def test_step_zero_is_required_for_the_stepper_firmwares_and_only_for_them(tmp_path, capsys):
    for fmt in ("klipper", "mechaduino"):
        with pytest.raises(SystemExit) as info:
            run(capsys, "export", MODEL, "--format", fmt, "-o", tmp_path / "x")
        err = capsys.readouterr().err
        assert info.value.code == 2 and f"--format {fmt} needs --step-zero DEG" in err
        assert not (tmp_path / "x").exists()
    with pytest.raises(SystemExit) as info:
        run(capsys, "export", MODEL, "--format", "moteus", "--step-zero", "1", "-o", tmp_path / "x")
    assert info.value.code == 2 and "--step-zero is for --format klipper and mechaduino" in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        run(capsys, "export", MODEL, "--format", "klipper", "--step-zero", "nan", "-o", tmp_path / "x")
    assert info.value.code == 2 and "expected a finite angle in degrees, got 'nan'" in capsys.readouterr().err
    assert "klipper, mechaduino:" in capsys.readouterr().out + _help(capsys)


def _help(capsys):
    with pytest.raises(SystemExit):
        run(capsys, "export", "--help")
    return capsys.readouterr().out


def test_import_of_a_reversed_list_says_to_fit_with_reverse(tmp_path, capsys):
    values = ", ".join(f"{65400 - i * 327.68:.1f}" for i in range(200))
    (tmp_path / "k.cfg").write_text(f"[angle s]\ncalibrate:\n    {values}\n")
    status, out, _ = run(capsys, "import", "klipper", tmp_path / "k.cfg", "-o", tmp_path / "k.csv")
    assert status == 0 and "fit it with --reverse" in out
    with pytest.raises(encal.errors.CalibrationError, match="use --reverse"):
        encal.read_calibration(tmp_path / "k.csv")
    cal = encal.read_calibration(tmp_path / "k.csv", reverse=True)
    assert cal.reading_sign == -1 and len(cal) == 200


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

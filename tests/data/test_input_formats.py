"""Input that meets the user: other column names, units per column, whitespace-separated files, and
the resolution inferred from the readings; each of the README's three kinds of file with one command."""

import json

import numpy as np
import pytest

from encal import read_calibration
from encal.cli import main
from encal._core.errors import CalibrationError
from tests._paths import EXAMPLES

STEPPER = ["--ref-col", "step_deg", "--enc-col", "counts", "--enc-unit", "counts:14"]
MOTOR = ["--ref-col", "commanded_rev", "--enc-col", "measured_rev", "--unit", "rev"]
#: RMS of the examples' profile 9 sin + 6 cos 2θ + 2.5 sin 4θ (arcmin)
PROFILE_RMS = np.sqrt((9.0**2 + 6.0**2 + 2.5**2) / 2)


def run(capsys, *argv):
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def test_a_stepper_in_counts_with_an_arbitrary_zero(capsys):
    status, out, err = run(capsys, "profile", EXAMPLES / "stepper.csv", *STEPPER, "--json")
    assert status == 0 and err == ""
    record = json.loads(out)
    assert record["n"] == 200 and record["resolution_bits"] == 14
    assert record["zero"] == "arbitrary"
    assert record["zero_offset_arcmin"] == pytest.approx(59.3 * 60.0, abs=0.5)
    assert record["rms_arcmin"] == pytest.approx(PROFILE_RMS, abs=0.25)  # + 0.5 noise, 1.3' counts
    assert [h["order"] for h in record["harmonics"][:3]] == [1, 2, 4]


def test_a_motor_log_in_revolutions_separated_by_whitespace(capsys):
    status, out, err = run(capsys, "profile", EXAMPLES / "motor_log.txt", *MOTOR, "--json")
    assert status == 0 and err == ""
    record = json.loads(out)
    assert record["n"] == 400 and record["zero"] == "fixed"
    assert record["rms_arcmin"] == pytest.approx(PROFILE_RMS, abs=0.1)
    top = {h["order"]: h["amplitude_arcmin"] for h in record["harmonics"][:3]}
    assert top == pytest.approx({1: 9.0, 2: 6.0, 4: 2.5}, abs=0.1)


@pytest.mark.parametrize("name, options", [("stepper.csv", STEPPER), ("motor_log.txt", MOTOR)])
def test_fit_and_report_take_the_same_options(tmp_path, capsys, name, options):
    model = tmp_path / "m.json"
    status, out, _ = run(capsys, "fit", EXAMPLES / name, *options, "-o", model, "--method", "fourier", "--json")
    assert status == 0
    record = json.loads(out)
    assert record["training_set"]["rms_arcmin"] < 1.0  # the shape is corrected to the noise
    page = tmp_path / "r.html"
    status, _, _ = run(capsys, "report", EXAMPLES / name, *options, "-o", page, "--method", "fourier",
                       "--no-uncertainty", "--no-comparison")
    assert status == 0 and "<h2>Harmonics</h2>" in page.read_text(encoding="utf-8")


def test_the_api_reads_columns_and_units():
    cal = read_calibration(EXAMPLES / "stepper.csv", reference_column="step_deg", encoder_column="counts",
                           encoder_unit="counts:14")
    assert cal.resolution_bits == 14
    assert cal.reference_deg[1] == pytest.approx(1.8)
    np.testing.assert_allclose(cal.encoder_deg * 2**14 / 360, np.round(cal.encoder_deg * 2**14 / 360), atol=1e-6)
    motor = read_calibration(EXAMPLES / "motor_log.txt", reference_column="commanded_rev",
                             encoder_column="measured_rev", reference_unit="rev", encoder_unit="rev")
    assert motor.reference_deg[1] == pytest.approx(0.9)


@pytest.mark.parametrize("unit, scale", [("deg", 1.0), ("rad", np.pi / 180.0), ("rev", 1 / 360.0)])
def test_units_convert_to_degrees(write_csv, unit, scale):
    ref = np.arange(0.0, 360.0, 5.0)
    text = "a,b\n" + "".join(f"{float(r * scale)!r},{float((r + 0.1) * scale)!r}\n" for r in ref)
    cal = read_calibration(write_csv(text), reference_column="a", encoder_column="b", reference_unit=unit,
                           encoder_unit=unit)
    np.testing.assert_allclose(cal.errors_arcmin, 6.0, atol=1e-9)


def test_a_missing_column_names_the_header_and_the_option(write_csv, capsys):
    path = write_csv("step_deg,counts\n" + "".join(f"{1.8 * i},{82 * i}\n" for i in range(200)))
    status, _, err = run(capsys, "profile", path)
    assert status == 1 and err.count("\n") == 1
    assert "step_deg, counts" in err and "--ref-col" in err and "--enc-col" in err
    status, _, err = run(capsys, "profile", path, "--ref-col", "step", "--enc-col", "counts")
    assert status == 1 and "no column 'step'" in err


def test_an_unknown_unit_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as info:
        main(["profile", str(EXAMPLES / "stepper.csv"), "--enc-unit", "counts"])
    assert info.value.code == 2
    assert "counts:B" in capsys.readouterr().err


def test_a_whitespace_row_with_a_missing_field_is_refused(write_csv):
    rows = "".join(f"{r:.1f}  {r + 0.1:.4f}\n" for r in np.arange(0.0, 360.0, 2.0))
    path = write_csv("ref   enc\n" + rows + "12.0\n", name="log.txt")
    with pytest.raises(CalibrationError, match=r"line 182: has 1 field, expected 2"):
        read_calibration(path, reference_column="ref", encoder_column="enc")


def test_the_resolution_is_inferred_from_readings_on_a_2_to_the_b_grid(write_csv, capsys):
    ref = np.arange(0.0, 360.0, 1.8)
    counts = np.round((ref + 0.3 + np.sin(np.radians(ref)) / 6) * 2**14 / 360)
    path = write_csv("reference_deg,encoder_deg\n" + "".join(f"{r!r},{c * 360 / 2**14!r}\n"
                                                             for r, c in zip(ref.tolist(), counts.tolist())))
    status, out, _ = run(capsys, "profile", path)
    assert status == 0 and "14-bit encoder (inferred from the readings)" in out and "LSB" in out
    status, out, _ = run(capsys, "profile", path, "--json")
    assert json.loads(out)["resolution_bits"] == 14 and json.loads(out)["resolution_inferred"] is True


def test_a_file_without_header_is_read_by_column_numbers(write_csv, capsys):
    ref = np.arange(0.0, 360.0, 2.0)
    rows = "".join(f"{i} {float(np.radians(r))!r} {float(np.radians(r + 0.05 * np.sin(np.radians(r))))!r}\n"
                   for i, r in enumerate(ref.tolist()))
    path = write_csv(rows, name="log.txt")
    status, out, err = run(capsys, "profile", path, "--ref-col", "2", "--enc-col", "3", "--unit", "rad", "--json")
    assert status == 0 and err == ""
    record = json.loads(out)
    assert record["n"] == 180
    assert record["harmonics"][0]["order"] == 1
    assert record["harmonics"][0]["amplitude_arcmin"] == pytest.approx(3.0, abs=1e-3)
    status, _, err = run(capsys, "profile", path, "--ref-col", "2", "--enc-col", "9", "--unit", "rad")
    assert status == 1 and "no column 9" in err and "1 to 3" in err

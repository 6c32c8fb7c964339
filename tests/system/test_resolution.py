"""The encoder resolution from the readings: inferred, recorded in the model file, printed, overridden."""

import json

import numpy as np
import pytest

import encal
from encal._core.angles import resolution_of_readings
from encal.cli import main
from encal.models.fitting import resolution_bits
from tests._paths import REAL_MECHADUINO as REAL


@pytest.mark.parametrize("bits", [8, 12, 14, 16, 20, 24])
def test_whole_codes_give_their_resolution(bits):
    rng = np.random.default_rng(bits)
    codes = rng.integers(0, 2**bits, 200)
    codes[0] |= 1  # one odd code: the resolution is not one bit less
    assert resolution_of_readings(codes * (360.0 / 2**bits)) == bits


def test_readings_written_with_eight_decimals_still_count():
    codes = np.arange(0, 16384, 83) | 1
    assert resolution_of_readings(np.round(codes * (360.0 / 16384), 8)) == 14


def test_readings_that_are_not_codes_give_none():
    assert resolution_of_readings(np.arange(0.0, 360.0, 2.0) + 0.0123) is None
    assert resolution_of_readings([]) is None


def write_cal(path, bits, comment=None):
    ref = np.arange(0.0, 360.0, 1.8)
    codes = np.round((ref + 0.3 * np.sin(np.radians(ref))) * 2**bits / 360.0) % 2**bits
    lines = ([f"# {comment}"] if comment else []) + ["reference_deg,encoder_deg"]
    lines += [f"{r:.1f},{c * 360.0 / 2**bits:.10f}" for r, c in zip(ref, codes)]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_fit_records_the_resolution_of_the_readings(tmp_path):
    cal = encal.read_calibration(write_cal(tmp_path / "c.csv", 14))
    assert cal.resolution_bits is None and resolution_bits(cal) == 14
    model = encal.fit(cal, method="fourier", orders=[0, 1])
    assert model.encoder["resolution_bits"] == 14


def test_cli_prints_it_and_bits_overrides(tmp_path, capsys):
    cal = write_cal(tmp_path / "c.csv", 14)
    assert main(["fit", str(cal), "-o", str(tmp_path / "m.json"), "--method", "fourier"]) == 0
    out = capsys.readouterr().out
    assert "resolution: 14 bits (every reading is a multiple of 360/2^14 degrees)" in out
    assert json.loads((tmp_path / "m.json").read_text())["encoder"]["resolution_bits"] == 14
    assert main(["fit", str(cal), "-o", str(tmp_path / "m16.json"), "--method", "fourier", "--bits", "16"]) == 0
    assert "resolution: 16 bits (declared)" in capsys.readouterr().out
    assert json.loads((tmp_path / "m16.json").read_text())["encoder"]["resolution_bits"] == 16


def test_unknown_resolution_is_said_and_export_still_writes_the_formula(tmp_path, capsys):
    path = tmp_path / "c.csv"
    ref = np.arange(0.0, 360.0, 2.0)
    path.write_text("reference_deg,encoder_deg\n" + "".join(
        f"{r},{r + 0.01 * np.sin(np.radians(r)) + 0.00123}\n" for r in ref))
    assert main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--method", "fourier"]) == 0
    assert "resolution: unknown" in capsys.readouterr().out
    status = main(["export", str(tmp_path / "m.json"), "--format", "c", "-o", str(tmp_path / "c")])
    assert status == 0 and "note: the encoder resolution is unknown" in capsys.readouterr().out
    assert "resolution is unknown" in (tmp_path / "c" / "encal.c").read_text()
    status = main(["export", str(tmp_path / "m.json"), "--format", "c", "--target", "cortex-m4f",
                   "-o", str(tmp_path / "m4")])
    out = capsys.readouterr().out
    assert status == 0 and "note: the encoder resolution is unknown" in out


@pytest.mark.skipif(not REAL.is_dir(), reason="the real data set is not beside the repository")
def test_the_real_as5047d_calibrations_are_14_bit():
    files = sorted(REAL.glob("mech_*.csv"))[:5]
    assert files
    for path in files:
        assert resolution_bits(encal.read_calibration(path)) == 14

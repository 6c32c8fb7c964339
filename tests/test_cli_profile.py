"""``encal profile`` (encal.cli.cmd_profile)."""

import json

import numpy as np
import pytest

from encal.cli import main
from encal.profile import error_stats

STAT_KEYS = {"n", "mae_arcmin", "rms_arcmin", "std_arcmin", "min_arcmin", "max_arcmin",
             "max_abs_arcmin", "pp_arcmin"}


def profile_arcmin(ref_deg):
    """0.5 + 2 sin θ + 1.2 cos 16θ - 0.3 cos 2θ arcmin: orders ranked 1, 16, 0, 2."""
    theta = np.radians(ref_deg)
    return 0.5 + 2.0 * np.sin(theta) + 1.2 * np.cos(16 * theta) - 0.3 * np.cos(2 * theta)


def calibration_csv(write_csv, header="", reverse=False, name="enc7.csv"):
    ref = np.arange(0.0, 360.0, 2.0)
    enc = ref + profile_arcmin(ref) / 60.0
    if reverse:
        enc = -enc
    rows = [f"{float(r)!r},{float(e)!r}" for r, e in zip(ref, enc)]
    return write_csv(header + "reference_deg,encoder_deg\n" + "\n".join(rows) + "\n", name=name)


def test_json_output_is_one_object_with_the_contract_keys(write_csv, capsys):
    path = calibration_csv(write_csv)
    assert main(["profile", str(path), "--json"]) == 0
    out = capsys.readouterr().out
    record = json.loads(out)
    assert out.count("\n") == 1
    assert STAT_KEYS | {"harmonics", "name"} <= set(record)
    assert record["name"] == "enc7"
    assert record["n"] == 180
    expected = error_stats(profile_arcmin(np.arange(0.0, 360.0, 2.0))).as_dict()
    for key in STAT_KEYS - {"n"}:
        assert record[key] == pytest.approx(expected[key], abs=1e-6)
    assert [h["order"] for h in record["harmonics"][:4]] == [1, 16, 0, 2]
    assert len(record["harmonics"]) == 10
    assert record["harmonics"][0]["amplitude_arcmin"] == pytest.approx(2.0, abs=1e-4)
    amplitudes = [h["amplitude_arcmin"] for h in record["harmonics"]]
    assert amplitudes == sorted(amplitudes, reverse=True)


@pytest.mark.parametrize("top, expected", [("3", 3), ("0", 91)])
def test_top_sets_how_many_harmonics_are_listed(write_csv, capsys, top, expected):
    path = calibration_csv(write_csv)
    assert main(["profile", str(path), "--json", "--top", top]) == 0
    assert len(json.loads(capsys.readouterr().out)["harmonics"]) == expected


def test_human_table_shows_statistics_lsb_and_harmonics(write_csv, capsys):
    path = calibration_csv(write_csv, header="# resolution_bits: 16\n")
    assert main(["profile", str(path)]) == 0
    out = capsys.readouterr().out
    for word in ("MAE", "RMS", "STD", "min", "max", "peak-to-peak", "LSB", "0.3296", "order", "amplitude"):
        assert word in out
    harmonic_lines = out.split("phase/deg\n", 1)[1].splitlines()
    assert [int(line.split()[0]) for line in harmonic_lines[:4]] == [1, 16, 0, 2]
    assert len(harmonic_lines) == 10


def test_reverse_reads_an_encoder_counting_against_the_reference(write_csv, capsys):
    path = calibration_csv(write_csv, reverse=True)
    assert main(["profile", str(path), "--json"]) == 1
    assert "--reverse" in capsys.readouterr().err
    assert main(["profile", str(path), "--json", "--reverse"]) == 0
    assert json.loads(capsys.readouterr().out)["harmonics"][0]["order"] == 1


def test_gaps_are_refused_unless_allowed(write_csv, capsys):
    ref = np.arange(0.0, 300.0, 2.0)
    path = write_csv("reference_deg,encoder_deg\n" + "".join(f"{r},{r + 0.01}\n" for r in ref))
    assert main(["profile", str(path)]) == 1
    assert main(["profile", str(path), "--allow-gaps", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n"] == 150


def test_bad_file_is_one_line_on_stderr_and_status_1(write_csv, capsys):
    path = write_csv("reference_deg,encoder_deg\n0,1\n2,x\n")
    assert main(["profile", str(path)]) == 1
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and "Traceback" not in captured.err
    assert main(["profile", str(path.with_name("missing.csv"))]) == 1


def test_wrong_usage_is_status_2(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["profile", "x.csv", "--top", "-1"])
    assert exit_info.value.code == 2


def test_a_real_mechaduino_calibration(real_data_dir, capsys):
    path = sorted(real_data_dir.glob("mech_jcchurch_*.csv"))[0]
    assert main(["profile", str(path), "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["n"] == 200
    assert 20.0 < record["pp_arcmin"] < 400.0  # README: 30..100 typical, one file ~320
    assert record["std_arcmin"] < record["rms_arcmin"]  # an arbitrary zero: the mean is large
    assert record["harmonics"][0]["order"] == 0
    assert {1, 2} <= {h["order"] for h in record["harmonics"][:5]}

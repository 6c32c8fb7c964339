"""Tests of ``encal simulate``: files, their contents, summaries and exit codes."""

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from encal._version import __version__
from encal.data.calibration import read_calibration
from encal.cli import main
from encal.simulate import RUN_NAMES, TEST_GRID_DEG, TRAINING_GRID_DEG, demo_fleet, simulate_fleet


def csv_files(folder):
    return sorted(p.name for p in folder.iterdir())


def expected_files(n):
    return sorted(f"enc{k}_{run}.csv" for k in range(1, n + 1) for run in RUN_NAMES)


def noise_free_column(path):
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    header = lines[0].split(",")
    column = header.index("noise_free_error_arcmin")
    return np.array([float(line.split(",")[column]) for line in lines[1:]])


def test_without_a_seed_it_writes_the_demo_fleet(tmp_path, capsys):
    out = tmp_path / "sim"
    assert main(["simulate", "--out", str(out)]) == 0
    assert csv_files(out) == expected_files(4)
    printed = capsys.readouterr().out.splitlines()
    assert len(printed) == 4 and printed[0].startswith("enc1: train MAE")
    for word in ("MAE", "RMS", "STD", "min", "max", "arcmin"):
        assert word in printed[0]

    for member in demo_fleet():
        for run_name, run in member.runs.items():
            path = out / f"{member.name}_{run_name}.csv"
            cal = read_calibration(path)
            assert cal.resolution_bits == 16
            assert_array_equal(cal.reference_deg, run.calibration.reference_deg)
            assert_array_equal(cal.encoder_deg, run.calibration.encoder_deg)
            assert_array_equal(cal.epoch, run.calibration.epoch)
            assert_array_equal(noise_free_column(path), run.noise_free_error_arcmin)
            header = [line for line in path.read_text().splitlines() if line.startswith("#")]
            text = "\n".join(header)
            assert f"encal {__version__} simulate" in text
            assert f"seed: {member.seed.entropy}" in text
            assert f"encoder: {member.name}" in text and f"run: {run_name}" in text

    first = read_calibration(out / "enc1_train.csv")
    assert_array_equal(first.reference_deg, TRAINING_GRID_DEG)
    assert_array_equal(read_calibration(out / "enc1_test.csv").reference_deg, TEST_GRID_DEG)
    summary = printed[0].split()
    mae = float(summary[summary.index("MAE") + 1])
    assert mae == pytest.approx(np.mean(np.abs(first.errors_arcmin)), abs=0.005)


def test_with_a_seed_it_draws_that_fleet(tmp_path, capsys):
    out = tmp_path / "seeded"
    assert main(["simulate", "--encoders", "2", "--seed", "7", "--out", str(out)]) == 0
    assert csv_files(out) == expected_files(2)
    assert len(capsys.readouterr().out.splitlines()) == 2
    fleet = simulate_fleet(2, seed=7)
    cal = read_calibration(out / "enc2_decoder2.csv")
    assert_array_equal(cal.encoder_deg, fleet[1].decoder2.calibration.encoder_deg)
    assert "seed: 7, stream 1" in (out / "enc2_decoder2.csv").read_text()


def test_more_than_four_demo_encoders_come_from_a_fixed_seed(tmp_path, capsys):
    first, second = tmp_path / "a", tmp_path / "b"
    assert main(["simulate", "--encoders", "5", "--out", str(first)]) == 0
    assert main(["simulate", "--encoders", "5", "--out", str(second)]) == 0
    capsys.readouterr()
    assert csv_files(first) == expected_files(5)
    assert (first / "enc5_train.csv").read_text() == (second / "enc5_train.csv").read_text()
    assert (first / "enc1_test.csv").read_text() == (second / "enc1_test.csv").read_text()


def test_the_noise_free_column_is_close_to_the_measured_error(tmp_path, capsys):
    out = tmp_path / "sim"
    assert main(["simulate", "--encoders", "1", "--seed", "3", "--out", str(out)]) == 0
    capsys.readouterr()
    path = out / "enc1_test.csv"
    residual = read_calibration(path).errors_arcmin - noise_free_column(path)
    assert_allclose(residual, 0.0, atol=0.7)  # noise 0.10' RMS and +-0.5 LSB quantisation: 5 sigma
    assert np.sqrt(np.mean(residual**2)) < 0.2


def test_the_default_folder_is_encal_sim(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "--encoders", "1"]) == 0
    capsys.readouterr()
    assert csv_files(tmp_path / "encal-sim") == expected_files(1)


def test_an_existing_folder_is_reused(tmp_path, capsys):
    assert main(["simulate", "--encoders", "1", "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    assert csv_files(tmp_path) == expected_files(1)


@pytest.mark.parametrize("value", ["0", "1001", "-2", "many"])
def test_an_encoder_count_out_of_range_is_a_usage_error(tmp_path, capsys, value):
    with pytest.raises(SystemExit) as exit_info:
        main(["simulate", "--encoders", value, "--out", str(tmp_path / "x")])
    assert exit_info.value.code == 2
    assert "--encoders" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_a_negative_seed_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["simulate", "--seed", "-1", "--out", str(tmp_path / "x")])
    assert exit_info.value.code == 2
    assert "--seed" in capsys.readouterr().err


def test_a_missing_parent_folder_is_one_line_and_exit_1(tmp_path, capsys):
    assert main(["simulate", "--out", str(tmp_path / "no" / "such")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not exist" in err
    assert not (tmp_path / "no").exists()


def test_out_naming_a_file_is_one_line_and_exit_1(tmp_path, capsys):
    target = tmp_path / "file.csv"
    target.write_text("x\n")
    assert main(["simulate", "--out", str(target)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is a file" in err
    assert target.read_text() == "x\n"

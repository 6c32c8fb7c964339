"""The commands of the paper's procedure: ``encal demo``, ``encal compare`` and ``encal study``."""

import contextlib
import io
import json

import numpy as np
import pytest

from encal import Calibration, evaluate, load_model, write_calibration
from encal.cli import main

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def run(argv):
    """Exit status, stdout and stderr of ``encal argv``."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(argv)
        except SystemExit as exc:  # argparse usage errors
            status = exc.code
    return status, out.getvalue(), err.getvalue()


# --------------------------------------------------------------------------- encal demo


@pytest.fixture(scope="module")
def quick_demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    status, stdout, stderr = run(["demo", "--quick", "--out", str(out)])
    return out, status, stdout, stderr


def test_demo_quick_writes_report_tables_figures_and_models(quick_demo):
    out, status, stdout, stderr = quick_demo
    assert status == 0, stderr
    assert (out / "report.html").read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    assert {p.name for p in out.glob("enc*.json")} == {"enc1.json", "enc2.json", "enc3.json", "enc4.json"}
    assert len(list((out / "tables").glob("*.csv"))) == 6
    figures = list((out / "figures").glob("*.png"))
    assert len(figures) == 9 and all(p.read_bytes().startswith(PNG_MAGIC) for p in figures)
    assert not list(out.rglob(".*.tmp"))


def test_demo_prints_tables_on_stdout_and_progress_on_stderr(quick_demo):
    _, _, stdout, stderr = quick_demo
    for title in ("Table 1.", "Table 2.", "Table 3."):
        assert title in stdout and title not in stderr
    assert "hidden-node sweep: 6/6 done" in stderr
    assert "figures: 9/9 done" in stderr


def test_demo_model_file_corrects_its_test_run_as_the_demo_states(quick_demo):
    import re

    from encal.simulate import demo_fleet

    out, _, stdout, _ = quick_demo
    for member in demo_fleet():
        after = evaluate(load_model(out / f"{member.name}.json"), member.test.calibration).after
        line = next(row for row in stdout.splitlines() if row.startswith(f"{member.name}: {member.name}.json"))
        assert "chosen by encal fit" in line
        stated = float(re.search(r" to ([0-9.]+) arcmin", line).group(1))
        assert after.rms == pytest.approx(stated, abs=5e-4)


def test_demo_refuses_a_file_as_its_folder(tmp_path):
    path = tmp_path / "taken"
    path.write_text("x")
    status, _, stderr = run(["demo", "--quick", "--out", str(path), "--workers", "0", "--no-progress"])
    assert status == 1
    assert stderr.count("\n") == 1 and "is a file; expected a folder" in stderr


@pytest.mark.parametrize("argv", [["demo", "--workers", "-1"], ["demo", "--encoders", "0"], ["demo", "--bogus"]])
def test_demo_usage_errors_exit_2(argv):
    assert run(argv)[0] == 2


# --------------------------------------------------------------------------- compare and study


def _profile(theta_deg):
    t = np.radians(theta_deg)
    return 1.3 * np.sin(t) + 0.5 * np.cos(2 * t) + 0.3 * np.sin(16 * t)


@pytest.fixture(scope="module")
def csv_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cal")
    paths = {}
    for name, grid, seed in (("enc_train", np.arange(0.0, 360.0, 2.0), 1), ("enc_test", np.arange(1.0, 360.0, 2.0), 2)):
        error = _profile(grid) + np.random.default_rng(seed).normal(0.0, 0.05, grid.size)
        paths[name] = folder / f"{name}.csv"
        write_calibration(paths[name], Calibration(grid, grid + error / 60.0, resolution_bits=16))
    return paths["enc_train"], paths["enc_test"]


def test_compare_prints_table3_for_one_encoder(csv_files):
    train, test = csv_files
    status, stdout, stderr = run(["compare", str(train), str(test), "--models", "fourier,lut-linear,lut-cubic"])
    assert status == 0, stderr
    assert "Table 3." in stdout and "Fourier top-10 (paper)" in stdout and "LUT cubic" in stdout
    assert "ANN" not in stdout


def test_compare_json_has_the_statistics_of_every_model(csv_files):
    train, test = csv_files
    status, stdout, _ = run(["compare", str(train), str(test), "--json", "--epochs", "3",
                             "--models", "fourier,ann-periodic"])
    assert status == 0
    data = json.loads(stdout)
    assert data["encoder"] == "enc_train" and data["n"] == 180 and data["floor_arcmin"] is None
    assert [m["model"] for m in data["models"]] == ["before", "fourier", "ann-periodic"]
    for model in data["models"]:
        assert {"n", "mae_arcmin", "rms_arcmin", "std_arcmin", "max_abs_arcmin"} <= set(model)
    assert data["models"][1]["rms_arcmin"] < 0.1 < data["models"][0]["rms_arcmin"]


def test_compare_refuses_unknown_models(csv_files):
    train, test = csv_files
    status, _, stderr = run(["compare", str(train), str(test), "--models", "fourier,magic"])
    assert status == 1 and "--models must list some of" in stderr


def test_compare_reports_a_missing_file_in_one_line(csv_files, tmp_path):
    status, _, stderr = run(["compare", str(csv_files[0]), str(tmp_path / "absent.csv")])
    assert status == 1 and stderr.count("\n") == 1 and "no such file" in stderr


def test_study_prune_writes_its_table_and_figure(csv_files, tmp_path):
    train, test = csv_files
    status, stdout, stderr = run(["study", "prune", str(train), "--test", str(test), "--hidden", "10",
                                  "--epochs", "5", "--out", str(tmp_path / "prune")])
    assert status == 0, stderr
    assert "SVD pruning" in stdout
    assert (tmp_path / "prune" / "fig3_pruning.csv").is_file()
    assert (tmp_path / "prune" / "fig3_singular_values.png").read_bytes().startswith(PNG_MAGIC)


def test_study_sweep_prints_its_table(csv_files):
    status, stdout, stderr = run(["study", "sweep", str(csv_files[0]), "--hidden", "4,8", "--epochs", "3",
                                  "--workers", "0", "--no-progress"])
    assert status == 0, stderr
    assert "Hidden-node sweep" in stdout and stderr == ""
    assert [line.split()[0] for line in stdout.splitlines()[3:5]] == ["4", "8"]


def test_study_algorithms_with_seeds_and_a_test_file(csv_files, tmp_path):
    train, test = csv_files
    status, stdout, stderr = run(["study", "algorithms", str(train), "--test", str(test), "--algorithms",
                                  "trainlm,trainscg", "--hidden", "6", "--epochs", "3", "--seeds", "2",
                                  "--workers", "0", "--out", str(tmp_path)])
    assert status == 0, stderr
    assert "2 seeds per algorithm" in stdout and "trainscg" in stdout
    assert {p.name for p in tmp_path.iterdir()} == {"table2_algorithms.csv", "table2_algorithms.png",
                                                    "table2_training.png"}


@pytest.mark.parametrize("study, extra, message", [
    ("prune", ["--hidden", "0"], "--hidden must be"),
    ("prune", ["--hidden", "8,16"], "--hidden must be one whole number"),
    ("prune", ["--threshold", "2"], "--threshold must be a finite number in (0, 1)"),
    ("algorithms", ["--algorithms", "trainlm,trainmagic"], "--algorithms must name some of"),
    ("sweep", ["--hidden", "4,x"], "--hidden must be comma-separated whole numbers"),
])
def test_study_bad_options_are_one_line_errors(csv_files, study, extra, message):
    status, _, stderr = run(["study", study, str(csv_files[0]), "--epochs", "2", "--workers", "0", *extra])
    assert status == 1 and stderr.count("\n") == 1 and message in stderr


def test_study_needs_a_known_study(csv_files):
    assert run(["study", "bogus", str(csv_files[0])])[0] == 2

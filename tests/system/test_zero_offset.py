"""The zero offset stated apart from the shape: ``fit``, ``evaluate``, ``drift`` and the API."""

import json

import numpy as np
import pytest

from encal import Calibration, error_stats, evaluate, fit, load_model, write_calibration
from encal.cli import main

STEPS = np.arange(0.0, 360.0, 1.8)  # a stepper's 200 full steps


def shape_arcmin(theta_enc_deg):
    """The encoder's own error against its reading: mean 0, RMS sqrt(5) arcmin."""
    r = np.radians(theta_enc_deg)
    return 3.0 * np.sin(r) + 1.0 * np.cos(2 * r)


def stepper(offset_deg, noise_arcmin=0.0, seed=0):
    """A calibration against a stepper's full steps whose zero is wherever the motor started."""
    shaft = STEPS + offset_deg  # shaft angle in the encoder's frame
    noise = np.random.default_rng(seed).normal(0.0, noise_arcmin, STEPS.size)
    encoder = shaft + (shape_arcmin(shaft) + noise) / 60.0
    return Calibration(STEPS, encoder, name=f"stepper{offset_deg:g}")


def test_error_stats_takes_an_arbitrary_zero_apart():
    cal = stepper(59.0)
    fixed, shape, auto = (error_stats(cal, zero=mode) for mode in ("fixed", "arbitrary", "auto"))
    assert fixed.offset is None and fixed.rms > 3000.0
    assert auto == shape
    assert shape.offset == pytest.approx(59.0 * 60.0, abs=1e-3)
    assert shape.rms == pytest.approx(np.sqrt(5.0), abs=1e-3)
    assert shape.as_dict()["zero_offset_arcmin"] == shape.offset
    assert "zero_offset_arcmin" not in fixed.as_dict()
    assert error_stats(stepper(0.2), zero="auto").offset is None  # 12 arcmin: a fixed zero


def test_a_repeat_calibration_from_another_start_is_not_a_six_fold_worsening():
    first, repeat = stepper(59.0, 0.2, seed=1), stepper(95.0, 0.2, seed=2)
    model = fit(first, method="fourier", orders=[0, 1, 2])
    fixed = evaluate(model, repeat)
    assert fixed.after.rms > 2000.0  # the change of start position counted as error
    result = evaluate(model, repeat, zero="auto")
    assert result.arbitrary_zero and result.as_dict()["zero"] == "arbitrary"
    assert result.before.offset == pytest.approx(95.0 * 60.0, abs=0.1)
    assert result.after.offset == pytest.approx(36.0 * 60.0, abs=0.1)  # the change of start, apart
    assert result.before.rms == pytest.approx(np.sqrt(5.0), abs=0.05)
    assert result.after.rms < 0.3  # the shape is corrected: only the 0.2 arcmin noise is left
    assert "larger than 1 deg" in result.zero_sentence()
    text = str(result)
    assert "zero offset" in text and "before" in text and "after" in text


def write(tmp_path, cal):
    path = tmp_path / f"{cal.name}.csv"
    write_calibration(path, cal)
    return path


def test_cli_fit_and_evaluate_state_the_offset_apart(tmp_path, capsys):
    first, repeat = write(tmp_path, stepper(59.0, 0.2, 1)), write(tmp_path, stepper(95.0, 0.2, 2))
    model_path = tmp_path / "m.json"
    assert main(["fit", str(first), "-o", str(model_path), "--method", "fourier", "--orders", "0,1,2"]) == 0
    out = capsys.readouterr().out
    assert "zero offset +3539.9" in out or "zero offset +3540.0" in out
    assert "training-set RMS of the shape 2.2" in out
    assert load_model(model_path).training["zero_offset_arcmin"] == pytest.approx(3540.0, abs=0.1)
    assert main(["evaluate", str(model_path), str(repeat), "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["zero"] == "arbitrary" and record["rms_arcmin"] < 0.3
    assert record["zero_offset_arcmin"] == pytest.approx(2160.0, abs=0.1)
    assert record["before"]["zero_offset_arcmin"] == pytest.approx(5700.0, abs=0.1)
    assert main(["evaluate", str(model_path), str(repeat), "--zero", "fixed", "--json"]) == 0
    fixed = json.loads(capsys.readouterr().out)
    assert fixed["zero"] == "fixed" and fixed["rms_arcmin"] > 2000.0 and "zero_offset_arcmin" not in fixed


def test_cli_drift_removes_offsets_only_when_the_zero_is_arbitrary(tmp_path, capsys):
    small = [write(tmp_path, stepper(offset, 0.2, seed)) for seed, offset in enumerate((0.1, 0.3))]
    assert main(["drift", *map(str, small), "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["zero"] == "fixed" and record["offset"] == "keep"
    large = [write(tmp_path, stepper(offset, 0.2, seed)) for seed, offset in enumerate((59.0, 95.0))]
    assert main(["drift", *map(str, large), "--tolerance", "0.2"]) == 0
    out = capsys.readouterr().out
    assert "larger than 1 deg" in out and "verdict: the model still holds" in out
    assert "the first's is +3540.0" in out or "the first's is +3539.9" in out
    assert main(["drift", *map(str, large), "--json", "--keep-offset"]) == 0
    assert json.loads(capsys.readouterr().out)["offset"] == "keep"


def test_cli_fit_json_records_the_drawn_seed(tmp_path, capsys):
    path = write(tmp_path, stepper(0.0, 0.2, 3))
    model_path = tmp_path / "m.json"
    assert main(["fit", str(path), "-o", str(model_path), "--method", "ann", "--hidden", "3", "--epochs", "5",
                 "--json"]) == 0
    out = capsys.readouterr().out
    record = json.loads(out)
    assert out.count("\n") == 1
    assert {"name", "model_kind", "output", "n_points", "seed", "training_set", "zero_note"} <= set(record)
    seed = record["seed"]
    assert isinstance(seed, int) and load_model(model_path).training["seed"] == seed
    assert {"rms_arcmin", "before"} <= set(record["training_set"])
    again = tmp_path / "again.json"
    assert main(["fit", str(path), "-o", str(again), "--method", "ann", "--hidden", "3", "--epochs", "5",
                 "--seed", str(seed), "--json"]) == 0
    capsys.readouterr()
    assert load_model(again).parameters() == load_model(model_path).parameters()

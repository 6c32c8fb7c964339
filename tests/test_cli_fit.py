"""`encal fit` and `encal evaluate` through the command line's main()."""

import json

import numpy as np
import pytest

import encal
from encal.cli import main


@pytest.fixture
def train_and_test(tmp_path):
    def write(name, offset):
        ref = np.arange(0.0, 360.0, 2.0) + offset
        theta = np.radians(ref)
        error = 1.2 * np.sin(theta + 0.4) + 0.5 * np.cos(2 * theta) + 0.2 * np.sin(16 * theta)
        path = tmp_path / name
        encal.write_calibration(path, encal.Calibration(ref, ref + error / 60.0, resolution_bits=16))
        return path

    return write("train.csv", 0.0), write("test.csv", 1.0)


def test_fit_then_evaluate_json(train_and_test, tmp_path, capsys):
    train, test = train_and_test
    model_path = tmp_path / "m.json"
    assert main(["fit", str(train), "-o", str(model_path), "--method", "fourier", "--orders", "0,1,2,16"]) == 0
    out = capsys.readouterr().out
    assert "fourier model" in out and str(model_path) in out
    assert main(["evaluate", str(model_path), str(test), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["n"] == 180
    assert result["rms_arcmin"] < 0.01 < result["before"]["rms_arcmin"]
    assert result["model_kind"] == "fourier"


def test_evaluate_text_table(train_and_test, tmp_path, capsys):
    train, test = train_and_test
    model_path = tmp_path / "m.json"
    main(["fit", str(train), "-o", str(model_path), "--method", "lut"])
    capsys.readouterr()
    assert main(["evaluate", str(model_path), str(test)]) == 0
    out = capsys.readouterr().out
    assert "before" in out and "after" in out and "RMS" in out


def test_fit_ann_with_seed_is_reproducible(train_and_test, tmp_path, capsys):
    train, _ = train_and_test
    paths = [tmp_path / "a.json", tmp_path / "b.json"]
    for path in paths:
        assert main(["fit", str(train), "-o", str(path), "--method", "ann", "--hidden", "8",
                     "--epochs", "30", "--seed", "3", "--reproducible"]) == 0
    assert paths[0].read_bytes() == paths[1].read_bytes()


@pytest.mark.parametrize("argv, message", [
    (["--method", "fourier", "--hidden", "5"], "--hidden applies to --method ann or hybrid, not fourier"),
    (["--method", "fourier", "--orders", "1,x"], "--orders must be whole numbers"),
    (["--method", "lut", "--seed", "1"], "--seed applies to"),
])
def test_fit_refuses_options_of_another_method(train_and_test, tmp_path, capsys, argv, message):
    train, _ = train_and_test
    out = tmp_path / "m.json"
    assert main(["fit", str(train), "-o", str(out), *argv]) == 1
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not out.exists()


def test_fit_usage_errors_exit_2(train_and_test, tmp_path):
    train, _ = train_and_test
    with pytest.raises(SystemExit) as info:
        main(["fit", str(train), "-o", str(tmp_path / "m.json"), "--hidden", "0"])
    assert info.value.code == 2
    with pytest.raises(SystemExit) as info:
        main(["fit", str(train), "-o", str(tmp_path / "m.json"), "--method", "spline"])
    assert info.value.code == 2


def test_fit_into_missing_folder(train_and_test, tmp_path, capsys):
    train, _ = train_and_test
    assert main(["fit", str(train), "-o", str(tmp_path / "nope" / "m.json"), "--method", "lut"]) == 1
    assert "does not exist" in capsys.readouterr().err


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"encal {encal.__version__}"


def test_at_steps_lets_auto_keep_a_per_step_alternation(tmp_path, capsys):
    """A 200-step calibration whose reference alternates by ±2 arcmin between steps: with
    --at-steps auto validates at the steps and keeps the alternation (order 100); without it the
    alternation is invisible to cross-validation between the points."""
    ref = np.arange(200) * 1.8
    theta = np.radians(ref)
    noise = np.random.default_rng(0).normal(0.0, 0.1, ref.size)
    error = 6.0 * np.sin(theta + 0.3) + 2.0 * np.cos(2 * theta) + 2.0 * (-1.0) ** np.arange(200) + noise
    cal = tmp_path / "steps.csv"
    encal.write_calibration(cal, encal.Calibration(ref, ref + error / 60.0))
    orders = {}
    for flag in ((), ("--at-steps",)):
        model_path = tmp_path / f"m{len(flag)}.json"
        assert main(["fit", str(cal), "-o", str(model_path), "--seed", "0", *flag]) == 0
        capsys.readouterr()
        model = encal.load_model(model_path)
        orders[bool(flag)] = set(model.training.get("orders", ())) if model.kind == "fourier" else set()
        if flag:
            assert model.kind == "fourier" and model.training["fit_options"]["use_grid"] is True
            residual = error - model.predict(ref)
            assert np.sqrt(np.mean(residual**2)) < 0.15  # the noise is 0.1 arcmin
    assert 100 in orders[True] and 100 not in orders[False]


def test_at_steps_is_an_option_of_auto_only(train_and_test, tmp_path, capsys):
    train, _ = train_and_test
    assert main(["fit", str(train), "-o", str(tmp_path / "m.json"), "--method", "lut", "--at-steps"]) == 1
    assert "--at-steps applies to --method auto, not lut" in capsys.readouterr().err


def test_at_steps_off_the_grid_warns_in_one_line(tmp_path, capsys):
    ref = np.sort(np.random.default_rng(1).uniform(0.0, 360.0, 90))
    error = 2.0 * np.sin(np.radians(ref))
    cal = tmp_path / "irregular.csv"
    encal.write_calibration(cal, encal.Calibration(ref, ref + error / 60.0))
    assert main(["fit", str(cal), "-o", str(tmp_path / "m.json"), "--at-steps", "--seed", "0"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "use_grid (--at-steps) has no effect" in err[0]


def test_fit_of_a_csv_with_a_direction_column_corrects_each_direction(tmp_path, capsys):
    ref = np.tile(np.arange(0.0, 360.0, 3.0), 2)
    direction = np.repeat([1, -1], ref.size // 2)
    error = np.sin(np.radians(ref)) + 0.15 * direction                # arcmin: a 0.3 arcmin reversal
    csv = tmp_path / "bi.csv"
    rows = "\n".join(f"{r:.17g},{r + e / 60.0:.17g},{d:+d}" for r, e, d in zip(ref, error, direction))
    csv.write_text("reference_deg,encoder_deg,direction\n" + rows + "\n", encoding="utf-8")
    assert main(["fit", str(csv), "-o", str(tmp_path / "m.json"), "--method", "fourier", "--orders", "0,1"]) == 0
    assert "one fourier model per direction" in capsys.readouterr().out
    model = encal.load_model(tmp_path / "m.json")
    assert model.kind == "directional"
    assert float(model.predict(ref[0] + error[0] / 60.0, direction=1)) == pytest.approx(error[0], abs=1e-3)
    assert float(model.predict(ref[-1] + error[-1] / 60.0, direction=-1)) == pytest.approx(error[-1], abs=1e-3)

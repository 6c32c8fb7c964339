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


def test_fit_reproducible_without_a_seed_fixes_the_seed_too(train_and_test, tmp_path, capsys):
    # a drawn seed (auto's folds, ann's weights) made two --reproducible runs write different files
    train, _ = train_and_test
    paths = [tmp_path / "a.json", tmp_path / "b.json"]
    for path in paths:
        assert main(["fit", str(train), "-o", str(path), "--method", "ann", "--hidden", "8", "--epochs", "30",
                     "--reproducible"]) == 0
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert json.loads(paths[0].read_text())["training"]["seed"] == 0


@pytest.mark.parametrize("argv, message", [
    (["--method", "fourier", "--hidden", "5"], "--hidden applies to --method ann or hybrid, not fourier"),
    (["--method", "fourier", "--orders", "1,x"], "--orders must be whole numbers"),
    (["--method", "lut", "--seed", "1"], "--seed applies to"),
    (["--method", "lut", "--noise", "0.1"], "--noise applies to --method spectral or auto, not lut"),
    (["--method", "fourier", "--repeat", "x.csv"], "--repeat applies to --method spectral or auto, not fourier"),
    (["--networks", "--method", "lut"], "--networks applies to --method auto, not lut"),
    (["--method", "spectral", "--folds", "3"], "--folds applies to --method auto, not spectral"),
    (["--target", "fixed"], "--target names the processor of --budget"),
])
def test_fit_options_of_another_method_are_usage_errors(train_and_test, tmp_path, capsys, argv, message):
    train, _ = train_and_test
    out = tmp_path / "m.json"
    with pytest.raises(SystemExit) as info:
        main(["fit", str(train), "-o", str(out), *argv])
    assert info.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith("encal fit: error: ") and message in last
    assert not out.exists()


def test_folds_help_says_it_switches_the_scheme(capsys):
    with pytest.raises(SystemExit):
        main(["fit", "--help"])
    assert "any K switches, 5 included" in " ".join(capsys.readouterr().out.split())


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
    with pytest.raises(SystemExit) as info:
        main(["fit", str(train), "-o", str(tmp_path / "m.json"), "--method", "lut", "--at-steps"])
    assert info.value.code == 2
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


# ---------------------------------------------------------------- repeated readings and --repeat

def _pass(path, reference, seed, shift_arcmin=0.0, sign=1, direction=None):
    """A calibration run with 0.1 arcmin of noise; ``sign=-1`` writes an encoder that counts backwards."""
    theta = np.radians(reference)
    error = (1.2 * np.sin(theta + 0.4) + 0.5 * np.cos(2 * theta) + shift_arcmin
             + np.random.default_rng(seed).normal(0.0, 0.1, reference.size))
    encal.write_calibration(path, encal.Calibration(reference, sign * (reference + error / 60.0), direction=direction))
    return path


GRID = np.arange(0.0, 360.0, 2.0)


def test_fit_takes_the_noise_from_three_readings_at_every_stop(tmp_path, capsys):
    path = _pass(tmp_path / "three.csv", np.repeat(GRID, 3), seed=1)
    assert main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--method", "spectral"]) == 0
    assert "prior: noise from repeated readings at the same reference angle" in capsys.readouterr().out
    noise = encal.load_model(tmp_path / "m.json").training["noise"]
    assert noise["source"] == "repeated readings"
    assert noise["std_arcmin"] == pytest.approx(0.1, rel=0.1)


def test_fit_keeps_irregular_repeats_only_when_asked(tmp_path, capsys):
    path = _pass(tmp_path / "some.csv", np.r_[GRID, GRID[:60]], seed=2)  # a third of the stops read twice
    assert main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--method", "spectral"]) == 1
    assert "use --keep-duplicates to keep them as repeated readings" in capsys.readouterr().err
    assert main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--method", "spectral", "--keep-duplicates"]) == 0
    assert encal.load_model(tmp_path / "m.json").training["noise"]["source"] == "repeated readings"
    with pytest.raises(SystemExit) as info:
        main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--keep-duplicates", "--average-duplicates"])
    assert info.value.code == 2


def test_a_repeat_pass_on_another_grid_is_refused(tmp_path, capsys):
    first, other = _pass(tmp_path / "a.csv", GRID, seed=3), _pass(tmp_path / "b.csv", GRID + 1.0, seed=4)
    assert main(["fit", str(first), "-o", str(tmp_path / "m.json"), "--repeat", str(other)]) == 1
    err = capsys.readouterr().err
    assert err == (f"encal fit: error: --repeat {other}: 180 of its 180 stops (1, 3, 5, ... deg) are not stops of "
                   f"{first}; expected a second pass over the same reference angles (within 1e-9 deg), since only "
                   "readings at the same angle measure the noise (give a known noise with --noise, or fit the other "
                   "grid on its own)\n")
    fewer = _pass(tmp_path / "c.csv", GRID[:-1], seed=4)
    assert main(["fit", str(first), "-o", str(tmp_path / "m.json"), "--repeat", str(fewer)]) == 1
    assert f"--repeat {fewer}: it lacks 1 of the 180 stops of {first} (358 deg)" in capsys.readouterr().err
    assert not (tmp_path / "m.json").exists()


def test_a_repeat_pass_at_another_zero_is_refused(tmp_path, capsys):
    first = _pass(tmp_path / "a.csv", GRID, seed=3)
    moved = _pass(tmp_path / "b.csv", GRID, seed=4, shift_arcmin=0.5)  # 0.5 arcmin against 0.14 of scatter
    assert main(["fit", str(first), "-o", str(tmp_path / "m.json"), "--repeat", str(moved)]) == 1
    err = capsys.readouterr().err
    assert f"--repeat {moved}: its readings are +0.5" in err and f"off those of {first}" in err
    assert "so the zero moved between the passes" in err and "encal drift" in err
    same = _pass(tmp_path / "c.csv", GRID, seed=5)
    assert main(["fit", str(first), "-o", str(tmp_path / "m.json"), "--repeat", str(same)]) == 0


def test_a_repeat_pass_keeps_the_reading_sign_and_the_direction(tmp_path, capsys):
    first, second = (_pass(tmp_path / f"{n}.csv", GRID, seed=n, sign=-1) for n in (1, 2))
    assert main(["fit", str(first), "-o", str(tmp_path / "m.json"), "--repeat", str(second), "--reverse",
                 "--method", "spectral"]) == 0
    model = encal.load_model(tmp_path / "m.json")
    assert model.reading_sign == -1
    cal = encal.read_calibration(first, reverse=True)
    assert encal.evaluate(model, cal).after.rms < 0.15  # 1.57 arcmin when the combined passes lost the sign
    both = np.tile(GRID, 2)
    direction = np.repeat([1, -1], GRID.size)
    with_direction = _pass(tmp_path / "d.csv", both, seed=3, direction=direction)
    plain = _pass(tmp_path / "p.csv", GRID, seed=6)
    assert main(["fit", str(with_direction), "-o", str(tmp_path / "d.json"), "--repeat", str(plain)]) == 1
    assert f"{with_direction} has a direction column but {plain} has none" in capsys.readouterr().err
    again = _pass(tmp_path / "e.csv", both, seed=4, direction=direction)
    assert main(["fit", str(with_direction), "-o", str(tmp_path / "d.json"), "--repeat", str(again)]) == 0
    assert encal.load_model(tmp_path / "d.json").kind == "directional"


def _bidirectional_csv(path, seed=0):
    """Forward over a 2-degree grid, then back: a 0.3 arcmin reversal, 16-bit codes, 0.05 arcmin noise."""
    forward = np.arange(0.0, 360.0, 2.0)
    ref = np.r_[forward, forward[::-1]]
    direction = np.repeat([1, -1], forward.size)
    theta = np.radians(ref)
    error = (1.2 * np.sin(theta + 0.4) + 0.5 * np.cos(2 * theta) + 0.2 * np.sin(16 * theta) + 0.15 * direction
             + np.random.default_rng(seed).normal(0.0, 0.05, ref.size))
    encoder = np.round((ref + error / 60.0) * 2**16 / 360.0) * 360.0 / 2**16
    rows = "\n".join(f"{r:.17g},{e:.17g},{d:+d}" for r, e, d in zip(ref, encoder, direction))
    path.write_text("# resolution_bits: 16\nreference_deg,encoder_deg,direction\n" + rows + "\n", encoding="utf-8")
    return path


def test_bidirectional_lut_states_a_held_out_estimate_per_direction(tmp_path, capsys):
    csv = _bidirectional_csv(tmp_path / "bi.csv")
    assert main(["fit", str(csv), "-o", str(tmp_path / "m.json"), "--method", "lut"]) == 0
    lines = capsys.readouterr().out.splitlines()
    for name in ("forward", "reverse"):
        line = next(line for line in lines if line.startswith(f"{name}: held-out estimate: RMS "))
        assert "5 interleaved folds" in line and "1.4-1.8 times the test RMS for lut" in line
    assert main(["fit", str(csv), "-o", str(tmp_path / "m.json"), "--method", "lut", "--json"]) == 0
    held_out = json.loads(capsys.readouterr().out)["held_out"]
    for name in ("forward", "reverse"):
        assert held_out[name]["estimator"] == "interleaved CV" and held_out[name]["folds"] == 5
        assert 0.05 < held_out[name]["rms_arcmin"] < 0.3   # the readings' noise and code are 0.05 and 0.1 arcmin


def test_bidirectional_spectral_states_noise_and_prior_per_direction(tmp_path, capsys):
    csv = _bidirectional_csv(tmp_path / "bi.csv")
    assert main(["fit", str(csv), "-o", str(tmp_path / "m.json"), "--method", "spectral"]) == 0
    out = capsys.readouterr().out
    for name in ("forward", "reverse"):
        assert f"{name}: noise: sigma " in out and "prior: blind" in out
        assert f"{name}: sigma / (LSB/sqrt(12)) = " in out and f"{name}: held-out estimate (posterior" in out
    assert main(["fit", str(csv), "-o", str(tmp_path / "m.json"), "--method", "spectral", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    for name in ("forward", "reverse"):
        noise = result["noise"][name]
        assert noise["source"] == "blind" and noise["resolution_bits"] == 16
        assert noise["lsb_over_sqrt12_arcmin"] == pytest.approx(21600 / 2**16 / 12**0.5)
        assert noise["ratio_to_quantisation"] == pytest.approx(noise["std_arcmin"] / noise["lsb_over_sqrt12_arcmin"])
        assert result["held_out"][name]["estimator"] == "posterior" and result["held_out"][name]["rms_arcmin"] > 0


def test_bidirectional_mean_states_its_held_out_estimate_and_half_the_reversal(tmp_path, capsys):
    csv = _bidirectional_csv(tmp_path / "bi.csv")
    assert main(["fit", str(csv), "-o", str(tmp_path / "m.json"), "--method", "lut", "--bidirectional", "mean"]) == 0
    out = capsys.readouterr().out
    assert "held-out estimate: RMS " in out
    note = next(line for line in out.splitlines() if line.startswith("the model is of the mean of both directions"))
    half = float(note.split("half the reversal, ")[1].split(" arcmin")[0])
    assert half == pytest.approx(0.15, abs=0.02)


def test_a_target_tolerance_fits_the_mean_of_a_reference_read_afresh_and_is_recorded(tmp_path, capsys):
    csv = _bidirectional_csv(tmp_path / "bi.csv")
    lines = csv.read_text(encoding="utf-8").splitlines()
    wobble = np.random.default_rng(1).uniform(-0.003, 0.003, len(lines) - 2)  # the reference read afresh
    rows = [f"{float(r) + w:.17g},{float(e) + w:.17g},{d}"
            for (r, e, d), w in zip((line.split(",") for line in lines[2:]), wobble)]
    afresh = tmp_path / "afresh.csv"
    afresh.write_text("\n".join(lines[:2] + rows) + "\n", encoding="utf-8")
    out = str(tmp_path / "m.json")
    assert main(["fit", str(afresh), "-o", out, "--method", "lut", "--bidirectional", "mean"]) == 1
    assert "no reference angle was approached in both directions" in capsys.readouterr().err
    assert main(["fit", str(afresh), "-o", out, "--method", "lut", "--bidirectional", "mean",
                 "--target-tolerance", "0.01"]) == 0
    training = encal.load_model(out).training
    assert training["target_tolerance_deg"] == 0.01 and training["n_points"] == 180
    assert training["mean_reversal_value_arcmin"] == pytest.approx(0.3, abs=0.03)


def test_a_target_tolerance_is_refused_for_one_direction_and_as_no_plain_number(train_and_test, tmp_path, capsys):
    train, _ = train_and_test
    assert main(["fit", str(train), "-o", str(tmp_path / "m.json"), "--target-tolerance", "0.01"]) == 1
    err = capsys.readouterr().err
    assert "--target-tolerance matches the targets of a run in both directions" in err
    assert "Traceback" not in err and not (tmp_path / "m.json").exists()
    for text in ("1_0", "0", "11", "nan"):
        with pytest.raises(SystemExit) as exit_:
            main(["fit", str(train), "-o", str(tmp_path / "m.json"), "--target-tolerance", text])
        assert exit_.value.code == 2
        assert "argument --target-tolerance: expected degrees greater than 0 and at most 10" in capsys.readouterr().err


def test_fit_json_has_the_held_out_estimate_and_the_noise_as_data(train_and_test, tmp_path, capsys):
    train, _ = train_and_test
    assert main(["fit", str(train), "-o", str(tmp_path / "m.json"), "--method", "spectral", "--noise", "0.1",
                 "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["noise"]["std_arcmin"] == pytest.approx(0.1) and result["noise"]["source"] == "supplied"
    assert result["noise"]["prior"].startswith("noise supplied by the user")
    assert result["held_out"]["estimator"] == "posterior" and result["held_out"]["rms_arcmin"] > 0
    assert main(["fit", str(train), "-o", str(tmp_path / "m.json"), "--method", "fourier", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["noise"] is None
    held_out = result["held_out"]
    assert held_out["folds"] == 5 and len(held_out["fold_rms_arcmin"]) == 5
    assert held_out["rms_arcmin"] == pytest.approx(np.sqrt(np.mean(np.square(held_out["fold_rms_arcmin"]))))


def test_hybrid_held_out_estimate_is_the_median_fold_and_names_the_bent_folds(tmp_path, capsys):
    """The first demo encoder, seed 0: two of the five fold refits' networks bend in the gaps the held-out
    points leave (pooled RMS 14.3 arcmin); the fit on all points tests at 0.198 arcmin on the test run."""
    from encal.simulate import demo_fleet

    member = demo_fleet(1)[0]
    encal.write_calibration(tmp_path / "train.csv", member.train.calibration)
    assert main(["fit", str(tmp_path / "train.csv"), "-o", str(tmp_path / "m.json"), "--method", "hybrid",
                 "--seed", "0", "--json"]) == 0
    held_out = json.loads(capsys.readouterr().out)["held_out"]
    assert held_out["rms_arcmin"] == pytest.approx(np.median(held_out["fold_rms_arcmin"]))
    assert held_out["pooled_rms_arcmin"] > 5.0 and held_out["bent_folds"] == 2
    test = member.test.calibration
    model = encal.load_model(tmp_path / "m.json")
    test_rms = np.sqrt(np.mean((test.errors_arcmin - model.predict(test.encoder_deg)) ** 2))
    assert held_out["rms_arcmin"] < 2.5 * test_rms
    assert held_out["bend_between_points_arcmin"] < 0.5
    assert "the network of 2 of the 5 fold refits bent" in held_out["text"]


def test_fit_gives_back_what_the_reading_freed_before_fitting(train_and_test, tmp_path, monkeypatch):
    """Issue 30 (dense30): between the reading and the fit the freed memory is given back (``encal._core.memory``:
    the 10^6-row random file's peak 204 -> 189 MiB resident)."""
    from encal._core import memory
    from encal.models import fitting

    events = []
    monkeypatch.setattr(memory, "release_freed_memory", lambda: events.append("released"))
    plain_fit = fitting.fit
    monkeypatch.setattr(fitting, "fit", lambda *args, **kwargs: events.append("fit") or plain_fit(*args, **kwargs))
    assert main(["fit", str(train_and_test[0]), "-o", str(tmp_path / "m.json"), "--method", "fourier"]) == 0
    assert events == ["released", "fit"]


def test_the_model_file_records_the_iso_230_2_reversal_of_a_hand_made_log(tmp_path, capsys):
    """metrology8: B and B̄ the model file records (training), against the standard's formulas worked by hand."""
    from tests.cli.test_profile import HAND_FIGURES, hand_log

    out = tmp_path / "hand.json"
    assert main(["fit", str(hand_log(tmp_path)), "-o", str(out), "--allow-gaps", "--keep-duplicates",
                 "--method", "fourier"]) == 0
    capsys.readouterr()
    training = json.loads(out.read_text())["training"]
    assert training["reversal_value_arcmin"] == pytest.approx(HAND_FIGURES["reversal_value"], abs=1e-9)
    assert training["mean_reversal_value_arcmin"] == pytest.approx(HAND_FIGURES["mean_reversal_value"], abs=1e-9)

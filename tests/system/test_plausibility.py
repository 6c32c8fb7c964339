"""Issue 25: wrong numbers that look right with exit 0 -- the plausibility of the data and of a correction.

Each test fails without its fix: a repeat pass that is the calibration itself, an encoder that does not turn once
per reference turn, a correction that makes the errors larger, a continuous sweep whose reference is a quantised
encoder, a long spin log (tests/selfcal/test_spin.py), the zero offset a correction leaves.
"""

import warnings

import numpy as np
import pytest

import encal
from encal import read_calibration
from encal._core.errors import EncalWarning


def _profile_arcmin(theta_deg):
    theta = np.radians(theta_deg)
    return 2.0 * np.sin(theta + 0.3) + 0.6 * np.cos(2 * theta) + 0.2 * np.sin(16 * theta)


def _write(path, reference, encoder, comments=()):
    lines = [f"# {c}" for c in comments] + ["reference_deg,encoder_deg"]
    lines += [f"{float(r)!r},{float(e)!r}" for r, e in zip(reference, encoder)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _quiet_read(path, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("error", EncalWarning)
        return read_calibration(path, **options)


# ---------------------------------------------------------------- item 4: a sweep over several turns

def _sweep(n, revolutions, reference_bits, noise_arcmin, seed=3):
    """A continuous sweep: the true angle, a reference quantised to whole codes, the encoder's readings."""
    rng = np.random.default_rng(seed)
    theta = np.linspace(0.0, 360.0 * revolutions, n, endpoint=False) + rng.uniform(0.0, 1.0)
    lsb = 360.0 / 2**reference_bits
    reference = np.round(theta / lsb) * lsb
    encoder = theta + (_profile_arcmin(theta) + rng.normal(0.0, noise_arcmin, n)) / 60.0
    return theta, reference, encoder


def test_a_sweep_whose_reference_repeats_codes_is_read_as_one(tmp_path):
    """A 12-bit reference read 2.4 times per code over 3 turns: consecutive rows repeat a code, so fewer than 95 %
    of the steps moved; it was refused ("appears more than once with different readings") without
    --keep-duplicates. Kept whole, the spectral model recovers the profile."""
    theta, reference, encoder = _sweep(30_000, 3, 12, 0.05)
    assert np.mean(np.diff(reference) > 0) < 0.95  # the old test of one-way travel failed
    cal = _quiet_read(_write(tmp_path / "sweep.csv", reference, encoder))
    assert len(cal) == 30_000
    model = encal.fit(cal, method="spectral")
    grid = np.arange(0.0, 360.0, 0.25)
    miss = model.predict(grid + _profile_arcmin(grid) / 60.0) - _profile_arcmin(grid)
    assert np.sqrt(np.mean(miss**2)) < 0.1  # of a profile of 1.5 arcmin RMS; the reference rounds by 1.5 arcmin RMS


def test_a_stray_repeat_after_a_sweep_in_another_epoch_is_still_refused(tmp_path):
    """The sweep test is made per run (direction and epoch): two passes that are two epochs are no sweep."""
    grid = np.arange(0.0, 360.0, 2.0)
    reference = np.r_[grid, grid, 10.0]
    text = "reference_deg,encoder_deg,epoch\n" + "".join(
        f"{float(r)!r},{float(r) + 0.01 * (i % 3)!r},{'a' if i < 180 else 'b'}\n" for i, r in enumerate(reference))
    (tmp_path / "two.csv").write_text(text, encoding="utf-8")
    with pytest.raises(encal.CalibrationError, match="reference angle 10 deg appears more than once"):
        read_calibration(tmp_path / "two.csv")


def test_a_noise_free_log_over_two_turns_raises_no_misread_warning(tmp_path):
    """The readings at 95 deg and at 455 deg (wrapped to 95) differ by the rounding of doubles (1e-12 arcmin), which
    was taken for the readings' spread: profile steps of 0.002 arcmin were called misreads."""
    reference = np.arange(0.0, 720.0, 0.5)
    path = _write(tmp_path / "two.csv", reference, reference + _profile_arcmin(reference) / 60.0)
    assert len(_quiet_read(path)) == reference.size


# ---------------------------------------------------------------- item 1: repeats that carry no noise

LSB_14 = 360.0 / 2**14


def _fine_profile(theta_deg):
    return _profile_arcmin(theta_deg) + 0.05 * np.sin(np.radians(40 * theta_deg))


def _passes(seed, noise_arcmin, grid=np.arange(0.0, 360.0, 2.0)):
    """Two passes of a 14-bit encoder over one grid: (encoder angles, errors in arcmin) of both together."""
    rng = np.random.default_rng(seed)
    readings = [np.round((grid + (_fine_profile(grid) + rng.normal(0.0, noise_arcmin, grid.size)) / 60.0) / LSB_14)
                * LSB_14 for _ in range(2)]
    theta = np.concatenate(readings)
    return theta, (theta - np.r_[grid, grid]) * 60.0


def _midpoint_rms(model):
    test = np.arange(1.0, 360.0, 2.0)
    return float(np.sqrt(np.mean((model.predict(test + _fine_profile(test) / 60.0) - _fine_profile(test)) ** 2)))


def test_identical_repeats_are_left_out_of_the_spectral_fit():
    """The same readings twice made the blind flat level 1.7e-7 arcmin and the model follow every reading."""
    from encal.models.spectral import fit_spectral

    theta, error = _passes(0, 0.1)
    one = fit_spectral(theta[:180], error[:180])
    twice = fit_spectral(np.r_[theta[:180], theta[:180]], np.r_[error[:180], error[:180]])
    assert twice.training["noise"]["std_arcmin"] == pytest.approx(one.training["noise"]["std_arcmin"])
    assert twice.training["noise"]["identical_repeats_dropped"] == 180
    np.testing.assert_allclose(twice.predict(np.arange(0.0, 360.0, 0.5)), one.predict(np.arange(0.0, 360.0, 0.5)))


@pytest.mark.parametrize("seed", range(5))
def test_a_repeat_scatter_below_the_quantisation_is_raised_to_it(seed):
    """A 14-bit encoder with 0.05 arcmin of noise repeats most codes: the scatter (about 0.1 arcmin) misses the rounding
    (LSB/sqrt(12) = 0.38 arcmin), which differs from stop to stop. Used as is it had the model follow the rounding;
    raised to the floor the model is closer to the truth between the stops, on every seed."""
    from encal.models.spectral import fit_spectral, repeat_noise

    theta, error = _passes(seed, 0.05)
    floor = LSB_14 * 60.0 / np.sqrt(12.0)
    scatter = repeat_noise(np.tile(np.arange(0.0, 360.0, 2.0), 2), error)[0]
    assert 0 < scatter < floor
    model = fit_spectral(theta, error)
    assert model.training["noise"]["std_arcmin"] == pytest.approx(floor)
    assert model.training["noise"]["repeat_std_arcmin"] == pytest.approx(scatter)
    as_is = fit_spectral(theta, error, noise_arcmin=scatter)
    assert _midpoint_rms(model) < _midpoint_rms(as_is)


def test_fit_refuses_the_calibration_as_its_own_repeat(tmp_path, capsys):
    from encal.cli import main

    theta, _ = _passes(0, 0.1)
    grid = np.arange(0.0, 360.0, 2.0)
    path = _write(tmp_path / "a.csv", grid, theta[:180])
    assert main(["fit", str(path), "--repeat", str(path), "-o", str(tmp_path / "m.json"), "--method", "spectral"]) == 1
    err = capsys.readouterr().err
    assert "is the same file as" in err and "a second pass" in err and err.count("\n") == 1  # cli check_paths
    assert not (tmp_path / "m.json").exists()
    # a copy: warned about and ignored, the same model as without it
    copy = _write(tmp_path / "copy.csv", grid, theta[:180])
    assert main(["fit", str(path), "--repeat", str(copy), "-o", str(tmp_path / "m.json"), "--method", "spectral",
                 "--json"]) == 0
    err = capsys.readouterr().err
    assert "warning: --repeat" in err and "identical" in err and "ignored" in err
    assert main(["fit", str(path), "-o", str(tmp_path / "alone.json"), "--method", "spectral", "--json"]) == 0
    capsys.readouterr()
    same = [encal.load_model(tmp_path / name).predict(grid + 1.0) for name in ("m.json", "alone.json")]
    np.testing.assert_allclose(same[0], same[1])


# ---------------------------------------------------------------- item 2: one encoder turn per reference turn

GRID = np.arange(0.0, 360.0, 2.0)
TRUE_ENCODER = GRID + _profile_arcmin(GRID) / 60.0


@pytest.mark.parametrize("encoder, options, option", [
    (np.round(TRUE_ENCODER / 360.0 * 2**16) % 2**16, {"encoder_unit": "counts:14"}, "--enc-unit counts:16"),
    (np.round(TRUE_ENCODER / 360.0 * 2**14) % 2**14, {}, "--enc-unit counts:14"),
    (np.radians(TRUE_ENCODER), {}, "--enc-unit rad"),
    (TRUE_ENCODER / 360.0, {}, "--enc-unit rev"),
    (-np.round(TRUE_ENCODER / 360.0 * 2**12), {}, "--enc-unit counts:12 --reverse"),
], ids=["16-bit-as-14", "counts-as-degrees", "radians-as-degrees", "turns-as-degrees", "reversed-counts"])
def test_an_encoder_read_in_another_unit_is_refused_naming_the_unit(tmp_path, encoder, options, option):
    """`fit u16.csv --enc-unit counts:14` gave "RMS 6237 -> 6264 arcmin" with exit status 0."""
    path = _write(tmp_path / "cal.csv", GRID, encoder)
    with pytest.raises(encal.CalibrationError) as info, warnings.catch_warnings():
        warnings.simplefilter("ignore", EncalWarning)  # radians are warned about, as before
        read_calibration(path, **options)
    message = str(info.value)
    assert "does not turn once per turn of the reference" in message and f"(use {option})" in message
    assert "\n" not in message and str(path) in message


def test_a_reference_in_radians_is_named(tmp_path):
    path = _write(tmp_path / "cal.csv", np.radians(GRID), TRUE_ENCODER)
    with pytest.warns(EncalWarning, match="--unit rad"), pytest.raises(encal.CalibrationError, match="--ref-unit rad"):
        read_calibration(path)


def test_both_columns_in_radians_are_warned_about_with_the_option(tmp_path):
    path = _write(tmp_path / "cal.csv", np.radians(GRID), np.radians(TRUE_ENCODER))
    with pytest.warns(EncalWarning, match="--unit rad"), pytest.raises(encal.CalibrationError, match="gap"):
        read_calibration(path)
    assert len(read_calibration(path, reference_unit="rad", encoder_unit="rad")) == GRID.size


@pytest.mark.parametrize("amplitude_deg", [20.0, 50.0])
def test_a_large_error_that_does_not_fold_is_still_accepted(tmp_path, amplitude_deg):
    """A misplaced magnet: a first harmonic of up to 57 deg keeps the encoder going forward."""
    path = _write(tmp_path / "cal.csv", GRID, GRID + 33.0 + amplitude_deg * np.sin(np.radians(GRID)))
    assert len(_quiet_read(path)) == GRID.size


def test_an_encoder_counting_against_the_reference_still_gets_reverse(tmp_path):
    path = _write(tmp_path / "cal.csv", GRID, -TRUE_ENCODER)
    with pytest.raises(encal.CalibrationError, match="counts against the reference.*--reverse"):
        read_calibration(path)


# ---------------------------------------------------------------- item 3: a correction worse than none

def _other_encoder(path):
    """Another encoder's calibration: another profile, larger than the first's."""
    theta = np.radians(GRID)
    return _write(path, GRID, GRID + (3.0 * np.sin(2 * theta + 1.0) + 8.0 * np.cos(theta + 2.0)) / 60.0)


@pytest.fixture
def two_encoders(tmp_path):
    from encal.cli import main

    first = _write(tmp_path / "first.csv", GRID, TRUE_ENCODER)
    other = _other_encoder(tmp_path / "other.csv")
    assert main(["fit", str(first), "-o", str(tmp_path / "first.json"), "--method", "fourier", "--json"]) == 0
    return first, other, tmp_path / "first.json"


def test_evaluate_says_when_the_correction_makes_things_worse(two_encoders, capsys):
    """A model of one encoder applied to another: RMS 6.6 -> 7.4 arcmin "after correction", said nowhere."""
    from encal.cli import main

    first, other, model = two_encoders
    capsys.readouterr()
    assert main(["evaluate", str(model), str(other)]) == 0  # a valid measurement: status 0
    captured = capsys.readouterr()
    result = encal.models.fitting.evaluate(encal.load_model(model), read_calibration(other))
    before, after = f"{result.before.rms:.4g}", f"{result.after.rms:.4g}"
    assert result.after.rms > 1.05 * result.before.rms
    warning = [line for line in captured.err.splitlines() if line.startswith("encal evaluate: warning: ")]
    assert len(warning) == 1 and "the correction makes the errors larger" in warning[0]
    assert f"RMS {before} arcmin without it, {after} arcmin with it" in warning[0]
    assert "verdict: the correction makes the errors larger" in captured.out
    assert main(["evaluate", str(model), str(other), "--json"]) == 0
    document = __import__("json").loads(capsys.readouterr().out)
    assert document["correction_worse"] is True and before in document["verdict"]
    # on its own encoder: no warning, and the verdict says smaller
    assert main(["evaluate", str(model), str(first)]) == 0
    captured = capsys.readouterr()
    assert "warning" not in captured.err and "verdict: the correction makes the errors smaller" in captured.out


def test_drift_and_report_say_when_the_correction_makes_things_worse(two_encoders, capsys, tmp_path):
    from encal.cli import main

    first, other, model = two_encoders
    capsys.readouterr()
    assert main(["drift", str(first), str(other)]) == 0
    captured = capsys.readouterr()
    assert "encal drift: warning: the correction makes the errors larger on other.csv: RMS " in captured.err
    assert "verdict: the correction makes the errors larger on other.csv" in captured.out
    assert main(["drift", str(first), str(other), "--json"]) == 0
    epoch = __import__("json").loads(capsys.readouterr().out)["epochs"][0]
    assert epoch["correction_worse"] is True and epoch["uncorrected_rms_arcmin"] < epoch["residual_rms_arcmin"]
    assert main(["report", str(first), str(other), "-o", str(tmp_path / "r.html"), "--method", "fourier",
                 "--no-uncertainty", "--no-comparison"]) == 0
    captured = capsys.readouterr()
    assert "encal report: warning: on other, the correction makes the errors larger: RMS " in captured.err
    assert "Warning: on other, the correction makes the errors larger" in (tmp_path / "r.html").read_text()


# ---------------------------------------------------------------- item 6: the zero offset a correction leaves

def test_evaluate_explains_the_zero_offset_the_correction_leaves(tmp_path, capsys):
    """A model fitted on a repeat whose zero moved by 79.2 deg, evaluated on the first run: "after" zero offset
    -4752 arcmin, and "zero offset +0.00 arcmin, larger than 1 deg", without a word of why."""
    from encal.cli import main

    first = _write(tmp_path / "first.csv", GRID, TRUE_ENCODER)
    moved = _write(tmp_path / "moved.csv", GRID - 79.2, TRUE_ENCODER)  # the reference started 79.2 deg later
    assert main(["fit", str(moved), "-o", str(tmp_path / "moved.json"), "--method", "fourier", "--json"]) == 0
    capsys.readouterr()
    assert main(["evaluate", str(tmp_path / "moved.json"), str(first)]) == 0
    captured = capsys.readouterr()
    assert "warning" not in captured.err  # the shape is corrected as well as on its own calibration
    assert "+0.00 arcmin (+0.000 deg), larger than 1 deg" not in captured.out
    assert "zero offset after the correction -4752.00 arcmin (-79.200 deg), larger than 1 deg" in captured.out
    assert ("after the correction a zero offset of -4752.00 arcmin (-79.200 deg) remains: the model carries the zero "
            "offset of the calibration it was fitted on (+4752.00 arcmin)") in captured.out
    assert "not an error of the correction" in captured.out


def test_fit_refuses_a_calibration_in_another_unit_built_from_arrays():
    counts = np.round(TRUE_ENCODER / 360.0 * 2**14) % 2**14
    with pytest.raises(encal.CalibrationError, match=r"^counts: the encoder does not turn once per turn"):
        encal.fit(encal.Calibration(GRID, counts, name="counts"), method="fourier")

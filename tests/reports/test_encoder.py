"""``encal report``: the HTML page and figures for the user's own encoder (encal.reports.encoder)."""

import re
import shutil
import subprocess

import numpy as np
import pytest

from encal import Calibration, load_model, read_calibration, write_calibration
from encal.cli import main
from encal.reports.encoder import ENCODER_FIGURES, encoder_report, write_encoder_report

STEPS = np.arange(0.0, 360.0, 1.8)

#: Python representations that must never reach the page.
REPRS = re.compile(r"np\.float|array\(|<encal|Calibration\(|ErrorStats\(|Evaluation\(|\bNone\b|\bnan\b|dtype")


def shape_arcmin(theta_deg):
    r = np.radians(theta_deg)
    return 3.0 * np.sin(r) + 1.0 * np.cos(2 * r) + 0.4 * np.sin(4 * r + 0.3)


def stepper(offset_deg, seed, name, counts_bits=None):
    """A stepper's full steps against an encoder; the zero is wherever the motor started."""
    shaft = STEPS + offset_deg
    noise = np.random.default_rng(seed).normal(0.0, 0.2, STEPS.size)
    encoder = shaft + (shape_arcmin(shaft) + noise) / 60.0
    if counts_bits is not None:
        encoder = np.round(encoder * 2**counts_bits / 360.0) * 360.0 / 2**counts_bits
    return Calibration(STEPS, encoder, name=name)


def write(tmp_path, cal):
    path = tmp_path / f"{cal.name}.csv"
    write_calibration(path, cal)
    return path


def figures_in(page):
    return re.findall(r'<img data-figure="([a-z_]+)"', page)


def test_a_stepper_with_an_arbitrary_zero(tmp_path, capsys):
    first = write(tmp_path, stepper(59.0, 1, "motor_a", counts_bits=14))
    again = write(tmp_path, stepper(95.0, 2, "motor_b", counts_bits=14))
    out = tmp_path / "report.html"
    assert main(["report", str(first), str(again), "-o", str(out), "--method", "fourier", "--no-uncertainty"]) == 0
    printed = capsys.readouterr().out
    assert "larger than 1 deg" in printed and "14-bit encoder" in printed
    page = out.read_text(encoding="utf-8")
    assert figures_in(page) == ["profile", "harmonics", "selection", "before_after"]
    assert sorted(p.name for p in (tmp_path / "report_figures").iterdir()) == \
        ["before_after.png", "harmonics.png", "profile.png", "selection.png"]
    # the comparison: every family scored on held-out points, the model encal fit made marked
    comparison = page.split("<h2>Model comparison</h2>", 1)[1].split("<h2>", 1)[0]
    for family in ("spectral", "fourier select=cv", "lut interpolation=linear", "ann hidden=6", "hybrid"):
        assert f'<td class="text">{family}' in comparison
    assert comparison.count(">chosen</td>") == 1 and "--method fourier" in comparison
    assert not REPRS.search(page)
    # the offset stated apart, the statistics those of the shape (RMS of shape_arcmin is 2.26 arcmin)
    assert "+3540.0" in page or "+3539.9" in page
    assert "zero offset (apart)" in page
    record = re.search(r"<td class=\"text\">RMS</td><td class=\"num\">([0-9.]+)</td>", page)
    assert float(record.group(1)) == pytest.approx(2.27, abs=0.1)
    # held-out: the repeat from another start is corrected to the noise and the 14-bit rounding
    after = re.findall(r"<td class=\"text\">RMS</td><td class=\"num\">([0-9.]+)</td><td class=\"num\">([0-9.]+)",
                       page)
    assert float(after[0][1]) < 0.6


def test_a_rotary_table_with_test_and_later_epochs_shows_drift(tmp_path, capsys):
    assert main(["simulate", "--encoders", "1", "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    train, test, epoch2 = (tmp_path / f"enc1_{kind}.csv" for kind in ("train", "test", "epoch2"))
    out = tmp_path / "enc1.html"
    assert main(["report", str(train), str(test), str(epoch2), "-o", str(out), "--method", "fourier",
                 "--no-uncertainty", "--no-comparison", "--figures", str(tmp_path / "figs")]) == 0
    printed = capsys.readouterr().out
    assert "within 1 deg" in printed  # a rotary table: the zero is fixed
    page = out.read_text(encoding="utf-8")
    assert figures_in(page) == ["profile", "harmonics", "before_after", "drift"]
    assert len(list((tmp_path / "figs").glob("*.png"))) == 4
    assert "<h2>Drift</h2>" in page and "enc1_epoch2" in page
    assert not REPRS.search(page)


def test_a_bidirectional_run_shows_the_reversal_with_a_direction_column(tmp_path, capsys):
    ref = np.tile(np.arange(0.0, 360.0, 2.0), 2)
    direction = np.repeat([1, -1], 180)
    hysteresis = 0.5 * direction  # arcmin: B = x̄↑ - x̄↓ = 1.0
    cal = Calibration(ref, ref + (shape_arcmin(ref) + hysteresis) / 60.0, direction=direction, name="table")
    path = write(tmp_path, cal)
    out = tmp_path / "table.html"
    assert main(["report", str(path), "-o", str(out), "--method", "fourier", "--no-uncertainty",
                 "--no-comparison"]) == 0
    capsys.readouterr()
    page = out.read_text(encoding="utf-8")
    assert "reversal" in figures_in(page)
    assert "<th>direction</th>" in page and "forward (+1)" in page and "reverse (-1)" in page
    value = re.search(r"reversal value</td><td class=\"num\">([0-9.]+)", page)
    assert float(value.group(1)) == pytest.approx(1.0, abs=1e-6)


def test_a_bidirectional_run_reports_with_the_default_model_and_its_uncertainty(tmp_path, capsys):
    # auto with its uncertainty on a direction column used to stop with a StopIteration traceback
    ref = np.tile(np.arange(0.0, 360.0, 2.0), 2)
    direction = np.repeat([1, -1], 180)
    cal = Calibration(ref, ref + (shape_arcmin(ref) + 0.5 * direction) / 60.0, direction=direction, name="table")
    out = tmp_path / "table.html"
    assert main(["report", str(write(tmp_path, cal)), "-o", str(out), "--no-comparison"]) == 0
    assert "Traceback" not in capsys.readouterr().err
    page = out.read_text(encoding="utf-8")
    assert "its 95 % band for a new reading" in page and "reverse (-1)" in page


def test_the_model_is_the_one_encal_fit_makes(tmp_path, capsys):
    path = write(tmp_path, stepper(0.0, 3, "small"))
    fitted, reported = tmp_path / "fit.json", tmp_path / "report.json"
    assert main(["fit", str(path), "-o", str(fitted), "--seed", "5", "--method", "ann", "--hidden", "3",
                 "--epochs", "10"]) == 0
    report = encoder_report(read_calibration(path), method="ann", rng=5, uncertainty=False, compare=False, hidden=3,
                            epochs=10)
    report.model.save(reported)
    assert load_model(reported).parameters() == load_model(fitted).parameters()
    assert main(["report", str(path), "-o", str(tmp_path / "r.html"), "--seed", "5", "--model",
                 str(tmp_path / "cli.json"), "--no-uncertainty", "--no-comparison"]) == 0
    capsys.readouterr()
    assert main(["fit", str(path), "-o", str(tmp_path / "auto.json"), "--seed", "5"]) == 0
    capsys.readouterr()
    assert load_model(tmp_path / "cli.json").parameters() == load_model(tmp_path / "auto.json").parameters()


def test_bad_output_folder_is_one_line_and_writes_nothing(tmp_path, capsys):
    path = write(tmp_path, stepper(0.0, 4, "x"))
    assert main(["report", str(path), "-o", str(tmp_path / "missing" / "r.html"), "--method", "fourier"]) == 1
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and "does not exist" in captured.err
    assert not (tmp_path / "missing").exists()


@pytest.mark.slow
def test_the_page_displays_every_figure_in_a_headless_browser(tmp_path):
    """Opened in a real browser (Chromium, headless): every figure decodes and the page is not blank."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if browser is None:
        pytest.skip("no Chromium on this machine (apt-get install chromium) to open the report in")
    import matplotlib.image

    first, again = stepper(59.0, 1, "motor_a", 14), stepper(95.0, 2, "motor_b", 14)
    ref = np.tile(STEPS, 2)
    direction = np.repeat([1, -1], STEPS.size)
    both = Calibration(ref, np.r_[first.encoder_deg, first.encoder_deg + 0.01], direction=direction,
                       epoch=np.repeat(["a", "b"], STEPS.size), name="motor")
    report = encoder_report(both, [again], method="fourier")
    page = tmp_path / "page.html"
    write_encoder_report(report, page)
    expected = figures_in(page.read_text(encoding="utf-8"))
    assert expected == list(ENCODER_FIGURES)
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--window-size=1200,4000"]
    dom = subprocess.run([browser, *flags, "--dump-dom", page.as_uri()], capture_output=True, text=True,
                         timeout=120, check=True).stdout
    loaded = re.search(r'data-figures-loaded="(\d+)"', dom)
    assert loaded is not None, "the page's figure check did not run"
    assert int(loaded.group(1)) == len(expected)
    shot = tmp_path / "shot.png"
    subprocess.run([browser, *flags, f"--screenshot={shot}", page.as_uri()], capture_output=True, timeout=120,
                   check=True)
    pixels = matplotlib.image.imread(shot)[..., :3]
    assert pixels.shape[:2] == (4000, 1200)
    assert float(pixels.std()) > 0.05  # not blank
    assert float(np.mean(pixels.min(axis=-1) < 0.5)) > 0.01  # text and curves, not an empty white page
    # a desktop and a phone: nothing sticks out past the page's width (tables scroll inside their box). A
    # headless window is at least 500 px wide, so the page is laid out in a frame of each width.
    for width in (1400, 390):
        frame = tmp_path / f"frame{width}.html"
        frame.write_text(f'<!DOCTYPE html><html><body><iframe id="f" src="{page.name}" style="width:{width}px;'
                         'height:900px;border:0"></iframe><script>document.getElementById("f").addEventListener('
                         '"load", function () { var d = this.contentDocument.documentElement; document.body.'
                         'setAttribute("data-widths", d.scrollWidth + " " + d.clientWidth); });</script>'
                         '</body></html>', encoding="utf-8")
        dom = subprocess.run([browser, *flags, "--allow-file-access-from-files", "--dump-dom", frame.as_uri()],
                             capture_output=True, text=True, timeout=120, check=True).stdout
        laid_out, window = map(int, re.search(r'data-widths="(\d+) (\d+)"', dom).groups())
        assert 0 < laid_out <= window <= width, width


def test_with_a_test_calibration_every_candidate_is_scored_on_it(tmp_path):
    train, test = stepper(0.0, 1, "train"), stepper(0.9, 2, "test")  # the test between the training steps
    report = encoder_report(train, [test], method="fourier", zero="fixed", rng=0, uncertainty=False)
    comparison = report.comparison
    assert comparison["scheme"] == "tests" and comparison["folds"] == 0
    row = next(r for r in comparison["table"] if r["label"] == "fourier select=cv")
    from encal.models import select

    fitted = select.Candidate("fourier", {"select": "cv"}).fit(train.encoder_deg, train.errors_arcmin,
                                                              rng=np.random.default_rng(0))
    residual = test.errors_arcmin - fitted.predict(test.encoder_deg)
    assert row["cv_rms_arcmin"] == pytest.approx(np.sqrt(np.mean(residual**2)), rel=1e-9)
    out = tmp_path / "r.html"
    write_encoder_report(report, out)
    page = out.read_text(encoding="utf-8")
    assert "scored on the test calibrations" in page and "test RMS (arcmin)" in page


def test_the_page_says_which_figure_to_trust_when_the_comparison_ranks_the_choice_low():
    report = encoder_report(stepper(0.0, 1, "train"), method="fourier", zero="fixed", rng=0, uncertainty=False,
                            compare=False)
    chosen = report.model.training.get("method", report.model.kind)
    from encal.reports.encoder import _trust_sentence

    rows = [{"label": "other", "family": "lut", "cv_rms_arcmin": 1.0},
            {"label": "mine", "family": chosen, "cv_rms_arcmin": 5.0}]
    report.comparison = {"scheme": "report", "folds": 5, "table": rows, "chosen": "mine", "reason": ""}
    sentence = _trust_sentence(report)
    assert "ranks 2 of 2" in sentence and "interleaved folds" in sentence and "TEST.csv" in sentence
    report.comparison = {**report.comparison, "scheme": "tests"}
    assert "fit --method lut" in _trust_sentence(report)
    rows[1]["cv_rms_arcmin"] = 1.02  # within 5 % of the best: nothing to say
    assert _trust_sentence(report) == ""


def test_a_dense_log_leaves_the_comparison_out_and_says_why(tmp_path, monkeypatch, capsys):
    import encal.reports.encoder as module

    monkeypatch.setattr(module, "COMPARISON_MAX_POINTS", 100)  # the 200 full steps count as dense here
    path = write(tmp_path, stepper(0.0, 1, "dense"))
    out = tmp_path / "r.html"
    assert main(["report", str(path), "-o", str(out), "--method", "fourier", "--no-uncertainty"]) == 0
    assert "The model comparison was left out" in capsys.readouterr().out
    page = out.read_text(encoding="utf-8")
    assert "The model comparison was left out" in page and "selection" not in figures_in(page)
    assert main(["report", str(path), "-o", str(out), "--method", "fourier", "--no-uncertainty",
                 "--comparison"]) == 0
    assert "selection" in figures_in(out.read_text(encoding="utf-8"))


def test_comparison_and_no_comparison_together_are_a_usage_error(tmp_path, capsys):
    path = write(tmp_path, stepper(0.0, 1, "cal"))
    with pytest.raises(SystemExit) as exit_info:
        main(["report", str(path), "-o", str(tmp_path / "r.html"), "--comparison", "--no-comparison"])
    assert exit_info.value.code == 2


def test_the_page_opens_with_a_verdict_on_the_data_it_rests_on(tmp_path, capsys):
    from encal.reports.encoder import verdict

    train, test = stepper(0.0, 1, "train"), stepper(0.9, 2, "test")
    with_test = encoder_report(train, [test], method="fourier", zero="fixed", uncertainty=False, compare=False)
    line = verdict(with_test)
    evaluation = with_test.held_out[0][1]
    assert f"RMS {with_test.stats.rms:.3g} arcmin" in line
    assert f"after correction RMS {evaluation.after.rms:.3g} arcmin is left on {len(test)} test points" in line
    alone = encoder_report(train, method="spectral", zero="fixed", uncertainty=False, compare=False)
    assert "the model's own estimate" in verdict(alone)
    other = Calibration(test.reference_deg, test.reference_deg - (test.encoder_deg - test.reference_deg), name="x")
    worse = encoder_report(train, [other], method="fourier", zero="fixed", uncertainty=False, compare=False)
    assert "the correction makes it worse there" in verdict(worse)
    out = tmp_path / "r.html"
    write_encoder_report(alone, out)
    page = out.read_text(encoding="utf-8")
    assert page.index('class="verdict"') < page.index("<h2>Summary</h2>")


def test_a_bidirectional_verdict_states_the_held_out_estimate_and_the_band():
    """Without a test calibration a directional model's verdict rested on its training points, with no band (the
    parts' posteriors were not read); now the parts' estimates, pooled, and the band of a reading whose direction is
    unknown."""
    from encal.reports.encoder import verdict

    ref = np.tile(np.arange(0.0, 360.0, 2.0), 2)
    direction = np.repeat([1, -1], 180)
    noise = np.random.default_rng(2).normal(0.0, 0.1, ref.size)
    cal = Calibration(ref, ref + (shape_arcmin(ref) + 0.5 * direction + noise) / 60.0, direction=direction,
                      name="table")
    report = encoder_report(cal, rng=0, compare=False)
    assert report.model.kind == "directional"
    parts = [part.expected_rms_between_points() for part in (report.model.forward, report.model.reverse)]
    expected = float(np.sqrt(np.mean(np.square(parts))))
    line = verdict(report)
    assert f"about RMS {expected:.3g} arcmin is expected at readings it did not see" in line
    _, std = report.model.predict(np.linspace(0.0, 360.0, 721)[:-1], return_std=True)
    assert f"95 % band for a new reading is ± {1.959963984540054 * float(np.mean(std)):.3g} arcmin" in line
    assert 0.05 < expected < 0.2  # the noise is 0.1 arcmin


def test_the_band_of_a_smoothed_calibration_with_its_sigma_is_not_said_to_be_for_a_new_reading():
    """metrology8: a self-calibration's output (a smoothed curve with its sigma_arcmin) has no reading noise in its
    points, so the band is the profile's alone; it was called "for a new reading" and covered 25 % of new readings
    of an encoder with 2 arcmin of noise (benchmarks/bench_report_band.py, 50 spins)."""
    from encal.reports.encoder import verdict

    grid = np.arange(0.0, 360.0, 1.0)
    smooth = Calibration(grid - shape_arcmin(grid) / 60.0, grid, reference_std_arcmin=np.full(grid.size, 0.3),
                         name="selfcal")
    report = encoder_report(smooth, rng=0, compare=False)
    line = verdict(report)
    assert "the model's 95 % band for the encoder's error is ±" in line and "not for a new reading" in line
    assert "a new reading's own noise comes on top of both figures" in line
    from encal.reports.encoder import _profile_figure

    labels = [artist.get_label() for artist in _profile_figure(report).axes[0].collections]
    assert "95 % band of the encoder's error" in labels and "95 % band of a new reading" not in labels
    noisy = Calibration(smooth.reference_deg, smooth.encoder_deg + np.random.default_rng(0).normal(0, 0.3, grid.size)
                        / 60.0, reference_std_arcmin=np.full(grid.size, 0.05), name="certified")
    line = verdict(encoder_report(noisy, rng=0, compare=False))
    assert "the model's 95 % band for a new reading is ±" in line and "not for a new reading" not in line


def test_the_iso_230_2_table_of_the_page_is_the_standards_on_a_hand_made_log(tmp_path, capsys):
    """metrology8: every ISO 230-2 figure of the page, in arcmin and in the standard's arcsec, against the
    formulas worked by hand (tests/cli/test_profile.py)."""
    from tests.cli.test_profile import HAND_FIGURES, hand_log

    out = tmp_path / "hand.html"
    assert main(["report", str(hand_log(tmp_path)), "-o", str(out), "--allow-gaps", "--keep-duplicates",
                 "--method", "fourier", "--no-uncertainty", "--no-comparison"]) == 0
    capsys.readouterr()
    page = out.read_text(encoding="utf-8")
    assert "<th>ISO 230-2 value</th><th>arcmin</th><th>arcsec</th>" in page
    for key, value in HAND_FIGURES.items():
        label = key.replace("_", " ")
        cells = re.search(rf"<td class=\"text\">{label}</td><td class=\"num\">([-0-9.e]+)</td>"
                          rf"<td class=\"num\">([-0-9.e]+)</td>", page)
        assert cells is not None, label
        assert float(cells.group(1)) == pytest.approx(value, rel=5e-4), label  # 4 significant digits
        assert float(cells.group(2)) == pytest.approx(60 * value, rel=5e-4), label


def test_the_band_of_a_smoothed_calibration_with_its_measured_reading_noise_is_for_a_new_reading():
    """noise9: with the reading noise a self-calibration measured from its log (its reading_noise_arcmin comment,
    here the metadata it is read into), the band adds it and is said to be for a new reading, with its source."""
    from encal.reports.encoder import _profile_figure, verdict

    grid = np.arange(0.0, 360.0, 1.0)
    smooth = Calibration(grid - shape_arcmin(grid) / 60.0, grid, reference_std_arcmin=np.full(grid.size, 0.3),
                         name="selfcal", metadata={"reading_noise_arcmin": 2.0})
    report = encoder_report(smooth, rng=0, compare=False)
    line = verdict(report)
    assert "the model's 95 % band for a new reading is ±" in line and "not for a new reading" not in line
    assert "with the reading noise the self-calibration measured from its log (2 arcmin RMS)" in line
    _, std = report.model.predict(grid, return_std=True)
    assert float(np.min(std)) >= 2.0  # the noise is in every point's band
    labels = [artist.get_label() for artist in _profile_figure(report).axes[0].collections]
    assert "95 % band of a new reading" in labels

"""`encal selfcal`: spin and sweep from the command line, and a moteus capture end to end to firmware."""

import numpy as np
import pytest

from encal.data.calibration import read_calibration
from encal.cli import build_parser, main
from encal.deploy import load_model
from encal.selfcal.moteus_capture import write_moteus_capture
from encal.selfcal.synthetic import draw_magnetic_encoder, make_motor, simulate_spin, simulate_sweep
from encal.selfcal.spin import SpinLog
from encal.selfcal.spin_log import write_spin_log
from tests.selfcal_truth import GRID, rms, truth_at_orders

ENCODER = draw_magnetic_encoder(31, eccentricity_deg=1.0)


def _export_formats():
    parser = build_parser(every_command=True)
    export = parser._subparsers._group_actions[0].choices["export"]
    return next(action.choices for action in export._actions if action.dest == "format")


def test_moteus_capture_to_model_to_c_and_moteus_table(tmp_path, capsys):
    motor = make_motor(21, 36, 9)
    capture = simulate_sweep(motor, ENCODER, rng=10)
    raw = tmp_path / "moteus_raw.txt"
    write_moteus_capture(raw, capture.direction, capture.phase, capture.encoder)
    cal_path, model_path = tmp_path / "cal.csv", tmp_path / "model.json"
    assert main(["selfcal", "sweep", str(raw), "--pole-pairs", "21", "-o", str(cal_path)]) == 0
    printed = capsys.readouterr().out
    assert "multiple of 21" in printed and "+-2 sigma" in printed
    cal = read_calibration(cal_path)
    assert len(cal) == 360 and cal.resolution_bits == 16
    assert main(["fit", str(cal_path), "-o", str(model_path), "--method", "fourier"]) == 0
    model = load_model(model_path)
    truth = truth_at_orders(ENCODER, [k for k in range(1, 33) if k % 21])
    predicted = model.predict(GRID)
    assert rms(predicted - predicted.mean() - truth) <= 0.1 * rms(truth)
    out = tmp_path / "firmware"
    assert main(["export", str(model_path), "--format", "c", "-o", str(out)]) == 0
    source = (out / "encal.c").read_text()
    assert "encal_correct_deg" in source
    assert "moteus" in _export_formats()
    moteus = tmp_path / "moteus.cfg"
    assert main(["export", str(model_path), "--format", "moteus", "-o", str(moteus)]) == 0
    assert "conf set" in moteus.read_text()


def test_a_moteus_capture_swept_twice_writes_its_reading_noise_for_fit_and_report(tmp_path, capsys):
    """sweepnoise: the reading noise a sweep measures from its repeated angles reaches encal fit and report."""
    capture = simulate_sweep(make_motor(7, 12, 9), ENCODER, rng=10, passes=2)
    raw, out = tmp_path / "moteus_raw.txt", tmp_path / "cal.csv"
    write_moteus_capture(raw, capture.direction, capture.phase, capture.encoder)
    assert main(["selfcal", "sweep", str(raw), "--pole-pairs", "7", "-o", str(out)]) == 0
    assert "reading noise (one reading about the profile" in capsys.readouterr().out
    truth = np.hypot(ENCODER.noise_arcmin, 21600.0 / 2**14 / np.sqrt(12.0))
    assert read_calibration(out).metadata["reading_noise_arcmin"] == pytest.approx(truth, rel=0.12)
    assert main(["fit", str(out), "-o", str(tmp_path / "model.json")]) == 0
    assert "and a new reading's noise (" in capsys.readouterr().out
    assert main(["report", str(out), "-o", str(tmp_path / "report.html"), "--no-comparison"]) == 0
    assert "band for a new reading" in capsys.readouterr().out


def test_steps_of_single_reads_writes_their_reading_noise_and_averaged_steps_do_not(tmp_path, capsys):
    """sweepnoise: --single-reads writes the noise two calibrations' difference measures; without it, none."""
    from encal.data.calibration import write_calibration
    from encal.selfcal.synthetic import draw_stepper, simulate_steps

    stepper, paths = draw_stepper(4), [tmp_path / "a.csv", tmp_path / "b.csv"]
    for path, encoder, seed in zip(paths, (ENCODER, ENCODER.turned(137.5)), (1, 2)):
        write_calibration(path, simulate_steps(stepper, encoder, readings_per_step=1, rng=seed).calibration)
    out = tmp_path / "cal.csv"
    assert main(["selfcal", "steps", *map(str, paths), "--single-reads", "-o", str(out)]) == 0
    assert "reading noise (one reading about the profile" in capsys.readouterr().out
    truth = np.hypot(ENCODER.noise_arcmin, 21600.0 / 2**14 / np.sqrt(12.0))
    assert read_calibration(out).metadata["reading_noise_arcmin"] == pytest.approx(truth, rel=0.18)
    assert main(["selfcal", "steps", *map(str, paths), "-o", str(out)]) == 0
    assert "reading noise: not measured" in capsys.readouterr().out
    assert "reading_noise_arcmin" not in read_calibration(out).metadata


def test_spin_at_two_speeds_from_one_log_file(tmp_path, capsys):
    motor = make_motor(7, 12, 3)
    runs = [simulate_spin(motor, ENCODER, speed, revolutions=10, sample_rate_hz=1200.0, rng=seed)
            for speed, seed in ((2.0, 1), (4.0, 2))]
    log = tmp_path / "spin.csv"
    write_spin_log(log, [SpinLog(r.time_s, r.encoder_deg) for r in runs])
    out = tmp_path / "cal.csv"
    assert main(["selfcal", "spin", str(log), "--pole-pairs", "7", "-o", str(out), "--bits", "14"]) == 0
    assert "speed ripple" in capsys.readouterr().out
    cal = read_calibration(out)
    truth = truth_at_orders(ENCODER, range(1, 33), grid=cal.encoder_deg)
    assert rms(cal.errors_arcmin - truth) <= 0.1 * rms(truth)
    header = [line for line in out.read_text().splitlines() if not line.startswith("#")][0]
    assert header == "reference_deg,encoder_deg,error_arcmin,sigma_arcmin"
    # noise9: the reading noise measured from the log is written with the curve and used by encal fit and report
    truth = np.hypot(ENCODER.noise_arcmin, 21600.0 / 2**14 / np.sqrt(12.0))
    assert cal.metadata["reading_noise_arcmin"] == pytest.approx(truth, rel=0.05)
    assert "# reading_noise_arcmin: " in out.read_text()
    assert main(["fit", str(out), "-o", str(tmp_path / "model.json")]) == 0
    assert "and a new reading's noise (" in capsys.readouterr().out
    assert load_model(tmp_path / "model.json").uncertainty["noise_std_arcmin"] >= cal.metadata["reading_noise_arcmin"]
    assert main(["report", str(out), "-o", str(tmp_path / "report.html"), "--no-comparison"]) == 0
    printed = capsys.readouterr().out
    assert "band for a new reading" in printed and "the reading noise the self-calibration measured" in printed
    # --noise on such a file counted the noise twice in the band (noise9's note): refused, nothing written
    assert main(["fit", str(out), "-o", str(tmp_path / "twice.json"), "--noise", "2"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "records the reading noise its self-calibration measured" in err[0]
    assert "(leave out --noise)" in err[0] and not (tmp_path / "twice.json").exists()


@pytest.mark.parametrize("args, message", [
    (["sweep", "{missing}", "--pole-pairs", "7"], "no such file"),
    (["sweep", "{bad}", "--pole-pairs", "7"], "line 2, field 1: direction is 9"),
    (["spin", "{badlog}"], "line 3, column 2: encoder_deg is 'x'"),
])
def test_bad_input_is_one_sentence_and_exit_1(tmp_path, capsys, args, message):
    (tmp_path / "bad.txt").write_text("CAL start\n9 0 0\nCAL done\n")
    (tmp_path / "badlog.csv").write_text("time_s,encoder_deg\n0,1\n0.1,x\n")
    paths = {"missing": tmp_path / "none.txt", "bad": tmp_path / "bad.txt", "badlog": tmp_path / "badlog.csv"}
    args = [a.format(**paths) for a in args]
    out = tmp_path / "cal.csv"
    assert main(["selfcal", *args, "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "Traceback" not in err[0]
    assert not out.exists()


def test_missing_method_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["selfcal"])
    assert exit_.value.code == 2


def test_steps_with_two_calibrations_writes_the_calibration_and_the_stepper(tmp_path, capsys):
    from encal.data.calibration import write_calibration
    from encal.selfcal.synthetic import draw_stepper, simulate_steps

    stepper = draw_stepper(4)
    paths = []
    for turn, seed in ((0.0, 1), (137.5, 2)):
        run = simulate_steps(stepper, ENCODER.turned(turn), rng=seed)
        paths.append(tmp_path / f"cal{seed}.csv")
        write_calibration(paths[-1], run.calibration)
    out, stepper_csv = tmp_path / "enc.csv", tmp_path / "stepper.csv"
    assert main(["selfcal", "steps", *map(str, paths), "-o", str(out), "--stepper-csv", str(stepper_csv)]) == 0
    assert "turn deg: 137.5" in capsys.readouterr().out
    cal = read_calibration(out)
    assert cal.resolution_bits == 14
    truth = truth_at_orders(ENCODER, range(1, 17), grid=cal.encoder_deg)
    assert rms(cal.errors_arcmin - truth) <= 0.1 * rms(truth)
    rows = stepper_csv.read_text().splitlines()
    assert rows[0].startswith("step,reference_deg,stepper_error_arcmin") and len(rows) == 201


def test_steps_options_that_need_a_second_calibration(tmp_path, capsys):
    from encal.data.calibration import write_calibration
    from encal.selfcal.synthetic import draw_stepper, simulate_steps

    path = tmp_path / "a.csv"
    write_calibration(path, simulate_steps(draw_stepper(4), ENCODER, rng=1).calibration)
    assert main(["selfcal", "steps", str(path), "--turn", "90", "-o", str(tmp_path / "o.csv")]) == 1
    assert "need a second calibration" in capsys.readouterr().err
    assert not (tmp_path / "o.csv").exists()
    with pytest.raises(SystemExit) as exit_info:  # sweepnoise: a usage error
        main(["selfcal", "steps", str(path), "--single-reads", "-o", str(tmp_path / "o.csv")])
    assert exit_info.value.code == 2 and "--single-reads needs a second calibration" in capsys.readouterr().err
    assert not (tmp_path / "o.csv").exists()


def test_sweep_from_a_csv_of_the_commanded_electrical_angle(tmp_path):
    motor = make_motor(7, 12, 9)
    capture = simulate_sweep(motor, ENCODER, rng=11)
    log = tmp_path / "sweep.csv"
    rows = ["electrical_deg,encoder_deg"]
    electrical = np.unwrap(capture.phase * 360.0 / 65536, period=360.0)  # any turn: unwrapped or not
    rows += [f"{float(p)!r},{float(e) * 360.0 / 65536!r}" for p, e in zip(electrical, capture.encoder)]
    log.write_text("\n".join(rows) + "\n")
    out = tmp_path / "cal.csv"
    assert main(["selfcal", "sweep", str(log), "--pole-pairs", "7", "-o", str(out)]) == 0
    cal = read_calibration(out)
    truth = truth_at_orders(ENCODER, [k for k in range(1, 33) if k % 7], grid=cal.encoder_deg)
    assert rms(cal.errors_arcmin - truth) <= 0.1 * rms(truth)


def test_steps_keeps_the_resolution_its_readings_show(tmp_path, capsys):
    """users7: a real Mechaduino calibration in degrees (whole 14-bit codes, no resolution line) gave a calibration
    of unknown resolution: `encal fit` asked for --bits and the cortex-m4f export left out its code functions."""
    from encal.selfcal.synthetic import draw_stepper, simulate_steps

    run = simulate_steps(draw_stepper(4), ENCODER, rng=1).calibration
    path = tmp_path / "a.csv"
    path.write_text("reference_deg,encoder_deg\n" + "".join(f"{r!r},{e!r}\n" for r, e in
                                                            zip(run.reference_deg.tolist(), run.encoder_deg.tolist())))
    assert read_calibration(path).resolution_bits is None
    assert main(["selfcal", "steps", str(path), "-o", str(tmp_path / "o.csv")]) == 0
    assert read_calibration(tmp_path / "o.csv").resolution_bits == 14

"""selfcal at NumPy speed (issue 30): no scipy.interpolate, logs of plain numbers read by NumPy, the same
numbers as the line-by-line reader, and the column and unit options of every other command."""

import subprocess
import sys

import numpy as np
import pytest

from encal.data.calibration import read_calibration
from encal.cli import main
from encal.selfcal.synthetic import draw_magnetic_encoder, make_motor, simulate_spin, simulate_sweep
from encal.selfcal.spin import cubic_bspline_design
from encal.selfcal.spin_log import read_spin_log
from encal.selfcal.sweep_log import read_sweep_log


@pytest.mark.parametrize("intervals", [1, 2, 7, 40])
def test_cubic_bspline_design_is_scipys(intervals):
    from scipy.interpolate import BSpline

    start, stop = 0.25, 17.0
    inner = np.linspace(start, stop, intervals + 1)[1:-1]
    knots = np.concatenate([[start] * 4, inner, [stop] * 4])
    x = np.r_[start, np.sort(np.random.default_rng(0).uniform(start, stop, 300)), inner, stop]
    ours = cubic_bspline_design(x, knots)
    assert ours.shape == (x.size, knots.size - 4)
    np.testing.assert_allclose(ours, BSpline.design_matrix(x, knots, 3).toarray(), rtol=0, atol=1e-14)


def test_spin_does_not_import_scipy_interpolate():
    code = "import sys, encal.selfcal.spin, encal.cli.cmd_selfcal; print('scipy.interpolate' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def _spin_rows():
    motor = make_motor(7, 12, 3)
    encoder = draw_magnetic_encoder(5, eccentricity_deg=1.0)
    runs = [simulate_spin(motor, encoder, speed, revolutions=8, sample_rate_hz=800.0, rng=seed)
            for speed, seed in ((2.0, 1), (4.0, 2))]
    return [(float(t), float(e), number) for number, run in enumerate(runs, start=1)
            for t, e in zip(run.time_s, run.encoder_deg)]


def test_plain_log_reads_the_same_numbers_as_the_careful_reader(tmp_path):
    rows = _spin_rows()
    plain, careful = tmp_path / "plain.csv", tmp_path / "careful.csv"
    body = "".join(f"{t!r},{e!r},{run}\n" for t, e, run in rows)
    plain.write_text("time_s,encoder_deg,run\n" + body)
    careful.write_text("time_s,encoder_deg,run\n# a comment sends the file to the line-by-line reader\n" + body)
    fast, slow = read_spin_log(plain), read_spin_log(careful)
    assert [log.label.split(" run ")[1] for log in fast] == ["1", "2"]
    for a, b in zip(fast, slow):
        assert a.label.split(" run ")[1] == b.label.split(" run ")[1]
        assert np.array_equal(a.time_s, b.time_s) and np.array_equal(a.encoder_deg, b.encoder_deg)


def test_plain_log_with_an_overflowing_value_names_its_line(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("time_s,encoder_deg\n" + "".join(f"{k * 0.01},{k * 3.0}\n" for k in range(100))
                    + "1.5,1e999\n")
    with pytest.raises(Exception, match=r"line 102, column 2: encoder_deg is '1e999'"):
        read_spin_log(path)


def test_spin_log_columns_by_name_and_number_and_unit(tmp_path, capsys):
    rows = _spin_rows()
    named, other = tmp_path / "named.csv", tmp_path / "other.csv"
    named.write_text("time_s,encoder_deg,run\n" + "".join(f"{t!r},{e!r},{r}\n" for t, e, r in rows))
    other.write_text("run,angle_rad,t\n" + "".join(f"{r},{float(np.radians(e))!r},{t!r}\n" for t, e, r in rows))
    base = ["--pole-pairs", "7", "--points", "90"]
    assert main(["selfcal", "spin", str(named), "-o", str(tmp_path / "a.csv"), *base]) == 0
    assert main(["selfcal", "spin", str(other), "-o", str(tmp_path / "b.csv"), "--time-col", "3",
                 "--enc-col", "ANGLE_RAD", "--enc-unit", "rad", *base]) == 0
    a, b = read_calibration(tmp_path / "a.csv"), read_calibration(tmp_path / "b.csv")
    np.testing.assert_allclose(a.errors_arcmin, b.errors_arcmin, rtol=0, atol=1e-6)


def test_sweep_csv_columns_and_units(tmp_path):
    motor = make_motor(11, 12, 3)
    capture = simulate_sweep(motor, draw_magnetic_encoder(3), rng=4)
    phase, encoder = capture.phase * 360.0 / 65536.0, capture.encoder * 360.0 / 65536.0
    path = tmp_path / "sweep.csv"
    path.write_text("enc,phase_rev\n" + "".join(f"{float(e)!r},{float(p) / 360.0!r}\n" for p, e in zip(phase, encoder)))
    log = read_sweep_log(path, phase_column="PHASE_REV", encoder_column=1, phase_unit="rev")
    np.testing.assert_allclose(log.phase_deg_e, phase, rtol=0, atol=1e-9)
    np.testing.assert_allclose(log.encoder_deg, encoder, rtol=0, atol=0)


def test_column_options_refused_for_a_moteus_capture(tmp_path):
    from encal.selfcal.moteus_capture import write_moteus_capture

    capture = simulate_sweep(make_motor(11, 12, 3), draw_magnetic_encoder(3), rng=4)
    raw = tmp_path / "raw.txt"
    write_moteus_capture(raw, capture.direction, capture.phase, capture.encoder)
    with pytest.raises(SystemExit) as exit_info:
        main(["selfcal", "sweep", str(raw), "--pole-pairs", "11", "--enc-unit", "rad", "-o", str(tmp_path / "c.csv")])
    assert exit_info.value.code == 2

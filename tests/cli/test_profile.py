"""``encal profile`` (encal.cli.cmd_profile)."""

import json

import numpy as np
import pytest

from encal.cli import main
from encal._core.angles import wrap180
from encal.analysis.profile import error_stats

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
    ref = np.concatenate([np.arange(0.0, 100.0, 2.0), np.arange(150.0, 250.0, 2.0)])  # two gaps: scattered
    path = write_csv("reference_deg,encoder_deg\n" + "".join(f"{r},{r + 0.01}\n" for r in ref))
    assert main(["profile", str(path)]) == 1
    assert main(["profile", str(path), "--allow-gaps", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n"] == 100


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
    # The motor's zero is arbitrary (tens of degrees): detected, stated apart, statistics of the shape.
    assert record["zero"] == "arbitrary" and abs(record["zero_offset_arcmin"]) > 600.0
    assert "larger than 1 deg" in record["zero_note"]
    assert record["rms_arcmin"] < 100.0 and abs(record["rms_arcmin"] - record["std_arcmin"]) < 0.05
    assert {1, 2} <= {h["order"] for h in record["harmonics"][:5]}
    assert all("phase_deg" in h for h in record["harmonics"])
    assert main(["profile", str(path), "--json", "--zero", "fixed"]) == 0
    fixed = json.loads(capsys.readouterr().out)
    assert fixed["zero"] == "fixed" and "zero_offset_arcmin" in fixed
    assert fixed["rms_arcmin"] > 600.0 and fixed["harmonics"][0]["order"] == 0
    assert fixed["std_arcmin"] == pytest.approx(record["std_arcmin"], abs=1e-9)


@pytest.mark.parametrize("offset_deg, option, arbitrary", [
    (59.0, [], True), (-120.0, [], True), (0.5, [], False), (0.5, ["--arbitrary-zero"], True),
    (59.0, ["--zero", "fixed"], False)])
def test_the_zero_offset_is_stated_apart_from_the_shape(write_csv, capsys, offset_deg, option, arbitrary):
    """A stepper's arbitrary zero: the offset under its own key, the statistics those of the shape."""
    ref = np.arange(0.0, 360.0, 1.8)
    shape = 3.0 * np.sin(np.radians(ref)) + 1.0 * np.cos(np.radians(2 * ref))  # mean 0, RMS sqrt(5)
    rows = "".join(f"{float(r)!r},{float((r + offset_deg + e / 60.0) % 360.0)!r}\n" for r, e in zip(ref, shape))
    path = write_csv("reference_deg,encoder_deg\n" + rows)
    assert main(["profile", str(path), "--json", *option]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["zero_offset_arcmin"] == pytest.approx(offset_deg * 60.0, abs=1e-6)
    if arbitrary:
        assert record["zero"] == "arbitrary"
        assert record["rms_arcmin"] == pytest.approx(np.sqrt(5.0), abs=1e-9)
        assert record["pp_arcmin"] == pytest.approx(np.ptp(shape), abs=1e-9)
        assert record["harmonics"][0]["order"] == 1
        # against the encoder angle θ_ref = θ_enc - offset - e/60: 3 sin(θ_ref) = 3 cos(θ_enc - 90° - offset)
        assert record["harmonics"][0]["amplitude_arcmin"] == pytest.approx(3.0, abs=1e-5)
        assert record["harmonics"][0]["phase_deg"] == pytest.approx(wrap180(90.0 + offset_deg), abs=0.02)
    else:
        assert record["zero"] == "fixed"
        assert record["rms_arcmin"] == pytest.approx(np.sqrt(5.0 + (offset_deg * 60.0) ** 2), abs=1e-6)
    assert main(["profile", str(path), *option]) == 0
    text = capsys.readouterr().out
    assert ("stated apart" in text) == arbitrary
    assert ("zero offset (apart)" in text) == arbitrary


# -- both directions of travel: the ISO 230-2 values of the axis (as encal report gives them) ------------------------

def _bidirectional_csv(tmp_path, runs=5):
    from encal import write_calibration
    from tests.data.test_reversal import iso_run

    cal, up, down = iso_run(runs=runs)
    path = tmp_path / "axis.csv"
    write_calibration(path, cal)
    return path, up, down


def test_a_bidirectional_calibration_gets_its_iso_230_2_values(tmp_path, capsys):
    path, up, down = _bidirectional_csv(tmp_path)
    b = up.mean(axis=1) - down.mean(axis=1)
    s_up = up.std(axis=1, ddof=1)
    assert main(["profile", str(path), "--json", "--allow-gaps"]) == 0
    iso = json.loads(capsys.readouterr().out)["iso230_2"]
    assert iso["reversal_value_arcmin"] == pytest.approx(np.abs(b).max(), abs=1e-9)
    assert iso["mean_reversal_value_arcmin"] == pytest.approx(b.mean(), abs=1e-9)
    assert iso["repeatability_forward_arcmin"] == pytest.approx(4 * s_up.max(), abs=1e-9)
    assert iso["caption"] == "12 targets approached both ways, at least 5 time(s) each way (ISO 230-2 asks for 5)"
    assert main(["profile", str(path), "--allow-gaps"]) == 0
    text = capsys.readouterr().out
    assert ("ISO 230-2, both directions of travel (the statistics above pool them): 12 targets approached both "
            "ways") in text
    assert f"reversal value B{np.abs(b).max():>26.3f}" in text
    assert f"mean reversal value B\u0304{b.mean():>21.3f}" in text  # the bar combines: the columns stay aligned


def test_without_repeats_repeatability_and_accuracy_are_said_to_need_them(tmp_path, capsys):
    path, _, _ = _bidirectional_csv(tmp_path, runs=1)
    assert main(["profile", str(path), "--allow-gaps"]) == 0
    text = capsys.readouterr().out
    assert "repeatability R↑" in text and "(needs 2 approaches each way at every target)" in text
    assert main(["profile", str(path), "--json", "--allow-gaps"]) == 0
    assert json.loads(capsys.readouterr().out)["iso230_2"]["accuracy_arcmin"] is None


def test_one_direction_has_no_iso_values(write_csv, capsys):
    assert main(["profile", str(calibration_csv(write_csv)), "--json"]) == 0
    assert "iso230_2" not in json.loads(capsys.readouterr().out)


def test_a_target_tolerance_joins_readings_taken_afresh(tmp_path, capsys):
    from encal import Calibration, write_calibration
    from tests.data.test_reversal import iso_run

    cal, _, _ = iso_run()
    jitter = np.random.default_rng(3).uniform(-0.01, 0.01, len(cal))  # the reference read afresh at every approach
    moved = Calibration(cal.reference_deg + jitter, cal.encoder_deg + jitter, direction=cal.direction)
    write_calibration(tmp_path / "afresh.csv", moved)
    assert main(["profile", str(tmp_path / "afresh.csv"), "--json", "--target-tolerance", "0.05",
                 "--allow-gaps"]) == 0
    iso = json.loads(capsys.readouterr().out)["iso230_2"]
    assert iso["n_targets"] == 12 and iso["n_unmatched"] == 0 and iso["target_tolerance_deg"] == 0.05


def test_a_log_of_both_directions_with_no_common_target_is_profiled_and_says_why_there_are_no_iso_values(tmp_path,
                                                                                                     capsys):
    from encal import Calibration, write_calibration

    angles = np.arange(0.0, 360.0, 1.0)
    cal = Calibration(np.r_[angles, angles[::-1] + 0.5], np.r_[angles, angles[::-1] + 0.5] + 0.01,
                      direction=np.r_[np.ones(360), -np.ones(360)])
    write_calibration(tmp_path / "log.csv", cal)
    assert main(["profile", str(tmp_path / "log.csv")]) == 0
    assert "\nISO 230-2: none (" in capsys.readouterr().out
    assert main(["profile", str(tmp_path / "log.csv"), "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["iso230_2"] is None and "both directions" in record["iso230_2_note"]


# -- metrology8: every ISO 230-2 figure of a small hand-made log, against the standard's formulas worked by hand -----

#: Deviations x = θ_enc − θ_ref (arcmin) of each approach, by target (deg) and direction (↑ = +1, ↓ = −1): unequal
#: repeats (4 ↑ at 270, 2 ↓ at 0 and 180) and a target (45) approached ↑ only.
HAND_UP = {0: [1.0, 1.2, 1.4], 45: [0.3], 90: [2.0, 2.4, 2.2], 180: [-1.0, -0.6, -0.8], 270: [0.5, 0.5, 0.5, 0.9]}
HAND_DOWN = {0: [0.6, 1.0], 90: [1.5, 1.7, 1.9], 180: [-1.5, -1.1], 270: [0.0, 0.4, 0.2]}
ROOT_008 = 0.08 ** 0.5  # s↓ at 0 and 180: two approaches 0.4 apart, sqrt(2 · 0.2² / (2 − 1))
#: ISO 230-2:2014 clause 3 worked by hand on HAND_UP/HAND_DOWN (45 deg left out: not approached ↓).
#: x̄↑ = 1.2, 2.2, −0.8, 0.6 and s↑ = 0.2 at every target; x̄↓ = 0.8, 1.7, −1.3, 0.2 and s↓ = ROOT_008, 0.2,
#: ROOT_008, 0.2; B_i = 0.4, 0.5, 0.5, 0.4; x̄_i = 1.0, 1.95, −1.05, 0.4.
HAND_FIGURES = {
    "reversal_value": 0.5,                                    # B = max |B_i|
    "mean_reversal_value": 0.45,                              # B̄ = mean B_i
    "systematic_deviation_forward": 2.2 - -0.8,               # E↑ = max x̄↑_i − min x̄↑_i
    "systematic_deviation_reverse": 1.7 - -1.3,               # E↓
    "systematic_deviation": 2.2 - -1.3,                       # E = max(x̄↑_i, x̄↓_i) − min(x̄↑_i, x̄↓_i)
    "mean_bidirectional_deviation": 1.95 - -1.05,             # M = max x̄_i − min x̄_i
    "repeatability_forward": 4 * 0.2,                         # R↑ = max 4 s↑_i
    "repeatability_reverse": 4 * ROOT_008,                    # R↓
    "repeatability": 2 * 0.2 + 2 * ROOT_008 + 0.5,            # R = max_i max(2 s↑_i + 2 s↓_i + |B_i|, 4 s↑_i, 4 s↓_i)
    "accuracy_forward": (2.2 + 0.4) - (-0.8 - 0.4),           # A↑ = max(x̄↑_i + 2 s↑_i) − min(x̄↑_i − 2 s↑_i)
    "accuracy_reverse": (1.7 + 0.4) - (-1.3 - 2 * ROOT_008),  # A↓
    "accuracy": (2.2 + 0.4) - (-1.3 - 2 * ROOT_008),          # A over both directions
}
#: The labels encal profile prints for the figures.
HAND_LABELS = {"reversal_value": "reversal value B", "mean_reversal_value": "mean reversal value B\u0304",
               "systematic_deviation_forward": "systematic deviation E↑",
               "systematic_deviation_reverse": "systematic deviation E↓",
               "systematic_deviation": "systematic deviation E", "mean_bidirectional_deviation":
               "mean bidirectional deviation M", "repeatability_forward": "repeatability R↑",
               "repeatability_reverse": "repeatability R↓", "repeatability": "repeatability R",
               "accuracy_forward": "accuracy A↑", "accuracy_reverse": "accuracy A↓", "accuracy": "accuracy A"}


def iso_by_definition(up, down):
    """ISO 230-2:2014 clause 3, computed here from the deviations with plain Python (none of encal's helpers)."""
    from statistics import mean, stdev

    common = sorted(set(up) & set(down))
    m_up, m_down = [mean(up[t]) for t in common], [mean(down[t]) for t in common]
    s_up, s_down = [stdev(up[t]) for t in common], [stdev(down[t]) for t in common]
    b = [u - d for u, d in zip(m_up, m_down)]
    bidirectional = [(u + d) / 2 for u, d in zip(m_up, m_down)]
    return {
        "reversal_value": max(abs(v) for v in b), "mean_reversal_value": mean(b),
        "systematic_deviation_forward": max(m_up) - min(m_up),
        "systematic_deviation_reverse": max(m_down) - min(m_down),
        "systematic_deviation": max(m_up + m_down) - min(m_up + m_down),
        "mean_bidirectional_deviation": max(bidirectional) - min(bidirectional),
        "repeatability_forward": max(4 * s for s in s_up), "repeatability_reverse": max(4 * s for s in s_down),
        "repeatability": max(max(2 * su + 2 * sd + abs(bi), 4 * su, 4 * sd) for su, sd, bi in zip(s_up, s_down, b)),
        "accuracy_forward": max(x + 2 * s for x, s in zip(m_up, s_up)) - min(x - 2 * s for x, s in zip(m_up, s_up)),
        "accuracy_reverse": (max(x + 2 * s for x, s in zip(m_down, s_down))
                             - min(x - 2 * s for x, s in zip(m_down, s_down))),
        "accuracy": (max(x + 2 * s for x, s in zip(m_up + m_down, s_up + s_down))
                     - min(x - 2 * s for x, s in zip(m_up + m_down, s_up + s_down))),
    }


def hand_log(tmp_path, jitter_deg=0.0):
    """HAND_UP/HAND_DOWN as an ISO linear cycle: each pass ↑ over the targets ascending, then ↓ descending.
    ``jitter_deg`` moves the reference (and the encoder with it) by up to that much, a different amount each row."""
    lines = ["reference_deg,encoder_deg,direction"]
    for run in range(4):
        for table, sign, order in ((HAND_UP, "+1", sorted), (HAND_DOWN, "-1", lambda t: sorted(t, reverse=True))):
            for target in order(table):
                if run < len(table[target]):
                    shift = jitter_deg * ((len(lines) * 7) % 9 - 4) / 4
                    lines.append(f"{target + shift:.12f},{target + shift + table[target][run] / 60:.12f},{sign}")
    path = tmp_path / "hand.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_the_hand_figures_are_the_standards_formulas():
    by_definition = iso_by_definition(HAND_UP, HAND_DOWN)
    for key, value in HAND_FIGURES.items():
        assert by_definition[key] == pytest.approx(value, abs=1e-12), key


def printed_iso_rows(text):
    """The ISO 230-2 rows encal profile prints: label -> (arcmin, arcsec), as printed."""
    lines = text.split("\nISO 230-2, both directions of travel", 1)[1].splitlines()
    assert lines[1] == ("(deviation x = encoder − reference, the negative of a machine test's actual − target: B_i and "
                        "B̄ have the opposite sign, the other values the same)")
    assert lines[2].split() == ["value", "arcmin", "arcsec"]
    return {line[:32 + line.count("\u0304")].rstrip(): tuple(map(float, line[32 + line.count("\u0304"):].split()[:2]))
            for line in lines[3:] if line.strip()}


@pytest.mark.parametrize("jitter_deg, tolerance", [(0.0, None), (0.004, "0.01"), (0.0, "10")])
def test_every_iso_230_2_figure_printed_and_in_json_is_the_standards_on_a_hand_made_log(tmp_path, capsys, jitter_deg,
                                                                                         tolerance):
    path = hand_log(tmp_path, jitter_deg)
    option = [] if tolerance is None else ["--target-tolerance", tolerance]
    # unequal repeats per target are repeated approaches, kept with --keep-duplicates (refused without, naming it)
    assert main(["profile", str(path), "--allow-gaps", *option]) == 1
    assert "--keep-duplicates" in capsys.readouterr().err
    assert main(["profile", str(path), "--allow-gaps", "--keep-duplicates", "--json", *option]) == 0
    iso = json.loads(capsys.readouterr().out)["iso230_2"]
    for key, value in HAND_FIGURES.items():
        assert iso[f"{key}_arcmin"] == pytest.approx(value, abs=1e-9), key
    assert (iso["n_targets"], iso["n_unmatched"], iso["min_approaches"]) == (4, 1, 2)
    assert "; 1 point at reference angles approached one way only (targets match" in iso["caption"]
    assert iso["forward_travel"] == "increasing reference angle"  # ↑ is +1, ascending in the file as in ISO's ↑
    assert iso["deviation"] == "encoder - reference"  # B̄ > 0: the encoder reads more approached ↑ than ↓
    from statistics import mean, stdev

    for row in iso["targets"]:  # each target's x̄↑_i, x̄↓_i, s↑_i, s↓_i, B_i, x̄_i
        target = min(HAND_DOWN, key=lambda t: abs((row["target_deg"] - t + 180.0) % 360.0 - 180.0))
        up, down = HAND_UP[target], HAND_DOWN[target]
        assert abs((row["target_deg"] - target + 180.0) % 360.0 - 180.0) <= jitter_deg
        assert (row["n_forward"], row["n_reverse"]) == (len(up), len(down))
        expected = {"mean_forward_arcmin": mean(up), "mean_reverse_arcmin": mean(down), "std_forward_arcmin": stdev(up),
                    "std_reverse_arcmin": stdev(down), "reversal_arcmin": mean(up) - mean(down),
                    "mean_bidirectional_arcmin": (mean(up) + mean(down)) / 2}
        for key, value in expected.items():
            assert row[key] == pytest.approx(value, abs=1e-9), (target, key)
    assert sorted(round(row["target_deg"]) % 360 for row in iso["targets"]) == sorted(HAND_DOWN)
    assert main(["profile", str(path), "--allow-gaps", "--keep-duplicates", *option]) == 0
    printed = printed_iso_rows(capsys.readouterr().out)
    assert set(printed) == set(HAND_LABELS.values())
    for key, label in HAND_LABELS.items():
        arcmin, arcsec = printed[label]
        assert arcmin == pytest.approx(HAND_FIGURES[key], abs=0.0005), label  # printed to 0.001 arcmin
        assert arcsec == pytest.approx(60 * HAND_FIGURES[key], abs=0.005), label  # and to 0.01 arcsec


def test_a_target_tolerance_below_the_scatter_of_the_hand_made_log_is_refused_and_out_of_range_is_a_usage_error(
        tmp_path, capsys):
    path = hand_log(tmp_path, 0.004)
    assert main(["profile", str(path), "--allow-gaps", "--keep-duplicates", "--target-tolerance", "0.001"]) == 1
    assert ("span 0.003 deg as one target; expected the approaches to one target within the tolerance of each other "
            "(give a target tolerance above the scatter of one target's angles and below the spacing of the targets)"
            ) in capsys.readouterr().err
    for bad in ("0", "-0.01", "10.5", "nan"):
        with pytest.raises(SystemExit) as exit_:
            main(["profile", str(path), "--allow-gaps", "--keep-duplicates", "--target-tolerance", bad])
        assert exit_.value.code == 2
        assert "expected degrees greater than 0 and at most 10" in capsys.readouterr().err

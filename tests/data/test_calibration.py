import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.testing import assert_allclose, assert_array_equal

from tests.conftest import grid_csv
from encal import Calibration, CalibrationError, read_calibration, write_calibration
from encal._core.errors import EncalWarning


# ---------------------------------------------------------------- refused, in one sentence


def _refused(path, match, **kwargs):
    with pytest.raises(CalibrationError, match=match) as info:
        read_calibration(path, **kwargs)
    message = str(info.value)
    assert "\n" not in message
    assert str(path) in message
    return message


def test_missing_file(tmp_path):
    _refused(tmp_path / "nope.csv", "no such file")


def test_folder(tmp_path):
    _refused(tmp_path, "is a folder")


@pytest.mark.parametrize("text", ["", "\n\n", "# only a comment\n"])
def test_empty_file(write_csv, text):
    _refused(write_csv(text), "empty")


def test_no_header(write_csv):
    text = "\n".join(f"{r},{r}" for r in range(0, 360, 10))
    message = _refused(write_csv(text), "header lacks reference_deg and encoder_deg")
    assert "line 1" in message and "row of numbers" in message


def test_header_without_encoder_column(write_csv):
    message = _refused(write_csv("reference_deg,reading\n0,0\n"), "header lacks encoder_deg")
    assert "reference_deg, reading" in message


def test_semicolons_are_read_like_commas(write_csv):
    """A spreadsheet's semicolon-separated export (issue 25): the same calibration as the comma-separated file."""
    comma = read_calibration(write_csv(grid_csv(), name="comma.csv"))
    semicolons = read_calibration(write_csv(grid_csv().replace(",", ";"), name="semicolons.csv"))
    np.testing.assert_array_equal(semicolons.reference_deg, comma.reference_deg)
    np.testing.assert_array_equal(semicolons.encoder_deg, comma.encoder_deg)


@pytest.mark.parametrize("separator", ["\t", " ", "  \t "])
def test_a_header_without_commas_is_read_as_whitespace_separated(write_csv, separator):
    comma = read_calibration(write_csv(grid_csv(), name="comma.csv"))
    blanks = read_calibration(write_csv(grid_csv().replace(",", separator), name="blank.txt"))
    np.testing.assert_array_equal(blanks.reference_deg, comma.reference_deg)
    np.testing.assert_array_equal(blanks.encoder_deg, comma.encoder_deg)


def test_non_numeric_value_names_line_and_column(write_csv):
    lines = grid_csv().splitlines()
    lines[5] = "8.0,abc"
    message = _refused(write_csv("\n".join(lines)), "'abc'")
    assert "line 6, column 2" in message


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf", "NaN"])
def test_nan_and_infinity(write_csv, bad):
    lines = grid_csv().splitlines()
    lines[3] = f"{bad},4.0"
    message = _refused(write_csv("\n".join(lines)), "finite")
    assert "line 4, column 1" in message


def test_too_few_points(write_csv):
    text = "reference_deg,encoder_deg\n" + "".join(f"{r},{r}\n" for r in range(0, 360, 52))
    _refused(write_csv(text), "7 calibration points, expected at least 8")


def test_truncated_row(write_csv):
    text = grid_csv() + "358.5\n"
    _refused(write_csv(text), "truncated")


def test_binary_file(write_csv):
    _refused(write_csv(bytes(range(256)) * 4), "binary")


def test_gap_refused_and_allowed(write_csv):
    text = grid_csv(step=2.0)
    # two gaps (100-150 and 200-300 deg): scattered data, refused (issue 31 accepts one contiguous arc)
    lines = [line for line in text.splitlines() if line.startswith("reference")
             or not (100 <= float(line.split(",")[0]) < 150 or 200 <= float(line.split(",")[0]) < 300)]
    path = write_csv("\n".join(lines))
    message = _refused(path, "gap of")
    assert "--allow-gaps" in message
    cal = read_calibration(path, allow_gaps=True)
    assert len(cal) == len(lines) - 1
    # one gap: a calibration over one arc is read without options
    arc = [line for line in text.splitlines() if line.startswith("reference") or float(line.split(",")[0]) < 200]
    assert len(read_calibration(write_csv("\n".join(arc)))) == len(arc) - 1


def test_reversed_encoder_refused_and_accepted(write_csv):
    ref = np.arange(0.0, 360.0, 2.0)
    text = "reference_deg,encoder_deg\n" + "".join(f"{r},{(-r + 0.01) % 360}\n" for r in ref)
    path = write_csv(text)
    _refused(path, "counts against the reference.*--reverse")
    cal = read_calibration(path, reverse=True)
    assert_allclose(cal.errors_arcmin, -0.6, atol=1e-9)


def test_conflicting_duplicates_refused_or_averaged(write_csv):
    text = grid_csv() + "4.0,4.02\n"
    path = write_csv(text)
    _refused(path, "more than once with different readings")
    # The repeat reads 1.2 arcmin off the first, over 10 times the profile's typical step: averaged as asked,
    # and named as a likely misread.
    with pytest.warns(EncalWarning, match=r"line 182 \(encoder 4\.020 deg\) .* a misread\?"):
        cal = read_calibration(path, duplicates="average")
    assert len(cal) == 180
    i = int(np.flatnonzero(cal.reference_deg == 4.0)[0])
    assert_allclose(cal.encoder_deg[i], (4.0 + 0.01 * np.sin(np.radians(4.0)) + 4.02) / 2)


def _rows(reference, encoder, labels=None, header="reference_deg,encoder_deg"):
    """CSV text of the given rows (``labels``: an extra last column, named in ``header``)."""
    cells = zip(reference, encoder, labels if labels is not None else [None] * len(reference))
    return header + "\n" + "".join(f"{float(r)!r},{float(e)!r}" + (f",{x}" if x is not None else "") + "\n"
                                    for r, e, x in cells)


def _noisy(reference, seed=0):
    """Readings of the grid_csv profile with 0.1 arcmin of noise (degrees)."""
    noise = np.random.default_rng(seed).normal(0.0, 0.1 / 60.0, np.size(reference))
    return np.asarray(reference) + 0.01 * np.sin(np.radians(reference)) + noise


GRID = np.arange(0.0, 360.0, 2.0)


@pytest.mark.parametrize("reference", [np.repeat(GRID, 3), np.tile(GRID, 2),
                                       np.tile(np.random.default_rng(1).permutation(GRID), 3)],
                         ids=["three-in-a-row", "two-passes", "three-passes-in-a-shuffled-order"])
def test_the_same_number_of_readings_at_every_stop_is_read_as_repeated_readings(write_csv, reference):
    cal = read_calibration(write_csv(_rows(reference, _noisy(reference))))
    assert len(cal) == reference.size
    assert_array_equal(cal.reference_deg, reference)
    # --average-duplicates still averages them
    assert len(read_calibration(write_csv(_rows(reference, _noisy(reference))), duplicates="average")) == 180


@pytest.mark.parametrize("reference", [
    np.r_[GRID, 10.0],                          # a stray repeated row
    np.r_[np.repeat(GRID, 3), 10.0],            # four readings at one stop, three at the others
    np.r_[GRID, GRID[::-1]],                    # there and back: a second direction of travel
    np.r_[np.repeat(GRID[:90], 2), GRID[90:]],  # half the stops read twice
], ids=["stray", "one-count-differs", "there-and-back", "half-the-stops"])
def test_repeats_without_a_deliberate_pattern_are_refused(write_csv, reference):
    path = write_csv(_rows(reference, _noisy(reference)))
    message = _refused(path, "appears more than once with different readings")
    assert "or the same number at every angle" in message
    assert "use --keep-duplicates to keep them as repeated readings of one stop" in message
    assert len(read_calibration(path, duplicates="keep")) == reference.size


def test_repeats_are_judged_within_each_epoch(write_csv):
    reference = np.r_[np.repeat(GRID, 2), GRID]
    labels = ["a"] * 360 + ["b"] * 180
    text = _rows(reference, _noisy(reference), labels, header="reference_deg,encoder_deg,epoch")
    assert len(read_calibration(write_csv(text))) == 540
    # a stray repeat in epoch b is still refused
    reference = np.r_[reference, 10.0]
    text = _rows(reference, _noisy(reference), labels + ["b"], header="reference_deg,encoder_deg,epoch")
    _refused(write_csv(text), "reference angle 10 deg appears more than once")


def test_is_repeated_stops():
    from encal.data.calibration import is_repeated_stops

    assert is_repeated_stops(np.repeat(GRID, 2))
    assert is_repeated_stops(np.tile(GRID, 4) + 360.0)  # angles wrap
    assert not is_repeated_stops(GRID)  # nothing repeated
    assert not is_repeated_stops(np.r_[GRID, GRID[::-1]])
    runs = np.r_[np.zeros(360, int), np.ones(360, int)]
    assert is_repeated_stops(np.r_[np.tile(GRID, 2), np.repeat(GRID, 2)], runs)
    assert not is_repeated_stops(np.r_[np.tile(GRID, 2), np.repeat(GRID, 2)])  # one run: no pattern


def test_identical_duplicates_kept(write_csv):
    text = grid_csv()
    repeat = text.splitlines()[3]
    cal = read_calibration(write_csv(text + repeat + "\n"))
    assert len(cal) == 181


# ---------------------------------------------------------------- accepted


def test_odd_but_valid_file(write_csv):
    ref = np.arange(0.0, 360.0, 5.0)
    rows = [f"x{i},{r + 720.0 + 0.02},{r - 360.0}" for i, r in enumerate(ref)]
    text = "\ufeff# a comment\r\nNote,Encoder_DEG,REFERENCE_deg\r\n" + "\r\n".join(rows[:10]) \
        + "\r\n# another comment\r\n" + "\r\n".join(rows[10:]) + "\r\n"
    cal = read_calibration(write_csv(text))
    assert len(cal) == ref.size
    assert_allclose(cal.reference_deg, ref, atol=1e-9)
    assert_allclose(cal.errors_arcmin, 1.2, atol=1e-9)
    assert np.all((cal.encoder_deg >= 0) & (cal.encoder_deg < 360))
    assert cal.name == "cal"


def test_direction_and_epoch_columns(write_csv):
    ref = np.arange(0.0, 360.0, 10.0)
    rows = [f"{r},{r},cw,a" for r in ref] + [f"{r},{r + 0.01},CCW,a" for r in ref]
    cal = read_calibration(write_csv("reference_deg,encoder_deg,direction,epoch\n" + "\n".join(rows)))
    assert_array_equal(np.unique(cal.direction), [-1, 1])
    assert set(cal.epoch) == {"a"}


def test_bad_direction(write_csv):
    text = "reference_deg,encoder_deg,direction\n" + "".join(f"{r},{r},up\n" for r in range(0, 360, 10))
    message = _refused(write_csv(text), "direction is 'up'")
    assert "line 2, column 3" in message


@pytest.mark.parametrize("cell", ["\u00a0-1", "cw\u3000", "\u2003ccw"])
def test_a_direction_cell_with_a_blank_other_than_a_space_or_tab_is_refused(write_csv, cell):
    # fuzz6: str.strip() took any Unicode blank for one, where a number's cell allows ASCII spaces and tabs only
    rows = [f"{r},{r},{cell if r == 30 else ' +1'}\n" for r in range(0, 360, 10)]
    message = _refused(write_csv("reference_deg,encoder_deg,direction\n" + "".join(rows)), "direction is")
    assert "line 5, column 3" in message


def test_resolution_comment(write_csv):
    cal = read_calibration(write_csv("# resolution_bits: 14\n" + grid_csv()))
    assert cal.resolution_bits == 14


def test_reading_noise_comment_is_read_into_the_metadata(write_csv):
    # noise9: encal selfcal writes one reading's noise, measured from its log, as this comment
    cal = read_calibration(write_csv("# reading_noise_arcmin: 2.05\n" + grid_csv()))
    assert cal.metadata["reading_noise_arcmin"] == 2.05
    assert "reading_noise_arcmin" not in read_calibration(write_csv(grid_csv())).metadata


@pytest.mark.parametrize("comments, message", [
    ("# reading_noise_arcmin: -1\n", "line 1: reading_noise_arcmin is '-1', expected a number of arc-minutes >= 0"),
    ("# reading_noise_arcmin: nan\n", "line 1: reading_noise_arcmin is 'nan'"),
    ("# reading_noise_arcmin: 2\n# reading_noise_arcmin: 3\n", "line 2: reading_noise_arcmin is 3 but line 1 says 2"),
])
def test_a_bad_reading_noise_comment_is_refused_with_its_line(write_csv, comments, message):
    _refused(write_csv(comments + grid_csv()), message)


def test_large_zero_offset_near_180_stays_continuous():
    ref = np.arange(0.0, 360.0, 1.8)
    error_deg = 179.9 + 0.2 * np.sin(np.radians(ref))  # crosses the +-180 boundary
    cal = Calibration(ref, ref + error_deg)
    assert_allclose(cal.errors_arcmin / 60.0 % 360.0, error_deg % 360.0, atol=1e-9)
    assert np.ptp(cal.errors_arcmin) < 0.5 * 60


def test_real_file(real_data_dir):
    cal = read_calibration(real_data_dir / "mech_jcchurch_2016-11-22_9d73d2c6.csv")
    assert len(cal) == 200
    assert 10 < np.ptp(cal.errors_arcmin) < 200


# ---------------------------------------------------------------- round trip

angles = arrays(np.float64, st.integers(8, 60),
                elements=st.floats(-1e4, 1e4, allow_nan=False, allow_infinity=False))


@settings(max_examples=50, deadline=None)
@given(angles, st.floats(-5, 5), st.sampled_from([None, 12, 16]))
def test_write_read_round_trip(tmp_path_factory, reference, offset, bits):
    reference = np.sort(np.mod(reference, 360.0))
    cal = Calibration(reference, reference + offset / 60.0, name="rt", resolution_bits=bits)
    path = tmp_path_factory.mktemp("rt") / "rt.csv"
    write_calibration(path, cal, extra_columns={"note": ["n"] * len(cal)})
    with warnings.catch_warnings():  # a few angles within 0..2*pi look like radians: not what is tested here
        warnings.simplefilter("ignore", EncalWarning)
        back = read_calibration(path, allow_gaps=True, duplicates="average")
    unique = np.unique(np.round(cal.reference_deg, 9)).size
    if unique == len(cal):
        assert_array_equal(back.reference_deg, cal.reference_deg)
        assert_array_equal(back.encoder_deg, cal.encoder_deg)
    assert back.resolution_bits == bits


def test_write_is_atomic_when_folder_missing(tmp_path):
    cal = Calibration(np.arange(0, 360, 10.0), np.arange(0, 360, 10.0))
    with pytest.raises(Exception, match="does not exist"):
        write_calibration(tmp_path / "missing" / "x.csv", cal)
    assert not (tmp_path / "missing").exists()


def test_calibration_validation():
    with pytest.raises(CalibrationError, match="one reading per reference angle"):
        Calibration([0, 1], [0])
    with pytest.raises(CalibrationError, match="finite"):
        Calibration([0, np.nan], [0, 1])
    with pytest.raises(CalibrationError, match=r"\+1 or -1"):
        Calibration([0, 1], [0, 1], direction=[1, 0])


def test_a_column_named_twice_is_refused(write_csv):
    lines = grid_csv().splitlines()
    text = "reference_deg,encoder_deg,Encoder_deg\n" + "\n".join(f"{row},{float(row.split(',')[1]) + 1}"
                                                               for row in lines[1:]) + "\n"
    message = _refused(write_csv(text), "line 1: the header names encoder_deg 2 times")
    assert message.endswith("(columns 2, 3); expected each column once, so that it is clear which to read")


@pytest.mark.parametrize("cell", ["1" * 100_000, "x" * 100_000])
def test_a_huge_cell_is_shown_shortened(write_csv, cell):
    lines = grid_csv().splitlines()
    lines[5] = lines[5].split(",")[0] + "," + cell
    message = _refused(write_csv("\n".join(lines) + "\n"), "line 6, column 2: encoder_deg is '")
    assert len(message) < 300 and "...'" in message


def test_a_huge_header_is_shown_shortened(write_csv):
    path = write_csv("[" * 100_000 + "\n" + "1,2\n" * 10)
    message = _refused(path, "the header lacks")
    # The file's name is as long as the temporary folder makes it (longer under pytest-xdist): not counted.
    assert len(message) - len(str(path)) < 450


def test_quoted_fields_are_read_as_csv(write_csv):
    lines = grid_csv().splitlines()
    def quoted(row):
        return ",".join(f'"{cell}"' for cell in row.split(","))

    rows = [f'"run 1, table A",{row}' if i % 2 else f'"note",{quoted(row)}' for i, row in enumerate(lines[1:])]
    cal = read_calibration(write_csv("note,\"reference_deg\",encoder_deg\n" + "\n".join(rows) + "\n"))
    plain = read_calibration(write_csv(grid_csv(), name="plain.csv"))
    assert np.array_equal(cal.reference_deg, plain.reference_deg)
    assert np.array_equal(cal.encoder_deg, plain.encoder_deg)


def test_turn_checked_errors_are_the_calibrations_errors_and_refuse_a_wound_encoder():
    from encal.data.calibration import turn_checked_errors

    reference = np.arange(0.0, 360.0, 2.0)
    error_arcmin = 3.0 * np.sin(np.radians(reference)) + 1.5
    one_run = Calibration(reference, np.mod(reference + error_arcmin / 60.0, 360.0))
    two_runs = Calibration(np.r_[reference, reference], np.mod(np.r_[reference, reference] + 0.1, 360.0),
                           epoch=np.repeat([1, 2], reference.size))
    for cal in (one_run, two_runs):
        assert np.array_equal(turn_checked_errors(cal), cal.errors_arcmin)
    wound = Calibration(reference, np.mod(3.0 * reference, 360.0))  # the encoder turns three times a turn
    with pytest.raises(CalibrationError, match="turn"):
        turn_checked_errors(wound, where="wound.csv")


# -- a frozen calibration: what its checks found is kept ------------------------------------------------------------

def test_a_calibrations_arrays_are_read_only_and_its_errors_a_fresh_copy_each_time():
    reference = np.arange(36) * 10.0
    cal = Calibration(reference, reference + 0.05)
    for values in (cal.reference_deg, cal.encoder_deg):
        with pytest.raises(ValueError, match="read-only"):
            values[0] = 1.0
    errors = cal.errors_arcmin
    assert_allclose(errors, 3.0, rtol=0, atol=1e-9)
    errors[:] = 99.0  # the caller's copy: the calibration's own errors are as they were
    assert_allclose(cal.errors_arcmin, 3.0, rtol=0, atol=1e-9)
    assert reference.flags.writeable  # the caller's array is not the calibration's


def test_a_fit_does_not_check_again_what_reading_the_file_checked(write_csv, monkeypatch):
    import encal
    from encal.data import calibration as module

    reference = np.arange(90) * 4.0
    path = write_csv("reference_deg,encoder_deg\n" + "".join(
        f"{float(r)!r},{float(r + 0.1 * np.sin(np.radians(r)))!r}\n" for r in reference))
    from encal._core import arcs

    calls = {"folds": 0, "turns": 0, "errors": 0, "arc": 0}
    for owner, name, key in ((module, "_find_folds", "folds"), (module, "_check_turns", "turns"),
                             (module, "_errors_arcmin", "errors"), (arcs, "arc_of", "arc")):
        def counted(*args, _original=getattr(owner, name), _key=key, **kwargs):
            calls[_key] += 1
            return _original(*args, **kwargs)
        monkeypatch.setattr(owner, name, counted)
    cal = read_calibration(path)
    assert calls == {"folds": 1, "turns": 1, "errors": 1, "arc": 0}  # every 15-degree bin filled: no gap over 30
    model = encal.fit(cal, method="fourier")
    assert calls == {"folds": 1, "turns": 1, "errors": 1, "arc": 0}
    assert model.range_deg is None
    assert np.abs(model.predict(cal.encoder_deg) - cal.errors_arcmin).max() < 1e-3  # the profile, 6 arcmin
    fresh = Calibration(cal.reference_deg, cal.encoder_deg)  # not read from a file: checked by the fit
    encal.fit(fresh, method="fourier")
    assert calls == {"folds": 2, "turns": 2, "errors": 2, "arc": 1}


# strict6: a cell only Python reads as a number ('1_0' is 10, a full-width or Arabic-Indic digit its digit) is refused
# by the careful reader (the NumPy reader of plain bodies never reads such bytes), in every dialect
@pytest.mark.parametrize("text, where, why", [
    ("reference_deg,encoder_deg\n" + "".join(f"{r},{r + 0.01}\n" for r in range(0, 360, 30)).replace("\n60,", "\n6_0,"),
     "line 4, column 1",
     r"'6_0', expected a number of degrees; an underscore between digits is not read \(write '60'\)"),
    ("reference_deg;encoder_deg\n" + "".join(f"{r};{r},01\n" for r in range(0, 360, 30)).replace("\n30;30,01",
                                                                                               "\n30;3_0,01"),
     "line 3, column 2", "underscore"),
    ('reference_deg,encoder_deg\n"0",0.01\n' + "".join(f"{r},{r + 0.01}\n" for r in range(30, 360, 30)).replace(
        "\n90,", "\n\uff19\uff10,"), "line 5, column 1", r"U\+FF19 FULLWIDTH DIGIT NINE \(write '90'\)"),
    ("# an encoder\nreference_deg,encoder_deg\n" + "".join(f"{r},{r + 0.01}\n" for r in range(0, 360, 30)).replace(
        "\n120,", "\n\u0661\u0662\u0660,"), "line 7, column 1", "U\\+0661 ARABIC-INDIC DIGIT ONE"),
])
def test_a_number_only_python_reads_is_refused_in_every_dialect(tmp_path, text, where, why):
    path = tmp_path / "cal.csv"
    path.write_text(text, encoding="utf-8")
    _refused(path, f"{where}: .*{why}")


@pytest.mark.parametrize("header, method", [("time_s,encoder_deg,run", "spin"), ("electrical_deg,encoder_deg", "sweep"),
                                            ("time_s,motor_deg,output_deg", "dual")])
def test_a_log_without_a_reference_is_pointed_to_the_selfcal_that_reads_it(write_csv, header, method):
    """users7: a motor user's spin log read by encal profile or fit was told to name its reference column, which a
    spin has none of; the command that makes it a calibration was not named."""
    path = write_csv(header + "\n" + "".join(f"{0.01 * i},{i},{i % 3}\n" for i in range(20)))
    assert f"encal selfcal {method} " in _refused(path, "the header lacks")


def test_a_log_with_a_reference_under_another_name_is_not_pointed_to_selfcal(write_csv):
    path = write_csv("time_s,commanded_rev,measured_rev\n" + "".join(f"{0.01 * i},{i},{i}\n" for i in range(20)))
    assert "selfcal" not in _refused(path, "the header lacks")


# -- the reference's own uncertainty (a sigma_arcmin column) ---------------------------------------------------------

def _with_sigma(sigma_cells, direction=False):
    ref = np.arange(0.0, 360.0, 30.0)
    header = "reference_deg,encoder_deg,sigma_arcmin" + (",direction" if direction else "")
    rows = [f"{float(r)!r},{float(r) + 0.01!r},{s}" + (",+1" if direction else "") for r, s in zip(ref, sigma_cells)]
    return "\n".join([header] + rows) + "\n"


@pytest.mark.parametrize("careful", [False, True], ids=["plain reader", "line by line"])
def test_a_sigma_arcmin_column_is_the_references_standard_uncertainty(write_csv, careful):
    sigma = [0.1 * k for k in range(12)]
    cal = read_calibration(write_csv(_with_sigma(sigma, direction=careful)))
    np.testing.assert_array_equal(cal.reference_std_arcmin, sigma)
    assert not cal.reference_std_arcmin.flags.writeable
    np.testing.assert_array_equal(cal.subset([1, 3]).reference_std_arcmin, [0.1, 0.30000000000000004])
    assert read_calibration(write_csv(grid_csv(), name="plain.csv")).reference_std_arcmin is None


@pytest.mark.parametrize("cell, why", [("-0.1", "'-0.1'"), ("abc", "'abc'"), ("nan", "'nan'"), ("inf", "'inf'")])
@pytest.mark.parametrize("careful", [False, True], ids=["plain reader", "line by line"])
def test_a_bad_sigma_cell_is_named_by_line_and_column(write_csv, cell, why, careful):
    sigma = ["0.2"] * 12
    sigma[4] = cell
    with pytest.raises(CalibrationError, match=rf"cal\.csv, line 6, column 3: sigma_arcmin is {why}, expected the "
                                               r"reference's "
                                               r"standard uncertainty, a finite number of arc-minutes >= 0"):
        read_calibration(write_csv(_with_sigma(sigma, direction=careful)))


def test_the_column_is_written_back_and_not_twice(tmp_path):
    ref = np.arange(0.0, 360.0, 30.0)
    cal = Calibration(ref, ref, reference_std_arcmin=np.full(12, 0.25))
    write_calibration(tmp_path / "c.csv", cal, extra_columns={"error_arcmin": np.zeros(12)})
    assert (tmp_path / "c.csv").read_text().splitlines()[0] == "reference_deg,encoder_deg,error_arcmin,sigma_arcmin"
    np.testing.assert_array_equal(read_calibration(tmp_path / "c.csv").reference_std_arcmin, np.full(12, 0.25))
    with pytest.raises(CalibrationError, match="extra column 'sigma_arcmin' is the calibration's "
                                               "reference_std_arcmin"):
        write_calibration(tmp_path / "d.csv", cal, extra_columns={"sigma_arcmin": np.zeros(12)})
    assert not (tmp_path / "d.csv").exists()


@pytest.mark.parametrize("std, message", [
    (np.full(3, 0.1), "must hold one standard uncertainty"),
    (np.r_[np.full(11, 0.1), -0.1], r"point 12 has -0\.1"),
    (np.r_[np.nan, np.full(11, 0.1)], "point 1 has nan"),
])
def test_a_calibrations_reference_std_is_checked(std, message):
    with pytest.raises(CalibrationError, match=message):
        Calibration(np.arange(12.0) * 30, np.arange(12.0) * 30, reference_std_arcmin=std)


def test_averaged_repeats_keep_the_largest_reference_std(write_csv):
    text = "reference_deg,encoder_deg,sigma_arcmin\n" + "".join(
        f"{float(r)!r},{float(r) + 0.01 * (k + 1)!r},{0.1 * (k + 1)}\n" for k in range(2)
        for r in np.arange(0.0, 360.0, 30.0))
    text = text.replace("0.0,0.02,0.2\n", "0.0,0.02,0.2\n30.0,30.03,0.7\n")  # a third reading at 30 deg
    cal = read_calibration(write_csv(text), duplicates="average")
    assert len(cal) == 12
    np.testing.assert_allclose(cal.reference_std_arcmin, np.r_[0.2, 0.7, np.full(10, 0.2)])


@pytest.mark.parametrize("angle_mark, sigma_cell, refused", [
    (".", "1,080", "'1,080' has a comma"),  # read as 1.08 arcmin beside angles written with a point (fuzz7)
    (",", "0.5", "line 2 writes '0.5' with a decimal point"),
    (",", "0,5", None),
])
def test_a_sigma_cell_with_the_other_decimal_mark_is_refused(write_csv, angle_mark, sigma_cell, refused):
    """A semicolon file's sigma_arcmin cells count in its one decimal mark, as its angles do: '1,080' beside
    angles with a decimal point may group digits (1080 arcmin), and was read as 1.08 arcmin with exit 0."""
    rows = [f"{r:.1f};{r + 0.01:.2f}".replace(".", angle_mark) + f";{sigma_cell}" for r in np.arange(0.0, 360.0, 30.0)]
    path = write_csv("reference_deg;encoder_deg;sigma_arcmin\n" + "\n".join(rows) + "\n")
    if refused is None:
        np.testing.assert_array_equal(read_calibration(path).reference_std_arcmin, np.full(12, 0.5))
    else:
        with pytest.raises(CalibrationError, match=rf"line 2, column \d: .*{refused}"):
            read_calibration(path)


def test_passes_in_random_order_are_refused_saying_the_order_the_pattern_needs(write_csv):
    """Two passes shuffled together have the same number of readings at every stop, which the message asked for,
    and were still refused (truth8): it now says that the readings must come in a row or in passes."""
    reference = np.tile(GRID, 2)[np.random.default_rng(2).permutation(2 * GRID.size)]
    path = write_csv(_rows(reference, _noisy(reference)))
    message = _refused(path, "appears more than once with different readings")
    assert ("or the same number at every angle, each stop's readings in a row or the stops in the same order in every "
            "pass") in message
    assert "use --keep-duplicates" in message
    assert len(read_calibration(path, duplicates="keep")) == reference.size


@pytest.mark.parametrize("forward, reverse", [("1.0", "-1.0"), ("+1.", "-1e0"),
                                              ("1.000000000000000000e+00", "-1.000000000000000000e+00")])
def test_a_direction_written_as_a_float_of_one_is_read(tmp_path, forward, reverse):
    # NumPy's savetxt writes a float column so; it was refused ("direction is '1.0', expected +1, -1, cw or ccw")
    angles = np.repeat(np.arange(12) * 30.0, 2)
    rows = "\n".join(f"{a},{a + 0.01},{forward if i % 2 == 0 else reverse}" for i, a in enumerate(angles))
    path = tmp_path / "run.csv"
    path.write_text("reference_deg,encoder_deg,direction\n" + rows + "\n")
    assert list(read_calibration(path).direction) == [1, -1] * 12


@pytest.mark.parametrize("cell", ["0.5", "2", "1.5e0", "0", "nan"])
def test_a_direction_number_other_than_one_is_refused(tmp_path, cell):
    path = tmp_path / "run.csv"
    rows = "\n".join(f"{a},{a + 0.01},-1" for a in np.arange(1, 12) * 30.0)
    path.write_text(f"reference_deg,encoder_deg,direction\n0,0.01,{cell}\n{rows}\n")
    with pytest.raises(CalibrationError, match=r"line 2, column 3: direction is .*expected \+1, -1, cw or ccw"):
        read_calibration(path)


@pytest.mark.parametrize("direction", [np.full(4, 1.7), np.full(4, -1.5), ["cw"] * 4, np.ones(4, bool)])
def test_a_direction_that_is_not_plus_or_minus_one_is_refused_before_any_cast(direction):
    """1.7 was cast to int8 and taken as +1, and 'cw' raised NumPy's ValueError (task pyapi)."""
    with pytest.raises(CalibrationError, match="direction must hold"):
        Calibration([0.0, 90.0, 180.0, 270.0], [0.0, 90.0, 180.0, 270.0], direction=direction)


def test_arrays_of_shapes_that_pair_other_readings_are_refused():
    """A (2, n) reference and an (n, 2) encoder were flattened and paired other readings (task pyapi); one shape for
    both, or an (n, 1) column against (n,), is read."""
    angles = np.arange(0.0, 360.0, 30.0)
    with pytest.raises(CalibrationError, match=r"shape \(2, 6\) but encoder_deg \(6, 2\)"):
        Calibration(angles.reshape(2, 6), angles.reshape(6, 2))
    assert_array_equal(Calibration(angles.reshape(-1, 1), angles).encoder_deg, angles)
    assert_array_equal(Calibration(angles.reshape(2, 6), angles.reshape(2, 6)).reference_deg, angles)


@pytest.mark.parametrize("index", [[12], np.ones(3, bool), "all"])
def test_a_subset_index_numpy_cannot_take_is_one_sentence(index):
    cal = Calibration(np.arange(0.0, 360.0, 30.0), np.arange(0.0, 360.0, 30.0))
    with pytest.raises(CalibrationError, match="Calibration.subset expects a mask of 12 booleans"):
        cal.subset(index)

"""One CSV dialect for every reader and writer of encal (``encal._core.csv_dialect``).

The calibration reader and the ``encal correct`` stream agree on: quoted fields holding commas (a
quoted header name must not shift the columns), the field count of every row (a decimal comma in
one cell must not read as a smaller number), line ends (only LF, CRLF or CR end a line; a form feed
or U+2028 inside a comment does not, so later line numbers stay right).
"""

import io

import numpy as np
import pytest

import encal
from encal._core import csv_dialect as _csv
from encal.data.calibration import read_calibration, write_calibration
from encal.deploy import Compensator
from encal.deploy.stream import correct_stream
from encal._core.errors import CalibrationError, InputError
from encal.models.fourier import FourierModel

# A constant +30 arcmin: a corrected angle is the reading minus 0.5 degree.
COMPENSATOR = Compensator(FourierModel([0], [30.0], [0.0]))


def correct_text(text, **options):
    sink = io.BytesIO()
    correct_stream(COMPENSATOR, io.BytesIO(text.encode("utf-8")), sink, **options)
    return [float(line) for line in sink.getvalue().decode().splitlines()]


def calibration_text(header, rows):
    return header + "\n" + "".join(row + "\n" for row in rows)


def grid_rows(template):
    return [template.format(ref=float(r), enc=float(r) + 0.01) for r in np.arange(0.0, 360.0, 10.0)]


# ------------------------------------------------------------------ the dialect itself

@pytest.mark.parametrize("line, expected", [
    ("a,b", ["a", "b"]),
    ('"time, s",encoder_deg,temp_C', ["time, s", "encoder_deg", "temp_C"]),
    ('a,"say ""hi"""', ["a", 'say "hi"']),
    (' "x,y" , z', ["x,y", " z"]),
    ('ab"c,d', ['ab"c', "d"]),
    ('"",', ["", ""]),
])
def test_fields(line, expected):
    assert _csv.fields(line) == expected


@pytest.mark.parametrize("line, message", [
    ('"abc,d', "not closed"),
    ('"a"b,c', "text follows the closing quote"),
])
def test_unbalanced_quotes(line, message):
    with pytest.raises(_csv.QuotingError, match=message):
        _csv.fields(line)


def test_only_line_ends_split_lines():
    text = "a\r\nb\rc\n# x\x0cy\u2028z\x85w\x1ev\nlast"
    assert _csv.split_lines(text) == ["a", "b", "c", "# x\x0cy\u2028z\x85w\x1ev", "last"]


@pytest.mark.parametrize("values", [["a,b", "c"], ['x"y', " s"], ["plain", "1.5"], ["", "tail "]])
def test_join_round_trips(values):
    assert _csv.fields(_csv.join(values)) == values


# ------------------------------------------------------------------ item 2: quoted header in `correct`

def test_correct_reads_a_quoted_header_name_holding_a_comma():
    text = '"time, s",encoder_deg,temp_C\n0.5,10.0,25.0\n1.0,20.0,26.0\n'
    assert correct_text(text) == [9.5, 19.5]


def test_correct_reads_quoted_cells():
    text = 'note,encoder_deg\n"a, b",10.0\n"c",20.0\n'
    assert correct_text(text) == [9.5, 19.5]


def test_calibration_reader_and_stream_find_the_same_column(write_csv):
    header = '"time, s",reference_deg,encoder_deg,"temp, C"'
    path = write_csv(calibration_text(header, grid_rows('"1,5",{ref!r},{enc!r},"20,0"')))
    cal = read_calibration(path)
    np.testing.assert_allclose(cal.encoder_deg, np.arange(0.0, 360.0, 10.0) + 0.01)
    stream = correct_text(path.read_text())
    np.testing.assert_allclose(stream, encal._core.angles.wrap360(cal.encoder_deg - 0.5))


# ------------------------------------------------------------------ item 4: field count

def test_a_decimal_comma_in_one_cell_is_refused_by_the_reader(write_csv):
    rows = grid_rows("{ref!r},{enc!r}")
    rows[9] = "98.0,98,031005859375"  # 98.031005859375 written with a decimal comma
    path = write_csv(calibration_text("reference_deg,encoder_deg", rows))
    with pytest.raises(CalibrationError, match=r"line 11: has 3 fields, expected 2 as in the header \(a decimal"):
        read_calibration(path)


def test_a_decimal_comma_in_one_cell_is_refused_by_the_stream():
    text = "reference_deg,encoder_deg\n1.0,10.0\n98.0,98,031005859375\n"
    with pytest.raises(InputError, match="line 3 of stdin.*3 fields, not 2 as in the header"):
        correct_text(text)
    assert np.isnan(correct_text(text, skip_bad=True)[1])


def test_a_decimal_comma_without_header_is_refused_by_the_stream():
    with pytest.raises(InputError, match="line 2 of stdin"):
        correct_text("10.0\n98,031005859375\n")


def test_extra_columns_named_in_the_header_are_accepted(write_csv):
    rows = grid_rows("{ref!r},{enc!r},98,031")
    path = write_csv(calibration_text("reference_deg,encoder_deg,whole,fraction", rows))
    assert len(read_calibration(path)) == 36
    assert correct_text(path.read_text())[:2] == [359.51, 9.51]


def test_a_trailing_comma_is_an_extra_field(write_csv):
    rows = grid_rows("{ref!r},{enc!r},")
    path = write_csv(calibration_text("reference_deg,encoder_deg", rows))
    with pytest.raises(CalibrationError, match="line 2: has 3 fields, expected 2"):
        read_calibration(path)


def test_fewer_fields_still_say_truncated(write_csv):
    rows = grid_rows("{ref!r},{enc!r}")
    rows[-1] = "350.0"
    path = write_csv(calibration_text("reference_deg,encoder_deg", rows))
    with pytest.raises(CalibrationError, match="line 37: has 1 field, expected 2.*truncated"):
        read_calibration(path)


def test_unbalanced_quotes_are_refused_with_the_line(write_csv):
    rows = grid_rows("{ref!r},{enc!r}")
    rows[2] = '"20.0,20.01'
    path = write_csv(calibration_text("reference_deg,encoder_deg", rows))
    with pytest.raises(CalibrationError, match="line 4: the quoted field starting at character 1 is not closed"):
        read_calibration(path)


# ------------------------------------------------------------------ item 14: line ends only

@pytest.mark.parametrize("separator", ["\x0c", "\u2028", "\x85", "\x0b", "\x1c"])
def test_a_comment_holding_a_line_separator_keeps_line_numbers(write_csv, separator):
    rows = grid_rows("{ref!r},{enc!r}")
    rows[4] = "40.0,oops"
    path = write_csv(f"# run{separator}2\n" + calibration_text("reference_deg,encoder_deg", rows))
    with pytest.raises(CalibrationError, match=r"line 7, column 2: encoder_deg is 'oops'"):
        read_calibration(path)
    with pytest.raises(InputError, match="line 7 of stdin"):
        correct_text(path.read_text(encoding="utf-8"))


def test_cr_alone_ends_a_line_in_files_and_streams(write_csv):
    rows = grid_rows("{ref!r},{enc!r}")
    text = "\r".join(["reference_deg,encoder_deg", *rows]) + "\r"
    assert len(read_calibration(write_csv(text))) == 36
    assert len(correct_text(text)) == 36


# ------------------------------------------------------------------ item 13: a non-ASCII digit

@pytest.mark.parametrize("value", ["²", "١٦", "16.0"])
def test_resolution_comment_with_other_digits_is_refused_in_one_sentence(write_csv, value):
    path = write_csv(f"# resolution_bits: {value}\n" + calibration_text("reference_deg,encoder_deg",
                                                                          grid_rows("{ref!r},{enc!r}")))
    with pytest.raises(CalibrationError, match="line 1: resolution_bits is"):
        read_calibration(path)


# ------------------------------------------------------------------ the writer

def test_written_epoch_labels_holding_commas_read_back(tmp_path):
    ref = np.arange(0.0, 360.0, 10.0)
    cal = encal.Calibration(ref, ref + 0.01, epoch=["run 1, morning"] * ref.size)
    path = tmp_path / "cal.csv"
    write_calibration(path, cal, extra_columns={'note "x"': ["a,b"] * ref.size})
    back = read_calibration(path)
    assert set(back.epoch) == {"run 1, morning"}
    np.testing.assert_array_equal(back.encoder_deg, cal.encoder_deg)


# ------------------------------------------------------------------ the self-calibration logs read the same dialect

def test_selfcal_logs_read_quoted_names_and_refuse_a_decimal_comma(tmp_path):
    from encal.selfcal._logfile import read_columns

    path = tmp_path / "spin.csv"
    path.write_text('"note, free",time_s,encoder_deg\n"a, b",0.0,10.5\n"c",0.001,11.0\n')
    columns = read_columns(path, (("time_s", "seconds"), ("encoder_deg", "degrees")))
    assert columns["encoder_deg"].tolist() == [10.5, 11.0]
    path.write_text("time_s,encoder_deg\n0.0,10.5\n0.001,11,0\n")
    with pytest.raises(InputError, match="line 3: has 3 fields, expected 2"):
        read_columns(path, (("time_s", "seconds"), ("encoder_deg", "degrees")))

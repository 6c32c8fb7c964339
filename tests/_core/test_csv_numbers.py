"""A plain body read in NumPy: the same numbers as the careful reader, or None and the careful reader's message."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import encal
from encal._core.csv_numbers import CHUNK_BYTES, plain_rows
from encal._core.errors import CalibrationError, EncalWarning


def sweep_text(rows=20_000, seed=0, newline="\n"):
    """A dense sweep over 4 revolutions as CSV text, angles written by ``repr``."""
    rng = np.random.default_rng(seed)
    reference = np.tile(np.arange(rows // 4) * 360.0 / (rows // 4), 4)
    encoder = np.mod(reference + (2.0 * np.sin(np.radians(reference)) + rng.normal(0, 0.1, rows)) / 60.0, 360.0)
    lines = ["reference_deg,encoder_deg"] + [f"{r!r},{e!r}" for r, e in zip(reference.tolist(), encoder.tolist())]
    return newline.join(lines) + newline


def read_quietly(path, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("error", EncalWarning)
        return encal.read_calibration(path, **options)


def test_the_numbers_are_the_careful_readers_bit_for_bit(tmp_path):
    text = sweep_text()
    plain = tmp_path / "plain.csv"
    plain.write_text(text)
    careful = tmp_path / "careful.csv"  # a comment in the body: read line by line
    lines = text.splitlines(keepends=True)
    careful.write_text("".join(lines[:5000] + ["# a comment\n"] + lines[5000:]))
    a, b = read_quietly(plain), read_quietly(careful)
    assert len(a) == 20_000
    assert a.reference_deg.tobytes() == b.reference_deg.tobytes()
    assert a.encoder_deg.tobytes() == b.encoder_deg.tobytes()


def test_reprs_read_as_float_reads_them():
    rng = np.random.default_rng(3)
    values = np.concatenate([rng.uniform(-1e9, 1e9, 500), rng.normal(0, 1e-7, 500), rng.uniform(0, 360, 500)])
    body = "".join(f"{a!r},{b:.17e}, {c:.3f}\n" for a, b, c in values.reshape(-1, 3).tolist()).encode()
    table = plain_rows(body, ",", 3)
    expected = [[float(cell) for cell in line.split(",")] for line in body.decode().splitlines()]
    assert table.tobytes() == np.array(expected).tobytes()


@pytest.mark.parametrize("body", [
    b"1,2\n\n3,4\n",  # a blank line: the careful reader skips it and counts it
    b"1,2\n \n3,4\n",
    b"1,2\r3,4\n",  # a CR alone ends a line
    b"1,2\n3,4,5\n",  # a field over
    b"1,2\n3\n",  # a field short
    b"1,,2\n",
    b"1,nan\n",
    b'1,"2"\n',
    b"1,2 # note\n",
    b"1_0,2\n",  # float() reads it, NumPy does not: the careful reader decides
    b"1-2,3\n",
])
def test_anything_but_plain_rows_is_left_to_the_careful_reader(body):
    assert plain_rows(body, ",", 2) is None


def test_whitespace_and_crlf_and_progress():
    done = []
    body = b"1 \t 2\r\n-3.5e2  +4.\r\n" * (CHUNK_BYTES // 10)
    table = plain_rows(body, None, 2, progress=lambda n, total: done.append((n, total)))
    assert table.shape == (2 * (CHUNK_BYTES // 10), 2)
    assert table[:2].tolist() == [[1.0, 2.0], [-350.0, 4.0]]
    assert len(done) >= 2 and done[-1] == (len(body), len(body))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.lists(st.text(alphabet="0123456789.eE+- \t", max_size=6), min_size=2, max_size=2),
                min_size=1, max_size=4))
def test_what_numpy_reads_is_what_float_reads(rows):
    body = "".join(",".join(row) + "\n" for row in rows).encode()
    table = plain_rows(body, ",", 2)
    if table is None:
        return
    assert table.tolist() == [[float(cell) for cell in row] for row in rows]


@pytest.mark.parametrize("row, message", [
    ("12.5,abc", "line 15002, column 2: encoder_deg is 'abc', expected a number of degrees"),
    ("12.5,inf", "line 15002, column 2: encoder_deg is 'inf', expected a finite number of degrees"),
    ("12.5,1e10", "line 15002, column 2: encoder_deg is '1e10', expected an angle within +-1e+09 degrees"),
    ("12.5,12.6,3", "line 15002: has 3 fields, expected 2 as in the header (a decimal comma"),
    ("12.5", "line 15002: has 1 field, expected 2 as in the header (is the file truncated?)"),
])
def test_a_bad_row_deep_in_a_dense_file_is_named_as_before(tmp_path, row, message):
    lines = sweep_text().splitlines()
    lines[15001] = row
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(CalibrationError) as info:
        encal.read_calibration(path)
    assert str(info.value).startswith(f"{path}, {message}")


def test_a_misread_in_a_plain_file_is_named_by_its_line(tmp_path):
    text = sweep_text(newline="\r\n")
    lines = text.splitlines()
    reference, encoder = (float(cell) for cell in lines[7001].split(","))
    lines[7001] = f"{reference!r},{encoder + 0.3!r}"  # 18 arcmin off: line 7002
    path = tmp_path / "misread.csv"
    path.write_text("# resolution_bits: 24\r\n" + "\r\n".join(lines) + "\r\n")
    with pytest.warns(EncalWarning, match=r"line 7003 \(encoder "):
        cal = encal.read_calibration(path)
    assert cal.resolution_bits == 24


def test_a_file_without_a_header_is_read_from_its_first_row(tmp_path):
    path = tmp_path / "numbers.csv"
    path.write_text("".join(sweep_text().splitlines(keepends=True)[1:]))
    cal = read_quietly(path, reference_column=1, encoder_column=2)
    assert len(cal) == 20_000 and cal.reference_deg[0] == 0.0


def test_a_plain_file_is_not_parsed_line_by_line(tmp_path, monkeypatch):
    """The careful reader took 3.9 s of a 6 s fit of 10^6 rows; a plain file is read in NumPy (BENCHMARKS.md)."""
    import encal.data.calibration

    def no_cell_by_cell(*args):
        raise AssertionError("parsed cell by cell")

    monkeypatch.setattr(encal.data.calibration, "_parse_float", no_cell_by_cell)
    path = tmp_path / "plain.csv"
    path.write_text("# resolution_bits: 24\n\n" + sweep_text())
    assert len(read_quietly(path)) == 20_000


# -- issue 30 (dense30): lines counted a piece at a time -----------------------------------------------------------

@pytest.mark.parametrize("text", [b"", b"a", b"a\n", b"1,2\n3,4", b"\n\n\n", b"x" * 70_000 + b"\n" * 3 + b"y"])
@pytest.mark.parametrize("start", [0, 1, 2])
@pytest.mark.parametrize("piece", [1, 3, 1 << 18])
def test_line_count_is_the_lf_count_and_a_last_line(text, start, piece, monkeypatch):
    from encal._core import csv_numbers

    monkeypatch.setattr(csv_numbers, "_COUNT_PIECE", piece)
    start = min(start, len(text))
    expected = text.count(b"\n", start) + (len(text) > start and not text.endswith(b"\n"))
    assert csv_numbers.line_count(text, start) == expected


def test_line_count_of_a_large_file_allocates_no_array_as_large():
    import tracemalloc

    from encal._core.csv_numbers import line_count

    text = b"123.4567890123,234.5678901234\n" * 1_000_000  # 30 MB, as a 10^6-row calibration
    tracemalloc.start()
    try:
        assert line_count(text) == 1_000_000
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2**20  # a 30 MB boolean array before

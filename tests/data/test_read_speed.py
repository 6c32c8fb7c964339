"""Dense files at NumPy speed (issue 30 item 2, task read-speed): a plain file parsed by NumPy from its path,
the checks sharing their sorts and passes. Every shortcut is checked against the computation it replaces."""

import os
import time
import warnings

import numpy as np
import pytest

import encal._core.csv_numbers as csv_numbers
import encal.analysis.outliers as outliers
import encal.data.calibration as calibration
from encal._core.angles import wrap180
from encal._core.errors import EncalWarning
from encal._core.sorting import stable_argsort
from encal.data.calibration import read_calibration


def _sweep_text(stops=2000, passes=3, misread_row=None, seed=0):
    rng = np.random.default_rng(seed)
    reference = np.tile(np.arange(stops) * 360.0 / stops, passes)
    encoder = np.mod(reference + (3.0 * np.sin(np.radians(reference)) + rng.normal(0.0, 0.1, reference.size)) / 60.0,
                     360.0)
    if misread_row is not None:
        encoder[misread_row] += 0.5  # 30 arcmin: a misread among readings 0.1 arcmin apart
    return "reference_deg,encoder_deg\n" + "".join(f"{r:.10f},{e:.10f}\n" for r, e in zip(reference, encoder))


def _old_wrap180(angle):
    return (-np.mod(-np.asarray(angle, dtype=float) + 180.0, 360.0) + 180.0)[()]


def test_wrap180_without_fmod_is_the_same_bit_for_bit():
    rng = np.random.default_rng(0)
    edges = np.array([180.0, -180.0, 540.0, -540.0, 0.0, -0.0, 360.0, -360.0, 1e-17, -1e-17, 5e-324, -5e-324,
                      180.0 + 2e-14, 180.0 - 2e-14, -180.0 + 2e-14, -180.0 - 2e-14, 720.0, -720.0])
    edges = np.r_[edges, np.nextafter(edges, np.inf), np.nextafter(edges, -np.inf)]
    for values in (np.r_[rng.uniform(-540.0, 540.0, 10_000), edges], np.r_[rng.uniform(-1e-12, 1e-12, 100), edges],
                   rng.uniform(-180.0, 180.0, 100), rng.uniform(-1e4, 1e4, 100)):
        np.testing.assert_array_equal(wrap180(values).view(np.int64), _old_wrap180(values).view(np.int64))


def _settled(monkeypatch):
    """Read every file as if written a second ago (a file changed less than 0.1 s before is read from its bytes)."""
    monkeypatch.setattr(calibration, "_clock_ns", lambda: time.time_ns() + 1_000_000_000)


def test_a_plain_regular_file_is_parsed_by_numpy_from_its_path(tmp_path, monkeypatch):
    path = tmp_path / "sweep.csv"
    path.write_text("# resolution_bits: 20\n\n" + _sweep_text())
    _settled(monkeypatch)
    read_from = []
    real_loadtxt = np.loadtxt
    monkeypatch.setattr(csv_numbers.np, "loadtxt", lambda source, *a, **k: read_from.append(source)
                        or real_loadtxt(source, *a, **k))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cal = read_calibration(path)
    assert read_from == [str(path)]  # one call, with the path (not bytes in memory, read line by line)
    assert len(cal) == 6000 and cal.resolution_bits == 20
    table = real_loadtxt(path, delimiter=",", skiprows=3)
    np.testing.assert_array_equal(cal.reference_deg, table[:, 0])
    np.testing.assert_array_equal(cal.encoder_deg, table[:, 1])


def test_a_file_changed_between_the_two_reads_is_read_as_first_read(tmp_path, monkeypatch):
    path = tmp_path / "sweep.csv"
    text = _sweep_text()
    path.write_text(text)
    real = csv_numbers.plain_file_rows

    def changing(*args, **kwargs):  # another program rewrites the file, as long, between the two reads
        path.write_text(text.replace("0.0000000000,", "9.0000000000,", 1))
        return real(*args, **kwargs)

    monkeypatch.setattr(calibration, "plain_file_rows", changing)
    cal = read_calibration(path)
    assert cal.reference_deg[0] == 0.0  # the bytes checked, not the ones written since


def test_a_blank_line_in_a_plain_body_keeps_the_line_numbers(tmp_path):
    lines = _sweep_text(misread_row=4100).splitlines()
    lines.insert(3000, "")
    path = tmp_path / "blank.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.warns(EncalWarning, match="line 4103 "):  # the header, the blank line, then row 4100 (from 0)
        read_calibration(path)


def test_a_misread_in_a_dense_sweep_is_found_without_sorting_the_encoder_angles(tmp_path, monkeypatch):
    path = tmp_path / "sweep.csv"
    path.write_text(_sweep_text(misread_row=2500))
    sorted_angles = []
    real = outliers.stable_argsort
    monkeypatch.setattr(outliers, "stable_argsort", lambda values, **k: sorted_angles.append(1) or real(values, **k))
    with pytest.warns(EncalWarning, match=r"line 2502 .* off the median of the readings at its reference angle"):
        read_calibration(path)
    assert sorted_angles == []


@pytest.mark.parametrize("k", [3, 4, 5, 8])
@pytest.mark.parametrize("quantum", [None, 0.01])
def test_the_stops_table_finds_what_the_labelled_groups_find(k, quantum):
    rng = np.random.default_rng(k)
    stops = 500
    reference = np.tile(np.arange(stops) * 360.0 / stops, k)
    rng.shuffle(reference)
    error = np.sin(np.radians(reference)) + rng.normal(0.0, 0.05, reference.size)
    error[rng.choice(reference.size, 7, replace=False)] += rng.choice([-3.0, 3.0], 7)
    by_stop = stable_argsort(reference)
    stop = np.empty(reference.size, dtype=np.intp)
    stop[by_stop] = np.repeat(np.arange(stops), k)
    counts = np.bincount(stop)
    expected = outliers._isolated_repeats(error, stop, counts, quantum, 10.0, by_stop=by_stop)
    found = outliers._isolated_table(error, by_stop, k, quantum, 10.0)
    assert found.index.size >= 5
    np.testing.assert_array_equal(found.index, expected.index)
    np.testing.assert_array_equal(found.deviation_arcmin, expected.deviation_arcmin)
    assert found.typical_step_arcmin == expected.typical_step_arcmin and found.repeated


def _old_neighbour_test(theta, error, factor=10.0):
    """The neighbour test as it was written with np.roll (outliers.py before read-speed)."""
    order = np.argsort(theta, kind="stable")
    e = error[order]
    steps = np.abs(e - np.roll(e, 1))
    nonzero = steps[steps > 0]
    typical = max(1.4826 * float(np.median(steps)), float(nonzero.min()))
    from_left = e - (np.roll(e, 1) + np.roll(e, 2)) / 2.0
    from_right = e - (np.roll(e, -1) + np.roll(e, -2)) / 2.0
    same_side = np.sign(from_left) == np.sign(from_right)
    deviation = np.where(same_side, np.sign(from_left) * np.minimum(np.abs(from_left), np.abs(from_right)), 0.0)
    far = np.flatnonzero(np.abs(deviation) > factor * typical)
    in_input_order = np.argsort(order[far], kind="stable")
    return order[far][in_input_order], deviation[far][in_input_order], typical


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_neighbour_test_on_views_is_the_rolled_one(seed):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.0, 360.0, 5000)
    error = np.sin(np.radians(theta)) + rng.normal(0.0, 0.01, theta.size)
    error[rng.choice(theta.size, 9, replace=False)] += rng.choice([-2.0, 2.0], 9)
    error[:2] += 5.0  # at the ends of the input, not of the circle
    found = outliers.isolated_points(theta, error)
    index, deviation, typical = _old_neighbour_test(theta, error)
    assert index.size >= 9
    np.testing.assert_array_equal(found.index, index)
    np.testing.assert_array_equal(found.deviation_arcmin, deviation)
    assert found.typical_step_arcmin == typical


def test_the_sign_of_the_median_by_counting():
    rng = np.random.default_rng(0)
    for size in (2, 3, 4, 5, 10, 11):
        for _ in range(300):
            values = rng.choice([-2.0, -1.0, -1e-300, 0.0, 1e-300, 1.0, 2.0], size) * rng.uniform(0.5, 1.5, size)
            assert calibration._median_is_negative(values) == (np.median(values) < 0), values


def test_identical_points_told_by_one_sort_of_values():
    rng = np.random.default_rng(0)
    theta = rng.uniform(0.0, 360.0, 3000)
    error = rng.normal(0.0, 1.0, theta.size)
    assert outliers._has_identical(theta, error) is False
    theta[10], error[10] = theta[20], error[20] + 0.5  # one encoder angle twice: not identical
    assert outliers._has_identical(theta, error) is False
    theta[30], error[30] = theta[40], error[40]
    assert outliers._has_identical(theta, error) is True
    np.testing.assert_array_equal(outliers._first_of_identical(theta, error), np.delete(np.arange(theta.size), 40))
    theta[:200] = np.repeat(theta[200:300], 2)  # 100 shared angles: left to the argsort
    assert outliers._has_identical(theta, error) is None


def test_stable_argsort_gives_the_sorted_values():
    rng = np.random.default_rng(0)
    for values in (rng.uniform(0.0, 1.0, 2000), np.round(rng.uniform(0.0, 50.0, 2000)), np.arange(2000.0) % 7,
                   np.tile(np.arange(500.0), 4)):
        order, ordered = stable_argsort(values, return_sorted=True)
        np.testing.assert_array_equal(order, np.argsort(values, kind="stable"))
        np.testing.assert_array_equal(ordered, values[order])


@pytest.mark.parametrize("body, start, plain, lines", [
    (b"a,b\n1,2\n3,4\n", 4, True, 2),
    (b"a,b\n1,2\n3,4", 4, True, 2),
    (b"a,b\r\n1,2\r\n3,4\r\n", 5, True, 2),
    (b"a,b\n1,2\r3,4\n", 4, False, 1),  # a CR alone ends a line for the careful reader
    (b"a,b\n1,2\nx,4\n", 4, False, 2),
    (b"a,b\n", 4, True, 0),
])
def test_plainness_and_lines_after_the_head_without_a_copy(body, start, plain, lines):
    assert csv_numbers.plain_body(body, start) is plain
    assert csv_numbers.line_count(body, start) == lines


def _stable_argsort_cases():
    rng = np.random.default_rng(0)
    uniform = rng.uniform(0.0, 360.0, 3000)
    # values that share all but their last 12 bits (an index of 3000 takes 12): the packed sort sees them as equal
    # and orders them by index, the wrong way round here, and sorts their runs again
    near = uniform.copy()
    top = near[::300].view(np.int64) & ~np.int64(0xFFF)  # ten such runs (the mending takes up to 3000 // 256)
    near[::300] = (top | 7).view(np.float64)
    near[1::300] = (top | 3).view(np.float64)
    near[2::300] = (top | 3).view(np.float64)  # and an equal pair among them: index order
    clustered = rng.choice(rng.uniform(0.0, 360.0, 30), 3000) + rng.uniform(0.0, 1e-12, 3000)  # many such runs
    quantised = np.round(uniform * 2**10 / 360.0) * 360.0 / 2**10
    signed = np.r_[uniform[:100], -0.0, 0.0, -1.0, 0.0, -0.0]  # a sign bit: not packed
    zeros = np.where(np.arange(300) % 3 == 0, -0.0, 0.0)  # ties of -0.0 and 0.0: their sorted values told apart
    return [uniform, near, clustered, quantised, signed, np.tile(uniform[:500], 6), np.zeros(3000),
            np.r_[uniform[:300], zeros][::-1]]


@pytest.mark.parametrize("case", range(8))
def test_stable_argsort_by_packed_integers_is_numpys_stable_order(case):
    values = _stable_argsort_cases()[case]
    order, ordered = stable_argsort(values, return_sorted=True)
    np.testing.assert_array_equal(order, np.argsort(values, kind="stable"))
    np.testing.assert_array_equal(ordered.view(np.int64), values[order].view(np.int64))  # bit for bit: -0.0


def test_the_packed_sort_mends_runs_of_shared_top_bits_and_gives_up_on_many():
    from encal._core.sorting import _packed_argsort

    uniform, near, clustered = _stable_argsort_cases()[:3]
    shift = 12
    packed = (near.view(np.int64) >> shift << shift) | np.arange(near.size)
    packed.sort()
    unmended = packed & 0xFFF
    assert np.count_nonzero(np.diff(near[unmended]) < 0) == 10  # the mending has work to do
    np.testing.assert_array_equal(_packed_argsort(near)[0], np.argsort(near, kind="stable"))
    assert _packed_argsort(clustered) is None  # left to the argsort and its mending of ties


# --- task reader-audit: the fast reader against the careful one


@pytest.mark.parametrize("suffix", [".xz", ".lzma", ".gz", ".bz2"])
def test_a_plain_file_named_as_compressed_is_read_as_the_text_it_is(tmp_path, suffix):
    text = _sweep_text(stops=200, passes=1)
    (tmp_path / "sweep.csv").write_text(text)
    (tmp_path / f"sweep{suffix}").write_text(text)  # np.loadtxt of this path would decompress it (.xz: LZMAError)
    expected = read_calibration(tmp_path / "sweep.csv")
    cal = read_calibration(tmp_path / f"sweep{suffix}")
    np.testing.assert_array_equal(cal.reference_deg, expected.reference_deg)
    np.testing.assert_array_equal(cal.encoder_deg, expected.encoder_deg)


def test_a_file_rewritten_within_one_tick_of_its_time_stamps_is_read_as_first_read(tmp_path, monkeypatch):
    # coarse time stamps (a kernel tick, before Linux 6.13): a rewrite as long in the tick of the last one leaves size,
    # modification time and inode as they were; the reader takes the bytes it checked, not the ones written since
    path = tmp_path / "sweep.csv"
    text = _sweep_text()
    path.write_text(text)
    before = os.stat(path)
    real = csv_numbers.plain_file_rows
    path_read = None

    def rewritten_in_the_same_tick(*args, **kwargs):
        if path_read is not None:
            time.sleep(0.02)  # past the tick (at most 10 ms) of the write before the read: st_ctime tells them apart
        path.write_text(text.replace("0.0000000000,", "9.0000000000,", 1))
        os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns))
        if path_read is None:
            pytest.fail("a file changed 0.1 s before it was read was read again from its path")
        path_read.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(calibration, "plain_file_rows", rewritten_in_the_same_tick)
    monkeypatch.setattr(calibration, "_clock_ns", lambda: before.st_ctime_ns + 1_000_000)  # read 1 ms after the write
    assert read_calibration(path).reference_deg[0] == 0.0  # a file changed 0.1 s before or less: its bytes
    path.write_text(text)
    before = os.stat(path)
    _settled(monkeypatch)
    path_read = []
    assert read_calibration(path).reference_deg[0] == 0.0  # an older one: read again, its change told by st_ctime
    assert path_read == [1]


def _variants():
    """Files of 40 rows that the dense reader may take or leave: (name, text, keyword arguments)."""
    reference = np.arange(40) * 9.0
    encoder = reference + 0.1 * np.sin(np.radians(reference))
    rows = [f"{r!r},{e!r}" for r, e in zip(reference.tolist(), encoder.tolist())]
    head, body = "reference_deg,encoder_deg", "\n".join(rows)
    return [
        ("plain", f"{head}\n{body}\n", {}),
        ("comma after every row", head + "\n" + "\n".join(r + "," for r in rows) + "\n", {}),
        ("comma after the header and every row", head + ",\n" + "\n".join(r + "," for r in rows) + "\n", {}),
        ("blank lines of spaces and tabs", f"{head}\n" + "\n".join(rows[:20]) + "\n \n\t\n" + "\n".join(rows[20:]), {}),
        ("CR line ends", head + "\r" + "\r".join(rows) + "\r", {}),
        ("a comment ending with CR", f"# c\r{head}\r{body}\n", {}),
        ("CR CR LF", head + "\n" + "\r\r\n".join(rows) + "\r\r\n", {}),
        ("LF CR", head + "\n" + "\n\r".join(rows) + "\n", {}),
        ("blanks and tabs", "reference_deg\t encoder_deg\n" + body.replace(",", " \t ") + "\n", {}),
        ("no header, leading blanks", "\n".join("  " + r.replace(",", "   ") for r in rows) + "\n",
         {"reference_column": 1, "encoder_column": 2}),
        ("no header, columns swapped", body + "\n", {"reference_column": 2, "encoder_column": 1}),
        ("a vertical tab in a number", f"{head}\n" + "\n".join(rows[:5]) + "\n1.0\x0b,2.0\n" + "\n".join(rows[5:]), {}),
        ("a form feed in a comment", f"# a\x0cb\n{head}\n{body}\n", {}),
        ("a line of spaces first", f"   \r\n{head}\r\n" + "\r\n".join(rows) + "\r\n", {}),
        ("blank line at the end", f"{head}\n{body}\n\n", {}),
        ("spaces at the end, no line end", f"{head}\n{body}\n \t", {}),
        ("fifty other columns first", ",".join([f"x{i}" for i in range(50)] + [head]) + "\n"
         + "\n".join(",".join(["1.5"] * 50 + [r]) for r in rows) + "\n", {}),
        ("beyond 1e9 degrees", f"{head}\n{body}\n1000000000,1000000000.0000001\n", {}),
        ("1e9 degrees", f"{head}\n{body}\n1000000000,-1000000000\n", {}),
        ("signs and points", f"{head}\n{body}\n-0,-0.0\n+.5,5.\n", {}),
        ("a sign alone", f"{head}\n{body}\n+,1\n", {}),
        ("an exponent without digits", f"{head}\n{body}\n1e,1\n", {}),
        ("an empty field", f"{head}\n{body}\n1,,2\n", {}),
        ("a blank inside a number", f"{head}\n{body}\n1 0,2\n", {}),
        ("subnormal and underflow", f"{head}\n{body}\n4.9e-324,1e-400\n", {}),
        ("overflow", f"{head}\n{body}\n1e400,1\n", {}),
        ("counts", head + "\n" + "\n".join(f"{int(r * 16384 / 360)},{int(e * 16384 / 360)}"
                                            for r, e in zip(reference, encoder)) + "\n",
         {"reference_unit": "counts:14", "encoder_unit": "counts:14"}),
        ("counts beyond 1e9 degrees", f"{head}\n{body}\n1,30000000000000\n", {"encoder_unit": "counts:14"}),
        ("tabs with decimal commas", "reference_deg\tencoder_deg\n" + body.replace(",", "\t").replace(".", ",") + "\n",
         {}),
        ("a second header", f"{head}\n{head}\n{body}\n", {}),
        ("a quoted number", f'{head}\n{body}\n"1.0",2.0\n', {}),
        ("underscores", f"{head}\n{body}\n1_0,2\n", {}),
        ("a minus sign", f"{head}\n{body}\n\u22121,2\n", {}),
        ("only the header", f"{head}\n", {}),
        ("only the header, no line end", head, {}),
    ]


def _outcome(path, kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            cal = read_calibration(path, **kwargs)
        except calibration.CalibrationError as exc:
            return str(exc), [str(w.message) for w in caught]
    return (cal.reference_deg.tobytes(), cal.encoder_deg.tobytes(), cal.resolution_bits), [str(w.message)
                                                                                         for w in caught]


@pytest.mark.parametrize("name, text, kwargs", _variants(), ids=[case[0] for case in _variants()])
@pytest.mark.parametrize("suffix", [".csv", ".xz"])
def test_the_numpy_reader_and_the_careful_one_agree(tmp_path, monkeypatch, name, text, kwargs, suffix):
    # numbers bit for bit, messages and warnings word for word, with the file read again from its path, or from its
    # bytes (also in pieces of a few lines), or line by line
    path = tmp_path / f"cal{suffix}"
    path.write_bytes(text.encode())
    _settled(monkeypatch)
    outcomes = [_outcome(path, kwargs)]
    with monkeypatch.context() as patch:
        patch.setattr(calibration, "plain_file_rows", lambda *args, **kwargs: None)
        outcomes.append(_outcome(path, kwargs))
        patch.setattr(csv_numbers, "CHUNK_BYTES", 97)
        outcomes.append(_outcome(path, kwargs))
    with monkeypatch.context() as patch:
        patch.setattr(calibration, "_head_of_plain", lambda raw: None)
        careful = _outcome(path, kwargs)
    assert outcomes == [careful] * 3

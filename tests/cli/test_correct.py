"""`encal correct`: streaming correction of encoder angles."""

import os
import select
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from encal.cli import main
from encal.deploy import Compensator
from tests._paths import DATA

MODEL = DATA / "model_v1_fourier.json"
ENCAL = [sys.executable, "-m", "encal"]


@pytest.fixture(scope="module")
def compensator():
    return Compensator(MODEL)


def correct(capsys, *args):
    status = main(["correct", str(MODEL), *map(str, args)])
    out, err = capsys.readouterr()
    return status, out, err


def values(out):
    return [float(line) for line in out.splitlines()]


def fixed(corrected):
    """The lines `encal correct` writes for these corrected angles: printf's %.12f of each."""
    return [f"{value:.12f}" for value in np.atleast_1d(corrected).tolist()]


def test_one_angle_per_line(tmp_path, capsys, compensator):
    angles = [0.0, 1.5, 359.999, -10.0, 720.25, 1e-9]
    (tmp_path / "in.txt").write_text("".join(f"{a!r}\n" for a in angles))
    status, out, err = correct(capsys, tmp_path / "in.txt")
    assert status == 0 and err == ""
    assert out.splitlines() == fixed(compensator.correct(angles))


def test_exact_writes_the_shortest_repr(tmp_path, capsys, compensator):
    angles = [0.0, 1.5, 359.999, -10.0, 720.25, 1e-9, 1e-5, 123.456]
    (tmp_path / "in.txt").write_text("".join(f"{a!r}\n" for a in angles))
    status, out, err = correct(capsys, tmp_path / "in.txt", "--exact")
    assert status == 0 and err == ""
    assert out.splitlines() == [repr(value) for value in compensator.correct(angles).tolist()]
    assert values(out) == compensator.correct(angles).tolist()  # exact: repr round-trips


def test_csv_with_an_encoder_deg_column(tmp_path, capsys, compensator):
    (tmp_path / "in.csv").write_text(textwrap.dedent("""\
        # acquired 2026-11-22
        time_s,Encoder_Deg,temperature
        0.0,10.5,21.0
        0.1, 11.25 ,21.1

        0.2,12.0,21.1
        """))
    status, out, _ = correct(capsys, tmp_path / "in.csv")
    assert status == 0
    assert out.splitlines() == fixed(compensator.correct([10.5, 11.25, 12.0]))


def test_comments_blank_lines_crlf_bom_and_no_final_newline(tmp_path, capsys, compensator):
    (tmp_path / "in.txt").write_bytes(b"\xef\xbb\xbf# header comment\r\n1.0\r\n\r\n  2.0  \r\n3.0")
    status, out, _ = correct(capsys, tmp_path / "in.txt")
    assert status == 0 and out.splitlines() == fixed(compensator.correct([1.0, 2.0, 3.0]))


def test_empty_input_gives_empty_output(tmp_path, capsys):
    (tmp_path / "in.txt").write_text("")
    assert correct(capsys, tmp_path / "in.txt") == (0, "", "")


def test_malformed_line_stops_with_its_number_and_content(tmp_path, capsys, compensator):
    (tmp_path / "in.txt").write_text("1.0\n2.0\n# note\nabc\n4.0\n")
    status, out, err = correct(capsys, tmp_path / "in.txt")
    assert status == 1
    assert out.splitlines() == fixed(compensator.correct([1.0, 2.0]))
    assert len(err.strip().splitlines()) == 1
    assert "line 4" in err and "'abc'" in err and str(tmp_path / "in.txt") in err


@pytest.mark.parametrize("bad", ["nan", "inf", "-Infinity", "1.0,2.0", "12deg"])
def test_non_finite_and_malformed_numbers_are_bad_lines(tmp_path, capsys, bad):
    (tmp_path / "in.txt").write_text(f"1.0\n{bad}\n")
    status, out, err = correct(capsys, tmp_path / "in.txt")
    assert status == 1 and "line 2" in err and len(values(out)) == 1


def test_malformed_csv_field(tmp_path, capsys):
    (tmp_path / "in.csv").write_text("a,encoder_deg\n1,2\n3\n")
    status, out, err = correct(capsys, tmp_path / "in.csv")
    assert status == 1 and "line 3" in err and "column 2" in err and len(values(out)) == 1


def test_skip_bad_writes_nan_and_goes_on(tmp_path, capsys, compensator):
    (tmp_path / "in.txt").write_text("1.0\nabc\nnan\n4.0\n")
    status, out, _ = correct(capsys, tmp_path / "in.txt", "--skip-bad")
    assert status == 0
    result = values(out)
    assert np.isnan(result[1]) and np.isnan(result[2])
    assert [out.splitlines()[0], out.splitlines()[3]] == fixed(compensator.correct([1.0, 4.0]))


@pytest.mark.parametrize("exact", [False, True])
def test_large_file_in_blocks_is_exact(tmp_path, capsys, compensator, exact):
    angles = np.random.default_rng(0).uniform(-400.0, 400.0, 50_000)  # several read blocks
    (tmp_path / "in.txt").write_text("".join(f"{a!r}\n" for a in angles.tolist()))
    status, out, _ = correct(capsys, tmp_path / "in.txt", *(["--exact"] if exact else []))
    corrected = compensator.correct(angles)
    assert status == 0 and out.splitlines() == ([repr(v) for v in corrected.tolist()] if exact else fixed(corrected))


def test_bad_line_in_a_later_block_keeps_the_earlier_answers(tmp_path, capsys):
    lines = [f"{i * 0.01!r}\n" for i in range(30_000)]
    lines[25_000] = "oops\n"
    (tmp_path / "in.txt").write_text("".join(lines))
    status, out, err = correct(capsys, tmp_path / "in.txt")
    assert status == 1 and "line 25001" in err and len(values(out)) == 25_000


def test_overlong_line_is_refused(tmp_path, capsys):
    (tmp_path / "in.txt").write_text("1" * 200_000)
    status, _, err = correct(capsys, tmp_path / "in.txt")
    assert status == 1 and "bytes" in err


def test_missing_input_and_bad_model_exit_1(tmp_path, capsys):
    assert main(["correct", str(MODEL), str(tmp_path / "missing.txt")]) == 1
    assert "missing.txt" in capsys.readouterr().err
    (tmp_path / "m.json").write_text("{")
    (tmp_path / "angles.txt").write_text("10\n")
    assert main(["correct", str(tmp_path / "m.json"), str(tmp_path / "angles.txt")]) == 1
    assert "m.json" in capsys.readouterr().err


def test_usage_error_exits_2(capsys):
    with pytest.raises(SystemExit) as info:
        main(["correct"])
    assert info.value.code == 2


# -- as a process in a pipe -------------------------------------------------------------

def test_reads_standard_input_by_default(compensator):
    result = subprocess.run([*ENCAL, "correct", str(MODEL)], input=b"10\n20\n",
                            capture_output=True, timeout=120, check=True)
    assert result.stdout.decode().splitlines() == fixed(compensator.correct([10.0, 20.0]))
    dash = subprocess.run([*ENCAL, "correct", str(MODEL), "-"], input=b"10\n",
                          capture_output=True, timeout=120, check=True)
    assert dash.stdout.decode().splitlines() == fixed(compensator.correct([10.0]))


def test_answers_each_line_before_the_next_is_written(compensator):
    # A live acquisition chain: one reading in, its correction out, then the next.
    with subprocess.Popen([*ENCAL, "correct", str(MODEL)], stdin=subprocess.PIPE,
                          stdout=subprocess.PIPE) as proc:
        for theta in (12.5, 200.0, 359.75, -3.0):
            proc.stdin.write(f"{theta}\n".encode())
            proc.stdin.flush()
            ready, _, _ = select.select([proc.stdout], [], [], 120)  # guards against a hang
            assert ready, "no answer to a line while the input stayed open"
            assert proc.stdout.readline().decode() == fixed(compensator.correct(theta))[0] + "\n"
        proc.stdin.close()
        assert proc.wait(timeout=60) == 0


def test_closed_output_pipe_ends_quietly():
    with subprocess.Popen([sys.executable, "-c", "import sys\n"
                           "for i in range(300000): sys.stdout.write(f'{i % 360}\\n')"],
                          stdout=subprocess.PIPE, stderr=subprocess.DEVNULL) as source, \
            subprocess.Popen([*ENCAL, "correct", str(MODEL)], stdin=source.stdout,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE) as proc:
        source.stdout.close()
        first = proc.stdout.readline()
        proc.stdout.close()  # like `| head -1`
        err = proc.stderr.read()
        proc.wait(timeout=120)
    assert float(first) >= 0
    assert proc.returncode == 0 and b"Traceback" not in err and b"Exception" not in err


# -- constant memory --------------------------------------------------------------------

GENERATOR = """\
import sys
n = int(sys.argv[1])
block = "".join(f"{(i * 0.0137) % 720 - 360!r}\\n" for i in range(10_000)).encode()
out = sys.stdout.buffer
for _ in range(n // 10_000):
    out.write(block)
"""


def stream_lines(n):
    """Pipe n generated lines through `encal correct`.

    Returns the number of lines out, the last line and the peak RSS of `encal correct` in KiB.
    """
    with subprocess.Popen([sys.executable, "-c", GENERATOR, str(n)],
                          stdout=subprocess.PIPE) as source, \
            subprocess.Popen([*ENCAL, "correct", str(MODEL)], stdin=source.stdout,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE) as proc:
        source.stdout.close()
        count, tail = 0, b""
        while chunk := proc.stdout.read(1 << 20):
            count += chunk.count(b"\n")
            tail = (tail + chunk)[-200:]
        stderr = proc.stderr.read()
        _, status, usage = os.wait4(proc.pid, 0)  # the rusage of this one process
        proc.returncode = os.waitstatus_to_exitcode(status)
    assert proc.returncode == 0 and source.returncode == 0, stderr
    return count, tail.splitlines()[-1], usage.ru_maxrss


@pytest.mark.slow
def test_ten_million_lines_in_constant_memory(compensator):
    small_count, _, small_rss = stream_lines(10_000)
    count, last, rss = stream_lines(10_000_000)
    assert small_count == 10_000 and count == 10_000_000
    last_input = (9_999 * 0.0137) % 720 - 360
    assert last.decode() == fixed(compensator.correct(last_input))[0]
    # The whole input would take > 500 MB as Python floats and strings: memory must not grow.
    assert rss - small_rss < 16 * 1024, (small_rss, rss)


def test_direction_option_selects_a_directional_models_part(tmp_path, capsys):
    """`--direction` corrects with one direction's model; without it, the mean of both."""

    import encal

    model_path = DATA / "model_v1_directional.json"
    model = encal.load_model(model_path)
    angles = tmp_path / "a.txt"
    theta = [0.0, 10.5, 123.25, 359.9]
    angles.write_text("".join(f"{t}\n" for t in theta), encoding="utf-8")
    results = {}
    for direction in (1, -1, None):
        argv = ["correct", str(model_path), str(angles)]
        if direction is not None:
            argv += ["--direction", str(direction)]
        assert main(argv) == 0
        out = capsys.readouterr().out.split()
        expected = model.correct(theta, direction=direction) if direction else model.correct(theta)
        assert out == fixed(expected)
        results[direction] = out
    assert results[1] != results[-1]  # the two directions' models differ by arc-minutes here


def test_a_direction_column_corrects_each_row_with_its_direction(tmp_path, capsys):
    """Task edge5: a CSV with the calibration's direction column was corrected with the mean of both directions
    (exit 0); each row now gets its own direction, and --direction with such a file is refused."""
    import encal

    model_path = DATA / "model_v1_directional.json"
    model = encal.load_model(model_path)
    theta = [0.0, 10.5, 123.25, 359.9]
    direction = [1, -1, -1, 1]
    table = tmp_path / "run.csv"
    table.write_text("encoder_deg,direction\n" + "".join(f"{t},{'cw' if d > 0 else 'ccw'}\n"
                                                         for t, d in zip(theta, direction)), encoding="utf-8")
    assert main(["correct", str(model_path), str(table)]) == 0
    assert capsys.readouterr().out.split() == fixed(model.correct(theta, direction=np.array(direction)))
    assert main(["correct", str(model_path), str(table), "--direction", "-1"]) == 1
    out, err = capsys.readouterr()
    assert out == "" and "names each reading's direction in its direction column, and --direction -1" in err


def test_closed_standard_output_is_one_sentence(tmp_path):
    readings = tmp_path / "angles.txt"
    readings.write_text("10\n20\n")
    done = subprocess.run([sys.executable, "-m", "encal", "correct", str(DATA / "model_v1_fourier.json"),
                           str(readings)], preexec_fn=lambda: os.close(1), capture_output=False,
                          stderr=subprocess.PIPE, text=True, timeout=120)
    assert done.returncode == 1
    assert done.stderr == ("encal correct: error: standard output is closed; expected somewhere to write the "
                           "corrected angles\n")


def _csv_rows(angles, newline="\n"):
    return "".join(f"{i * 0.001:.3f},{angle!r},{20 + i % 7}{newline}" for i, angle in enumerate(angles))


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_large_csv_in_blocks(tmp_path, capsys, compensator, newline):
    """Rows of several read blocks, the column in the middle: each block's column read in NumPy."""
    angles = np.random.default_rng(1).uniform(-400.0, 400.0, 30_000).tolist()
    (tmp_path / "in.csv").write_bytes(("time_s,encoder_deg,temp_C" + newline + _csv_rows(angles, newline)).encode())
    status, out, err = correct(capsys, tmp_path / "in.csv")
    assert status == 0 and err == ""
    assert out.splitlines() == fixed(compensator.correct(angles))


def test_a_comment_row_with_the_header_s_fields_in_a_later_block_is_skipped(tmp_path, capsys, compensator):
    angles = np.random.default_rng(2).uniform(0.0, 360.0, 20_000).tolist()
    rows = _csv_rows(angles).splitlines(keepends=True)
    rows.insert(8_000, "# paused,123.0,21\n")  # as many fields as the header: still a comment
    rows.insert(19_000, '0.5,"77.25",21\n')  # a quoted field (in another block): the line-by-line reader
    (tmp_path / "in.csv").write_text("time_s,encoder_deg,temp_C\n" + "".join(rows))
    status, out, _ = correct(capsys, tmp_path / "in.csv")
    expected = angles[:18_999] + [77.25] + angles[18_999:]
    assert status == 0 and out.splitlines() == fixed(compensator.correct(expected))


def test_a_short_csv_row_in_a_later_block_names_its_line(tmp_path, capsys):
    angles = np.random.default_rng(3).uniform(0.0, 360.0, 20_000).tolist()
    rows = _csv_rows(angles).splitlines(keepends=True)
    rows[12_345] = "1.0,2.0\n"
    (tmp_path / "in.csv").write_text("time_s,encoder_deg,temp_C\n" + "".join(rows))
    status, out, err = correct(capsys, tmp_path / "in.csv")
    assert status == 1 and "line 12347" in err and "2 fields, not 3" in err
    assert len(out.splitlines()) == 12_345


# -- readings in other units and columns (a firmware's log of raw counts) --------------------------------------------

@pytest.mark.parametrize("unit, per_degree", [("counts:14", 2**14 / 360), ("counts:12", 2**12 / 360),
                                              ("rev", 1 / 360), ("rad", np.pi / 180)])
@pytest.mark.parametrize("layout", ["lines", "csv"])
def test_readings_in_another_unit_are_corrected_as_their_angle_in_degrees(tmp_path, capsys, compensator, unit,
                                                                        per_degree, layout):
    degrees = np.array([0.0, 22.5, 90.0, 181.40625, 359.12109375] * 300)  # every one a whole 12- and 14-bit code
    readings = degrees * per_degree
    text = "".join(f"{r!r}\n" for r in readings.tolist())
    if layout == "csv":
        text = "time_s,Raw\n" + "".join(f"{i},{r!r}\n" for i, r in enumerate(readings.tolist()))
    path = tmp_path / "log.txt"
    path.write_text(text)
    status, out, err = correct(capsys, path, "--enc-unit", unit, *(["--enc-col", "raw"] if layout == "csv" else []))
    assert status == 0 and err == ""
    np.testing.assert_allclose(values(out), compensator.correct(readings / per_degree), rtol=0, atol=1e-11)
    if unit.startswith("counts"):  # whole codes in degrees exactly: the same answers as the angles themselves
        assert out.splitlines() == fixed(compensator.correct(degrees))


def test_a_bad_reading_names_the_unit_and_the_column(tmp_path, capsys):
    path = tmp_path / "log.csv"
    path.write_text("t,raw\n1,4096\n2,4x096\n")
    status, out, err = correct(capsys, path, "--enc-unit", "counts:14", "--enc-col", "raw")
    assert status == 1 and len(out.splitlines()) == 1
    assert "line 3 of " in err and "expected a finite number of counts of a 14-bit encoder in column 2 (raw)" in err


def test_counts_beyond_1e9_degrees_are_malformed_and_more_codes_are_not(tmp_path, capsys):
    path = tmp_path / "log.txt"
    path.write_text(f"{2**14 * 10**6}\n")  # a million turns of a 14-bit encoder: 3.6e8 degrees
    assert correct(capsys, path, "--enc-unit", "counts:14")[0] == 0
    path.write_text("1e8\n")  # 1e8 turns: 3.6e10 degrees
    status, _, err = correct(capsys, path, "--enc-unit", "rev")
    assert status == 1 and "within +-1e+09 degrees" in err


def test_without_the_column_the_header_is_no_header(tmp_path, capsys):
    path = tmp_path / "log.csv"
    path.write_text("t,raw\n1,4096\n")
    status, _, err = correct(capsys, path, "--enc-unit", "counts:14")
    assert status == 1 and "line 1 of " in err and "a CSV header with an encoder_deg column first" in err


def test_a_dash_after_an_option_is_standard_input(monkeypatch, capsys, compensator):
    """``encal correct M.json --exact -`` reads standard input (fuzz7: it was 'unrecognized arguments: -', exit 2)."""
    import io

    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(b"4096\n"), encoding="utf-8"))
    status, out, err = correct(capsys, "--enc-unit", "counts:14", "--exact", "-")
    assert status == 0, err
    assert values(out) == [compensator.correct(90.0)]


def test_a_blank_column_name_is_a_usage_error_and_a_named_column_reads_well(tmp_path, capsys):
    """--enc-col '' exited 1 naming correct_stream's 'column' parameter; a header without the named column
    said 'a CSV header with an raw column' (fuzz7)."""
    with pytest.raises(SystemExit) as exited:
        main(["correct", str(MODEL), "--enc-col", " "])
    assert exited.value.code == 2 and "--enc-col: expected the name of a CSV column" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exited:  # a directional model corrected +1 and -1 as angles, exit 0
        main(["correct", str(MODEL), "--enc-col", "Direction"])
    assert exited.value.code == 2 and "--enc-col: expected the column of the readings" in capsys.readouterr().err
    path = tmp_path / "log.csv"
    path.write_text("time_s,encoder_deg\n0,10\n")
    status, _, err = correct(capsys, "--enc-col", "raw", path)
    assert status == 1 and "a CSV header with a raw column first" in err

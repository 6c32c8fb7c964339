"""Plain ASCII decimals: the numbers every reader and option of encal takes (task strict6)."""

import argparse
import math

import numpy as np
import pytest

from encal._core.csv_numbers import plain_rows
from encal._core.number_cells import is_plain_number_text, not_plain_note, plain_option, read_number, read_whole

PLAIN = ["0", "-2.5", "+.5", "1.", "6.02e23", "1E-05", " 10.5 ", "\t7\t", "360", "-0", "1e400", "nan", "-Infinity"]
ONLY_PYTHON = ["1_000", "1_0.5", "\uff120.01", "\u0661\u0662", "1\u00a0", "\u20031", "2\x0c", "\x0b3",
               "\u0967\u0968", "1e1_0"]


@pytest.mark.parametrize("text", PLAIN)
def test_a_plain_decimal_reads_as_float_reads_it(text):
    expected = float(text)
    for form in (text, text.encode("ascii")):
        value = read_number(form)
        assert value == expected or (math.isnan(value) and math.isnan(expected))
        assert not_plain_note(form) == ""


@pytest.mark.parametrize("text", ONLY_PYTHON)
def test_a_number_only_python_reads_is_refused_with_why(text):
    float(text)  # the premise: Python reads it
    with pytest.raises(ValueError):
        read_number(text)
    assert not is_plain_number_text(text)
    assert not_plain_note(text).startswith("; ")


def test_the_notes_name_the_character_and_the_plain_text():
    assert not_plain_note("1_000") == "; an underscore between digits is not read (write '1000')"
    assert "U+FF12 FULLWIDTH DIGIT TWO" in not_plain_note("\uff120.01") and "(write '20.01')" in not_plain_note(
        "\uff120.01")
    assert "ARABIC-INDIC DIGIT ONE" in not_plain_note("\u0661\u0662") and "'12'" in not_plain_note("\u0661\u0662")
    assert "NO-BREAK SPACE" in not_plain_note("1\u00a0")
    assert not_plain_note("abc") == "" and not_plain_note("1,5") == ""  # no number at all: the message says enough
    assert len(not_plain_note("1_" * 1000 + "1")) < 120  # a long cell is shortened


def test_whole_numbers():
    assert read_whole(" +42 ") == 42 and read_whole("-7") == -7
    for text in ("1_0", "\u0661\u0660", "\uff11", "1.5", "1e3"):
        with pytest.raises(ValueError):
            read_whole(text)


def test_an_option_reads_plain_numbers_and_refuses_others_as_a_usage_error():
    parser = argparse.ArgumentParser()
    parser.add_argument("--noise", type=plain_option(float))
    parser.add_argument("--bits", type=plain_option(int))
    args = parser.parse_args(["--noise", "1.5e-1", "--bits", "14"])
    assert (args.noise, args.bits) == (0.15, 14)
    for argv in (["--noise", "1_0"], ["--bits", "\uff11\uff14"], ["--bits", "1.5"]):
        with pytest.raises(SystemExit) as stopped:
            parser.parse_args(argv)
        assert stopped.value.code == 2


def test_the_numpy_reader_of_plain_bodies_never_reads_what_python_alone_reads():
    # the fast path returns None (the careful reader then refuses): it must not read '1_0' as 10
    for cell in ("1_0", "\uff120", "1\u00a0"):
        assert plain_rows(f"1,2\n{cell},3\n".encode("utf-8"), ",", 2) is None
    assert np.array_equal(plain_rows(b"1,2\n+.5,6.02e23\n", ",", 2), [[1, 2], [0.5, 6.02e23]])

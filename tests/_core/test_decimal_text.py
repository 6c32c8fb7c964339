"""Decimal text to doubles and back in NumPy (``encal._core.decimal_text``): exactly Python's answers.

``parse_lines`` must give the double ``float()`` gives for every line it accepts (correct rounding, also
for 17-digit significands and text a hair from the midpoint between two doubles), and refuse every
other line; ``format_fixed`` must write printf's ``%.12f``, also for values a hair from a rounding tie.
"""

from decimal import Decimal

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from encal._core.decimal_text import format_fixed, parse_lines


def parse(lines, newline="\n"):
    return parse_lines(np.frombuffer("".join(f"{line}{newline}" for line in lines).encode(), dtype=np.uint8))


def assert_same_doubles(got, texts):
    expected = np.array([float(text) for text in texts])
    assert got is not None
    # bit for bit, the sign of zero included
    np.testing.assert_array_equal(got.view(np.int64), expected.view(np.int64))


@pytest.mark.parametrize("low, high", [(0.0, 360.0), (-720.0, 720.0), (1e-4, 1e-2), (0.0, 1.0)])
def test_reprs_of_doubles_read_back_bit_for_bit(low, high):
    angles = np.random.default_rng(0).uniform(low, high, 20_000)
    texts = [repr(value) for value in angles.tolist() if "e" not in repr(value)]
    assert_same_doubles(parse(texts), texts)


@pytest.mark.parametrize("places", [0, 1, 3, 6, 9, 12, 15])
def test_fixed_point_text_reads_as_float_does(places):
    angles = np.random.default_rng(places).uniform(-400.0, 400.0, 5_000)
    texts = [f"{value:.{places}f}" for value in angles.tolist()]
    assert_same_doubles(parse(texts), texts)


def _near_midpoints(count, digits, seed):
    """Decimal texts within one unit of their last digit of the midpoint between two adjacent doubles."""
    rng = np.random.default_rng(seed)
    texts = []
    for value in rng.uniform(0.0, 360.0, count).tolist():
        midpoint = (Decimal(value) + Decimal(np.nextafter(value, np.inf))) / 2
        for rounding in ("ROUND_FLOOR", "ROUND_CEILING"):
            quantum = Decimal(1).scaleb(-(digits - 1 - midpoint.adjusted()))
            texts.append(str(midpoint.quantize(quantum, rounding=rounding)))
    return texts


@pytest.mark.parametrize("digits", [17, 18])
def test_text_a_hair_from_a_midpoint_rounds_as_float_does(digits):
    texts = _near_midpoints(2_000, digits, seed=digits)
    assert_same_doubles(parse(texts), texts)


def test_signs_leading_zeros_crlf_and_bare_points():
    texts = ["-0", "+0", "-0.0", "+12.5", "-.5", "5.", "007.25", "0.0000000000000000000001", "123456.5",
             "-359.99999999999994", "0.30000000000000004"]
    assert_same_doubles(parse(texts, newline="\r\n"), texts)


@pytest.mark.parametrize("text", ["", " 1", "1 ", "1e5", "1E5", ".", "+", "-", "+-1", "1-", "1.2.3", "1..2", "nan",
                                  "inf", "1_000", "0x10", "1,5", "#1", "1234567.5", "0." + "1" * 23,
                                  "999999.999999999999999", "\u00bd", "1\r2"])
def test_anything_else_is_refused(text):
    assert parse(["1.5", text, "2.5"]) is None


def test_a_line_without_its_line_end_is_refused():
    assert parse_lines(np.frombuffer(b"1.5\n2.5", dtype=np.uint8)) is None
    assert parse_lines(np.frombuffer(b"", dtype=np.uint8)) is None


_DECIMALS = st.builds(
    lambda sign, whole, fraction, point: sign + whole + ("." + fraction if point or not whole else ""),
    st.sampled_from(["", "-", "+"]), st.text("0123456789", max_size=6), st.text("0123456789", max_size=22),
    st.booleans())


@settings(max_examples=400, deadline=None)
@given(st.lists(_DECIMALS, min_size=1, max_size=20))
def test_any_plain_decimal_is_read_as_float_does_or_refused_for_its_size(texts):
    got = parse(texts)
    digits = [text.lstrip("+-").replace(".", "") for text in texts]
    if all(digit for digit in digits) and all(int(digit) < 9e18 for digit in digits):
        assert_same_doubles(got, texts)
    elif not all(digit for digit in digits):
        assert got is None  # a line without digits


def printf(values):
    return "".join("0.000000000000\n" if f"{value:.12f}" in ("360.000000000000", "-0.000000000000")
                   else f"{value:.12f}\n" for value in values).encode()


def test_format_is_printf_12_decimals():
    values = np.random.default_rng(1).uniform(0.0, 360.0, 50_000)
    assert format_fixed(values) == printf(values.tolist())


def test_format_near_ties_small_values_and_the_ends_of_the_turn():
    rng = np.random.default_rng(2)
    counts = rng.integers(0, 360 * 10**12, 5_000)
    ties = ((counts + 0.5) / 1e12).tolist()  # the doubles nearest the rounding ties
    values = ties + [np.nextafter(t, 0.0) for t in ties] + [np.nextafter(t, 360.0) for t in ties] + [
        0.0, -0.0, 5e-13, 1.5e-12, 2.5e-12, 1e-300, 9.5, 99.5, 100.0, 359.9999999999995, 359.9999999999996,
        np.nextafter(360.0, 0.0)]
    assert format_fixed(np.array(values)) == printf(values)


def test_format_writes_nan_and_values_outside_the_turn_as_python_does():
    values = [1.0, np.nan, 2.0, -1.5, 400.25, 3.0, 1e20]
    assert format_fixed(np.array(values)) == "".join(f"{v:.12f}\n" for v in values).encode()
    assert format_fixed(np.empty(0)) == b""


def test_every_written_angle_is_within_5e13_degrees():
    values = np.random.default_rng(3).uniform(0.0, 360.0, 10_000)
    written = np.array(format_fixed(values).split(), dtype=float)
    assert np.max(np.abs(written - values)) <= 5e-13 + 360 * 2**-52


def test_a_quotient_the_residual_cannot_vouch_for_is_read_by_float(monkeypatch):
    import encal._core.decimal_text as decimal_text

    texts = _near_midpoints(300, 17, seed=5)
    monkeypatch.setattr(decimal_text, "_MARGIN", 0.49)  # almost every quotient left unsure
    assert_same_doubles(parse(texts), texts)

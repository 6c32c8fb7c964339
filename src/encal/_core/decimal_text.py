"""Plain decimal text to doubles and doubles to fixed-point text, a block of lines at a time in NumPy.

Python's ``float`` and ``repr`` cost a few hundred nanoseconds per number, and a stream of encoder
angles spends most of its time there. This module does both for a whole block of lines with integer
arithmetic on NumPy arrays, giving exactly Python's answers:

- :func:`parse_lines` reads lines holding one plain decimal each (``[+-]digits[.digits]``) and returns
  the doubles ``float()`` returns, correctly rounded. The digits are read eight at a time from 64-bit
  words (SWAR); the significand divided by its power of ten is checked with an exact residual in
  double-double arithmetic, and the rare quotient that check cannot vouch for is read by ``float()``.
  Any other text (a blank line, a comment, spaces, an exponent, ``nan``, too many digits) makes it
  return None, and the caller reads that block the slow, exact way, with its own messages.
- :func:`format_fixed` writes each double as ``'%.12f' % value`` and a newline (printf's correctly
  rounded text), the digits built eight at a time in 64-bit words.
"""

import numpy as np

__all__ = ["parse_lines", "format_fixed", "FIXED_DECIMALS"]

#: Decimal places of :func:`format_fixed`: a written angle is within 5e-13 degrees of the double.
FIXED_DECIMALS = 12

_DIGITS_INT = 6  # longest integer part read (a thousand turns in degrees)
_DIGITS_FRAC = 22  # longest fraction read (10**22 is the largest power of ten that is an exact double)
_MAX_SIGNIFICAND = 9.0e18  # below 2**63: the significand fits an int64
_BEFORE = 7  # bytes of a window before its point: one spare and the integer digits
_WINDOW = 32  # bytes read around a point: 7 before it, the point, 24 after (22 of them used)
_MARGIN = 2.0**-20  # in units in the last place: far above the residual's rounding, far below a tie
_SPLITTER = 134217729.0  # 2**27 + 1: Veltkamp's split of a double into two halves of 26 bits

_ZERO, _LF, _CR, _PLUS, _MINUS, _POINT = (np.uint8(ord(c)) for c in "0\n\r+-.")
_POW10_INT = 10 ** np.arange(19, dtype=np.int64)
_POW10_UINT = 10 ** np.arange(20, dtype=np.uint64)
_POW10 = 10.0 ** np.arange(_DIGITS_FRAC + 1)  # every one exact in binary64


def _split(a):
    """``a`` as the sum of two doubles of 26 significant bits (Veltkamp)."""
    c = _SPLITTER * a
    high = c - (c - a)
    return high, a - high


_POW10_HIGH, _POW10_LOW = _split(_POW10)


def parse_lines(data):
    """The number on each line of ``data``, or None if a line is not one plain decimal.

    Parameters
    ----------
    data : ndarray of uint8
        Whole lines of text, each ending with LF (or CRLF), the last one too.

    Returns
    -------
    ndarray of float or None
        ``float(line)`` of every line; None when a line is not ``[+-]digits[.digits]`` with at least
        one digit, at most 6 digits before the point and 22 after it, and a significand below 9e18.
    """
    if data.size == 0 or data[-1] != _LF:
        return None
    marks = np.flatnonzero((data - _ZERO) >= 10)  # every byte that is not a digit
    chars = data[marks]
    line_end = chars == _LF
    point = chars == _POINT
    sign = (chars == _PLUS) | (chars == _MINUS)
    cr = chars == _CR
    if np.count_nonzero(line_end | point | sign | cr) != chars.size:
        return None
    if cr.any() and np.any(data[marks[cr] + 1] != _LF):  # a CR alone ends a line: the slow reader's case
        return None
    ends = marks[line_end]
    starts = np.concatenate(([0], ends[:-1] + 1))
    if sign.any():  # only as a line's first character
        at = marks[sign]
        if np.any((at > 0) & (data[np.maximum(at - 1, 0)] != _LF)):
            return None
    if cr.any():
        ends = ends - (data[np.maximum(ends - 1, 0)] == _CR)
    separators = chars[line_end | point]  # each line's point (if any), then its LF
    if np.any((separators[1:] == _POINT) & (separators[:-1] == _POINT)):  # two points in a line
        return None
    before = np.flatnonzero(separators == _LF) - 1
    has_point = (before >= 0) & (separators[np.maximum(before, 0)] == _POINT)
    head = data[starts]  # every line holds at least its LF: each start is inside data
    negative = head == _MINUS
    first = starts + (negative | (head == _PLUS))
    points = np.where(has_point, marks[line_end | point][np.maximum(before, 0)], ends)
    n_int = points - first
    n_frac = np.where(has_point, ends - points - 1, 0)
    if np.any(n_int + n_frac < 1) or np.any(n_int > _DIGITS_INT) or np.any(n_frac > _DIGITS_FRAC):
        return None
    significand = _significands(data, points, n_int, n_frac)
    if significand is None:
        return None
    values = _quotient(significand, n_frac)
    unsure = np.flatnonzero(np.isnan(values))
    if unsure.size:
        text = data.tobytes()
        for i in unsure.tolist():
            values[i] = float(text[first[i]:ends[i]])
    np.negative(values, out=values, where=negative)
    return values


def _significands(data, points, n_int, n_frac):
    """The digits around each point as one integer (int64), or None if one would not fit.

    The 32 bytes around a point are read as four little-endian 64-bit words of eight digits each: three
    multiply-shift-mask steps turn eight digits into their number (SWAR). Every byte that is not a digit
    (the point, line ends, signs) reads as 0; the digits of neighbouring lines caught in a window are
    cut off with the digit counts.
    """
    digits = data - _ZERO
    digits *= digits < 10
    padded = np.concatenate((np.zeros(_BEFORE, np.uint8), digits, np.zeros(_WINDOW, np.uint8)))
    words = _words_at(padded)
    base = points  # padded shifts by 7: the word at ``points`` starts 7 bytes before the point
    words = [words[base], words[base + 8], words[base + 16], words[base + 24]]
    integer = (_eight_digits(words[0]) // np.uint64(10)).astype(np.int64) % _POW10_INT[n_int]
    first16 = _eight_digits(words[1]) * np.uint64(10**8) + _eight_digits(words[2])
    if np.any((integer + first16 / 1e16) * _POW10[n_frac] >= _MAX_SIGNIFICAND):  # an estimate, 2% from 2**63
        return None
    short = n_frac <= 16  # the fraction's digits: the first 16 cut to n_frac, or all 16 and some of the next 8
    fraction = np.where(short, first16 // _POW10_UINT[np.where(short, 16 - n_frac, 0)],
                        first16 * _POW10_UINT[np.where(short, 0, n_frac - 16)]
                        + _eight_digits(words[3]) // _POW10_UINT[np.where(short, 0, 24 - n_frac)])
    return integer * _POW10_INT[np.minimum(n_frac, 18)] + fraction.astype(np.int64)  # integer is 0 past 18


def _words_at(buffer):
    """Every 64-bit little-endian word of ``buffer`` (uint8), one starting at each byte (unaligned)."""
    return np.ndarray((buffer.size - 7,), dtype="<u8", buffer=buffer, strides=(1,))


def _eight_digits(word):
    """The number whose decimal digits are the eight bytes of ``word`` (uint64, first byte first)."""
    word = word * np.uint64(10) + (word >> np.uint64(8))
    word &= np.uint64(0x00FF00FF00FF00FF)
    word = word * np.uint64(100) + (word >> np.uint64(16))
    word &= np.uint64(0x0000FFFF0000FFFF)
    return (word * np.uint64(10000) + (word >> np.uint64(32))) & np.uint64(0xFFFFFFFF)


def _quotient(significand, exponent):
    """``significand / 10**exponent`` correctly rounded, NaN where that is not certain.

    The significand rounded to a double, divided by the power of ten, is within two units in the last
    place of the value; the residual ``significand - quotient * 10**exponent``, in double-double
    arithmetic (Dekker's exact product), says whether it or a neighbour is the correctly rounded value.
    Below 2**53 the quotient of two exact doubles is correctly rounded already (Clinger's fast path),
    and the residual, zero, confirms it.

    Parameters
    ----------
    significand : ndarray of int64, non-negative, below 9e18
    exponent : ndarray of int, 0 to 22
    """
    power = _POW10[exponent]
    high = significand.astype(float)
    low = (significand - high.astype(np.int64)).astype(float)  # exact: |low| <= ulp(high) / 2
    quotient = high / power
    product = quotient * power
    qh, ql = _split(quotient)
    ph, pl = _POW10_HIGH[exponent], _POW10_LOW[exponent]
    error = ((qh * ph - product) + qh * pl + ql * ph) + ql * pl  # quotient * power == product + error
    residual = (high - product) + (low - error)  # high - product is exact (Sterbenz)
    ulp = np.spacing(quotient)
    steps = residual / (ulp * power)  # units in the last place from the quotient up to the value
    below = quotient - ulp
    up = (steps > 0.5 + _MARGIN) & (steps < 1.5 - _MARGIN)
    down = (steps < -0.5 - _MARGIN) & (steps > -1.5 + _MARGIN) & (np.spacing(below) == ulp)  # same binade
    result = np.where(up, quotient + ulp, np.where(down, below, quotient))
    result[~((np.abs(steps) < 0.5 - _MARGIN) | up | down)] = np.nan
    return result


_SCALE = 10.0**FIXED_DECIMALS
_SCALE_HIGH, _SCALE_LOW = _split(_SCALE)
_ASCII_ZEROS = np.uint64(0x3030303030303030)
_LINE_BYTES = 3 + 1 + FIXED_DECIMALS + 1  # up to 3 digits, the point, the decimals, LF


def format_fixed(values):
    """Each value as ``'%.12f' % value`` and a newline, as ASCII bytes.

    Values in [0, 360) are written with integer arithmetic: the scaled value ``value * 1e12`` is
    rounded with its exact residual (Dekker's product), ties to even as printf does, and its 15 digits
    made eight at a time. Others (NaN, values outside [0, 360), and the scaled values too close to a
    tie to decide in double-double) are written by Python. A value that rounds to ``360.000000000000``
    is written ``0.000000000000``: the same angle, kept in [0, 360); so is ``-0.0`` (where printf writes
    ``-0.000000000000``).

    Parameters
    ----------
    values : ndarray of float, shape (n,)

    Returns
    -------
    bytes
    """
    values = np.asarray(values, dtype=float).reshape(-1)
    if values.size == 0:
        return b""
    fast = (values >= 0.0) & (values < 360.0)
    scaled = np.where(fast, values, 0.0)
    product = scaled * _SCALE
    vh, vl = _split(scaled)
    error = ((vh * _SCALE_HIGH - product) + vh * _SCALE_LOW + vl * _SCALE_HIGH) + vl * _SCALE_LOW
    nearest = np.rint(product)
    offset = (product - nearest) + error  # the exact scaled value minus nearest, to ~2**-50
    fast &= np.abs(np.abs(offset) - 0.5) > 1e-6  # not a tie, nor too close to one to tell
    counts = nearest.astype(np.int64) + (offset > 0.5) - (offset < -0.5)
    counts[counts == 360 * 10**FIXED_DECIMALS] = 0
    whole = counts // 10**FIXED_DECIMALS
    skipped = 2 - (whole >= 10) - (whole >= 100)  # leading zeros of the 3-digit integer part
    ends = np.cumsum(_LINE_BYTES - skipped)
    out = np.empty(2 + ends[-1] + 8, dtype=np.uint8)
    # Each line is written as three pieces at its place, 'ddd.dddd' shifted left over its leading zeros;
    # the two bytes this spills into the line before are written over by that line's later pieces.
    at = 2 + np.concatenate(([0], ends[:-1])) - skipped
    words = _words_at(out)
    high = _eight_ascii(counts // 10**8)  # '0ddd' and the first 4 decimals
    words[at] = ((high >> np.uint64(8)) & np.uint64(0xFFFFFF)) | np.uint64(ord(".") << 24) \
        | (high & np.uint64(0xFFFFFFFF00000000))
    words[at + 8] = _eight_ascii(counts % 10**8)
    out[at + 16] = ord("\n")
    if fast.all():
        return out[2:2 + ends[-1]].tobytes()
    pieces = []
    starts = np.concatenate(([0], ends[:-1]))
    for run in np.split(np.arange(values.size), np.flatnonzero(np.diff(fast)) + 1):
        if fast[run[0]]:
            pieces.append(out[2 + starts[run[0]]:2 + ends[run[-1]]].tobytes())
        else:
            pieces.append("".join(f"{value:.{FIXED_DECIMALS}f}\n" for value in values[run].tolist()).encode("ascii"))
    return b"".join(pieces)


def _eight_ascii(number):
    """The eight decimal digits of ``number`` (below 1e8) as ASCII in a uint64, first digit first."""
    number = number.astype(np.uint64)
    high = number // np.uint64(10000)
    word = high | ((number - high * np.uint64(10000)) << np.uint64(32))  # two lanes of 4 digits
    tens = ((word * np.uint64(5243)) >> np.uint64(19)) & np.uint64(0x0000007F0000007F)  # lane // 100
    word = tens | ((word - tens * np.uint64(100)) << np.uint64(16))  # four lanes of 2 digits
    tens = ((word * np.uint64(103)) >> np.uint64(10)) & np.uint64(0x000F000F000F000F)  # lane // 10
    word = tens | ((word - tens * np.uint64(10)) << np.uint64(8))  # eight lanes of 1 digit
    return word | _ASCII_ZEROS

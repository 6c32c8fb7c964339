"""Correct a stream of encoder angles, text line by text line, in constant memory.

Input: one angle in degrees per line, or a CSV table whose first data line is a
header naming an ``encoder_deg`` column (case-insensitive); blank lines and
lines starting with ``#`` are skipped. Output: one corrected angle per input
angle, in degrees, written with Python's ``repr`` (the shortest text that reads
back to the same double), ``nan`` for a malformed line when skipping them.

The stream is read in blocks of whatever is available (``read1``): a file
gives large blocks, corrected with NumPy in one go; a pipe fed one line at a
time gives one line, whose answer is written and flushed before the next is
read, so the corrector can sit in a live acquisition chain.
"""

import numpy as np

from ..errors import InputError

__all__ = ["correct_stream", "BLOCK_BYTES", "MAX_LINE_BYTES"]

#: Largest read, in bytes: bounds the memory of one block of lines.
BLOCK_BYTES = 1 << 16
#: Longest line accepted, in bytes: bounds the memory when no newline comes.
MAX_LINE_BYTES = 1 << 16
_HEADER_COLUMN = b"encoder_deg"


def correct_stream(compensator, source, sink, *, skip_bad=False, name="stdin", direction=None):
    """Read encoder angles from ``source``, write corrected angles to ``sink``.

    Parameters
    ----------
    compensator : Compensator
        Evaluates the model (anything with ``correct(theta_deg) -> degrees``).
    source : binary file
        Text lines (UTF-8 or ASCII); read with ``read1`` when it has it.
    sink : binary file
        Receives one line per input angle; flushed after every block.
    skip_bad : bool, default=False
        Write ``nan`` for a malformed line and go on, instead of stopping.
    name : str, default='stdin'
        Name of the input in messages.
    direction : {+1, -1}, optional
        Direction of travel of every reading, for bidirectional (``directional``) models; other
        models ignore it. None: the mean of the two directions.

    Returns
    -------
    int
        Number of angles written.

    Raises
    ------
    InputError
        At the first malformed line (unless ``skip_bad``), naming its number
        and content; the answers to the lines before it are written first.
    """
    parser = _LineParser(skip_bad, name)
    read = getattr(source, "read1", source.read)
    pending = b""
    written = 0
    while True:
        block = read(BLOCK_BYTES)
        lines = (pending + block).split(b"\n")
        pending = b"" if not block else lines.pop()
        if len(pending) > MAX_LINE_BYTES:
            raise InputError(f"line {parser.line_number + len(lines) + 1} of {name}: expected "
                             f"lines of at most {MAX_LINE_BYTES} bytes, got a longer one")
        values, error = parser.parse(lines)
        if values.size:
            sink.write(_format(_correct(compensator, values, direction)))
            sink.flush()
            written += values.size
        if error is not None:
            raise error
        if not block:
            return written


def _correct(compensator, values, direction=None):
    correct = compensator.correct if direction is None else (
        lambda theta: compensator.correct(theta, direction))
    good = np.isfinite(values)
    if good.all():
        return correct(values)
    corrected = np.full(values.shape, np.nan)
    corrected[good] = correct(values[good])
    return corrected


def _format(values):
    return ("\n".join(map(repr, values.tolist())) + "\n").encode("ascii")


class _LineParser:
    """Turns blocks of lines into angles, remembering line numbers and the header."""

    def __init__(self, skip_bad, name):
        self.skip_bad = skip_bad
        self.name = name
        self.line_number = 0
        self.column = None  # None: no data line seen yet; -1: one angle per line

    def parse(self, lines):
        """Angles of the complete ``lines``, and the error to raise after writing them (or None)."""
        if self.column is not None:
            values = self._fast(lines)
            if values is not None:
                self.line_number += len(lines)
                return values, None
        return self._slow(lines)

    def _fast(self, lines):
        # The common case of a block: every line a finite number; else None.
        try:
            if self.column < 0:
                values = np.array([float(line) for line in lines])
            else:
                values = np.array([float(line.split(b",")[self.column]) for line in lines])
        except (ValueError, IndexError):
            return None
        return values if np.all(np.isfinite(values)) else None

    def _slow(self, lines):
        values = []
        for line in lines:
            self.line_number += 1
            text = line.strip()
            if self.line_number == 1:
                text = text.removeprefix(b"\xef\xbb\xbf").strip()
            if not text or text.startswith(b"#"):
                continue
            if self.column is None and self._is_header(text):
                continue
            if self.column is None:
                self.column = -1
            value = self._value(text)
            if value is None:
                if not self.skip_bad:
                    return np.array(values), self._error(text)
                value = np.nan
            values.append(value)
        return np.array(values), None

    def _is_header(self, text):
        fields = [field.strip().strip(b'"').lower() for field in text.split(b",")]
        if _HEADER_COLUMN in fields:
            self.column = fields.index(_HEADER_COLUMN)
            return True
        return False

    def _value(self, text):
        try:
            field = text if self.column < 0 else text.split(b",")[self.column]
            value = float(field)
        except (ValueError, IndexError):
            return None
        return value if np.isfinite(value) else None

    def _error(self, text):
        shown = text.decode("utf-8", "replace")
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        expected = ("an encoder angle in degrees (one number per line, or a CSV header with "
                    "an encoder_deg column first)" if self.column < 0
                    else f"a finite number of degrees in column {self.column + 1} (encoder_deg)")
        return InputError(f"line {self.line_number} of {self.name}: expected {expected}, "
                          f"got {shown!r}")

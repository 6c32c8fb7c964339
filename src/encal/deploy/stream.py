"""Correct a stream of encoder angles, text line by text line, in constant memory.

Input: one angle in degrees per line (or in another unit: radians, turns, an encoder's counts), or a CSV table
whose first data line is a header naming an ``encoder_deg`` column (or another, case-insensitive); blank lines and
lines starting with ``#`` are skipped. Output: one corrected angle per input
angle, in degrees, written as printf's ``%.12f`` (within 5e-13 degrees of the
double), or with ``exact=True`` as Python's ``repr`` (the shortest text that
reads back to the same double); ``nan`` for a malformed line when skipping them.

The stream is read in blocks of whatever is available (``read1``): a file
gives large blocks, corrected with NumPy in one go; a pipe fed one line at a
time gives one line, whose answer is written and flushed before the next is
read, so the corrector can sit in a live acquisition chain. A block whose lines
are all plain decimals (``[+-]digits[.digits]``, the common case), or plain CSV
rows whose column is, is read by :mod:`encal._core.decimal_text` in NumPy; any other
block line by line, the exact reader whose messages name the line and column.

A number is read as every reader of encal reads one (:mod:`encal._core.number_cells`: plain ASCII
decimals, not ``1_0`` nor full-width digits), and an angle beyond +-1e9 degrees (``MAX_ABS_DEG``, as in a
calibration CSV) is a malformed line: its answer would be the residue of a double that keeps less than
1e-5 arcmin of the angle within a turn (1e308 gave 295.99 degrees), a glitch or a column of counts.
"""

import numbers

import numpy as np

from .._core import csv_dialect as _csv
from .._core.angles import angle_unit
from .._core.decimal_text import format_fixed, parse_lines
from .._core.errors import InputError
from .._core.number_cells import MAX_ABS_DEG, is_plain_number_text, not_plain_note, read_number
from ..models.base import CHUNK_NUMBERS
from .._core.parameters import check_bool, check_type, invalid

__all__ = ["correct_stream", "BLOCK_BYTES", "MAX_LINE_BYTES"]

#: Largest read, in bytes: bounds the memory of one block of lines.
BLOCK_BYTES = 1 << 16
#: Longest line accepted, in bytes: bounds the memory when no newline comes.
MAX_LINE_BYTES = 1 << 16
_HEADER_COLUMN = "encoder_deg"
_UNIT_WORDS = {"deg": "degrees", "rad": "radians", "rev": "turns"}
#: The calibration CSV's direction column (values: encal._core.csv_dialect.DIRECTIONS), read for a directional model.
_DIRECTION_COLUMN = "direction"
_DIRECTION_PROBLEM = "the direction column"  # (a marker between _value and _error)
_LF, _CR, _COMMA = (np.uint8(ord(c)) for c in "\n\r,")


def _reuse_block_memory():
    """Have the C allocator keep the memory of one block's temporary arrays for the next block.

    glibc's ``malloc`` serves a request above its mmap threshold (128 KiB at first) with fresh pages, which
    the kernel zeroes by page faults, and unmaps them on ``free``: a model's temporaries for one block (a
    9-order Fourier model: 3,548 angles by 9 orders, 255 KB each) crossed it, and every block faulted its
    pages anew (5·10^4 page faults per 10^6 lines). Freeing one mmapped allocation raises the threshold to
    its size (mallopt(3), "dynamic mmap threshold"), so one allocation as large as a chunk's temporaries,
    freed at once, lets the blocks reuse heap memory. Importing SciPy used to do the same by chance.
    Elsewhere than glibc this costs one short-lived allocation and nothing else.
    """
    np.empty(CHUNK_NUMBERS, dtype=float)  # allocated and freed at once, never touched


def correct_stream(compensator, source, sink, *, skip_bad=False, name="stdin", direction=None, exact=False,
                   column=_HEADER_COLUMN, unit="deg"):
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
        models ignore it. None: the mean of the two directions, or, for a directional model, each row's
        own direction when the CSV header names a ``direction`` column (``+1``/``-1``/``cw``/``ccw``, as in a
        calibration); ``direction`` given with such a column is refused.
    exact : bool, default=False
        Write each corrected angle as Python's ``repr`` (the shortest text that reads back to the same
        double) instead of ``'%.12f'`` (within 5e-13 degrees, about five times faster to write).
    column : str, default='encoder_deg'
        The CSV header's column of the readings (any letter case); input of one number per line needs none.
    unit : str or AngleUnit, default='deg'
        Unit of the readings: ``'deg'``, ``'rad'``, ``'rev'`` or ``'counts:B'`` (codes of a B-bit encoder); they
        are converted to degrees before the correction, and the corrected angles are written in degrees. A
        reading beyond +-1e9 degrees once converted is malformed.

    Returns
    -------
    int
        Number of angles written.

    Raises
    ------
    InputError
        At the first malformed line (unless ``skip_bad``), naming its number
        and content; the answers to the lines before it are written first. When ``direction`` is given
        for a directional model and the CSV has a direction column, before anything is written.
    """
    caller = "correct_stream"
    check_bool(skip_bad, "skip_bad", caller)
    check_bool(exact, "exact", caller)
    check_type(name, str, "name", caller, "a str")
    check_type(column, str, "column", caller, "a str naming a CSV column")
    if not column.strip() or column.strip().lower() == _DIRECTION_COLUMN:
        raise invalid("column", caller, "the name of the CSV column of the readings (not the direction column)",
                      column)
    try:
        unit = angle_unit(unit)
    except ValueError as exc:
        raise InputError(f"The 'unit' parameter of {caller}: {exc}") from None
    if direction is not None and (isinstance(direction, bool) or not isinstance(direction, numbers.Integral)
                                  or direction not in (1, -1)):
        raise invalid("direction", caller, "+1 (forward), -1 (reverse) or None (unknown)", direction)
    _reuse_block_memory()
    model = getattr(compensator, "model", compensator)
    parser = _LineParser(skip_bad, name, read_direction=getattr(model, "kind", None) == "directional",
                         column=column, unit=unit)
    read = getattr(source, "read1", source.read)
    write = _format_repr if exact else format_fixed
    pending = b""
    written = 0
    while True:
        block = read(BLOCK_BYTES)
        data = pending + block
        cut = data.rfind(b"\n") + 1 if block else len(data)  # whole lines only, until the end
        pending = data[cut:]
        if len(pending) > MAX_LINE_BYTES:
            number = parser.line_number + data.count(b"\n", 0, cut) + 1
            raise InputError(f"line {number} of {name}: expected "
                             f"lines of at most {MAX_LINE_BYTES} bytes, got a longer one")
        values, directions, error = parser.parse(data[:cut] if block else data)
        if directions is not None and direction is not None:
            raise InputError(f"{name} names each reading's direction in its {_DIRECTION_COLUMN} column, and "
                             f"--direction {direction:+d} was given too; expected one of them (drop --direction to "
                             "correct each reading with its own direction)")
        if values.size:
            if unit.degrees_per_unit != 1.0:
                values = values * unit.degrees_per_unit
            sink.write(write(_correct(compensator, values, direction if directions is None else directions)))
            sink.flush()
            written += values.size
        if error is not None:
            raise error
        if not block:
            return written


def _correct(compensator, values, direction=None):
    """``direction``: None, +1, -1, or one per value (a direction column)."""
    per_value = np.ndim(direction) > 0

    def correct(mask):
        theta = values if mask is None else values[mask]
        if direction is None:
            return compensator.correct(theta)
        return compensator.correct(theta, direction[mask] if per_value and mask is not None else direction)

    good = np.isfinite(values)
    if good.all():
        return correct(None)
    corrected = np.full(values.shape, np.nan)
    corrected[good] = correct(good)
    return corrected


def _format_repr(values):
    return ("\n".join(map(repr, values.tolist())) + "\n").encode("ascii")


class _LineParser:
    """Turns blocks of lines into angles, remembering line numbers and the header.

    Lines are read in encal's one CSV dialect (:mod:`encal._core.csv_dialect`): ``#`` comments, quoted fields,
    and every row of a CSV table with as many fields as its header.
    """

    def __init__(self, skip_bad, name, read_direction=False, column=_HEADER_COLUMN, unit=None):
        self.skip_bad = skip_bad
        self.name = name
        self.header_column = column.strip().lower()
        self.unit = unit if unit is not None else angle_unit("deg")
        # the largest reading whose angle is within MAX_ABS_DEG degrees
        self.largest = MAX_ABS_DEG / self.unit.degrees_per_unit
        self.line_number = 0
        self.column = None  # None: no data line seen yet; -1: one angle per line
        self.n_fields = 1  # fields of every row: the header's
        self.read_direction = read_direction  # a directional model: read a direction column if there is one
        self.direction_column = None

    def parse(self, text):
        """Angles of ``text`` (bytes: whole lines, or the end of the input), their directions (None without a
        direction column that is read), and the error to raise after writing them (or None)."""
        if self.column is not None and self.direction_column is None and text.endswith(b"\n"):
            # (at most 6 integer digits: every reading parse_lines reads, in any unit, is within MAX_ABS_DEG degrees)
            values = (parse_lines(np.frombuffer(text, dtype=np.uint8)) if self.column < 0
                      else self._fast_column(text))
            if values is not None:
                self.line_number += values.size
                return values, None, None
        lines = text.split(b"\n") if text else []
        if text.endswith(b"\n"):
            lines.pop()  # the line end of the last line does not start another one
        if self.column is not None and not (self.column >= 0 and b"#" in text) and is_plain_number_text(text):
            fast = self._fast(lines)  # (not for a comment's fields, nor a block with '1_0' or a non-ASCII byte)
            if fast is not None:
                self.line_number += len(lines)
                return fast
        return self._slow(lines)

    def _fast_column(self, text):
        """The column's angles of a block of CSV rows, read in NumPy, or None (then line by line).

        Only for plain rows: no quotes, no comments, CR only before LF, and every row with the header's
        number of fields. The column's fields are copied into a buffer of their own, one per line, for
        :func:`~encal._core.decimal_text.parse_lines`.
        """
        if b'"' in text or b"#" in text or text.count(b"\r") != text.count(b"\r\n"):
            return None
        data = np.frombuffer(text, dtype=np.uint8)
        ends = np.flatnonzero(data == _LF)
        commas = np.flatnonzero(data == _COMMA)
        per_row = self.n_fields - 1
        if commas.size != ends.size * per_row or (
                per_row and np.any(np.searchsorted(commas, ends) != np.arange(1, ends.size + 1) * per_row)):
            return None
        commas = commas.reshape(ends.size, per_row)
        if self.column == 0:
            first = np.concatenate(([0], ends[:-1] + 1))
        else:
            first = commas[:, self.column - 1] + 1
        if self.column == per_row:
            last = ends - (data[np.maximum(ends - 1, 0)] == _CR)
        else:
            last = commas[:, self.column]
        lengths = last - first
        if np.any(lengths <= 0):
            return None
        stops = np.cumsum(lengths + 1)  # the fields, each followed by a line end, one after the other
        field = data[np.arange(stops[-1]) + np.repeat(first - (stops - lengths - 1), lengths + 1)]
        field[stops - 1] = _LF
        return parse_lines(field)

    def _fast(self, lines):
        # The common case of a block: every line a finite number (in the column) and no quotes, and a valid
        # direction in its column; else None.
        directions = None
        try:
            if self.column < 0:
                values = np.array([float(line) for line in lines])
            else:
                rows = [line.split(b",") for line in lines]
                if any(len(row) != self.n_fields or b'"' in line for row, line in zip(rows, lines)):
                    return None
                values = np.array([float(row[self.column]) for row in rows])
                if self.direction_column is not None:
                    directions = np.array([_csv.DIRECTIONS[row[self.direction_column].strip().lower().decode("ascii")]
                                           for row in rows], dtype=int)
        except (ValueError, KeyError, UnicodeDecodeError):  # (the careful reader reads '1.0' and says what is not)
            return None
        return (values, directions, None) if np.all(np.abs(values) <= self.largest) else None  # (False for NaN)

    def _slow(self, lines):
        values, directions = [], []

        def read(error=None):
            return (np.array(values), None if self.direction_column is None else np.array(directions, dtype=int),
                    error)

        for text in self._texts(lines):
            if _csv.is_skipped(text):
                continue
            if self.column is None and self._is_header(text):
                continue
            if self.column is None:
                self.column = -1
            value, direction, problem = self._value(text)
            if value is None:
                if not self.skip_bad:
                    return read(self._error(text, problem))
                value, direction = np.nan, 1
            values.append(value)
            directions.append(direction)
        return read()

    def _texts(self, lines):
        """The text of each line (split at LF), counting line numbers; a CR alone also ends a line."""
        for line in lines:
            text = line.decode("utf-8", "replace")
            if self.line_number == 0:
                text = text.removeprefix("\ufeff")
            for part in (_csv.split_lines(text) if "\r" in text else [text]) or [""]:
                self.line_number += 1
                yield part

    def _is_header(self, text):
        try:
            names = _csv.column_names(text)
        except _csv.QuotingError:
            return False
        if self.header_column in names:
            self.column = names.index(self.header_column)
            self.n_fields = len(names)
            if self.read_direction and _DIRECTION_COLUMN in names:
                self.direction_column = names.index(_DIRECTION_COLUMN)
            return True
        return False

    def _value(self, text):
        """The angle of a data line and its direction (None without a direction column), or None and what is
        wrong with the line (None: not a finite number)."""
        direction = None
        if self.column < 0:
            field = text
        else:
            try:
                cells = _csv.fields(text)
            except _csv.QuotingError as exc:
                return None, None, str(exc)
            if len(cells) != self.n_fields:
                count = f"{len(cells)} field" + ("s" if len(cells) != 1 else "")
                return None, None, (f"it has {count}, not {self.n_fields} as in the header"
                                    + (" (a decimal comma?)" if len(cells) > self.n_fields else ""))
            field = cells[self.column]
            if self.direction_column is not None:
                cell = cells[self.direction_column].strip(" \t")  # ASCII blanks only, as around a number
                direction = _csv.direction_of(cell)
                if direction is None:
                    return None, None, _DIRECTION_PROBLEM
        try:
            value = read_number(field)
        except ValueError:
            return None, None, not_plain_note(field).removeprefix("; ") or None
        if not np.isfinite(value):
            return None, None, None
        if abs(value) > self.largest:
            return None, None, (f"encal reads angles within +-{MAX_ABS_DEG:g} degrees, as in a calibration CSV "
                                "(beyond, a double keeps less than 1e-5 arcmin of the angle within a turn: a glitch, "
                                "or counts? say so with --enc-unit counts:B)")
        return value, direction, None

    def _error(self, text, problem=None):
        shown = text.strip()
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        words = _UNIT_WORDS.get(self.unit.name, "degrees")
        if self.unit.name == "counts":
            words = f"counts of a {self.unit.bits}-bit encoder"
        what = "an encoder angle in degrees" if self.unit.name == "deg" else f"an encoder reading in {words}"
        article = "an" if self.header_column[:1] in "aeiou" else "a"
        expected = (f"{what} (one number per line, or a CSV header with "
                    f"{article} {self.header_column} column first)" if self.column < 0
                    else f"a finite number of {words} in column {self.column + 1} ({self.header_column})")
        if problem == _DIRECTION_PROBLEM:
            expected, problem = (f"+1, -1, cw or ccw in column {self.direction_column + 1} ({_DIRECTION_COLUMN}), "
                                 "the direction of a reading for a directional model"), None
        why = f"; {problem}" if problem else ""
        return InputError(f"line {self.line_number} of {self.name}: expected {expected}, "
                          f"got {shown!r}{why}")

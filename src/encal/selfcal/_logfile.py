"""Reading the numeric CSV logs of self-calibration: named columns of finite numbers, one sentence per error."""

from pathlib import Path

import numpy as np

from .._core import csv_dialect as _csv
from .._core.errors import InputError
from .._core.number_cells import not_plain_note, read_number
from ..data.calibration import MAX_ABS_DEG  # the largest |angle| in a log, degrees, as in a calibration CSV

__all__ = ["read_columns"]


def _fail(path, line, message, column=None):
    where = f"{path}, line {line}" + (f", column {column}" if column is not None else "")
    raise InputError(f"{where}: {message}")


def _fields(path, number, line, lower=False):
    """The fields of a line in encal's CSV dialect (:mod:`encal._core.csv_dialect`)."""
    try:
        cells = _csv.fields(line)
    except _csv.QuotingError as exc:
        _fail(path, number, str(exc))
    return [cell.strip().lower() for cell in cells] if lower else cells


def read_columns(path, required, optional=(), what="log", labels=(), columns=None, units=None):
    """Numeric columns of a CSV log.

    Parameters
    ----------
    path : str or os.PathLike
    required : sequence of (str, str)
        ``(name, unit)`` of the columns that must be present (names matched case-insensitively).
    optional : sequence of (str, str)
        Numeric columns that may be present.
    what : str
        What the file is, for messages.
    labels : sequence of str
        Text columns that may be present (read as stripped strings).
    columns : dict of str to (str or int), optional
        The header name, or the number from 1, of a column where it is not called by its own name
        (``{'encoder_deg': 'angle'}``); the result still holds it under its own name.
    units : dict of str to str or AngleUnit, optional
        Unit of an angle column (deg, rad, rev, counts:B): its values are returned in degrees.

    Returns
    -------
    dict of str to ndarray
        Every present column; numeric ones as float arrays.

    A body of plain numbers (the rows after the header: digits, signs, points, exponents and commas, no
    comment, quote or blank line) is read by NumPy at C speed (:func:`encal._core.csv_numbers.plain_rows`);
    any other body, or a value NumPy does not read as a finite number, line by line, naming the line.
    """
    from .._core.angles import angle_unit

    path = Path(path)
    columns, units = dict(columns or {}), {name: angle_unit(unit) for name, unit in (units or {}).items()}
    chosen = {name: str(columns.get(name, name)).strip().lower() for name, _ in (*required, *optional)}
    chosen |= {name: str(columns.get(name, name)).strip().lower() for name in labels}
    expected = ", ".join(chosen[name] for name, _ in required)
    if not path.is_file():
        raise InputError(f"{path}: no such file; expected a {what} CSV with columns {expected}")
    raw = path.read_bytes()
    try:
        text = None if raw.isascii() else raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text; expected a {what} CSV with columns {expected}") from None
    head = _plain_head(raw) if text is None else None
    if head is not None:
        header_line, header, body = head
        records = None
    else:
        text = raw.decode("utf-8-sig") if text is None else text
        records = [(number, line) for number, line in enumerate(_csv.split_lines(text), start=1)
                   if not _csv.is_skipped(line)]
        if not records:
            raise InputError(f"{path}: the file is empty; expected a header naming {expected} and rows of numbers")
        header_line, header = records[0]
    names = _fields(path, header_line, header, lower=True)
    repeated = _csv.repeated_names(names)
    if repeated is not None:
        _fail(path, header_line, repeated)
    index = {}
    for name, column in chosen.items():
        if column in names:
            index[name] = names.index(column)
        elif column.isascii() and column.isdigit() and 1 <= int(column) <= len(names):
            index[name] = int(column) - 1
    missing = [chosen[name] for name, _ in required if name not in index]
    if missing:
        _fail(path, header_line, f"the header lacks {' and '.join(missing)}; expected a {what} with columns "
                                 f"{expected}")
    numeric = [(name, f"{units[name]} (as given)" if name in units and units[name].name != "deg" else unit)
               for name, unit in (*required, *optional) if name in index]
    # degrees per unit of each angle column, for the bound of MAX_ABS_DEG (a time or direction column has none)
    scales = {name: units[name].degrees_per_unit if name in units else 1.0
              for name, unit in (*required, *optional) if name in index and (name in units or "degrees" in unit)}
    text_columns = [name for name in labels if name in index]
    values = None
    if head is not None:
        values = _plain_columns(body, len(names), numeric, text_columns, index, scales)
        if values is None:  # the careful reader names the first problem
            records = [(number, line) for number, line in
                       enumerate(_csv.split_lines(raw.decode("ascii")), start=1) if not _csv.is_skipped(line)]
    if values is None:
        values = _careful_columns(path, records, names, numeric, text_columns, index, expected, scales)
    for name, unit in units.items():
        if name in values:
            values[name] = unit.to_degrees(values[name])
    return values


def _plain_head(raw):
    """``(header_line_number, header, body)`` of an ASCII file whose body is for :func:`plain_rows`, or None."""
    from ..data.calibration import _head_of_plain

    head = _head_of_plain(raw)
    if head is None:
        return None
    lines, _, body_start = head
    if not lines or _csv.is_skipped(lines[-1]):
        return None
    return len(lines), lines[-1], raw[body_start:]


def _plain_columns(body, n_columns, numeric, text_columns, index, scales):
    """The columns of a plain body (:func:`encal._core.csv_numbers.plain_rows`), or None: not plain, no rows, or
    a value that is not finite (or, in an angle column, beyond +-1e9 degrees). A label column of numbers is
    returned as the text of each label's first row."""
    from .._core.csv_numbers import plain_rows

    table = plain_rows(body, ",", n_columns)
    if table is None or table.shape[0] == 0:
        return None
    values = {}
    for name, _ in numeric:
        column = table[:, index[name]].copy()
        if not np.all(np.isfinite(column)):
            return None
        if name in scales and np.max(np.abs(column)) * scales[name] > MAX_ABS_DEG:
            return None
        values[name] = column
    if text_columns:
        ends = np.flatnonzero(np.frombuffer(body, dtype=np.uint8) == ord("\n"))
        if ends.size < table.shape[0]:
            ends = np.r_[ends, len(body)]
        starts = np.r_[0, ends[:-1] + 1]
        for name in text_columns:
            numbers, first, inverse = np.unique(table[:, index[name]], return_index=True, return_inverse=True)
            texts = [body[starts[row]:ends[row]].decode("ascii").rstrip("\r").split(",")[index[name]].strip()
                     for row in first]
            values[name] = np.asarray(texts)[inverse.reshape(-1)]
    return values


def _careful_columns(path, records, names, numeric, text_columns, index, expected, scales):
    """The columns read line by line, naming the line and column of the first bad value."""
    values = {name: [] for name, _ in numeric} | {name: [] for name in text_columns}
    for number, line in records[1:]:
        cells = _fields(path, number, line)
        if len(cells) != len(names):  # more: a decimal comma in a cell, or a column without a name
            _fail(path, number, f"has {len(cells)} fields, expected {len(names)} as in the header (encal's one CSV "
                                "dialect: name every column)")
        for name, unit in numeric:
            column = index[name]
            try:
                value = read_number(cells[column])
            except ValueError:
                value = float("nan")
            if not np.isfinite(value):
                _fail(path, number, f"{names[column]} is {cells[column].strip()[:40]!r}, expected a finite number "
                                    f"of {unit}{not_plain_note(cells[column])}", column + 1)
            if name in scales and abs(value) * scales[name] > MAX_ABS_DEG:
                _fail(path, number, f"{names[column]} is {cells[column].strip()[:40]!r}, expected an angle within "
                                    f"+-{MAX_ABS_DEG:g} degrees (beyond it a double cannot hold the angle within a "
                                    "turn to 1e-5 arcmin: a glitch, or a column in another unit?)", column + 1)
            values[name].append(value)
        for name in text_columns:
            values[name].append(cells[index[name]].strip())
    if len(records) == 1:
        raise InputError(f"{path}: the file has a header but no rows; expected rows of {expected}")
    return {name: np.asarray(column) for name, column in values.items()}

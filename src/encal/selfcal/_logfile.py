"""Reading the numeric CSV logs of self-calibration: named columns of finite numbers, one sentence per error."""

from pathlib import Path

import numpy as np

from .._core import csv_dialect as _csv
from .._core.errors import InputError

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


def read_columns(path, required, optional=(), what="log", labels=()):
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

    Returns
    -------
    dict of str to ndarray
        Every present column; numeric ones as float arrays.
    """
    path = Path(path)
    expected = ", ".join(name for name, _ in required)
    if not path.is_file():
        raise InputError(f"{path}: no such file; expected a {what} CSV with columns {expected}")
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text; expected a {what} CSV with columns {expected}") from None
    records = [(number, line) for number, line in enumerate(_csv.split_lines(text), start=1)
               if not _csv.is_skipped(line)]
    if not records:
        raise InputError(f"{path}: the file is empty; expected a header naming {expected} and rows of numbers")
    header_line, header = records[0]
    names = _fields(path, header_line, header, lower=True)
    repeated = _csv.repeated_names(names)
    if repeated is not None:
        _fail(path, header_line, repeated)
    missing = [name for name, _ in required if name not in names]
    if missing:
        _fail(path, header_line, f"the header lacks {' and '.join(missing)}; expected a {what} with columns "
                                 f"{expected}")
    numeric = [(name, unit) for name, unit in (*required, *optional) if name in names]
    text_columns = [name for name in labels if name in names]
    values = {name: [] for name, _ in numeric} | {name: [] for name in text_columns}
    for number, line in records[1:]:
        cells = _fields(path, number, line)
        if len(cells) != len(names):  # more: a decimal comma in a cell, or a column without a name
            _fail(path, number, f"has {len(cells)} fields, expected {len(names)} as in the header (encal's one CSV "
                                "dialect: name every column)")
        for name, unit in numeric:
            column = names.index(name)
            try:
                value = float(cells[column])
            except ValueError:
                value = float("nan")
            if not np.isfinite(value):
                _fail(path, number, f"{name} is {cells[column].strip()[:40]!r}, expected a finite number of {unit}",
                      column + 1)
            values[name].append(value)
        for name in text_columns:
            values[name].append(cells[names.index(name)].strip())
    if len(records) == 1:
        raise InputError(f"{path}: the file has a header but no rows; expected rows of {expected}")
    return {name: np.asarray(column) for name, column in values.items()}

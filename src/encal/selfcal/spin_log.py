"""The spin log CSV: ``time_s`` and ``encoder_deg`` columns, optionally a ``run`` label per speed."""

from pathlib import Path

import numpy as np

from ..errors import InputError
from .spin import SpinLog

__all__ = ["read_spin_log", "write_spin_log"]

_REQUIRED = ("time_s", "encoder_deg")


def _fail(path, line, message, column=None):
    where = f"{path}, line {line}" + (f", column {column}" if column is not None else "")
    raise InputError(f"{where}: {message}")


def read_spin_log(path):
    """Read a spin log: one or more runs of (time, encoder reading).

    The file is comma-separated UTF-8 text with ``#`` comment lines and a header naming ``time_s``
    (seconds) and ``encoder_deg`` (degrees), any case and order; an optional ``run`` column splits it
    into runs (one per speed). Other columns are ignored.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    list of SpinLog
        One per run, in the order of their first line.

    Raises
    ------
    InputError
        For a missing file, a header without the two columns, a line with too few fields, or a value that
        is not a finite number; naming the file, line and column.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file; expected a spin log CSV with columns time_s, encoder_deg")
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text; expected a spin log CSV with columns time_s, encoder_deg") from None
    records = [(number, line) for number, line in enumerate(text.splitlines(), start=1)
               if line.strip() and not line.lstrip().startswith("#")]
    if not records:
        raise InputError(f"{path}: the file is empty; expected a header 'time_s,encoder_deg' and rows of numbers")
    header_line, header = records[0]
    names = [cell.strip().strip('"').lower() for cell in header.split(",")]
    missing = [name for name in _REQUIRED if name not in names]
    if missing:
        _fail(path, header_line, f"the header lacks {' and '.join(missing)}; expected columns time_s (seconds) and "
                                 "encoder_deg (degrees), and optionally run")
    columns = [names.index(name) for name in _REQUIRED]
    run_column = names.index("run") if "run" in names else None
    times, readings, labels = [], [], []
    for number, line in records[1:]:
        cells = line.split(",")
        if len(cells) < len(names):
            _fail(path, number, f"has {len(cells)} fields, expected {len(names)} as in the header")
        for column, target, unit in ((columns[0], times, "seconds"), (columns[1], readings, "degrees")):
            try:
                value = float(cells[column])
            except ValueError:
                value = float("nan")
            if not np.isfinite(value):
                _fail(path, number, f"{names[column]} is {cells[column].strip()[:40]!r}, expected a finite number of "
                                    f"{unit}", column + 1)
            target.append(value)
        labels.append(cells[run_column].strip() if run_column is not None else "")
    if not times:
        raise InputError(f"{path}: the file has a header but no rows; expected rows of time_s, encoder_deg")
    times, readings, labels = np.asarray(times), np.asarray(readings), np.asarray(labels)
    logs = []
    for label in dict.fromkeys(labels):
        members = labels == label
        logs.append(SpinLog(times[members], readings[members], f"{path.name}" + (f" run {label}" if label else "")))
    return logs


def write_spin_log(path, logs):
    """Write spin logs as one CSV (atomically), each with its ``run`` label (1, 2, ...)."""
    from .._atomic import atomic_open

    with atomic_open(path, "w", newline="\n") as handle:
        handle.write("time_s,encoder_deg,run\n")
        for number, log in enumerate(logs, start=1):
            for t, e in zip(log.time_s, log.encoder_deg):
                handle.write(f"{float(t)!r},{float(e)!r},{number}\n")

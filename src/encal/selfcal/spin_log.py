"""The spin log CSV: ``time_s`` and ``encoder_deg`` columns, optionally a ``run`` label per speed."""

from pathlib import Path

from ._logfile import read_columns
from .spin import SpinLog

__all__ = ["read_spin_log", "write_spin_log"]


def read_spin_log(path, *, time_column="time_s", encoder_column="encoder_deg", encoder_unit="deg"):
    """Read a spin log: one or more runs of (time, encoder reading).

    The file is comma-separated UTF-8 text with ``#`` comment lines and a header naming ``time_s``
    (seconds) and ``encoder_deg`` (degrees), any case and order; an optional ``run`` column splits it
    into runs (one per speed). Other columns are ignored.

    Parameters
    ----------
    path : str or os.PathLike
    time_column, encoder_column : str or int, default='time_s', 'encoder_deg'
        The time (seconds) and the encoder column: a header name (any case) or a column number from 1.
    encoder_unit : str, default='deg'
        Unit of the encoder column: deg, rad, rev or counts:B.

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
    columns = read_columns(path, (("time_s", "seconds"), ("encoder_deg", "degrees")), what="spin log",
                           labels=("run",), columns={"time_s": time_column, "encoder_deg": encoder_column},
                           units={"encoder_deg": encoder_unit})
    labels = columns.get("run")
    if labels is None:
        return [SpinLog(columns["time_s"], columns["encoder_deg"], Path(path).name)]
    return [SpinLog(columns["time_s"][labels == label], columns["encoder_deg"][labels == label],
                    f"{Path(path).name}" + (f" run {label}" if label else ""))
            for label in dict.fromkeys(labels)]


def write_spin_log(path, logs):
    """Write spin logs as one CSV (atomically), each with its ``run`` label (1, 2, ...)."""
    from .._atomic import atomic_open

    with atomic_open(path, "w", newline="\n") as handle:
        handle.write("time_s,encoder_deg,run\n")
        for number, log in enumerate(logs, start=1):
            for t, e in zip(log.time_s, log.encoder_deg):
                handle.write(f"{float(t)!r},{float(e)!r},{number}\n")

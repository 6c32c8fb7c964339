"""The rows of a CSV body that holds plain numbers only, read in NumPy at C speed.

A dense calibration (10^5 to 10^6 rows of two angles) spent most of its reading time in Python: a list
of lines, the fields of each, ``float`` on each cell. When the body after the header is plain (ASCII
digits, signs, points, exponents, separators, LF or CRLF line ends, no comment, no quote, no blank
line), :func:`plain_rows` reads it with :func:`numpy.loadtxt` a few megabytes at a time. NumPy turns
text into doubles with the same routine as Python's ``float`` (``PyOS_string_to_double``), so the
numbers are the same, bit for bit.

A body already found plain in a regular file is best read by :func:`plain_file_rows`: ``np.loadtxt``
given a path reads the file in blocks, 1.3-1.4x faster than from bytes in memory (a file-like object
that is not a path is read line by line, one Python object per line).

Whenever the body is anything else, or NumPy refuses a piece of it (a field it cannot read, a row with
another number of fields), :func:`plain_rows` returns None and the caller reads the file line by line,
which names the file, line and column of the first problem. Nothing here raises for bad data.
"""

import io
import os
import warnings

import numpy as np

__all__ = ["plain_rows", "plain_file_rows", "plain_body", "line_count", "CHUNK_BYTES"]

#: Bytes of the body given to NumPy at a time (whole lines): the progress is reported after each piece.
CHUNK_BYTES = 1 << 22

_PLAIN_BYTES = b"0123456789.eE+-,\n\r \t"
#: Endings of a path that ``np.loadtxt`` opens as compressed (``numpy.lib._datasource``, exact letter case): a plain
#: text file so named is read from its bytes (a ``.xz`` one would raise ``lzma.LZMAError``, a traceback).
_DECOMPRESSED_SUFFIXES = (".gz", ".bz2", ".xz", ".lzma")
_LF, _CR = ord("\n"), ord("\r")


def plain_rows(body, separator, n_columns, progress=None):
    """The numbers of a plain body as an array of shape (rows, columns), or None if it is not plain.

    Parameters
    ----------
    body : bytes
        The lines after the header (or from the first row, for a file without one), ASCII.
    separator : {',', None}
        Comma, or None for blanks (spaces or tabs).
    n_columns : int
        Fields every row must have.
    progress : callable, optional
        Called as ``progress(done_bytes, total_bytes)`` after each piece.

    Returns
    -------
    ndarray of float of shape (rows, n_columns), or None
        None unless every line of ``body`` is a row of exactly ``n_columns`` numbers that NumPy reads
        (one row per line: a blank line, a comment or a quoted field makes it None).
    """
    total = len(body)
    if total == 0:
        return np.zeros((0, n_columns))
    if not plain_body(body):
        return None
    tables, start = [], 0
    while start < total:
        end = body.find(b"\n", min(start + CHUNK_BYTES, total) - 1) + 1 or total
        table = _read_piece(body[start:end], separator, n_columns)
        if table is None:
            return None
        tables.append(table)
        start = end
        if progress is not None:
            progress(start, total)
    return tables[0] if len(tables) == 1 else np.concatenate(tables)


def plain_body(data, start=0):
    """True if ``data[start:]`` (bytes) holds only the bytes of plain numbers, separators and LF or CRLF line ends
    (told without copying it)."""
    # bytes left once the plain ones are deleted (at C speed), none but the head's
    if len(data.translate(None, _PLAIN_BYTES)) != len(data[:start].translate(None, _PLAIN_BYTES)):
        return False
    if data.find(b"\r", start) < 0:  # a search, at memchr speed: a third of the time of a count
        return True
    return data.count(b"\r", start) == data.count(b"\r\n", start)  # a CR alone ends a line for the careful
    # reader, not for NumPy


#: Bytes compared at a time by :func:`line_count` (its comparison's temporary stays in the cache).
_COUNT_PIECE = 1 << 18


def line_count(data, start=0):
    """Lines of ``data[start:]`` (bytes): its LF, and one more for a last line without one (a quarter of the time of
    ``bytes.count``, no copy: compared a piece at a time, not into a fresh array as large as the file)."""
    view = np.frombuffer(data, dtype=np.uint8, offset=start)
    ends = sum(int(np.count_nonzero(view[i:i + _COUNT_PIECE] == ord("\n")))
               for i in range(0, view.size, _COUNT_PIECE))
    return ends + (len(data) > start and not data.endswith(b"\n"))


def plain_file_rows(path, skip_lines, n_rows, separator, n_columns):
    """The numbers of a plain body read by NumPy from the file itself, or None.

    Parameters
    ----------
    path : str or os.PathLike
        A regular file, ASCII, whose lines after the first ``skip_lines`` are a body that
        :func:`plain_body` accepts (the caller has checked its bytes).
    skip_lines : int
        Lines before the body (comments, blank lines, the header).
    n_rows : int
        Lines of the body: the rows expected.
    separator : {',', None}
        Comma, or None for blanks (spaces or tabs).
    n_columns : int
        Fields every row must have.

    Returns
    -------
    ndarray of float of shape (n_rows, n_columns), or None
        None if NumPy refuses a row or cannot read the file, or if it reads another number of rows (a
        blank line skipped, a file changed since its bytes were checked), or if NumPy would decompress the
        file for its name (:data:`_DECOMPRESSED_SUFFIXES`): the caller then reads the bytes it has.
    """
    if os.path.splitext(os.fspath(path))[1] in _DECOMPRESSED_SUFFIXES:
        return None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # "input contained no data": not plain
            table = np.loadtxt(os.fspath(path), delimiter=separator, skiprows=skip_lines, dtype=float,
                               comments=None, quotechar=None, ndmin=2, encoding="latin1")
    except (ValueError, Warning, OSError, UnicodeError):
        return None
    if table.shape != (n_rows, n_columns):
        return None
    return table


def _read_piece(piece, separator, n_columns):
    """One piece of whole lines as numbers, or None: NumPy refused it, or it skipped a line."""
    lines = piece.count(b"\n") + (not piece.endswith(b"\n"))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # "input contained no data" (blank lines only): not plain
            table = np.loadtxt(io.BytesIO(piece), delimiter=separator, dtype=float, comments=None, ndmin=2,
                               encoding=None)
    except (ValueError, Warning):
        return None
    if table.shape != (lines, n_columns):  # a blank line skipped, or every row one field short or over
        return None
    return table

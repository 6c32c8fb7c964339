"""The one CSV dialect of every file encal reads or writes.

- UTF-8 text; a byte-order mark at the start is ignored.
- Lines end with LF, CRLF or CR, and nothing else: a form feed, a vertical tab or a Unicode line
  separator (U+2028) inside a line is part of that line (``str.splitlines`` would split there and
  shift every later line number).
- A line whose first non-blank character is ``#`` is a comment; blank lines are skipped.
- Fields are separated by commas. A field may be quoted with double quotes (RFC 4180): it may then
  hold commas, and a doubled quote stands for one; spaces before the opening quote are ignored. A
  quoted field does not span lines. Calibrations also read a spreadsheet's export separated by
  semicolons or tabs (:func:`separator_of`), whose fields :func:`fields` splits the same way.
- A header names each column once (:func:`repeated_names`).
- Column names are compared without surrounding spaces and without regard to letter case.
- Every data row has exactly as many fields as the header: a row with more fields is a decimal
  comma (``98,03``) or a shifted row, one with fewer a truncated file. Extra columns are named in
  the header.

Writers quote a field only when it needs it (it holds a comma, a quote, a line break or surrounding
spaces), so a file written by encal reads back with the same fields.
"""

import re

__all__ = ["split_lines", "is_skipped", "fields", "column_names", "repeated_names", "is_number", "quote", "join",
           "QuotingError", "DIRECTIONS", "direction_of"]

#: The values of a ``direction`` column (lower case, without surrounding spaces) and the direction of travel each
#: means: +1 forward, -1 reverse.
DIRECTIONS = {"+1": 1, "1": 1, "-1": -1, "cw": 1, "ccw": -1, "+": 1, "-": -1}
#: A direction written as a number in ASCII (``1.0``, ``-1.000000e+00``, as NumPy's ``savetxt`` writes a float
#: column): read as one when it is exactly +1 or -1.
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")


def direction_of(cell):
    """The direction of travel a ``direction`` cell means: +1, -1, or None when it means neither.

    ``cell`` is the cell without surrounding blanks, any case: one of :data:`DIRECTIONS`, or a number that is
    exactly +1 or -1 (``1.0``, ``-1e0``).

    Examples
    --------
    >>> [direction_of(cell) for cell in ("+1", "CCW", "1.0", "-1.000000000000000000e+00", "0.5", "2")]
    [1, -1, 1, -1, None, None]
    """
    known = DIRECTIONS.get(cell.lower())
    if known is not None or not _NUMBER.fullmatch(cell):
        return known
    value = float(cell)
    return int(value) if value in (1.0, -1.0) else None

_LINE_END = re.compile(r"\r\n|\r|\n")
_NEEDS_QUOTES = re.compile(r'[",\r\n]|^\s|\s$')


class QuotingError(ValueError):
    """A line whose double quotes are not balanced (an opening quote never closed, text after a closing one)."""


def split_lines(text):
    """The lines of ``text``, split at LF, CRLF or CR only (see the module docstring)."""
    lines = _LINE_END.split(text)
    if lines and lines[-1] == "":
        lines.pop()  # the line end of the last line does not start another one
    return lines


def is_skipped(line):
    """True for a blank line or a ``#`` comment."""
    stripped = line.strip()
    return not stripped or stripped.startswith("#")


def fields(line, separator=","):
    """The fields of one line, unquoted (spaces around a quoted field are dropped, others kept).

    ``separator`` is the comma of encal's dialect, or the semicolon or tab of a spreadsheet's export
    (see :func:`separator_of`).

    Raises
    ------
    QuotingError
        If a quoted field is not closed, or text other than spaces follows its closing quote.
    """
    if '"' not in line:
        return line.split(separator)
    named = _SEPARATOR_NAMES[separator]
    result, start, end = [], 0, len(line)
    while True:
        first = start
        while first < end and line[first] in " \t" and line[first] != separator:
            first += 1
        if first == end or line[first] != '"':
            comma = line.find(separator, start)
            if comma < 0:
                result.append(line[start:])
                return result
            result.append(line[start:comma])
            start = comma + 1
            continue
        parts, at = [], first + 1
        while True:
            closing = line.find('"', at)
            if closing < 0:
                raise QuotingError(f"the quoted field starting at character {first + 1} is not closed")
            parts.append(line[at:closing])
            if line.startswith('"', closing + 1):  # a doubled quote stands for one
                parts.append('"')
                at = closing + 2
                continue
            break
        after = closing + 1
        while after < end and line[after] in " \t" and line[after] != separator:
            after += 1
        if after < end and line[after] != separator:
            raise QuotingError(f"text follows the closing quote at character {closing + 1}; expected {named}")
        result.append("".join(parts))
        if after == end:
            return result
        start = after + 1


#: How a message names each separator.
_SEPARATOR_NAMES = {",": "a comma", ";": "a semicolon", "\t": "a tab"}
_QUOTED = re.compile(r'"(?:[^"]|"")*"')


def separator_of(header):
    """The separator of a file whose header line is ``header``: ``','``, ``';'``, ``'\\t'``, or None for blanks.

    Looked for outside double quotes: a semicolon (a spreadsheet's export where the decimal mark is a
    comma: a first row of numbers has commas too), else a comma (encal's dialect), else a tab in a
    header that quotes its names (a spreadsheet's tab-separated export); else a header that splits at
    blanks into two or more names is separated by blanks (spaces or tabs, any number). A single name:
    a comma.
    """
    bare = _QUOTED.sub("", header)
    if ";" in bare:
        return ";"
    if "," in bare:
        return ","
    if '"' in header:
        return "\t" if "\t" in bare else ","
    return None if len(header.split()) >= 2 else ","


def column_names(line):
    """The header's column names: stripped and lower-case."""
    return [name.strip().lower() for name in fields(line)]


def repeated_names(names):
    """The problem with a header that names a column more than once, as a message part, or None.

    Names are compared as :func:`column_names` gives them (stripped, lower-case); empty names and names
    that are numbers (a first row of numbers is no header) are not compared. A reader that took the
    first of two ``encoder_deg`` columns would read the wrong one half the time, silently.
    """
    where = {}
    for index, name in enumerate(names, start=1):
        name = name.strip().lower()
        if name and not is_number(name):
            where.setdefault(name, []).append(index)
    repeated = {name: columns for name, columns in where.items() if len(columns) > 1}
    if not repeated:
        return None
    said = "; ".join(f"{name} {len(columns)} times (columns {', '.join(map(str, columns))})"
                     for name, columns in repeated.items())
    return f"the header names {said}; expected each column once, so that it is clear which to read"


def is_number(text):
    """Whether ``text`` reads as one number (``float()`` accepts it: ``1e3``, `` -2.5 ``, ``nan``)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def quote(value):
    """``value`` (text) as one field: quoted only if it needs it."""
    text = str(value)
    if _NEEDS_QUOTES.search(text):
        return '"' + text.replace('"', '""') + '"'
    return text


def join(values):
    """One line of fields (without its line end)."""
    return ",".join(quote(value) for value in values)

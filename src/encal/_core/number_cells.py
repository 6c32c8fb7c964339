"""The numbers encal reads from text: plain ASCII decimals, as every reader and option takes them.

A cell, a line of ``encal correct``'s input, an element of a firmware's table or a numeric option is read as
Python's ``float`` (or ``int``) reads it, but only if it is written in plain ASCII:

- optional blanks (spaces or tabs), an optional sign, ASCII digits with an optional decimal point, an optional
  exponent (``e`` or ``E``, optional sign, digits), optional blanks: ``1``, ``-2.5``, ``+.5``, ``1.``,
  ``6.02e23``, `` 10.5 ``; and ``nan``, ``inf``, ``infinity`` (any letter case, optional sign), which each
  reader then refuses as no finite number, naming them as such;
- nothing else. ``float`` also takes an underscore between digits (``1_000`` is 1000, so a glitch ``1_0`` is
  read as 10) and the digits of every script (``２0.01`` with a full-width two, ``١٢`` in Arabic-Indic digits),
  and a vertical tab or form feed around the number: a CSV is not Python source, and a digit no one can see
  as a digit is no number a user wrote on purpose. NumPy's reader of plain bodies
  (:mod:`encal._core.csv_numbers`) never sees such cells (their bytes are not plain), so the two readers
  agree.

:func:`read_number` and :func:`read_whole` raise ``ValueError`` for anything else, as ``float`` does;
:func:`not_plain_note` says why a text ``float`` would have read was refused, for the reader's message.
"""

__all__ = ["read_number", "read_whole", "is_plain_number_text", "not_plain_note", "plain_option", "MAX_ABS_DEG"]

#: Largest |angle| read from text, in degrees (2.8 million turns): up to it a double keeps the angle to better than
#: 1e-5 arcmin after wrapping to [0, 360); far beyond it the column is not angles in degrees (a glitch, counts, time
#: stamps). Every reader applies it (``encal.data.calibration.MAX_ABS_DEG`` is this one).
MAX_ABS_DEG = 1e9

# Besides ASCII digits, signs, points, exponents, blanks and the letters of nan/inf, float() and int() accept only
# these ASCII characters (any non-ASCII character is refused with them): an underscore between digits, and the
# vertical tab and form feed it strips as white space (LF and CR end a line before a cell is cut).
_NOT_PLAIN = ("_", "\x0b", "\x0c")


def is_plain_number_text(text):
    """False if ``text`` (str or bytes) holds a character that ``float`` reads but encal does not (an underscore,
    a non-ASCII digit or blank, a vertical tab or form feed); True otherwise (it may still be no number)."""
    try:  # three searches at memchr speed (a loop over _NOT_PLAIN took 8 times float()'s time)
        return text.isascii() and "_" not in text and "\x0b" not in text and "\x0c" not in text
    except TypeError:  # bytes: a str is not in them
        return text.isascii() and b"_" not in text and b"\x0b" not in text and b"\x0c" not in text


def read_number(text):
    """The float of a plain decimal ``text`` (str or bytes; see the module docstring).

    Raises
    ------
    ValueError
        If ``text`` is no number, or is one only as Python reads it (``1_000``, ``２0``).
    """
    try:  # is_plain_number_text inlined: this runs for every cell of a file the careful reader reads
        plain = text.isascii() and "_" not in text and "\x0b" not in text and "\x0c" not in text
    except TypeError:
        plain = is_plain_number_text(text)
    if plain:
        return float(text)
    raise ValueError(f"not a plain decimal number: {text!r}")


def read_whole(text):
    """The int of a plain whole number ``text`` (str: optional blanks and sign, ASCII digits).

    Raises
    ------
    ValueError
        If ``text`` is no whole number, or is one only as Python reads it (``1_0``, ``١٠``).
    """
    if not is_plain_number_text(text):
        raise ValueError(f"not a plain whole number: {text!r}")
    return int(text)


def not_plain_note(text):
    """Why ``text`` was refused though Python reads it as a number, as a clause for a message (starting with
    ``'; '``), or ``''`` if Python does not read it either (then the message says enough)."""
    try:
        float(text)
    except ValueError:
        try:
            int(text)
        except ValueError:
            return ""
    import unicodedata  # only for a message

    if isinstance(text, (bytes, bytearray)):
        text = text.decode("ascii")
    if "_" in text:
        return f"; an underscore between digits is not read (write {_shown(text.strip().replace('_', ''))!r})"
    strange = next((c for c in text if not c.isascii() or c in _NOT_PLAIN), None)
    if strange is None:
        return ""
    described = f"U+{ord(strange):04X} {unicodedata.name(strange, 'a control character')}"
    if unicodedata.decimal(strange, None) is not None:
        plain = "".join(str(unicodedata.decimal(c)) if unicodedata.decimal(c, None) is not None else c
                        for c in text.strip())
        return f"; only the ASCII digits 0-9 are read as digits, not {described} (write {_shown(plain)!r})"
    return f"; only ASCII spaces and tabs may surround a number, not {described}"


def _shown(text, limit=40):
    """``text`` for a message: whole if short, else its start and '...'."""
    return text if len(text) <= limit else text[:limit - 3] + "..."


def plain_option(kind=float):
    """An argparse ``type`` reading an option's number as :func:`read_number` (``kind=float``) or
    :func:`read_whole` (``kind=int``) does: ``--noise 1_0`` is a usage error (status 2) as ``--noise abc`` is.

    Its ``ArgumentTypeError`` names the value and, for a number only Python reads, why it is refused.
    """
    import argparse

    read = read_number if kind is float else read_whole
    expected = "a number" if kind is float else "a whole number"

    def parse(text):
        try:
            return read(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}{not_plain_note(text)}") from None

    parse.__name__ = kind.__name__  # argparse names the type in its messages
    return parse

"""Environment variables that change what encal writes, read and checked in one place."""

import os

from .errors import InputError
from .number_cells import read_whole

__all__ = ["source_date_epoch", "LATEST_SOURCE_DATE_EPOCH"]

#: 9999-12-31T23:59:59Z, the last second a date of the model file (four-digit years) can name.
LATEST_SOURCE_DATE_EPOCH = 253402300799


def source_date_epoch():
    """``SOURCE_DATE_EPOCH`` (seconds since 1970-01-01T00:00:00Z, reproducible-builds.org), or None if unset.

    Raises
    ------
    InputError
        If it is set but is not a whole number of seconds from 0 to 253402300799: the specification asks
        a build to stop on a malformed value rather than write another date.
    """
    text = os.environ.get("SOURCE_DATE_EPOCH")
    if text is None:
        return None
    try:
        seconds = read_whole(text)  # ASCII digits: not '1_700_000_000' nor another script's
    except ValueError:
        seconds = None
    if seconds is None or not 0 <= seconds <= LATEST_SOURCE_DATE_EPOCH:
        shown = text if len(text) <= 40 else text[:37] + "..."
        raise InputError(f"expected SOURCE_DATE_EPOCH to be a whole number of seconds since 1970 from 0 to "
                         f"{LATEST_SOURCE_DATE_EPOCH} (year 9999), got {shown!r}; unset it or fix it")
    return seconds

"""Calibration records per serial number: the store of an end-of-line station.

A record holds one calibration of one unit: its serial number, its epoch (1, 2, ... per serial, given
by the store, never reused or overwritten), the calibration itself (CSV text), the model file (JSON),
the figures (RMS before and after the correction, the held-out estimate), the grade, the station, the
time (UTC) and encal's version. A later calibration of the same unit is a new epoch.

Two back ends, one interface (:class:`Store`):

- SQLite (the default; Python's standard library): a file, ``encal-store.sqlite`` next to the user's
  data unless named, in WAL mode so that readers never wait for a writer;
- PostgreSQL, by URL (``postgresql://user@host/db``), for several stations writing at once, through
  ``psycopg`` 3 (``pip install encal[postgres]``).

Every write is one transaction, so concurrent writers (processes, stations) lose nothing and leave
nothing half-written; the records table refuses UPDATE and DELETE (a trigger), so a record, once
written, stays as it was. The one exception is the conversion of a store of layout 1 when it is opened:
its serial numbers are put in Unicode's composed form (NFC), two spellings of one unit made one history
(a file stored under both kept once), and what changed is kept in ``encal_serials_composed`` and
``encal_serials_composed_duplicates``.
"""

from ._store import (DEFAULT_STORE_NAME, GRADE_NONE, CopiedCalibrationError, Record, Store, StoreWriteError,
                     default_store_path, grade_of, open_store, parse_grades)

__all__ = ["Store", "Record", "open_store", "default_store_path", "DEFAULT_STORE_NAME", "parse_grades",
           "grade_of", "GRADE_NONE", "CopiedCalibrationError", "StoreWriteError"]

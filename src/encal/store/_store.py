"""The calibration store: one table of records, SQLite or PostgreSQL behind one interface."""

import abc
import dataclasses
import datetime
import hashlib
import math
import os
import re
import unicodedata
from pathlib import Path

from .._version import __version__
from .._core.errors import InputError

__all__ = ["Store", "Record", "open_store", "default_store_path", "DEFAULT_STORE_NAME", "parse_grades",
           "grade_of", "GRADE_NONE", "CopiedCalibrationError", "StoreWriteError"]

#: The store's file name when the user names none: next to the calibrations.
DEFAULT_STORE_NAME = "encal-store.sqlite"
#: The grade of a unit that meets no threshold.
GRADE_NONE = "out"
#: Version of the tables' layout, recorded in the store. 1: the first. 2: every serial in Unicode's composed form
#: (NFC) and an index on ``source_sha256``; a store of layout 1, whose serials may be decomposed (NFD, written by an
#: encal before it composed them), is converted when opened (:meth:`Store._upgrade`).
SCHEMA_VERSION = 2
#: Longest serial number, in characters.
MAX_SERIAL_CHARS = 200
#: Seconds a writer waits for another's transaction (SQLite's lock) before it gives up.
LOCK_TIMEOUT_S = 120.0

_SERIAL = re.compile(r"[^\x00-\x1f\x7f]+")

#: The record's columns after ``id``, in order: (name, SQLite type, PostgreSQL type).
_COLUMNS = (
    ("serial", "TEXT NOT NULL", "TEXT NOT NULL"),
    ("epoch", "INTEGER NOT NULL", "INTEGER NOT NULL"),
    ("created_utc", "TEXT NOT NULL", "TEXT NOT NULL"),
    ("station", "TEXT", "TEXT"),
    ("encal_version", "TEXT NOT NULL", "TEXT NOT NULL"),
    ("source_name", "TEXT", "TEXT"),
    ("source_sha256", "TEXT", "TEXT"),
    ("calibration_csv", "TEXT", "TEXT"),
    ("model_json", "TEXT NOT NULL", "TEXT NOT NULL"),
    ("model_kind", "TEXT", "TEXT"),
    ("n_points", "INTEGER", "INTEGER"),
    ("rms_before_arcmin", "REAL", "DOUBLE PRECISION"),
    ("rms_after_arcmin", "REAL", "DOUBLE PRECISION"),
    ("held_out_arcmin", "REAL", "DOUBLE PRECISION"),
    ("grade", "TEXT", "TEXT"),
)
_NAMES = tuple(name for name, _, _ in _COLUMNS)
_REFUSAL = "encal store: records are never overwritten or deleted; a new calibration is a new epoch"
#: What the conversion of layout 1 to 2 changed: each record's serial and epoch before and after.
_RENAMED_TABLE = "encal_serials_composed"
#: Records the conversion took out of a unit's history: the same calibration stored under its other spelling.
_DUPLICATES_TABLE = "encal_serials_composed_duplicates"


class CopiedCalibrationError(InputError):
    """A record whose calibration (the same bytes, by ``source_sha256``) is stored under another serial number.

    Attributes
    ----------
    serial : str
        The serial number the record was to be stored under.
    others : list of str
        The serial numbers the same calibration is stored under.
    """

    def __init__(self, serial, source_sha256, others):
        self.serial, self.source_sha256, self.others = serial, source_sha256, list(others)
        super().__init__(f"the calibration of {serial} (SHA-256 {source_sha256[:12]}...) is stored under "
                         f"{', '.join(self.others)} already; expected each unit's own calibration (a copied or "
                         f"misnamed file?), not the same bytes under a second serial number")


class StoreWriteError(InputError):
    """The store could not take a write at all (locked by another program past :data:`LOCK_TIMEOUT_S`, a full disk,
    a lost connection): nothing of the call is written, and no other record would be either, so a batch stops."""


@dataclasses.dataclass(frozen=True)
class Record:
    """One calibration of one unit, as stored.

    Attributes
    ----------
    serial : str
        The unit's serial number.
    epoch : int
        1 for the unit's first calibration, 2 for the next, ...
    created_utc : str
        When the record was written, ISO 8601 in UTC.
    station : str or None
        The station that calibrated the unit.
    encal_version : str
        encal's version that fitted the model.
    source_name : str or None
        The calibration file's name.
    source_sha256 : str or None
        SHA-256 of the calibration file's bytes (a file already stored is skipped by ``encal fleet fit``).
    calibration_csv : str or None
        The calibration file's text.
    model_json : str
        The model file's text (JSON).
    model_kind : str or None
        The model's kind.
    n_points : int or None
        Readings in the calibration.
    rms_before_arcmin, rms_after_arcmin : float or None
        RMS of the error before and after the correction, on the calibration (arc-minutes).
    held_out_arcmin : float or None
        The fit's estimate of its RMS error at readings it did not see (arc-minutes).
    grade : str or None
        The grade by the thresholds in force when it was written (:meth:`grade_limits` gives them).
    id : int or None
        The row's number in the store (in the order written).
    """

    serial: str
    epoch: int
    created_utc: str
    station: str | None
    encal_version: str
    source_name: str | None
    source_sha256: str | None
    calibration_csv: str | None
    model_json: str
    model_kind: str | None
    n_points: int | None
    rms_before_arcmin: float | None
    rms_after_arcmin: float | None
    held_out_arcmin: float | None
    grade: str | None
    id: int | None = None

    def model(self):
        """The stored model, rebuilt (:class:`encal.models.base.Model`); its checksum is verified."""
        import json

        from .._core.errors import ModelFileError
        from ..models.modelfile import model_from_dict

        where = f"the model of {self.serial} epoch {self.epoch} in the store"
        try:
            document = json.loads(self.model_json)
        except ValueError as exc:
            raise ModelFileError(f"{where}: is not JSON ({exc}); expected a model file") from None
        return model_from_dict(document, source=where)

    def grade_limits(self):
        """The thresholds :attr:`grade` was given by: ``[(name, largest held-out RMS in arc-minutes), ...]`` by
        increasing limit, as :func:`parse_grades` gives them, or None when the record holds none (fitted without
        ``--grades``, or by an encal that did not record them).

        ``encal fleet fit --grades`` records them in the model file's training metadata (``grades_arcmin``), which
        the model's checksum covers, so that a grade is never read against thresholds it was not computed with.
        """
        import json

        try:
            limits = json.loads(self.model_json).get("training", {}).get("grades_arcmin")
        except (ValueError, AttributeError):
            return None
        if not isinstance(limits, list) or not limits:
            return None
        try:
            return [(str(name), float(limit)) for name, limit in limits]
        except (TypeError, ValueError):
            return None


def default_store_path(data_dir):
    """The default store of calibrations in ``data_dir``: ``data_dir/encal-store.sqlite``."""
    return Path(data_dir) / DEFAULT_STORE_NAME


def is_url(location):
    """Whether ``location`` names a PostgreSQL server rather than an SQLite file."""
    return str(location).startswith(("postgresql://", "postgres://"))


def open_store(location, *, option="--store"):
    """Open (and create when new) the store at ``location``.

    Parameters
    ----------
    location : str or os.PathLike
        The path of an SQLite file (created when missing; its folder must exist), or a PostgreSQL URL
        ``postgresql://user:password@host:port/database`` (needs ``psycopg``: ``pip install encal[postgres]``).
    option : str, default='--store'
        The command-line option that named the store, as its messages name it (``--prior-from``).

    Returns
    -------
    Store

    Raises
    ------
    InputError
        If the file is not an SQLite database, its folder is missing, the server cannot be reached, or the
        driver is not installed, in one sentence.
    """
    if isinstance(location, bool) or not isinstance(location, (str, os.PathLike)):
        raise InputError(f"{option}: expected the path of an SQLite file or a postgresql:// URL, got "
                         f"{type(location).__name__}")
    if is_url(location):
        return _PostgresStore(str(location), option)
    return _SQLiteStore(Path(location), option)


def check_serial(serial):
    """``serial`` stripped and in Unicode's composed form (NFC), or InputError when it is empty, too long or holds
    control characters.

    The form is one, whatever wrote it: macOS names files in the decomposed form (NFD), so that ``SNÅ1.csv`` from a
    Mac and ``--serial SNÅ1`` typed elsewhere would otherwise be two units, the lookup finding the older one. Case
    and leading zeros are kept: ``sn1``, ``SN1`` and ``SN001`` are three units.
    """
    if not isinstance(serial, str):
        raise InputError(f"a serial number must be text; got {type(serial).__name__}")
    text = unicodedata.normalize("NFC", serial).strip()
    if not text or len(text) > MAX_SERIAL_CHARS or not _SERIAL.fullmatch(text):
        raise InputError(f"serial number {serial!r}: expected 1 to {MAX_SERIAL_CHARS} printable characters "
                         "(no line ends or control characters)")
    return text


def _composed(serial):
    """``serial`` in the form :func:`check_serial` gives, or as it is when that refuses it (it is not this
    conversion's to judge a stored serial)."""
    try:
        return check_serial(serial)
    except InputError:
        return serial


def _model_file_text(model, serial):
    """The model file's text of a record: ``model`` itself when it is one (checked: JSON, of a model file whose checksum
    holds), or a :class:`~encal.models.base.Model`'s file; ModelFileError otherwise.

    A record is never changed or deleted, so one whose model cannot be read (a path given for the file's text, a
    calibration, a file edited by hand) would break ``export --serial`` and the fleet report for good: it is refused
    before it is written.
    """
    import json

    from .._core.errors import ModelFileError
    from ..models.base import Model
    from ..models.modelfile import dumps, model_from_dict, model_to_dict

    if isinstance(model, Model):
        return dumps(model_to_dict(model))
    where = f"the model given for {serial}"
    if not isinstance(model, str):
        raise ModelFileError(f"{where}: expected a model file's text (JSON) or a Model, got {type(model).__name__}")
    try:
        document = json.loads(model)
    except ValueError as exc:
        raise ModelFileError(f"{where}: is not JSON ({exc}: {model[:40]!r}); expected a model file's text (JSON, "
                             "not its path) or a Model") from None
    if not isinstance(document, dict):
        raise ModelFileError(f"{where}: expected a model file's text (a JSON object), got JSON "
                             f"{type(document).__name__}")
    model_from_dict(document, source=where)
    return model


def _whole_count(value):
    """Whether ``value`` is a whole number >= 0 (360, numpy's int64, 360.0), not a bool or text."""
    if isinstance(value, (bool, str, bytes)):
        return False
    try:
        number = float(value)
    except (TypeError, ValueError):
        return False
    return number.is_integer() and number >= 0


def _iso_time(text):
    """Whether ``text`` is an ISO 8601 date and time (a record's ``created_utc``: the fleet report shows it)."""
    if not isinstance(text, str):
        return False
    try:
        datetime.datetime.fromisoformat(text)
    except ValueError:
        return False
    return True


def _figure(value, name):
    if value is None:
        return None
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise InputError(f"the record's {name} must be a finite number >= 0 (arc-minutes); got {value!r}") from None
    if not math.isfinite(value) or value < 0:
        raise InputError(f"the record's {name} must be a finite number >= 0 (arc-minutes); got {value!r}")
    return value


class Store(abc.ABC):
    """The records of a store, behind the same methods for SQLite and PostgreSQL.

    Use as a context manager, or call :meth:`close`. A store is used by one thread; processes (and
    stations) may each open their own at once.
    """

    location = None
    #: The command-line option that named the store, as messages name it.
    option = "--store"
    _placeholder = "?"

    # --- what a back end provides (SQLite and PostgreSQL below) -----------------------------------
    @abc.abstractmethod
    def _insert(self, rows, skip_stored=False):
        """Insert records (dicts of the columns) in one transaction, numbering their epochs; return [(id, epoch)].

        ``skip_stored``: a record whose serial and ``source_sha256`` are stored already is not inserted (None).
        A record whose ``source_sha256`` is stored under another serial raises :class:`CopiedCalibrationError`
        (:meth:`_stored_already`, inside the transaction) and nothing of the call is written.
        """

    @abc.abstractmethod
    def _query(self, sql, parameters=()):
        """The rows of one read-only query, with this back end's placeholders."""

    # --- the interface --------------------------------------------------------------------------
    def add(self, serial, model_json, *, calibration_csv=None, source_name=None, source_sha256=None,
            model_kind=None, n_points=None, rms_before_arcmin=None, rms_after_arcmin=None, held_out_arcmin=None,
            grade=None, station=None, created_utc=None):
        """Write a new record: the unit's next epoch, in one transaction.

        Parameters
        ----------
        serial : str
            The unit's serial number.
        model_json : str or Model
            The model file's text (as :meth:`Model.save` writes it), or the model itself. Checked before it is
            written: JSON of a model file whose checksum holds.
        calibration_csv : str, optional
            The calibration's text.
        source_name, source_sha256 : str, optional
            The calibration file's name and the SHA-256 of its bytes (default: of ``calibration_csv``).
        model_kind : str, optional
        n_points : int, optional
        rms_before_arcmin, rms_after_arcmin, held_out_arcmin : float, optional
            Figures in arc-minutes.
        grade, station : str, optional
        created_utc : str, optional
            ISO 8601 time; default now.

        Returns
        -------
        Record
            As stored, with its epoch and id.

        Raises
        ------
        CopiedCalibrationError
            When the same calibration (``source_sha256``) is stored under another serial number: which unit the
            readings belong to cannot be told, and a unit must never get another's model. Checked inside the
            write's transaction, so two writers of one file under two serials at once store it once.
        ModelFileError
            When ``model_json`` is not a model file (not JSON, a path for the text, another file, a checksum
            that fails): a record is never changed or deleted, so one whose model cannot be read is never written.
        InputError
            When the serial number or a figure is not usable.
        """
        values = self._values(serial, model_json, calibration_csv=calibration_csv, source_name=source_name,
                              source_sha256=source_sha256, model_kind=model_kind, n_points=n_points,
                              rms_before_arcmin=rms_before_arcmin, rms_after_arcmin=rms_after_arcmin,
                              held_out_arcmin=held_out_arcmin, grade=grade, station=station, created_utc=created_utc)
        (row_id, epoch), = self._insert([values])
        return Record(**{**values, "epoch": epoch, "id": row_id})

    def add_many(self, records, *, skip_stored=False):
        """Write several new records in one transaction (all or none); each is ``dict`` of :meth:`add`'s arguments.

        One transaction costs one commit (a disk flush), so a batch that writes its records in groups
        writes them several times faster than one by one.

        Parameters
        ----------
        records : sequence of dict
        skip_stored : bool, default=False
            Leave out a record whose serial number and calibration (``source_sha256``) are stored already,
            checked inside the transaction: two batches on the same files at once store each file once.

        Returns
        -------
        list of Record or None
            One per record; None for one left out.

        Raises
        ------
        CopiedCalibrationError
            When a record's calibration is stored under another serial number (as :meth:`add`); none is written.
        """
        for fields in records:
            if not isinstance(fields, dict):
                raise InputError(f"add_many: expected each record as a dict of add()'s arguments; got "
                                 f"{type(fields).__name__}")
        values = [self._values(**fields) for fields in records]
        if not values:
            return []
        placed = self._insert(values, skip_stored)
        return [None if where is None else Record(**{**v, "epoch": where[1], "id": where[0]})
                for v, where in zip(values, placed)]

    def _values(self, serial, model_json, *, calibration_csv=None, source_name=None, source_sha256=None,
                model_kind=None, n_points=None, rms_before_arcmin=None, rms_after_arcmin=None, held_out_arcmin=None,
                grade=None, station=None, created_utc=None):
        serial = check_serial(serial)
        model_json = _model_file_text(model_json, serial)
        if calibration_csv is not None and not isinstance(calibration_csv, str):
            raise InputError(f"the record of {serial} needs the calibration as text (the CSV's content); got "
                             f"{type(calibration_csv).__name__}")
        if n_points is not None and not _whole_count(n_points):
            raise InputError(f"the record of {serial} needs n_points as a whole number >= 0; got {n_points!r}")
        for name, text in (("grade", grade), ("station", station), ("source_name", source_name),
                           ("model_kind", model_kind)):
            if text is not None and not isinstance(text, str):
                raise InputError(f"the record of {serial} needs its {name} as text or None; got {text!r}")
        if created_utc is not None and not _iso_time(created_utc):
            raise InputError(f"the record of {serial} needs created_utc as an ISO 8601 date and time (as "
                             f"2026-11-28T12:00:00+00:00); got {created_utc!r}")
        if source_sha256 is None and calibration_csv is not None:
            source_sha256 = hashlib.sha256(calibration_csv.encode("utf-8")).hexdigest()
        values = {
            "serial": serial, "epoch": None,
            "created_utc": created_utc or datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "station": station, "encal_version": __version__, "source_name": source_name,
            "source_sha256": source_sha256, "calibration_csv": calibration_csv, "model_json": model_json,
            "model_kind": model_kind, "n_points": None if n_points is None else int(n_points),
            "rms_before_arcmin": _figure(rms_before_arcmin, "RMS before"),
            "rms_after_arcmin": _figure(rms_after_arcmin, "RMS after"),
            "held_out_arcmin": _figure(held_out_arcmin, "held-out estimate"), "grade": grade,
        }
        return values

    # --- shared by the back ends, inside their write transaction ----------------------------------
    def _stored_already(self, cursor, values, skip_stored):
        """Whether to leave out ``values`` (``skip_stored`` and its serial and calibration stored already); raise
        :class:`CopiedCalibrationError` when its calibration is stored under another serial.

        Called inside the write's transaction, after the back end's lock, so that what it reads cannot change before
        the commit (the batch's check at its start cannot see a batch running beside it).
        """
        sha256 = values["source_sha256"]
        if sha256 is None:
            return False
        mark = self._placeholder
        if skip_stored:
            cursor.execute(f"SELECT 1 FROM encal_records WHERE serial = {mark} AND source_sha256 = {mark}",
                           (values["serial"], sha256))
            if cursor.fetchone() is not None:
                return True
        cursor.execute(f"SELECT DISTINCT serial FROM encal_records WHERE source_sha256 = {mark} AND serial <> {mark} "
                       "ORDER BY serial", (sha256, values["serial"]))
        others = [row[0] for row in cursor.fetchall()]
        if others:
            raise CopiedCalibrationError(values["serial"], sha256, others)
        return False

    def _upgrade(self, cursor):
        """Bring the store's layout to :data:`SCHEMA_VERSION`, in the caller's transaction (which holds the write
        lock); refuse a store of a newer layout."""
        cursor.execute("SELECT value FROM encal_store WHERE key = 'schema_version'")
        version = int(cursor.fetchone()[0])
        if version > SCHEMA_VERSION:
            raise InputError(f"{self.option} {self.location}: "
                             f"written by a newer encal (layout {version}, this encal reads "
                             f"{SCHEMA_VERSION}); expected a store this encal reads (upgrade encal)")
        if version < SCHEMA_VERSION:
            self._convert(cursor, version)

    def _convert(self, cursor, version):
        """Convert a store of layout ``version`` to :data:`SCHEMA_VERSION`, in the caller's transaction."""
        self._hold_records(cursor)
        cursor.execute("CREATE INDEX IF NOT EXISTS encal_records_source ON encal_records (source_sha256)")
        self._compose_serials(cursor)
        cursor.execute(f"UPDATE encal_store SET value = {self._placeholder} WHERE key = 'schema_version'",
                       (str(SCHEMA_VERSION),))

    def _compose_serials(self, cursor):
        """Store every serial in the form :func:`check_serial` gives (Unicode's composed form, NFC), in the caller's
        transaction.

        Stores of layout 1 may hold a serial as it came: a file named on a Mac (decomposed, NFD) stored
        ``SN-Mu\u0308ller`` beside ``SN-M\u00fcller``, two units, of which a lookup by either spelling found one.
        The two spellings are one unit (as every write now takes them), so their records become one history: its
        epochs 1, 2, ... in the order the records were written (their row numbers, the order epochs are given
        in). A record whose calibration (``source_sha256``) an earlier record of the other spelling holds is the
        same file stored a second time, not a calibration (a batch run again skips it): it is moved, whole, to
        ``encal_serials_composed_duplicates``. Nothing is lost: each changed record's serial and epoch before are
        kept in ``encal_serials_composed`` (its epoch after NULL for one moved).
        """
        mark = self._placeholder
        cursor.execute("SELECT DISTINCT serial FROM encal_records")
        spellings = {}
        for (serial,) in cursor.fetchall():
            spellings.setdefault(_composed(serial), []).append(serial)
        changes = []  # (id, serial before, epoch before, serial after, epoch after or None when moved)
        for serial, written in spellings.items():
            if written == [serial]:
                continue
            marks = ", ".join(mark for _ in written)
            cursor.execute(f"SELECT id, serial, epoch, source_sha256 FROM encal_records WHERE serial IN ({marks}) "
                           "ORDER BY id", written)
            kept, spelled = 0, {}  # spelled: the spellings of the records kept, per calibration
            for row_id, before, epoch, sha256 in cursor.fetchall():
                if sha256 is not None and spelled.get(sha256, set()) - {before}:
                    changes.append((int(row_id), before, int(epoch), serial, None))
                    continue
                kept += 1
                spelled.setdefault(sha256, set()).add(before)
                after = kept if len(written) > 1 else int(epoch)
                if (before, epoch) != (serial, after):
                    changes.append((int(row_id), before, int(epoch), serial, after))
        if not changes:
            return
        cursor.execute(f"CREATE TABLE IF NOT EXISTS {_RENAMED_TABLE} (record_id {self._integer} NOT NULL, "
                       "serial_before TEXT NOT NULL, epoch_before INTEGER NOT NULL, serial TEXT NOT NULL, "
                       "epoch INTEGER, changed_utc TEXT NOT NULL)")
        cursor.execute(f"CREATE TABLE IF NOT EXISTS {_DUPLICATES_TABLE} AS SELECT * FROM encal_records WHERE 1 = 0")
        now = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
        self._records_changeable(cursor, True)
        for row_id, *_, epoch in changes:
            if epoch is None:
                cursor.execute(f"INSERT INTO {_DUPLICATES_TABLE} SELECT * FROM encal_records WHERE id = {mark}",
                               (row_id,))
                cursor.execute(f"DELETE FROM encal_records WHERE id = {mark}", (row_id,))
        renumbered = [change for change in changes if change[-1] is not None]
        # two passes, so that no (serial, epoch) is held twice between two updates: first each record to an epoch
        # of its own (minus its row number), then to its place in the merged history
        for row_id, _, _, serial, _ in renumbered:
            cursor.execute(f"UPDATE encal_records SET serial = {mark}, epoch = {mark} WHERE id = {mark}",
                           (serial, -row_id, row_id))
        for row_id, _, _, _, epoch in renumbered:
            cursor.execute(f"UPDATE encal_records SET epoch = {mark} WHERE id = {mark}", (epoch, row_id))
        self._records_changeable(cursor, False)
        for change in changes:
            cursor.execute(f"INSERT INTO {_RENAMED_TABLE} VALUES ({mark}, {mark}, {mark}, {mark}, {mark}, {mark})",
                           (*change, now))

    @abc.abstractmethod
    def _hold_records(self, cursor):
        """Keep other writers out of the records table until the caller's transaction ends."""

    @abc.abstractmethod
    def _records_changeable(self, cursor, changeable):
        """Lift (True) or restore (False) the triggers that refuse UPDATE and DELETE of a record, in the caller's
        transaction."""

    def history(self, serial):
        """Every record of ``serial``, by epoch (an empty list for an unknown serial)."""
        return self._records(f"WHERE serial = {self._placeholder} ORDER BY epoch", (check_serial(serial),))

    def latest(self, serial):
        """The latest record of ``serial``, or None."""
        found = self._records(f"WHERE serial = {self._placeholder} ORDER BY epoch DESC LIMIT 1",
                              (check_serial(serial),))
        return found[0] if found else None

    def latest_model(self, serial):
        """The latest record of ``serial``, or InputError naming the store when it has none."""
        record = self.latest(serial)
        if record is None:
            count = len(self.serials())
            raise InputError(f"--serial {serial}: no record in the store {self.location} ({count} serial numbers "
                             "there); expected the serial number of a unit fitted with 'encal fleet fit' "
                             "(--store names another store)")
        return record

    def records(self):
        """Every record, in the order written."""
        return self._records("ORDER BY id")

    def latest_records(self):
        """The latest record of every serial number, by serial number."""
        return self._records("WHERE NOT EXISTS (SELECT 1 FROM encal_records later WHERE later.serial = "
                             "encal_records.serial AND later.epoch > encal_records.epoch) ORDER BY serial")

    def serials(self):
        """The serial numbers in the store, sorted."""
        return [row[0] for row in self._query("SELECT DISTINCT serial FROM encal_records ORDER BY serial")]

    def stored_sources(self):
        """The set of ``(serial, source_sha256)`` already stored (what a resumed batch skips)."""
        return {(row[0], row[1]) for row in
                self._query("SELECT serial, source_sha256 FROM encal_records WHERE source_sha256 IS NOT NULL")}

    def count(self):
        """The number of records."""
        return int(self._query("SELECT COUNT(*) FROM encal_records")[0][0])

    def _records(self, clause, parameters=()):
        names = ", ".join(("id",) + _NAMES)
        rows = self._query(f"SELECT {names} FROM encal_records {clause}", parameters)
        return [Record(**dict(zip(_NAMES, row[1:])), id=row[0]) for row in rows]

    def close(self):
        """Close the connection."""
        connection, self._connection = getattr(self, "_connection", None), None
        if connection is not None:
            connection.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()

    def __repr__(self):
        return f"{type(self).__name__}({self.location!r})"


class _SQLiteStore(Store):
    """A store in an SQLite file (WAL mode: readers never wait for the writer)."""

    def __init__(self, path, option="--store"):
        import sqlite3

        self.location, self.option = str(path), option
        folder = path.parent if str(path.parent) else Path(".")
        if path.is_dir():
            raise InputError(f"{self.option} {path}: "
                             "is a folder; expected the path of an SQLite file (created when new) "
                             "or a postgresql:// URL")
        if not folder.is_dir():
            raise InputError(f"{self.option} {path}: "
                             f"the folder {folder} does not exist; expected the path of a file in an "
                             "existing folder")
        self._sqlite = sqlite3
        try:
            # isolation_level=None: the transactions are the explicit BEGIN IMMEDIATE ... COMMIT below
            self._connection = sqlite3.connect(path, timeout=LOCK_TIMEOUT_S, isolation_level=None)
            self._refuse_another_database(path)
            self._write_ahead_log()
            self._create()
        except sqlite3.DatabaseError as exc:
            self.close()
            raise InputError(f"{self.option} {path}: "
                             f"cannot be used as a store ({exc}); expected an SQLite file written "
                             "by encal, or the path of a new one") from None
        except InputError:
            self.close()
            raise

    def _refuse_another_database(self, path):
        """Refuse an SQLite database that holds tables and no store: opening it would write the store's tables into
        it and put it in WAL mode, even for a command that only reads (a report, ``export --serial``)."""
        tables = sorted(row[0] for row in self._connection.execute("SELECT name FROM sqlite_master WHERE type = "
                                                                   "'table' AND name NOT LIKE 'sqlite%'"))
        if tables and "encal_records" not in tables:
            shown = ", ".join(tables[:3]) + (", ..." if len(tables) > 3 else "")
            raise InputError(f"{self.option} {path}: "
                             f"is an SQLite database of other tables ({shown}), not a calibration "
                             "store; expected a store written by 'encal fleet fit', or the path of a new file")

    def _write_ahead_log(self):
        """Put the file in WAL mode, waiting for other openers as long as for a writer.

        SQLite answers "database is locked" at once, without its busy wait, to a connection that asks for WAL
        while another does the same: two batches started together on a new store, one of them refused
        (14 of 60 openers, 4 at a time on a new file).
        """
        import time

        deadline = time.monotonic() + LOCK_TIMEOUT_S
        while True:
            try:
                self._connection.execute("PRAGMA journal_mode=WAL")
                return
            except self._sqlite.OperationalError as exc:
                if "locked" not in str(exc) or time.monotonic() > deadline:
                    raise
                time.sleep(0.02)

    _integer = "INTEGER"

    def _create(self):
        columns = ", ".join(f"{name} {sqlite}" for name, sqlite, _ in _COLUMNS)
        with self._transaction() as cursor:
            cursor.execute(f"CREATE TABLE IF NOT EXISTS encal_records (id INTEGER PRIMARY KEY AUTOINCREMENT, "
                           f"{columns}, UNIQUE (serial, epoch))")
            cursor.execute("CREATE TABLE IF NOT EXISTS encal_store (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
            cursor.execute("INSERT OR IGNORE INTO encal_store VALUES ('schema_version', ?)", (str(SCHEMA_VERSION),))
            for event in ("UPDATE", "DELETE"):
                self._refuse(cursor, event)
            self._upgrade(cursor)
            cursor.execute("CREATE INDEX IF NOT EXISTS encal_records_source ON encal_records (source_sha256)")

    @staticmethod
    def _refuse(cursor, event):
        cursor.execute(f"CREATE TRIGGER IF NOT EXISTS encal_records_no_{event.lower()} BEFORE {event} ON "
                       f"encal_records BEGIN SELECT RAISE(ABORT, '{_REFUSAL}'); END")

    def _hold_records(self, cursor):
        pass  # BEGIN IMMEDIATE holds the file's write lock already

    def _records_changeable(self, cursor, changeable):
        for event in ("UPDATE", "DELETE"):
            if changeable:
                cursor.execute(f"DROP TRIGGER encal_records_no_{event.lower()}")
            else:
                self._refuse(cursor, event)

    class _Transaction:
        def __init__(self, connection):
            self.connection = connection

        def __enter__(self):
            # IMMEDIATE takes the write lock now, so that the epoch read and the insert see the same table
            self.connection.execute("BEGIN IMMEDIATE")
            return self.connection.cursor()

        def __exit__(self, kind, value, traceback):
            if kind is not None:
                self.connection.execute("ROLLBACK")
                return False
            try:
                self.connection.execute("COMMIT")
            except Exception:
                if self.connection.in_transaction:  # a commit that failed (a full disk): nothing of it stays
                    self.connection.execute("ROLLBACK")
                raise
            return False

    def _transaction(self):
        return self._Transaction(self._connection)

    def _insert(self, rows, skip_stored=False):
        try:
            return self._insert_rows(rows, skip_stored)
        except self._sqlite.Error as exc:
            raise StoreWriteError(f"{self.option} {self.location}: "
                                  f"could not be written ({exc}; nothing of this group of "
                                  f"{len(rows)} records was written); expected the store free of other writers within "
                                  f"{LOCK_TIMEOUT_S:g} s, on a disk with room") from None

    def _insert_rows(self, rows, skip_stored):
        names = ", ".join(_NAMES)
        marks = ", ".join("?" for _ in _NAMES)
        placed = []
        with self._transaction() as cursor:
            for values in rows:
                if self._stored_already(cursor, values, skip_stored):
                    placed.append(None)
                    continue
                cursor.execute("SELECT COALESCE(MAX(epoch), 0) + 1 FROM encal_records WHERE serial = ?",
                               (values["serial"],))
                epoch = int(cursor.fetchone()[0])
                cursor.execute(f"INSERT INTO encal_records ({names}) VALUES ({marks})",
                               [epoch if name == "epoch" else values[name] for name in _NAMES])
                placed.append((int(cursor.lastrowid), epoch))
        return placed

    def _query(self, sql, parameters=()):
        return self._connection.execute(sql, parameters).fetchall()


class _PostgresStore(Store):
    """A store in a PostgreSQL database, for several stations writing at once."""

    _placeholder = "%s"

    def __init__(self, url, option="--store"):
        self.location, self.option = _without_password(url), option
        try:
            import psycopg
        except ImportError:
            raise InputError(f"{self.option} {self.location}: "
                             "a PostgreSQL store needs the psycopg driver, which is not "
                             "installed; expected it installed (pip install 'encal[postgres]') or an SQLite file "
                             "path") from None
        self._psycopg = psycopg
        try:
            self._connection = psycopg.connect(url, connect_timeout=10)
            self._create()
        except psycopg.Error as exc:
            self.close()
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise InputError(f"{self.option} {self.location}: "
                             f"cannot be used as a store ({first}); expected a reachable "
                             "PostgreSQL server and a database the user may create tables in") from None
        except InputError:
            self.close()
            raise

    _integer = "BIGINT"

    def _create(self):
        columns = ", ".join(f"{name} {postgres}" for name, _, postgres in _COLUMNS)
        with self._connection.transaction(), self._connection.cursor() as cursor:
            # one creator at a time: concurrent CREATE TABLE IF NOT EXISTS can collide in the catalogue
            cursor.execute("SELECT pg_advisory_xact_lock(4242003200)")
            cursor.execute("SELECT to_regclass('encal_records')")
            if cursor.fetchone()[0] is None:
                cursor.execute(f"CREATE TABLE encal_records (id BIGSERIAL PRIMARY KEY, {columns}, "
                               "UNIQUE (serial, epoch))")
                cursor.execute("CREATE INDEX encal_records_source ON encal_records (source_sha256)")
                cursor.execute("CREATE TABLE IF NOT EXISTS encal_store (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
                cursor.execute("INSERT INTO encal_store VALUES ('schema_version', %s) ON CONFLICT DO NOTHING",
                               (str(SCHEMA_VERSION),))
                cursor.execute("CREATE OR REPLACE FUNCTION encal_records_refuse() RETURNS trigger LANGUAGE plpgsql "
                               f"AS $$ BEGIN RAISE EXCEPTION '{_REFUSAL}'; END $$")
                cursor.execute("CREATE TRIGGER encal_records_never_changed BEFORE UPDATE OR DELETE ON encal_records "
                               "FOR EACH ROW EXECUTE FUNCTION encal_records_refuse()")
            self._upgrade(cursor)

    def _convert(self, cursor, version):
        try:
            super()._convert(cursor, version)
        except self._psycopg.errors.InsufficientPrivilege as exc:
            raise InputError(f"{self.option} {self.location}: "
                             f"is of layout {version}, which its first opening converts to "
                             f"layout {SCHEMA_VERSION} (serial numbers composed), and this user may not "
                             f"({str(exc).strip().splitlines()[0]}); expected encal run once as the owner of the "
                             "store's tables") from None

    def _hold_records(self, cursor):
        # writers wait (readers do not) until the conversion commits: none adds a serial it has not seen
        cursor.execute("LOCK TABLE encal_records IN SHARE ROW EXCLUSIVE MODE")

    def _records_changeable(self, cursor, changeable):
        cursor.execute(f"ALTER TABLE encal_records {'DISABLE' if changeable else 'ENABLE'} TRIGGER "
                       "encal_records_never_changed")

    def _insert(self, rows, skip_stored=False):
        try:
            return self._insert_rows(rows, skip_stored)
        except self._psycopg.OperationalError as exc:  # the server gone, a lost connection, a full disk
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise StoreWriteError(f"{self.option} {self.location}: "
                                  f"could not be written ({first}; nothing of this group "
                                  f"of {len(rows)} records was written); expected a reachable PostgreSQL server with "
                                  "room in its database") from None

    def _insert_rows(self, rows, skip_stored):
        names = ", ".join(_NAMES)
        marks = ", ".join("%s" for _ in _NAMES)
        placed = []
        with self._connection.transaction(), self._connection.cursor() as cursor:
            # writers of one serial number take turns (a lock held to the commit), and so do writers of one
            # calibration (its SHA-256) under any serials, so that the check for a copy sees what the other wrote;
            # others run on. The locks are taken in the order of their keys, so that two writers never wait on
            # each other.
            locked = {values["serial"] for values in rows}
            locked.update(f"source_sha256:{values['source_sha256']}" for values in rows if values["source_sha256"])
            cursor.execute("SELECT DISTINCT hashtextextended(name, 0) FROM unnest(%s::text[]) AS name", (list(locked),))
            for key in sorted(row[0] for row in cursor.fetchall()):
                cursor.execute("SELECT pg_advisory_xact_lock(%s)", (key,))
            for values in rows:
                if self._stored_already(cursor, values, skip_stored):
                    placed.append(None)
                    continue
                cursor.execute("SELECT COALESCE(MAX(epoch), 0) + 1 FROM encal_records WHERE serial = %s",
                               (values["serial"],))
                epoch = int(cursor.fetchone()[0])
                cursor.execute(f"INSERT INTO encal_records ({names}) VALUES ({marks}) RETURNING id",
                               [epoch if name == "epoch" else values[name] for name in _NAMES])
                placed.append((int(cursor.fetchone()[0]), epoch))
        return placed

    def _query(self, sql, parameters=()):
        with self._connection.transaction(), self._connection.cursor() as cursor:
            cursor.execute(sql, parameters)
            return cursor.fetchall()


def _without_password(url):
    """The URL as messages show it: the password replaced by ***."""
    return re.sub(r"(://[^:/@]*:)[^@]*@", r"\1***@", url)


# --- grades ---------------------------------------------------------------------------------------

_GRADE = re.compile(r"\s*([A-Za-z0-9_+-]{1,20})\s*=\s*([0-9.eE+-]+)\s*(deg|arcmin|arcsec|°)?\s*")
_UNIT_ARCMIN = {None: 60.0, "deg": 60.0, "°": 60.0, "arcmin": 1.0, "arcsec": 1.0 / 60.0}


def parse_grades(text):
    """The thresholds of ``--grades``: ``'A=0.02,B=0.05'`` in degrees, or with a unit (``A=1.2arcmin``).

    Returns
    -------
    list of (str, float)
        (grade, largest held-out RMS in arc-minutes), by increasing threshold.

    Raises
    ------
    InputError
        Naming the part that is not ``NAME=NUMBER[deg|arcmin|arcsec]``.
    """
    grades = []
    for part in str(text).split(","):
        match = _GRADE.fullmatch(part)
        value = None
        if match:
            try:
                value = float(match.group(2)) * _UNIT_ARCMIN[match.group(3)]
            except ValueError:
                value = None
        if value is None or not math.isfinite(value) or value <= 0:
            raise InputError(f"--grades {text}: {part.strip()!r} is not NAME=LIMIT; expected grades such as "
                             "A=0.02,B=0.05 (degrees of held-out RMS error) or A=1.2arcmin")
        grades.append((match.group(1), value))
    names = [name for name, _ in grades]
    if len(set(names)) != len(names) or GRADE_NONE in names:
        raise InputError(f"--grades {text}: expected each grade named once, and none named '{GRADE_NONE}' (the "
                         "grade of a unit that meets no threshold)")
    return sorted(grades, key=lambda grade: grade[1])


def grade_of(error_arcmin, grades):
    """The first grade whose threshold ``error_arcmin`` meets (``<=``), :data:`GRADE_NONE` if none, None without
    thresholds or figure."""
    if not grades or error_arcmin is None:
        return None
    for name, limit in grades:
        if error_arcmin <= limit:
            return name
    return GRADE_NONE


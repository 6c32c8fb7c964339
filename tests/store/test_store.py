"""The calibration store (encal.store): epochs per serial, records never overwritten, concurrent writers.

Every test runs against SQLite, and against a real PostgreSQL server when ENCAL_TEST_POSTGRES_URL names one
(.ci/run starts one); otherwise the PostgreSQL cases skip with the reason.
"""

import json
import os
import re
import subprocess
import sys
import textwrap
import uuid

import pytest

from encal._core.errors import InputError
from encal.store import GRADE_NONE, grade_of, open_store, parse_grades
from tests import _paths
from tests.store.old_layout import write_layout_1_store

SRC = str(_paths.SRC)


def _postgres_url():
    """A URL to a fresh schema of the test server, and the function that drops it; or pytest.skip."""
    url = os.environ.get("ENCAL_TEST_POSTGRES_URL")
    if not url:
        pytest.skip("no PostgreSQL server for the tests: ENCAL_TEST_POSTGRES_URL is not set (.ci/run sets it)")
    psycopg = pytest.importorskip("psycopg", reason="the psycopg driver is not installed (pip install encal[postgres])")
    schema = "t_" + uuid.uuid4().hex[:12]
    try:
        with psycopg.connect(url, connect_timeout=5, autocommit=True) as connection:
            connection.execute(f"CREATE SCHEMA {schema}")
    except psycopg.Error as exc:
        pytest.skip(f"the PostgreSQL server at ENCAL_TEST_POSTGRES_URL cannot be reached: {exc}")

    def drop():
        with psycopg.connect(url, autocommit=True) as connection:
            connection.execute(f"DROP SCHEMA {schema} CASCADE")

    separator = "&" if "?" in url else "?"
    return f"{url}{separator}options=-csearch_path%3D{schema}", drop


@pytest.fixture(params=["sqlite", "postgres"])
def location(request, tmp_path):
    if request.param == "sqlite":
        yield str(tmp_path / "store.sqlite")
        return
    url, drop = _postgres_url()
    yield url
    drop()


#: a model file of a small Fourier model whose training metadata carries what the tests tell records apart by (the
#: store refuses a model that is not a model file); {training} is replaced by that metadata's JSON
_MODEL_FILE = textwrap.dedent("""
    import json
    from encal.models.fourier import FourierModel
    from encal.models.modelfile import dumps, model_to_dict
    def model_file(**training):
        model = FourierModel([0, 1], [0.0, 1.0], [0.0, 0.5], training={"payload": "x" * 2000, **training})
        return dumps(model_to_dict(model, reproducible=True))
""")
_namespace = {}
exec(_MODEL_FILE, _namespace)
_model_file = _namespace["model_file"]


def _model_json(label):
    return _model_file(label=label)


def _training(text):
    """The training metadata of a model file's text: what :func:`_model_file` was given."""
    return json.loads(text)["training"]


def test_epochs_count_per_serial_and_latest_is_the_last(location):
    with open_store(location) as store:
        first = store.add("SN-1", _model_json("a"), calibration_csv="reference_deg,encoder_deg\n0,0\n", grade="A")
        store.add("SN-2", _model_json("b"))
        second = store.add("SN-1", _model_json("c"), rms_after_arcmin=0.5)
        assert (first.epoch, second.epoch) == (1, 2)
        assert store.latest("SN-1").model_json == _model_json("c")
        assert [r.epoch for r in store.history("SN-1")] == [1, 2]
        assert store.history("nobody") == [] and store.latest("nobody") is None
        assert store.serials() == ["SN-1", "SN-2"]
        assert [(r.serial, r.epoch) for r in store.latest_records()] == [("SN-1", 2), ("SN-2", 1)]
        assert len(store.stored_sources()) == 1 and store.count() == 3
        assert first.source_sha256 is not None and first.grade == "A"
    with open_store(location) as again:  # reopened: the records are there
        assert again.count() == 3


def _assert_records_are_never_changed(store, location):
    """An UPDATE or DELETE of the records table is refused by the store's own trigger or rule."""
    for statement in ("UPDATE encal_records SET grade = 'A'", "DELETE FROM encal_records"):
        with pytest.raises(Exception, match="never overwritten"):
            if location.startswith("postgresql"):
                with store._connection.transaction():
                    store._connection.execute(statement)
            else:
                store._connection.execute(statement)


def test_a_record_is_never_overwritten_or_deleted(location):
    with open_store(location) as store:
        store.add("SN-1", _model_json("a"))
        _assert_records_are_never_changed(store, location)
        assert store.latest("SN-1").grade is None and store.count() == 1


_WRITER = _MODEL_FILE + textwrap.dedent("""
    import sys
    from encal.store import open_store
    location, writer, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    with open_store(location) as store:
        for index in range(count):
            serial = f"SN-{index % 3}"
            store.add(serial, model_file(writer=writer, index=index),
                      calibration_csv=f"{writer},{index}\\n" * 200, station=f"station-{writer}")
""")


@pytest.mark.parametrize("writers", [2, 8])
def test_concurrent_writers_lose_nothing(location, writers):
    """Processes writing the same serials at once: every record present, whole, epochs 1..n per serial."""
    count = 12
    environment = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    processes = [subprocess.Popen([sys.executable, "-c", _WRITER, location, str(w), str(count)], env=environment,
                                  stderr=subprocess.PIPE, text=True) for w in range(writers)]
    for process in processes:
        _, error = process.communicate(timeout=120)
        assert process.returncode == 0, error
    with open_store(location) as store:
        records = store.records()
        assert len(records) == writers * count
        written = {(_training(r.model_json)["writer"], _training(r.model_json)["index"]) for r in records}
        assert written == {(w, i) for w in range(writers) for i in range(count)}
        for record in records:
            document = _training(record.model_json)
            assert record.calibration_csv == f"{document['writer']},{document['index']}\n" * 200
            assert record.station == f"station-{document['writer']}"
        for serial in store.serials():
            assert [r.epoch for r in store.history(serial)] == list(range(1, len(store.history(serial)) + 1))


def test_a_file_that_is_no_database_is_refused_in_one_sentence(tmp_path):
    path = tmp_path / "notes.sqlite"
    path.write_text("these are not records\n" * 100)
    with pytest.raises(InputError, match=r"notes.sqlite: cannot be used as a store .*expected an SQLite file"):
        open_store(path)
    with pytest.raises(InputError, match="does not exist"):
        open_store(tmp_path / "missing" / "store.sqlite")


def test_a_bad_serial_is_refused(tmp_path):
    with open_store(tmp_path / "s.sqlite") as store, pytest.raises(InputError, match="printable characters"):
        store.add("SN\n2", _model_json("x"))


def test_grades_in_degrees_by_default_or_with_a_unit():
    grades = parse_grades("B=0.05,A=0.02")
    assert grades == [("A", pytest.approx(1.2)), ("B", pytest.approx(3.0))]
    assert parse_grades("A=30arcsec") == [("A", pytest.approx(0.5))]
    assert grade_of(1.0, grades) == "A" and grade_of(2.0, grades) == "B" and grade_of(3.5, grades) == GRADE_NONE
    assert grade_of(1.0, []) is None
    for bad in ("A", "A=x", "A=-1", "A=1,A=2", "out=1"):
        with pytest.raises(InputError, match="--grades"):
            parse_grades(bad)


def test_a_calibration_stored_meanwhile_is_left_out_inside_the_transaction(location):
    """Two batches on the same file at once: add_many(skip_stored=True) stores it once."""
    with open_store(location) as store:
        model_json = _model_json("x")
        first = store.add_many([{"serial": "SN-1", "model_json": model_json, "source_sha256": "ab"}], skip_stored=True)
        again = store.add_many([{"serial": "SN-1", "model_json": model_json, "source_sha256": "ab"},
                                {"serial": "SN-1", "model_json": model_json, "source_sha256": "cd"}], skip_stored=True)
        assert first[0].epoch == 1 and again[0] is None and again[1].epoch == 2
        assert store.count() == 2


def test_a_serial_number_is_one_whatever_its_unicode_form(location):
    """Composed (NFC) and decomposed (NFD, as macOS names files) spellings of one serial are one unit."""
    import unicodedata

    composed, decomposed = (unicodedata.normalize(form, "SNÅ1") for form in ("NFC", "NFD"))
    with open_store(location) as store:
        store.add(composed, _model_json("x"))
        store.add(decomposed, _model_json("x"))
        assert store.serials() == [composed]
        assert [r.epoch for r in store.history(decomposed)] == [1, 2] and store.latest(composed).epoch == 2



def test_a_store_opened_while_another_opener_turns_it_to_wal_waits(tmp_path, monkeypatch):
    """SQLite answers "database is locked" at once, without its busy wait, to a request for WAL mode made while
    another connection makes the same: 4 processes opening a new store at one instant, 15 times, had 14 of their
    60 openings refused ("cannot be used as a store (database is locked)"). The first two requests fail here."""
    import sqlite3

    connect = sqlite3.connect
    refusals = []

    class Busy:
        def __init__(self, connection):
            self.connection = connection

        def execute(self, sql, *parameters):
            if sql.startswith("PRAGMA journal_mode") and len(refusals) < 2:
                refusals.append(sql)
                raise sqlite3.OperationalError("database is locked")
            return self.connection.execute(sql, *parameters)

        def __getattr__(self, name):
            return getattr(self.connection, name)

    monkeypatch.setattr(sqlite3, "connect", lambda *args, **kwargs: Busy(connect(*args, **kwargs)))
    with open_store(tmp_path / "s.sqlite") as store:
        store.add("SN1", _model_json("x"))
        assert store.count() == 1
    assert len(refusals) == 2


def test_odd_serial_numbers_are_units_of_their_own_found_as_written(location):
    """Quotes, ';', '/', '..', case and leading zeros: each serial its own unit, its own model."""
    serials = ["SN'; DROP TABLE encal_records;--", 'SN"1', "lot/7", "..", "%", "SN_1", "sn1", "SN1", "SN01"]
    with open_store(location) as store:
        for serial in serials:
            store.add(serial, _model_json(serial))
        store.add(" SN1 ", _model_json("SN1 again"))
        assert sorted(store.serials()) == sorted(serials)
        for serial in serials:
            assert _training(store.latest(serial).model_json)["label"] == ("SN1 again" if serial == "SN1" else serial)
        assert store.latest("SN%") is None and store.latest("SN_") is None  # no pattern matching


# --- store6: stores of layout 1 with decomposed serials; the copied-file check inside the write transaction ---------

_MULLER = "SN-M\u00fcller"  # composed (NFC), as typed
_MULLER_NFD = "SN-Mu\u0308ller"  # decomposed (NFD), as macOS names a file


def _layout_1_store(location, rows):
    """A store of layout 1 holding ``rows`` ((serial, epoch, label[, label of the calibration]), in the order
    written); each calibration's SHA-256 is 'sha-' and its label."""
    write_layout_1_store(location, [{"serial": serial, "epoch": epoch, "source_sha256": f"sha-{(*row, label)[0]}",
                                     "model_json": _model_json(label)} for serial, epoch, label, *row in rows])


def _label(record):
    return _training(record.model_json)["label"]


def test_an_old_store_with_decomposed_serials_is_converted_when_opened(location):
    """A unit calibrated on a Mac (NFD file name), then elsewhere (NFC), then on the Mac again, in a store of layout 1:
    two units there, and --serial with the composed name found its epoch 1 of two (the middle calibration) with exit
    0. Converted on open: one unit, its three calibrations its epochs 1, 2, 3 in the order written; the Mac's first
    file, stored again under the composed name (a batch run on a copy of the folder), is no fourth calibration."""
    _layout_1_store(location, [(_MULLER_NFD, 1, "mac-1"), ("SN3", 1, "sn3"), (_MULLER, 1, "station-1"),
                               (_MULLER_NFD, 2, "mac-2"), ("SN\u00c52".replace("\u00c5", "A\u030a"), 1, "only-nfd"),
                               (_MULLER, 2, "mac-1 again", "mac-1")])
    with open_store(location) as store:
        assert store.serials() == sorted([_MULLER, "SN3", "SN\u00c52"])
        for spelling in (_MULLER, _MULLER_NFD):
            assert _label(store.latest_model(spelling)) == "mac-2"
            assert [(r.epoch, _label(r)) for r in store.history(spelling)] == [(1, "mac-1"), (2, "station-1"),
                                                                               (3, "mac-2")]
        assert [(r.epoch, _label(r)) for r in store.history("SN\u00c52")] == [(1, "only-nfd")]
        assert [(r.serial, r.epoch, _label(r)) for r in store.records()][1] == ("SN3", 1, "sn3")
        assert {(r.serial, _label(r)) for r in store.latest_records()} == {(_MULLER, "mac-2"), ("SN3", "sn3"),
                                                                           ("SN\u00c52", "only-nfd")}
        # what was changed is kept; the records are as unchangeable as before; the next write is epoch 4
        changed = store._query("SELECT serial_before, epoch_before, serial, epoch FROM encal_serials_composed "
                               "ORDER BY record_id")
        assert [tuple(row) for row in changed] == [(_MULLER_NFD, 1, _MULLER, 1), (_MULLER, 1, _MULLER, 2),
                                                   (_MULLER_NFD, 2, _MULLER, 3),
                                                   ("SNA\u030a2", 1, "SN\u00c52", 1), (_MULLER, 2, _MULLER, None)]
        duplicates = store._query("SELECT id, serial, epoch, source_sha256 FROM encal_serials_composed_duplicates")
        assert [tuple(row) for row in duplicates] == [(6, _MULLER, 2, "sha-mac-1")]
        assert store._query("SELECT value FROM encal_store WHERE key = 'schema_version'")[0][0] == "2"
        _assert_records_are_never_changed(store, location)
        assert store.add(_MULLER_NFD, _model_json("mac-3")).epoch == 4
    with open_store(location) as again:  # converted once: a second opening changes nothing
        assert again.count() == 6 and len(again._query("SELECT * FROM encal_serials_composed")) == 5


def test_a_station_that_may_not_convert_an_old_store_is_told_who_may(location, monkeypatch):
    """PostgreSQL: the conversion changes the tables (ALTER TABLE), which only their owner may do; a station's user
    with SELECT and INSERT was refused as a store that 'cannot be used', without why."""
    if not location.startswith("postgresql"):
        pytest.skip("SQLite has no users: whoever may write the file may convert it")
    import psycopg

    from encal.store._store import Store

    _layout_1_store(location, [(_MULLER_NFD, 1, "mac-1")])

    def refused(self, cursor):
        raise psycopg.errors.InsufficientPrivilege("must be owner of table encal_records")

    monkeypatch.setattr(Store, "_compose_serials", refused)
    with pytest.raises(InputError, match=r"is of layout 1, which its first opening converts to layout 2 \(serial "
                                         r"numbers composed\), and this user may not \(must be owner of table "
                                         r"encal_records\); expected encal run once as the owner"):
        open_store(location)
    monkeypatch.undo()
    with open_store(location) as store:  # nothing was half converted
        assert store.serials() == [_MULLER]


def test_a_store_of_a_newer_layout_is_refused(location):
    with open_store(location) as store:
        store.add("SN1", _model_json("x"))
        if location.startswith("postgresql"):
            with store._connection.transaction():
                store._connection.execute("UPDATE encal_store SET value = '99' WHERE key = 'schema_version'")
        else:
            store._connection.execute("UPDATE encal_store SET value = '99' WHERE key = 'schema_version'")
    with pytest.raises(InputError, match=r"written by a newer encal \(layout 99, this encal reads 2\)"):
        open_store(location)


def test_a_calibration_stored_under_another_serial_is_refused(location):
    from encal.store import CopiedCalibrationError

    csv = "reference_deg,encoder_deg\n0,0.01\n"
    with open_store(location) as store:
        store.add("SN1", _model_json("a"), calibration_csv=csv)
        with pytest.raises(CopiedCalibrationError, match=r"the calibration of SN2 \(SHA-256 [0-9a-f]{12}\.\.\.\) is "
                                                         r"stored under SN1 already; expected each unit's own"):
            store.add_many([{"serial": "SN3", "model_json": _model_json("x"), "calibration_csv": "other"},
                            {"serial": "SN2", "model_json": _model_json("x"), "calibration_csv": csv}])
        assert store.count() == 1  # all or none: SN3 was not written either
        assert store.add("SN1", _model_json("b"), calibration_csv=csv).epoch == 2  # its own unit's: a new epoch


class _HeldAfterInsert:
    """A store connection that, once it has inserted a record, holds its transaction open until ``release`` is set."""

    def __init__(self, connection, inserted, release):
        self._connection, self._inserted, self._release = connection, inserted, release

    def _hold(self, sql):
        if sql.startswith("INSERT INTO encal_records"):
            self._inserted.set()
            assert self._release.wait(60)

    def execute(self, sql, *parameters):
        result = self._connection.execute(sql, *parameters)
        self._hold(sql)
        return result

    def cursor(self):
        held = self

        class Cursor:
            def __init__(self, cursor):
                self._cursor = cursor

            def execute(self, sql, *parameters):
                result = self._cursor.execute(sql, *parameters)
                held._hold(sql)
                return result

            def __enter__(self):
                self._cursor.__enter__()
                return self

            def __exit__(self, *exc_info):
                return self._cursor.__exit__(*exc_info)

            def __getattr__(self, name):
                return getattr(self._cursor, name)

        return Cursor(self._connection.cursor())

    def __getattr__(self, name):
        return getattr(self._connection, name)


def test_two_writers_of_one_calibration_under_two_serials_at_once_store_it_once(location):
    """The first writer holds its transaction open after its insert; the second, under another serial, must wait for
    it and then be refused. Checked only before the write (as the batch did at its start), or without the lock on the
    calibration (PostgreSQL: writers of different serials do not wait on each other), both were stored."""
    import threading

    from encal.store import CopiedCalibrationError

    inserted, release, opened, go = (threading.Event() for _ in range(4))
    outcome = {}

    def first():
        with open_store(location) as store:
            store._connection = _HeldAfterInsert(store._connection, inserted, release)
            outcome["first"] = store.add("SN1", _model_json("x"), source_sha256="ab" * 32)
            store._connection = store._connection._connection

    def second():
        with open_store(location) as store:
            opened.set()
            assert go.wait(60)
            try:
                outcome["second"] = store.add("SN9", _model_json("x"), source_sha256="ab" * 32)
            except CopiedCalibrationError as exc:
                outcome["second"] = exc

    open_store(location).close()  # created before either writer
    threads = [threading.Thread(target=second), threading.Thread(target=first)]
    threads[0].start()
    assert opened.wait(60)
    threads[1].start()
    assert inserted.wait(60)
    go.set()
    threads[0].join(1.0)
    waited = threads[0].is_alive()  # the second writer waits for the first's commit
    release.set()
    for thread in threads:
        thread.join(60)
    assert waited and outcome["first"].epoch == 1
    assert isinstance(outcome["second"], CopiedCalibrationError) and outcome["second"].others == ["SN1"]
    with open_store(location) as store:
        assert [(r.serial, r.source_sha256) for r in store.records()] == [("SN1", "ab" * 32)]


_OPENER = _MODEL_FILE + textwrap.dedent("""
    import sys
    from encal.store import open_store
    location, opener = sys.argv[1], int(sys.argv[2])
    with open_store(location) as store:
        store.add("SN-M\\u00fcller", model_file(label="opener-%d" % opener))
""")


def test_openers_of_an_old_store_at_once_convert_it_once(location):
    """4 processes open a store of layout 1 together and each writes the unit's next calibration: the conversion is
    made once (one set of changes kept), and the unit's epochs are 1..6 without a gap or a repeat."""
    _layout_1_store(location, [(_MULLER_NFD, 1, "mac-1"), (_MULLER, 1, "station-1")])
    environment = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    processes = [subprocess.Popen([sys.executable, "-c", _OPENER, location, str(k)], env=environment,
                                  stderr=subprocess.PIPE, text=True) for k in range(4)]
    for process in processes:
        _, error = process.communicate(timeout=120)
        assert process.returncode == 0, error
    with open_store(location) as store:
        history = store.history(_MULLER)
        assert [r.epoch for r in history] == [1, 2, 3, 4, 5, 6]
        assert [_label(r) for r in history[:2]] == ["mac-1", "station-1"]
        assert sorted(_label(r) for r in history[2:]) == [f"opener-{k}" for k in range(4)]
        assert len(store._query("SELECT * FROM encal_serials_composed")) == 2


@pytest.mark.parametrize("layout", [1, 2])
def test_the_copy_check_is_a_lookup_in_an_index(location, layout):
    """The check made inside every write's transaction reads the records of one SHA-256 through an index, in a new
    store and in a converted one: a scan of the table per record took 1.6 s per flush of 64 records on 20,200
    records (benchmarks/bench_store.py)."""
    if layout == 1:
        _layout_1_store(location, [(_MULLER_NFD, 1, "mac-1")])
    with open_store(location) as store:
        if location.startswith("postgresql"):
            found = store._query("SELECT indexdef FROM pg_indexes WHERE indexname = 'encal_records_source' AND "
                                 "schemaname = current_schema()")
            assert len(found) == 1 and "(source_sha256)" in found[0][0]
        else:
            plan = store._query("EXPLAIN QUERY PLAN SELECT DISTINCT serial FROM encal_records WHERE source_sha256 = ? "
                                "AND serial <> ?", ("ab", "SN1"))
            assert any("USING INDEX encal_records_source" in row[-1] for row in plan), plan


def test_another_programs_database_is_refused_and_left_as_it_was(tmp_path):
    """fleet8: 'encal fleet report --store app.sqlite' (a command that only reads) wrote the store's tables and
    triggers into another program's SQLite database and put it in WAL mode, then said it held 0 units."""
    import sqlite3

    foreign = tmp_path / "app.sqlite"
    with sqlite3.connect(foreign) as connection:
        connection.execute("CREATE TABLE parts (id INTEGER)")
    connection.close()
    before = foreign.read_bytes()
    with pytest.raises(InputError, match=r"app.sqlite: is an SQLite database of other tables \(parts\), not a "
                                         r"calibration store; expected a store written by 'encal fleet fit'"):
        open_store(foreign)
    assert foreign.read_bytes() == before and not (tmp_path / "app.sqlite-wal").exists()
    with open_store(tmp_path / "s.sqlite") as store:  # a new file, and then a store, are opened as before
        store.add("SN1", _model_json("x"))
    with open_store(tmp_path / "s.sqlite") as store:
        assert store.count() == 1


def test_a_write_the_store_cannot_take_is_one_sentence_and_writes_nothing(location, monkeypatch):
    """fleet8: SQLite locked by another writer past the wait, or a PostgreSQL connection lost, surfaced as the driver's
    exception (a traceback in 'encal fleet fit'); it is StoreWriteError, an InputError, with nothing of the call
    written."""
    from encal.store import StoreWriteError
    from encal.store import _store

    monkeypatch.setattr(_store, "LOCK_TIMEOUT_S", 0.2)
    with open_store(location) as store:
        store.add("SN-1", _model_json("a"))
        if location.startswith("postgresql"):
            import psycopg

            with store._connection.cursor() as cursor:
                cursor.execute("SELECT pg_backend_pid()")
                pid = cursor.fetchone()[0]
            store._connection.commit()
            with psycopg.connect(location, autocommit=True) as other:
                other.execute("SELECT pg_terminate_backend(%s)", (pid,))
            says = "could not be written"
        else:
            import sqlite3

            holder = sqlite3.connect(location, isolation_level=None)
            holder.execute("BEGIN IMMEDIATE")
            says = "could not be written (database is locked; nothing of this group of 2 records was written)"
        with pytest.raises(StoreWriteError, match=re.escape(says)):
            store.add_many([{"serial": "SN-2", "model_json": _model_json("b")},
                            {"serial": "SN-3", "model_json": _model_json("c")}])
        if not location.startswith("postgresql"):
            holder.execute("ROLLBACK")
            holder.close()
    with open_store(location) as again:
        assert [r.serial for r in again.records()] == ["SN-1"]


def test_a_model_that_is_no_model_file_is_refused_before_it_is_written(tmp_path):
    """A record is never changed or deleted, so one whose model cannot be read would break ``export --serial`` and the
    fleet report for good (task storeapi: text, a path, a calibration, a hand-edited file were all stored)."""
    from encal._core.errors import ModelFileError
    from encal.models.fourier import FourierModel
    from encal.models.modelfile import load_model, save_model

    saved = tmp_path / "model.json"
    model = FourierModel([0, 1], [0.0, 1.0], [0.0, 0.5])
    save_model(model, saved)
    edited = json.loads(saved.read_text(encoding="utf-8"))
    edited["parameters"]["cos"][1] = 2.0
    with open_store(tmp_path / "store.sqlite") as store:
        for given, said in [("not a model", "is not JSON"), (str(saved), "not its path"),
                            ('{"kind": "fourier"}', "'format'"), (json.dumps(edited), "checksum does not match"),
                            (None, "got NoneType")]:
            with pytest.raises(ModelFileError, match=said) as caught:
                store.add("SN1", given)
            assert "\n" not in str(caught.value) and str(caught.value).startswith("the model given for SN1: ")
        assert store.count() == 0
        # a Model, or its file's text: the same record's model
        by_object, by_text = store.add("SN1", model), store.add("SN2", saved.read_text(encoding="utf-8"))
        assert by_object.model().predict(30.0) == by_text.model().predict(30.0) == load_model(saved).predict(30.0)
    for location in (None, 7):
        with pytest.raises(InputError, match="expected the path of an SQLite file or a postgresql:// URL"):
            open_store(location)


def test_a_records_texts_and_time_are_checked_before_it_is_written(tmp_path):
    # a record is permanent: a grade of 1, a station of 3.5 or a creation time of 'yesterday' were stored as given
    from encal.models.fourier import FourierModel

    model = FourierModel([0, 1], [0.0, 1.0], [0.0, 0.5])
    with open_store(tmp_path / "store.sqlite") as store:
        for fields, said in [({"grade": 1}, "grade as text or None"), ({"station": 3.5}, "station as text"),
                             ({"created_utc": "yesterday"}, "created_utc as an ISO 8601 date and time"),
                             ({"created_utc": 20261128}, "created_utc as an ISO 8601")]:
            with pytest.raises(InputError, match=said):
                store.add("SN1", model, **fields)
        assert store.count() == 0
        record = store.add("SN1", model, grade="A", station="line 2", created_utc="2026-11-28T12:00:00+00:00")
        assert (record.grade, record.station, record.created_utc) == ("A", "line 2", "2026-11-28T12:00:00+00:00")

"""The calibration store (encal.store): epochs per serial, records never overwritten, concurrent writers.

Every test runs against SQLite, and against a real PostgreSQL server when ENCAL_TEST_POSTGRES_URL names one
(.ci/run starts one); otherwise the PostgreSQL cases skip with the reason.
"""

import json
import os
import subprocess
import sys
import textwrap
import uuid

import pytest

from encal._core.errors import InputError
from encal.store import GRADE_NONE, grade_of, open_store, parse_grades
from tests import _paths

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


def _model_json(label):
    return json.dumps({"label": label, "payload": "x" * 2000})


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


def test_a_record_is_never_overwritten_or_deleted(location):
    with open_store(location) as store:
        store.add("SN-1", _model_json("a"))
        for statement in ("UPDATE encal_records SET grade = 'A'", "DELETE FROM encal_records"):
            with pytest.raises(Exception, match="never overwritten"):
                if location.startswith("postgresql"):
                    with store._connection.transaction():
                        store._connection.execute(statement)
                else:
                    store._connection.execute(statement)
        assert store.latest("SN-1").grade is None and store.count() == 1


_WRITER = textwrap.dedent("""
    import json, sys
    from encal.store import open_store
    location, writer, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    with open_store(location) as store:
        for index in range(count):
            serial = f"SN-{index % 3}"
            store.add(serial, json.dumps({"writer": writer, "index": index, "payload": "x" * 5000}),
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
        written = {(json.loads(r.model_json)["writer"], json.loads(r.model_json)["index"]) for r in records}
        assert written == {(w, i) for w in range(writers) for i in range(count)}
        for record in records:
            document = json.loads(record.model_json)
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
        store.add("SN\n2", "{}")


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
        first = store.add_many([{"serial": "SN-1", "model_json": "{}", "source_sha256": "ab"}], skip_stored=True)
        again = store.add_many([{"serial": "SN-1", "model_json": "{}", "source_sha256": "ab"},
                                {"serial": "SN-1", "model_json": "{}", "source_sha256": "cd"}], skip_stored=True)
        assert first[0].epoch == 1 and again[0] is None and again[1].epoch == 2
        assert store.count() == 2


def test_a_serial_number_is_one_whatever_its_unicode_form(location):
    """Composed (NFC) and decomposed (NFD, as macOS names files) spellings of one serial are one unit."""
    import unicodedata

    composed, decomposed = (unicodedata.normalize(form, "SNÅ1") for form in ("NFC", "NFD"))
    with open_store(location) as store:
        store.add(composed, "{}")
        store.add(decomposed, "{}")
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
        store.add("SN1", "{}")
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
            assert json.loads(store.latest(serial).model_json)["label"] == ("SN1 again" if serial == "SN1" else serial)
        assert store.latest("SN%") is None and store.latest("SN_") is None  # no pattern matching

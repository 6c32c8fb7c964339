"""A store of layout 1 written directly through SQL, as an encal before serials were composed (NFC) left it: each
serial as it came, a file named on a Mac (decomposed, NFD) under its decomposed serial."""

from encal.store._store import _COLUMNS, _REFUSAL

__all__ = ["write_layout_1_store"]


def write_layout_1_store(location, records):
    """Write the tables of layout 1 at ``location`` (an SQLite path or a postgresql:// URL) holding ``records``.

    Parameters
    ----------
    location : str
    records : sequence of dict
        Columns of each record (``serial``, ``epoch``, ``model_json`` at least), in the order written; the columns
        ``created_utc`` and ``encal_version`` are filled in when missing.
    """
    postgres = str(location).startswith("postgresql")
    columns = ", ".join(f"{name} {types[1] if postgres else types[0]}" for name, *types in _COLUMNS)
    statements = [
        f"CREATE TABLE encal_records (id {'BIGSERIAL' if postgres else 'INTEGER'} PRIMARY KEY"
        f"{'' if postgres else ' AUTOINCREMENT'}, {columns}, UNIQUE (serial, epoch))",
        "CREATE TABLE encal_store (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
        "INSERT INTO encal_store VALUES ('schema_version', '1')",
    ]
    if postgres:
        import psycopg

        statements += [f"CREATE FUNCTION encal_records_refuse() RETURNS trigger LANGUAGE plpgsql AS $$ BEGIN RAISE "
                       f"EXCEPTION '{_REFUSAL}'; END $$",
                       "CREATE TRIGGER encal_records_never_changed BEFORE UPDATE OR DELETE ON encal_records FOR EACH "
                       "ROW EXECUTE FUNCTION encal_records_refuse()"]
        connection, mark = psycopg.connect(location, autocommit=True), "%s"
    else:
        import sqlite3

        statements += [f"CREATE TRIGGER encal_records_no_{event.lower()} BEFORE {event} ON encal_records BEGIN "
                       f"SELECT RAISE(ABORT, '{_REFUSAL}'); END" for event in ("UPDATE", "DELETE")]
        connection, mark = sqlite3.connect(location, isolation_level=None), "?"
    try:
        for statement in statements:
            connection.execute(statement)
        for second, record in enumerate(records):
            record = {"created_utc": f"2026-01-01T00:{second // 60:02d}:{second % 60:02d}+00:00",
                      "encal_version": "0.1.0", **record}
            names = list(record)
            connection.execute(f"INSERT INTO encal_records ({', '.join(names)}) VALUES "
                               f"({', '.join(mark for _ in names)})", [record[name] for name in names])
    finally:
        connection.close()

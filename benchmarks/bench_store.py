"""The calibration store's costs of store6: converting a store of layout 1 (decomposed serials) when it is opened,
and the copied-calibration check made inside every write's transaction.

Usage::

    python benchmarks/bench_store.py                    # 20,000 records in an SQLite file
    python benchmarks/bench_store.py --records 100000   # a larger store

A store of layout 1 is written directly through SQL (as an encal before serials were composed left it): ``--records``
records of one epoch each (a calibration of 4 kB and a model of 2 kB), every 100th unit calibrated a second time under
its serial's decomposed spelling (NFD), so that 1 % of the units are merged. Then, in CPU seconds of this process
(``time.process_time``; SQLite works in it) and wall seconds:

1. the first opening, which converts it (an index on the calibrations' SHA-256, the serials composed, the merged
   units' epochs numbered again) and a second opening, which has nothing to do;
2. a batch's flush: 64 new records in one transaction, each checked inside it against the store for the same
   calibration under its own serial and under any other (the index answers), median of 20 flushes;
3. the same flush with the index dropped, each check then a scan of the table: why layout 2 has the index.
"""

import argparse
import hashlib
import statistics
import sys
import tempfile
import time
import unicodedata
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from encal.store import open_store  # noqa: E402
from tests.store.old_layout import write_layout_1_store  # noqa: E402


def _timed(function):
    cpu, wall = time.process_time(), time.perf_counter()
    result = function()
    return result, time.process_time() - cpu, time.perf_counter() - wall


def _records(count):
    calibration, model = "x" * 4096, '{"label": "%s", "payload": "%s"}'
    for index in range(count):
        serial = f"SN-M\u00fcller-{index:06d}"
        yield {"serial": serial, "epoch": 1, "source_sha256": hashlib.sha256(serial.encode()).hexdigest(),
               "calibration_csv": calibration, "model_json": model % (serial, "y" * 2048)}
        if index % 100 == 0:
            again = unicodedata.normalize("NFD", serial)
            yield {"serial": again, "epoch": 1, "source_sha256": hashlib.sha256(b"again" + serial.encode()).hexdigest(),
                   "calibration_csv": calibration, "model_json": model % (again, "y" * 2048)}


def _model_file(label):
    """A small model file's text (the store takes model files only, and checks each: about 0.1 ms for this one)."""
    from encal.models.fourier import FourierModel
    from encal.models.modelfile import dumps, model_to_dict

    return dumps(model_to_dict(FourierModel([0, 1], [0.0, 1.0], [0.0, 0.5], training={"label": label}),
                               reproducible=True))


def _flushes(store, start, count=20, group=64):
    times = []
    model_json = _model_file("flush")
    for flush in range(count):
        records = [{"serial": f"SN-new-{start + flush}-{k}", "model_json": model_json,
                    "calibration_csv": f"{start},{flush},{k}"} for k in range(group)]
        _, cpu, wall = _timed(lambda: store.add_many(records, skip_stored=True))
        times.append((cpu, wall))
    return statistics.median(t[0] for t in times), statistics.median(t[1] for t in times)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=20_000, help="records of the store of layout 1")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "old.sqlite"
        write_layout_1_store(str(path), _records(args.records))
        size = path.stat().st_size
        store, cpu, wall = _timed(lambda: open_store(path))
        merged = len(store._query("SELECT DISTINCT serial FROM encal_serials_composed"))
        count = store.count()
        store.close()
        _, cpu_again, wall_again = _timed(lambda: open_store(path).close())
        print(f"store of layout 1: {count} records, {size / 1e6:.0f} MB; {merged} units merged")
        print("| step | CPU s | wall s |\n| --- | --- | --- |")
        print(f"| first opening (conversion) | {cpu:.3f} | {wall:.3f} |")
        print(f"| second opening | {cpu_again:.4f} | {wall_again:.4f} |")
        with open_store(path) as store:
            flush_cpu, flush_wall = _flushes(store, 0)
            print(f"| flush of 64 records, checked in the transaction (median of 20) | {flush_cpu:.4f} | "
                  f"{flush_wall:.4f} |")
            store._connection.execute("DROP INDEX encal_records_source")
            flush_cpu, flush_wall = _flushes(store, 1000)
            print(f"| the same without the index on source_sha256 | {flush_cpu:.4f} | {flush_wall:.4f} |")


if __name__ == "__main__":
    main()

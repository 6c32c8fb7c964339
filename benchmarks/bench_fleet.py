"""A production line (issue 32): a lot of simulated units fitted by the batch, and concurrent writers of the store.

Usage::

    python benchmarks/bench_fleet.py                    # 10,000 units (the goal: <= 10 min on 2 cores)
    python benchmarks/bench_fleet.py --units 1000       # a smaller lot; the time for 10,000 is extrapolated
    python benchmarks/bench_fleet.py --units 0 --writers-records 200   # the concurrent writers only
    ENCAL_TEST_POSTGRES_URL=postgresql://... python benchmarks/bench_fleet.py --units 200   # PostgreSQL too

Table 1: the batch. ``--units`` simulated resolvers (encal.simulate, each its training run 0:2:358 degrees),
written as CSV files, then ``encal.fleet.batch.fit_batch`` on a pool of ``--jobs`` processes into an
SQLite store (every record committed as it comes): wall time, units per second, the time extrapolated
linearly to 10,000 units, the CPU time of the batch (the workers' included) and what it means for 10,000
units on idle cores, and the store's size. The machine's load average is printed, since the
fits share its cores.

Table 2: concurrent writers. 2, then 8 processes each write ``--writers-records`` records (a model of
5 kB and a calibration of 2 kB each) for 3 serial numbers shared by all, at once; afterwards every
record must be present and whole, and each serial's epochs 1..n without a gap or a repeat.
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import multiprocessing  # noqa: E402
import platform  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

GOAL_UNITS = 10_000
GOAL_S = 600.0


def write_lot(folder, units, seed=32):
    """Write ``units`` simulated training runs as SN000001.csv, ...; return the paths."""
    from encal.data.calibration import write_calibration
    from encal.simulate import simulate_fleet

    paths = []
    for first in range(1, units + 1, 500):
        for member in simulate_fleet(min(500, units + 1 - first), seed=seed, first_number=first):
            path = folder / f"SN{int(member.name[3:]):06d}.csv"
            write_calibration(path, member.train.calibration)
            paths.append(path)
    return paths


def bench_batch(units, jobs):
    from encal.fleet.batch import fit_batch
    from encal.store import open_store

    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        start = time.perf_counter()
        paths = write_lot(folder, units)
        simulated = time.perf_counter() - start
        store_path = folder / "encal-store.sqlite"
        load = os.getloadavg()[0]
        start, cpu_start = time.perf_counter(), _cpu_seconds()
        with open_store(store_path) as store:
            result = fit_batch(paths, store, grades=[("A", 1.2), ("B", 3.0)], station="bench", jobs=jobs)
            count = store.count()
        wall = time.perf_counter() - start
        cpu = _cpu_seconds() - cpu_start  # the workers' too: they are joined when fit_batch returns
        size = sum(p.stat().st_size for p in folder.glob("encal-store.sqlite*"))
        # resumed: nothing left to fit
        start = time.perf_counter()
        with open_store(store_path) as store:
            again = fit_batch(paths, store, jobs=jobs)
        resumed = time.perf_counter() - start
    assert count == units == len(result.fitted) and not result.refused, (count, units, result.refused[:3])
    assert len(again.skipped) == units and not again.fitted
    print(f"\nTable 1: the batch ({units} simulated units, {jobs} worker processes, load average before "
          f"{load:.1f} on {os.cpu_count()} cores)")
    print(f"  simulated and written as CSV: {simulated:.1f} s")
    print(f"  fitted into the store:        {wall:.1f} s  ({units / wall:.1f} units/s; "
          f"{wall / units * 1000:.0f} ms per unit of wall time)")
    print(f"  extrapolated to {GOAL_UNITS} units:    {wall / units * GOAL_UNITS:.0f} s "
          f"(goal {GOAL_S:.0f} s: {'met' if wall / units * GOAL_UNITS <= GOAL_S else 'NOT met'})")
    print(f"  CPU of the batch:             {cpu:.1f} s, workers' start-up included ({cpu / units * 1000:.0f} ms "
          f"per unit): {cpu / units * GOAL_UNITS / jobs:.0f} s for {GOAL_UNITS} units on {jobs} idle cores")
    print(f"  store size:                   {size / 1e6:.1f} MB ({size / units / 1e3:.1f} kB per record)")
    print(f"  resumed run (all stored):     {resumed:.1f} s, {len(again.skipped)} skipped")


def _cpu_seconds():
    """User and system CPU seconds of this process and of its finished children (the machine is shared: the
    wall time depends on the other jobs on its cores, the CPU time much less)."""
    times = os.times()
    return times.user + times.system + times.children_user + times.children_system


def _model_file(**training):
    """A small model file's text carrying ``training`` (the store takes model files only)."""
    from encal.models.fourier import FourierModel
    from encal.models.modelfile import dumps, model_to_dict

    return dumps(model_to_dict(FourierModel([0, 1], [0.0, 1.0], [0.0, 0.5], training=training), reproducible=True))


def _writer(location, writer, count):
    from encal.store import open_store

    with open_store(location) as store:
        for index in range(count):
            store.add(f"SN-{index % 3}", _model_file(writer=writer, index=index, payload="x" * 5000),
                      calibration_csv=f"{writer},{index}\n" * 200, station=f"station-{writer}")


def bench_writers(location_of, records):
    from encal.store import open_store

    print(f"\nTable 2: concurrent writers ({records} records each, 3 serial numbers shared)")
    print(f"  {'back end':<10} {'writers':>7} {'records':>8} {'wall s':>7} {'records/s':>9}  check")
    context = multiprocessing.get_context("spawn")
    for name, make in location_of.items():
        for writers in (2, 8):
            location, cleanup = make()
            try:
                with open_store(location):
                    pass  # the tables, before the clock starts
                processes = [context.Process(target=_writer, args=(location, w, records)) for w in range(writers)]
                start = time.perf_counter()
                for process in processes:
                    process.start()
                for process in processes:
                    process.join()
                wall = time.perf_counter() - start
                assert all(p.exitcode == 0 for p in processes)
                with open_store(location) as store:
                    stored = store.records()
                    whole = all(r.calibration_csv
                                == "{writer},{index}\n".format(**json.loads(r.model_json)["training"]) * 200
                                for r in stored)
                    epochs = all([r.epoch for r in store.history(s)] == list(range(1, len(store.history(s)) + 1))
                                 for s in store.serials())
                ok = len(stored) == writers * records and whole and epochs
                print(f"  {name:<10} {writers:>7} {len(stored):>8} {wall:>7.2f} {len(stored) / wall:>9.0f}  "
                      f"{'all present, whole, epochs 1..n' if ok else 'FAILED'}")
                assert ok
            finally:
                cleanup()


def _sqlite_location():
    folder = tempfile.TemporaryDirectory()
    return str(Path(folder.name) / "s.sqlite"), folder.cleanup


def _postgres_location(url):
    import uuid

    import psycopg

    schema = "bench_" + uuid.uuid4().hex[:10]
    with psycopg.connect(url, autocommit=True) as connection:
        connection.execute(f"CREATE SCHEMA {schema}")

    def drop():
        with psycopg.connect(url, autocommit=True) as connection:
            connection.execute(f"DROP SCHEMA {schema} CASCADE")

    separator = "&" if "?" in url else "?"
    return f"{url}{separator}options=-csearch_path%3D{schema}", drop


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--units", type=int, default=GOAL_UNITS)
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--writers-records", type=int, default=100)
    args = parser.parse_args()
    import encal

    print(f"encal {encal.__version__}, Python {platform.python_version()}, {platform.machine()}, "
          f"{os.cpu_count()} cores")
    if args.units > 0:
        bench_batch(args.units, args.jobs)
    locations = {"SQLite": _sqlite_location}
    url = os.environ.get("ENCAL_TEST_POSTGRES_URL")
    if url:
        locations["PostgreSQL"] = lambda: _postgres_location(url)
    else:
        print("\n(PostgreSQL: ENCAL_TEST_POSTGRES_URL is not set, its rows are left out)")
    if args.writers_records > 0:
        bench_writers(locations, args.writers_records)


if __name__ == "__main__":
    main()

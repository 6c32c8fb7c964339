"""A production line: fit every unit's calibration into the calibration store, and report on the fleet.

Examples:
  encal fleet fit lot7/ --station eol-2 --grades A=0.02,B=0.05
  encal fleet fit 'lot7/*.csv' --store postgresql://station@db.example/encal --jobs 8
  encal fleet report --store lot7/encal-store.sqlite -o fleet.html
  encal export --serial SN0042 --store lot7/encal-store.sqlite --format table -o SN0042.bin

fleet fit: each file is one calibration of one unit, its serial number the file name's stem (or what
--serial-pattern finds in it); every unit is fitted on a pool of processes and written to the store as
a new epoch of its serial number (records are never overwritten). A file already in the store (the same
serial number, the same bytes) is skipped, so an interrupted batch resumes where it stopped. A file that
cannot be fitted is reported in one sentence and skipped; the exit status is then 1.

The store: an SQLite file (default: encal-store.sqlite in the folder of the first calibration) or a
PostgreSQL URL (pip install 'encal[postgres]'). docs/production.md describes the workflow.
"""

import sys

from ._common import activity, add_calibration_options, check_paths, warnings_as_lines


def add_arguments(parser):
    commands = parser.add_subparsers(dest="fleet_command", metavar="{fit,report}", required=True)
    fit = commands.add_parser("fit", help="fit every calibration of a folder or pattern into the store",
                              description=__doc__, formatter_class=parser.formatter_class)
    fit.add_argument("sources", nargs="+", metavar="DIR|GLOB|FILE",
                     help="a folder (its *.csv), a quoted glob pattern ('lot7/**/*.csv') or calibration files")
    _store_option(fit, default_text="encal-store.sqlite in the folder of the first calibration")
    fit.add_argument("--station", metavar="NAME", help="the station's name, recorded in every record")
    fit.add_argument("--grades", metavar="A=0.02,B=0.05",
                     help="grade each unit by its held-out RMS error (the fit's estimate of the error after "
                          "correction at angles not calibrated): the first grade "
                          "whose limit it meets, in degrees, or with a unit (A=1.2arcmin, A=30arcsec); a unit "
                          "that meets none is graded 'out'")
    fit.add_argument("--method", default="spectral", choices=("spectral", "auto"),
                     help="the model (default spectral, the empirical-Bayes Fourier model; auto as 'encal fit' "
                          "chooses): both state the held-out estimate the grades go by")
    fit.add_argument("--prior-from", metavar="DB",
                     help="fit each unit under the fleet prior learned from the latest record of every other unit in "
                          "this store (it may be --store): for partial calibrations, a quarter turn or every 4th stop "
                          "(spectral; docs/production.md, 'A fleet prior')")
    fit.add_argument("--serial-pattern", metavar="REGEX",
                     help="find the serial number in the file name's stem with this regular expression (its "
                          "first group, or the whole match); default the whole stem")
    fit.add_argument("--jobs", type=_jobs, metavar="N",
                     help="worker processes (default: the machine's cores; 0 fits in this process)")
    add_calibration_options(fit)
    fit.set_defaults(fleet_parser=fit)
    report = commands.add_parser("report", help="one HTML page on the fleet in the store",
                                 description="The fleet's mean profile and spread per harmonic order, the units "
                                             "that stand out (a robust score per order and overall), the "
                                             "grades, the drift of units calibrated more than once.")
    _store_option(report, required=True)
    report.add_argument("-o", "--output", required=True, metavar="FLEET.html", help="the HTML page to write")
    report.add_argument("--grades", metavar="A=0.02,B=0.05",
                        help="grade the units again by these thresholds (degrees, or with a unit) instead of "
                             "the grades stored")
    report.set_defaults(fleet_parser=report)


def _store_option(parser, *, default_text=None, required=False):
    parser.add_argument("--store", metavar="DB", required=required,
                        help="the calibration store: an SQLite file (created when new) or a postgresql:// URL"
                             + (f" (default: {default_text})" if default_text else ""))


def _jobs(text):
    from ._common import int_in_range

    return int_in_range(0, 1024)(text)


def _store_location(args, paths):
    from pathlib import Path

    from ..store import default_store_path

    if args.store is not None:
        return args.store
    return str(default_store_path(Path(paths[0]).parent))


def _check_store(location, *, must_exist=False, option="--store"):
    """Refuse a store that is a folder, in a missing folder, or (to read) missing, before any work."""
    from pathlib import Path

    from .._core.errors import InputError
    from ..store._store import is_url

    if is_url(location):
        return
    if must_exist:
        from ._serial import stored_file_problem

        problem = stored_file_problem(Path(location))
        if problem and problem != "a folder":  # a folder: check_paths says so, as for the store fit writes
            raise InputError(f"{option} {location}: {problem}; expected a store written by 'encal fleet fit'")
    check_paths(outputs=[(option, location)])


def _without_the_store(paths, location, sources):
    """``paths`` without the store's own files (``'lot7/*'`` matches ``lot7/encal-store.sqlite`` and its ``-wal`` once
    a batch has written it: each run refused it as a calibration, exit status 1)."""
    import os

    from .._core.errors import InputError
    from ..store._store import is_url

    if is_url(location):
        return paths
    own = {os.path.realpath(f"{location}{suffix}") for suffix in ("", "-wal", "-shm", "-journal")}
    kept = [path for path in paths if os.path.realpath(path) not in own]
    if not kept:
        raise InputError(f"{' '.join(map(str, sources))} names only the store {location} and its files; expected "
                         "calibration CSVs")
    return kept


def run(args):
    if args.fleet_command == "fit":
        return _fit(args)
    return _report(args)


def _fit(args):
    from .._core.progress import clear_line
    from ..fleet.batch import find_calibrations, fit_batch
    from ..store import open_store, parse_grades

    grades = parse_grades(args.grades) if args.grades is not None else []
    if args.serial_pattern is not None:
        import re

        try:
            re.compile(args.serial_pattern)
        except re.error as exc:
            args.fleet_parser.error(f"--serial-pattern {args.serial_pattern}: not a regular expression ({exc})")
    if args.ref_col.strip().lower() == args.enc_col.strip().lower():
        args.fleet_parser.error(f"--ref-col {args.ref_col} and --enc-col {args.enc_col} name the same column; "
                                "expected the reference and the encoder in two different columns")
    read_options = {"allow_gaps": args.allow_gaps, "reverse": args.reverse, "duplicates": args.duplicates,
                    "reference_column": args.ref_col, "encoder_column": args.enc_col,
                    "reference_unit": args.ref_unit or args.unit or "deg",
                    "encoder_unit": args.enc_unit or args.unit or "deg"}
    if args.prior_from is not None and args.method != "spectral":
        args.fleet_parser.error(f"--prior-from fits under the fleet's spectral prior; expected --method spectral, "
                                f"not {args.method}")
    paths = find_calibrations(args.sources)
    location = _store_location(args, paths)
    _check_store(location)
    paths = _without_the_store(paths, location, args.sources)
    prior = None
    if args.prior_from is not None:
        from ..fleet.prior import StorePrior

        _check_store(args.prior_from, must_exist=True, option="--prior-from")
        from .._core.errors import InputError

        with open_store(args.prior_from, option="--prior-from") as source:
            try:
                prior = StorePrior(source.latest_records())  # each unit under the prior of the others
            except InputError as exc:  # too few units: the store named
                raise InputError(f"--prior-from {source.location}: {exc}") from None

    def refused(path, sentence):
        clear_line()
        print(f"encal fleet: error: refused {path}: {sentence}", file=sys.stderr)

    def warned(path, message):
        clear_line()
        print(f"encal fleet: warning: {path}: {message}", file=sys.stderr)

    with open_store(location) as store, warnings_as_lines("fleet"), activity("fleet fit") as progress:
        progress.stage(f"fitting {len(paths)} files", total=len(paths))
        result = fit_batch(paths, store, method=args.method, grades=grades, station=args.station,
                           serial_pattern=args.serial_pattern, jobs=args.jobs, read_options=read_options, prior=prior,
                           progress=progress.advance, on_refused=refused, on_warning=warned)
        total = store.count()
    graded = ""
    if grades:
        counts = {}
        for record in result.fitted:
            counts[record.grade] = counts.get(record.grade, 0) + 1
        graded = "; grades " + ", ".join(f"{name} {counts.get(name, 0)}" for name in
                                         [name for name, _ in grades] + ["out"])
    print(f"encal fleet fit: {len(result.fitted)} of {len(paths)} files fitted into {store.location} "
          f"({total} records in all){graded}; {len(result.skipped)} already stored, skipped; "
          f"{len(result.refused)} refused" + (" (each said on stderr)" if result.refused else ""))
    return 1 if result.refused else 0  # each refusal is one line on stderr, said as it came


def _report(args):
    from ..fleet.report import write_fleet_report
    from ..store import open_store, parse_grades

    grades = parse_grades(args.grades) if args.grades is not None else None
    from ..store._store import is_url

    _check_store(args.store, must_exist=True)
    # the page never written over the store (-o s.sqlite replaced every record with the page, exit 0)
    check_paths(inputs=[(None if is_url(args.store) else args.store, "store")], outputs=[("-o", args.output)])
    with open_store(args.store) as store, activity("fleet report") as progress:
        progress.stage("reading the store")
        records = store.records()
        summary = write_fleet_report(records, args.output, grades=grades, store_name=store.location,
                                     progress=progress)
    print(f"encal fleet report: wrote {args.output}: {summary}")
    return 0

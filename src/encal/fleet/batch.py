"""Fit many calibrations into the calibration store: a process pool, resumable, bad files refused apart.

A *task* is one unit: its serial number and its calibration files (a serial with several files gets
one epoch per file, in file-name order). Workers fit and return plain records; the calling process
alone writes them to the store, in groups of up to :data:`FLUSH_RECORDS` records or :data:`FLUSH_S`
seconds, one transaction each (one commit per record took 12 ms); an interrupted batch writes the
units it finished before it stops, and a new run skips them (a file is known by its serial number
and the SHA-256 of its bytes).
"""

import concurrent.futures.process
import glob
import hashlib
import os
import re
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from .._core.errors import EncalError, InputError

__all__ = ["BatchResult", "find_calibrations", "serial_of", "fit_batch", "fit_unit", "METHODS"]

#: The methods ``encal fleet fit`` offers, those whose fit states a held-out estimate to grade by: the spectral
#: model (default; its posterior's) or auto (its choice's).
METHODS = ("spectral", "auto")
#: Fitted records are written in one transaction per group: at most this many ...
FLUSH_RECORDS = 64
#: ... or every this many seconds, so that an interruption loses little and a resumed batch refits it.
FLUSH_S = 2.0


def find_calibrations(sources):
    """The calibration files named by ``sources``: folders (their ``*.csv``, ``*.CSV``, ...), glob patterns or files.

    Returns
    -------
    list of Path
        Sorted, each file once however it was named (``lot/SN1.csv``, ``/abs/lot/SN1.csv``, ``lot/../lot/SN1.csv``
        or a link to it: the first spelling given), so that a file is never fitted or counted twice.

    Raises
    ------
    InputError
        When a source matches no file.
    """
    found = {}  # the file (resolved) -> the path as first given
    for source in sources:
        text = str(source)
        path = Path(text)
        if path.is_dir():
            # *.csv in any case: SN7.CSV from a Windows station is a calibration too (it was left out, unsaid)
            matches = [p for p in path.iterdir() if p.suffix.lower() == ".csv" and p.is_file()]
            what = f"{text} is a folder with no *.csv file"
        elif glob.has_magic(text):
            matches = [Path(p) for p in glob.glob(text, recursive=True) if Path(p).is_file()]
            what = f"the pattern {text} matches no file"
        elif path.is_file():
            matches = [path]
            what = ""
        else:
            matches = []
            what = f"{text}: no such file or folder"
        if not matches:
            raise InputError(f"{what}; expected a folder of calibration CSVs, a glob pattern such as 'lot7/*.csv' "
                             "(quoted), or files")
        for match in matches:
            found.setdefault(match.resolve(), match)
    return sorted(found.values())


def serial_of(path, pattern=None):
    """The serial number of a calibration file: its name's stem, or the first group of ``pattern`` in it.

    Raises
    ------
    InputError
        When ``pattern`` does not match the stem.
    """
    from ..store._store import MAX_SERIAL_CHARS, check_serial

    stem = Path(path).stem
    if pattern is None:
        found = stem
    else:
        match = re.search(pattern, stem)
        if match is None:
            raise InputError(f"{path}: --serial-pattern {pattern} does not match its name {stem!r}; expected a "
                             "pattern that finds the serial number in every file name (its first group, or the whole "
                             "match)")
        found = match.group(1) if match.groups() else match.group(0)
        if found is None or found == "":
            # an optional first group that took no part, or a pattern matching the empty text: no serial number
            what = "its first group takes no part in the match" if found is None else "the text it finds is empty"
            raise InputError(f"{path}: --serial-pattern {pattern} matches its name {stem!r}, but {what}; expected a "
                             "pattern that finds the serial number in every file name (its first group, or the whole "
                             "match)")
    try:
        # the store's form (stripped, NFC): files of one unit are one task, fitted in order, whatever their spelling
        return check_serial(found or "")
    except InputError:
        raise InputError(f"{path}: its serial number {found!r} is not 1 to {MAX_SERIAL_CHARS} printable characters "
                         "(no line ends or control characters); expected the file renamed, or --serial-pattern "
                         "to find the serial number in its name") from None


def _natural_key(path):
    """Sort key of a path with its digit runs compared as numbers: ``run9`` before ``run10``, ``day9/`` before
    ``day10/``."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", str(path))]


@dataclass
class BatchResult:
    """What a batch did.

    Attributes
    ----------
    fitted : list of Record
        Records written, in the order written.
    skipped : list of Path
        Files already in the store (same serial, same bytes), not fitted again.
    refused : list of (Path, str)
        Files refused, with the sentence that says why.
    """

    fitted: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    refused: list = field(default_factory=list)


def file_sha256(path):
    """SHA-256 of a file's bytes (hex)."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def fit_unit(task):
    """Fit one unit's calibration files; a worker's job.

    Parameters
    ----------
    task : tuple
        ``(serial, [(path, sha256), ...], method, grades, read_options, prior)``; ``grades`` as
        :func:`encal.store.parse_grades`, ``read_options`` keywords of :func:`encal.data.calibration.read_calibration`,
        ``prior`` a :class:`~encal.fleet.prior.FleetPrior` or None.

    Returns
    -------
    list of (str, str, dict or str)
        Per file, ``(path, 'ok', fields of Store.add)`` or ``(path, 'refused', sentence)``.
    """
    serial, files, method, grades, read_options, prior = task
    return [_fit_file(serial, path, sha256, method, grades, read_options, prior) for path, sha256 in files]


def _fit_file(serial, path, sha256, method, grades, read_options, prior=None):
    from ..data.calibration import read_calibration
    from ..models.fitting import evaluate, fit
    from ..models.modelfile import dumps, model_to_dict
    from ..store import grade_of

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            cal = read_calibration(path, **read_options)
            if prior is None and method == "spectral":
                _refuse_an_arc(cal)
            model = fit(cal, method=method) if prior is None else _fit_under_prior(cal, prior)
            fitted = evaluate(model, cal, zero="auto")
            model.training["zero"] = "arbitrary" if fitted.arbitrary_zero else "fixed"
            model.training["zero_offset_arcmin"] = fitted.before.offset if fitted.arbitrary_zero else None
            model.training["serial"] = serial
            if grades:  # the thresholds the record's grade is given by, kept with it (Record.grade_limits)
                model.training["grades_arcmin"] = [[name, float(limit)] for name, limit in grades]
            text = dumps(model_to_dict(model))
        held_out = _held_out(model, cal)
        raw = Path(path).read_bytes()
        try:
            calibration_text = raw.decode("utf-8")
        except UnicodeDecodeError:
            calibration_text = raw.decode("latin-1")
        return (str(path), "ok", {
            "serial": serial, "model_json": text, "calibration_csv": calibration_text,
            "source_name": Path(path).name, "source_sha256": sha256, "model_kind": model.kind,
            "n_points": len(cal), "rms_before_arcmin": float(fitted.before.rms),
            "rms_after_arcmin": float(fitted.after.rms), "held_out_arcmin": held_out,
            "grade": grade_of(held_out, grades), "warnings": [str(w.message) for w in caught],
        })
    except EncalError as exc:
        return (str(path), "refused", str(exc))
    except (OSError, ValueError, ArithmeticError, MemoryError) as exc:  # a file that breaks a fit never stops the batch
        return (str(path), "refused", f"{path}: could not be fitted ({type(exc).__name__}: {exc}); expected a "
                                      "calibration CSV that 'encal fit' accepts")


def _refuse_an_arc(cal):
    """Refuse a calibration over an arc for the spectral model, naming the options of ``encal fleet fit`` that fit it.

    ``encal.fit``'s own sentence names its default, the arc family; the fleet's default is the spectral model.
    """
    from .._core.arcs import describe_range
    from ..models.fitting import calibrated_arc

    arc = calibrated_arc(cal)
    if arc is not None:
        raise InputError(f"{cal.source or cal.name}: covers only an arc ({describe_range(list(arc))} of the encoder "
                         "angle), which does not pin down the spectral model, a periodic one, between its points; "
                         "expected --method auto (the arc family, its model holding over the arc only) or "
                         "--prior-from STORE (a model of the whole turn under the fleet prior)")


def _fit_under_prior(cal, prior):
    """A spectral model of ``cal`` under the fleet prior (:func:`encal.fleet.prior.fit_with_prior`)."""
    from ..data.reversal import has_both_directions
    from ..models.fitting import resolution_bits
    from .prior import fit_with_prior

    if has_both_directions(cal):
        raise InputError(f"{cal.source}: has readings in both directions of travel; the fleet prior fits one "
                         "profile (fit it without --prior-from, which gives one model per direction)")
    from ..models.uncertainty import with_reference_uncertainty

    model = fit_with_prior(cal.encoder_deg, cal.errors_arcmin, prior)
    # a selfcal output's sigma_arcmin: the reference's own uncertainty, which no prior averages away
    model.uncertainty = with_reference_uncertainty(model.uncertainty, cal)
    model.encoder = {"name": cal.name, "resolution_bits": resolution_bits(cal)}
    model.training = {"method": "spectral", **model.training, "n_points": len(cal)}
    model.reading_sign = cal.reading_sign
    return model


def _held_out(model, cal=None):
    """The fit's estimate of its RMS error at readings it did not see (arcmin), or None.

    A spectral model's posterior gives it; a model auto chose by cross-validation, the chosen row's CV figure,
    with the reference's own uncertainty of ``cal`` (its ``sigma_arcmin`` column) in quadrature, as ``encal fit``
    states it: no fold sees an error the reference shares with its neighbours (a posterior has it already). The
    training RMS is never used in its place: a lookup table's is 0.
    """
    expected = getattr(model, "expected_rms_between_points", None)
    if callable(expected) and expected() is not None:
        return float(expected())
    from ..models.uncertainty import with_reference_rms

    selection = model.training.get("selection") or {}
    for row in selection.get("table") or ():
        if row.get("label") == selection.get("chosen") and row.get("cv_rms_arcmin") is not None:
            return with_reference_rms(float(row["cv_rms_arcmin"]), cal)
    return None


def fit_batch(paths, store, *, method="spectral", grades=(), station=None, serial_pattern=None, jobs=None,
              read_options=None, prior=None, progress=None, on_refused=None, on_warning=None):
    """Fit every calibration file into ``store``, in parallel; skip those already stored.

    Parameters
    ----------
    paths : sequence of path-like
        Calibration CSVs.
    store : encal.store.Store
        Where the records go (written by this process only).
    method : str, default='spectral'
        One of :data:`METHODS`.
    grades : list of (str, float)
        Thresholds (arc-minutes of held-out RMS), :func:`encal.store.parse_grades`.
    station : str, optional
        Recorded in every record.
    serial_pattern : str, optional
        A regular expression that finds the serial number in a file's stem (see :func:`serial_of`).
    read_options : dict, optional
        Keywords of :func:`encal.data.calibration.read_calibration` (columns, units, duplicates, ...).
    prior : encal.fleet.prior.FleetPrior or encal.fleet.prior.StorePrior, optional
        Fit every unit under this fleet prior instead of ``method`` (partial calibrations); a ``StorePrior`` fits
        each unit under the prior of the store's other units (a unit whose prior would hold fewer than
        :data:`~encal.fleet.prior.MIN_UNITS` is refused).
    jobs : int, optional
        Worker processes; default the machine's cores; 0 fits in this process.
    progress : callable, optional
        Called with the number of files done, after each unit (and once for the files skipped).
    on_refused : callable, optional
        Called with ``(path, sentence)`` for each refused file, as it comes.
    on_warning : callable, optional
        Called with ``(path, message)`` for each warning of a fit.

    Returns
    -------
    BatchResult
    """
    from ..store import CopiedCalibrationError, StoreWriteError

    paths = list(paths)
    result = BatchResult()
    stored = store.stored_sources()

    def refuse(path, sentence):
        result.refused.append((Path(path), sentence))
        if on_refused:
            on_refused(Path(path), sentence)

    known = []
    for path in paths:
        try:
            known.append((path, serial_of(path, serial_pattern), file_sha256(path)))
        except (InputError, OSError) as exc:
            refuse(path, str(exc) if isinstance(exc, InputError) else f"{path}: cannot be read ({exc.strerror or exc})")
    owners = _owners_of_bytes(known, stored)
    units = {}
    stored_last = {}  # per serial, the file of this batch stored already that its name puts last
    for path, serial, sha256 in known:
        if (serial, sha256) in stored:
            result.skipped.append(Path(path))
            if serial not in stored_last or _natural_key(path) > _natural_key(stored_last[serial]):
                stored_last[serial] = path
            continue
        others = sorted(owners[sha256] - {serial})
        if others:
            # one unit's readings under another's serial number: a copied or misnamed file; which of them is
            # that unit's own cannot be told, so none is fitted (the store's record, if any, stays as it was)
            where = "in the store" if any((other, sha256) in stored for other in others) else "in this batch"
            refuse(path, _copied(path, serial, others, where))
            continue
        units.setdefault(serial, []).append((str(path), sha256))
    for serial, files in list(units.items()):
        files.sort(key=lambda file: _natural_key(file[0]))  # a unit's epochs in the order of its files' names
        if serial in stored_last:
            # a file its name puts before one stored already (a resumed batch whose earlier file was refused, then
            # mended) would be stored after it, as the unit's latest calibration: the older model exported as its
            # newest. Epochs are given in the order written, and a record is never changed.
            last = stored_last[serial]
            early = [file for file in files if _natural_key(file[0]) < _natural_key(last)]
            for path, _ in early:
                refuse(path, f"{path}: its name puts it before {last}, stored already as a calibration of {serial}; "
                             f"stored now it would be {serial}'s latest epoch, after {Path(last).name}; expected a "
                             "unit's calibrations stored in the order of their names (fit it alone to store it as "
                             "the unit's newest)")
            files[:] = [file for file in files if file not in early]
            if not files:
                del units[serial]
        if serial_pattern is None and len(files) > 1 and on_warning:
            # without --serial-pattern, one stem in two folders: a unit recalibrated, or two units whose serial
            # numbers collide (two lines, two lots); which cannot be told, and the last becomes the unit's model
            names = ", ".join(path for path, _ in files[:3]) + (", ..." if len(files) > 3 else "")
            on_warning(Path(files[-1][0]), f"{len(files)} files of this batch have the serial number {serial} "
                                           f"({names}): each is stored as a new epoch of {serial}, in that order, "
                                           "the last its latest (two units whose serial numbers collide would share "
                                           "one history)")
    tasks = []
    for serial, files in units.items():
        unit_prior = prior
        if hasattr(prior, "for_unit"):  # a StorePrior: the prior of the other units, never one learned from this one
            try:
                unit_prior = prior.for_unit(serial, [sha256 for _, sha256 in files])
            except InputError as exc:
                for path, _ in files:
                    refuse(path, f"{path}: {exc}")
                continue
        tasks.append((serial, files, method, list(grades), dict(read_options or {}), unit_prior))
    queued = sum(len(task[1]) for task in tasks)
    if progress and len(paths) - queued:
        progress(len(paths) - queued)  # skipped or refused already
    if jobs is None:
        jobs = os.cpu_count() or 1
    jobs = min(jobs, len(tasks))

    waiting = []  # fitted, not yet written
    waiting_paths = []
    last_flush = [time.monotonic()]

    def add_each(records, paths):
        """``store.add_many``, or record by record when one of them is refused (the others are kept)."""
        try:
            return store.add_many(records, skip_stored=True)
        except StoreWriteError:
            raise  # the store takes no write at all: no record of the group would be taken alone either
        except InputError:
            pass
        added = []
        for record, path in zip(records, paths):
            try:
                added.extend(store.add_many([record], skip_stored=True))
            except CopiedCalibrationError as exc:
                # stored under another serial by a batch running beside this one, after this one's check at its start
                refuse(path, _copied(path, exc.serial, exc.others, "in the store"))
                added.append(False)
            except InputError as exc:
                refuse(path, f"{path}: its record was refused by the store ({exc})")
                added.append(False)
        return added

    def flush():
        if waiting:
            try:
                added = add_each(waiting, waiting_paths)
            except StoreWriteError as exc:
                unwritten = len(waiting)
                waiting.clear()  # not tried again when the batch stops
                waiting_paths.clear()
                raise StoreWriteError(f"{exc}; the batch stopped, {len(result.fitted)} records of it written before, "
                                      f"{unwritten} fitted and not written: the same command run again fits what is "
                                      "missing") from None
            for path, record in zip(waiting_paths, added):
                if record is False:
                    continue
                if record is None:  # another batch stored the same file meanwhile
                    result.skipped.append(path)
                else:
                    result.fitted.append(record)
            waiting.clear()
            waiting_paths.clear()
        last_flush[0] = time.monotonic()

    def write(outcome):
        for path, status, value in outcome:
            if status == "ok":
                fields = dict(value)
                for message in fields.pop("warnings"):
                    if on_warning:
                        on_warning(Path(path), message)
                waiting.append({**fields, "station": station})
                waiting_paths.append(Path(path))
            else:
                refuse(path, value)
        if len(waiting) >= FLUSH_RECORDS or time.monotonic() - last_flush[0] >= FLUSH_S:
            flush()
        if progress:
            progress(len(outcome))

    try:
        if jobs <= 0:
            for task in tasks:
                write(fit_unit(task))
        else:
            _run_pool(tasks, jobs, write)
    except concurrent.futures.process.BrokenProcessPool:
        flush()
        raise EncalError(f"a worker process ended abruptly while fitting (killed, out of memory?); the batch stopped, "
                         f"{len(result.fitted)} records of it written: the same command run again fits what is "
                         "missing (--jobs 0 fits in this process, and says what stops it)") from None
    finally:
        flush()  # an interrupted batch keeps every unit it finished
    return result


def _copied(path, serial, others, where):
    """The refusal of a file whose bytes are the calibration of ``others`` as well (``where``: in the store or in
    this batch)."""
    return (f"{path}: its bytes are the calibration of {', '.join(others)} as well ({where}); expected each unit's "
            f"own calibration (a copied or misnamed file?), not fitted as {serial}")


def _owners_of_bytes(known, stored):
    """The serial numbers whose calibration has each SHA-256 of ``known`` ((path, serial, sha256)), in the batch
    or in ``stored`` ((serial, sha256) pairs of the store)."""
    owners = {sha256: set() for _, _, sha256 in known}
    for serial, sha256 in stored:
        if sha256 in owners:
            owners[sha256].add(serial)
    for _, serial, sha256 in known:
        owners[sha256].add(serial)
    return owners


def _run_pool(tasks, jobs, write):
    import concurrent.futures

    from .._core.pool import Workers

    with Workers(jobs) as workers:
        executor = workers.executor()
        unwritten = set()

        def write_done(done):
            # the units that finished first: a pool whose worker died fails every unit not finished, and a unit
            # finished before it must still be written whatever the order of the set
            for future in sorted(done, key=lambda future: future.exception() is not None):
                unwritten.discard(future)
                write(future.result())

        try:
            # a bounded window of submitted units: memory stays flat on a lot of 10^5 files
            for task in tasks:
                unwritten.add(executor.submit(fit_unit, task))
                if len(unwritten) >= 4 * jobs:
                    write_done(concurrent.futures.wait(unwritten, return_when="FIRST_COMPLETED")[0])
            while unwritten:
                write_done(concurrent.futures.wait(unwritten, return_when="FIRST_COMPLETED")[0])
        except BaseException:
            for future in unwritten:
                future.cancel()
            raise

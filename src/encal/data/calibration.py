"""Calibration data: encoder readings against a reference, and its CSV form."""

import math
import os
import re
import stat
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from .._core import csv_dialect as _csv
from .._core.csv_numbers import line_count, plain_body, plain_file_rows, plain_rows
from .._core.number_cells import MAX_ABS_DEG, not_plain_note, read_number  # MAX_ABS_DEG: the largest |angle| read
from .._core.sorting import stable_argsort
from .._core.angles import ARCMIN_PER_DEG, READING_SIGNS, angle_unit, model_input, wrap180, wrap360
from .._core.errors import CalibrationError, EncalWarning
from .._core.parameters import check_bool, check_choice, check_int, check_number, check_type, invalid, real_array

__all__ = ["Calibration", "read_calibration", "write_calibration", "check_folds", "check_turns",
           "turn_checked_errors", "is_multi_revolution", "is_repeated_stops", "warn_if_in_radians"]


@dataclass(frozen=True, eq=False)
class Calibration:
    """One calibration run of one encoder.

    Parameters
    ----------
    reference_deg : array-like of shape (n,)
        Reference (true) angles in degrees; wrapped to [0, 360).
    encoder_deg : array-like of shape (n,)
        Encoder readings in degrees; wrapped to [0, 360).
    direction : array-like of shape (n,) of {+1, -1}, optional
        Direction of travel at each point, for bidirectional runs.
    epoch : array-like of shape (n,) of str, optional
        Label of the calibration run each point belongs to.
    name : str, default=''
        Encoder name.
    resolution_bits : int, optional
        Encoder resolution in bits, if known.
    source : str, optional
        File the calibration was read from.
    metadata : dict, optional
        Anything else known about the run.
    reading_sign : {1, -1}, default=1
        -1 when the encoder counts against the reference: ``encoder_deg`` then holds the negated readings
        (see ``reverse`` of :func:`read_calibration`), and models fitted to it record it.
    target_tolerance_deg : float, optional
        For a bidirectional run whose reference is read afresh at every approach (a rotary table positioned
        to its targets and measured by an autocollimator or a reference encoder): reference angles within this
        many degrees of a neighbour are one target position of ISO 230-2 (:func:`encal.data.reversal.reversal`,
        the mean of both directions). Default None: :data:`encal.data.reversal.TARGET_TOLERANCE_DEG`, the
        same angle written twice. From 0 (exclusive) to :data:`MAX_TARGET_TOLERANCE_DEG`.
    reference_std_arcmin : array-like of shape (n,), optional
        Standard uncertainty (one sigma, arc-minutes, finite, >= 0) of each point's error that is the
        reference's own, not noise of the reading: a self-calibration's (``encal selfcal``, its ``sigma_arcmin``
        column) or a reference's calibration certificate. It is shared by neighbouring points, so a fit cannot
        average it away: a model fitted to the calibration includes it in its uncertainty
        (:func:`encal.models.uncertainty.with_reference_uncertainty`). Default None: a reference exact for
        the purpose.

    Raises
    ------
    CalibrationError
        If the angles are not real numbers, not finite, or not one reading per reference angle (lengths, or 2-D
        shapes that would pair other readings once flattened), or a direction is not +1 or -1.
    """

    reference_deg: np.ndarray
    encoder_deg: np.ndarray
    direction: np.ndarray | None = None
    epoch: np.ndarray | None = None
    name: str = ""
    resolution_bits: int | None = None
    source: str | None = None
    metadata: dict = field(default_factory=dict)
    reading_sign: int = 1
    target_tolerance_deg: float | None = None
    reference_std_arcmin: np.ndarray | None = None

    def __post_init__(self):
        ref = real_array(self.reference_deg, "reference_deg", "Calibration", "real numbers of degrees",
                         error=CalibrationError)
        enc = real_array(self.encoder_deg, "encoder_deg", "Calibration", "real numbers of degrees",
                         error=CalibrationError)
        if ref.shape != enc.shape and np.squeeze(ref).shape != np.squeeze(enc).shape and max(ref.ndim, enc.ndim) > 1:
            # flattened, a (2, n) reference and an (n, 2) encoder would pair other readings than the caller's
            raise CalibrationError(
                f"reference_deg has the shape {ref.shape} but encoder_deg {enc.shape}; expected one reading per "
                "reference angle, in two 1-D arrays of the same length"
            )
        ref, enc = ref.reshape(-1), enc.reshape(-1)
        if ref.shape != enc.shape:
            raise CalibrationError(
                f"reference_deg has {ref.size} values but encoder_deg has {enc.size}; "
                "expected one reading per reference angle"
            )
        if not (np.all(np.isfinite(ref)) and np.all(np.isfinite(enc))):
            raise CalibrationError("calibration angles must be finite numbers (found NaN or infinity)")
        if self.resolution_bits is not None:
            object.__setattr__(self, "resolution_bits", check_int(
                self.resolution_bits, "resolution_bits", "Calibration", low=1, high=MAX_BITS,
                note="or None when unknown", error=CalibrationError))
        if self.reading_sign not in READING_SIGNS or isinstance(self.reading_sign, bool):
            raise invalid("reading_sign", "Calibration", "1 or -1", self.reading_sign, error=CalibrationError)
        if self.target_tolerance_deg is not None:
            object.__setattr__(self, "target_tolerance_deg", check_number(
                self.target_tolerance_deg, "target_tolerance_deg", "Calibration", low=0.0, low_open=True,
                high=MAX_TARGET_TOLERANCE_DEG, note="degrees, or None: the same angle written twice",
                error=CalibrationError))
        object.__setattr__(self, "reference_deg", wrap360(ref).reshape(-1))
        object.__setattr__(self, "encoder_deg", wrap360(enc).reshape(-1))
        if self.direction is not None:
            direction = np.asarray(self.direction).reshape(-1)
            # checked before the cast to int8, which would make 1.7 a 1 and 'cw' a ValueError
            if direction.shape != ref.shape or direction.dtype.kind not in "iuf" \
                    or not np.all(np.isin(direction, (-1, 1))):
                raise CalibrationError("direction must hold +1 or -1 for every point")
            object.__setattr__(self, "direction", direction.astype(np.int8))
        if self.epoch is not None:
            epoch = np.asarray(self.epoch, dtype=str).reshape(-1)
            if epoch.shape != ref.shape:
                raise CalibrationError("epoch must hold one label for every point")
            object.__setattr__(self, "epoch", epoch)
        if self.reference_std_arcmin is not None:
            object.__setattr__(self, "reference_std_arcmin", _checked_reference_std(self.reference_std_arcmin,
                                                                                   ref.shape))
        # Frozen, arrays and all (they are the calibration's own: made above): what a check found stays true.
        for values in (self.reference_deg, self.encoder_deg, self.direction, self.epoch, self.reference_std_arcmin):
            if values is not None:
                values.flags.writeable = False

    def __len__(self):
        return self.reference_deg.size

    @property
    def errors_arcmin(self):
        """Error ``encoder - reference`` of every point, in arc-minutes.

        Each difference is wrapped to within 180 degrees of the differences' circular mean. For the usual
        small errors that is the (-180, 180] degree convention of DESIGN.md; for a calibration whose zero
        offset is near 180 degrees it keeps the profile continuous instead of splitting it into values near
        +10800 and -10800 arcmin.
        """
        known = _passed(self).get("errors")
        if known is None:
            known = _remember_errors(self, _errors_arcmin(self))
        return known.copy()

    @property
    def readings_deg(self):
        """The encoder readings as the encoder gave them, in degrees in [0, 360) (``encoder_deg`` un-negated)."""
        return model_input(self.encoder_deg, self.reading_sign)

    def subset(self, index):
        """A calibration holding only the points selected by ``index`` (mask or indices)."""
        try:
            kept = np.arange(self.reference_deg.size)[index]
        except (IndexError, TypeError, ValueError):
            shown = repr(index) if len(repr(index)) <= 40 else f"an index of type {type(index).__name__}"
            raise CalibrationError(f"Calibration.subset expects a mask of {self.reference_deg.size} booleans, indices "
                                   f"from {-self.reference_deg.size} to {self.reference_deg.size - 1} or a slice; "
                                   f"got {shown}") from None
        pick = lambda a: None if a is None else a[kept]  # noqa: E731
        return Calibration(
            self.reference_deg[kept],
            self.encoder_deg[kept],
            direction=pick(self.direction),
            epoch=pick(self.epoch),
            name=self.name,
            resolution_bits=self.resolution_bits,
            source=self.source,
            metadata=dict(self.metadata),
            reading_sign=self.reading_sign,
            target_tolerance_deg=self.target_tolerance_deg,
            reference_std_arcmin=pick(self.reference_std_arcmin),
        )


def _checked_reference_std(values, shape):
    """``reference_std_arcmin`` as a new float array of ``shape``, or a CalibrationError saying what is wrong."""
    try:
        std = np.array(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        std = None
    if std is None or std.shape != shape:
        raise CalibrationError("reference_std_arcmin must hold one standard uncertainty (arcmin) for every point")
    bad = ~np.isfinite(std) | (std < 0)
    if np.any(bad):
        raise CalibrationError(f"reference_std_arcmin must be finite numbers of arc-minutes >= 0; point "
                               f"{int(np.argmax(bad)) + 1} has {float(std[np.argmax(bad)])!r}")
    return std


def _passed(cal):
    """What was found of ``cal`` already (its arrays are read-only): ``'turns'`` and ``'folds'`` when those checks
    passed, ``'errors'`` its :attr:`Calibration.errors_arcmin` (read-only); a fit need not check again what
    :func:`read_calibration` checked, nor compute the errors again (on 10^6 readings each costs tens of ms)."""
    return cal.__dict__.setdefault("_passed", {})


def remembered(cal, what, compute):
    """``compute(cal)``, once per calibration (its arrays are read-only): ``what`` names the result among those
    kept (``'arc'``: the arc :func:`encal._core.arcs.arc_of` finds, which reading the file may have found
    already)."""
    found = _passed(cal)
    if what not in found:
        found[what] = compute(cal)
    return found[what]


def _remember_errors(cal, errors):
    errors.flags.writeable = False
    _passed(cal)["errors"] = errors
    return errors


def _mean_phasor(reference_deg, encoder_deg):
    """``mean(exp(i (encoder - reference)))`` (angles in degrees) as a complex number: the errors' circular mean
    is its angle, the coherence of :func:`check_turns` its modulus (the cosines and sines of the differences
    computed once for both)."""
    difference = np.radians(encoder_deg - reference_deg)
    return complex(np.cos(difference).mean(), np.sin(difference).mean())


def _errors_arcmin(cal, mean_phasor=None):
    """:attr:`Calibration.errors_arcmin`; ``mean_phasor``: :func:`_mean_phasor` of ``cal``, if known."""
    if mean_phasor is None:
        mean_phasor = _mean_phasor(cal.reference_deg, cal.encoder_deg)
    centre = np.degrees(np.arctan2(mean_phasor.imag, mean_phasor.real))
    if abs(centre) < 90.0:
        centre = 0.0  # the common case: plain (-180, 180] wrapping
    delta = wrap180(cal.encoder_deg - cal.reference_deg - centre)
    return (centre + delta) * ARCMIN_PER_DEG


# --------------------------------------------------------------------------- CSV

_REQUIRED = ("reference_deg", "encoder_deg")
MIN_POINTS = 8
MAX_GAP_DEG = 30.0
#: Encoder resolutions a calibration may declare, in bits.
MAX_BITS = 32
#: Largest target tolerance (degrees): ISO 230-2's targets on a rotary axis are degrees apart, and a tolerance that
#: joins neighbouring targets is refused by :func:`encal.data.reversal.target_positions` in any case.
MAX_TARGET_TOLERANCE_DEG = 10.0
#: Largest backward travel of the encoder, in degrees, while the reference moves forward, taken for
#: reading noise (see :func:`check_folds`).
MAX_FOLD_DEG = 0.5
#: Largest calibration file read, in bytes (a million rows take about 40 MB): beyond it the input is not a
#: calibration (``/dev/zero``, an endless pipe) and reading on would exhaust the memory.
MAX_FILE_BYTES = 1 << 30
_READ_CHUNK = 1 << 20
#: Lines the careful (line-by-line) reader reads between two calls of ``progress``.
_PROGRESS_LINES = 50_000
_LINE_END_BYTES = re.compile(rb"\r\n|\r|\n")
#: Mean travel of the reference, in degrees, over which :func:`is_multi_revolution` takes each step of a
#: dense log: far above a reference's quantisation and jitter, far below a turn.
SWEEP_STEP_DEG = 1.0
#: What :func:`read_calibration` may do with conflicting repeated reference angles.
DUPLICATES = ("refuse", "average", "keep")


def _fail(path, line, message, column=None):
    where = f"{path}, line {line}" + (f", column {column}" if column is not None else "")
    raise CalibrationError(f"{where}: {message}")


#: Age, in nanoseconds, of a regular file's last change below which it is not parsed again from its path (it may be
#: being written): where time stamps are coarse (a kernel tick of up to 10 ms, before Linux 6.13's fine-grained
#: ones) a rewrite in the same tick would leave its size, times and inode as they were.
_SETTLED_NS = 100_000_000
_clock_ns = time.time_ns


def _read_bytes(path):
    """The file's bytes, and its ``os.stat_result`` if it is a regular file whose last change (``st_mtime``,
    ``st_ctime``) is :data:`_SETTLED_NS` older than the read (else None: read from the bytes alone).

    Read in chunks: a binary or endless input is refused at its first NUL byte or at :data:`MAX_FILE_BYTES`, not
    after it has filled the memory. A regular file's bytes up to its size are read at once (half the time of
    chunks joined), then whatever it grew by in chunks.
    """
    chunks, size = [], 0
    with open(path, "rb") as handle:
        status = os.fstat(handle.fileno())
        regular = stat.S_ISREG(status.st_mode)
        settled = _clock_ns() - max(status.st_mtime_ns, status.st_ctime_ns) >= _SETTLED_NS
        first = handle.read(status.st_size) if regular and 0 < status.st_size <= MAX_FILE_BYTES else b""
        while chunk := first or handle.read(_READ_CHUNK):
            first = b""
            if b"\x00" in chunk:
                before = b"".join(chunks) + chunk[:chunk.index(b"\x00")]
                _decode(path, before)  # UTF-16 and other encodings are named as such
                _fail(path, before.count(b"\n") + 1, "contains NUL bytes (is this a binary file?); expected a "
                                                      "calibration CSV")
            size += len(chunk)
            if size > MAX_FILE_BYTES:
                raise CalibrationError(f"{path}: is larger than {MAX_FILE_BYTES >> 20} MiB; expected a calibration "
                                       "CSV (is this an endless stream or a device?)")
            chunks.append(chunk)
    return (chunks[0] if len(chunks) == 1 else b"".join(chunks)), (status if regular and settled else None)


def _decode(path, raw):
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        _fail(path, line, "not UTF-8 text (is this a binary file?); expected a calibration CSV")
    if "\x00" in text:
        line = text[: text.index("\x00")].count("\n") + 1
        _fail(path, line, "contains NUL bytes (is this a binary file?); expected a calibration CSV")
    return text


def _head_of_plain(raw):
    """The lines of an ASCII file up to its first that is not blank or a comment, and where that line and the
    rest begin: ``(lines, header_start, body_start)`` in bytes; None if those lines are not ASCII or the rest holds
    a ``#`` or a double quote (comments and quoted fields are for the careful reader). Whether the rest is ASCII
    is left to the test of a plain body (:func:`encal._core.csv_numbers.plain_body`).

    Line ends are those of :func:`encal._core.csv_dialect.split_lines` (LF, CRLF or CR).
    """
    lines, start = [], 0
    for match in _LINE_END_BYTES.finditer(raw):
        line = raw[start:match.start()]
        if not line.isascii():
            return None
        line = line.decode("ascii")
        lines.append(line)
        line_start, start = start, match.end()
        if not _csv.is_skipped(line):
            break
    else:
        line_start = start
        if start < len(raw):
            if not raw[start:].isascii():
                return None
            lines.append(raw[start:].decode("ascii"))
            start = len(raw)
    if raw.find(b"#", start) >= 0 or raw.find(b'"', start) >= 0:
        return None
    return lines, line_start, start


#: Largest plain file read by one ``np.loadtxt`` of its path (about 2·10^6 rows of two angles, 0.3 s): larger ones
#: are read from memory in pieces, for the progress line.
_ONE_PIECE_BYTES = 1 << 26


def _plain_table(path, raw, status, skip_lines, body_start, separator, n_columns, progress=None):
    """The numbers of a file whose lines from ``body_start`` (after ``skip_lines`` lines) are plain numbers
    (:mod:`encal._core.csv_numbers`), or None. A regular file of up to :data:`_ONE_PIECE_BYTES` that has not
    changed since ``raw`` was read (size, times, inode) is read again by NumPy from its path, the fastest way;
    else ``raw``. ``status``: of :func:`_read_bytes`, None for a file not to be read again."""
    if status is not None and len(raw) <= _ONE_PIECE_BYTES:
        if not plain_body(raw, body_start):
            return None
        rows = line_count(raw, body_start)
        if progress is not None:
            progress(0, len(raw) - body_start)
        table = plain_file_rows(path, skip_lines, rows, separator, n_columns)
        try:
            now = os.stat(path)
        except OSError:
            now = None
        if table is not None and now is not None and (now.st_size, now.st_mtime_ns, now.st_ctime_ns, now.st_ino) == \
                (status.st_size, status.st_mtime_ns, status.st_ctime_ns, status.st_ino):
            if progress is not None:
                progress(len(raw) - body_start, len(raw) - body_start)
            return table
    return plain_rows(raw[body_start:], separator, n_columns, progress=progress)


def _plain_angles(values, unit):
    """True if every value is finite and within +-1e9 degrees in ``unit`` (what :func:`_parse_float` checks)."""
    if values.size == 0:
        return True
    lowest, highest = values.min(), values.max()  # NaN if any is; |v * f| is largest at an end (f > 0)
    with np.errstate(over="ignore", invalid="ignore"):
        return bool(np.isfinite(lowest) and np.isfinite(highest) and
                    max(abs(lowest * unit.degrees_per_unit), abs(highest * unit.degrees_per_unit)) <= MAX_ABS_DEG)


def _cells(path, number, line, separator=","):
    """The fields of line ``number`` in encal's CSV dialect (:mod:`encal._core.csv_dialect`)."""
    try:
        return _csv.fields(line, separator)
    except _csv.QuotingError as exc:
        _fail(path, number, f"{exc}")


def _shown(text, limit=40):
    """``text`` for a message: whole if short, else its start and '...' (a cell may be megabytes long)."""
    return text if len(text) <= limit else text[:limit - 3] + "..."


_UNIT_WORDS = {"deg": "degrees", "rad": "radians", "rev": "revolutions", "counts": "counts"}


def _parse_float(path, line, column, name, cell, unit=None, decimal_comma=False):
    """The number in a cell, checked finite and within +-1e9 degrees once converted from ``unit``.

    With ``decimal_comma`` (a file not separated by commas), a comma in the cell is its decimal mark.
    """
    words = _UNIT_WORDS[unit.name] if unit is not None else "degrees"
    text = cell.replace(",", ".") if decimal_comma and "," in cell else cell
    try:
        value = read_number(text)
    except ValueError:
        why = not_plain_note(text)  # '1_0', a full-width digit: a number to Python alone
        grouping = (" (a comma is read as the decimal mark in a file separated by semicolons, tabs or blanks; "
                    "digit grouping is not read)" if decimal_comma and "," in cell and not why else "")
        _fail(path, line, f"{name} is {_shown(cell)!r}, expected a number of {words}{grouping}{why}", column)
    if not np.isfinite(value):
        _fail(path, line, f"{name} is {_shown(cell.strip())!r}, expected a finite number of {words}", column)
    degrees = value if unit is None else value * unit.degrees_per_unit
    if abs(degrees) > MAX_ABS_DEG:
        _fail(path, line, f"{name} is {_shown(cell.strip())!r}, expected an angle within +-{MAX_ABS_DEG:g} "
                          f"degrees (beyond that a double cannot hold the angle within a turn to 1e-5 arcmin; "
                          f"is this column counts or time stamps? Say so with a unit, e.g. --enc-unit counts:14)",
              column)
    return value


#: The column of a calibration CSV that holds :attr:`Calibration.reference_std_arcmin` (``encal selfcal`` writes it).
REFERENCE_STD_COLUMN = "sigma_arcmin"
#: The comment (``# reading_noise_arcmin: X``) and metadata key of one reading's noise, arc-minutes RMS, measured by a
#: self-calibration from its log: its curve is smoothed, so a model fitted to it cannot see the noise of a new reading.
READING_NOISE_KEY = "reading_noise_arcmin"


def _parse_std(path, line, column, cell, decimal_comma=False):
    """The standard uncertainty in a ``sigma_arcmin`` cell: a finite number of arc-minutes >= 0."""
    text = cell.replace(",", ".") if decimal_comma and "," in cell else cell
    try:
        value = read_number(text)
    except ValueError:
        value = None
    if value is None or not np.isfinite(value) or value < 0:
        why = not_plain_note(text) if value is None else ""
        _fail(path, line, f"{REFERENCE_STD_COLUMN} is {_shown(cell.strip())!r}, expected the reference's standard "
                          f"uncertainty, a finite number of arc-minutes >= 0{why}", column)
    return value


def _plain_stds(values):
    """True if every value is a finite number >= 0 (what :func:`_parse_std` checks)."""
    return values.size == 0 or bool(np.all(np.isfinite(values)) and values.min() >= 0)


def _check_decimal_marks(path, first_comma, first_point):
    """Refuse a file whose numbers use both a decimal comma and a decimal point: its commas may group digits
    (``1,080`` for 1080), and reading them as decimal commas would give wrong numbers.

    ``first_comma``, ``first_point``: ``(line, column, cell)`` of the first number read with each mark, or None.
    """
    if first_comma is None or first_point is None:
        return
    (line, column, cell), (point_line, _, point_cell) = first_comma, first_point
    _fail(path, line, f"{cell.strip()!r} has a comma, read as a decimal comma, but line {point_line} writes "
                      f"{point_cell.strip()!r} with a decimal point; expected one decimal mark in the whole file "
                      "(is the comma grouping digits? Save the numbers without digit grouping)", column)


def read_calibration(path, *, allow_gaps=False, reverse=False, name=None, resolution_bits=None,
                     duplicates="refuse", reference_column="reference_deg", encoder_column="encoder_deg",
                     reference_unit="deg", encoder_unit="deg", progress=None, target_tolerance_deg=None):
    """Read a calibration CSV (see DESIGN.md).

    The file is UTF-8 text (a byte-order mark is accepted), comma-separated (encal's dialect,
    :mod:`encal._core.csv_dialect`), or as a spreadsheet exports it, separated by semicolons or tabs with a decimal
    comma (:func:`encal._core.csv_dialect.separator_of`), or, when its header has none of these, separated by blanks
    (spaces or tabs); in a file not separated by commas a comma in a number is its decimal mark. It
    has one header row naming at least the reference and the encoder column (``reference_deg`` and
    ``encoder_deg`` unless named otherwise; any letter case, any order, other columns ignored, each
    named once), may have ``#`` comment lines, and LF, CRLF or CR line ends. Angles may be any finite
    numbers within +-1e9 degrees (2.8 million turns) once converted from their unit; they are wrapped into [0, 360).
    Numbers are plain ASCII decimals (:mod:`encal._core.number_cells`): not ``1_0`` nor other scripts' digits.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file.
    allow_gaps : bool, default=False
        Accept a calibration whose largest gap between neighbouring encoder angles exceeds 30 degrees.
        No model knows the error where the encoder was never seen, so this is refused by default.
    reverse : bool, default=False
        The encoder counts against the reference: use ``-encoder_deg`` (mod 360).
    name : str, optional
        Encoder name; by default the file's stem.
    resolution_bits : int, optional
        Encoder resolution in bits (1 to 32), if known; read from a ``# resolution_bits: B`` comment
        otherwise.
    duplicates : {'refuse', 'average', 'keep'}, default='refuse'
        What to do with repeated reference angles whose readings disagree (points of one direction and
        epoch). Identical repeats are always kept as they are. ``'keep'`` keeps every repeat as a
        repeated reading of its stop (the spectral model takes the noise from their scatter). A file that
        is plainly a log of several revolutions (:func:`is_multi_revolution`) keeps its repeats as
        repeated readings unless ``'average'`` is asked for, and so does a run (points of one direction
        and epoch) with the same number of readings at every stop, in a row or in passes
        (:func:`is_repeated_stops`); a stray repeat elsewhere is still refused. Repeats are refused only where
        the reference angles are stops (the data's own grid decides, see :func:`_reference_has_stops`): two
        equal angles among continuous ones (random, or sampled in time) are a coincidence of the decimals.
    reference_column, encoder_column : str or int, default='reference_deg', 'encoder_deg'
        The columns of the reference and the encoder angle: a header name (any letter case) or a
        column number from 1. With numbers for both, a file whose first row is numbers has no header.
    reference_unit, encoder_unit : str, default='deg'
        Unit of each column: 'deg', 'rad', 'rev' (turns) or 'counts:B' (codes of a B-bit encoder; an
        encoder column in counts also sets ``resolution_bits`` to B when the file does not say).
    progress : callable, optional
        Called as ``progress(done, total)`` while the rows are read (bytes or lines done of the total), for
        a progress bar on a long file.
    target_tolerance_deg : float, optional
        Reference angles within this many degrees of a neighbour are one target position of a bidirectional
        run (see :class:`Calibration`).

    Returns
    -------
    Calibration

    Raises
    ------
    CalibrationError
        With one sentence naming the file, line and column, for: a missing or empty file, no header or a
        header without the two columns or naming a column twice, a row whose field count differs from
        the header's, a unit other than the four above, non-numeric (``1_0`` included), NaN, infinite or
        absurdly large (beyond +-1e9 degrees) values, decimal commas mixed with decimal points in a file not
        separated by commas, a resolution outside 1 to 32 bits, fewer than 8 points,
        a coverage gap over 30 degrees (unless ``allow_gaps``), an encoder that counts against the reference
        (unless ``reverse``), an encoder that goes back while the reference goes forward (see
        :func:`check_folds`), conflicting repeated reference angles.

    Warns
    -----
    EncalWarning
        When a column's values all lie within one turn measured in radians and span most of it: angles
        in radians over a full revolution, probably, where degrees were expected.
    """
    from pathlib import Path

    where = "read_calibration"
    allow_gaps = check_bool(allow_gaps, "allow_gaps", where)
    reverse = check_bool(reverse, "reverse", where)
    if resolution_bits is not None:
        resolution_bits = check_int(resolution_bits, "resolution_bits", where, low=1, high=MAX_BITS,
                                    note="or None: from the file's comment, if any")
    duplicates = check_choice(duplicates, "duplicates", where, DUPLICATES)
    if name is not None:
        check_type(name, str, "name", where, "a str or None")
    if isinstance(path, bool) or not (isinstance(path, (str, bytes)) or hasattr(type(path), "__fspath__")):
        raise invalid("path", where, "the path of a calibration CSV (a str or os.PathLike)", path,
                      error=CalibrationError)
    path = Path(os.fsdecode(path))
    if not path.exists():
        raise CalibrationError(f"{path}: no such file; expected a calibration CSV")
    if path.is_dir():
        raise CalibrationError(f"{path}: is a folder; expected a calibration CSV file")
    try:
        raw, status = _read_bytes(path)
    except OSError as exc:
        raise CalibrationError(f"{path}: cannot be read ({exc.strerror or exc}); expected a calibration CSV") from None
    head = _head_of_plain(raw)
    if head is not None:  # a plain body: only the lines up to the header are needed as text
        lines, header_start, body_start = head
        records = [(number, line) for number, line in enumerate(lines, start=1) if not _csv.is_skipped(line)]
    else:
        lines = _csv.split_lines(_decode(path, raw))
        records = [(number, line) for number, line in enumerate(lines, start=1) if not _csv.is_skipped(line)]
    if resolution_bits is None:
        resolution_bits = _resolution_from_comments(path, lines)
    reading_noise = _reading_noise_from_comments(path, lines)
    if not records:
        raise CalibrationError(f"{path}: the file is empty; expected a header row "
                               "'reference_deg,encoder_deg' and at least 8 rows of angles")
    try:
        units = angle_unit(reference_unit), angle_unit(encoder_unit)
    except ValueError as exc:
        raise CalibrationError(f"{path}: {exc}") from None
    header_line, header = records[0]
    separator = _csv.separator_of(header)
    decimal_comma = separator != ","  # a spreadsheet's export where the comma is the decimal mark

    def cells_of(number, line):
        return _cells(path, number, line, separator) if separator is not None else line.split()

    names = cells_of(header_line, header)
    columns, has_header = _header_columns(path, header_line, names, reference_column, encoder_column,
                                          decimal_comma=decimal_comma)
    n_columns = len(names)
    ref_col, enc_col = columns["reference"], columns["encoder"]
    ref_name, enc_name = columns["reference_name"], columns["encoder_name"]
    dir_col, epoch_col = columns.get("direction"), columns.get("epoch")
    std_col = columns.get("reference_std")
    reference_std = [] if std_col is not None else None
    table = None
    if head is not None and dir_col is None and epoch_col is None and separator in (",", None):
        first = header_line + 1 if has_header else header_line
        table = _plain_table(path, raw, status, len(lines) - (not has_header),
                             body_start if has_header else header_start, separator, n_columns, progress)
        if table is not None:
            reference, encoder = table[:, ref_col].copy(), table[:, enc_col].copy()
            if std_col is not None:
                reference_std = table[:, std_col].copy()
            if not (_plain_angles(reference, units[0]) and _plain_angles(encoder, units[1])
                    and (std_col is None or _plain_stds(reference_std))):
                table = None  # the careful reader names the first bad value
    if table is not None:
        del table
        line_numbers = np.arange(first, first + reference.size)
        direction, epoch = [], []
    else:
        if head is not None:
            lines = _csv.split_lines(_decode(path, raw))
            records = [(number, line) for number, line in enumerate(lines, start=1) if not _csv.is_skipped(line)]
        reference, encoder, direction, epoch = [], [], [], []
        reference_std = [] if std_col is not None else None
        marks = {",": None, ".": None}  # the first number read with a decimal comma, with a decimal point
        data = records[1:] if has_header else records
        for count, (number, line) in enumerate(data, start=1):
            cells = cells_of(number, line)
            if len(cells) != n_columns:
                _fail(path, number, _field_count_problem(line, len(cells), n_columns, separator))
            reference.append(_parse_float(path, number, ref_col + 1, ref_name, cells[ref_col], units[0],
                                          decimal_comma))
            encoder.append(_parse_float(path, number, enc_col + 1, enc_name, cells[enc_col], units[1],
                                        decimal_comma))
            if decimal_comma and (marks[","] is None or marks["."] is None):
                # (the sigma column too: '1,080' beside angles written with a point may group digits)
                for column in (ref_col, enc_col) + (() if std_col is None else (std_col,)):
                    for mark in ",.":
                        if marks[mark] is None and mark in cells[column]:
                            marks[mark] = (number, column + 1, cells[column])
                _check_decimal_marks(path, marks[","], marks["."])
            if dir_col is not None:
                sense = _csv.direction_of(cells[dir_col].strip(" \t"))  # ASCII blanks only, as around a number
                if sense is None:
                    _fail(path, number, f"direction is {cells[dir_col].strip()!r}, expected +1, -1, cw or ccw",
                          dir_col + 1)
                direction.append(sense)
            if epoch_col is not None:
                epoch.append(cells[epoch_col].strip())
            if std_col is not None:
                reference_std.append(_parse_std(path, number, std_col + 1, cells[std_col], decimal_comma))
            if progress is not None and count % _PROGRESS_LINES == 0:
                progress(count, len(data))
        line_numbers = np.array([number for number, _ in data], dtype=np.int64)
        del lines, records, data
    del raw
    if len(reference) < MIN_POINTS:
        raise CalibrationError(f"{path}: has {len(reference)} calibration points, expected at least "
                               f"{MIN_POINTS} to model an error profile")
    in_degrees = {ref_name: np.asarray(reference), enc_name: np.asarray(encoder)}
    as_read = in_degrees[ref_name], in_degrees[enc_name]
    _warn_if_radians(path, {key: values for (key, values), unit in zip(in_degrees.items(), units)
                            if unit.name == "deg"})
    reference, encoder = units[0].to_degrees(reference), units[1].to_degrees(encoder)
    if resolution_bits is None and units[1].name == "counts":
        resolution_bits = units[1].bits
    if reverse:
        encoder = -encoder
    cal = Calibration(
        np.asarray(reference), encoder,
        direction=np.asarray(direction) if dir_col is not None else None,
        epoch=np.asarray(epoch) if epoch_col is not None else None,
        name=name if name is not None else path.stem,
        resolution_bits=resolution_bits,
        source=str(path),
        reading_sign=-1 if reverse else 1,
        target_tolerance_deg=target_tolerance_deg,
        reference_std_arcmin=reference_std,
        metadata={} if reading_noise is None else {READING_NOISE_KEY: reading_noise},
    )
    rows = cal
    runs = _runs(cal)
    # of one run, the coherence is the modulus of the errors' mean phasor: computed once for both
    phasor = _mean_phasor(cal.reference_deg, cal.encoder_deg) if runs is None else None
    _check_turns(*as_read, units, reverse=reverse, runs=runs, where=str(path),
                 found=None if phasor is None else abs(phasor))
    del as_read, in_degrees
    # one sort by reference angle serves every check of a calibration of one run
    order = reference_order = sorted_reference = None
    if runs is None:
        order, sorted_reference = stable_argsort(cal.reference_deg, return_sorted=True)
        reference_order = order
    repeated = None
    if duplicates == "refuse":
        def repeated():
            # k readings at every stop of a run, or a run that is a continuous log over several turns: repeated
            # readings; a stray repeat in another run is still refused. Asked for only when there are repeats.
            pattern = _repeat_pattern(cal.reference_deg, runs, order=order)[0]
            return pattern if pattern.all() else pattern | _multi_revolution_runs(reference, runs)
    cal = _check_duplicates(path, cal, duplicates, repeated=repeated, order=order, sorted_reference=sorted_reference)
    if cal is not rows:
        order = None
    by_reference = None if order is None else (sorted_reference, cal.encoder_deg[order])
    del sorted_reference
    _check_direction_of_count(path, cal, reverse, order=order, by_reference=by_reference)
    _check_folds(cal, str(path), order=order, by_reference=by_reference)
    del by_reference
    _check_coverage(path, cal, allow_gaps)
    errors = None if phasor is None else _remember_errors(rows, _errors_arcmin(rows, phasor))
    if phasor is not None:
        _passed(rows)["turns"] = True  # the check of the columns in their units is the fit's check, passed
    _warn_if_isolated(path, rows, line_numbers, order=None if runs is not None else reference_order, errors=errors)
    return cal


def _selfcal_hint(names, missing):
    """For the header of a log with no reference column, the ``encal selfcal`` method that reads it (or '')."""
    names = {name.strip().lower() for name in names}
    if {"motor_deg", "output_deg"} <= names:
        return "; a log of two encoders of one joint has no reference: encal selfcal dual makes it calibrations"
    for column, method, log in (("electrical_deg", "sweep", "an electrical-angle sweep"), ("time_s", "spin", "a spin")):
        if column in names and missing == ["reference_deg"]:
            return f"; a log of {log} has no reference: encal selfcal {method} makes it a calibration"
    return ""


def _field_count_problem(line, n_fields, n_columns, header_separator=","):
    """Why a row of ``n_fields`` fields does not fit a header of ``n_columns`` columns (a message)."""
    fields = f"{n_fields} field" + ("s" if n_fields != 1 else "")
    if n_fields > n_columns:
        why = ("a decimal comma, or a value holding a comma that is not quoted? Name every extra column "
               "in the header" if header_separator == "," else
               "a value holding a separator that is not quoted? Name every extra column in the header")
    else:
        others = [(sep, label) for sep, label in ((";", "semicolons"), ("\t", "tabs"), (",", "commas"))
                  if sep != header_separator and not (header_separator is None and sep == "\t")]
        separator = next((label for sep, label in others if sep in line), None)
        why = f"its fields are separated by {separator}" if separator else "is the file truncated?"
    return f"has {fields}, expected {n_columns} as in the header ({why})"


def _warn_if_isolated(path, cal, line_numbers, order=None, errors=None):
    """Warn about readings far off their neighbours on both sides, or off the other readings at their reference
    angle when most angles were read several times (:mod:`encal.analysis.outliers`), per direction and epoch.
    ``order``: the stable argsort of the reference angles of a calibration of one run, if known; ``errors``:
    ``cal.errors_arcmin``, if known."""
    from ..analysis.outliers import ISOLATION_FACTOR, isolated_points

    quantum = None if cal.resolution_bits is None else 360.0 * ARCMIN_PER_DEG / 2**cal.resolution_bits
    runs = _runs(cal)
    errors = cal.errors_arcmin if errors is None else errors
    found = []
    each = np.zeros(1, dtype=int) if runs is None else np.unique(runs)
    for run in each:
        members = np.flatnonzero(runs == run) if each.size > 1 else slice(None)  # one run: no copies
        isolated = isolated_points(cal.encoder_deg[members], errors[members], reference_deg=cal.reference_deg[members],
                                   quantum_arcmin=quantum, reference_order=order if each.size == 1 else None)
        found += [(i if each.size == 1 else members[i], d, isolated.typical_step_arcmin, isolated.repeated)
                  for i, d in zip(isolated.index, isolated.deviation_arcmin)]
    if not found:
        return
    found.sort()
    index, deviation, step, repeated = found[0]
    where = f"line {line_numbers[index]} (encoder {cal.encoder_deg[index]:.3f} deg)"
    more = f", and {len(found) - 1} more reading{'s' if len(found) > 2 else ''} like it" if len(found) > 1 else ""
    if repeated:
        off = (f"{abs(deviation):.4g} arcmin off the median of the readings at its reference angle, over "
               f"{ISOLATION_FACTOR:g} times the readings' typical spread of {step:.3g} arcmin")
    else:
        off = (f"{abs(deviation):.4g} arcmin off its neighbours on both sides, over {ISOLATION_FACTOR:g} times their "
               f"typical step of {step:.3g} arcmin")
    warnings.warn(
        f"{path}: {where} has an error of {errors[index]:.4g} arcmin, {off}{more}: a misread? {MISREAD_EFFECT}; "
        "measure it again or remove the line", EncalWarning, stacklevel=3)


#: What a misread does to the models, in the warning about it.
MISREAD_EFFECT = ("It pulls every model towards it, and one that passes through the calibrated points (a lookup "
                  "table with a node at each, a network) follows it")


def _resolution_from_comments(path, lines):
    found = None  # (line number, bits) of the first declaration
    for number, line in enumerate(lines, start=1):
        if not line.lstrip().startswith("#"):
            continue
        stripped = line.strip().lstrip("#").strip().lower()
        if stripped.startswith("resolution_bits"):
            value = stripped.split(":", 1)[-1].split("=", 1)[-1].strip()
            if not (value.isascii() and value.isdigit() and 1 <= int(value) <= MAX_BITS):  # not '²': int() refuses it
                _fail(path, number, f"resolution_bits is {value!r}, expected a whole number of bits from 1 to "
                                    f"{MAX_BITS}")
            if found is None:
                found = (number, int(value))
            elif int(value) != found[1]:  # fuzz5: the first of two was taken, silently
                _fail(path, number, f"resolution_bits is {int(value)} but line {found[0]} says {found[1]}; expected "
                                    "one resolution (remove one of the comments)")
    return None if found is None else found[1]


def _reading_noise_from_comments(path, lines):
    """One reading's noise (arcmin) from a ``# reading_noise_arcmin: X`` comment (``encal selfcal`` writes it), or
    None; a value that is not a finite number >= 0, or two that differ, is refused with its line."""
    found = None  # (line number, value) of the first declaration
    for number, line in enumerate(lines, start=1):
        if not line.lstrip().startswith("#"):
            continue
        stripped = line.strip().lstrip("#").strip()
        if not stripped.lower().startswith(READING_NOISE_KEY):
            continue
        text = stripped[len(READING_NOISE_KEY):].lstrip().lstrip(":=").strip()
        try:
            value = float(text) if text.isascii() else math.nan
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value >= 0.0):
            _fail(path, number, f"{READING_NOISE_KEY} is {_shown(text)!r}, expected a number of arc-minutes >= 0 "
                                "(one reading's noise; correct or remove the comment)")
        if found is None:
            found = (number, value)
        elif value != found[1]:
            _fail(path, number, f"{READING_NOISE_KEY} is {value:g} but line {found[0]} says {found[1]:g}; expected "
                                "one reading noise (remove one of the comments)")
    return None if found is None else found[1]


def _warn_if_radians(path, columns):
    """Warn when angle columns look like radians over a full revolution (see :func:`_looks_like_radians`)."""
    suspects = [name for name, values in columns.items() if _looks_like_radians(values)]
    if suspects:
        values = np.concatenate([columns[name] for name in suspects])
        warnings.warn(
            f"{path}: {' and '.join(suspects)} all lie between {values.min():.4g} and {values.max():.4g}, as "
            "radians over a full revolution would; expected degrees (radians times 57.29578; if they are radians, "
            "say so with --unit rad, or --ref-unit rad or --enc-unit rad for one column)",
            EncalWarning, stacklevel=3)


def warn_if_in_radians(cal):
    """Warn when a calibration built in Python holds radians over a turn: in degrees it is an arc of about 6, fitted
    as such (or judged), its errors 57 times too small. :func:`read_calibration` warns of a file itself; this is for
    :func:`~encal.models.fitting.fit` and :func:`~encal.models.fitting.evaluate` of a calibration made in memory
    (the warning points at their caller)."""
    if all(_looks_like_radians(values) or _looks_like_radians(wrap180(values))
           for values in (cal.reference_deg, cal.encoder_deg)):
        warnings.warn(
            f"{cal.name or 'the calibration'}: reference_deg and encoder_deg all lie within one turn measured in "
            "radians, as radians over a full revolution would; expected degrees (if they are radians, pass "
            "numpy.degrees of them to Calibration)", EncalWarning, stacklevel=4)


def _looks_like_radians(values):
    """True if all ``values`` lie within one turn measured in radians (0..2 pi or -pi..pi) and span most of it.

    A calibration in degrees spanning so little (under 13 degrees) would leave a coverage gap of over 340
    degrees, so the test is safe; for radians over a whole revolution it always holds.
    """
    if values.size == 0:
        return False
    lowest, highest = float(values.min()), float(values.max())
    margin = 0.1  # radians: an offset or an error does not take radians far outside one turn
    return -np.pi - margin <= lowest and highest <= 2 * np.pi + margin and highest - lowest >= 1.5 * np.pi


def _header_columns(path, line, names, reference_column="reference_deg", encoder_column="encoder_deg", *,
                    decimal_comma=False):
    """Indices of the reference, encoder, direction and epoch columns, and whether ``names`` is a header.

    Returns ``({'reference': i, 'encoder': j, 'reference_name': ..., 'encoder_name': ..., 'direction': k,
    'epoch': l}, has_header)``; a column is chosen by its name or its number from 1.
    """
    names = [name.strip().lower() for name in names]
    # a first row of numbers (with decimal commas, where the separator is no comma) is no header
    is_number = (lambda text: _csv.is_number(text.replace(",", "."))) if decimal_comma else _csv.is_number
    numbered = [_column_number(column) for column in (reference_column, encoder_column)]
    if all(number is not None for number in numbered) and all(is_number(cell) for cell in names if cell):
        for column, number in zip((reference_column, encoder_column), numbered):
            if not 1 <= number <= len(names):
                _fail(path, line, f"there is no column {number}; expected a column number from 1 to {len(names)}")
        if numbered[0] == numbered[1]:
            _fail(path, line, f"the reference and the encoder column are both column {numbered[0]}; expected two "
                              "different columns")
        return ({"reference": numbered[0] - 1, "encoder": numbered[1] - 1,
                 "reference_name": f"column {numbered[0]}", "encoder_name": f"column {numbered[1]}"}, False)
    columns = {}
    for index, cell in enumerate(names):
        columns.setdefault(cell, index)
    wanted = [str(column).strip().lower() for column in (reference_column, encoder_column)]
    repeated = _csv.repeated_names(["" if is_number(name) else name for name in names])
    if repeated is not None:
        _fail(path, line, repeated)
    chosen = {}
    for role, column, name, number in zip(("reference", "encoder"), (reference_column, encoder_column), wanted,
                                          numbered):
        if name in columns:
            chosen[role], chosen[f"{role}_name"] = columns[name], name
        elif number is not None and 1 <= number <= len(names):
            chosen[role], chosen[f"{role}_name"] = number - 1, names[number - 1] or f"column {number}"
    missing = [name for role, name in zip(("reference", "encoder"), wanted) if role not in chosen]
    if missing:
        looks_numeric = all(is_number(cell) for cell in names if cell)
        found = "a row of numbers" if looks_numeric else f"columns {_shown(', '.join(names), 200)}"
        if (reference_column, encoder_column) == ("reference_deg", "encoder_deg"):
            hint = _selfcal_hint(names, missing)
            _fail(path, line, f"the header lacks {' and '.join(missing)}; expected a header row naming "
                              f"reference_deg and encoder_deg, found {found} (name your columns with --ref-col "
                              f"and --enc-col, their units with --ref-unit and --enc-unit{hint})")
        _fail(path, line, f"there is no column {missing[0]!r} in the header; expected the name of a column "
                          f"or its number from 1, found {found}")
    if chosen["reference"] == chosen["encoder"]:
        _fail(path, line, f"the reference and the encoder column are both column {chosen['reference'] + 1} "
                          f"({chosen['reference_name']}); expected two different columns")
    for optional in ("direction", "epoch"):
        if optional in columns:
            chosen[optional] = columns[optional]
    if REFERENCE_STD_COLUMN in columns:
        chosen["reference_std"] = columns[REFERENCE_STD_COLUMN]
    return chosen, True


def _column_number(column):
    """A column given as a number from 1 (an int or a string of digits), or None."""
    if isinstance(column, (int, np.integer)) and not isinstance(column, bool):
        return int(column)
    text = str(column).strip()
    return int(text) if text.isascii() and text.isdigit() else None


def is_multi_revolution(reference_deg):
    """Whether reference angles, in file order, are a continuous log of several revolutions.

    True when the reference moves one way (at least 95 % of the steps in one direction, wrapping at
    360° or counting past it) over at least one and a half turns: its repeated angles are then
    repeated readings of the same stops, not conflicting rows. The steps are taken over about
    :data:`SWEEP_STEP_DEG` of the travel each, and steps of zero are left out: a quantised reference
    (a 17-bit encoder) read faster than it changes code repeats a code, or jitters back by one, from
    one row to the next, and such a sweep is still one way.

    Examples
    --------
    >>> is_multi_revolution(np.tile(np.arange(0.0, 360.0, 0.5), 3))
    True
    >>> is_multi_revolution(np.arange(0.0, 360.0, 0.5))
    False
    """
    raw = np.asarray(reference_deg, dtype=float).reshape(-1)
    if raw.size < 16:
        return False
    turned = np.degrees(np.unwrap(np.radians(raw)))
    travel = abs(turned[-1] - turned[0])
    if travel < 540.0:
        return False
    stride = max(1, int(SWEEP_STEP_DEG / (travel / (raw.size - 1))))
    steps = np.diff(turned[::stride])
    steps = steps[steps != 0.0]
    return bool(steps.size >= 8 and max(np.mean(steps > 0), np.mean(steps < 0)) >= 0.95)


def _multi_revolution_runs(reference_deg, runs=None):
    """A mask over the points: those of runs (``runs``: a label per point, one run by default) whose reference
    angles, in file order, are a log of several revolutions (:func:`is_multi_revolution`)."""
    reference = np.asarray(reference_deg, dtype=float).reshape(-1)
    if runs is None:
        return np.full(reference.size, is_multi_revolution(reference))
    mask = np.zeros(reference.size, dtype=bool)
    for run in np.unique(runs):
        members = runs == run
        mask[members] = is_multi_revolution(reference[members])
    return mask


def is_repeated_stops(reference_deg, runs=None):
    """Whether reference angles, in file order, are the same number of readings at every stop.

    True when, within each run (``runs``: a label per point, e.g. of its direction and epoch; one run
    by default), the reference angles are k >= 2 copies of one sequence of distinct stops, either each
    stop k times in a row (``0, 0, 0, 2, 2, 2, ...``) or the whole sequence k times over
    (``0, 2, ..., 358, 0, 2, ..., 358``, the stops in the same order in every pass), with at least one
    run so repeated and the others without repeats. Angles are the same stop when equal to 1e-9 degree
    (as :func:`read_calibration` compares them). Such a file is a deliberate repeated-readings
    calibration, and its repeats are the noise of one reading; a stray repeated row, a different count
    at some stops, or a pass back in the reverse order (a second direction of travel, whose hysteresis
    is not noise) is not.

    Parameters
    ----------
    reference_deg : array-like of shape (n,)
        Reference angles in degrees, in file order.
    runs : array-like of shape (n,), optional
        Label of each point's run; the pattern is checked within each run.

    Examples
    --------
    >>> is_repeated_stops(np.repeat(np.arange(0.0, 360.0, 2.0), 3))
    True
    >>> is_repeated_stops(np.tile(np.arange(0.0, 360.0, 2.0), 2))
    True
    >>> is_repeated_stops(np.r_[np.arange(0.0, 360.0, 2.0), 10.0])
    False
    """
    repeated, irregular = _repeat_pattern(reference_deg, runs)
    return bool(repeated.any() and not irregular.any())


def _repeat_pattern(reference_deg, runs=None, order=None):
    """``(repeated, irregular)``, masks over the points: those of runs that follow the pattern of
    :func:`is_repeated_stops` with k >= 2, and those of runs with repeats that do not. ``order``: the stable
    argsort of ``reference_deg`` (wrapped to [0, 360)) of a single run, if known."""
    keys = np.round(wrap360(np.asarray(reference_deg, dtype=float).reshape(-1)), 9)
    runs = np.zeros(keys.size, dtype=int) if runs is None else np.asarray(runs).reshape(-1)
    repeated, irregular = np.zeros(keys.size, dtype=bool), np.zeros(keys.size, dtype=bool)
    for run in np.unique(runs) if order is None else (0,):
        members = runs == run if order is None else slice(None)
        sequence = keys[members]
        if order is None:
            stops, counts = np.unique(sequence, return_counts=True)
        else:  # rounding keeps the order: the keys sorted without a second sort
            ordered = sequence[order]
            starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
            stops, counts = ordered[starts], np.diff(np.r_[starts, ordered.size])
            del ordered
        if counts.max() == 1:
            continue
        k = int(counts[0])
        regular = counts.min() == counts.max()
        if regular:
            in_a_row, passes = sequence.reshape(stops.size, k), sequence.reshape(k, stops.size)
            regular = bool(np.all(in_a_row == in_a_row[:, :1]) or np.all(passes == passes[:1]))
        (repeated if regular else irregular)[members] = True
    return repeated, irregular


def _runs(cal):
    """A label per point of its run (direction and epoch), or None for a calibration of one run."""
    if cal.direction is None and cal.epoch is None:
        return None
    runs = np.zeros(len(cal), dtype=int)
    for labels in (cal.direction, cal.epoch):
        if labels is not None:
            runs = runs * (len(cal) + 1) + np.unique(labels, return_inverse=True)[1].reshape(-1)
    return runs


def _check_duplicates(path, cal, duplicates, repeated=None, order=None, sorted_reference=None):
    """``cal`` with its conflicting repeats refused, averaged or kept (``duplicates``); those of the points
    ``repeated`` (a mask, see :func:`_repeat_pattern`, or a function that returns it, called only when there are
    repeats) are always kept; ``order``: the stable argsort of the reference angles of a calibration of one run,
    if known, and ``sorted_reference`` the angles in that order.

    Points are repeats when their reference angles agree to :data:`STOP_DECIMALS` decimals and they belong to
    one run. Repeats are refused only where the reference angles are stops (:func:`_reference_has_stops`): in a
    log whose reference takes continuous values, two equal angles are a coincidence of the written decimals
    (ten decimals of 10^6 random angles give about three), not a second reading of one stop. One sort, no
    Python loop over the points.
    """
    if duplicates == "keep" or len(cal) < 2:
        return cal
    runs = _runs(cal)
    if runs is None and order is not None and sorted_reference is not None:
        sorted_keys = np.round(sorted_reference, STOP_DECIMALS)  # rounding keeps the order
    else:
        keys = np.round(cal.reference_deg, STOP_DECIMALS)
        if runs is not None:
            order = np.lexsort((runs, keys))
        elif order is None:
            order = stable_argsort(keys)
        sorted_keys = keys[order]
        del keys
    starts_group = np.ones(order.size, dtype=bool)
    starts_group[1:] = sorted_keys[1:] != sorted_keys[:-1]
    new_stop = starts_group.copy()
    if runs is not None:
        sorted_runs = runs[order]
        starts_group[1:] |= sorted_runs[1:] != sorted_runs[:-1]
        del sorted_runs
    if starts_group.all():
        return cal
    if duplicates == "refuse" and not _reference_has_stops(sorted_keys[new_stop]):
        return cal
    del sorted_keys, new_stop
    if callable(repeated):
        repeated = repeated()
    if repeated is not None and repeated.all():  # every repeat a repeated reading: nothing to refuse
        return cal
    group = np.cumsum(starts_group) - 1
    first = order[np.flatnonzero(starts_group)]  # the first point of each group, in file order
    encoder = cal.encoder_deg
    offsets = wrap180(encoder[order] - encoder[first][group])
    conflicting = np.abs(offsets) > 1e-9
    if repeated is not None:
        conflicting &= ~repeated[order]
    if not conflicting.any():
        return cal
    if duplicates == "refuse":
        at = int(np.argmax(conflicting))
        first, index = int(first[group[at]]), int(order[at])
        raise CalibrationError(
            f"{path}: reference angle {cal.reference_deg[index]:g} deg appears more than once with "
            f"different readings ({cal.encoder_deg[first]:g} and {cal.encoder_deg[index]:g} deg, data rows "
            f"{first + 1} and {index + 1}); expected one reading per reference angle, or the same number at "
            "every angle, each stop's readings in a row or the stops in the same order in every pass (use "
            "--keep-duplicates to keep them as repeated readings of one stop, --average-duplicates to average "
            "them)")
    mean_offset = np.bincount(group, weights=offsets) / np.bincount(group)
    in_file_order = np.argsort(first)
    keep = first[in_file_order]
    averaged = cal.subset(keep)
    return Calibration(averaged.reference_deg, (encoder[first] + mean_offset)[in_file_order],
                       direction=averaged.direction, epoch=averaged.epoch, name=cal.name,
                       resolution_bits=cal.resolution_bits, source=cal.source,
                       metadata={"averaged_duplicates": len(cal) - keep.size}, reading_sign=cal.reading_sign,
                       target_tolerance_deg=cal.target_tolerance_deg,
                       # the largest of a stop's: one reference angle's own uncertainty does not average away
                       reference_std_arcmin=None if cal.reference_std_arcmin is None else _group_largest(
                           cal.reference_std_arcmin[order], group)[in_file_order])


def _group_largest(values, group):
    """The largest of ``values`` in each run of equal labels of ``group`` (sorted labels 0, 1, ...)."""
    starts = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    return np.maximum.reduceat(values, starts)


#: Reference angles that agree to this many decimals of a degree are one stop (far below any reference's
#: resolution, far above the rounding of a double).
STOP_DECIMALS = 9
#: A reference is continuous, not stops, when more than this fraction of the gaps between its distinct angles
#: is under :data:`_SMALL_GAP` of their median gap: random angles have about 3.4 % so, a grid none.
_CONTINUOUS_FRACTION = 0.01
_SMALL_GAP = 1.0 / 20.0
#: Fewest distinct angles for the decision (below, the angles are taken for stops).
_MIN_GAPS = 32


def _reference_has_stops(distinct):
    """Whether sorted distinct reference angles are stops (a grid, regular or not) rather than continuous values.

    The data's own grid decides: on stops, the gaps between neighbouring angles are steps of the table, and
    none is a small fraction of the typical one; on a continuous reference (a sweep sampled in time, random
    angles) the gaps are spread like an exponential's, and about 3.4 % of them are under a twentieth of the
    median gap.
    """
    gaps = np.diff(distinct)
    if gaps.size < _MIN_GAPS:
        return True
    return bool(np.mean(gaps < np.median(gaps) * _SMALL_GAP) <= _CONTINUOUS_FRACTION)


#: Smallest coherence ``|mean exp(i (θ_enc − θ_ref))|`` (per run) of a calibration whose encoder turns once per
#: reference turn. An error profile that does not fold the encoder back has a slope above -1, so its first
#: harmonic is under 57 deg (coherence at least J0(1 rad) = 0.77) and a misplaced magnet's 20 deg leaves 0.97; an
#: encoder read in another unit, or with other bits, winds round the circle against the reference and has ~0.
MIN_TURN_COHERENCE = 0.3
#: Coherence a reading in another unit must reach to be named as the likely one.
LIKELY_UNIT_COHERENCE = 0.9
#: Points used to try the other units (evenly spaced in the file).
_TURN_SAMPLE = 20_000
_UNIT_NAMES = {"deg": "degrees", "rad": "radians", "rev": "revolutions"}


def _turn_coherence(reference_deg, encoder_deg, runs):
    """``|mean exp(i (encoder - reference))|`` per run (a zero offset of its own each), weighted by size."""
    if runs is None:
        return abs(_mean_phasor(reference_deg, encoder_deg))
    phasor = np.exp(1j * np.radians(encoder_deg - reference_deg))
    group = np.unique(runs, return_inverse=True)[1].reshape(-1)
    sums = np.bincount(group, weights=phasor.real) + 1j * np.bincount(group, weights=phasor.imag)
    return float(np.sum(np.abs(sums)) / phasor.size)


def _unit_text(unit):
    return _UNIT_NAMES.get(unit.name) or f"counts of a {unit.bits}-bit encoder"


def check_turns(reference, encoder, units=("deg", "deg"), *, reverse=False, runs=None, where="calibration"):
    """Refuse a calibration whose encoder does not turn once per turn of the reference.

    Read in the wrong unit (16-bit counts as ``counts:14``, counts or radians as degrees) the encoder runs a
    multiple of the reference's speed, and its "error" winds round the circle: a profile of thousands of arc-minutes
    that a model fits as well as it can, with exit status 0. The test is the coherence of ``encoder - reference``
    within each run (:data:`MIN_TURN_COHERENCE`); when it fails, the other units of either column (deg, rad, rev,
    counts:1..32) are tried and the one that makes the encoder follow the reference is named with its option.
    An encoder that counts against the reference is left to the check that names ``--reverse``.

    Parameters
    ----------
    reference, encoder : array-like of shape (n,)
        The columns as read, in their units.
    units : (str or AngleUnit, str or AngleUnit), default=('deg', 'deg')
        Units of the reference and the encoder column.
    reverse : bool, default=False
        The encoder counts against the reference (its readings are negated).
    runs : array-like of shape (n,), optional
        A label per point of its run (direction, epoch): each run has a zero offset of its own.
    where : str
        Name of the data, for the message.

    Raises
    ------
    CalibrationError
        Naming the units read, the coherence and, when one fits, the option of the right unit.
    """
    _check_turns(reference, encoder, units, reverse=reverse, runs=runs, where=where)


def turn_checked_errors(cal, *, where="calibration"):
    """:func:`check_turns` of a calibration (each run its own), then its :attr:`Calibration.errors_arcmin`.

    For a calibration of one run the two share one mean phasor of the differences (one pass of cosines and sines
    of every point fewer); the errors are those of :attr:`Calibration.errors_arcmin`, bit for bit.

    Parameters
    ----------
    cal : Calibration
    where : str
        Name of the data, for the message.

    Returns
    -------
    ndarray of shape (n,)
        The errors ``encoder - reference`` in arc-minutes.

    Raises
    ------
    CalibrationError
        The encoder does not turn once per turn of the reference.
    """
    if "turns" in _passed(cal):
        return cal.errors_arcmin
    runs = _runs(cal)
    phasor = _mean_phasor(cal.reference_deg, cal.encoder_deg) if runs is None else None
    _check_turns(cal.reference_deg, cal.encoder_deg, runs=runs, where=where,
                 found=None if phasor is None else abs(phasor))
    _passed(cal)["turns"] = True
    return _remember_errors(cal, _errors_arcmin(cal, phasor)).copy()


def _check_turns(reference, encoder, units=("deg", "deg"), *, reverse=False, runs=None, where="calibration",
                 found=None):
    """:func:`check_turns`; ``found``: the coherence of the columns in their units, if known (for one run, the
    modulus of :func:`_mean_phasor` of the calibration they make)."""
    reference = np.asarray(reference, dtype=float).reshape(-1)
    encoder = np.asarray(encoder, dtype=float).reshape(-1)
    units = tuple(angle_unit(unit) for unit in units)
    sign = -1.0 if reverse else 1.0

    def coherence(ref_unit, enc_unit, factor=sign, pick=slice(None)):
        return _turn_coherence(reference[pick] * ref_unit.degrees_per_unit,
                               factor * encoder[pick] * enc_unit.degrees_per_unit,
                               None if runs is None else np.asarray(runs)[pick])

    if found is None:
        found = coherence(*units)
    if found >= MIN_TURN_COHERENCE or coherence(*units, factor=-sign) >= MIN_TURN_COHERENCE:
        return
    pick = slice(None, None, max(1, reference.size // _TURN_SAMPLE))
    others = [angle_unit(name) for name in ("deg", "rad", "rev")] + [angle_unit(f"counts:{b}")
                                                                      for b in range(1, MAX_BITS + 1)]
    candidates = [(units[0], unit) for unit in others if unit != units[1]]
    candidates += [(unit, units[1]) for unit in others if unit != units[0]]
    candidates += [(unit, unit) for unit in others if unit not in units]
    candidates += [(others[0], unit) for unit in others if others[0] != units[0] and unit != units[1]]
    # a reading that squeezes the reference into a few degrees makes any encoder "follow" it: only readings whose
    # reference goes round the circle are tried
    candidates = [(ref_unit, enc_unit) for ref_unit, enc_unit in candidates
                  if abs(np.mean(np.exp(1j * np.radians(reference[pick] * ref_unit.degrees_per_unit)))) < 0.5]
    # the most coherent reading wins (a grid of whole degrees read in revolutions can come close by aliasing);
    # of equals, the first: the encoder's unit, then the reference's, then both
    tried = [(coherence(ref_unit, enc_unit, factor, pick), -number, (ref_unit, enc_unit, flip))
             for number, (ref_unit, enc_unit) in enumerate(candidates)
             for factor, flip in ((sign, ""), (-sign, " --reverse" if not reverse else ""))]
    best = max(tried, key=lambda item: (round(item[0], 3), item[1]), default=(0.0, 0, None))
    hint = best[2] if best[0] >= LIKELY_UNIT_COHERENCE else None
    read = (f"read as {_unit_text(units[1])} against a reference in {_unit_text(units[0])}")
    if hint is None:
        advice = ("no other unit of either column makes it follow the reference (is the encoder geared to it, or "
                  "are these other columns? name them with --ref-col and --enc-col)")
    else:
        ref_unit, enc_unit, flip = hint
        ratio = units[1].degrees_per_unit / enc_unit.degrees_per_unit * ref_unit.degrees_per_unit \
            / units[0].degrees_per_unit
        if ref_unit == units[0]:
            option, change = f"--enc-unit {enc_unit}", f"the encoder read as {_unit_text(enc_unit)}"
        elif enc_unit == units[1]:
            option, change = f"--ref-unit {ref_unit}", f"the reference read as {_unit_text(ref_unit)}"
        elif ref_unit == enc_unit:
            option, change = f"--unit {enc_unit}", f"both columns read as {_unit_text(enc_unit)}"
        else:
            option = f"--ref-unit {ref_unit} --enc-unit {enc_unit}"
            change = f"the reference read as {_unit_text(ref_unit)} and the encoder as {_unit_text(enc_unit)}"
        advice = (f"its angle runs {ratio:.4g} times as fast as the reference's; with {change}, the encoder "
                  f"follows the reference (use {option}{flip})")
    raise CalibrationError(
        f"{where}: the encoder does not turn once per turn of the reference: {read}, encoder minus reference winds "
        f"round the circle (coherence {found:.2f}, expected over {MIN_TURN_COHERENCE:g}); {advice}")


def _check_direction_of_count(path, cal, reverse, order=None, by_reference=None):
    """Refuse an encoder whose angle decreases while the reference increases: the median of the encoder's steps
    over the reference's is negative. ``order``: the stable argsort of the reference angles, if known;
    ``by_reference``: the reference and the encoder angles in that order, if known."""
    if by_reference is None:
        if order is None:
            order = stable_argsort(cal.reference_deg)
        by_reference = cal.reference_deg[order], cal.encoder_deg[order]
    steps_ref = np.diff(by_reference[0])
    moving = steps_ref > 1e-9
    if np.count_nonzero(moving) < 2:
        return
    ratio = wrap180(np.diff(by_reference[1])[moving]) / steps_ref[moving]
    if _median_is_negative(ratio):
        if reverse:
            raise CalibrationError(f"{path}: even with --reverse the encoder counts against the reference")
        raise CalibrationError(
            f"{path}: the encoder angle decreases as the reference angle increases (it counts against the "
            "reference); expected both to increase together - use --reverse (reverse=True) to negate the "
            "encoder angles")


def _median_is_negative(values):
    """``np.median(values) < 0`` for a 1-D array without NaN, by counting (no partition) unless the two middle
    values straddle 0."""
    n = values.size
    negative = int(np.count_nonzero(values < 0))
    if n % 2 or negative != n // 2:  # the middle value, or both middle values, on one side of 0
        return negative > n // 2
    return bool(np.mean([values[values < 0].max(), values[values >= 0].min()]) < 0)


def check_folds(cal, where="calibration"):
    """Refuse a calibration whose encoder goes back while the reference goes forward.

    Within each run (points of one direction and epoch), sorted by reference angle, the encoder angle
    must not fall more than :data:`MAX_FOLD_DEG` (0.5 degrees) below a reading taken at a smaller
    reference angle. Where it does, one encoder angle is read at two shaft positions, so the error is
    not a function of the encoder angle and no model of it can correct the encoder (a folded error of
    tens of degrees, a slipping coupling or a glitch). Each encoder step is taken as the reference step
    plus the wrapped difference, so steps across 0/360 and coverage gaps are measured correctly.

    Parameters
    ----------
    cal : Calibration
    where : str, default='calibration'
        Name of the data, for the message.

    Raises
    ------
    CalibrationError
        Naming both points and how far the encoder went back.
    """
    if "folds" not in _passed(cal):
        _check_folds(cal, where)


def _check_folds(cal, where, order=None, by_reference=None):
    """:func:`check_folds`; ``order``: the stable argsort of the reference angles of a calibration of one run,
    ``by_reference``: its reference and encoder angles in that order, if known."""
    _find_folds(cal, where, order, by_reference)
    _passed(cal)["folds"] = True


def _find_folds(cal, where, order, by_reference):
    runs = _runs(cal)
    for run in (0,) if runs is None else np.unique(runs):
        run_order = order
        if run_order is None:
            members = np.arange(len(cal)) if runs is None else np.flatnonzero(runs == run)
            run_order = members[stable_argsort(cal.reference_deg[members])]
        if by_reference is not None and runs is None:
            ref, enc = by_reference
        else:
            ref, enc = cal.reference_deg[run_order], cal.encoder_deg[run_order]
        if ref.size < 2:
            continue
        if ref[0] + 360.0 - ref[-1] <= MAX_GAP_DEG:
            # a whole turn: its first point again, a turn on, so that a glitch in the first or the last point (the
            # first read 81 deg back, nothing before it to fall below) is measured as one in any other point
            ref, enc = np.append(ref, ref[0] + 360.0), np.append(enc, enc[0])
        step_ref = np.diff(ref)
        travel = np.concatenate([[0.0], np.cumsum(step_ref + wrap180(np.diff(enc) - step_ref))])
        drop = np.maximum.accumulate(travel) - travel
        last = int(np.argmax(drop))
        if drop[last] > MAX_FOLD_DEG:
            first = int(np.argmax(travel[: last + 1]))
            raise CalibrationError(
                f"{where}: the encoder reads {enc[first]:.4g} deg at reference {ref[first]:.4g} deg but "
                f"{enc[last]:.4g} deg at reference {wrap360(ref[last]):.4g} deg"
                f"{' (a turn on)' if ref[last] >= 360.0 else ''}, {drop[last]:.3g} deg back although the "
                f"reference went forward; expected the encoder angle to increase with the reference (within "
                f"{MAX_FOLD_DEG:g} deg of noise), since otherwise the error is not a function of the encoder "
                "angle (an error of tens of degrees that folds over, a slipping coupling or a glitch; or a column "
                "in another unit: --ref-unit, --enc-unit)")


def _check_coverage(path, cal, allow_gaps):
    from .._core.arcs import arc_of, no_gap_over

    if no_gap_over(cal.encoder_deg, MAX_GAP_DEG):  # a full turn, told without a sort
        _passed(cal)["arc"] = None
        return
    angles = np.sort(cal.encoder_deg)  # repeats leave gaps of 0, which do not change the largest
    if angles.size == 1:
        gap = 360.0
    else:
        gaps = np.diff(np.concatenate([angles, angles[:1] + 360.0]))
        gap = float(gaps.max())
    if gap > MAX_GAP_DEG + 1e-9 and arc_of(angles, MAX_GAP_DEG) is not None \
            and not _looks_like_radians(cal.encoder_deg):  # a turn in radians is no arc of 6 degrees
        return  # one contiguous arc (a joint of limited travel): fitted over the arc, see encal._core.arcs
    if gap > MAX_GAP_DEG + 1e-9 and not allow_gaps:  # a 30-degree grid is not refused for a rounding error
        start = angles[np.argmax(np.diff(np.concatenate([angles, angles[:1] + 360.0])))] if angles.size > 1 \
            else angles[0]
        raise CalibrationError(
            f"{path}: the encoder angles leave a gap of {gap:.1f} deg after {start:.2f} deg; expected no gap "
            f"over {MAX_GAP_DEG:g} deg, because no model knows the error where the encoder was never seen "
            "(one contiguous arc is accepted; use --allow-gaps to accept scattered gaps)")


def write_calibration(path, cal, *, extra_columns=None, comments=()):
    """Write a calibration as CSV (see DESIGN.md), atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; its folder must exist.
    cal : Calibration
    extra_columns : dict of str to array-like, optional
        More columns to write after the standard ones (readers ignore them, but for ``sigma_arcmin``, which
        they read as the reference's standard uncertainty). A calibration's ``reference_std_arcmin`` is
        written after them, as ``sigma_arcmin``.
    comments : sequence of str
        Lines written first, each prefixed with ``# `` (each line of a comment that holds line breaks).

    Angles are written with ``repr`` precision, so reading the file back gives the same numbers.
    """
    from .._core.atomic import atomic_open

    check_type(cal, Calibration, "cal", "write_calibration", "a Calibration")
    check_type(extra_columns or {}, dict, "extra_columns", "write_calibration",
               "a dict of column names to values, or None")
    columns = {"reference_deg": cal.reference_deg, "encoder_deg": cal.encoder_deg}
    if cal.direction is not None:
        columns["direction"] = [f"{int(d):+d}" for d in cal.direction]
    if cal.epoch is not None:
        columns["epoch"] = cal.epoch
    for key, values in (extra_columns or {}).items():
        values = list(values)
        if len(values) != len(cal):
            raise CalibrationError(f"extra column {key!r} has {len(values)} values, expected {len(cal)}")
        if key == REFERENCE_STD_COLUMN and cal.reference_std_arcmin is not None:
            raise CalibrationError(f"extra column {key!r} is the calibration's reference_std_arcmin, which is "
                                   "written as that column; expected it once")
        columns[key] = values
    if cal.reference_std_arcmin is not None:
        columns[REFERENCE_STD_COLUMN] = cal.reference_std_arcmin
    # a line break in a comment would start a line without '#' that the reader takes for the header
    comments = [line for comment in comments for line in (str(comment).splitlines() or [""])]
    if cal.resolution_bits is not None and not any("resolution_bits" in c for c in comments):
        comments.append(f"resolution_bits: {cal.resolution_bits}")
    with atomic_open(path, "w", newline="\n") as handle:
        for comment in comments:
            handle.write(f"# {comment}\n")
        handle.write(_csv.join(columns) + "\n")
        cells = [[_cell(v) for v in values] for values in columns.values()]
        for row in zip(*cells):
            handle.write(_csv.join(row) + "\n")


def _cell(value):
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return str(value)

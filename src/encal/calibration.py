"""Calibration data: encoder readings against a reference, and its CSV form."""

from dataclasses import dataclass, field

import numpy as np

from .angles import ARCMIN_PER_DEG, wrap180, wrap360
from .errors import CalibrationError

__all__ = ["Calibration", "read_calibration", "write_calibration"]


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
    """

    reference_deg: np.ndarray
    encoder_deg: np.ndarray
    direction: np.ndarray | None = None
    epoch: np.ndarray | None = None
    name: str = ""
    resolution_bits: int | None = None
    source: str | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        ref = np.asarray(self.reference_deg, dtype=float).reshape(-1)
        enc = np.asarray(self.encoder_deg, dtype=float).reshape(-1)
        if ref.shape != enc.shape:
            raise CalibrationError(
                f"reference_deg has {ref.size} values but encoder_deg has {enc.size}; "
                "expected one reading per reference angle"
            )
        if not (np.all(np.isfinite(ref)) and np.all(np.isfinite(enc))):
            raise CalibrationError("calibration angles must be finite numbers (found NaN or infinity)")
        object.__setattr__(self, "reference_deg", wrap360(ref).reshape(-1))
        object.__setattr__(self, "encoder_deg", wrap360(enc).reshape(-1))
        if self.direction is not None:
            direction = np.asarray(self.direction, dtype=np.int8).reshape(-1)
            if direction.shape != ref.shape or not np.all(np.isin(direction, (-1, 1))):
                raise CalibrationError("direction must hold +1 or -1 for every point")
            object.__setattr__(self, "direction", direction)
        if self.epoch is not None:
            epoch = np.asarray(self.epoch, dtype=str).reshape(-1)
            if epoch.shape != ref.shape:
                raise CalibrationError("epoch must hold one label for every point")
            object.__setattr__(self, "epoch", epoch)

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
        difference = np.radians(self.encoder_deg - self.reference_deg)
        centre = np.degrees(np.arctan2(np.sin(difference).mean(), np.cos(difference).mean()))
        if abs(centre) < 90.0:
            centre = 0.0  # the common case: plain (-180, 180] wrapping
        delta = wrap180(self.encoder_deg - self.reference_deg - centre)
        return (centre + delta) * ARCMIN_PER_DEG

    def subset(self, index):
        """A calibration holding only the points selected by ``index`` (mask or indices)."""
        pick = lambda a: None if a is None else a[index]  # noqa: E731
        return Calibration(
            self.reference_deg[index],
            self.encoder_deg[index],
            direction=pick(self.direction),
            epoch=pick(self.epoch),
            name=self.name,
            resolution_bits=self.resolution_bits,
            source=self.source,
            metadata=dict(self.metadata),
        )


# --------------------------------------------------------------------------- CSV

_REQUIRED = ("reference_deg", "encoder_deg")
_DIRECTIONS = {"+1": 1, "1": 1, "-1": -1, "cw": 1, "ccw": -1, "+": 1, "-": -1}
MIN_POINTS = 8
MAX_GAP_DEG = 30.0


def _fail(path, line, message, column=None):
    where = f"{path}, line {line}" + (f", column {column}" if column is not None else "")
    raise CalibrationError(f"{where}: {message}")


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


def _parse_float(path, line, column, name, cell):
    try:
        value = float(cell)
    except ValueError:
        shown = cell if len(cell) <= 40 else cell[:37] + "..."
        _fail(path, line, f"{name} is {shown!r}, expected a number of degrees", column)
    if not np.isfinite(value):
        _fail(path, line, f"{name} is {cell.strip()!r}, expected a finite number of degrees", column)
    return value


def read_calibration(path, *, allow_gaps=False, reverse=False, name=None, resolution_bits=None,
                     duplicates="refuse"):
    """Read a calibration CSV (see DESIGN.md).

    The file is UTF-8 text (a byte-order mark is accepted), comma-separated, with one header row naming at
    least ``reference_deg`` and ``encoder_deg`` (any letter case, any order, other columns ignored),
    ``#`` comment lines, and LF or CRLF line ends. Angles may be any finite numbers of degrees; they are
    wrapped into [0, 360).

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
        Encoder resolution in bits, if known; read from a ``# resolution_bits: B`` comment otherwise.
    duplicates : {'refuse', 'average'}, default='refuse'
        What to do with repeated reference angles whose readings disagree (points of one direction and
        epoch). Identical repeats are always kept as they are.

    Returns
    -------
    Calibration

    Raises
    ------
    CalibrationError
        With one sentence naming the file, line and column, for: a missing or empty file, no header or a
        header without the two columns, a semicolon- or tab-separated file, non-numeric, NaN or infinite
        values, fewer than 8 points, a coverage gap over 30 degrees (unless ``allow_gaps``), an encoder that
        counts against the reference (unless ``reverse``), conflicting repeated reference angles.
    """
    from pathlib import Path

    path = Path(path)
    if not path.exists():
        raise CalibrationError(f"{path}: no such file; expected a calibration CSV")
    if path.is_dir():
        raise CalibrationError(f"{path}: is a folder; expected a calibration CSV file")
    text = _decode(path, path.read_bytes())
    lines = text.splitlines()
    records = [(number, line) for number, line in enumerate(lines, start=1)
               if line.strip() and not line.lstrip().startswith("#")]
    if resolution_bits is None:
        resolution_bits = _resolution_from_comments(lines)
    if not records:
        raise CalibrationError(f"{path}: the file is empty; expected a header row "
                               "'reference_deg,encoder_deg' and at least 8 rows of angles")
    header_line, header = records[0]
    columns = _header_columns(path, header_line, header)
    n_columns = len(header.split(","))
    ref_col, enc_col = columns["reference_deg"], columns["encoder_deg"]
    dir_col, epoch_col = columns.get("direction"), columns.get("epoch")
    reference, encoder, direction, epoch = [], [], [], []
    for number, line in records[1:]:
        cells = line.split(",")
        if len(cells) < n_columns:
            _fail(path, number, f"has {len(cells)} fields, expected {n_columns} as in the header "
                                "(is the file truncated?)")
        reference.append(_parse_float(path, number, ref_col + 1, "reference_deg", cells[ref_col]))
        encoder.append(_parse_float(path, number, enc_col + 1, "encoder_deg", cells[enc_col]))
        if dir_col is not None:
            cell = cells[dir_col].strip().lower()
            if cell not in _DIRECTIONS:
                _fail(path, number, f"direction is {cells[dir_col].strip()!r}, expected +1, -1, cw or ccw",
                      dir_col + 1)
            direction.append(_DIRECTIONS[cell])
        if epoch_col is not None:
            epoch.append(cells[epoch_col].strip())
    if len(reference) < MIN_POINTS:
        raise CalibrationError(f"{path}: has {len(reference)} calibration points, expected at least "
                               f"{MIN_POINTS} to model an error profile")
    encoder = np.asarray(encoder)
    if reverse:
        encoder = -encoder
    cal = Calibration(
        np.asarray(reference), encoder,
        direction=np.asarray(direction) if dir_col is not None else None,
        epoch=np.asarray(epoch) if epoch_col is not None else None,
        name=name if name is not None else path.stem,
        resolution_bits=resolution_bits,
        source=str(path),
    )
    cal = _check_duplicates(path, cal, duplicates, first_data_line=records[1][0])
    _check_direction_of_count(path, cal, reverse)
    _check_coverage(path, cal, allow_gaps)
    return cal


def _resolution_from_comments(lines):
    for line in lines:
        stripped = line.strip().lstrip("#").strip().lower()
        if stripped.startswith("resolution_bits"):
            value = stripped.split(":", 1)[-1].split("=", 1)[-1].strip()
            if value.isdigit():
                return int(value)
    return None


def _header_columns(path, line, header):
    for separator, label in ((";", "semicolons"), ("\t", "tabs")):
        if separator in header and "," not in header:
            _fail(path, line, f"fields are separated by {label}; expected commas "
                              "(save the file as comma-separated CSV)")
    names = [cell.strip().strip('"').lower() for cell in header.split(",")]
    columns = {}
    for index, cell in enumerate(names):
        columns.setdefault(cell, index)
    missing = [name for name in _REQUIRED if name not in columns]
    if missing:
        looks_numeric = all(_is_number(cell) for cell in names if cell)
        found = "a row of numbers" if looks_numeric else f"columns {', '.join(names)}"
        _fail(path, line, f"the header lacks {' and '.join(missing)}; expected a header row naming "
                          f"reference_deg and encoder_deg, found {found}")
    return columns


def _is_number(text):
    try:
        float(text)
    except ValueError:
        return False
    return True


def _check_duplicates(path, cal, duplicates, first_data_line):
    if duplicates not in ("refuse", "average"):
        raise CalibrationError(f"duplicates must be 'refuse' or 'average'. Got {duplicates!r} instead.")
    keys = np.round(cal.reference_deg, 9)
    groups = [keys]
    if cal.direction is not None:
        groups.append(cal.direction)
    if cal.epoch is not None:
        groups.append(cal.epoch)
    order = np.lexsort(groups[::-1])
    seen = {}
    conflicts = []
    for index in order:
        key = tuple(g[index] for g in groups)
        if key in seen:
            first = seen[key][0]
            if abs(wrap180(cal.encoder_deg[index] - cal.encoder_deg[first])) > 1e-9:
                conflicts.append((first, index))
            seen[key].append(index)
        else:
            seen[key] = [index]
    if not conflicts:
        return cal
    if duplicates == "refuse":
        first, index = conflicts[0]
        raise CalibrationError(
            f"{path}: reference angle {cal.reference_deg[index]:g} deg appears more than once with "
            f"different readings ({cal.encoder_deg[first]:g} and {cal.encoder_deg[index]:g} deg, the "
            f"{first + 1}th and {index + 1}th data rows); expected one reading per reference angle "
            "(use --average-duplicates to average them)")
    keep, encoder = [], []
    for indices in seen.values():
        keep.append(indices[0])
        base = cal.encoder_deg[indices[0]]
        offsets = wrap180(cal.encoder_deg[indices] - base)
        encoder.append(base + offsets.mean())
    keep = np.asarray(keep)
    order = np.argsort(keep)
    averaged = cal.subset(keep[order])
    return Calibration(averaged.reference_deg, np.asarray(encoder)[order], direction=averaged.direction,
                       epoch=averaged.epoch, name=cal.name, resolution_bits=cal.resolution_bits,
                       source=cal.source, metadata={"averaged_duplicates": len(cal) - len(keep)})


def _check_direction_of_count(path, cal, reverse):
    """Refuse an encoder whose angle decreases while the reference increases."""
    order = np.argsort(cal.reference_deg, kind="stable")
    steps_ref = np.diff(cal.reference_deg[order])
    steps_enc = wrap180(np.diff(cal.encoder_deg[order]))
    moving = steps_ref > 1e-9
    if moving.sum() < 2:
        return
    if np.median(steps_enc[moving] / steps_ref[moving]) < 0:
        if reverse:
            raise CalibrationError(f"{path}: even with --reverse the encoder counts against the reference")
        raise CalibrationError(
            f"{path}: the encoder angle decreases as the reference angle increases (it counts against the "
            "reference); expected both to increase together - use --reverse (reverse=True) to negate the "
            "encoder angles")


def _check_coverage(path, cal, allow_gaps):
    angles = np.unique(cal.encoder_deg)
    if angles.size == 1:
        gap = 360.0
    else:
        gaps = np.diff(np.concatenate([angles, angles[:1] + 360.0]))
        gap = float(gaps.max())
    if gap > MAX_GAP_DEG and not allow_gaps:
        start = angles[np.argmax(np.diff(np.concatenate([angles, angles[:1] + 360.0])))] if angles.size > 1 \
            else angles[0]
        raise CalibrationError(
            f"{path}: the encoder angles leave a gap of {gap:.1f} deg after {start:.2f} deg; expected no gap "
            f"over {MAX_GAP_DEG:g} deg, because no model knows the error where the encoder was never seen "
            "(use --allow-gaps to accept it)")


def write_calibration(path, cal, *, extra_columns=None, comments=()):
    """Write a calibration as CSV (see DESIGN.md), atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; its folder must exist.
    cal : Calibration
    extra_columns : dict of str to array-like, optional
        More columns to write after the standard ones (readers ignore them).
    comments : sequence of str
        Lines written first, each prefixed with ``# ``.

    Angles are written with ``repr`` precision, so reading the file back gives the same numbers.
    """
    from ._atomic import atomic_open

    columns = {"reference_deg": cal.reference_deg, "encoder_deg": cal.encoder_deg}
    if cal.direction is not None:
        columns["direction"] = [f"{int(d):+d}" for d in cal.direction]
    if cal.epoch is not None:
        columns["epoch"] = cal.epoch
    for key, values in (extra_columns or {}).items():
        values = list(values)
        if len(values) != len(cal):
            raise CalibrationError(f"extra column {key!r} has {len(values)} values, expected {len(cal)}")
        columns[key] = values
    comments = list(comments)
    if cal.resolution_bits is not None and not any("resolution_bits" in c for c in comments):
        comments.append(f"resolution_bits: {cal.resolution_bits}")
    with atomic_open(path, "w", newline="\n") as handle:
        for comment in comments:
            handle.write(f"# {comment}\n")
        handle.write(",".join(columns) + "\n")
        cells = [[_cell(v) for v in values] for values in columns.values()]
        for row in zip(*cells):
            handle.write(",".join(row) + "\n")


def _cell(value):
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return str(value)

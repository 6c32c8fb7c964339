"""The moteus raw calibration capture: ``CAL start``, lines ``dir phase encoder``, ``CAL done``.

``moteus_tool --calibrate`` records the open-loop sweep of the electrical angle that it uses to find
the pole count and the encoder's offset. Each line between the two markers holds the direction code
(1 or 3: phase going up, 2 or 4: going down), the commanded electrical phase and the encoder
reading, both uint16 (65536 per electrical turn and per mechanical turn), then optional
``key=value`` fields (``i1=``, ``i2=``, ``i3=`` currents) that are ignored. The file is read strictly:
anything else is refused in one sentence naming the line and field.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._core.errors import InputError
from .._core.number_cells import not_plain_note, read_whole

__all__ = ["MoteusCapture", "read_moteus_capture", "write_moteus_capture", "UP_CODES", "DOWN_CODES"]

#: Direction codes of a pass with the phase going up, and going down.
UP_CODES = (1, 3)
DOWN_CODES = (2, 4)
#: Counts of one turn of the phase and of the encoder.
COUNTS = 65536


@dataclass(frozen=True)
class MoteusCapture:
    """A moteus raw calibration capture.

    Attributes
    ----------
    direction : ndarray of int
        Direction code of each sample (1, 3 up; 2, 4 down).
    phase : ndarray of int
        Commanded electrical phase, 0..65535 per electrical turn.
    encoder : ndarray of int
        Encoder reading, 0..65535 per turn.
    line : ndarray of int
        Line of each sample in the file (for messages).
    source : str
        The file.
    """

    direction: np.ndarray
    phase: np.ndarray
    encoder: np.ndarray
    line: np.ndarray
    source: str = ""

    @property
    def phase_deg_e(self):
        """Commanded electrical angle in electrical degrees [0, 360)."""
        return self.phase * (360.0 / COUNTS)

    @property
    def encoder_deg(self):
        """Encoder reading in degrees [0, 360)."""
        return self.encoder * (360.0 / COUNTS)

    @property
    def travel(self):
        """+1 for a sample of a pass up, -1 for a pass down."""
        return np.where(np.isin(self.direction, UP_CODES), 1, -1)


def _fail(path, line, message, field=None):
    where = f"{path}, line {line}" + (f", field {field}" if field is not None else "")
    raise InputError(f"{where}: {message}")


def read_moteus_capture(path):
    """Read a moteus raw calibration capture.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    MoteusCapture

    Raises
    ------
    InputError
        For a missing file, a first line other than ``CAL start``, a capture without ``CAL done`` (cut
        short), a line with fewer than three fields, a direction code other than 1-4, a phase or encoder
        value that is not a whole number from 0 to 65535, or no pass up or no pass down.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file; expected a moteus raw calibration capture")
    text = path.read_bytes().decode("latin-1")
    lines = [(number, line.strip()) for number, line in enumerate(text.splitlines(), start=1) if line.strip()]
    if not lines or not lines[0][1].startswith(("CAL start", "CALI start")):
        found = repr(lines[0][1][:40]) if lines else "an empty file"
        _fail(path, lines[0][0] if lines else 1, f"expected the capture to begin with 'CAL start', found {found}")
    if not lines[-1][1].startswith(("CAL done", "CALI done")):
        _fail(path, lines[-1][0], "the capture ends without 'CAL done'; expected a whole capture (was it cut short?)")
    rows = []
    for number, line in lines[1:-1]:
        fields = line.split()
        if len(fields) < 3:
            _fail(path, number, f"has {len(fields)} field{'s' if len(fields) != 1 else ''}, expected 'dir phase "
                                 "encoder'")
        values = []
        for field, (name, cell, allowed) in enumerate(
                (("direction", fields[0], "1, 2, 3 or 4"), ("phase", fields[1], "a whole number from 0 to 65535"),
                 ("encoder", fields[2], "a whole number from 0 to 65535")), start=1):
            try:
                value = read_whole(cell)
            except ValueError:
                _fail(path, number, f"{name} is {cell[:40]!r}, expected {allowed}{not_plain_note(cell)}", field)
            if (name == "direction" and value not in (1, 2, 3, 4)) or not 0 <= value < COUNTS:
                _fail(path, number, f"{name} is {value}, expected {allowed}", field)
            values.append(value)
        for field, extra in enumerate(fields[3:], start=4):
            if "=" not in extra:
                _fail(path, number, f"extra field {extra[:40]!r}, expected key=value (e.g. i1=0.5)", field)
        rows.append((*values, number))
    if not rows:
        _fail(path, lines[-1][0], "the capture holds no samples between 'CAL start' and 'CAL done'")
    data = np.array(rows, dtype=np.int64)
    capture = MoteusCapture(data[:, 0], data[:, 1], data[:, 2], data[:, 3], str(path))
    for codes, label in ((UP_CODES, "up (direction 1 or 3)"), (DOWN_CODES, "down (direction 2 or 4)")):
        if not np.isin(capture.direction, codes).any():
            raise InputError(f"{path}: the capture has no pass {label}; expected a sweep up and a sweep down")
    return capture


def write_moteus_capture(path, direction, phase, encoder):
    """Write a capture in the moteus raw format, atomically.

    Parameters
    ----------
    path : str or os.PathLike
    direction, phase, encoder : array-like of int
        As in :class:`MoteusCapture`.
    """
    from .._core.atomic import atomic_open

    with atomic_open(path, "w", newline="\n") as handle:
        handle.write("CAL start\n")
        for d, p, e in zip(direction, phase, encoder):
            handle.write(f"{int(d)} {int(p)} {int(e)}\n")
        handle.write("CAL done\n")

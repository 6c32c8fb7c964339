"""What the firmware formats share: the correction to store, the round-trip figures, C array text."""

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._core.errors import InputError
from ..._core.number_cells import is_plain_number_text, not_plain_note
from ...models.lut import LookupTableModel
from ..._core.parameters import check_int
from ..compact import _least_squares_nodes, evaluation_bits, model_on_codes
from ..compensator import Compensator

__all__ = ["FirmwareExport", "correction_on_codes", "correction_nodes", "correction_model", "read_c_array",
           "round_trip", "read_text", "checked", "ROUND_TRIP_RATIO"]

# A table whose round trip through the firmware's rule leaves more than this fraction of the correction's
# RMS (beyond the storage rounding) does not do what encal would say it does: it is refused.
ROUND_TRIP_RATIO = 0.25


@dataclass(frozen=True)
class FirmwareExport:
    """A model written in a firmware's format.

    Attributes
    ----------
    firmware : str
    text : str
        The file content.
    max_error_arcmin, rms_error_arcmin : float
        Round trip: that firmware's run-time rule applied to the written values, against
        the model's correction, over every code (``codes`` of them).
    quantisation_arcmin : float
        The largest change that rounding the stored values can cause, a priori.
    codes : int
    note : str
        What the format cannot hold, or how to load it.
    offset_arcmin : float
        A constant left out of the table (the mean correction: the reference's arbitrary zero, as
        the firmware's own calibration leaves it out); the round trip is against the correction
        minus it. Set it as the firmware's zero offset if the absolute angle matters.
    offset_note : str
        What that constant is, when not the mean correction (e.g. the correction at node 0).
    """

    firmware: str
    text: str
    max_error_arcmin: float
    rms_error_arcmin: float
    quantisation_arcmin: float
    codes: int
    note: str = ""
    offset_arcmin: float = 0.0
    offset_note: str = ""

    def describe(self):
        what = self.offset_note or "the mean correction, the reference's zero"
        why = "" if self.offset_note else ", as the firmware's own calibration leaves it out"
        offset = "" if self.offset_arcmin == 0.0 else (
            f"; a constant {self.offset_arcmin:.6g} arcmin ({what}) is left out of the table{why}")
        return (f"{self.firmware}: round trip through its own run-time rule within max "
                f"{self.max_error_arcmin:.3g}, RMS {self.rms_error_arcmin:.3g} arcmin of the model on all "
                f"{self.codes} codes (storage rounding at most {self.quantisation_arcmin:.3g} arcmin)"
                + offset + (f"; {self.note}" if self.note else ""))


def compensator(model):
    from ..._core.arcs import refuse_arc

    comp = model if isinstance(model, Compensator) else Compensator(model)
    refuse_arc(comp, "a firmware table")  # periodic: it cannot say "outside" (see encal._core.arcs)
    return comp


def correction_on_codes(comp, bits):
    """The correction (arcmin) to add to each raw code's angle, in the reading's own sense.

    ``-error`` for an encoder that counts with its reference; ``+error`` for one that counts
    against it (``reading_sign`` -1: the corrected angle in the reading's sense is the
    negated reference-sense one).
    """
    return -comp.reading_sign * model_on_codes(comp, bits)


def correction_nodes(comp, nodes, bits, *, remove_mean=True):
    """Least-squares node values (arcmin) of a periodic linear interpolation of the correction.

    Returns the node values, the correction on every code they stand for, and the constant
    (its mean over the codes) taken out of both when ``remove_mean``.
    """
    target = correction_on_codes(comp, bits)
    offset = float(np.mean(target)) if remove_mean else 0.0
    target = target - offset
    return _least_squares_nodes(target, nodes), target, offset


def checked(export, correction_arcmin, *, ratio=ROUND_TRIP_RATIO):
    """``export``, unless its round trip is not far smaller than the correction it stands for.

    Parameters
    ----------
    export : FirmwareExport
    correction_arcmin : array-like
        The correction the table should apply (arc-minutes, on the codes the round trip was measured
        on, with any constant left out of the table already removed).
    ratio : float
        The largest RMS round trip allowed, as a fraction of the correction's RMS. A round trip within
        the storage rounding (``export.quantisation_arcmin``) is always allowed: a near-zero correction
        is not refused for the rounding of its last digit.

    Raises
    ------
    InputError
        When the firmware, applying the written table with its own rule, would leave more than
        ``ratio`` of the correction's RMS: the file would mis-correct with exit 0.
    """
    correction = np.asarray(correction_arcmin, dtype=float)
    size = float(np.sqrt(np.mean(correction**2))) if correction.size else 0.0
    if export.rms_error_arcmin > max(ratio * size, export.quantisation_arcmin):
        raise InputError(
            f"the {export.firmware} table would not do what the model says: through the firmware's own rule it "
            f"misses the model's correction by RMS {export.rms_error_arcmin:.3g} arcmin (max "
            f"{export.max_error_arcmin:.3g}), against a correction of RMS {size:.3g} arcmin; expected at most "
            f"{ratio:g} of it, so no file was written")
    return export


def round_trip(deployed_arcmin, target_arcmin):
    """(max, RMS) of the difference, arcmin."""
    gap = np.asarray(deployed_arcmin, dtype=float) - target_arcmin
    return float(np.max(np.abs(gap))), float(np.sqrt(np.mean(gap**2)))


def grid_bits(comp, bits, caller, default=16):
    """The bits of the code grid an export is measured on: ``bits``, else the model file's, else ``default``."""
    bits = comp.encoder.get("resolution_bits") if bits is None else bits
    if bits is not None:
        bits = check_int(bits, "bits", caller, low=1, high=32, note="the encoder resolution, or None for the model "
                         f"file's, else {default}")
    return evaluation_bits(default if bits is None else bits)


#: Largest correction a firmware table can mean, arc-minutes: half a turn (180 degrees). The firmwares' own
#: calibrations store the error about its mean, a few degrees at most; an entry of half a turn or more is a
#: wrong unit or a corrupted file (a SimpleFOC entry of 256 radians was read as 14,668 degrees).
MAX_CORRECTION_ARCMIN = 10800.0


def correction_model(correction_arcmin, *, name="", note="", where="the table", entry=None):
    """An encal model of an existing firmware correction: nodes at ``i * 360 / N``, linear with wrap.

    Parameters
    ----------
    correction_arcmin : array-like of shape (N,)
        The correction the firmware adds at each node, arc-minutes.
    where : str
        The file, for messages.
    entry : callable, optional
        ``entry(i)`` names node ``i`` in the file for messages (default ``"entry i"``).

    Returns
    -------
    LookupTableModel
        Predicts the error ``-correction`` (what the firmware assumes), so it can be
        evaluated on a calibration or compared with another model.

    Raises
    ------
    InputError
        If an entry is not a finite correction of less than half a turn (:data:`MAX_CORRECTION_ARCMIN`).
    """
    correction = np.asarray(correction_arcmin, dtype=float).reshape(-1)
    with np.errstate(invalid="ignore"):
        bad = np.flatnonzero(~(np.abs(correction) < MAX_CORRECTION_ARCMIN))
    if bad.size:
        index = int(bad[0])
        raise InputError(f"{where}: {entry(index) if entry else f'entry {index}'} is a correction of "
                         f"{correction[index]:.6g} arcmin; expected less than half a turn ({MAX_CORRECTION_ARCMIN:g} "
                         "arcmin), all a correction table can mean (a wrong unit, or a corrupted file?)")
    error = -correction
    n = error.size
    breaks = np.arange(n + 1) * (360.0 / n)
    slopes = (np.roll(error, -1) - error) / (360.0 / n)
    return LookupTableModel(breaks, [slopes, error], "linear",
                            encoder={"name": name}, training={"method": "firmware", "note": note})


def read_text(source):
    """The text of a file (path) or the text itself (a str with a newline)."""
    if isinstance(source, str) and "\n" in source:
        return source, "text"
    path = Path(source)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    return path.read_text(encoding="utf-8", errors="replace"), str(path)


def _shown(text, limit=40):
    """``text`` for a message: whole if short, else its start and '...' (an element may be megabytes long: a table
    whose commas became another separator is one element)."""
    return text if len(text) <= limit else text[:limit - 3] + "..."


#: A C integer literal with a leading zero: octal in C (``010`` is 8), read by ``float`` as decimal (10).
_C_OCTAL = re.compile(r"[+-]?0+[1-9][0-9]*[uUlL]*")


def read_c_array(source, name):
    """The numbers of the C array ``name`` (``... name[N] = { ... };``) in a file or text.

    Raises
    ------
    InputError
        If there is no such array, or an element is not a number (the message names the element).
    """
    text, where = read_text(source)
    # comments blanked to spaces (newlines kept), so positions still give line numbers
    text = re.sub(r"/\*.*?\*/|//[^\n]*", lambda m: re.sub(r"[^\n]", " ", m.group(0)), text, flags=re.S)
    match = re.search(rf"\b{re.escape(name)}\s*\[\s*(\w*)\s*\]\s*=\s*\{{(.*?)\}}", text, flags=re.S)
    if not match:
        raise InputError(f"{where}: expected a C array '{name}[...] = {{...}};', found none")
    items = [item.strip() for item in match.group(2).split(",")]
    if items and items[-1] == "":
        items.pop()
    if not items or items == [""]:
        raise InputError(f"{where}: {name}[] holds no values, expected its table's numbers")
    parts = match.group(2).split(",")
    # where each element starts in the text (its first non-blank character), for its line number
    starts = match.start(2) + np.cumsum([0] + [len(part) + 1 for part in parts])[:-1] \
        + [len(part) - len(part.lstrip()) for part in parts]
    values = []
    for index, item in enumerate(items):
        octal = _C_OCTAL.fullmatch(item) is not None
        try:
            if octal or not is_plain_number_text(item):  # C reads 010 as 8, and no '1_0' nor a full-width digit
                raise ValueError(item)
            value = float(item.rstrip("fFlLuU") if not item.lower().startswith("0x") else int(item, 16))
        except ValueError:
            value = None
        if value is None or not np.isfinite(value):
            # the line counted only here: counted for every element, 5 million one-digit elements on one line took
            # minutes (each count scans the text up to the element)
            line = text.count("\n", 0, int(starts[index])) + 1
            why = ("; a C integer with a leading 0 is octal (010 is 8), which encal does not read: write it in "
                   "decimal" if octal else not_plain_note(item.rstrip("fFlLuU")))
            raise InputError(f"{where}: line {line}: element {index} of {name}[] is {_shown(item)!r}, expected a "
                             f"{'number' if value is None else 'finite number'}{why}")
        values.append(value)
    declared = match.group(1)
    if declared.isdigit() and int(declared) != len(values):
        raise InputError(f"{where}: {name}[{declared}] holds {len(values)} values, expected {declared}")
    return np.asarray(values)

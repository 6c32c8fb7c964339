"""Mechaduino: ``lookup[16384]``, the corrected angle in degrees of every raw AS5047 count.

Format (``Mechaduino/Mechaduino/Parameters.cpp``, ``Controller.cpp`` and ``Utils.cpp`` of
github.com/jcchurch13/Mechaduino-Firmware): ``const float __attribute__((__aligned__(256)))
lookup[16384]``; the control loop reads ``y = lookup[readEncoder()]``: one entry per raw
14-bit count, no interpolation. The firmware's own calibration stores each angle as
``0.001 * mod(1000 * angle, 360000)``, to a thousandth of a degree; encal writes the same.
"""

import numpy as np

from ...calibration import Calibration
from ...errors import InputError
from ...parameters import invalid
from ._common import FirmwareExport, compensator, read_c_array, round_trip

__all__ = ["export_mechaduino", "read_mechaduino", "COUNTS"]

COUNTS = 16384


def export_mechaduino(model, *, bits=None):
    """The ``lookup[16384]`` array: ``comp.correct`` at every count, to 0.001 degree."""
    comp = compensator(model)
    bits = comp.encoder.get("resolution_bits") if bits is None else bits
    if bits is not None and (isinstance(bits, bool) or bits != 14):
        raise invalid("bits", "export_mechaduino", "14 or None (Mechaduino's lookup[16384] is for its 14-bit "
                      "AS5047D; default the model file's resolution)", bits)
    angles = np.arange(COUNTS) * (360.0 / COUNTS)
    corrected = np.asarray(comp.correct(angles), dtype=float)
    stored = np.round(corrected, 3) % 360.0
    deployed = stored.astype(np.float32).astype(float)
    gap = (deployed - corrected + 180.0) % 360.0 - 180.0
    max_error, rms_error = round_trip(gap * 60.0, 0.0)
    items = [f"{v:.3f}" for v in stored]
    rows = ",\n".join(", ".join(items[i:i + 16]) for i in range(0, COUNTS, 16))
    text = ("//This is the encoder lookup table (created by encal)\n"
            f"const float __attribute__((__aligned__(256))) lookup[{COUNTS}] = {{\n{rows}\n}};\n")
    note = "paste into Parameters.cpp in place of the calibration routine's table"
    # a thousandth of a degree, then float32 (half an ulp below 512 degrees: 2^-16 degree)
    return FirmwareExport("mechaduino", text, max_error, rms_error, (0.0005 + 2.0**-16) * 60.0, COUNTS, note)


def read_mechaduino(source_text, *, name=None):
    """A Mechaduino ``lookup[16384]`` as a calibration: every raw count against its table angle.

    Returns
    -------
    Calibration
        ``encoder_deg = k * 360 / 16384``, ``reference_deg = lookup[k]`` (its zero is where the
        motor stood when calibration began), resolution 14 bits.
    """
    lookup = read_c_array(source_text, "lookup")
    if lookup.size != COUNTS:
        raise InputError(f"expected {COUNTS} lookup entries, got {lookup.size}")
    return Calibration(lookup, np.arange(COUNTS) * (360.0 / COUNTS), name=name or "mechaduino lookup",
                       resolution_bits=14, metadata={"format": "Mechaduino lookup[16384]"})

"""Mechaduino: ``lookup[16384]``, the angle in degrees of every raw AS5047 count, from full step 0.

Format (``Mechaduino/Mechaduino/Parameters.cpp``, ``Controller.cpp`` and ``Utils.cpp`` of
github.com/jcchurch13/Mechaduino-Firmware, read at commit ca2835c9 of 2018-11-26, firmware 0.1.5):
``const float __attribute__((__aligned__(256))) lookup[16384]``; the control loop reads
``y = lookup[readEncoder()]`` (``Controller.cpp`` line 19): one entry per raw 14-bit count, no
interpolation, and commutates with ``output(-y ± PA)`` (lines 71-90; ``PA`` one full step), so ``y``
is also the commutation angle: it must be the rotor's angle from full step 0 (electrical zero),
counted in the direction the encoder counts up. Its own ``calibrate()`` (``Utils.cpp`` lines
178-376) starts at ``stepNumber`` 0 (``output(0)``: electrical zero), refuses a motor that steps the
encoder down ("Wired backwards", line 203: the user swaps a phase), and stores each angle as
``0.001 * mod(1000 * angle, 360000)``: a table that rises once through 360 degrees with the count.

encal writes ``lookup[c] = sign * (theta(c) - step_zero) mod 360``: ``theta(c)`` the model's
corrected reference angle at count ``c``, ``step_zero`` the reference angle of a full step at driver
phase 0, ``sign`` -1 for an encoder counting against its reference (the table then still rises
with the count, as the firmware's own calibration would make it after the phase swap), to a
thousandth of a degree.
"""

import numpy as np

from ..._core.angles import wrap180
from ...data.calibration import MAX_ABS_DEG, Calibration
from ..._core.errors import InputError
from ..._core.parameters import invalid
from ._common import FirmwareExport, checked, compensator, correction_on_codes, read_c_array, read_text, round_trip
from ._stepper import check_step_zero

__all__ = ["export_mechaduino", "read_mechaduino", "COUNTS"]

COUNTS = 16384


def export_mechaduino(model, *, bits=None, step_zero_deg=None):
    """The ``lookup[16384]`` array in the firmware's frame: angles from full step 0, to 0.001 degree.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
    bits : int, optional
        14 or None (the model file's resolution): the lookup has one entry per 14-bit count.
    step_zero_deg : float
        The reference angle, degrees, of a full step at driver phase 0 (electrical zero). Required:
        the table is the commutation angle.

    Returns
    -------
    FirmwareExport
        Its round trip is ``y = lookup[count]`` (float32) against the model's angle from
        ``step_zero_deg`` on every count, no constant removed (the constant is the commutation).
    """
    comp = compensator(model)
    if bits is None and comp.encoder.get("resolution_bits") not in (None, 14):
        raise InputError(f"Mechaduino's lookup[16384] has one entry per count of its 14-bit AS5047D, but the model "
                         f"file records a {comp.encoder['resolution_bits']}-bit encoder; if its readings were 14-bit "
                         "counts, give --bits 14 (bits=14 in Python), else fit the model from the Mechaduino's own "
                         "readings")
    if bits is not None and (isinstance(bits, bool) or bits != 14):
        raise invalid("bits", "export_mechaduino", "14 or None (Mechaduino's lookup[16384] is for its 14-bit "
                      "AS5047D; default the model file's resolution)", bits)
    step_zero = check_step_zero(step_zero_deg, "Mechaduino", "export_mechaduino")
    counts = np.arange(COUNTS) * (360.0 / COUNTS)
    target = (comp.reading_sign * (np.asarray(comp.correct(counts), dtype=float) - step_zero)) % 360.0
    stored = np.round(target, 3) % 360.0
    deployed = stored.astype(np.float32).astype(float)
    max_error, rms_error = round_trip(wrap180(deployed - target) * 60.0, 0.0)
    items = [f"{v:.3f}" for v in stored]
    rows = ",\n".join(", ".join(items[i:i + 16]) for i in range(0, COUNTS, 16))
    text = ("//This is the encoder lookup table (created by encal: angles from full step 0, the reference's "
            f"{step_zero:g} deg)\nconst float __attribute__((__aligned__(256))) lookup[{COUNTS}] = {{\n{rows}\n}};\n")
    note = "paste into Parameters.cpp in place of the calibration routine's table"
    correction = correction_on_codes(comp, 14)
    # a thousandth of a degree, then float32 (half an ulp below 512 degrees: 2^-16 degree)
    export = FirmwareExport("mechaduino", text, max_error, rms_error, (0.0005 + 2.0**-16) * 60.0, COUNTS, note)
    return checked(export, correction - np.mean(correction))


def read_mechaduino(source_text, *, name=None):
    """A Mechaduino ``lookup[16384]`` as a calibration: every raw count against its table angle.

    Returns
    -------
    Calibration
        ``encoder_deg = k * 360 / 16384``, ``reference_deg = lookup[k]`` (its zero is full step 0, so a
        model fitted to it is exported back with ``step_zero_deg=0``), resolution 14 bits. A table
        that falls with the count (which the firmware's own calibration never writes) is read as an
        encoder counting against its reference: ``reading_sign`` -1, ``encoder_deg`` negated.

    Raises
    ------
    InputError
        Naming the element that is not a finite number, or when the table does not go once round
        the turn (up or down).
    """
    where = read_text(source_text)[1]
    lookup = read_c_array(source_text, "lookup")
    if lookup.size != COUNTS:
        raise InputError(f"{where}: expected {COUNTS} lookup entries, got {lookup.size}")
    bad = np.flatnonzero(~(np.abs(lookup) <= MAX_ABS_DEG))  # fuzz5: 6.02e23 was written to the calibration, wrapped
    if bad.size:
        raise InputError(f"{where}: element {bad[0]} of lookup[] is {float(lookup[bad[0]])!r}, expected a finite "
                         f"angle in degrees (within +-{MAX_ABS_DEG:g}, as in a calibration CSV)")
    turn = float(np.sum(wrap180(np.diff(lookup, append=lookup[:1]))))
    if abs(abs(turn) - 360.0) > 1.0:
        raise InputError(f"{where}: expected a lookup[] that goes once round the turn with the count (+360 "
                         f"degrees, as the firmware's calibration writes it), got one that goes {turn:+.4g}")
    sign = 1 if turn > 0 else -1
    return Calibration(lookup, sign * np.arange(COUNTS) * (360.0 / COUNTS), name=name or "mechaduino lookup",
                       resolution_bits=14, reading_sign=sign,
                       metadata={"format": "Mechaduino lookup[16384]", "step_zero_deg": 0.0})

"""Tinymovr: the 64-entry encoder rectification table ``rec_table``, in the sensor's native ticks.

Format (``firmware/src/sensor/sensor.h`` of github.com/tinymovr/Tinymovr,
``sensor_get_angle_rectified``; ``ECN_BITS`` = 6 in ``config.h``): ``int32_t rec_table[64]`` (since
2024-02; ``int16_t`` before) in ``SensorConfig``, node ``i`` at raw angle ``i << (bits - 6)``, where
``bits`` is the sensor's own resolution (``sensor_get_bits``) and the raw angle its native reading
(``get_raw_angle_func``). At run time, in ``int32_t``, ``off_1 = t[a >> s]``,
``off_2 = t[((a >> s) + 1) % 64]``, ``off = off_1 + (((off_2 - off_1) * (a - ((a >> s) << s))) >> s)``
with ``s = bits - 6`` (an arithmetic shift: a floor), and the rectified angle is ``a + off``: the
entries are **native ticks of the B-bit sensor** (2^B per turn). The firmware's own eccentricity
calibration (``sensor.c``) measures its error in the 13-bit "common" ticks (``SENSOR_COMMON_RES_BITS``,
8192 per turn) mapped into the sensor's frame; the two agree only for a 13-bit sensor. No command
loads the table: it is compiled in, element by element.
"""

import numpy as np

from ..._core.errors import InputError
from ..._core.parameters import check_int
from ..compact import evaluation_bits
from ._common import (FirmwareExport, checked, compensator, correction_model, correction_nodes, read_c_array,
                      read_text, round_trip)

__all__ = ["export_tinymovr", "tinymovr_rule", "read_tinymovr", "NODES"]

NODES = 64


def tinymovr_rule(table, angle, bits):
    """Tinymovr's rectification offset (ticks, integer) at raw angles of a ``bits``-bit sensor."""
    table = np.asarray(table, dtype=np.int64)
    angle = np.asarray(angle, dtype=np.int64)
    shift = bits - 6
    index = angle >> shift
    off_1 = table[index]
    off_2 = table[(index + 1) % NODES]
    return off_1 + (((off_2 - off_1) * (angle - (index << shift))) >> shift)


def export_tinymovr(model, *, bits=None):
    """``int32_t rec_table[64]`` in native ticks of a ``bits``-bit sensor (default the model file's resolution).

    The round trip is the firmware's integer rule on every code (on 2^20 evenly spaced codes above
    20 bits). Refused when the rule's ``(off_2 - off_1) * remainder`` would overflow ``int32_t``.
    """
    comp = compensator(model)
    bits = comp.encoder.get("resolution_bits") if bits is None else bits
    if bits is None:
        raise InputError("expected the sensor resolution (6 to 24 bits; Tinymovr's rule works in ticks), "
                         "got none; pass bits= (--bits)")
    bits = _check_bits(bits, "export_tinymovr")
    grid = evaluation_bits(bits)
    lsb = 21600.0 / 2**bits
    values, target, offset = correction_nodes(comp, NODES, grid)
    table = np.rint(values / lsb).astype(np.int64)
    step = np.max(np.abs(table - np.roll(table, -1))) * (2**(bits - 6) - 1)
    if np.max(np.abs(table)) > 2**31 - 1 or step > 2**31 - 1:
        raise InputError(f"expected a correction whose 64-node steps times the {bits}-bit remainder fit the "
                         f"firmware's int32_t arithmetic, got a product of {int(step)}; no file was written")
    codes = np.arange(2**grid, dtype=np.int64) << (bits - grid)
    deployed = tinymovr_rule(table, codes, bits) * lsb
    max_error, rms_error = round_trip(deployed, target)
    items = [str(int(v)) for v in table]
    rows = ",\n    ".join(", ".join(items[i:i + 16]) for i in range(0, NODES, 16))
    text = (f"/* encal: Tinymovr rec_table, rectification offsets in native ticks of the {bits}-bit sensor "
            f"(2^{bits} per turn; the firmware's own calibration works in 13-bit common ticks), node i at raw "
            f"angle i << {bits - 6}; copy element by element into SensorConfig.rec_table (int32_t since 2024-02) "
            f"and set rec_calibrated */\nint32_t rec_table[{NODES}] = {{\n    {rows}\n}};\n")
    note = (f"entries in native ticks of the {bits}-bit sensor (not the 13-bit common ticks of the firmware's own "
            "calibration); int32_t (firmware since 2024-02): copy element by element, not with memcpy from "
            "int16_t; set rec_calibrated. The rounding to whole ticks and the 64-node interpolation are the format's"
            + (f"; measured on 2^{grid} evenly spaced codes of the 2^{bits}" if grid < bits else ""))
    # node rounding (half a tick) plus the floor of the interpolation (under one tick)
    return checked(FirmwareExport("tinymovr", text, max_error, rms_error, 1.5 * lsb, 2**grid, note, offset), target)


def read_tinymovr(source_text, *, bits):
    """An existing ``rec_table`` (native ticks of a ``bits``-bit sensor, ``int32_t`` or ``int16_t``) as an error model.

    ``bits`` is the sensor's resolution, the unit of the entries the run-time rule adds (a table the
    firmware's own calibration wrote is in these units only for a 13-bit sensor).
    """
    bits = _check_bits(bits, "read_tinymovr")
    table = read_c_array(source_text, "rec_table")
    where = read_text(source_text)[1]
    if table.size != NODES:
        raise InputError(f"{where}: expected {NODES} rec_table entries, got {table.size}")
    fractional = np.flatnonzero(table != np.rint(table))
    if fractional.size:  # C would truncate 1.5 to 1 in an int32_t initialiser: read as 1.5 it is another table
        raise InputError(f"{where}: element {int(fractional[0])} of rec_table[] is {table[fractional[0]]:g}, "
                         "expected a whole number of ticks (the table is int32_t or int16_t)")
    with np.errstate(over="ignore"):  # an entry of 1e308 is refused below, as a correction beyond half a turn
        correction_arcmin = table * (21600.0 / 2**bits)
    return correction_model(correction_arcmin, name="Tinymovr rec_table", note="Tinymovr", where=where,
                            entry=lambda i: f"element {i} of rec_table[] ({table[i]:g} ticks of a {bits}-bit sensor)")


def _check_bits(bits, caller):
    return check_int(bits, "bits", caller, low=6, high=24, note="the sensor resolution; Tinymovr's rule works in "
                     "ticks of 2^bits per turn")

"""Tinymovr: the 64-entry encoder rectification table, in encoder ticks.

Format (``firmware/src/sensor/sensor.h`` of github.com/tinymovr/Tinymovr,
``sensor_get_angle_rectified``; ``ECN_BITS`` = 6 in ``config.h``): ``rec_table[64]`` of ticks,
node ``i`` at raw angle ``i << (bits - 6)``. At run time, in integers,
``off_1 = t[a >> s]``, ``off_2 = t[((a >> s) + 1) % 64]``,
``off = off_1 + (((off_2 - off_1) * (a - ((a >> s) << s))) >> s)`` with ``s = bits - 6``, and
the rectified angle is ``a + off``. Firmware before 2024 held ``int16_t``, current firmware
``int32_t`` entries; encal writes ``int16_t`` (the values fit either).
"""

import numpy as np

from ...errors import InputError
from ...parameters import check_int
from ._common import FirmwareExport, checked, compensator, correction_model, correction_nodes, read_c_array, round_trip

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
    """``int16_t rec_table[64]`` in ticks of a ``bits``-bit sensor (default the model file's resolution)."""
    comp = compensator(model)
    bits = comp.encoder.get("resolution_bits") if bits is None else bits
    if bits is None:
        raise InputError("expected the sensor resolution (6 to 24 bits; Tinymovr's rule works in ticks), "
                         "got none; pass bits= (--bits)")
    bits = _check_bits(bits, "export_tinymovr")
    lsb = 21600.0 / 2**bits
    values, target, offset = correction_nodes(comp, NODES, bits)
    table = np.rint(values / lsb).astype(np.int64)
    if np.max(np.abs(table)) > 32767:
        raise InputError(f"expected corrections within int16 ticks, got {int(np.max(np.abs(table)))}")
    deployed = tinymovr_rule(table, np.arange(2**bits), bits) * lsb
    max_error, rms_error = round_trip(deployed, target)
    items = [str(int(v)) for v in table]
    rows = ",\n    ".join(", ".join(items[i:i + 16]) for i in range(0, NODES, 16))
    text = (f"/* encal: rectification offsets in ticks of a {bits}-bit sensor, node i at raw angle "
            f"i << {bits - 6} */\nint16_t rec_table[{NODES}] = {{\n    {rows}\n}};\n")
    note = "the rounding to whole ticks and the 64-node interpolation are the format's; set rec_calibrated"
    # node rounding (half a tick) plus the floor of the interpolation (under one tick)
    return checked(FirmwareExport("tinymovr", text, max_error, rms_error, 1.5 * lsb, 2**bits, note, offset), target)


def read_tinymovr(source_text, *, bits):
    """An existing ``rec_table`` (ticks of a ``bits``-bit sensor) as an encal error model."""
    bits = _check_bits(bits, "read_tinymovr")
    table = read_c_array(source_text, "rec_table")
    if table.size != NODES:
        raise InputError(f"expected {NODES} rec_table entries, got {table.size}")
    return correction_model(table * (21600.0 / 2**bits), name="Tinymovr rec_table", note="Tinymovr")


def _check_bits(bits, caller):
    return check_int(bits, "bits", caller, low=6, high=24, note="the sensor resolution; Tinymovr's rule works in "
                     "ticks of 2^bits per turn")

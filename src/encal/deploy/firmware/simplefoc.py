"""SimpleFOC ``CalibratedSensor``: the ``calibrationLut`` of radians added to the raw angle.

Format (``src/encoders/calibrated/CalibratedSensor.cpp`` and ``.h`` of
github.com/simplefoc/Arduino-FOC-drivers): ``float calibrationLut[n_lut]`` (``n_lut`` = 128),
node ``i`` at ``i * 2 pi / n_lut`` radians of the raw mechanical angle. At run time, in
float: ``bucket = floor(raw / (2 pi / n))``, ``remainder = raw - (2 pi / n) * bucket``,
``offset = ((2 pi / n - remainder) / (2 pi / n)) * lut[bucket] + (remainder / (2 pi / n)) *
lut[(bucket + 1) % n]``, and the calibrated angle is ``raw + offset``.
"""

import numpy as np

from ...parameters import check_int
from ._common import (FirmwareExport, checked, compensator, correction_model, correction_nodes, grid_bits,
                      read_c_array, round_trip)

__all__ = ["export_simplefoc", "simplefoc_rule", "read_simplefoc", "NODES", "TWO_PI"]

NODES = 128
TWO_PI = np.float32(6.28318530718)  # SimpleFOC's _2PI


def simplefoc_rule(lut, raw_rad):
    """SimpleFOC's interpolated offset (radians, float32) at raw mechanical angles (float32 radians)."""
    f32 = np.float32
    lut = np.asarray(lut, dtype=f32)
    n = lut.size
    raw = np.asarray(raw_rad, dtype=f32)
    width = TWO_PI / f32(n)
    bucket = np.floor(raw.astype(float) / float(width)).astype(np.int64)  # floor() of a float: in double
    remainder = raw - width * bucket.astype(f32)
    return ((width - remainder) / width) * lut[bucket] + (remainder / width) * lut[(bucket + 1) % n]


def export_simplefoc(model, *, bits=None, nodes=NODES):
    """``float calibrationLut[N]`` for ``CalibratedSensor``.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
    bits : int, optional
        Resolution of the raw angle; default the model file's, else 16.
    nodes : int, default=128
        ``n_lut`` (128 in CalibratedSensor.h; change both together).
    """
    comp = compensator(model)
    grid = grid_bits(comp, bits, "export_simplefoc")
    nodes = check_int(nodes, "nodes", "export_simplefoc", low=2, high=2**grid,
                      note=f"CalibratedSensor's n_lut, at most one per code of the {grid}-bit grid")
    values, target, offset = correction_nodes(comp, nodes, grid)
    lut = (np.radians(values / 60.0)).astype(np.float32)
    raw = (np.arange(2**grid) * (2.0 * np.pi / 2**grid)).astype(np.float32)
    deployed = np.degrees(simplefoc_rule(lut, raw).astype(float)) * 60.0
    max_error, rms_error = round_trip(deployed, target)
    items = [f"{float(v):.9g}f" for v in lut]
    rows = ",\n    ".join(", ".join(items[i:i + 6]) for i in range(0, len(items), 6))
    text = (f"// encal: correction in radians added to the raw mechanical angle, node i at i*2*PI/{nodes}\n"
            f"float calibrationLut[{nodes}] = {{\n    {rows}\n}};\n")
    note = f"copy into CalibratedSensor (n_lut = {nodes}) instead of running its calibrate()"
    return checked(FirmwareExport("simplefoc", text, max_error, rms_error,
                          float(np.max(np.abs(lut))) * 2.0**-24 * 10800.0 / np.pi, 2**grid, note, offset), target)


def read_simplefoc(source_text):
    """An existing ``calibrationLut`` (radians) as an encal error model."""
    lut = read_c_array(source_text, "calibrationLut")
    return correction_model(np.degrees(lut) * 60.0, name="SimpleFOC calibrationLut",
                            note="SimpleFOC CalibratedSensor")

"""Tinymovr: encal's ``rec_table`` through the firmware's own ``sensor_get_angle_rectified``.

``../shared/firmware/tinymovr/firmware/src/sensor/sensor.h`` (the run-time rule, a static inline
function) and ``src/common.h`` are compiled with gcc against stub headers written for these tests
(``stubs/tinymovr/``: ``config.h`` with ``ECN_BITS`` 6, the frame-transform type, empty driver headers;
the vendor's ``pac5xxx*.h`` that common.h includes are generated empty in the build folder). The table
is copied element by element into ``SensorConfig.rec_table`` (``int32_t[64]``), every code of the
sensor is rectified, and the result is compared with the model's correction.
"""

import ctypes
import re
import shutil
from pathlib import Path

import numpy as np

from encal.deploy.firmware import export_tinymovr
from encal._core.errors import InputError

from . import FIRMWARE, Row
from .simplefoc import BITS, ZEROS_DEG, build_dir, compiled, measured, profile_model

SOURCE = FIRMWARE / "tinymovr" / "firmware"
STUBS = Path(__file__).resolve().parent / "stubs" / "tinymovr"


def unavailable():
    for path in (SOURCE / "src" / "sensor" / "sensor.h", SOURCE / "src" / "common.h"):
        if not path.is_file():
            return f"Tinymovr's own code is not here ({path} is missing)"
    if shutil.which("gcc") is None:
        return "gcc is not installed, so Tinymovr's own sensor.h cannot be compiled"
    return None


def library():
    vendor = build_dir() / "tinymovr-vendor-headers"
    vendor.mkdir(exist_ok=True)
    for header in re.findall(r'#include\s+"(pac5\w*\.h)"', (SOURCE / "src" / "common.h").read_text()):
        path = vendor / header
        if not path.exists():
            path.write_text("/* empty: the vendor's PAC55xx header is not needed on the host */\n")
    lib = compiled("tinymovr", [STUBS / "harness.c"], [STUBS, SOURCE, vendor], defines=["DEBUG", "BOARD_REV_R52"],
                   compiler="gcc", flags=["-std=gnu11", "-w"])
    lib.encal_rectified.argtypes = [ctypes.POINTER(ctypes.c_int32), ctypes.c_int, ctypes.POINTER(ctypes.c_int32),
                                    ctypes.c_int, ctypes.POINTER(ctypes.c_int32)]
    lib.encal_rectified.restype = ctypes.c_int
    return lib


def rectified(table, bits, angles):
    """``sensor_get_angle_rectified`` (ticks) of the firmware's own code at ``angles`` (raw ticks)."""
    table = np.ascontiguousarray(table, dtype=np.int32)
    angles = np.ascontiguousarray(angles, dtype=np.int32)
    out = np.zeros(angles.size, dtype=np.int32)
    pointer = ctypes.POINTER(ctypes.c_int32)
    size = library().encal_rectified(table.ctypes.data_as(pointer), bits, angles.ctypes.data_as(pointer),
                                     angles.size, out.ctypes.data_as(pointer))
    assert size == 4, f"rec_table holds {size}-byte entries in this firmware, expected int32_t"
    return out


def table_values(text):
    body = text[text.index("{", text.index("rec_table")) + 1:text.rindex("}")]
    return np.array([int(item) for item in body.split(",") if item.strip()], dtype=np.int64)


def row(bits, zero_deg, reading_sign):
    model = profile_model(bits, zero_deg, reading_sign)
    configuration = f"{bits}-bit, {'reversed' if reading_sign < 0 else 'forward'}, reference zero {zero_deg:g} deg"
    try:
        out = export_tinymovr(model, bits=bits)
    except InputError as error:
        return Row("tinymovr", configuration, None, None, None, None, str(error))
    codes = np.arange(2**bits)
    angles_rad = rectified(table_values(out.text), bits, codes) * (2.0 * np.pi / 2**bits)
    rms, largest = measured(model, angles_rad, out.offset_arcmin, bits)
    return Row("tinymovr", configuration, out.rms_error_arcmin, out.max_error_arcmin, rms, largest)


def matrix():
    for bits in BITS:
        for reading_sign in (1, -1):
            for zero_deg in ZEROS_DEG:
                yield row(bits, zero_deg, reading_sign)

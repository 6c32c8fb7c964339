"""SimpleFOC: encal's ``calibrationLut`` through Arduino-FOC-drivers' own ``CalibratedSensor``.

For 1.0.8 and 1.0.9 the library's own ``CalibratedSensor.cpp`` (``../shared/firmware/simplefoc/
drivers-v1.0.x/``) and the core's own ``Sensor.cpp`` (``arduino-foc/``, whose ``update()`` drops a
negative angle) are compiled with g++ against small stub headers written for these tests
(``stubs/simplefoc/``: timing no-ops, a ``FOCMotor`` with the members ``calibrate()`` names, a sensor
that returns ``code / (float)cpr * _2PI``), into a shared library called through ctypes; every code of
the encoder goes through ``update()`` in order and ``getMechanicalAngle()`` is read.

The uint16 LUT (pull request #75 of simplefoc/Arduino-FOC-drivers, merged 2025-12) is not among the
shared files, and the snapshot of the upstream repository that could be fetched stops at 1.0.8
(2024-08). Its run-time rule is modelled here from the code as read in two public forks that carry it,
Schnilz/Arduino-FOC-drivers@89b8e9597e1b0ca90b1685e671678f6353d56f78 and
Moddingear/Arduino-FOC-drivers@ed697c86115ffb857a01fb67703111de75513a4a,
``src/encoders/calibrated/CalibratedSensor.h`` (lines 15-16 of the Schnilz commit: ``LUT_SCALE
10430.2191955f``, ``LUT_OFFSET 32767.0f``; the inline ``decodeOffsetU16(u) = (u - LUT_OFFSET) / LUT_SCALE``)
and ``CalibratedSensor.cpp`` (lines 7-11, the constructor's ``lut_resolution = _2PI / n_lut`` and
``lut_resolution_inv = 1.0f / lut_resolution``; lines 35-65, ``getSensorAngle``:
``lut_index = raw_angle * lut_resolution_inv``, the upper index
``lut_index >= n_lut-1 ? 0 : lut_index + 1``, ``distance_lower = (raw_angle - lut_index *
lut_resolution) * lut_resolution_inv``, ``raw_angle - correction_offset`` normalised into [0, 2 pi)),
written independently of encal's copy below, in float32.
"""

import ctypes
import hashlib
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from encal.deploy import Compensator
from encal.deploy.firmware import export_simplefoc
from encal._core.errors import InputError
from encal.models.fourier import FourierModel

from . import FIRMWARE, Row

SOURCE = FIRMWARE / "simplefoc"
STUBS = Path(__file__).resolve().parent / "stubs" / "simplefoc"
VERSIONS = ("1.0.8", "1.0.9", "uint16")
BITS = (14, 16)
ZEROS_DEG = (0.0, 0.45, 0.9, 1.8, 2.5, 3.6, 7.2, 30.0)
_LIBRARIES = {}


def unavailable():
    for path in (SOURCE / "arduino-foc" / "src" / "common" / "base_classes" / "Sensor.cpp",
                 SOURCE / "drivers-v1.0.8" / "CalibratedSensor.cpp",
                 SOURCE / "drivers-v1.0.9" / "CalibratedSensor.cpp"):
        if not path.is_file():
            return f"SimpleFOC's own code is not here ({path} is missing)"
    if shutil.which("g++") is None:
        return "g++ is not installed, so SimpleFOC's own CalibratedSensor.cpp cannot be compiled"
    return None


def build_dir():
    path = Path(tempfile.gettempdir()) / "encal-firmware-own"
    path.mkdir(parents=True, exist_ok=True)
    return path


def compiled(name, sources, include_dirs, defines=(), compiler="g++", flags=()):
    """A shared library built from ``sources`` once per content (cached under the system's temporary folder)."""
    command = [compiler, "-O1", "-shared", "-fPIC", "-ffp-contract=off", *flags,
               *[f"-D{d}" for d in defines], *[f"-I{d}" for d in include_dirs]]
    digest = hashlib.sha256(" ".join(command).encode())
    for path in sorted(sources) + sorted(p for d in include_dirs for p in Path(d).rglob("*.h")):
        digest.update(str(path).encode() + Path(path).read_bytes())
    target = build_dir() / f"{name}-{digest.hexdigest()[:16]}.so"
    if target not in _LIBRARIES:
        if not target.is_file():
            partial = target.with_suffix(f".{np.random.default_rng().integers(1 << 30)}.tmp")
            subprocess.run([*command, *map(str, sources), "-o", str(partial)], check=True, capture_output=True,
                           text=True)
            partial.replace(target)
        _LIBRARIES[target] = ctypes.CDLL(str(target))
    return _LIBRARIES[target]


def library(version):
    """The compiled CalibratedSensor of drivers ``version`` ("1.0.8" or "1.0.9") with the core's Sensor."""
    drivers = SOURCE / f"drivers-v{version}"
    core = SOURCE / "arduino-foc" / "src"
    lib = compiled(f"simplefoc-{version}", [STUBS / "harness.cpp", drivers / "CalibratedSensor.cpp",
                                            core / "common" / "base_classes" / "Sensor.cpp"],
                   [drivers, core, STUBS, STUBS / "common" / "base_classes"],
                   defines=["ENCAL_DRIVERS_1_0_8"] if version == "1.0.8" else [], flags=["-std=gnu++17", "-w"])
    lib.encal_calibrated_angles.argtypes = [ctypes.POINTER(ctypes.c_float), ctypes.c_int, ctypes.c_int,
                                            ctypes.POINTER(ctypes.c_float)]
    lib.encal_calibrated_angles.restype = ctypes.c_int
    return lib


def firmware_angles(version, lut, bits):
    """The calibrated angle (float32 radians) of every code, as the firmware's ``getMechanicalAngle()`` gives it."""
    if version == "uint16":
        return uint16_model_angles(np.asarray(lut, dtype=np.uint16), bits)
    lut = np.ascontiguousarray(lut, dtype=np.float32)
    out = np.zeros(2**bits, dtype=np.float32)
    status = library(version).encal_calibrated_angles(lut.ctypes.data_as(ctypes.POINTER(ctypes.c_float)), lut.size,
                                                      bits, out.ctypes.data_as(ctypes.POINTER(ctypes.c_float)))
    assert status == 0, f"drivers {version} holds a different n_lut than the table's {lut.size}"
    return out


def uint16_model_angles(lut, bits):
    """The uint16 version's getSensorAngle (model of the forks' code cited above), float32, through Sensor::update."""
    f = np.float32
    two_pi = f(6.28318530718)
    n = lut.size
    raw = (np.arange(2**bits).astype(f) / f(2**bits)) * two_pi
    resolution = two_pi / f(n)
    inverse = f(1.0) / resolution
    index = (raw * inverse).astype(np.int64)
    upper = np.where(index >= n - 1, 0, index + 1)
    decoded = (lut.astype(f) - f(32767.0)) / f(10430.2191955)
    distance = (raw - index.astype(f) * resolution) * inverse
    angle = raw - ((f(1.0) - distance) * decoded[index] + distance * decoded[upper])
    wrapped = np.fmod(angle, two_pi)
    angle = np.where((angle < 0) | (angle >= two_pi), np.where(wrapped >= 0, wrapped, wrapped + two_pi), angle)
    return stale_where_negative(angle.astype(f))


def stale_where_negative(angle):
    """Sensor::update: a negative angle is dropped and the previous one stays (codes read in order, last first)."""
    angle = np.array(angle)
    previous = angle[-1]
    for i in np.flatnonzero(angle < 0):
        angle[i] = angle[i - 1] if i > 0 else previous
    return angle


def profile_model(bits, zero_deg, reading_sign, seed=26):
    """An encoder error of about 2.4 arcmin RMS (first harmonics and a 50th) plus a reference zero of ``zero_deg``."""
    rng = np.random.default_rng(seed)
    orders = [0, 1, 2, 3, 4, 5, 50]
    cos = [zero_deg * 60.0, *rng.normal(0.0, 1.5, 6)]
    sin = [0.0, *rng.normal(0.0, 1.5, 6)]
    model = FourierModel(orders, cos, sin, encoder={"resolution_bits": bits})
    model.reading_sign = reading_sign
    return model


def measured(model, angles_rad, offset_arcmin, bits):
    """(RMS, max) arcmin of the firmware's angles against the model's correction (``Compensator.correct``)."""
    comp = Compensator(model)
    codes_deg = np.arange(2**bits) * (360.0 / 2**bits)
    expected_deg = comp.reading_sign * comp.correct(codes_deg) - offset_arcmin / 60.0
    gap = (np.degrees(np.asarray(angles_rad, dtype=float)) - expected_deg + 180.0) % 360.0 - 180.0
    gap *= 60.0
    return float(np.sqrt(np.mean(gap**2))), float(np.max(np.abs(gap)))


def lut_values(text, version):
    body = text[text.index("{") + 1:text.index("}")]
    values = [item.strip().rstrip("f") for item in body.split(",") if item.strip()]
    return np.array(values, dtype=np.uint16 if version == "uint16" else np.float32)


def row(version, bits, zero_deg, reading_sign):
    model = profile_model(bits, zero_deg, reading_sign)
    configuration = (f"drivers {version}, {bits}-bit, {'reversed' if reading_sign < 0 else 'forward'}, "
                     f"reference zero {zero_deg:g} deg")
    try:
        out = export_simplefoc(model, firmware_version=version)
    except InputError as error:
        return Row("simplefoc", configuration, None, None, None, None, str(error))
    angles = firmware_angles(version, lut_values(out.text, version), bits)
    rms, largest = measured(model, angles, out.offset_arcmin, bits)
    return Row("simplefoc", configuration, out.rms_error_arcmin, out.max_error_arcmin, rms, largest)


def matrix():
    for version in VERSIONS:
        for bits in BITS:
            for reading_sign in (1, -1):
                for zero_deg in ZEROS_DEG:
                    yield row(version, bits, zero_deg, reading_sign)

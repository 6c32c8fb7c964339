"""SimpleFOC ``CalibratedSensor`` (Arduino-FOC-drivers): the ``calibrationLut`` of each library version.

Source: ``src/encoders/calibrated/CalibratedSensor.{h,cpp}`` of github.com/simplefoc/Arduino-FOC-drivers.
``raw`` is the wrapped sensor's mechanical angle, float32 radians in [0, 2 pi) (a magnetic sensor gives
``code / (float)cpr * _2PI``); node ``i`` sits at ``i * 2 pi / n_lut``; all arithmetic is float32.

- ``"1.0.8"`` (release 1.0.8, 2024-07): ``float`` LUT of ``n_lut`` = 128 (a constant of the header),
  ``bucket = floor(raw / (2 pi / n))``, ``remainder = raw - (2 pi / n) * bucket``, ``offset =
  ((w - remainder) / w) * lut[bucket] + (remainder / w) * lut[(bucket + 1) % n]``; returns
  ``raw + offset``: the LUT is the **correction**. No way to pass a table without editing the library.
- ``"1.0.9"`` (release 1.0.9, 2025-07-28): ``float`` LUT, ``n_lut`` a constructor argument (default 200)
  and the table the third one; ``index = (int)(raw / res)``, ``distance = (raw - index * res) / res``,
  ``offset = (1 - distance) * lut[index] + distance * lut[(index + 1) % n]``; returns ``raw - offset``:
  the LUT is the **error**. Its ``calibrate()`` prints ``float calibrationLut[N] = {...};`` (6 decimals).
- ``"uint16"`` (pull request #75, merged 2025-12, after 1.0.9 and in no release these sources know):
  ``uint16_t`` LUT, ``decode(u) = (u - 32767.0f) / 10430.2191955f`` radians of error,
  ``index = (int)(raw * inv)`` with ``inv = 1 / res``, the upper neighbour ``index >= n - 1 ? 0 : index + 1``,
  ``distance = (raw - index * res) * inv``; returns ``raw - offset``, normalised into [0, 2 pi).
  Its ``printLUT()`` prints ``uint16_t calibrationLut[N] = {...};``.

The core library's ``Sensor::update`` drops a negative angle (the reading goes stale), and near raw 0
``raw +/- lut`` is negative wherever the table's value at node 0 asks for it; so the constant encal leaves
out of the table is the correction at node 0 (not the mean), and the table holds 0 there: the calibrated
angle stays in [0, 2 pi) and the constant (the reference's zero) is stated.
"""

import re

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import spsolve

from ..._core.errors import InputError
from ..._core.parameters import check_int
from ._common import (FirmwareExport, checked, compensator, correction_model, correction_on_codes, grid_bits,
                      read_c_array, read_text, round_trip)

__all__ = ["export_simplefoc", "simplefoc_angle", "read_simplefoc", "VERSIONS", "DEFAULT_VERSION",
           "DEFAULT_NODES", "TWO_PI", "LUT_SCALE", "LUT_OFFSET"]

VERSIONS = ("1.0.8", "1.0.9", "uint16")
DEFAULT_VERSION = "1.0.9"  # the current release
DEFAULT_NODES = {"1.0.8": 128, "1.0.9": 200, "uint16": 200}
TWO_PI = np.float32(6.28318530718)  # SimpleFOC's _2PI
LUT_SCALE = np.float32(10430.2191955)  # the uint16 LUT's radians -> counts
LUT_OFFSET = np.float32(32767.0)
_F = np.float32
_ARCMIN_PER_RAD = 10800.0 / np.pi
_MARKER = re.compile(r"firmware_version=([\w.]*\w)")
_ARRAY = "calibrationLut"


def _check_version(version, caller):
    if version not in VERSIONS:
        raise InputError(f"The 'firmware_version' parameter of {caller} must be one of {', '.join(VERSIONS)} "
                         f"(the Arduino-FOC-drivers CalibratedSensor the table is for). Got {version!r} instead.")
    return version


def raw_angles(bits):
    """The wrapped sensor's float32 angle of every code: ``code / (float)cpr * _2PI``, as SimpleFOC computes it."""
    return (np.arange(2**bits, dtype=np.float64).astype(_F) / _F(2**bits)) * TWO_PI


def _weights(version, n, raw):
    """The two LUT indices each raw angle reads and their float32 weights, as the version computes them."""
    raw = np.asarray(raw, dtype=_F)
    one = _F(1)
    if version == "1.0.8":
        width = TWO_PI / _F(n)
        lower = np.floor(raw / width).astype(np.int64)
        remainder = raw - width * lower.astype(_F)
        return lower, (lower + 1) % n, (width - remainder) / width, remainder / width
    resolution = TWO_PI / _F(n)
    if version == "1.0.9":
        raw = np.fmod(raw, TWO_PI)
        lower = (raw / resolution).astype(np.int64)
        distance = (raw - lower.astype(_F) * resolution) / resolution
        return lower, (lower + 1) % n, one - distance, distance
    inverse = one / resolution
    lower = (raw * inverse).astype(np.int64)
    distance = (raw - lower.astype(_F) * resolution) * inverse
    return lower, np.where(lower >= n - 1, 0, lower + 1), one - distance, distance


def decode_u16(encoded):
    """The uint16 LUT's entries as float32 radians: ``(u - 32767.0f) / 10430.2191955f``."""
    return (np.asarray(encoded).astype(_F) - LUT_OFFSET) / LUT_SCALE


def simplefoc_angle(lut, raw, version=DEFAULT_VERSION):
    """``CalibratedSensor::getSensorAngle()`` of ``version``: the calibrated angle (float32 radians).

    Parameters
    ----------
    lut : array-like
        The stored table: float radians (1.0.8, 1.0.9) or uint16 codes (``"uint16"``).
    raw : array-like
        The wrapped sensor's mechanical angles, float32 radians in [0, 2 pi).
    """
    version = _check_version(version, "simplefoc_angle")
    raw = np.asarray(raw, dtype=_F)
    values = decode_u16(lut) if version == "uint16" else np.asarray(lut, dtype=_F)
    lower, upper, w_lower, w_upper = _weights(version, values.size, raw)
    offset = w_lower * values[lower] + w_upper * values[upper]
    if version == "1.0.8":
        return raw + offset
    angle = raw - offset
    if version == "uint16":  # normalised into [0, 2 pi) with _normalizeAngle
        outside = (angle < 0) | (angle >= TWO_PI)
        wrapped = np.fmod(angle, TWO_PI)
        angle = np.where(outside, np.where(wrapped >= 0, wrapped, wrapped + TWO_PI), angle).astype(_F)
    return angle


def _fit_nodes(version, n, raw, target):
    """Least-squares node values (arcmin) of the version's own interpolation, at its own float32 weights."""
    lower, upper, w_lower, w_upper = _weights(version, n, raw)
    rows = np.arange(raw.size)
    design = sparse.csr_matrix((np.concatenate([w_lower, w_upper]).astype(float),
                                (np.concatenate([rows, rows]), np.concatenate([lower, upper]))), shape=(raw.size, n))
    normal = (design.T @ design).tocsc()
    return np.asarray(spsolve(normal, design.T @ target), dtype=float)


def export_simplefoc(model, *, bits=None, nodes=None, firmware_version=DEFAULT_VERSION):
    """``calibrationLut`` for ``CalibratedSensor`` of one Arduino-FOC-drivers version.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
    bits : int, optional
        Resolution of the raw angle; default the model file's, else 16.
    nodes : int, optional
        ``n_lut``; default 128 for ``"1.0.8"`` (a constant of its CalibratedSensor.h: change both
        together), 200 for ``"1.0.9"`` and ``"uint16"`` (their constructor's default).
    firmware_version : {"1.0.9", "1.0.8", "uint16"}, default="1.0.9"
        The library version: 1.0.8 adds a float LUT (the correction), 1.0.9 subtracts one (the error),
        ``"uint16"`` (pull request #75, after 1.0.9) subtracts a uint16-encoded error.

    Returns
    -------
    FirmwareExport
        Its round trip is the version's own rule on every code, the float32 angle it returns included.
        The correction at node 0 is left out (``offset_arcmin``), so the angle stays in [0, 2 pi).

    Raises
    ------
    InputError
        When the version cannot hold the table (a uint16 entry out of range, an angle below 0 that
        ``Sensor::update`` would drop), or the round trip is not far smaller than the correction.
    """
    version = _check_version(firmware_version, "export_simplefoc")
    comp = compensator(model)
    grid = grid_bits(comp, bits, "export_simplefoc")
    nodes = DEFAULT_NODES[version] if nodes is None else check_int(
        nodes, "nodes", "export_simplefoc", low=2, high=2**grid,
        note=f"CalibratedSensor's n_lut, at most one per code of the {grid}-bit grid")
    target = correction_on_codes(comp, grid)
    raw = raw_angles(grid)
    values = _fit_nodes(version, nodes, raw, target)
    offset = float(values[0])
    values, target = values - offset, target - offset
    values[0] = 0.0
    radians = np.radians(values / 60.0) * (1.0 if version == "1.0.8" else -1.0)
    if version == "uint16":
        encoded = np.rint(radians * float(LUT_SCALE) + float(LUT_OFFSET))
        if encoded.min() < 0 or encoded.max() > 65535:
            raise InputError(f"expected a correction within the uint16 LUT's +/-pi radians, got "
                             f"{np.max(np.abs(values)):.6g} arcmin; no file was written")
        lut = encoded.astype(np.uint16)
        step = 0.5 / float(LUT_SCALE)
    else:
        lut = radians.astype(_F)
        step = float(np.max(np.abs(lut))) * 2.0**-24
    angle = simplefoc_angle(lut, raw, version)
    if version != "uint16" and np.any(angle < 0):
        raise InputError(f"the SimpleFOC {version} table would return a negative angle at raw "
                         f"{float(raw[np.argmax(angle < 0)]):.6g} rad, which Sensor::update drops; expected a "
                         "correction whose slope stays above -1, so no file was written")
    ideal = np.arange(2**grid) * (2.0 * np.pi / 2**grid)
    gap = np.remainder(angle.astype(float) - ideal + np.pi, 2.0 * np.pi) - np.pi
    max_error, rms_error = round_trip(gap * _ARCMIN_PER_RAD, target)
    # the stored values' rounding, plus the float32 raw angle's and returned angle's (half an ulp of 2 pi each)
    quantisation = (step + 2.0**-21) * _ARCMIN_PER_RAD
    text = _text(version, nodes, lut)
    note = _load_note(version, nodes)
    export = FirmwareExport("simplefoc", text, max_error, rms_error, quantisation, 2**grid, note, offset,
                            offset_note="the correction at node 0, so that the calibrated angle stays in "
                                        "[0, 2 pi): Sensor::update drops a negative one")
    return checked(export, target)


def _load_note(version, nodes):
    if version == "1.0.8":
        return (f"for Arduino-FOC-drivers 1.0.8 (raw + LUT), n_lut {nodes}: 1.0.8 takes no table, so copy these "
                "values into calibrationLut in CalibratedSensor's constructor and do not call calibrate()")
    kind = "uint16_t" if version == "uint16" else "float"
    which = ("Arduino-FOC-drivers with the uint16 LUT (pull request #75, after 1.0.9)" if version == "uint16"
             else "Arduino-FOC-drivers 1.0.9")
    return (f"for {which} (raw - LUT): pass the {kind} array to the constructor, "
            f"CalibratedSensor sensor_calibrated(sensor, {nodes}, calibrationLut), and do not call calibrate()")


def _text(version, nodes, lut):
    if version == "uint16":
        items = [str(int(v)) for v in lut]
        per_row, kind = 10, "uint16_t"
        what = ("the error (subtracted from the raw angle), encoded round(rad * 10430.2191955) + 32767 "
                "(decoded (u - 32767.0f) / 10430.2191955f)")
    else:
        items = [f"{float(v):.9g}f" for v in lut]
        per_row, kind = 6, "float"
        what = ("the correction in radians (added to the raw angle)" if version == "1.0.8"
                else "the error in radians (subtracted from the raw angle)")
    rows = ",\n    ".join(", ".join(items[i:i + per_row]) for i in range(0, len(items), per_row))
    return (f"// encal: SimpleFOC CalibratedSensor, firmware_version={version}: {what}, node i at i*2*PI/{nodes}\n"
            f"// {_load_note(version, nodes)}\n"
            f"{kind} {_ARRAY}[{nodes}] = {{\n    {rows}\n}};\n")


def _detected_version(text):
    """The version a file says it is for, or None: encal's own marker, a uint16 array, 1.0.9's print-out."""
    marker = _MARKER.search(text)
    if marker:
        return marker.group(1)
    if re.search(rf"\buint16_t\s+{_ARRAY}\s*\[", text):
        return "uint16"
    # only 1.0.9's calibrate() prints these lines around its float array (1.0.8 prints no table)
    if re.search(r"Constructing LUT\.|float zero_electric_angle\s*=|Direction sensor_direction\s*=", text):
        return "1.0.9"
    return None


def read_simplefoc(source_text, *, firmware_version=None):
    """An existing ``calibrationLut`` as an encal error model, read the way ``firmware_version`` applies it.

    Parameters
    ----------
    source_text : str or os.PathLike
        A file (or its text): encal's export, 1.0.9's ``calibrate()`` print-out, or the uint16
        version's ``printLUT()`` print-out.
    firmware_version : {"1.0.8", "1.0.9", "uint16"}, optional
        Default: what the file says (encal's ``firmware_version=`` comment, a ``uint16_t`` array, or
        1.0.9's print-out lines). A float array that says nothing is refused: 1.0.8 adds it, 1.0.9
        subtracts it.

    Raises
    ------
    InputError
        When the version is neither given nor in the file, contradicts the file, or an entry is not
        a finite number (a uint16 entry: an integer from 0 to 65535).
    """
    text, where = read_text(source_text)
    detected = _detected_version(text)
    if firmware_version is not None:
        _check_version(firmware_version, "read_simplefoc")
        if detected is not None and detected != firmware_version:
            raise InputError(f"{where}: the file is a calibrationLut for firmware_version {detected}, not "
                             f"{firmware_version}; expected them to agree (drop --firmware-version or correct it)")
    version = firmware_version or detected
    if version is None:
        raise InputError(f"{where}: a float calibrationLut is added to the raw angle by Arduino-FOC-drivers 1.0.8 "
                         "and subtracted by 1.0.9, and the file does not say which; expected --firmware-version "
                         "1.0.8 or 1.0.9 (firmware_version=)")
    if version not in VERSIONS:
        raise InputError(f"{where}: firmware_version={version} is not one encal reads; expected one of "
                         f"{', '.join(VERSIONS)}")
    lut = read_c_array(source_text, _ARRAY)
    if version == "uint16":
        bad = np.flatnonzero((lut != np.rint(lut)) | (lut < 0) | (lut > 65535))
        if bad.size:
            raise InputError(f"{where}: element {int(bad[0])} of {_ARRAY}[] is {lut[bad[0]]:g}, expected a uint16 "
                             "(an integer from 0 to 65535) in the uint16 LUT")
        radians = -decode_u16(lut.astype(np.uint16)).astype(float)
    else:
        radians = lut if version == "1.0.8" else -lut
    with np.errstate(over="ignore"):  # an entry of 1e308 is refused below, as a correction beyond half a turn
        correction_arcmin = np.degrees(radians) * 60.0
    return correction_model(correction_arcmin, name=f"SimpleFOC calibrationLut ({version})",
                            note=f"SimpleFOC CalibratedSensor, Arduino-FOC-drivers {version}", where=where,
                            entry=lambda i: f"element {i} of {_ARRAY}[] ({lut[i]:g})")

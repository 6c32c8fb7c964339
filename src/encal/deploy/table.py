"""A model compiled to a dense per-count correction table for a B-bit encoder.

A B-bit encoder reports integer codes ``k`` in ``[0, 2^B)``, i.e. angles
``k * 360 / 2^B`` degrees. The table holds the model's predicted error at
every code, so correcting a reading is one array lookup. It is stored as

- ``int16`` in a fixed-point unit of ``scale_arcmin = 2^e`` arc-minutes, the
  smallest power of two with which the model's largest error fits
  (a power of two, so converting back is exact in any float format), or
- ``float32`` arc-minutes (``scale_arcmin = 1``).

Two deviations from the model are measured when the table is compiled:

- ``quantisation_arcmin``: the largest ``|stored value - model|`` over all
  codes, the table's exact worst case for code readings. A priori it is at
  most ``scale_arcmin / 2`` (int16) or ``2^-24 * max |error|`` (float32).
- ``between_codes_arcmin``: the largest change of the model between a code
  and the midpoints next to it, that is the extra deviation when an angle
  that is not a code is looked up at its nearest code.

The file format (``encal export --format table``) is a fixed 80-byte header
followed by the raw little-endian array; see :func:`save_table`.
"""

import functools
import math
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._atomic import atomic_write
from ..angles import ARCMIN_PER_DEG, model_input, wrap360
from ..errors import InputError, ModelFileError
from ..models.base import as_angles
from ..parameters import check_choice, check_int, check_number, check_type, invalid
from .compact import check_exportable
from .compensator import Compensator

__all__ = ["CorrectionTable", "compile_table", "save_table", "load_table",
           "TABLE_MAGIC", "TABLE_VERSION", "TABLE_DTYPES", "MAX_TABLE_BITS"]

TABLE_MAGIC = b"ENCALTAB"
#: Newest table format this reader understands. Version 2 adds ``reading_sign`` after the 80-byte header;
#: a writer uses version 1 unless the model negates readings, so version-1 readers refuse only such tables.
TABLE_VERSION = 2
#: dtype name -> (code in the file header, little-endian NumPy dtype)
TABLE_DTYPES = {"int16": (1, np.dtype("<i2")), "float32": (2, np.dtype("<f4"))}
MAX_TABLE_BITS = 24
# magic, version, bits, dtype code, header size, entries, crc32 of the data,
# scale, quantisation, between codes (arcmin), model sha256 (raw bytes)
_HEADER = struct.Struct("<8sHBBIIIddd32s")
# version 2 only: reading_sign (int8, 1 or -1), 7 reserved zero bytes
_SIGN_HEADER = struct.Struct("<b7x")
_INT16_MAX = 32767
_CHUNK = 1 << 16  # angles per model evaluation, to bound memory for large tables


@dataclass(frozen=True, eq=False)
class CorrectionTable:
    """Predicted errors of a model at every code of a B-bit encoder.

    Attributes
    ----------
    bits : int
        Encoder resolution B; the table has ``2^B`` entries.
    values : ndarray of shape (2^B,), int16 or float32
        Stored errors, in units of ``scale_arcmin``; entry ``k`` is for code ``k``.
    scale_arcmin : float
        Arc-minutes per stored unit (a power of two; 1.0 for float32).
    quantisation_arcmin : float
        Largest deviation from the model at the codes, in arc-minutes.
    between_codes_arcmin : float
        Largest extra deviation for an angle between codes looked up at its
        nearest code, in arc-minutes (measured at the midpoints).
    model_sha256 : str or None
        Checksum of the model file the table was compiled from.
    reading_sign : {1, -1}
        The model's ``reading_sign``: -1 when the encoder counts against its reference. Entry ``k`` is
        still the error at raw code ``k``; the corrected angle is ``(-k * step - error) mod 360``.
    """

    bits: int
    values: np.ndarray
    scale_arcmin: float
    quantisation_arcmin: float
    between_codes_arcmin: float
    model_sha256: str | None = None
    reading_sign: int = 1

    def __post_init__(self):
        caller = "CorrectionTable"
        check_int(self.bits, "bits", caller, low=1, high=MAX_TABLE_BITS)
        check_type(self.values, np.ndarray, "values", caller, "an ndarray")
        if self.values.dtype.name not in TABLE_DTYPES or self.values.shape != (2**self.bits,):
            raise invalid("values", caller, f"an int16 or float32 array of 2^bits = {2**self.bits} entries",
                          self.values, shown=f"an array of {self.values.dtype.name} and shape {self.values.shape}")
        check_number(self.scale_arcmin, "scale_arcmin", caller, low=0.0, low_open=True, note="arc-minutes")
        check_number(self.quantisation_arcmin, "quantisation_arcmin", caller, low=0.0, note="arc-minutes")
        check_number(self.between_codes_arcmin, "between_codes_arcmin", caller, low=0.0, note="arc-minutes")
        if self.model_sha256 is not None:
            check_type(self.model_sha256, str, "model_sha256", caller, "a str or None")
        if isinstance(self.reading_sign, bool) or self.reading_sign not in (1, -1):
            raise invalid("reading_sign", caller, "1 or -1", self.reading_sign)

    @property
    def dtype(self):
        """``'int16'`` or ``'float32'``."""
        return self.values.dtype.name

    @property
    def step_deg(self):
        """Angle of one code, ``360 / 2^B`` degrees."""
        return 360.0 / 2**self.bits

    @functools.cached_property
    def error_arcmin(self):
        """The stored errors in arc-minutes (float64), one per code."""
        return self.values.astype(float) * self.scale_arcmin

    @functools.cached_property
    def _corrected_deg(self):
        # The corrected angle of every code, computed once: a reading is then one lookup.
        codes = np.arange(self.values.size, dtype=float)
        return wrap360(model_input(codes * self.step_deg, self.reading_sign) - self.error_arcmin / ARCMIN_PER_DEG)

    def predict_counts(self, codes):
        """Predicted error in arc-minutes at encoder codes.

        Parameters
        ----------
        codes : int or array-like of int
            Raw encoder readings, from 0 to ``2^B - 1``.
        """
        return self.error_arcmin[self._index(codes)]

    def correct_counts(self, codes):
        """Corrected angles in degrees, in [0, 360), of raw encoder codes (one lookup each)."""
        return self._corrected_deg[self._index(codes)]

    def nearest_codes(self, theta_deg):
        """The code nearest to each angle (degrees), ties rounded up, modulo ``2^B``."""
        theta = wrap360(as_angles(theta_deg))
        codes = np.floor(theta / self.step_deg + 0.5).astype(np.int64)
        return codes & (self.values.size - 1)

    def predict(self, theta_deg):
        """Predicted error in arc-minutes at angles (degrees), looked up at the nearest code."""
        return self.error_arcmin[self.nearest_codes(theta_deg)]

    def correct(self, theta_deg):
        """Corrected angles (degrees), subtracting the error stored at the nearest code."""
        # Wrap first: far from 0 a reading's spacing can exceed the correction, which would be lost.
        theta = wrap360(as_angles(theta_deg))
        return wrap360(model_input(theta, self.reading_sign) - self.predict(theta) / ARCMIN_PER_DEG)

    def _index(self, codes):
        codes = np.asarray(codes)
        if codes.dtype.kind not in "iu":
            raise InputError(f"expected integer encoder codes, got an array of {codes.dtype}")
        if codes.dtype.kind == "i" and codes.size and codes.min() < 0:
            raise InputError(f"expected encoder codes from 0 to {self.values.size - 1}, "
                             f"got {int(codes.min())}")
        unchecked = codes.dtype.kind == "u" and np.iinfo(codes.dtype).max < self.values.size
        if not unchecked and codes.size and codes.max() >= self.values.size:
            raise InputError(f"expected encoder codes from 0 to {self.values.size - 1} "
                             f"({self.bits} bits), got {int(codes.max())}")
        return codes

    def save(self, path):
        """Write the table file (see :func:`save_table`)."""
        return save_table(self, path)


def compile_table(model, bits=None, *, dtype="int16"):
    """Evaluate a model at every code of a B-bit encoder.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
        The model, or its model file.
    bits : int, optional
        Encoder resolution, 1 to 24. Default: the model's ``encoder.resolution_bits``.
    dtype : {'int16', 'float32'}, default='int16'
        Storage of the errors: int16 fixed point with a power-of-two unit, or float32.

    Returns
    -------
    CorrectionTable

    Raises
    ------
    InputError
        If ``bits`` is missing or out of range, or ``dtype`` unknown.
    """
    check_choice(dtype, "dtype", "compile_table", tuple(TABLE_DTYPES))
    comp = model if isinstance(model, Compensator) else Compensator(model)
    from ..arcs import refuse_arc

    refuse_arc(comp, "a dense table")  # periodic: it cannot say "outside" (see encal.arcs)
    bits = _check_bits(comp.encoder.get("resolution_bits") if bits is None else bits)
    n = 2**bits
    step = 360.0 / n
    codes = np.arange(n, dtype=float)
    error = check_exportable(_evaluate(comp, codes * step), comp, "compile_table")
    midpoint = check_exportable(_evaluate(comp, (codes + 0.5) * step), comp, "compile_table", (codes + 0.5) * step)
    between = max(np.max(np.abs(midpoint - error), initial=0.0),
                  np.max(np.abs(midpoint - np.roll(error, -1)), initial=0.0))
    if dtype == "int16":
        scale = _power_of_two_scale(np.max(np.abs(error)))
        values = np.rint(error / scale).astype("<i2")
    else:
        scale = 1.0
        values = error.astype("<f4")
    quantisation = float(np.max(np.abs(values * scale - error)))
    return CorrectionTable(bits, values, scale, quantisation, float(between), comp.sha256,
                           comp.reading_sign)


def _evaluate(comp, angles):
    return np.concatenate([comp.predict(angles[i:i + _CHUNK])
                           for i in range(0, angles.size, _CHUNK)])


def _power_of_two_scale(largest_arcmin):
    """The smallest ``2^e`` arcmin with ``largest / 2^e <= 32767`` (e in [-60, 60])."""
    if largest_arcmin == 0.0:
        return 2.0**-60
    exponent = max(-60, math.ceil(math.log2(largest_arcmin / _INT16_MAX)))
    if largest_arcmin / 2.0**exponent > _INT16_MAX:  # log2 rounding
        exponent += 1
    if exponent > 60:
        raise InputError(f"expected model errors that fit an int16 table, got {largest_arcmin:g} "
                         "arcmin; use dtype='float32'")
    return 2.0**exponent


def _check_bits(bits):
    if bits is None:
        raise InputError("expected the encoder resolution in bits (the model file does not "
                         "record it), got none; pass bits= (--bits on the command line)")
    return check_int(bits, "bits", "compile_table", low=1, high=MAX_TABLE_BITS,
                     note="the encoder resolution, or None for the model file's")


def save_table(table, path):
    """Write a table file, atomically.

    Layout (little-endian; offsets in bytes)::

        0   8   magic b"ENCALTAB"
        8   2   uint16  format version (1)
        10  1   uint8   bits B
        11  1   uint8   dtype: 1 = int16, 2 = float32
        12  4   uint32  header size (80): offset of the data
        16  4   uint32  number of entries, 2^B
        20  4   uint32  CRC-32 (zlib) of the data bytes
        24  8   float64 scale_arcmin: arc-minutes per stored unit
        32  8   float64 quantisation_arcmin
        40  8   float64 between_codes_arcmin
        48  32  SHA-256 of the model file (raw bytes; zeros if unknown)
        80      2^B values, int16 or float32; entry k is the error at code k

    The predicted error at code ``k`` is ``value[k] * scale_arcmin`` arcmin. A table of a model with
    ``reading_sign`` -1 (an encoder counting against its reference) is written as version 2, whose
    header is 88 bytes: the 80 above, then int8 ``reading_sign`` and 7 zero bytes; its corrected
    angle at code ``k`` is ``(-k * 360 / 2^B - value[k] * scale_arcmin / 60) mod 360``.

    Returns
    -------
    pathlib.Path
    """
    check_type(table, CorrectionTable, "table", "save_table", "a CorrectionTable")
    code, dtype = TABLE_DTYPES[table.dtype]
    data = np.ascontiguousarray(table.values, dtype=dtype).tobytes()
    sha = bytes.fromhex(table.model_sha256) if table.model_sha256 else bytes(32)
    reversed_ = table.reading_sign == -1
    size = _HEADER.size + (_SIGN_HEADER.size if reversed_ else 0)
    header = _HEADER.pack(TABLE_MAGIC, 2 if reversed_ else 1, table.bits, code, size,
                          table.values.size, zlib.crc32(data), table.scale_arcmin,
                          table.quantisation_arcmin, table.between_codes_arcmin, sha)
    if reversed_:
        header += _SIGN_HEADER.pack(-1)
    path = Path(path)
    atomic_write(path, header + data)
    return path


def load_table(path):
    """Read a table file written by :func:`save_table`.

    Raises
    ------
    ModelFileError
        If the file is not a complete, intact table file of a known version.
    """
    raw = Path(path).read_bytes()
    if len(raw) < _HEADER.size or raw[:8] != TABLE_MAGIC:
        raise ModelFileError(f"{path}: expected an encal table file (starting with "
                             f"{TABLE_MAGIC.decode()}), got {raw[:8]!r}")
    (_, version, bits, code, header_size, entries, crc, scale, quantisation, between,
     sha) = _HEADER.unpack_from(raw)
    if version > TABLE_VERSION:
        raise ModelFileError(f"{path}: the table has format version {version}, newer than "
                             f"version {TABLE_VERSION} that this encal reads; upgrade encal")
    dtypes = {c: (name, dt) for name, (c, dt) in TABLE_DTYPES.items()}
    if code not in dtypes or not 1 <= bits <= MAX_TABLE_BITS or entries != 2**bits:
        raise ModelFileError(f"{path}: expected a table header with 1 to {MAX_TABLE_BITS} bits, "
                             f"2^bits entries and dtype code 1 or 2, got {bits} bits, "
                             f"{entries} entries, dtype code {code}")
    dtype = dtypes[code][1]
    data = raw[header_size:]
    smallest = _HEADER.size + (_SIGN_HEADER.size if version >= 2 else 0)
    if header_size < smallest:
        raise ModelFileError(f"{path}: expected a header of at least {smallest} bytes for table format "
                             f"version {version}, got {header_size}; the file is damaged")
    if len(data) != entries * dtype.itemsize:
        raise ModelFileError(f"{path}: expected {entries * dtype.itemsize} bytes of table data, "
                             f"got {len(data)}; the file is truncated or damaged")
    if zlib.crc32(data) != crc:
        raise ModelFileError(f"{path}: the CRC-32 of the table data does not match its header, "
                             "so the file was damaged or altered")
    reading_sign = _SIGN_HEADER.unpack_from(raw, _HEADER.size)[0] if version >= 2 else 1
    if reading_sign not in (1, -1):
        raise ModelFileError(f"{path}: expected a reading sign of 1 or -1 in the version-{version} table "
                             f"header, got {reading_sign}")
    values = np.frombuffer(data, dtype=dtype).astype(dtype.newbyteorder("="))
    model_sha256 = sha.hex() if any(sha) else None
    try:
        return CorrectionTable(bits, values, scale, quantisation, between, model_sha256, reading_sign)
    except InputError as error:  # a header field out of range (the CRC-32 covers the data only)
        raise ModelFileError(f"{path}: the table header is damaged: {error}") from None

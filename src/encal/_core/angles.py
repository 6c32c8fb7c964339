"""Angles and units.

Conventions used throughout encal: angles in degrees, errors in arc-minutes,
``error = encoder - reference`` wrapped to (-180, 180] degrees.
"""

import numpy as np

from .parameters import check_int, invalid, real_array

__all__ = [
    "ARCMIN_PER_DEG",
    "wrap360",
    "wrap180",
    "angle_difference",
    "deg_to_arcmin",
    "arcmin_to_deg",
    "lsb_arcmin",
    "arcmin_to_lsb",
    "READING_SIGNS",
    "model_input",
    "resolution_of_readings",
    "ANGLE_UNITS",
    "AngleUnit",
    "angle_unit",
]

ARCMIN_PER_DEG = 60.0


def wrap360(angle_deg):
    """Wrap angles to [0, 360) degrees.

    Parameters
    ----------
    angle_deg : float or array-like
        Angles in degrees, any finite value.

    Returns
    -------
    float or ndarray
        The same angles in [0, 360).

    Examples
    --------
    >>> float(wrap360(-1.0))
    359.0
    >>> float(wrap360(720.5))
    0.5
    """
    angle = real_array(angle_deg, "angle_deg", "wrap360", "angles in degrees (real numbers)")
    if angle.size > 64:  # np.mod's value without its fmod (most of the time of a wrap), bit for bit
        low, high = angle.min(), angle.max()
        if 0.0 <= low and high < 360.0:
            return angle + 0.0  # (-0.0 becomes 0.0, as np.mod makes it)
        if -360.0 <= low and high < 720.0:
            # np.mod adds 360 to a negative remainder (rounding once) and subtracts it from one above
            # 360 (exactly); the sum can round to 360.0 exactly, which the product below makes 0.0
            wrapped = angle + 360.0 * ((angle < 0.0).view(np.int8) - (angle >= 360.0).view(np.int8))
            wrapped *= wrapped < 360.0
            return wrapped
        if -_EXACT_TURNS_DEG < low and high < _EXACT_TURNS_DEG:
            # angle - 360 k for the whole number of turns k is exact, and where np.mod adds 360 to a
            # negative remainder it rounds the same sum once; a quotient rounded up to a whole number
            # shows as a negative remainder
            turns = np.floor(angle / 360.0)
            wrapped = angle - 360.0 * turns
            turns -= wrapped < 0.0
            wrapped = angle - 360.0 * turns
        else:
            wrapped = np.mod(angle, 360.0)
    else:
        wrapped = np.mod(angle, 360.0)
    # np.mod(-1e-17, 360) rounds to 360.0 exactly; keep the half-open interval.
    return np.where(wrapped >= 360.0, 0.0, wrapped)[()]


#: Below this size, ``360 * turns`` and ``angle - 360 * turns`` are exact in binary64.
_EXACT_TURNS_DEG = 2.0**40


#: Orientations of an encoder relative to its reference: 1, it counts with the reference; -1, against it
#: (a calibration read with ``reverse=True``). A model records it as ``reading_sign``.
READING_SIGNS = (1, -1)


def model_input(theta_enc_deg, reading_sign=1):
    """The angle at which a model is evaluated for an encoder reading: ``(reading_sign * theta) mod 360``.

    A model of an encoder that counts against its reference was fitted on negated readings, so every
    consumer of raw readings maps them with this first. The map is its own inverse: applied to model
    inputs it gives back the readings (mod 360).

    Parameters
    ----------
    theta_enc_deg : float or array-like
        Encoder readings in degrees.
    reading_sign : {1, -1}, default=1
        The model's ``reading_sign``.

    Returns
    -------
    float or ndarray
        Degrees in [0, 360), same shape.

    Examples
    --------
    >>> float(model_input(10.0, -1)), float(model_input(10.0))
    (350.0, 10.0)
    """
    return wrap360(reading_sign * np.asarray(theta_enc_deg, dtype=float))


def wrap180(angle_deg):
    """Wrap angles to (-180, 180] degrees.

    Examples
    --------
    >>> float(wrap180(190.0))
    -170.0
    >>> float(wrap180(-180.0))
    180.0
    """
    shifted = -real_array(angle_deg, "angle_deg", "wrap180", "angles in degrees (real numbers)") + 180.0
    if shifted.size > 64 and -360.0 <= shifted.min() and shifted.max() < 720.0:
        # np.mod's value without its fmod (a fifth of the time), bit for bit: it adds 360 to a negative
        # remainder (rounding once, perhaps to 360.0 exactly, which it keeps) and subtracts 360 from a value
        # in [360, 720) exactly
        shifted += 360.0 * ((shifted < 0.0).view(np.int8) - (shifted >= 360.0).view(np.int8))
        return -shifted + 180.0
    wrapped = -np.mod(shifted, 360.0) + 180.0
    return wrapped[()]


def angle_difference(a_deg, b_deg):
    """Signed difference ``a - b`` wrapped to (-180, 180] degrees."""
    a = real_array(a_deg, "a_deg", "angle_difference", "angles in degrees (real numbers)")
    b = real_array(b_deg, "b_deg", "angle_difference", "angles in degrees (real numbers)")
    try:
        np.broadcast_shapes(a.shape, b.shape)
    except ValueError:
        raise invalid("b_deg", "angle_difference", f"one angle or angles of a shape that broadcasts with a_deg's "
                      f"{a.shape}", b_deg, shown=f"the shape {b.shape}") from None
    return wrap180(a - b)


def deg_to_arcmin(angle_deg):
    """Degrees to arc-minutes."""
    return np.asarray(angle_deg, dtype=float)[()] * ARCMIN_PER_DEG


def arcmin_to_deg(angle_arcmin):
    """Arc-minutes to degrees."""
    return np.asarray(angle_arcmin, dtype=float)[()] / ARCMIN_PER_DEG


def lsb_arcmin(bits):
    """Size of one least significant bit of a ``bits``-bit encoder, in arc-minutes.

    Examples
    --------
    >>> round(lsb_arcmin(16), 4)
    0.3296
    """
    return 21600.0 / 2.0 ** check_int(bits, "bits", "lsb_arcmin", low=1, high=64, note="the encoder resolution")


def arcmin_to_lsb(angle_arcmin, bits):
    """Arc-minutes to LSB of a ``bits``-bit encoder."""
    return np.asarray(angle_arcmin, dtype=float)[()] / lsb_arcmin(bits)


def resolution_of_readings(angles_deg, *, min_bits=8, max_bits=24, tolerance_counts=1e-3):
    """Resolution of an encoder whose readings are whole codes, or None.

    Parameters
    ----------
    angles_deg : array-like
        Encoder readings in degrees.
    min_bits, max_bits : int, default=8, 24
        Resolutions considered.
    tolerance_counts : float, default=1e-3
        Largest distance of a reading from a multiple of ``360 / 2**bits``, in codes
        (readings written with a few decimals are not exact multiples).

    Returns
    -------
    int or None
        The smallest ``bits`` for which every reading is within ``tolerance_counts`` of a
        multiple of ``360 / 2**bits`` degrees; None when there is none.

    Examples
    --------
    >>> resolution_of_readings(np.arange(0, 16384, 80) * (360 / 2**14))
    10
    >>> resolution_of_readings([0.5, 1.0, 100.123]) is None
    True
    """
    angles = np.asarray(angles_deg, dtype=float).reshape(-1)
    if angles.size == 0 or not np.all(np.isfinite(angles)):
        return None

    def whole(values, bits):
        counts = values * (2**bits / 360.0)
        return bool(np.all(np.abs(counts - np.round(counts)) < tolerance_counts))

    # a resolution the first readings refuse is refused without a pass over the rest (nor a wrap of them all)
    head = np.mod(angles[:1024], 360.0)
    candidates = [bits for bits in range(min_bits, max_bits + 1) if whole(head, bits)]
    if candidates:
        angles = wrap360(angles)  # np.mod's values
    for bits in candidates:
        if whole(angles, bits):
            return bits
    return None


#: Units a calibration column may be in: degrees, radians, revolutions (turns), or counts of a B-bit encoder.
ANGLE_UNITS = ("deg", "rad", "rev", "counts:B")


class AngleUnit:
    """A unit of angle readings: ``'deg'``, ``'rad'``, ``'rev'`` or ``'counts:B'`` (codes of a B-bit encoder).

    Attributes
    ----------
    name : str
        ``'deg'``, ``'rad'``, ``'rev'`` or ``'counts'``.
    bits : int or None
        Resolution of ``'counts'``.
    degrees_per_unit : float
        Degrees in one unit (360 / 2^B for counts).

    Examples
    --------
    >>> unit = angle_unit("counts:14")
    >>> unit.bits, float(unit.to_degrees(4096))
    (14, 90.0)
    >>> float(angle_unit("rev").to_degrees(0.25)), str(angle_unit("rad"))
    (90.0, 'rad')
    """

    def __init__(self, name, bits=None):
        self.name = name
        self.bits = bits
        self.degrees_per_unit = {"deg": 1.0, "rad": 180.0 / np.pi, "rev": 360.0}.get(name) or 360.0 / 2.0**bits

    def to_degrees(self, values):
        """Readings in this unit as degrees."""
        return (np.asarray(values, dtype=float) * self.degrees_per_unit)[()]

    def __str__(self):
        return self.name if self.bits is None else f"{self.name}:{self.bits}"

    def __eq__(self, other):
        return isinstance(other, AngleUnit) and (self.name, self.bits) == (other.name, other.bits)

    def __hash__(self):
        return hash((self.name, self.bits))


def angle_unit(text):
    """Parse a unit of angle readings (see :class:`AngleUnit`).

    Parameters
    ----------
    text : str or AngleUnit
        ``'deg'`` (also ``'degrees'``), ``'rad'`` (``'radians'``), ``'rev'`` (``'turns'``,
        ``'revolutions'``) or ``'counts:B'`` with B a whole number of bits from 1 to 32.

    Returns
    -------
    AngleUnit

    Raises
    ------
    ValueError
        Naming what was expected.
    """
    if isinstance(text, AngleUnit):
        return text
    word = str(text).strip().lower()
    aliases = {"deg": "deg", "degree": "deg", "degrees": "deg", "rad": "rad", "radian": "rad", "radians": "rad",
               "rev": "rev", "revs": "rev", "revolution": "rev", "revolutions": "rev", "turn": "rev", "turns": "rev"}
    if word in aliases:
        return AngleUnit(aliases[word])
    name, _, bits = word.partition(":")
    if name in ("counts", "count", "codes", "code") and bits.isascii() and bits.isdigit() and 1 <= int(bits) <= 32:
        return AngleUnit("counts", int(bits))
    raise ValueError(f"the unit {str(text)!r} is not one of deg, rad, rev or counts:B (B the encoder's bits, "
                     "1 to 32, e.g. counts:14)")

"""Klipper ``[angle]``: the ``calibrate:`` list, one sensor angle per full step of the stepper.

Format (``klippy/extras/angle.py`` of github.com/Klipper3d/klipper, ``AngleCalibration``):
``calibrate:`` holds, for every full step ``i`` of one turn, the sensor's angle in 16-bit units
(65536 per turn) measured there, written ``%.1f``, eight to a line. Klipper turns it into 64
buckets (``CALIBRATION_BITS`` = 6) by least squares (``load_calibration``) and, at run time,
interpolates in integers (``apply_calibration``): ``bucket = (a & 0xffff) >> 10``,
``adj = cal[bucket] + (((a & 0x3ff) * (cal[bucket + 1] - cal[bucket]) + 512) >> 10)``; the
corrected angle is ``a + ((adj - a) & 0xffff)`` as a signed 16-bit difference, negated when the
list runs backwards. Its zero is the lowest angle's step, so corrected angles carry an
arbitrary constant; round trips are compared after removing it.

encal writes the angle the sensor reads at each full step ``i * 360 / steps`` of the
reference (the model inverted), and reads a list back as a calibration.
"""

import numpy as np

from ...calibration import Calibration
from ...errors import InputError
from ...parameters import check_int
from ._common import FirmwareExport, compensator, read_text, round_trip

__all__ = ["export_klipper", "read_klipper", "klipper_load", "klipper_apply"]

ANGLE_BITS = 16
CALIBRATION_BITS = 6


def klipper_load(angles):
    """Klipper's ``load_calibration``: the 65 bucket values (and whether the list runs backwards)."""
    angle_max = 1 << ANGLE_BITS
    count = 1 << CALIBRATION_BITS
    bucket_size = angle_max // count
    angles = [float(a) for a in angles]
    full_steps = len(angles)
    nominal_step = float(angle_max) / full_steps
    reversed_ = angles[-2] > angles[-1]
    if reversed_:
        angles = list(reversed(angles))
    first = angles.index(min(angles))
    angles = angles[first:] + angles[:first]
    eqs = np.zeros((full_steps, count))
    ans = np.zeros(full_steps)
    for step, angle in enumerate(angles):
        int_angle = int(angle + .5) % angle_max
        bucket = int(int_angle / bucket_size)
        fraction = (angle - bucket * bucket_size) / bucket_size
        eqs[step, bucket] = 1.0 - fraction
        eqs[step, (bucket + 1) % count] = fraction
        ans[step] = float(step * nominal_step)
        if bucket + 1 >= count:
            ans[step] -= fraction * angle_max
    solution = np.linalg.lstsq(eqs, ans, rcond=None)[0]
    table = [int(s + .5) for s in solution]
    return table + [table[0] + angle_max], reversed_


def klipper_apply(calibration, reversed_, angle):
    """Klipper's ``apply_calibration`` for 16-bit sensor angles (integers)."""
    calibration = np.asarray(calibration, dtype=np.int64)
    angle = np.asarray(angle, dtype=np.int64)
    interp_bits = ANGLE_BITS - CALIBRATION_BITS
    bucket = (angle & 0xffff) >> interp_bits
    cal1 = calibration[bucket]
    cal2 = calibration[bucket + 1]
    adj = (angle & ((1 << interp_bits) - 1)) * (cal2 - cal1)
    adj = cal1 + ((adj + (1 << (interp_bits - 1))) >> interp_bits)
    diff = (adj - angle) & 0xffff
    diff -= (diff & 0x8000) << 1
    new = angle + diff
    return -new if reversed_ else new


def export_klipper(model, *, full_steps=200):
    """The ``calibrate:`` option of Klipper's ``[angle]`` section for a stepper of ``full_steps`` per turn."""
    full_steps = check_int(full_steps, "full_steps", "export_klipper", low=8, high=4096, note="full steps per turn")
    comp = compensator(model)
    reference = np.arange(full_steps) * (360.0 / full_steps)
    sign = comp.reading_sign
    reading = sign * reference % 360.0
    for _ in range(50):  # the reading whose corrected angle is the step: theta = sign * (ref + error / 60)
        reading = (sign * (reference + np.asarray(comp.predict(reading)) / 60.0)) % 360.0
    units = reading * (2**ANGLE_BITS / 360.0)
    written = np.round(units, 1) % 2**ANGLE_BITS
    table, reversed_ = klipper_load(written)
    angles = np.arange(2**ANGLE_BITS)
    corrected = klipper_apply(table, reversed_, angles) * (360.0 / 2**ANGLE_BITS)
    expected = np.asarray(comp.correct(angles * (360.0 / 2**ANGLE_BITS)))
    gap = (corrected - expected + 180.0) % 360.0 - 180.0
    gap -= np.degrees(np.arctan2(np.mean(np.sin(np.radians(gap))), np.mean(np.cos(np.radians(gap)))))
    max_error, rms_error = round_trip(gap * 60.0, 0.0)
    items = [f"{v:.1f}" for v in written]
    lines = [", ".join(items[i:i + 8]) for i in range(0, full_steps, 8)]
    text = "calibrate:\n" + ",\n".join(f"    {line}" for line in lines) + "\n"
    note = (f"paste into the [angle] section; Klipper keeps {1 << CALIBRATION_BITS} buckets, "
            "so detail finer than 5.6 degrees is lost")
    return FirmwareExport("klipper", text, max_error, rms_error, 0.05 * 21600.0 / 2**ANGLE_BITS,
                          2**ANGLE_BITS, note)


def read_klipper(source_text, *, name=None):
    """A Klipper ``calibrate:`` list (the option's value, or a config section holding it) as a calibration.

    Returns
    -------
    Calibration
        ``reference_deg = i * 360 / steps`` (its zero is the first step's), ``encoder_deg`` the
        sensor angle at step ``i``.
    """
    text, where = read_text(source_text)
    lines = text.splitlines()
    start = next((i for i, line in enumerate(lines) if line.strip().lower().startswith("calibrate")), None)
    if start is None:
        body = [(i + 1, line) for i, line in enumerate(lines)]
    else:
        first = lines[start].split(":", 1)[1] if ":" in lines[start] else lines[start].split("=", 1)[-1]
        body = [(start + 1, first)]
        for i in range(start + 1, len(lines)):
            if lines[i] and not lines[i][0].isspace():
                break
            body.append((i + 1, lines[i]))
    values = []
    for number, line in body:
        for item in line.split(","):
            item = item.strip()
            if not item or item.startswith("#"):
                continue
            try:
                values.append(float(item))
            except ValueError:
                raise InputError(f"{where}, line {number}: expected a number in the calibrate list, "
                                 f"got {item!r}") from None
    if len(values) < 8:
        raise InputError(f"{where}: expected a calibrate list of one angle per full step (8 or more), "
                         f"got {len(values)}")
    values = np.asarray(values)
    steps = values.size
    return Calibration(np.arange(steps) * (360.0 / steps), values * (360.0 / 2**ANGLE_BITS),
                       name=name or where, metadata={"format": "Klipper angle calibrate", "full_steps": steps})

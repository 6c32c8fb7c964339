"""Klipper ``[angle]``: the ``calibrate:`` list, one sensor angle per full step of the stepper.

Format (``klippy/extras/angle.py`` of github.com/Klipper3d/klipper, ``AngleCalibration``; read at
commit 84104bbb of 2026-08-07): ``calibrate:`` holds, for every full step ``i`` of one turn, the
sensor's angle in 16-bit units (65536 per turn) measured there, written ``%.1f``, eight to a line.
Klipper turns it into 64 buckets (``CALIBRATION_BITS`` = 6) by least squares (``load_calibration``)
and, at run time, interpolates in integers (``apply_calibration``): ``bucket = (a & 0xffff) >> 10``,
``adj = cal[bucket] + (((a & 0x3ff) * (cal[bucket + 1] - cal[bucket]) + 512) >> 10)``; the
corrected angle is ``a + ((adj - a) & 0xffff)`` as a signed 16-bit difference, negated when the
list runs backwards (``angles[-2] > angles[-1]``). Its zero is the lowest angle's step, and
``angle_phase_offset = (index(min) & 3) * 65536 / steps`` adds back that step's driver phase: the
list index is the stepper's full step counted from a step at driver phase 0, in the stepper's
positive direction (``ANGLE_CALIBRATE`` starts its sweep at phase 0 and rotates the list by a
multiple of 4 to start at the lowest angle, or the highest for a reversed sensor).

The index counts full steps in the stepper's positive direction as Klipper counts it: its mcu position
(``klippy/stepper.py``, negated from the MCU's count when ``dir_pin`` is inverted; ``ANGLE_CALIBRATE`` samples
with positive moves), the driver phase following it (``klippy/extras/tmc.py`` ``_handle_sync_mcu_pos``). A
sensor counting against that direction is Klipper's to handle (the reversed list, its angle negated); which
way the stepper turns the *reference* only the user knows. encal writes the angle the sensor reads at each
full step ``step_zero + d * i * 360 / steps`` of the reference (the model inverted), with ``step_zero`` the
reference angle of a full step at driver phase 0 and ``d`` the step direction, 1 when the stepper's positive
steps raise the reference angle, -1 when they lower it; it rotates the list as ``ANGLE_CALIBRATE`` does.
It reads back a list, a config section holding one, or the ``#*#`` ``SAVE_CONFIG`` block of a
``printer.cfg``, as a calibration.
"""

import re

import numpy as np

from ..._core.angles import wrap180
from ...data.calibration import Calibration
from ..._core.errors import InputError
from ..._core.number_cells import not_plain_note, read_number
from ._common import FirmwareExport, checked, compensator, correction_on_codes, grid_bits, read_text, round_trip
from ._stepper import check_full_steps, check_step_direction, check_step_zero, wrap_period

__all__ = ["export_klipper", "read_klipper", "klipper_load", "klipper_apply", "klipper_phase_offset"]

ANGLE_BITS = 16
CALIBRATION_BITS = 6
# ConfigAutoSave's header line (klippy/configfile.py AUTOSAVE_HEADER) and the prefix of every line below it.
AUTOSAVE_MARK = "#*# <---------------------- SAVE_CONFIG ---------------------->"
AUTOSAVE_PREFIX = "#*#"


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


def klipper_phase_offset(angles):
    """Klipper's ``angle_phase_offset`` (16-bit units): the driver phase of the list's lowest angle."""
    angles = [float(a) for a in angles]
    return (angles.index(min(angles)) & 3) * float(1 << ANGLE_BITS) / len(angles)


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


def step_readings(comp, reference_deg):
    """The reading (degrees) at which ``comp`` corrects to each reference angle: the model inverted."""
    sign = comp.reading_sign
    reading = sign * np.asarray(reference_deg, dtype=float) % 360.0
    for _ in range(50):  # the reading whose corrected angle is the step: theta = sign * (ref + error / 60)
        reading = (sign * (reference_deg + np.asarray(comp.predict(reading)) / 60.0)) % 360.0
    miss = np.abs(wrap180(np.asarray(comp.correct(reading)) - reference_deg))
    if np.max(miss) > 1e-6:
        raise InputError(f"expected a model whose corrected angle rises with the reading (it can be inverted at each "
                         f"full step), got one that misses a step by {np.max(miss) * 60:.3g} arcmin after 50 "
                         "iterations; no file was written")
    return reading


def export_klipper(model, *, full_steps=200, step_zero_deg=None, step_direction=None, bits=None):
    """The ``calibrate:`` option of Klipper's ``[angle]`` section for a stepper of ``full_steps`` per turn.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
    full_steps : int, default=200
        Full steps per turn, a multiple of 4.
    step_zero_deg : float
        The reference angle, degrees, of a full step at driver phase 0 (electrical zero); the list's
        index 0 is that step. Required: Klipper reads the driver phase from the index.
    step_direction : {1, -1}
        Which way the stepper's positive full steps (Klipper's mcu position rising: a positive
        ``FORCE_MOVE``, ``dir_pin`` inversion included) turn the reference: 1 raise its angle, -1 lower it.
        Required: the calibration does not say which way the stepper turned, and the wrong one gives a list
        two full steps out of phase.
        The list's index ``i`` is the full step at reference angle ``step_zero_deg + step_direction * i *
        360 / full_steps``.
    bits : int, optional
        The sensor's resolution (default the model file's, else 16): the round trip is measured on its
        codes as Klipper sees them (16-bit angles).

    Returns
    -------
    FirmwareExport
        Its round trip is Klipper's own rule (``load_calibration``, ``apply_calibration`` plus
        ``angle_phase_offset``) against the stepper's angle the model gives, ``step_direction`` times its
        corrected angle from ``step_zero_deg``, modulo the 4 full steps of the driver's electrical cycle
        (what Klipper aligns with the driver's phase).

    Raises
    ------
    InputError
        Without ``step_zero_deg`` or ``step_direction``, or when that round trip is not far smaller than the correction
        (:func:`~encal.deploy.firmware._common.checked`).
    """
    full_steps = check_full_steps(full_steps, "export_klipper")
    comp = compensator(model)
    step_zero = check_step_zero(step_zero_deg, "Klipper", "export_klipper")
    direction = check_step_direction(step_direction, "export_klipper")
    grid = min(grid_bits(comp, bits, "export_klipper"), ANGLE_BITS)
    angle_max = 1 << ANGLE_BITS
    step_deg = 360.0 / full_steps
    reference = step_zero + direction * np.arange(full_steps) * step_deg
    units = step_readings(comp, reference) * (angle_max / 360.0)
    written = np.round(units, 1) % angle_max
    # load_calibration rounds int(angle + .5) % 65536: an angle within half a unit of 65536 falls in bucket 0
    # with a fraction of 64; written just below 0 it is extrapolated from bucket 0, the same straight line.
    written = np.where(written >= angle_max - 0.5, written - angle_max, written)
    # ANGLE_CALIBRATE's order: by a multiple of 4 (the driver phase stays the index & 3) to start at the
    # lowest angle (the highest for a sensor counting against the stepper), so that Klipper's reverse test
    # angles[-2] > angles[-1] never straddles the sensor's wrap.
    against = comp.reading_sign * direction == -1  # the sensor counts down as the stepper steps up
    extreme = int(np.argmax(written) if against else np.argmin(written))
    first = extreme & ~3
    written = np.concatenate([written[first:], written[:first]])
    angles = [float(f"{v:.1f}") for v in written]
    table, reversed_ = klipper_load(angles)
    if reversed_ != against:
        raise InputError(f"expected a list Klipper reads in the sensor's direction, got one whose last two angles "
                         f"({angles[-2]:.1f}, {angles[-1]:.1f}) say {'reversed' if reversed_ else 'forward'}: the "
                         "model's error is too steep between full steps; no file was written")
    codes = np.arange(2**grid, dtype=np.int64) << (ANGLE_BITS - grid)
    position = (klipper_apply(table, reversed_, codes) + klipper_phase_offset(angles)) * (360.0 / angle_max)
    expected = direction * (np.asarray(comp.correct(codes * (360.0 / angle_max))) - step_zero)
    gap = wrap_period(position - expected, 4 * step_deg) * 60.0
    max_error, rms_error = round_trip(gap, 0.0)
    items = [f"{v:.1f}" for v in angles]
    lines = [", ".join(items[i:i + 8]) for i in range(0, full_steps, 8)]
    text = ("calibrate:\n" + ",\n".join(f"    {line}" for line in lines) + "\n")
    note = (f"paste into the [angle] section (index 0 is a full step at driver phase 0, the reference's "
            f"{step_zero:g} deg, and the stepper's positive steps {'raise' if direction == 1 else 'lower'} the "
            f"reference angle: --step-direction {direction}); Klipper keeps {1 << CALIBRATION_BITS} buckets, so "
            "detail finer than 5.6 degrees is lost")
    correction = correction_on_codes(comp, grid)
    # The rounding a priori, in 16-bit units: the list's "%.1f" (0.05), load_calibration's int(s + .5) of each
    # bucket (0.5) and apply_calibration's integer result (0.5). Only the first counted before: a profile whose
    # shape is a few LSB (a constant offset: none) was refused for Klipper's own 0.1-arcmin rounding.
    rounding = (0.05 + 0.5 + 0.5) * 21600.0 / angle_max
    export = FirmwareExport("klipper", text, max_error, rms_error, rounding, codes.size, note)
    return checked(export, correction - np.mean(correction))


def read_klipper(source_text, *, name=None):
    """A Klipper ``calibrate`` list as a calibration.

    Reads the ``#*#`` ``SAVE_CONFIG`` block of a ``printer.cfg`` (what ``ANGLE_CALIBRATE`` and
    ``SAVE_CONFIG`` write), an ``[angle ...]`` section holding ``calibrate``, the option alone
    (``calibrate:`` then its lines), or a bare comma-separated list. Where both the regular config and
    the ``SAVE_CONFIG`` block set it, the regular config's value is read, as Klipper does.

    Returns
    -------
    Calibration
        ``reference_deg = i * 360 / steps``: the list index is the stepper's full step from one at driver
        phase 0, in its positive direction, so a model fitted to it is exported back with ``step_zero_deg=0``
        (and ``step_direction=1``). ``encoder_deg`` the
        sensor angle at step ``i``; for a list Klipper reads as reversed (``angles[-2] > angles[-1]``),
        ``reading_sign`` -1 and the negated angles (as :func:`~encal.read_calibration` with ``reverse``).

    Raises
    ------
    InputError
        Naming the file and line: an item that is not a finite number, two numbers without a comma
        between them, several ``[angle]`` sections with a list, fewer than 8 angles, or a list Klipper
        would read as reversed though it increases (or the other way round).
    """
    text, where = read_text(source_text)
    lines = text.replace("\r\n", "\n").split("\n")
    section, found = _calibrate_option(lines, where)
    values, unfinished = [], None  # unfinished: the line of a last number not followed by a comma
    for number, fragment in found:
        if not fragment.strip():
            continue
        items = fragment.split(",")
        if unfinished is not None and items[0].strip():
            raise InputError(f"{where}, line {number}: expected a comma after the last angle of line {unfinished}, "
                             "got a line break; Klipper would not read this list")
        values.extend(_numbers(fragment, where, number))
        unfinished = number if items[-1].strip() else None
    if len(values) < 8:
        raise InputError(f"{where}: expected a calibrate list of one angle per full step (8 or more), "
                         f"got {len(values)}")
    values = np.asarray(values)
    steps = values.size
    rises = float(np.sum(wrap180(np.diff(values, append=values[:1]) * (360.0 / 2**ANGLE_BITS))))
    reversed_ = bool(values[-2] > values[-1])
    if abs(abs(rises) - 360.0) > 1.0 or (rises < 0) != reversed_:
        raise InputError(f"{where}: expected the list of one turn that Klipper reads in its direction, got one that "
                         f"goes {rises:+.4g} degrees over its {steps} steps while its last two angles "
                         f"({values[-2]:g}, {values[-1]:g}) make Klipper read it as "
                         f"{'reversed' if reversed_ else 'forward'}; rotate it to start at its lowest angle "
                         "(its highest for a reversed sensor), as ANGLE_CALIBRATE does")
    sign = -1 if reversed_ else 1
    metadata = {"format": "Klipper angle calibrate", "full_steps": steps, "step_zero_deg": 0.0}
    if section:
        metadata["section"] = section
    return Calibration(np.arange(steps) * (360.0 / steps), sign * values * (360.0 / 2**ANGLE_BITS),
                       name=name or where, metadata=metadata, reading_sign=sign)


def _numbers(fragment, where, number):
    values = []
    for item in fragment.split(","):
        item = item.strip()
        if not item:
            continue
        try:
            value = read_number(item)
        except ValueError:
            raise InputError(f"{where}, line {number}: expected a number in the calibrate list, "
                             f"got {item[:40]!r}{not_plain_note(item)}") from None
        if not np.isfinite(value):
            raise InputError(f"{where}, line {number}: expected a finite angle in the calibrate list, "
                             f"got {item[:40]!r}")
        values.append(value)
    return values


def _strip_comment(line):
    # Klipper's reader cuts every line at its first '#' (ConfigFileReader), then configparser at ' ;'
    line = line.split("#", 1)[0]
    return re.split(r"\s;", line, maxsplit=1)[0]


def _calibrate_option(lines, where):
    """(section name, [(line number, text)]) of the ``calibrate`` value Klipper would read."""
    autosave_at = next((i for i, line in enumerate(lines) if line.rstrip() == AUTOSAVE_MARK), None)
    regular = [(i + 1, line) for i, line in enumerate(lines[:autosave_at])]
    autosave = []
    if autosave_at is not None:
        for i in range(autosave_at + 1, len(lines)):
            line = lines[i]
            if not line.strip():
                continue
            if not line.startswith(AUTOSAVE_PREFIX) or (len(line) >= 4 and not line.startswith("#*# ")):
                raise InputError(f"{where}, line {i + 1}: expected every line of the SAVE_CONFIG block to start with "
                                 f"'#*# ', got {line[:40]!r}; Klipper ignores a block modified after its header")
            autosave.append((i + 1, line[4:]))
    found = []
    for part in (regular, autosave):
        options = _options(part)
        lists = [(section, body) for (section, option), body in options.items()
                 if option == "calibrate" and (section is None or section.split()[0].lower() == "angle")]
        named = [item for item in lists if item[0] is not None]
        if len(named) > 1:
            raise InputError(f"{where}: expected one [angle] section with a calibrate list, got "
                             f"{len(named)} ({', '.join('[' + s + ']' for s, _ in named)}); copy the one wanted "
                             "into a file of its own")
        found.append(named[0] if named else (lists[0] if lists else None))
    if found[0] is not None:
        return found[0]
    if found[1] is not None:
        return found[1]
    if any(re.match(r"\s*\[", line) or re.match(r"\s*[A-Za-z_]\w*\s*[:=]", line) for line in lines):
        included = any(re.match(r"\s*\[include\s", line) for line in lines)
        raise InputError(f"{where}: expected a 'calibrate' option in an [angle] section (or its SAVE_CONFIG "
                         "block), found none" + ("; [include] files are not followed: pass the file that holds it"
                                                 if included else ""))
    return None, [(i + 1, _strip_comment(line)) for i, line in enumerate(lines)]


def _options(numbered_lines):
    """{(section or None, option): [(line number, value text)]} of configparser-style lines."""
    options = {}
    section, current = None, None
    for number, raw in numbered_lines:
        line = _strip_comment(raw)
        if not line.strip():
            continue
        if line[0].isspace():
            if current is not None:
                current.append((number, line))
            continue
        header = re.match(r"\[([^\]]+)\]", line)
        if header:
            section, current = header.group(1).strip(), None
            continue
        option = re.match(r"([^:=\s][^:=]*?)\s*[:=](.*)", line)
        if option is None:
            current = None
            continue
        current = [(number, option.group(2))]
        options[(section, option.group(1).strip().lower())] = current
    return options

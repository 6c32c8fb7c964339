"""Mechaduino's own rules applied to encal's ``lookup[16384]``: a faithful model of its calibration and commutation.

The Mechaduino firmware (github.com/jcchurch13/Mechaduino-Firmware, commit
ca2835c9ae009957eb33f2cca6974e6c06d2fef5 of 2018-11-26, firmware "0.1.5") is not beside this repository
(shared/firmware/README.md), and its code needs the SAMD21 (SPI, flash, timers), so this harness models, line
by line, the parts that decide what the table means (file and line numbers of that commit, under
``Mechaduino/Mechaduino/``):

- ``Parameters.cpp`` 36-41: ``spr = 200``, ``aps = 360.0 / spr`` (float), ``cpr = 16384``, ``PA = aps``; 51-54:
  the sine table ``sin_1[a] = %+6.0f of sin(a * 3.1415 / 180 / 10) * 1024``, ``a`` in 0..3600;
- ``Utils.cpp`` 90-110 ``output(theta, effort)``: ``phase_multiplier = 10 * spr / 4``,
  ``angle_1 = mod(phase_multiplier * theta, 3600)``, ``angle_2 = mod(phase_multiplier * theta + 900, 3600)``
  (float products passed to ``int mod(int, int)``: truncated), ``v_coil_A = effort * sin_1[angle_1] / 1024``,
  ``v_coil_B = effort * sin_1[angle_2] / 1024`` (the coils' currents, signs by the H-bridge pins);
- ``Utils.cpp`` 568-580 ``oneStep()``: ``dir`` true decrements ``stepNumber``, then ``output(aps * stepNumber)``;
  716-718 ``mod``;
- ``Utils.cpp`` 178-376 ``calibrate()``: the "Wired backwards" check (196-205; the user swaps a phase, as
  its message says, and a false message near the encoder's rollover is answered by stepping away, as its
  comment says), going to step zero (207-217), one averaged reading per full step (219-259), the start of
  the table at count 0 (265-300) and the interpolated angles stored from ``lookup[0]`` on (315-365,
  ``store_lookup`` 162-175), each ``0.001 * mod(1000 * angle, 360000.0)``;
- ``Controller.cpp`` 19 ``y = lookup[readEncoder()]``, 71-90 ``y += PA`` (or ``-=``), ``output(-y, U)``.

The motor: a two-phase hybrid stepper of 50 pole pairs whose rotor settles where its electrical angle equals
the coils' field angle ``atan2(i_A, i_B)`` (``output(0)`` energises coil B alone: electrical zero, full step 0)
and whose torque towards increasing field angle is ``i_A cos(e) - i_B sin(e)`` at rotor electrical angle ``e``;
``wiring`` +1 or -1 is which way a rising field angle turns it in the reference's sense. The encoder is the
model's: the count at reference angle ``theta`` is the reading the model corrects to ``theta``.

Each row: encal writes ``lookup[]`` (``export_mechaduino``); the firmware's rule ``y = lookup[count]`` is
compared with the rotor's angle from full step 0 in the direction the firmware's own calibration counts
(after its "Wired backwards" check), on every count (the row's measured RMS / max); the commutation
``output(-(y ± PA))`` is applied at every count and the torque factor (the torque over the largest the
coils' current can give, in the commanded direction) is the smallest over counts and both signs of ``u``.
The firmware's own ``calibrate()`` is run on the same motor and encoder, and its table's frame (its RMS
difference from the rotor's angle) is checked against the one encal writes to.
"""

import math
from dataclasses import dataclass

import numpy as np

from . import Row

SPR = 200
CPR = 16384
APS = np.float32(360.0) / np.float32(SPR)  # Parameters.cpp 37: const float aps = 360.0/ spr
PA = APS  # Parameters.cpp 41
PHASE_MULTIPLIER = 10 * SPR // 4  # Utils.cpp 98 (int)
POLE_PAIRS = SPR // 4
ZEROS_DEG = (0.0, 0.45, 0.9, 1.8, 2.5, 3.6, 7.2, 30.0)
U_MAX = int((255 / 3.3) * (1.0 * 10 * 0.150))  # Parameters.cpp 43-45

__all__ = ["unavailable", "matrix", "cases", "Case", "calibrate", "Motor", "torque_factor", "run_case",
           "firmware_calibration", "read_lookup"]


def unavailable():
    return None  # a model written here from the firmware's source: nothing to compile or import


def _sin_table():
    # Parameters.cpp 51-54: perl printf "%+6.0f" of sin($a * 3.1415 / 180 / 10.0) * 1024, $a in 0..3600
    return np.array([float(f"{math.sin(a * 3.1415 / 180 / 10.0) * 1024:+6.0f}") for a in range(3601)], dtype=np.int64)


SIN_1 = _sin_table()


def c_mod(x, m):
    """Utils.cpp 716: ``int mod(int xMod, int mMod)`` of float arguments (converted to int: truncated)."""
    x = np.trunc(np.asarray(x, dtype=np.float64)).astype(np.int64)
    return (np.fmod(x, m) + m) % m  # C's % keeps the dividend's sign; the firmware's + m, % m makes it [0, m)


def c_div(a, b):
    """C integer division (truncates towards zero)."""
    a = np.asarray(a, dtype=np.int64)
    return np.where(a >= 0, a // b, -((-a) // b))


def output(theta, effort):
    """Utils.cpp 90-110: the coils' currents ``(v_coil_A, v_coil_B)`` for ``output(theta, effort)``."""
    product = np.float32(PHASE_MULTIPLIER) * np.asarray(theta, dtype=np.float32)
    angle_1 = c_mod(product, 3600)
    angle_2 = c_mod(product + np.float32(900), 3600)
    return c_div(effort * SIN_1[angle_1], 1024), c_div(effort * SIN_1[angle_2], 1024)


class Motor:
    """A stepper and the model's encoder (see the module's description)."""

    def __init__(self, comp, step_zero_deg, wiring):
        self.comp, self.step_zero, self.wiring = comp, float(step_zero_deg), int(wiring)
        self.electrical = 0.0  # degrees, continuous; the rotor starts at full step 0
        self.step_number = 0
        # calibrate() holds the rotor at full steps only (electrical angles 90 k): their counts, computed at once
        steps = np.arange(-4 * SPR, 4 * SPR + 1)
        counts = np.floor(reading_deg(comp, self.step_zero + self.wiring * steps * 90.0 / POLE_PAIRS) * CPR / 360.0)
        self._counts = dict(zip(steps.tolist(), (counts.astype(np.int64) % CPR).tolist()))

    @property
    def theta(self):
        """The rotor's reference angle, degrees."""
        return self.step_zero + self.wiring * self.electrical / POLE_PAIRS

    def settle(self, current_a, current_b):
        field = math.degrees(math.atan2(current_a, current_b))
        self.electrical += (field - self.electrical + 180.0) % 360.0 - 180.0

    def read_encoder(self):
        """``readEncoder()``: the 14-bit count at the rotor's angle (the model inverted)."""
        step = round(self.electrical / 90.0)
        if abs(self.electrical - 90.0 * step) < 1e-9 and step in self._counts:
            return self._counts[step]
        return int(np.floor(reading_deg(self.comp, self.theta) * CPR / 360.0)) % CPR

    def one_step(self, direction):
        """Utils.cpp 568-580 ``oneStep()``."""
        self.step_number += -1 if direction else 1
        self.settle(*output(APS * np.float32(self.step_number), int(0.33 * U_MAX)))


def reading_deg(comp, theta_deg):
    """The encoder reading (degrees) the model corrects to reference angle ``theta_deg``."""
    theta_deg = np.asarray(theta_deg, dtype=float)
    sign = comp.reading_sign
    reading = sign * theta_deg % 360.0
    for _ in range(60):
        reading = sign * (theta_deg + np.asarray(comp.predict(reading)) / 60.0) % 360.0
    return reading


def calibrate(motor, start_step=0):
    """Utils.cpp 178-376 ``calibrate()`` on ``motor``: the 16384 floats it stores, or None ("Wired backwards")."""
    motor.step_number = start_step  # the rotor held at full step start_step (of the cycle of step 0)
    motor.electrical = 90.0 * start_step
    encoder_reading = motor.read_encoder()  # 196-205
    motor.one_step(True)
    change = motor.read_encoder() - encoder_reading
    if abs(change) > CPR // 2:
        return "rollover"  # the check straddled the encoder's rollover: its answer is false either way (line 203)
    if change < 0:
        return None
    while motor.step_number != 0:  # 207-217
        motor.one_step(motor.step_number > 0)
    full_step_readings = []
    avg = 10
    for _ in range(SPR):  # 219-259
        last = motor.read_encoder()
        total = 0
        for _reading in range(avg):
            current = motor.read_encoder()
            if current - last < -(CPR // 2):
                current += CPR
            elif current - last > CPR // 2:
                current -= CPR
            total += current
            last = current
        reading = int(c_div(total, avg))
        if reading > CPR:
            reading -= CPR
        elif reading < 0:
            reading += CPR
        full_step_readings.append(reading)
        motor.one_step(True)
    readings = full_step_readings
    i_start = j_start = 0
    for i in range(SPR):  # 265-300
        ticks = _ticks(readings, i)
        if ticks > 1:
            for j in range(ticks):
                if (readings[i] + j) % CPR == 0:
                    i_start, j_start = i, j
        if ticks < 1:
            for j in range(-ticks, 0, -1):
                if (readings[SPR - 1 - i] + j) % CPR == 0:
                    i_start, j_start = i, j
    stored = []
    f = np.float32
    for i in range(i_start, i_start + SPR + 1):  # 315-365
        ticks = _ticks(readings, i % SPR)
        if ticks > 1:
            if i == i_start:
                js = range(j_start, ticks)
            elif i == i_start + SPR:
                js = range(0, j_start)
            else:
                js = range(0, ticks)
            for j in js:
                angle = f(1000) * (APS * f(i) + (APS * f(j)) / f(ticks))
                stored.append(f(0.001 * int(c_mod(angle, 360000))))
        elif ticks < 1:
            if i == i_start:
                js = range(-ticks, j_start, -1)
            elif i == i_start + SPR:
                js = range(j_start, 0, -1)
            else:
                js = range(-ticks, 0, -1)
            for j in js:
                angle = f(1000) * (APS * f(i) + (APS * f(ticks + j)) / f(ticks))
                stored.append(f(0.001 * int(c_mod(angle, 360000))))
    assert len(stored) == CPR, len(stored)
    return np.asarray(stored, dtype=np.float32)


def _ticks(readings, i):
    ticks = readings[(i + 1) % SPR] - readings[i % SPR]
    if ticks < -15000:
        ticks += CPR
    elif ticks > 15000:
        ticks -= CPR
    return ticks


def firmware_calibration(comp, step_zero_deg):
    """What the user gets from ``calibrate()``: (table, wiring), swapping a phase on "Wired backwards" as its
    message says, and starting away from the encoder's rollover, where its comment says the check is false."""
    for start_step in (0, 8, -8):
        for wiring in (1, -1):
            table = calibrate(Motor(comp, step_zero_deg, wiring), start_step)
            if isinstance(table, str):
                break  # at the rollover: step away and start again
            if table is not None:
                return table, wiring
    raise AssertionError("calibrate() said 'Wired backwards' with both wirings")


def torque_factor(comp, lookup, step_zero_deg, wiring):
    """Controller.cpp 19-90 at every count: the smallest torque factor (1 = the largest torque the current
    can give, in the direction of ``u``) over counts and both signs of ``u``."""
    lookup = np.asarray(lookup, dtype=np.float32)
    counts = np.arange(CPR)
    theta = np.asarray(comp.correct(counts * (360.0 / CPR)), dtype=float)  # the rotor where the count is read
    rotor = np.radians(wiring * POLE_PAIRS * (theta - step_zero_deg))
    factors = []
    for sign in (1, -1):  # u > 0: y += PA; u < 0: y -= PA (Controller.cpp 71-82)
        y = lookup[counts] + np.float32(sign) * PA
        current_a, current_b = output(-y, U_MAX)
        field = np.arctan2(current_a, current_b)
        towards_rising_field = np.sin(field - rotor)
        # the firmware's forward (u > 0) is the way calibrate() stepped: dir true, the field angle falling
        factors.append(-sign * towards_rising_field)
    return float(np.min(factors))


@dataclass(frozen=True)
class Case:
    row: Row
    torque_factor: float | None  # smallest over counts and both signs of u, for encal's table
    firmware_torque_factor: float | None  # the same for the firmware's own calibrate() table
    frame_rms_arcmin: float | None  # RMS of (the firmware's own table - the rotor angle encal writes to)


def cases():
    from .klipper import model_for

    for reversed_ in (False, True):
        for zero in ZEROS_DEG:
            for encoder_zero, step_zero, what in ((zero, 0.0, f"encoder zero {zero:g} deg ahead, step 0 at 0"),
                                                  (0.0, zero, f"step 0 at {zero:g} deg")):
                if what.startswith("step 0 at 0 "):
                    continue
                label = f"14-bit, {'reversed, ' if reversed_ else ''}{what}"
                yield run_case(model_for(14, reversed_, encoder_zero), step_zero, label)
    # Mechaduino's lookup[] is one entry per 14-bit count: every other resolution is refused in one sentence
    yield run_case(model_for(16, False, 0.0), 0.0, "16-bit (any configuration)")
    yield run_case(model_for(14, False, 0.0), None, "14-bit, no --step-zero")


def read_lookup(text):
    """The floats of a written ``lookup[16384] = {...}`` (as the compiler stores them: float32)."""
    body = text[text.index("{") + 1:text.rindex("}")]
    return np.array([float(v) for v in body.split(",")], dtype=np.float32)


def run_case(comp, step_zero, label):
    """encal's table for ``comp`` (``step_zero`` the reference angle of step 0, or None) through the firmware's
    rules, beside the firmware's own calibrate() on the same motor and encoder."""
    from encal.deploy.firmware import export_mechaduino
    from encal._core.errors import InputError

    try:
        written = export_mechaduino(comp, step_zero_deg=step_zero)
    except InputError as error:
        return Case(Row("mechaduino", label, None, None, None, None, str(error)), None, None, None)
    lookup = read_lookup(written.text)
    own, wiring = firmware_calibration(comp, step_zero)
    # task klipper-dir: which way the wiring calibrate() accepts turns the reference (Motor: dir true lowers the
    # field angle, so its forward steps raise the reference angle when wiring is -1)
    label += f", forward steps {'raise' if wiring == -1 else 'lower'} the reference"
    theta = np.asarray(comp.correct(np.arange(CPR) * (360.0 / CPR)), dtype=float)
    frame = (-wiring * (theta - step_zero)) % 360.0  # the rotor's angle from step 0, the way the firmware counts
    gap = ((lookup.astype(float) - frame + 180.0) % 360.0 - 180.0) * 60.0
    own_gap = ((own.astype(float) - frame + 180.0) % 360.0 - 180.0) * 60.0
    row = Row("mechaduino", label, written.rms_error_arcmin, written.max_error_arcmin,
              float(np.sqrt(np.mean(gap**2))), float(np.max(np.abs(gap))))
    return Case(row, torque_factor(comp, lookup, step_zero, wiring), torque_factor(comp, own, step_zero, wiring),
                float(np.sqrt(np.mean(own_gap**2))))


def matrix():
    for case in cases():
        yield case.row

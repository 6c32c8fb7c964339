"""A simulated brushless motor with a magnetic encoder: a constant-drive spin and an open-loop sweep.

The motor has inertia, viscous and Coulomb friction, and a torque ripple periodic in the rotor angle:
cogging at the least common multiple of the slot and pole counts (and its second harmonic), a small
per-slot irregularity (order = slots), a per-pole irregularity (order = 2 x pole pairs) and,
optionally, an unbalanced load (order 1). In an open-loop sweep the rotor follows the commanded
electrical angle through a magnetic spring; the field's direction is distorted at the 2nd and 6th
electrical harmonic.
"""

import math
from dataclasses import dataclass
from math import lcm

import numpy as np

from ..._core.angles import wrap360

__all__ = ["Motor", "make_motor", "SpinRun", "simulate_spin", "SweepCapture", "simulate_sweep", "simulate_moteus_cal"]


@dataclass(frozen=True)
class Motor:
    """A brushless motor.

    Parameters
    ----------
    pole_pairs : int
    slots : int
    inertia_kgm2 : float
        Rotor (and load) inertia, kg m^2.
    viscous_nm_s : float
        Viscous friction, N m per rad/s.
    coulomb_nm : float
        Coulomb friction, N m.
    ripple : tuple of (int, float, float)
        Torque ripple ``(order, amplitude_nm, phase_rad)``: the torque opposing the rotor is
        ``sum A sin(k theta + phase)`` at rotor angle ``theta``.
    holding_torque_nm : float
        Torque of the open-loop sweep current at 90 electrical degrees of displacement, N m.
    field_distortion : tuple of (int, float, float)
        ``(electrical order, amplitude_deg_e, phase_rad)``: the field points at
        ``psi + sum A sin(k psi + phase)`` electrical degrees when ``psi`` is commanded.
    """

    pole_pairs: int
    slots: int
    inertia_kgm2: float = 3e-5
    viscous_nm_s: float = 1e-4
    coulomb_nm: float = 3e-3
    ripple: tuple = ()
    holding_torque_nm: float = 0.15
    field_distortion: tuple = ()

    @property
    def cogging_order(self):
        """Cogging periods per revolution: lcm(slots, 2 x pole pairs)."""
        return lcm(self.slots, 2 * self.pole_pairs)

    def ripple_torque_nm(self, rotor_rad):
        """Torque ripple opposing the rotor, N m, at rotor angles in radians."""
        total = np.zeros(np.shape(rotor_rad))
        for order, amplitude, phase in self.ripple:
            total = total + amplitude * np.sin(order * rotor_rad + phase)
        return total

    def field_deg_e(self, commanded_deg_e):
        """Electrical angle (degrees) the field points at when ``commanded_deg_e`` is commanded."""
        psi = np.radians(commanded_deg_e)
        total = np.asarray(commanded_deg_e, dtype=float).copy()
        for order, amplitude, phase in self.field_distortion:
            total = total + amplitude * np.sin(order * psi + phase)
        return total


def make_motor(pole_pairs=7, slots=12, rng=None, *, cogging_nm=4e-3, irregularity=0.15, unbalance_nm=0.0,
               field_distortion_deg_e=1.5, **parameters):
    """A motor with cogging and irregularities of random phase.

    Parameters
    ----------
    pole_pairs, slots : int
    rng : int or numpy.random.Generator, optional
    cogging_nm : float, default=4e-3
        Amplitude of the cogging torque at lcm(slots, 2 pole_pairs), N m (its 2nd harmonic is 30 % of it).
    irregularity : float, default=0.15
        Per-slot (order = slots) and per-pole (order = 2 pole_pairs) ripple, as a fraction of the cogging.
    unbalance_nm : float, default=0.0
        An unbalanced load on a horizontal shaft: ripple of order 1, N m.
    field_distortion_deg_e : float, default=1.5
        Distortion of the field direction at the 6th electrical harmonic (the 2nd gets half), electrical degrees.
    **parameters
        Any other :class:`Motor` field.
    """
    rng = np.random.default_rng(rng)
    cog = lcm(slots, 2 * pole_pairs)
    terms = [(cog, cogging_nm), (2 * cog, 0.3 * cogging_nm), (slots, irregularity * cogging_nm),
             (2 * pole_pairs, irregularity * cogging_nm)]
    if unbalance_nm:
        terms.append((1, unbalance_nm))
    ripple = tuple((order, float(amplitude), float(rng.uniform(0, 2 * np.pi))) for order, amplitude in terms
                   if amplitude)
    field = tuple((order, float(amplitude), float(rng.uniform(0, 2 * np.pi)))
                  for order, amplitude in ((6, field_distortion_deg_e), (2, 0.5 * field_distortion_deg_e)))
    return Motor(pole_pairs, slots, ripple=ripple, field_distortion=field, **parameters)


@dataclass(frozen=True)
class SpinRun:
    """One constant-drive spin: sample times (s), encoder readings (degrees), true rotor angles (degrees)."""

    time_s: np.ndarray
    encoder_deg: np.ndarray
    rotor_deg: np.ndarray
    speed_rev_s: float


def simulate_spin(motor, encoder, speed_rev_s, revolutions=30, sample_rate_hz=2000.0, rng=None,
                  torque_noise_nm=0.0, drift=0.0):
    """Spin the motor at a constant drive torque and log its encoder.

    The drive torque (a current-controlled drive: no back-EMF damping) balances the friction at
    ``speed_rev_s``; after five mechanical time constants of settling the log starts. The rotor turns at that speed on
    average, with a speed ripple from the torque ripple (its angle ripple falls as 1/speed^2), a slow
    ``drift`` (fractional change of the drive over the run) and, with ``torque_noise_nm``, random torque
    at frequencies from 0.02 to 2 times the turning rate.

    Parameters
    ----------
    motor : Motor
    encoder : MagneticEncoder
    speed_rev_s : float
        Mean speed in revolutions per second (negative: backwards).
    revolutions : float, default=30
    sample_rate_hz : float, default=2000
    rng : int or numpy.random.Generator, optional
    torque_noise_nm : float, default=0
        RMS of the random torque, N m.
    drift : float, default=0

    Returns
    -------
    SpinRun
    """
    rng = np.random.default_rng(rng)
    omega0 = 2 * np.pi * speed_rev_s
    duration = revolutions / abs(speed_rev_s)
    time = np.arange(0.0, duration, 1.0 / sample_rate_hz)
    drive0 = motor.viscous_nm_s * omega0 + motor.coulomb_nm * np.sign(omega0)
    n_noise = 8
    frequencies = abs(speed_rev_s) * np.exp(rng.uniform(np.log(0.02), np.log(2.0), n_noise))
    noise = [(2 * math.pi * f, p, torque_noise_nm * math.sqrt(2.0 / n_noise))
             for f, p in zip(frequencies, rng.uniform(0, 2 * np.pi, n_noise))] if torque_noise_nm else []
    ripple = [(float(k), float(a), float(p)) for k, a, p in motor.ripple]
    inertia, viscous, coulomb = motor.inertia_kgm2, motor.viscous_nm_s, motor.coulomb_nm

    def acceleration(t, theta, omega):
        torque = drive0 * (1.0 + drift * max(t, 0.0) / duration) - viscous * omega - coulomb * math.tanh(omega / 0.01)
        for order, amplitude, phase in ripple:
            torque -= amplitude * math.sin(order * theta + phase)
        for angular, phase, amplitude in noise:
            torque += amplitude * math.sin(angular * t + phase)
        return torque / inertia

    # classical Runge-Kutta, at least 24 steps per period of the fastest ripple
    fastest = abs(speed_rev_s) * max([order for order, _, _ in ripple] + [1])
    substeps = max(1, math.ceil(24 * fastest / sample_rate_hz))
    h = 1.0 / sample_rate_hz / substeps
    theta, omega = float(rng.uniform(0, 2 * np.pi)), float(omega0)
    settle = math.ceil(5 * inertia / viscous * sample_rate_hz)  # five time constants before the log starts
    angles = np.empty(time.size)
    t = -settle / sample_rate_hz
    for i in range(-settle, time.size):
        if i >= 0:
            angles[i] = theta
        for _ in range(substeps):
            k1v = acceleration(t, theta, omega)
            k2v = acceleration(t + h / 2, theta + h / 2 * omega, omega + h / 2 * k1v)
            k3v = acceleration(t + h / 2, theta + h / 2 * (omega + h / 2 * k1v), omega + h / 2 * k2v)
            k4v = acceleration(t + h, theta + h * (omega + h / 2 * k2v), omega + h * k3v)
            theta += h * (omega + h / 6 * (k1v + k2v + k3v))
            omega += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
            t += h
    rotor_deg = np.degrees(angles)
    return SpinRun(time, encoder.read(rotor_deg, rng), rotor_deg, float(speed_rev_s))


@dataclass(frozen=True)
class SweepCapture:
    """An open-loop sweep as moteus records it: direction code, commanded phase and encoder, both uint16.

    ``direction`` is 1 or 3 for a pass up, 2 or 4 for a pass down; ``phase`` is the commanded electrical
    angle in 1/65536 of an electrical turn; ``encoder`` the reading in 1/65536 of a turn; ``rotor_deg``
    the true rotor angle (degrees, not in a real capture).
    """

    direction: np.ndarray
    phase: np.ndarray
    encoder: np.ndarray
    rotor_deg: np.ndarray


def simulate_sweep(motor, encoder, revolutions=1.0, samples_per_period=64, passes=1, rng=None):
    """Sweep the commanded electrical angle up and down and record a moteus-style capture.

    The rotor settles where the field's torque balances friction and torque ripple (quasi-static):
    ``holding sin(field - p theta) = coulomb * direction + ripple(theta)``.

    Parameters
    ----------
    motor : Motor
    encoder : MagneticEncoder
    revolutions : float, default=1
        Mechanical revolutions of each pass.
    samples_per_period : int, default=64
        Samples per electrical period.
    passes : {1, 2}, default=1
        Pairs of passes (up then down): 1 records directions 1, 2; 2 adds 3, 4.
    rng : int or numpy.random.Generator, optional

    Returns
    -------
    SweepCapture
    """
    rng = np.random.default_rng(rng)
    p = motor.pole_pairs
    n = int(round(revolutions * p * samples_per_period))
    up = np.arange(n + 1) * (360.0 / samples_per_period)
    start = rng.uniform(0, 360.0)
    segments, codes, travel = [], [], []
    for pair in range(passes):
        segments += [start + up, start + up[::-1]]
        codes += [np.full(up.size, 1 + 2 * pair), np.full(up.size, 2 + 2 * pair)]
        travel += [np.ones(up.size), -np.ones(up.size)]
    commanded = np.concatenate(segments)
    direction = np.concatenate(codes)
    sign = np.concatenate(travel)
    rotor = _settled_rotor_deg(motor, commanded, sign)
    reading = encoder.read(rotor, rng)
    phase = np.round(wrap360(commanded) * 65536 / 360.0).astype(np.int64) % 65536
    counts = np.round(reading * 65536 / 360.0).astype(np.int64) % 65536
    return SweepCapture(direction.astype(int), phase, counts, rotor)


def _settled_rotor_deg(motor, commanded_deg_e, sign):
    """Where the rotor settles (mechanical degrees) under each commanded electrical angle, moving in ``sign``."""
    field = motor.field_deg_e(commanded_deg_e)
    rotor = field / motor.pole_pairs
    for _ in range(50):
        load = (motor.coulomb_nm * sign + motor.ripple_torque_nm(np.radians(rotor))) / motor.holding_torque_nm
        rotor = (field - np.degrees(np.arcsin(np.clip(load, -1, 1)))) / motor.pole_pairs
    return rotor


#: moteus' calibration prints every 10th millisecond tick (board_debug.cc, ``cal_count_ % 10``).
MOTEUS_PRINT_TICKS = 10


def simulate_moteus_cal(motor, encoder, speed=1.0, runs=1, start_counts=0, rng=None):
    """The capture of moteus' voltage-mode encoder calibration (``d cal V s<speed>``), tick by tick as its firmware.

    As ``fw/board_debug.cc`` (mjbots/moteus db1a762, ``DoCalibration``) does it: every millisecond the phase
    (uint16) steps by ``int(speed * 65536 / 1000)`` from 0, up (direction 1) until the encoder has travelled more
    than one turn (65536 counts), then down (direction 2) until it has travelled one turn back; every 10th tick
    prints the phase commanded before that tick's step and the encoder's reading. A run thus sweeps ONE pass each
    way; ``runs`` > 1 appends further runs (each from phase 0 and tick 0, the rotor back at its start), whose
    printed phases are those of the first run exactly. Prints the firmware skips while a write is outstanding are
    not modelled.

    Parameters
    ----------
    motor : Motor
    encoder : MagneticEncoder
    speed : float, default=1
        Electrical turns per second (moteus_tool's ``--cal-ll-encoder-speed``, default 1).
    runs : int, default=1
    start_counts : int or sequence of int, default=0
        Phase each run starts from, 1/65536 of an electrical turn, one for all runs or one per run: 0 is
        ``d cal``'s; other values give runs whose printed phases do not coincide (as ``d cali``'s, whose phase is
        the control position, which starts where the rotor was held).
    rng : int or numpy.random.Generator, optional

    Returns
    -------
    SweepCapture
    """
    rng = np.random.default_rng(rng)
    step = int(speed * 65536.0 / 1000.0)
    if step < 1:
        raise ValueError(f"speed {speed} gives no phase step per millisecond; expected at least 1/65.536")
    most = int(math.ceil(1.5 * motor.pole_pairs * 65536 / step)) + 2 * MOTEUS_PRINT_TICKS

    def travelled_turn(counts):
        """Index of the first reading after which the int16 deltas add to more than a turn."""
        delta = np.cumsum(((np.diff(counts) + 32768) % 65536) - 32768)
        beyond = np.flatnonzero(np.abs(delta) > 65536)
        if beyond.size == 0:
            raise ValueError("the encoder did not travel one turn within 1.5 turns of phase")
        return int(beyond[0]) + 1

    directions, phases, readings, rotors = [], [], [], []
    starts = np.broadcast_to(np.asarray(start_counts, dtype=np.int64), (runs,))
    for start in starts:
        tick = np.arange(1, most + 1)  # cal_count_ after its increment
        up_phase = start + (tick - 1) * step  # unwrapped: the phase the rotor stands at when tick is read
        up_rotor = _settled_rotor_deg(motor, up_phase * (360.0 / 65536), 1.0)
        up_counts = _moteus_counts(encoder.read(up_rotor, rng))
        switch = travelled_turn(up_counts)  # index of the tick that turns the sweep down
        turn_tick = int(tick[switch])
        down_phase = up_phase[switch] - np.arange(most) * step
        down_rotor = _settled_rotor_deg(motor, down_phase * (360.0 / 65536), -1.0)
        down_counts = _moteus_counts(encoder.read(down_rotor, rng))
        end = travelled_turn(down_counts)  # the tick that ends the sweep prints nothing
        down_tick = turn_tick + np.arange(end)
        for code, ticks, phase, counts, rotor in ((1, tick[:switch], up_phase, up_counts, up_rotor),
                                                  (2, down_tick, down_phase, down_counts, down_rotor)):
            printed = np.flatnonzero(ticks % MOTEUS_PRINT_TICKS == 0)
            directions.append(np.full(printed.size, code))
            phases.append(phase[printed] % 65536)
            readings.append(counts[printed])
            rotors.append(rotor[printed])
    return SweepCapture(np.concatenate(directions).astype(int), np.concatenate(phases).astype(np.int64),
                        np.concatenate(readings), np.concatenate(rotors))


def _moteus_counts(reading_deg):
    """Readings in degrees as moteus' ``position_raw``: 65536 counts a turn."""
    return np.round(np.asarray(reading_deg) * 65536 / 360.0).astype(np.int64) % 65536

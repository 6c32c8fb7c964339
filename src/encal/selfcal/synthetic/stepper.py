"""A simulated stepper motor whose full steps are the reference of a magnetic encoder (Mechaduino)."""

from dataclasses import dataclass

import numpy as np

from ..._core.angles import ARCMIN_PER_DEG
from ...data.calibration import Calibration

__all__ = ["Stepper", "draw_stepper", "StepperCalibration", "simulate_steps"]


@dataclass(frozen=True)
class Stepper:
    """A hybrid stepper's full-step positions.

    Full step ``k`` stands at ``k * 360/steps + error(k)``: ``error(k) = pattern[k mod 4] + tooth[k // 4]``,
    a pattern that repeats every 4 full steps (one rotor tooth: unequal phase currents and detent)
    plus an error of each rotor tooth.

    Parameters
    ----------
    steps : int
        Full steps per revolution (a multiple of 4).
    pattern_arcmin : ndarray of shape (4,)
        The 4-step pattern, arc-minutes (mean zero).
    tooth_arcmin : ndarray of shape (steps // 4,)
        Error of each tooth, arc-minutes (mean zero).
    """

    steps: int
    pattern_arcmin: np.ndarray
    tooth_arcmin: np.ndarray

    def error_arcmin(self, step):
        """Position error of full step(s) ``step`` in arc-minutes."""
        step = np.asarray(step) % self.steps
        return self.pattern_arcmin[step % 4] + self.tooth_arcmin[step // 4]

    def position_deg(self, step):
        """True rotor angle of full step(s) ``step`` in degrees."""
        return np.asarray(step) * (360.0 / self.steps) + self.error_arcmin(step) / ARCMIN_PER_DEG


def draw_stepper(rng=None, steps=200, pattern_arcmin=4.0, tooth_arcmin=1.0):
    """A random stepper: 4-step pattern of RMS ``pattern_arcmin``, tooth errors of RMS ``tooth_arcmin``."""
    rng = np.random.default_rng(rng)
    pattern = rng.normal(size=4)
    pattern -= pattern.mean()
    pattern *= pattern_arcmin / np.sqrt(np.mean(pattern ** 2))
    tooth = rng.normal(0.0, tooth_arcmin, steps // 4)
    tooth -= tooth.mean()
    return Stepper(steps, pattern, tooth)


@dataclass(frozen=True)
class StepperCalibration:
    """A full-step calibration and its truth: the stepper's error at each listed step (arcmin)."""

    calibration: Calibration
    physical_step: np.ndarray
    stepper_error_arcmin: np.ndarray


def simulate_steps(stepper, encoder, start_step=0, readings_per_step=10, rng=None, name="sim"):
    """Step through one revolution of full steps and read the encoder as the Mechaduino does.

    At each full step the encoder is read ``readings_per_step`` times; the mean of the whole counts is
    truncated to a whole count. ``reference_deg`` counts steps from ``start_step`` (the zero of the
    reference is where the motor stood).

    Returns
    -------
    StepperCalibration
    """
    rng = np.random.default_rng(rng)
    k = np.arange(stepper.steps)
    physical = (start_step + k) % stepper.steps
    rotor = stepper.position_deg(start_step + k)
    readings = np.stack([encoder.read(rotor, rng) for _ in range(readings_per_step)])
    if encoder.bits is not None:
        counts = 2 ** encoder.bits
        raw = np.round(readings * counts / 360.0)
        raw = raw[0] + ((raw - raw[0] + counts / 2) % counts - counts / 2)  # unwrap around the first reading
        reading = np.floor(raw.mean(axis=0)) * 360.0 / counts
    else:
        reading = readings[0] + np.mean((readings - readings[0] + 180.0) % 360.0 - 180.0, axis=0)
    cal = Calibration(k * (360.0 / stepper.steps), reading, name=name, resolution_bits=encoder.bits)
    return StepperCalibration(cal, physical, stepper.error_arcmin(physical))

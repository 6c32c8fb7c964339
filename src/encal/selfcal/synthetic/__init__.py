"""Simulators for self-calibration: a magnetic encoder on a brushless motor or on a stepper.

Each gives the truth (the encoder's error as a function of its reading, the stepper's step errors)
so that every self-calibration method is tested against a known answer.
"""

from .encoder import MagneticEncoder, draw_magnetic_encoder
from .motor import Motor, SpinRun, SweepCapture, make_motor, simulate_moteus_cal, simulate_spin, simulate_sweep
from .stepper import Stepper, StepperCalibration, draw_stepper, simulate_steps

__all__ = ["MagneticEncoder", "draw_magnetic_encoder", "Motor", "make_motor", "SpinRun", "simulate_spin",
           "SweepCapture", "simulate_sweep", "simulate_moteus_cal", "Stepper", "draw_stepper", "StepperCalibration",
           "simulate_steps"]

"""Calibration without a precision reference: from a spin, an electrical-angle sweep or full steps.

Each method makes a reference from the motor the encoder sits on, recovers the encoder's error as
a Fourier series of its reading with the covariance of its coefficients, and says what it cannot
separate from the reference's own error. The result writes a calibration CSV for ``encal fit``.
See docs/self-calibration.md.
"""

from .moteus_capture import MoteusCapture, read_moteus_capture, write_moteus_capture
from .result import SelfCalibration
from .spin import SpinLog, motor_ripple_orders, spin
from .spin_log import read_spin_log, write_spin_log
from .steps import step_errors, steps
from .sweep import sweep, sweep_capture
from .sweep_log import SweepLog, read_sweep_log

__all__ = ["SelfCalibration", "SpinLog", "spin", "motor_ripple_orders", "read_spin_log", "write_spin_log",
           "sweep", "sweep_capture", "SweepLog", "read_sweep_log", "steps", "step_errors", "MoteusCapture",
           "read_moteus_capture", "write_moteus_capture"]

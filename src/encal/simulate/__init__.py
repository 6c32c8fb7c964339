"""Simulated resolver encoders calibrated on a rotary table.

A physical model of a low-cost single-speed resolver read by a 16-bit
resolver-to-digital converter (the encoders of Dhar et al.): winding
non-idealities and spatial harmonics, carrier phases, synchronous
demodulation, the converter's own errors, hysteresis and quantisation, and
the rotary table. See ``docs/simulator.md``.
"""

from ._encoder import EncoderState, SimulatedEncoder, draw_encoder
from ._fleet import DEMO_EXTRA_SEED, DEMO_SEEDS, RUN_NAMES, FleetMember, demo_fleet, simulate_fleet
from ._run import TEST_GRID_DEG, TRAINING_GRID_DEG, SimulatedRun, calibration_run, measurement_floor

__all__ = [
    "SimulatedEncoder",
    "EncoderState",
    "draw_encoder",
    "SimulatedRun",
    "calibration_run",
    "measurement_floor",
    "TRAINING_GRID_DEG",
    "TEST_GRID_DEG",
    "FleetMember",
    "RUN_NAMES",
    "demo_fleet",
    "simulate_fleet",
    "DEMO_SEEDS",
    "DEMO_EXTRA_SEED",
]

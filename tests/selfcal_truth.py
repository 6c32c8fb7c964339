"""Helpers shared by the self-calibration tests: the simulators' truth restricted to the orders a method recovers."""

import numpy as np

GRID = np.arange(720) * 0.5


def truth_at_orders(encoder, orders, grid=GRID):
    """The encoder's true error vs reading (arcmin) on ``grid``, keeping only harmonic ``orders``."""
    values = encoder.error_at_reading(grid)
    spectrum = np.fft.rfft(values)
    keep = np.zeros(spectrum.size)
    keep[np.asarray(orders, dtype=int)] = 1.0
    return np.fft.irfft(spectrum * keep, n=grid.size)


def rms(values):
    return float(np.sqrt(np.mean(np.square(values))))

"""Harmonic amplitudes of a profile sampled on a uniform grid (the spec's convention).

The general least-squares analysis for any angle list is ``encal.analysis.profile``;
this is the FFT shortcut the simulator's own checks use.
"""

import numpy as np

__all__ = ["harmonic_amplitudes", "top_orders"]


def harmonic_amplitudes(errors_arcmin):
    """Amplitudes of the orders 0..N/2 of errors sampled at N uniform angles from 0 degrees.

    ``A0 = |X0|`` and ``Ak = 2 |Xk|`` (``|Xk|`` at the Nyquist order of an even
    N), with ``X = rfft(errors) / N``; arc-minutes.
    """
    errors = np.asarray(errors_arcmin, dtype=float)
    amplitudes = 2.0 * np.abs(np.fft.rfft(errors)) / errors.size
    amplitudes[0] /= 2.0
    if errors.size % 2 == 0:
        amplitudes[-1] /= 2.0
    return amplitudes


def top_orders(errors_arcmin, count=10):
    """The ``count`` harmonic orders of largest amplitude, largest first."""
    amplitudes = harmonic_amplitudes(errors_arcmin)
    return [int(k) for k in np.argsort(-amplitudes, kind="stable")[:count]]

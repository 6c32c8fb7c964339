"""A Fourier series in float32 with exact phases: the cortex-m4f formula's arithmetic, in NumPy.

Any model kind whose prediction is a Fourier series deploys through it: the
``fourier`` kind and its subclasses (``spectral``), and any kind with a
``fourier_series()`` method.
"""

import math

import numpy as np

from ..models.fourier import FourierModel
from .compensator import Compensator

__all__ = ["fourier_terms", "fourier_float32"]


def fourier_terms(model):
    """``(orders, cos, sin)`` of a model that is a Fourier series of the reading, else None.

    A model kind whose prediction is a Fourier series says so with a
    ``fourier_series()`` method returning the same triple. A model that negates
    readings first (``reading_sign`` -1) is the series with its sine terms negated.
    """
    model = model.model if isinstance(model, Compensator) else model
    sign = getattr(model, "reading_sign", 1)
    series = getattr(model, "fourier_series", None)
    if callable(series):
        orders, cos, sin = series()
    elif isinstance(model, FourierModel):  # the fourier kind and its subclasses (spectral)
        orders, cos, sin = model.orders, model.cos, model.sin
    else:
        return None
    return (np.asarray(orders, dtype=np.int64), np.asarray(cos, dtype=float),
            sign * np.asarray(sin, dtype=float))


def fourier_float32(orders, cos, sin, angles):
    """The cortex-m4f Fourier rule: error (arcmin, float32) at 32-bit binary angles.

    Per term: ``p = k * angle mod 2^32`` (exact), ``phase = (p >> 8) * 2 pi / 2^24``
    in float32, ``sum += c * cosf(phase) + s * sinf(phase)``. NumPy's float32 sine
    and cosine may differ from a C library's by an ulp.
    """
    angles = np.asarray(angles, dtype=np.int64) & 0xFFFFFFFF
    total = np.zeros(angles.shape, dtype=np.float32)
    step = np.float32(2.0 * math.pi / 2**24)
    for order, c, s in zip(orders, cos, sin):
        p = (int(order) * angles) & 0xFFFFFFFF
        phase = (p >> 8).astype(np.float32) * step
        total = total + (np.float32(c) * np.cos(phase) + np.float32(s) * np.sin(phase))
    return total

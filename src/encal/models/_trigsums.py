"""The non-uniform FFT sums, kept importable here for the spectral model: see :mod:`encal._trigsums`.

They live below both :mod:`encal.profile` and the models, so that the harmonic analysis can use them.
"""

from .._trigsums import SeriesEvaluator, trig_moments, trig_series

__all__ = ["SeriesEvaluator", "trig_moments", "trig_series"]

"""Deprecated path of the calibration and its CSV: moved to :mod:`encal.data.calibration`;
this one works until encal 0.3, with a warning."""

from ._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal.data.calibration")

"""Deprecated path of the HTML report of a calibration: moved to :mod:`encal.reports.encoder`;
this one works until encal 0.3, with a warning."""

from ._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal.reports.encoder")

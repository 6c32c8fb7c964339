"""Deprecated path of the statistics and harmonics of an error profile: moved to :mod:`encal.analysis.profile`;
this one works until encal 0.3, with a warning."""

from ._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal.analysis.profile")

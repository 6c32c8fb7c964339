"""Deprecated path of fit and evaluate: moved to :mod:`encal.models.fitting`;
this one works until encal 0.3, with a warning."""

from ._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal.models.fitting")

"""Deprecated path of the directions of travel and their reversal: moved to :mod:`encal.data.reversal`;
this one works until encal 0.3, with a warning."""

from ._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal.data.reversal")

"""Deprecated path of angles and their units: moved to :mod:`encal._core.angles`;
this one works until encal 0.3, with a warning."""

from ._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal._core.angles")

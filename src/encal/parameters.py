"""Deprecated path of the checks of public parameters: moved to :mod:`encal._core.parameters`;
this one works until encal 0.3, with a warning."""

from ._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal._core.parameters")

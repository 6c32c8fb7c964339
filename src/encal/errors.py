"""Deprecated path of the exception and warning classes: moved to :mod:`encal._core.errors`;
this one works until encal 0.3, with a warning."""

from ._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal._core.errors", public="encal")

"""Deprecated path of the answer of fit(method='auto'): moved to :mod:`encal.models.auto`;
this one works until encal 0.3, with a warning."""

from .._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal.models.auto")

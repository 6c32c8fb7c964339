"""Deprecated path of the estimation of a model's uncertainty: moved to :mod:`encal.models.uncertainty`;
this one works until encal 0.3, with a warning."""

from ._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal.models.uncertainty")

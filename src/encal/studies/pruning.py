"""Deprecated path: moved to :mod:`encal.paper.studies.pruning`; this one works until encal 0.3, with a warning."""

from .._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal.paper.studies.pruning")

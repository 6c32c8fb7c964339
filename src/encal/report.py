"""Deprecated path of the paper's HTML report: moved to :mod:`encal.paper.report`;
this one works until encal 0.3, with a warning."""

from ._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal.paper.report")

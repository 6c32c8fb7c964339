"""Deprecated path of the paper's whole procedure: moved to :mod:`encal.paper.demo`;
this one works until encal 0.3, with a warning."""

from ._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal.paper.demo")

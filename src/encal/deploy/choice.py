"""Deprecated path of the cost-aware choice of a deployment: moved to :mod:`encal.deploy.deployment`;
this one works until encal 0.3, with a warning."""

from .._core.deprecation import moved_module

__getattr__, __dir__ = moved_module(__name__, "encal.deploy.deployment")

"""Error models: one module per kind, one :class:`Model` interface, one registry of kinds.

Importing this package registers every kind of :mod:`encal.models.registry`, so
:func:`model_kind` finds each of them by name.
"""

from .base import Model
from .kind import ModelKind, kind_names, model_kind
from . import registry  # noqa: E402,F401  (registers the kinds)

__all__ = ["Model", "ModelKind", "model_kind", "kind_names"]

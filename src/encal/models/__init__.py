"""Error models: one module per family, one :class:`Model` interface."""

from .base import MODEL_KINDS, Model, model_class, register_model

__all__ = ["Model", "register_model", "model_class", "MODEL_KINDS"]

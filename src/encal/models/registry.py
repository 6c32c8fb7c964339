"""The registry: every model kind encal knows, one entry each.

:func:`encal.fit` (the ``method``), the automatic choice (its candidate families and tie rule), a
stack (its member kinds), a directional model (its part kinds) and the model file (which class reads
a ``kind``) all look kinds up here, through :func:`~encal.models.kind.model_kind`.

To add a kind, write its module (a :class:`~encal.models.base.Model` subclass with a ``kind`` name,
and a fit function on plain arrays) and add one :class:`~encal.models.kind.ModelKind` line below;
``docs/architecture.md`` walks through it. A kind that a model file should hold also needs its
parameters specified in the model-file format (:mod:`encal.runtime`, ``docs/model-file.md``).
"""

from . import ann, choice, directional, fourier, hybrid, lut, spectral, stack
from .kind import ModelKind, register_kind

__all__ = ["KINDS"]

#: Simplicity ranks leave gaps, so that a new family can be placed between two others.
KINDS = (
    ModelKind("fourier", fourier.FourierModel, fourier.fit_fourier, grid_aware=True, simplicity=10,
              stack_member=True, directional_part=True),
    ModelKind("spectral", spectral.SpectralModel, spectral.fit_spectral, stack_member=True,
              directional_part=True),
    ModelKind("lut", lut.LookupTableModel, lut.fit_lut, simplicity=20, stack_member=True,
              directional_part=True),
    ModelKind("hybrid", hybrid.HybridModel, hybrid.fit_hybrid, randomised=True, simplicity=30,
              stack_member=True, directional_part=True),
    ModelKind("ann", ann.ANNModel, ann.fit_ann, randomised=True, simplicity=40, stack_member=True,
              directional_part=True),
    ModelKind("stack", stack.StackModel, stack.fit_stack, randomised=True, simplicity=90,
              directional_part=True),
    ModelKind("directional", directional.DirectionalModel, None),
    ModelKind("auto", None, choice.fit_auto, randomised=True),
)

for _kind in KINDS:
    register_kind(_kind)

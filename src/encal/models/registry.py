"""The registry: every model kind encal knows, one entry each.

:func:`encal.fit` (the ``method``), the automatic choice (its candidate families and tie rule), a
stack (its member kinds), a directional model (its part kinds) and the model file (which class reads
a ``kind``) all look kinds up here, through :func:`~encal.models.kind.model_kind`.

Each entry names its kind's module, class and fit function; the module is imported when the kind is
first used (:meth:`~encal.models.kind.ModelKind.loaded`), so that reading a model file imports only
its own kind (``encal correct`` on a Fourier model imports neither the network nor SciPy).

To add a kind, write its module (a :class:`~encal.models.base.Model` subclass with a ``kind`` name,
and a fit function on plain arrays) and add one :class:`~encal.models.kind.ModelKind` line below;
``docs/architecture.md`` walks through it. A kind that a model file should hold also needs its
parameters specified in the model-file format (:mod:`encal.runtime`, ``docs/model-file.md``).
"""

from .kind import ModelKind, register_kind

__all__ = ["KINDS"]

#: Simplicity ranks leave gaps, so that a new family can be placed between two others.
KINDS = (
    ModelKind("fourier", "FourierModel", "fit_fourier", module="encal.models.fourier", grid_aware=True,
              simplicity=10, stack_member=True, directional_part=True),
    ModelKind("spectral", "SpectralModel", "fit_spectral", module="encal.models.spectral", stack_member=True,
              directional_part=True),
    ModelKind("lut", "LookupTableModel", "fit_lut", module="encal.models.lut", simplicity=20,
              stack_member=True, directional_part=True),
    ModelKind("hybrid", "HybridModel", "fit_hybrid", module="encal.models.hybrid", randomised=True,
              simplicity=30, stack_member=True, directional_part=True),
    ModelKind("ann", "ANNModel", "fit_ann", module="encal.models.ann", randomised=True, simplicity=40,
              stack_member=True, directional_part=True),
    ModelKind("stack", "StackModel", "fit_stack", module="encal.models.stack", randomised=True, simplicity=90,
              directional_part=True),
    ModelKind("arc", "ArcModel", "fit_arc", module="encal.models.arc", directional_part=True),
    ModelKind("directional", "DirectionalModel", None, module="encal.models.directional"),
    ModelKind("auto", None, "fit_auto", module="encal.models.choice", randomised=True),
)

for _kind in KINDS:
    register_kind(_kind)

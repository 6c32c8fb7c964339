"""What a model kind is, and the lookup of the kinds encal knows.

A :class:`ModelKind` ties a name (``'fourier'``, the ``kind`` field of a model file, the ``method`` of
:func:`encal.fit`) to the kind's model class, its fit function and the facts other parts need about it:
whether the fit draws random numbers, whether ``fit(method='auto')`` tries it and how simple it ranks, and
whether it may be a member of a stack or one direction's part of a directional model.

The kinds themselves are listed once, in :mod:`encal.models.registry`, which registers them here when
:mod:`encal.models` is imported. An entry may name its class and fit function in the kind's module
instead of holding them: the module is then imported when :func:`model_kind` first returns the entry
(a file of that kind is read, or a model of it fitted), so reading a Fourier model imports neither the
network nor the spectral model's SciPy. This module sits below every kind, so a kind that combines others
(a stack, a directional model, the automatic choice) looks them up here by name without importing them.
"""

import dataclasses
import importlib
from dataclasses import dataclass
from typing import Callable

from .._core.errors import InputError

__all__ = ["ModelKind", "REGISTERED", "register_kind", "model_kind", "kind_names"]


@dataclass(frozen=True)
class ModelKind:
    """One entry of the registry of model kinds.

    Attributes
    ----------
    name : str
        The kind's name: a model file's ``kind`` and a ``method`` of :func:`encal.fit`.
    model_class : type, str or None
        The :class:`~encal.models.base.Model` subclass; ``model_class.from_parameters`` reads the
        ``parameters`` of a model file. None for ``'auto'``, which makes models of other kinds. A str is
        the class's name in ``module``, imported on first use.
    fit : callable, str or None
        ``fit(theta_enc_deg, error_arcmin, **options) -> Model`` on plain arrays (degrees, arc-minutes).
        None for a kind fitted from a whole calibration (``'directional'``: by :func:`encal.fit` from a
        calibration with a ``direction`` column). A str is the function's name in ``module``.
    randomised : bool, default=False
        The fit draws random numbers and takes ``rng``.
    grid_aware : bool, default=False
        The fit takes ``grid_points`` (the uniform grid of the whole calibration, for a fold's fit).
    simplicity : float or None, default=None
        Rank in the tie rule of ``fit(method='auto')``: a lower number is simpler. None when auto does not
        try the kind.
    stack_member : bool, default=False
        May be a member of a ``'stack'`` model.
    directional_part : bool, default=False
        May be one direction's part of a ``'directional'`` model.
    module : str or None, default=None
        The module (``'encal.models.fourier'``) that defines the ``model_class`` and ``fit`` given by name.
    """

    name: str
    model_class: type | str | None
    fit: Callable | str | None
    randomised: bool = False
    grid_aware: bool = False
    simplicity: float | None = None
    stack_member: bool = False
    directional_part: bool = False
    module: str | None = None

    def read(self, parameters, *, encoder=None, training=None):
        """The model held by a model file's ``parameters`` (see :meth:`Model.from_parameters`)."""
        model_class = self.loaded().model_class
        if model_class is None:
            raise InputError(f"{self.name!r} is a fitting method, not a model kind a file can hold")
        return model_class.from_parameters(parameters, encoder=encoder, training=training)

    def loaded(self):
        """This entry with the class and fit function it names imported from its ``module``."""
        named = {field: getattr(self, field) for field in ("model_class", "fit")
                 if isinstance(getattr(self, field), str)}
        if not named:
            return self
        module = importlib.import_module(self.module)
        kind = dataclasses.replace(self, **{field: getattr(module, name) for field, name in named.items()})
        _check_class(kind)
        return kind


#: name -> ModelKind of every registered kind (filled by :mod:`encal.models.registry`).
REGISTERED = {}


def register_kind(kind):
    """Add ``kind`` (a :class:`ModelKind`) to the lookup; :mod:`encal.models.registry` calls it."""
    if not isinstance(kind, ModelKind):
        raise InputError(f"The 'kind' parameter of register_kind must be a ModelKind. "
                         f"Got {type(kind).__name__} instead.")
    named = [field for field in ("model_class", "fit") if isinstance(getattr(kind, field), str)]
    if named and not isinstance(kind.module, str):
        raise InputError(f"the {' and '.join(named)} of kind {kind.name!r} given by name need the module "
                         f"that defines them. Got module={kind.module!r} instead.")
    if not isinstance(kind.model_class, str):  # a class given by name is checked when it is imported
        _check_class(kind)
    REGISTERED[kind.name] = kind
    return kind


def _check_class(kind):
    if kind.model_class is not None and getattr(kind.model_class, "kind", None) != kind.name:
        raise InputError(f"the model class of kind {kind.name!r} must have kind = {kind.name!r}. "
                         f"Got {getattr(kind.model_class, 'kind', None)!r} instead.")


def kind_names(**facts):
    """Names of the registered kinds whose attributes equal ``facts`` (all kinds without any), in the
    order of the registry.

    Examples
    --------
    >>> import encal.models
    >>> kind_names(stack_member=True)
    ['fourier', 'spectral', 'lut', 'hybrid', 'ann']
    """
    return [name for name, kind in REGISTERED.items()
            if all(getattr(kind, fact) == value for fact, value in facts.items())]


def model_kind(name, *, role=None, **facts):
    """The registered :class:`ModelKind` called ``name``.

    Parameters
    ----------
    name : str
    role : str, optional
        What the kind is asked for, for the message (``"method"``, ``"stack member"``, ...).
    **facts
        Attributes the kind must have (``stack_member=True``, ...); a kind without them is refused
        like an unknown one.

    Returns
    -------
    ModelKind
        The entry, its class and fit function imported (:meth:`ModelKind.loaded`).

    Raises
    ------
    InputError
        If no such kind is registered, naming the ones that are.
    """
    kind = REGISTERED.get(name) if isinstance(name, str) else None
    if kind is None or not all(getattr(kind, fact) == value for fact, value in facts.items()):
        what = role or "model kind"
        raise InputError(f"The {what} must be one of {', '.join(kind_names(**facts))}. Got {name!r} instead.")
    loaded = kind.loaded()
    if loaded is not kind:
        REGISTERED[name] = loaded
    return loaded

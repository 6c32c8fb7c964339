"""Stacked model: a weighted mean of member models of other kinds.

Stacked generalisation (Wolpert 1992; Breiman 1996, "stacked regressions"; the
"super learner" of van der Laan et al. 2007) predicts with a convex
combination ``Σ w_i f_i(θ)`` of models that err differently: a Fourier series
smooth between the calibration points and a lookup table through them
average to a better prediction than either. The weights come from the
members' held-out predictions (see :mod:`encal.models.select`); this module
holds the model and fits its members for given weights.

Members are single-profile models of the kinds registered as stack members
(:func:`member_kinds`; :mod:`encal.models.registry`). A
stack of stacks would be a flat stack with the products of the weights, so
members may not be stacks; an encoder whose error depends on the direction of
travel gets a ``directional`` model whose parts may be stacks.
"""

import copy
import math

import numpy as np

from ..errors import InputError, ModelFileError
from ..parameters import check_seed
from ..profile import profile_arrays
from .base import Model
from .kind import kind_names, model_kind

__all__ = ["StackModel", "fit_stack", "member_kinds", "WEIGHT_SUM_TOLERANCE"]


def member_kinds():
    """Names of the kinds a member of a stack may have (``stack_member`` in the registry)."""
    return kind_names(stack_member=True)

#: Largest distance of the weights' sum from 1. The model file's reader applies the same bound.
WEIGHT_SUM_TOLERANCE = 1e-9


class StackModel(Model):
    """A convex combination of member models: ``Σ weights[i] · members[i](θ)``.

    Parameters
    ----------
    members : sequence of Model
        Models of the kinds in :func:`member_kinds` (``'fourier'``, ``'lut'``, ``'ann'``,
        ``'hybrid'``), each predicting the error in arc-minutes.
    weights : sequence of float
        One weight per member, each > 0, summing to 1 within :data:`WEIGHT_SUM_TOLERANCE`.
    encoder, training : dict, optional
        See :class:`~encal.models.base.Model`.

    Attributes
    ----------
    members : tuple of Model
    weights : ndarray of shape (n_members,)

    Examples
    --------
    >>> from encal.models.fourier import FourierModel
    >>> stack = StackModel([FourierModel([0], [1.0], [0.0]), FourierModel([0], [2.0], [0.0])], [0.25, 0.75])
    >>> float(stack.predict(10.0))
    1.75
    >>> stack
    <StackModel 0.25 fourier + 0.75 fourier for unnamed encoder>
    """

    kind = "stack"

    def __init__(self, members, weights, *, encoder=None, training=None):
        super().__init__(encoder=encoder, training=training)
        members = _check_members(members)
        self.members = members
        self.weights = _check_weights(weights, len(members), "StackModel")

    @property
    def evaluation_width(self):
        return max(member.evaluation_width for member in self.members)

    def _predict(self, theta_deg):
        # Left to right, member by member: the order the runtime reader and the C export add in.
        return sum(weight * member._predict(theta_deg) for weight, member in zip(self.weights, self.members))

    def _table_bound(self):
        parts = [member._table_bound() for member in self.members]
        if None in parts:
            return None
        return tuple(sum(abs(float(weight)) * part[i] for weight, part in zip(self.weights, parts)) for i in range(2))

    def free_parameters(self):
        return sum(member.free_parameters() for member in self.members)

    def parameters(self):
        return {"members": [member.file_entry() for member in self.members],
                "weights": [float(weight) for weight in self.weights]}

    @classmethod
    def from_parameters(cls, parameters, *, encoder=None, training=None):
        members = parameters.get("members") if isinstance(parameters, dict) else None
        if not (isinstance(members, list) and members and isinstance(parameters.get("weights"), list)
                and all(isinstance(member, dict) and {"kind", "parameters"} <= set(member) for member in members)):
            shown = sorted(parameters) if isinstance(parameters, dict) else type(parameters).__name__
            raise ModelFileError("stack model parameters must be an object with a non-empty list 'members' of "
                                 "{'kind', 'parameters'} objects and a list 'weights' (docs/model-file.md). "
                                 f"Got {shown} instead.")
        kinds = [member["kind"] for member in members]
        wrong = [kind for kind in kinds if kind not in member_kinds()]
        if wrong:
            raise ModelFileError(f"stack model members must be of kind {', '.join(member_kinds())}. "
                                 f"Got {wrong[0]!r} instead.")
        built = [model_kind(kind).read(member["parameters"]) for kind, member in zip(kinds, members)]
        try:
            return cls(built, parameters["weights"], encoder=encoder, training=training)
        except InputError as exc:
            raise ModelFileError(f"stack model parameters are invalid: {exc}") from None

    def __repr__(self):
        name = self.encoder.get("name") or "unnamed encoder"
        terms = " + ".join(f"{weight:.2g} {member.kind}" for weight, member in zip(self.weights, self.members))
        return f"<StackModel {terms} for {name}>"


def fit_stack(theta_enc_deg, error_arcmin, *, members=None, weights=None, rng=None):
    """Fit every member on all points and combine them with the given weights.

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees.
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.
    members : sequence of dict
        One ``{'family': str, 'options': dict}`` per member: ``family`` one of
        :func:`member_kinds`, ``options`` the keyword options of its fit function
        (:attr:`ModelKind.fit <encal.models.kind.ModelKind>`); ``options`` may be left out.
    weights : sequence of float
        One weight per member, each > 0, summing to 1 within :data:`WEIGHT_SUM_TOLERANCE`.
    rng : None, int >= 0 or numpy.random.Generator
        Seed of the randomised members (``ann``, ``hybrid``). Member ``i`` draws from the
        ``i``-th stream spawned from it, so its fit depends on the seed and its place
        only, not on the other members. ``None`` draws a seed and records it.

    Returns
    -------
    StackModel
        ``training`` holds ``seed``, ``options`` (``members`` and ``weights``) and ``members``,
        the members' own training records (the members' ``training`` is cleared).

    Raises
    ------
    InputError
        If ``members``, ``weights`` or ``rng`` is invalid, or a member's fit rejects its options.

    Examples
    --------
    >>> theta = np.arange(0.0, 360.0, 2.0)
    >>> error = 2.0 * np.sin(np.radians(theta))
    >>> model = fit_stack(theta, error, members=[{"family": "fourier", "options": {"orders": [1]}},
    ...                                          {"family": "lut"}], weights=[0.5, 0.5])
    >>> model
    <StackModel 0.5 fourier + 0.5 lut for unnamed encoder>
    >>> round(float(model.predict(90.0)), 9)
    2.0
    """
    if members is None or weights is None:
        raise InputError("fit_stack expects members and weights: which models to average, and how much of "
                         "each (docs/model-selection.md, 'Stacking')")
    specs = _check_specs(members)
    weights = _check_weights(weights, len(specs), "fit_stack")
    generators, seed = _member_generators(rng, len(specs))
    theta, error = profile_arrays(theta_enc_deg, error_arcmin, "fit_stack")
    fitted = []
    for spec, generator in zip(specs, generators):
        kind = model_kind(spec["family"])
        randomised = {"rng": generator} if kind.randomised else {}
        fitted.append(kind.fit(theta, error, **spec["options"], **randomised))
    training = {
        "seed": seed,
        "options": {"members": specs, "weights": [float(weight) for weight in weights]},
        "members": [member.training for member in fitted],
    }
    for member in fitted:
        member.training = {}
    return StackModel(fitted, weights, training=training)


def _check_members(members):
    if isinstance(members, (str, bytes, dict)) or not hasattr(members, "__iter__"):
        raise InputError(f"The 'members' parameter of StackModel must be a sequence of models. "
                         f"Got {type(members).__name__} instead.")
    members = tuple(members)
    for member in members:
        if not isinstance(member, Model) or member.kind not in member_kinds():
            got = f"a {member.kind!r} model" if isinstance(member, Model) else f"a {type(member).__name__}"
            raise InputError(f"The 'members' parameter of StackModel must hold models of kind "
                             f"{', '.join(member_kinds())}. Got {got} instead.")
    if not members:
        raise InputError("The 'members' parameter of StackModel must hold at least one model. Got none instead.")
    return members


def _check_weights(weights, count, caller):
    """``weights`` as a float array after checking: ``count`` finite values > 0 that sum to 1."""
    start = f"The 'weights' parameter of {caller} must"
    try:
        values = np.asarray(weights)
    except ValueError:  # a ragged nesting
        values = None
    if values is None or values.dtype.kind not in "iuf":
        raise InputError(f"{start} be a sequence of floats. Got {weights!r:.80} instead.")
    values = values.astype(float)  # a copy: the caller's array stays the caller's
    if values.ndim != 1 or values.size != count:
        raise InputError(f"{start} hold one weight per member ({count}). Got {values.size} instead.")
    shown = np.round(values, 12).tolist()
    if not np.all(np.isfinite(values) & (values > 0)):
        raise InputError(f"{start} hold finite floats > 0. Got {shown} instead.")
    total = math.fsum(values.tolist())
    if abs(total - 1.0) > WEIGHT_SUM_TOLERANCE:
        raise InputError(f"{start} sum to 1 (within {WEIGHT_SUM_TOLERANCE:g}). Got {shown}, "
                         f"summing to {total!r}, instead.")
    return values


def _check_specs(members):
    """The members of :func:`fit_stack` as ``[{'family': str, 'options': dict}, ...]``, the options copied
    so that the training record keeps what was fitted."""
    expected = (f"The 'members' parameter of fit_stack must be a non-empty list of {{'family': ..., "
                f"'options': {{...}}}} with family one of {', '.join(member_kinds())} and no 'rng' option")
    if isinstance(members, (str, bytes, dict)) or not hasattr(members, "__iter__"):
        raise InputError(f"{expected}. Got {type(members).__name__} instead.")
    specs = []
    for i, member in enumerate(members):
        if not isinstance(member, dict) or not set(member) <= {"family", "options"}:
            raise InputError(f"{expected}. Got {member!r:.80} for member {i} instead.")
        family, options = member.get("family"), member.get("options", {})
        if family not in member_kinds():
            raise InputError(f"{expected}. Got family {family!r} for member {i} instead.")
        if not isinstance(options, dict) or "rng" in options:
            raise InputError(f"{expected}. Got options {options!r:.80} for member {i} instead.")
        specs.append({"family": family, "options": copy.deepcopy(options)})
    if not specs:
        raise InputError(f"{expected}. Got an empty list instead.")
    return specs


def _member_generators(rng, count):
    """``(generators, seed)``: an independent random stream per member, and the int seed to record (or None).

    An int seed (for None, a freshly drawn one) is spawned into child streams, member ``i``'s the
    ``i``-th child whatever the number and kinds of the others; a Generator spawns its own children.
    """
    rng = check_seed(rng, "rng", "fit_stack")
    if rng is None:
        rng = int(np.random.SeedSequence().generate_state(1)[0])
    if isinstance(rng, np.random.Generator):
        return rng.spawn(count), None
    return [np.random.default_rng(s) for s in np.random.SeedSequence(rng).spawn(count)], rng

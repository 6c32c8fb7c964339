"""Choose the model family by cross-validation: ``fit(cal, method='auto')``.

No family wins everywhere. A few Fourier orders describe a resolver's smooth
error and average out its noise; a lookup table follows kinks that no short
series can; a network, or a Fourier series plus a network, follows a local
defect. :func:`fit_auto` measures, instead of guessing, which one predicts the
error *between* calibration points best:

1. Sort the distinct encoder angles and deal them round-robin into ``k`` folds
   (the ``i``-th goes to fold ``i mod k``), so every fold is spread evenly round
   the circle and holding it out removes isolated points: each held-out point
   is predicted from neighbours on both sides, two grid steps apart. That is
   interpolation between calibration points, which is what correcting a live
   reading is.
2. Fit every candidate on ``k - 1`` folds and predict the held-out one; each
   candidate's data-driven choices (the Fourier order set, the network's
   weights) are made inside the fold, from the training folds alone. With
   ``use_grid=True`` and a calibration on a uniform grid of ``N`` points (a
   motor's full steps), the Fourier candidates are told so (``grid_points=N``):
   a fold's training part is a subset of that grid, and orders up to ``N / 2``
   stay distinguishable at its nodes, the per-step alternation among them.
3. Pool the held-out residuals of all folds into a CV RMS and MAE per
   candidate.
4. Stack: the convex combination of at most three candidates whose held-out
   predictions best fit the measured errors is one more candidate, its own
   accuracy cross-validated over the same folds (:func:`cross_validate_stack`).
   Candidates that err differently, a Fourier series smooth between the points
   and a lookup table through them, average to a better prediction than either.
5. Pick the lowest RMS, but prefer the simplest candidate whose RMS is within
   ``tolerance`` of it (see :func:`families`; a stack is the least simple),
   and refit that candidate, or every member of the stack, on all points (see
   :func:`_final_fit`).

The CV table and the reason for the choice are kept in
``model.training['selection']``. See ``docs/model-selection.md``.
"""

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from .._core.errors import EncalError, EncalWarning, InputError
from .._core.parameters import check_bool, check_int, check_number, check_seed
from ..analysis.profile import distinct_angles, profile_arrays, uniform_grid
from .kind import kind_names, model_kind
from .validation import held_out_predictions, interleaved_folds

__all__ = [
    "Candidate",
    "DEFAULT_CANDIDATES",
    "families",
    "CVScore",
    "free_parameters",
    "interleaved_folds",
    "cross_validate",
    "stack_weights",
    "cross_validate_stack",
    "choose",
    "fit_auto",
    "format_selection",
]

#: Folds when the caller names none (see docs/model-selection.md for why 5).
DEFAULT_FOLDS = 5

#: Fewest distinct angles per fold that ``folds`` may leave.
MIN_POINTS_PER_FOLD = 4

#: Most fits of the chosen candidate on all points (see :func:`_final_fit`).
FINAL_FIT_ATTEMPTS = 3

def families():
    """The families auto can choose from, simplest first: the registered kinds with a ``simplicity`` rank.

    A Fourier series is a closed-form least-squares fit of a few physically meaningful
    coefficients; a lookup table is closed-form too but keeps one value per point; a hybrid and a
    network are trained iteratively from a random start, the network with the most free weights of
    all; a stack needs all of its members. Within a family, fewer free parameters is simpler.
    """
    ranked = [model_kind(name) for name in kind_names() if model_kind(name).simplicity is not None]
    return tuple(kind.name for kind in sorted(ranked, key=lambda kind: kind.simplicity))


#: A stacked candidate combines at most this many candidates ...
STACK_MAX_MEMBERS = 3
#: ... each with at least this weight (a smaller share changes the prediction by less than
#: the spread of the fold models, and costs a whole member in firmware).
STACK_MIN_WEIGHT = 0.05


@dataclass(frozen=True)
class Candidate:
    """One model family with fixed options, as auto tries it.

    Parameters
    ----------
    family : str
        Model family, one of :func:`families` (``'fourier'``, ``'lut'``, ``'hybrid'``, ``'ann'``, ``'stack'``).
    options : dict, optional
        Keyword options of the family's fit function (``fit_fourier``, ...).
    """

    family: str
    options: dict = field(default_factory=dict)

    def __post_init__(self):
        # The family is checked where the candidate is used (:func:`fit_auto`): the registry of kinds
        # is filled after this module is imported.
        if not isinstance(self.family, str):
            raise InputError(f"a candidate's family must be a name (str). Got {self.family!r} instead.")

    def as_dict(self):
        """``{'family': ..., 'options': {...}}``, JSON-ready; ``Candidate(**d)`` rebuilds it."""
        return {"family": self.family, "options": dict(self.options)}

    @property
    def label(self):
        """Short name, e.g. ``'ann hidden=10 algorithm=trainbr'``, or for a stack
        ``'stack 0.62 fourier select=cv + 0.38 lut interpolation=cubic'``."""
        if self.family == "stack" and set(self.options) >= {"members", "weights"}:
            parts = (f"{weight:.2f} {_as_candidate(member).label}"
                     for member, weight in zip(self.options["members"], self.options["weights"]))
            return "stack " + " + ".join(parts)
        return " ".join([self.family, *(f"{key}={value:.4g}" if isinstance(value, float) else f"{key}={value}"
                                        for key, value in self.options.items())])

    def fit(self, theta_deg, error_arcmin, rng=None, grid_points=None):
        """Fit this candidate.

        ``rng`` is passed only to the families that draw random numbers; ``grid_points`` (the
        uniform grid the whole calibration lies on, for a fold's fit) only to those that use it,
        and only if the options do not set it.
        """
        kind = model_kind(self.family)
        options = dict(self.options)
        if kind.randomised:
            options["rng"] = rng
        if grid_points is not None and kind.grid_aware:
            options.setdefault("grid_points", grid_points)
        return kind.fit(theta_deg, error_arcmin, **options)


#: The candidates of ``fit_auto`` when none are given: the paper's Fourier model and
#: one whose order count is chosen by (inner) cross-validation, both lookup tables,
#: the hybrid, and periodic-input networks of three sizes trained by trainlm for 100
#: or 300 epochs. The epoch cap is early stopping: a network trained for MATLAB's 1000
#: epochs bends between the points to fit their noise and cross-validates several times
#: worse on the real calibrations (docs/model-selection.md gives the figures and the cost).
DEFAULT_CANDIDATES = (
    Candidate("fourier", {"select": "top", "n_orders": 10}),
    Candidate("fourier", {"select": "cv"}),
    Candidate("lut", {"interpolation": "linear"}),
    Candidate("lut", {"interpolation": "cubic"}),
    Candidate("hybrid", {}),
    *(Candidate("ann", {"hidden": hidden, "algorithm": "trainlm", "epochs": epochs})
      for hidden in (6, 12, 20) for epochs in (100, 300)),
)


@dataclass(frozen=True)
class CVScore:
    """Cross-validated accuracy of one candidate.

    Attributes
    ----------
    candidate : Candidate
    rms_arcmin, mae_arcmin : float
        RMS and mean absolute value of the held-out residuals of all folds, arcmin.
    max_abs_arcmin : float
        Largest absolute held-out residual, arcmin.
    n_parameters : float
        Free parameters of the fold models (see :func:`free_parameters`), averaged over the folds.
    time_s : float
        Wall-clock time of the ``k`` fold fits, seconds.
    error : str or None
        Why the candidate could not be fitted (its score is then infinite), else None.
    predictions : ndarray of shape (n,) or None
        Held-out prediction of every point, arcmin (None if the candidate failed); the
        stacked candidate is made from these. Not part of the CV table.
    """

    candidate: Candidate
    rms_arcmin: float
    mae_arcmin: float
    max_abs_arcmin: float
    n_parameters: float
    time_s: float
    error: str | None = None
    predictions: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def simplicity(self):
        """Sort key of the tie rule: the family's rank (:func:`families`), then free parameters."""
        return (model_kind(self.candidate.family).simplicity, self.n_parameters)

    def as_dict(self):
        """One row of the CV table, JSON-ready."""
        row = {
            "family": self.candidate.family,
            "options": dict(self.candidate.options),
            "label": self.candidate.label,
            "cv_rms_arcmin": _finite_or_none(self.rms_arcmin),
            "cv_mae_arcmin": _finite_or_none(self.mae_arcmin),
            "cv_max_abs_arcmin": _finite_or_none(self.max_abs_arcmin),
            "n_parameters": _finite_or_none(self.n_parameters),
            "time_s": round(self.time_s, 3),
        }
        if self.error is not None:
            row["error"] = self.error
        return row


def free_parameters(parameters, kind):
    """Number of fitted values in a model's ``parameters()`` (layout of ``docs/model-file.md``).

    Fourier: its coefficients (order 0 has one); lookup table: its entries (the interpolation
    derives the rest); network: its weights and biases; hybrid and stack: the sum of their parts
    (see each kind's :meth:`~encal.models.base.Model.free_parameters`).
    """
    return model_kind(kind, role="kind of free_parameters").read(parameters).free_parameters()


def _finite_or_none(value):
    return float(value) if np.isfinite(value) else None


def cross_validate(theta_deg, error_arcmin, candidate, fold, *, seeds, grid_points=None):
    """Held-out accuracy of one candidate over the given folds.

    Parameters
    ----------
    theta_deg, error_arcmin : ndarray of shape (n,)
        Encoder angles (degrees) and errors (arcmin).
    candidate : Candidate
    fold : ndarray of int of shape (n,)
        Fold of each point, from :func:`interleaved_folds`.
    seeds : sequence of numpy.random.SeedSequence
        One per fold, for the randomised families.
    grid_points : int, optional
        The calibration lies on a uniform grid of so many points per revolution
        (:func:`~encal.analysis.profile.uniform_grid`): the Fourier fold fits may use orders up
        to its Nyquist order although each fold's training part has gaps.

    Returns
    -------
    CVScore
    """
    seeds = list(seeds)
    n_parameters = []

    def fit_predict(k, train_theta, train_error, test_theta):
        model = candidate.fit(train_theta, train_error, rng=np.random.default_rng(seeds[k]),
                              grid_points=grid_points)
        n_parameters.append(model.free_parameters())
        return model.predict(test_theta)

    start = time.perf_counter()
    try:
        held_out = error_arcmin - held_out_predictions(fit_predict, theta_deg, error_arcmin, fold)
    except EncalError as exc:  # e.g. too few points for this family
        return CVScore(candidate, np.inf, np.inf, np.inf, np.inf, time.perf_counter() - start, error=str(exc))
    elapsed = time.perf_counter() - start
    if not np.all(np.isfinite(held_out)):
        return CVScore(candidate, np.inf, np.inf, np.inf, np.inf, elapsed, error="non-finite predictions")
    return CVScore(
        candidate,
        rms_arcmin=float(np.sqrt(np.mean(held_out**2))),
        mae_arcmin=float(np.mean(np.abs(held_out))),
        max_abs_arcmin=float(np.max(np.abs(held_out))),
        n_parameters=float(np.mean(n_parameters)),
        time_s=elapsed,
        predictions=error_arcmin - held_out,
    )


def stack_weights(predictions, error_arcmin, *, max_members=STACK_MAX_MEMBERS, min_weight=STACK_MIN_WEIGHT):
    """Convex weights that best combine held-out predictions (stacked generalisation).

    Minimises ``||error - weights @ predictions||`` over weights ``>= 0`` that sum to 1 (Breiman's
    stacked regression with the super learner's convex constraint), then drops the candidate of
    smallest weight and solves again while a weight is below ``min_weight`` or more than
    ``max_members`` are left.

    Parameters
    ----------
    predictions : ndarray of shape (m, n)
        Held-out predictions of ``m`` candidates at ``n`` points, arcmin.
    error_arcmin : ndarray of shape (n,)
        Measured errors at those points, arcmin.
    max_members : int, default=STACK_MAX_MEMBERS
        Most candidates left with a non-zero weight.
    min_weight : float, default=STACK_MIN_WEIGHT
        Smallest weight a candidate may keep (a fraction of 1).

    Returns
    -------
    ndarray of shape (m,)
        Weights, ``>= 0``, summing to 1; at most ``max_members`` are non-zero.

    Examples
    --------
    >>> a, b = np.array([1.0, 0.0, 1.0]), np.array([0.0, 1.0, 1.0])
    >>> stack_weights(np.array([a, b]), 0.25 * a + 0.75 * b).round(12).tolist()
    [0.25, 0.75]
    """
    import scipy.optimize

    predictions = np.asarray(predictions, dtype=float)
    error = np.asarray(error_arcmin, dtype=float)
    active = np.arange(predictions.shape[0])
    # The sum-to-one constraint as one heavily weighted extra equation of the non-negative fit.
    # Its scale follows the data's; where predictions and errors are all zero any convex weights fit them.
    scale = max(float(np.sqrt(np.mean(predictions**2))), float(np.sqrt(np.mean(error**2))))
    penalty = 1e3 * (scale if scale > 0.0 else 1.0)
    while True:
        system = np.vstack([predictions[active].T, np.full((1, active.size), penalty)])
        solution, _ = scipy.optimize.nnls(system, np.append(error, penalty))
        solution = solution / solution.sum()
        if active.size == 1 or (solution.min() >= min_weight and active.size <= max_members):
            break
        active = np.delete(active, np.argmin(solution))
    weights = np.zeros(predictions.shape[0])
    weights[active] = solution
    return weights


def cross_validate_stack(error_arcmin, scores, fold):
    """The stacked candidate of ``scores`` and its held-out accuracy, or None if it has one member.

    The weights are fitted to the candidates' held-out predictions of all points
    (:func:`stack_weights`). Their accuracy is cross-validated over the same folds: the
    weights of fold ``k`` are fitted to the held-out predictions of the other folds and
    applied to fold ``k``, so the stacked RMS is measured on points its weights did not see.

    Parameters
    ----------
    error_arcmin : ndarray of shape (n,)
        Measured errors, arcmin.
    scores : sequence of CVScore
        The candidates' scores from :func:`cross_validate` (with their ``predictions``).
    fold : ndarray of int of shape (n,)
        The folds the scores were made with.

    Returns
    -------
    CVScore or None
        A ``'stack'`` candidate whose options name its members (``Candidate.as_dict`` form)
        and weights.
    """
    usable = [score for score in scores if score.predictions is not None and np.isfinite(score.rms_arcmin)]
    if len(usable) < 2:
        return None
    start = time.perf_counter()
    predictions = np.array([score.predictions for score in usable])
    weights = stack_weights(predictions, error_arcmin)
    if np.count_nonzero(weights) < 2:
        return None
    held_out = np.empty_like(error_arcmin)
    for k in range(fold.max() + 1):
        test = fold == k
        held_out[test] = error_arcmin[test] - stack_weights(predictions[:, ~test], error_arcmin[~test]) \
            @ predictions[:, test]
    members = [(score, weight) for score, weight in zip(usable, weights) if weight > 0]
    candidate = Candidate("stack", {"members": [score.candidate.as_dict() for score, _ in members],
                                    "weights": [float(weight) for _, weight in members]})
    return CVScore(
        candidate,
        rms_arcmin=float(np.sqrt(np.mean(held_out**2))),
        mae_arcmin=float(np.mean(np.abs(held_out))),
        max_abs_arcmin=float(np.max(np.abs(held_out))),
        n_parameters=float(sum(score.n_parameters for score, _ in members)),
        time_s=sum(score.time_s for score, _ in members) + time.perf_counter() - start,
        predictions=error_arcmin - held_out,
    )


def choose(scores, tolerance=0.01, resolution_arcmin=0.0):
    """The candidate to use, and why: the simplest within ``tolerance`` of the lowest CV RMS.

    Parameters
    ----------
    scores : sequence of CVScore
    tolerance : float, default=0.01
        Relative margin: candidates with ``rms <= (1 + tolerance) * best_rms + resolution_arcmin``
        count as tied.
    resolution_arcmin : float, default=0
        Absolute margin, arc-minutes: differences this small are rounding, not accuracy (it decides
        between candidates that all reproduce a noise-free profile to ~1e-15 arcmin).

    Returns
    -------
    (CVScore, str)
        The chosen score and one sentence saying why it was chosen.
    """
    finite = [score for score in scores if np.isfinite(score.rms_arcmin)]
    if not finite:
        raise InputError("no candidate model could be fitted to this calibration; "
                         f"the first failure was: {scores[0].error}")
    best = min(finite, key=lambda score: score.rms_arcmin)
    limit = (1.0 + tolerance) * best.rms_arcmin + resolution_arcmin
    tied = [score for score in finite if score.rms_arcmin <= limit]
    chosen = min(tied, key=lambda score: (score.simplicity, score.rms_arcmin))
    if chosen is best:
        runner_up = min((s for s in finite if s is not best), key=lambda s: s.rms_arcmin, default=None)
        margin = "" if runner_up is None else (
            f"; the next best, {_name(runner_up.candidate)}, has {runner_up.rms_arcmin:.4g} arcmin")
        reason = f"{_name(best.candidate)} has the lowest CV RMS, {best.rms_arcmin:.4g} arcmin{margin}"
    else:
        reason = (f"{_name(chosen.candidate)} (CV RMS {chosen.rms_arcmin:.4g} arcmin) is within "
                  f"{tolerance:.0%} of the lowest, {_name(best.candidate)} ({best.rms_arcmin:.4g} arcmin), "
                  "and simpler")
    return chosen, reason


def _name(candidate):
    """A candidate's label, or for a stack (whose label lists every member) ``'the stack of 3'``."""
    if candidate.family == "stack" and "members" in candidate.options:
        return f"the stack of {len(candidate.options['members'])}"
    return candidate.label


def _as_candidate(item):
    if isinstance(item, Candidate):
        if item.family not in families():
            raise InputError(f"a candidate's family must be one of {', '.join(families())}. "
                             f"Got {item.family!r} instead.")
        return item
    if isinstance(item, dict) and set(item) <= {"family", "options"} and "family" in item:
        return _as_candidate(Candidate(item["family"], dict(item.get("options") or {})))
    raise InputError("The 'candidates' parameter of fit_auto must hold Candidate objects or "
                     f"{{'family': ..., 'options': {{...}}}} dicts. Got {item!r} instead.")


def _seed_sequence(rng):
    rng = check_seed(rng, "rng", "fit_auto")
    if isinstance(rng, np.random.Generator):
        return np.random.SeedSequence(int(rng.integers(2**63)))
    return np.random.SeedSequence(rng)


def fit_auto(theta_enc_deg, error_arcmin, *, rng=None, folds=None, candidates=None, tolerance=0.01,
             use_grid=False, stack=True):
    """Fit the model family that cross-validates best.

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles of the calibration points, degrees.
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` at those points, arc-minutes.
    rng : int or numpy.random.Generator, optional
        Seed of the networks' initial weights; the same seed gives the same choice and model.
    folds : int, optional
        Number of interleaved, circular cross-validation folds. By default 5, or fewer (down to 2) when
        the calibration has fewer than 20 distinct angles. From 2 to a quarter of the
        number of distinct encoder angles.
    candidates : sequence of Candidate or dict, optional
        Families and options to choose from, as :class:`Candidate` objects or
        ``{'family': ..., 'options': {...}}`` dicts; :data:`DEFAULT_CANDIDATES` by default.
    tolerance : float, default=0.01
        Tie rule: the simplest candidate whose CV RMS is within this fraction of the lowest wins.
    use_grid : bool, default=False
        Validate for readings *at the calibrated steps*: when the calibration lies on a uniform
        grid of ``N`` points, the Fourier candidates' fold fits are told so (``grid_points=N``),
        may use orders up to ``N / 2`` and are scored at the held-out grid nodes, so a per-step
        pattern that repeats at the steps (a stepper's alternation) can win. By default the
        folds are validated for readings *between* the points (orders up to what each fold's
        gaps allow), which favours smooth models; see docs/model-selection.md for what each
        costs on the other use.
    stack : bool, default=True
        Also try the convex combination of at most :data:`STACK_MAX_MEMBERS` candidates that best
        predicts the held-out points (:func:`cross_validate_stack`), cross-validated like the rest
        and last in the tie rule: a single candidate within ``tolerance`` of it wins. The
        chosen stack is a :class:`~encal.models.stack.StackModel`. ``False`` chooses one family.

    Returns
    -------
    Model
        The chosen candidate refitted on all points. ``model.training['selection']`` holds
        ``folds``, ``scheme``, ``tolerance``, ``table`` (one row per candidate: ``family``,
        ``options``, ``label``, ``cv_rms_arcmin``, ``cv_mae_arcmin``, ``cv_max_abs_arcmin``,
        ``time_s``), ``chosen`` (the label) and ``reason`` (one sentence).

    Examples
    --------
    >>> import numpy as np
    >>> theta = np.arange(0.0, 360.0, 2.0)
    >>> error = 3.0 * np.sin(np.radians(theta)) + 0.5 * np.cos(np.radians(4 * theta))
    >>> model = fit_auto(theta, error, rng=0)
    >>> model.training["selection"]["chosen"], model.orders.tolist()
    ('fourier select=cv', [1, 4])
    """
    theta, error = profile_arrays(theta_enc_deg, error_arcmin, "fit_auto")
    distinct = distinct_angles(theta)[0]
    if distinct.size < 2:
        raise InputError("fit_auto expects at least 2 distinct encoder angles to cross-validate; "
                         f"got {theta.size} readings all at {distinct[0]:.9g} degrees")
    most = max(distinct.size // MIN_POINTS_PER_FOLD, 2)
    if folds is None:
        folds = min(DEFAULT_FOLDS, most)
    folds = check_int(folds, "folds", "fit_auto", low=2, high=most,
                      note=f"at least {MIN_POINTS_PER_FOLD} distinct encoder angles per fold")
    use_grid = check_bool(use_grid, "use_grid", "fit_auto")
    stack = check_bool(stack, "stack", "fit_auto")
    tolerance = check_number(tolerance, "tolerance", "fit_auto", low=0.0, high=1.0, high_open=True)
    given = candidates
    candidates = tuple(_as_candidate(c) for c in (DEFAULT_CANDIDATES if candidates is None else candidates))
    if not candidates:
        raise InputError("The 'candidates' parameter of fit_auto must be a non-empty sequence of Candidate. "
                         "Got an empty sequence instead.")

    fold = interleaved_folds(theta, folds)
    # A calibration on N steps: each fold's training part is a subset of that grid, and at its
    # nodes orders up to N/2 stay distinguishable (docs/model-selection.md, the per-step pattern);
    # scored at the nodes, which is right for readings at the steps, optimistic between them.
    nodes = uniform_grid(theta) if use_grid else None
    grid_points = None if nodes is None else nodes.size
    if use_grid and nodes is None:
        warnings.warn(EncalWarning(
            f"use_grid (--at-steps) has no effect: the {distinct_angles(theta)[0].size} encoder angles "
            "do not lie on a uniform grid "
            "(each within a quarter step of its own node), so the candidates are validated between the "
            "points as by default"), stacklevel=3)
    # One seed stream per candidate (k fold fits, then the final fit and its retries),
    # so a candidate's result does not depend on which other candidates were tried.
    streams = [seq.spawn(folds + FINAL_FIT_ATTEMPTS) for seq in _seed_sequence(rng).spawn(len(candidates))]
    scores = [cross_validate(theta, error, c, fold, seeds=s[:folds], grid_points=grid_points)
              for c, s in zip(candidates, streams)]
    final_seeds = {id(score): stream[folds:] for score, stream in zip(scores, streams)}
    stacked = cross_validate_stack(error, scores, fold) if stack else None
    if stacked is not None:
        scores.append(stacked)
    # Differences below 1e-9 of the profile's RMS are rounding error, not accuracy.
    chosen, reason = choose(scores, tolerance, resolution_arcmin=1e-9 * float(np.sqrt(np.mean(error**2))))

    if chosen is stacked:
        model, attempts = _final_stack(theta, error, stacked, scores, final_seeds)
    else:
        model, attempts = _final_fit(theta, error, chosen, final_seeds[id(chosen)])
    # The auto seed regenerates the whole choice; a part's own seed would not.
    model.training["seed"] = int(rng) if isinstance(rng, (int, np.integer)) else None
    model.training["fit_options"] = {"folds": int(folds), "tolerance": float(tolerance)}
    if use_grid:
        model.training["fit_options"]["use_grid"] = True
    if not stack:
        model.training["fit_options"]["stack"] = False
    if given is not None:
        model.training["fit_options"]["candidates"] = [c.as_dict() for c in candidates]
    model.training["selection"] = {
        "folds": int(folds),
        "scheme": "interleaved circular: i-th distinct angle in increasing order in fold i mod folds",
        "tolerance": float(tolerance),
        "table": [score.as_dict() for score in scores],
        "chosen": chosen.candidate.label,
        "reason": reason,
        "final_fit_attempts": attempts,
    }
    return model


def _final_stack(theta, error, stacked, scores, final_seeds):
    """Refit every member of the chosen stack on all points (:func:`_final_fit`) and combine them.

    Returns
    -------
    (StackModel, int)
        The model and the number of fits made, all members together.
    """
    by_label = {score.candidate.label: score for score in scores if score is not stacked}
    members, trainings, attempts = [], [], 0
    for member in stacked.candidate.options["members"]:
        score = by_label[_as_candidate(member).label]
        model, made = _final_fit(theta, error, score, final_seeds[id(score)])
        members.append(model)
        trainings.append(model.training)
        model.training = {}
        attempts += made
    training = {"options": {key: list(value) for key, value in stacked.candidate.options.items()},
                "members": trainings}
    stack_class = model_kind("stack").model_class
    return stack_class(members, stacked.candidate.options["weights"], training=training), attempts


def _final_fit(theta, error, chosen, seeds):
    """Refit the chosen candidate on all points; retry a network that fits worse than it validated.

    A network fitted to all points should fit them at least as well as its fold models predicted
    points they had not seen. When it does not (training RMS above the CV RMS), training ended in
    a poor local minimum from an unlucky start: try the next seed, up to ``len(seeds)`` fits, and
    keep the first that passes or else the one that fits best.

    Returns
    -------
    (Model, int)
        The model and the number of fits made.
    """
    best = None
    for attempt, seed in enumerate(seeds, start=1):
        model = chosen.candidate.fit(theta, error, rng=np.random.default_rng(seed))
        fitted_rms = float(np.sqrt(np.mean((error - model.predict(theta)) ** 2)))
        if best is None or fitted_rms < best[0]:
            best = (fitted_rms, model, attempt)
        if not model_kind(chosen.candidate.family).randomised or fitted_rms <= chosen.rms_arcmin:
            return model, attempt
    return best[1], len(seeds)


def format_selection(selection):
    """The CV table and the reason of an auto fit, as text for a terminal.

    Parameters
    ----------
    selection : dict
        ``model.training['selection']`` of a model made by :func:`fit_auto` (also after a
        save/load round trip).

    Returns
    -------
    str
        One line per candidate, lowest CV RMS first, the chosen one marked ``*``, then the reason.
    """
    rows = sorted(selection["table"], key=lambda row: (row["cv_rms_arcmin"] is None, row["cv_rms_arcmin"] or 0.0))
    # A stack's label names all its members; the table shows a short name and lists them below it.
    shown = {id(row): (f"stack of {len(row['options']['members'])} (below)" if row["family"] == "stack"
                       else row["label"]) for row in rows}
    width = max(len(name) for name in shown.values())
    lines = [f"cross-validation over {selection['folds']} interleaved folds (arcmin):",
             f"    {'candidate':<{width}}  {'CV RMS':>9}  {'CV MAE':>9}  {'params':>6}  {'time':>7}"]
    for row in rows:
        mark = "*" if row["label"] == selection["chosen"] else " "
        name = shown[id(row)]
        if row["cv_rms_arcmin"] is None:
            lines.append(f"  {mark} {name:<{width}}  failed: {row.get('error', 'no finite prediction')}")
            continue
        lines.append(f"  {mark} {name:<{width}}  {row['cv_rms_arcmin']:#9.4g}  {row['cv_mae_arcmin']:#9.4g}  "
                     f"{row['n_parameters']:6.0f}  {_seconds(row['time_s'])}")
    for row in rows:
        if row["family"] == "stack":
            members = zip(row["options"]["weights"], row["options"]["members"])
            lines.append("stack of {}: {}".format(len(row["options"]["members"]), " + ".join(
                f"{weight:.2f} x ({_as_candidate(member).label})" for weight, member in members)))
    lines.append(f"chosen: {selection['reason']}")
    return "\n".join(lines)


def _seconds(time_s):
    """A CV-table time; reproducible model files store none."""
    return "      -" if time_s is None else f"{time_s:6.2f}s"

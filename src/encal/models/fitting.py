"""``fit`` and ``evaluate``: the public entry points from a calibration to a model and back.

Each model kind provides ``fit_<kind>(theta_enc_deg, error_arcmin, **options) -> Model`` on plain
arrays, listed in the registry of kinds (:mod:`encal.models.registry`); :func:`fit` takes a
:class:`~encal.data.calibration.Calibration`, looks ``method`` up there, and records the encoder and where the
model came from.
"""

import hashlib
import inspect
from dataclasses import dataclass

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, resolution_of_readings, wrap180
from ..data.reversal import (
    MODES as BIDIRECTIONAL_MODES,
    direction_subset,
    has_both_directions,
    mean_calibration,
    require_directions,
    reversal,
)
from ..data.calibration import Calibration, check_folds, turn_checked_errors, warn_if_in_radians
from .._core.errors import CalibrationError, InputError
from . import Model, kind_names, model_kind
from .._core.parameters import check_bool, check_choice, check_seed, check_type
from ..analysis.profile import (ARBITRARY_ZERO_ARCMIN, ZERO_MODES, ErrorStats, correction_is_worse, error_stats,
                                remove_offset, worse_sentence, zero_is_arbitrary, zero_offset_arcmin, zero_sentence)
from .uncertainty import (add_mean_uncertainty, add_part_uncertainties, estimate_uncertainty, has_posterior,
                          refit_spec, with_half_reversal, with_reference_uncertainty)
from .._core.threads import single_blas_thread

__all__ = ["fit", "fit_bidirectional", "evaluate", "Evaluation", "fitter", "calibration_sha256", "resolution_bits"]


def calibration_sha256(cal):
    """SHA-256 (hex) of a calibration's angles, to tie a model to the data it was fitted on."""
    digest = hashlib.sha256()
    for array in (cal.reference_deg, cal.encoder_deg):
        digest.update(np.ascontiguousarray(array, dtype="<f8").tobytes())
    if cal.direction is not None:
        digest.update(np.ascontiguousarray(cal.direction, dtype="i1").tobytes())
    return digest.hexdigest()


def fitter(method):
    """The fit function of a method: ``fit_<kind>(theta_enc_deg, error_arcmin, **options) -> Model``."""
    methods = [name for name in kind_names() if model_kind(name).fit is not None]
    if method not in methods:
        raise InputError(f"The 'method' parameter of fit must be one of {', '.join(methods)}. "
                         f"Got {method!r} instead.")
    return model_kind(method).fit


@single_blas_thread
def fit(cal, method="auto", *, rng=None, uncertainty=False, bidirectional=None, **options):
    """Fit an error model to a calibration.

    Parameters
    ----------
    cal : Calibration
        The calibration run (encoder readings and reference angles in degrees).
    method : {'auto', 'fourier', 'lut', 'ann', 'hybrid', 'stack'}, default='auto'
        Model family; ``'auto'`` chooses by cross-validation; ``'stack'`` is a weighted mean of
        members of the other families.
    rng : int or numpy.random.Generator, optional
        Seed for the methods that draw random numbers (network initialisation) and, with
        ``uncertainty=True``, for the bootstrap; ``'fourier'`` and ``'lut'`` use it only then and ignore
        it otherwise. When None and one is needed, a seed is drawn and recorded as ``model.training['seed']``, so the
        model file says how to fit the same model again.
    uncertainty : bool, default=False
        Also estimate the prediction uncertainty (bootstrap refits; see :mod:`encal.models.uncertainty`), so that
        ``model.predict(theta, return_std=True)`` works. Costs 30 (Fourier) to 100 (lookup table, networks) refits.
    bidirectional : {'per-direction', 'mean'}, optional
        How to fit a calibration whose ``direction`` column holds both directions of travel (+1 and -1);
        see :func:`fit_bidirectional`. Default ``'per-direction'``: one model per direction, in a
        ``'directional'`` model that corrects each reading with its direction's profile (and with their
        mean when the direction is not known). ``'mean'``: one model of the two directions' mean. Only for
        such a calibration.
    **options
        Passed to the family's fit function (``hidden``, ``algorithm``, ``encoding`` for ``'ann'``;
        ``orders``, ``n_orders``, ``select`` for ``'fourier'``; ``interpolation`` for ``'lut'``;
        ``members`` and ``weights`` for ``'stack'``).

    Returns
    -------
    Model
        Predicts the error ``encoder - reference`` in arc-minutes from the encoder angle in degrees (and
        the direction of travel, for a ``'directional'`` model).

    Raises
    ------
    InputError
        If the method or an option is invalid.
    CalibrationError
        If the encoder goes back while the reference goes forward, so that the error is not a function
        of the encoder angle (see :func:`~encal.data.calibration.check_folds`), or does not turn once per turn
        of the reference (angles in another unit, see :func:`~encal.data.calibration.check_turns`).

    Examples
    --------
    >>> import numpy as np, encal
    >>> ref = np.arange(0.0, 360.0, 2.0)
    >>> cal = encal.Calibration(ref, ref + np.sin(np.radians(ref)) / 60)   # 1 arcmin first harmonic
    >>> model = encal.fit(cal, method="fourier", orders=[0, 1])
    >>> round(float(model.predict(90.0 + 1 / 60)), 3)
    1.0
    """
    check_type(cal, Calibration, "cal", "fit", "a Calibration")
    fitter(method)  # an unknown method is refused before anything else
    _check_not_empty(cal, "fit")
    arc = calibrated_arc(cal)
    if arc is not None and cal.source is None:  # a file's reader has warned already
        warn_if_in_radians(cal)
    if arc is not None and method == "auto":
        method = "arc"  # over an arc the error is no periodic function: the interval's family
    if arc is not None and method not in ON_AN_ARC:
        from .._core.arcs import describe_range

        raise InputError(
            f"{cal.source or cal.name or 'the calibration'} covers only an arc ({describe_range(list(arc))} of the "
            f"encoder angle), and --method {method} fits a periodic model, which points over part of a turn do not "
            "pin down between them: it can swing far from the error inside the arc itself; expected the default "
            "(the arc family: leave out --method) or "
            f"{', '.join('--method ' + m for m in ON_AN_ARC if m != 'arc')}")
    model = _fit(cal, method, rng=rng, uncertainty=uncertainty, bidirectional=bidirectional, **options)
    if arc is not None:
        model.range_deg = list(arc)  # never a number where the encoder was not calibrated (encal._core.arcs)
    return model


def _check_not_empty(cal, caller):
    if len(cal) == 0:
        where = cal.source or cal.name or "the calibration"
        raise CalibrationError(f"{caller} expects a calibration with points; {where} has none")


#: The methods fitted on a calibration over an arc: the interval's own family, and the lookup table, which
#: interpolates between neighbouring points and says nothing past the arc's ends (its range is recorded).
ON_AN_ARC = ("arc", "lut")


def calibrated_arc(cal):
    """The arc ``(start, end)`` (degrees of the encoder angle) a calibration covers when it leaves one gap over
    30 degrees, else None (a full turn or scattered gaps)."""
    from .._core.arcs import arc_of
    from ..data.calibration import MAX_GAP_DEG, remembered

    return remembered(cal, "arc", lambda known: arc_of(known.encoder_deg, MAX_GAP_DEG))


def _fit(cal, method, *, rng=None, uncertainty=False, bidirectional=None, **options):
    rng = check_seed(rng, "rng", "fit")
    uncertainty = check_bool(uncertainty, "uncertainty", "fit")
    if bidirectional is not None:
        check_choice(bidirectional, "bidirectional", "fit", BIDIRECTIONAL_MODES)
    randomised = model_kind(method).randomised
    if rng is None and (uncertainty or randomised):
        # Drawn here so that the model file records the seed that regenerates it.
        rng = int(np.random.SeedSequence().generate_state(1)[0])
    if has_both_directions(cal):
        # Both directions of travel pooled into one profile would leave half the reversal in every residual.
        return fit_bidirectional(cal, bidirectional or "per-direction", method, rng=rng, uncertainty=uncertainty,
                                 **options)
    if bidirectional is not None:
        raise InputError("The 'bidirectional' parameter of fit applies to a calibration with both directions "
                         f"of travel in its direction column. Got {bidirectional!r} for "
                         f"{cal.source or cal.name or 'a calibration'}, which has one direction.")
    return _fit_one_direction(cal, method, rng, options, uncertainty=uncertainty)


def _fit_one_direction(cal, method, rng, options, *, uncertainty=False):
    """:func:`fit` of a calibration with one profile (its readings all taken one way, or the way unknown)."""
    options = dict(options)
    fit_family = fitter(method)
    where = cal.source or cal.name or "calibration"
    errors = turn_checked_errors(cal, where=where)
    check_folds(cal, where=where)
    # recorded for a refit; a progress callback is no option of the model (nor JSON)
    fit_options = {key: value for key, value in options.items() if key != "progress"}
    randomised = model_kind(method).randomised
    if randomised:
        options["rng"] = rng  # a deterministic method ignores rng (scikit-learn's random_state does the same)
    _check_options(method, fit_family, options)
    model = fit_family(cal.encoder_deg, errors, **options)
    model.encoder = {"name": cal.name, "resolution_bits": resolution_bits(cal)}
    model.training = {
        "method": method,
        **model.training,
        "n_points": len(cal),
        "data_sha256": calibration_sha256(cal),
    }
    model.training.setdefault("fit_options", fit_options)
    if isinstance(rng, (int, np.integer)):
        model.training.setdefault("seed", int(rng))
    if uncertainty and model.uncertainty is None:  # a spectral model has its posterior already
        refit_method, refit_options = refit_spec(model, method, fit_options)
        model.uncertainty = estimate_uncertainty(model, cal.encoder_deg, cal.errors_arcmin, method=refit_method,
                                                 options=refit_options, rng=rng)
    model.uncertainty = with_reference_uncertainty(model.uncertainty, cal)
    model.reading_sign = cal.reading_sign
    return model


def resolution_bits(cal):
    """The calibration's declared resolution, else the one its readings show (all whole codes), else None.

    Examples
    --------
    >>> import numpy as np, encal
    >>> ref = np.arange(0.0, 360.0, 1.8)
    >>> codes = np.round((ref + 0.3 * np.sin(np.radians(ref))) * 2**14 / 360)
    >>> resolution_bits(encal.Calibration(ref, codes * 360 / 2**14))
    14
    """
    if cal.resolution_bits is not None:
        return int(cal.resolution_bits)
    return resolution_of_readings(cal.encoder_deg)


def fit_bidirectional(cal, mode="per-direction", method="auto", *, rng=None, uncertainty=False, **options):
    """Fit an error model to a bidirectional calibration.

    The calibration is split once: into its two directions (``'per-direction'``), each fitted and given its
    uncertainty on its own points, then combined by the directional kind; or into the mean of both
    (``'mean'``).

    Parameters
    ----------
    cal : Calibration
        With a ``direction`` column (+1 forward, -1 reverse).
    mode : {'per-direction', 'mean'}, default='per-direction'
        ``'per-direction'``: one model per direction, in a :class:`~encal.models.directional.DirectionalModel`
        that uses the known direction of a reading (and the mean of both when it is unknown).
        ``'mean'``: one model of the mean of both directions at every target position (see
        :func:`mean_calibration`), of the kind ``method`` makes; it carries no direction and its residual
        in either direction is about half the reversal value.
    method : str, default='auto'
        Any method of :func:`encal.fit`.
    rng : int or numpy.random.Generator, optional
        For the randomised methods, then for the bootstrap of the uncertainty.
    uncertainty : bool, default=False
        Also estimate each model's prediction uncertainty (:func:`~encal.models.uncertainty.add_uncertainty`;
        a spectral model keeps its posterior); a model of the mean adds the half reversal value to its noise.
    **options
        Passed to :func:`encal.fit`.

    Returns
    -------
    Model
        ``training`` records ``bidirectional`` (the mode), ``fit_options`` and the calibration's
        ``mean_reversal_value_arcmin`` and ``reversal_value_arcmin`` (None in ``'per-direction'`` mode
        when no target position was approached both ways and the calibration has no ``target_tolerance_deg``), and
        the calibration's ``target_tolerance_deg`` when it has one.

    Raises
    ------
    InputError
        If ``mode`` is unknown.
    CalibrationError
        If the calibration has fewer than 8 points in a direction, or (``mode='mean'``, or any mode for a
        calibration with a ``target_tolerance_deg``) no target position approached in both directions or a
        tolerance that joins targets (see :func:`~encal.data.reversal.reversal`).

    Examples
    --------
    >>> import numpy as np, encal
    >>> ref = np.tile(np.arange(0.0, 360.0, 5.0), 2)
    >>> direction = np.repeat([1, -1], 72)
    >>> error = np.sin(np.radians(ref)) + 0.15 * direction          # arcmin; reversal 0.3
    >>> cal = encal.Calibration(ref, ref + error / 60, direction=direction)
    >>> model = encal.models.fitting.fit_bidirectional(cal, method="fourier", orders=[0, 1])
    >>> round(float(model.predict(90.0, direction=1)), 3), round(float(model.predict(90.0)), 3)
    (1.15, 1.0)
    """
    check_type(cal, Calibration, "cal", "fit_bidirectional", "a Calibration")
    check_choice(mode, "mode", "fit_bidirectional", BIDIRECTIONAL_MODES)
    require_directions(cal, "fit_bidirectional")
    uncertainty = check_bool(uncertainty, "uncertainty", "fit_bidirectional")
    analysis = _reversal_or_none(cal) if mode == "per-direction" else reversal(cal)
    generator = None if rng is None else np.random.default_rng(rng)
    settings = {"method": method, "options": dict(options)}
    record = {
        "bidirectional": mode,
        "fit_options": dict(options),
        "mean_reversal_value_arcmin": None if analysis is None else analysis.mean_reversal_value,
        "reversal_value_arcmin": None if analysis is None else analysis.reversal_value,
        **({"target_tolerance_deg": cal.target_tolerance_deg} if cal.target_tolerance_deg is not None else {}),
    }
    if mode == "mean":
        mean = mean_calibration(cal)
        model = _fit_one_direction(mean, method, generator, options)
        model.training.update(record)
        if uncertainty:  # after the fit, from the seed again: the refits do not change the model
            add_mean_uncertainty(model, mean, rng=np.random.default_rng(rng), **settings)
        if has_posterior(model) or uncertainty:
            model.uncertainty = with_half_reversal(model.uncertainty, cal)
    else:
        sides = {sign: direction_subset(cal, sign) for sign in (1, -1)}
        parts = [_fit_one_direction(sides[sign], method, generator, options) for sign in (1, -1)]
        for part in parts:
            part.reading_sign = 1  # the directional model maps readings before its parts see them
        model = model_kind("directional").model_class(*parts)
        model.reading_sign = cal.reading_sign
        model.training = {"method": method, **record, "n_points": len(cal)}
        if uncertainty:
            add_part_uncertainties(model, sides, rng=np.random.default_rng(rng), **settings)
    model.encoder = {"name": cal.name, "resolution_bits": resolution_bits(cal)}
    if isinstance(rng, (int, np.integer)):
        model.training.setdefault("seed", int(rng))
    return model



def _check_options(method, fit_family, options):
    """Refuse an option the method's fit function does not take (one that takes ``**options`` checks its own)."""
    parameters = inspect.signature(fit_family).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()):
        return
    accepted = [name for name, p in list(parameters.items())[2:]
                if p.kind in (inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise InputError(f"method {method!r} does not take the option(s) {', '.join(unknown)}; it takes: "
                         f"{', '.join(accepted) or 'none'}")


def _reversal_or_none(cal):
    """The reversal analysis, or None when no target position was approached in both directions.

    A calibration given a ``target_tolerance_deg`` asked for its targets: a tolerance that joins neighbouring
    targets, or matches no target both ways, is refused there as in ``'mean'`` mode and ``encal report`` (it was
    swallowed, the model file recording the tolerance and no reversal, exit 0).
    """
    if cal.target_tolerance_deg is not None:
        return reversal(cal)
    try:
        return reversal(cal)
    except CalibrationError:
        return None


@dataclass(frozen=True)
class Evaluation:
    """A model's accuracy on one calibration.

    Attributes
    ----------
    before : ErrorStats
        Statistics of the raw errors ``encoder - reference`` (arcmin).
    after : ErrorStats
        Statistics of the errors of the corrected angles ``corrected - reference`` (arcmin).
    encoder_deg : ndarray
        Encoder angles of the points (degrees).
    residual_arcmin : ndarray
        ``corrected - reference`` at every point (arcmin): the observed error minus the predicted one.
    error_arcmin : ndarray or None
        The raw errors ``encoder - reference`` at every point (arcmin).
    zero : str
        How the reference's zero was treated ('fixed', 'arbitrary' or 'auto', see :func:`evaluate`).
    """

    before: ErrorStats
    after: ErrorStats
    encoder_deg: np.ndarray
    residual_arcmin: np.ndarray
    error_arcmin: np.ndarray | None = None
    zero: str = "fixed"

    @property
    def arbitrary_zero(self):
        """Whether the statistics are of the shape about each one's zero offset."""
        return self.before.offset is not None

    def as_dict(self):
        """JSON-ready: the ``after`` statistics at top level and ``before`` as a nested object.

        With an arbitrary zero both carry ``zero_offset_arcmin``, and ``zero`` says 'arbitrary'.
        """
        return {**self.after.as_dict(), "before": self.before.as_dict(),
                "zero": "arbitrary" if self.arbitrary_zero else "fixed",
                "correction_worse": self.correction_worse, "verdict": self.verdict()}

    @property
    def correction_worse(self):
        """Whether the correction leaves a larger RMS error than none
        (see :func:`encal.analysis.profile.worse_sentence`)."""
        return correction_is_worse(self.before.rms, self.after.rms)

    def verdict(self):
        """One sentence: whether the correction makes the errors smaller or larger, with both RMS figures."""
        worse = worse_sentence(self.before.rms, self.after.rms)
        if worse is not None:
            return worse
        return (f"the correction makes the errors {'smaller' if self.after.rms < self.before.rms else 'no larger'}: "
                f"RMS {self.before.rms:.4g} arcmin without it, {self.after.rms:.4g} arcmin with it")

    def offset_sentence(self):
        """With an arbitrary zero, the zero offset the correction leaves and why, in a sentence; None otherwise.

        A model corrects to the zero of the calibration it was fitted on: on a repeat whose reference started
        elsewhere (a motor's power-on position), the readings it corrects keep the change of zero between the two,
        which is not an error of the model and is stated apart.
        """
        if not self.arbitrary_zero or abs(self.after.offset) <= ARBITRARY_ZERO_ARCMIN:
            return None
        learnt = float(wrap180((self.before.offset - self.after.offset) / ARCMIN_PER_DEG)) * ARCMIN_PER_DEG
        return (f"after the correction a zero offset of {self.after.offset:+.2f} arcmin "
                f"({self.after.offset / ARCMIN_PER_DEG:+.3f} deg) remains: the model carries the zero offset of the "
                f"calibration it was fitted on ({learnt:+.2f} arcmin) and this one's is {self.before.offset:+.2f} "
                "arcmin; their difference is a change of the reference's zero (the arbitrary zero), stated apart, "
                "not an error of the correction")

    def zero_sentence(self):
        """How the zero offset was treated, in one sentence."""
        offset = self.before.offset if self.arbitrary_zero else zero_offset_arcmin(
            self.error_arcmin if self.error_arcmin is not None else self.residual_arcmin)
        if self.arbitrary_zero and abs(offset) <= ARBITRARY_ZERO_ARCMIN < abs(self.after.offset):
            # arbitrary because of the offset the correction leaves (a model fitted at another zero)
            return zero_sentence(self.zero, self.after.offset, True).replace(
                "zero offset", "zero offset after the correction", 1)
        return zero_sentence(self.zero, offset, self.arbitrary_zero)

    def __str__(self):
        """Before and after side by side, in arc-minutes."""
        rows = (("n", "n", "{:d}"), ("MAE", "mae", "{:.4f}"), ("RMS", "rms", "{:.4f}"), ("STD", "std", "{:.4f}"),
                ("min", "min", "{:+.4f}"), ("max", "max", "{:+.4f}"), ("max |e|", "max_abs", "{:.4f}"))
        if self.arbitrary_zero:
            rows = (("n", "n", "{:d}"), ("zero offset", "offset", "{:+.4f}"), *rows[1:])
        lines = [f"{'arcmin':10s}{'before':>12s}{'after':>12s}"]
        for label, attribute, form in rows:
            before, after = getattr(self.before, attribute), getattr(self.after, attribute)
            lines.append(f"{label:10s}{form.format(before):>12s}{form.format(after):>12s}")
        if self.arbitrary_zero:
            lines.append("(arbitrary zero: each column is about its own zero offset)")
        return "\n".join(lines)

    def _repr_html_(self):
        """Rich display in a notebook: the text table and the figure."""
        from ..figures import html_repr

        return html_repr(self)

    def plot(self, ax=None, *, title=None):
        """Errors before and residuals after compensation on the same axes (each about its zero offset
        when the zero is arbitrary); returns the axes."""
        from ..figures import plot_before_after

        before = self.error_arcmin if self.error_arcmin is not None else np.full_like(self.residual_arcmin, np.nan)
        after = self.residual_arcmin
        if self.arbitrary_zero:
            before, after = remove_offset(before, self.before.offset), remove_offset(after, self.after.offset)
        return plot_before_after(self.encoder_deg, before, after, ax=ax, title=title)


@single_blas_thread
def evaluate(model, cal, *, zero="fixed"):
    """Residual statistics of a model on a calibration (ideally one it was not fitted on).

    Parameters
    ----------
    model : Model
    cal : Calibration
    zero : {'fixed', 'arbitrary', 'auto'}, default='fixed'
        The reference's zero. 'fixed': statistics about zero. 'arbitrary': the raw errors and the
        residuals are each taken about their own zero offset (a repeat calibration of a motor starts
        elsewhere, so its offset differs from the one the model learnt), which are reported apart.
        'auto': arbitrary when either offset exceeds 1 degree.

    Returns
    -------
    Evaluation
    """
    check_type(model, Model, "model", "evaluate", "a Model")
    check_type(cal, Calibration, "cal", "evaluate", "a Calibration")
    check_choice(zero, "zero", "evaluate", ZERO_MODES)
    _check_not_empty(cal, "evaluate")
    if cal.source is None:  # a file's reader has warned already
        warn_if_in_radians(cal)
    observed = cal.errors_arcmin
    # The model maps readings to its input itself (a model of a reversed encoder negates them).
    # A directional model predicts each reading with its own direction's profile.
    predicted = model.predict(cal.readings_deg, direction=cal.direction)
    encoder_deg = cal.encoder_deg
    if getattr(model, "range_deg", None) is not None:  # a model over an arc: the statistics over the arc
        from .._core.arcs import within_model_range

        keep = within_model_range(model, cal)
        observed, predicted, encoder_deg = observed[keep], predicted[keep], encoder_deg[keep]
    residual = wrap180((observed - predicted) / ARCMIN_PER_DEG) * ARCMIN_PER_DEG
    offsets = (zero_offset_arcmin(observed), zero_offset_arcmin(residual)) if zero == "auto" else ()
    mode = "arbitrary" if zero_is_arbitrary(zero, *offsets) else "fixed"
    return Evaluation(error_stats(observed, zero=mode), error_stats(residual, zero=mode), encoder_deg.copy(),
                      residual, observed.copy(), zero)

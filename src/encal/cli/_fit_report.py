"""What `encal fit` says about a fitted model beyond its training set: held-out error and noise.

Every fit states an estimate of its error at readings it did not see (the training RMS of a lookup
table is 0): a spectral model its posterior's; a model chosen by auto the CV figure of the choice;
any other method a cross-validation of the same method over interleaved folds. A spectral model
also states its noise σ̂, where it came from (the prior) and σ̂ against the quantisation's LSB/√12.
A calibration in both directions of travel gets all of it per direction (or for the model of their
mean). docs/model-selection.md (the held-out estimate) gives the measured accuracy of each figure.
"""

import math

import numpy as np

__all__ = ["held_out", "noise", "held_out_lines"]

#: Measured ratio of the interleaved 5-fold figure to the test RMS at the midpoints of the 2° grid, per
#: method, on 8 simulated resolvers (demo fleet and simulate --encoders 8 --seed 7; test points at the
#: odd degrees; the networks over 5 seeds, their median fold): benchmarks/bench_held_out.py,
#: docs/model-selection.md. A hybrid's 0.8 is a fit on all points that bent between them.
OVERSTATES = {"fourier": (1.1, 1.8), "lut": (1.4, 1.8), "ann": (1.3, 2.0), "hybrid": (0.8, 3.8)}

#: The network families: a fold's refit can bend between its points (see :func:`_cross_validated`).
_NETWORKS = ("ann", "hybrid")

#: A fold whose RMS exceeds this multiple of the median fold's is counted as bent.
_BENT_FOLD = 3.0

#: Options of `encal fit` that are not the family's own (the fold refits take only the latter).
_NOT_FAMILY = ("rng", "bidirectional", "noise_arcmin", "use_grid", "networks", "folds", "stack")


def noise(model):
    """The noise a spectral model found and its prior, JSON-ready, or None for another kind.

    Returns
    -------
    dict or None
        ``std_arcmin`` (σ̂, arcmin), ``source`` ('supplied', 'repeated readings' or blind), ``prior`` (a
        sentence), ``resolution_bits``, ``lsb_over_sqrt12_arcmin`` and ``ratio_to_quantisation``
        (σ̂ / (LSB/√12); both None when the resolution is unknown). For a directional model with
        spectral parts, ``{'forward': ..., 'reverse': ...}``.
    """
    if model.kind == "directional":
        parts = {name: noise(getattr(model, name)) for name in ("forward", "reverse")}
        return None if all(part is None for part in parts.values()) else parts
    training = model.training
    if model.kind != "spectral" or "noise" not in training:
        return None
    sigma = float(training["noise"]["std_arcmin"])
    bits = model.encoder.get("resolution_bits") or training.get("readings_resolution_bits")
    quantum = 21600.0 / 2**bits / math.sqrt(12.0) if bits else None
    return {"std_arcmin": sigma, "source": training["noise"]["source"], "prior": training["prior"],
            "resolution_bits": bits, "lsb_over_sqrt12_arcmin": quantum,
            "ratio_to_quantisation": None if quantum is None else sigma / quantum}


def held_out(model, cal, method, options):
    """The estimate of the error at readings the fit did not see, JSON-ready.

    Parameters
    ----------
    model : Model
        As fitted from ``cal``.
    cal : Calibration
        The calibration fitted.
    method : str
        The method of ``encal fit``.
    options : dict
        The options of the fit (``rng`` the seed).

    Returns
    -------
    dict or None
        ``rms_arcmin`` (None when not available), ``estimator`` ('posterior', 'auto CV' or
        'interleaved CV'), ``folds`` and ``text`` (the line printed), with the fold figures of a
        cross-validation (and ``mean_note`` for the model of the mean of both directions); for a directional
        model ``{'forward': ..., 'reverse': ...}``. None when the CV table of an auto fit is the estimate.
    """
    from ..data.reversal import direction_subset, has_both_directions, mean_calibration

    if model.kind == "directional":
        return {name: _one(getattr(model, name), direction_subset(cal, sign), method, options)
                for name, sign in (("forward", 1), ("reverse", -1))}
    if model.training.get("bidirectional") == "mean" and has_both_directions(cal):
        estimate = _one(model, mean_calibration(cal), method, options)
        reversal = model.training.get("mean_reversal_value_arcmin")
        if estimate is not None and reversal is not None:
            estimate["mean_note"] = ("the model is of the mean of both directions: a reading whose direction is "
                                     f"known is off it by about half the reversal, {abs(reversal) / 2:.3g} arcmin "
                                     f"(mean reversal value {reversal:.3g}), on top of the held-out estimate")
        return estimate
    return _one(model, cal, method, options)


def held_out_lines(estimate):
    """The lines that state ``estimate`` (from :func:`held_out`), each direction's prefixed."""
    if estimate is None:
        return []
    if "text" in estimate:
        return [estimate["text"]]
    return [f"{name}: {part['text']}" for name, part in estimate.items() if part is not None]


def _one(model, cal, method, options):
    return _with_reference_uncertainty(_estimate(model, cal, method, options), cal, model.uncertainty)


def _with_reference_uncertainty(estimate, cal, model_uncertainty=None):
    """``estimate`` including the reference's own uncertainty (:attr:`Calibration.reference_std_arcmin`): a
    posterior's has it already (:func:`encal.models.uncertainty.with_reference_uncertainty`), and it is said; a
    cross-validation's gets its RMS in quadrature (no fold can see an error the reference shares with its
    neighbours)."""
    from ..models.uncertainty import included_text, reading_noise, reference_std_rms, with_reference_rms

    reference, noise = reference_std_rms(cal), reading_noise(cal)
    if estimate is None or (reference is None and noise is None) or estimate.get("rms_arcmin") is None:
        return estimate
    estimate = dict(estimate)
    if reference is not None:
        if estimate["estimator"] == "posterior":  # averaged over the posterior's grid, as its estimate is
            reference = (model_uncertainty or {}).get("reference_std_rms_arcmin", reference)
        estimate["reference_std_rms_arcmin"] = reference
    if noise is not None:
        estimate["reading_noise_arcmin"] = noise
    included = included_text(reference, noise)
    if estimate["estimator"] == "posterior":
        estimate["text"] += ", including " + included
    else:
        estimate["rms_arcmin"] = with_reference_rms(estimate["rms_arcmin"], cal)
        estimate["text"] += f"; with {included} in quadrature: RMS {estimate['rms_arcmin']:.4g} arcmin"
    return estimate


def _estimate(model, cal, method, options):
    selection = model.training.get("selection")
    if model.kind in ("spectral", "arc"):  # the posterior of either says it
        expected = model.expected_rms_between_points()
        if expected is None:
            return None
        return {"rms_arcmin": expected, "estimator": "posterior", "folds": None,
                "text": (f"held-out estimate (posterior, readings at angles not calibrated): RMS {expected:.4g} "
                         "arcmin after correction")}
    if selection is not None:
        row = next((r for r in selection["table"] if r["label"] == selection["chosen"]), None)
        if row is None or row["cv_rms_arcmin"] is None:
            return None
        text = (f"held-out estimate: CV RMS {row['cv_rms_arcmin']:.4g} arcmin over {selection['folds']} "
                "interleaved folds")
        if selection.get("scheme") != "evidence":
            text += " (the chosen row of the table above)"
        return {"rms_arcmin": row["cv_rms_arcmin"], "estimator": "auto CV", "folds": selection["folds"], "text": text}
    return _cross_validated(model, cal, method, options)


def _cross_validated(model, cal, method, options):
    """The same method refitted on ``k - 1`` of ``k`` interleaved folds, each predicting the fold left out.

    A network's refit has, where each held-out point was, a gap of two grid steps with no point in
    it, and now and then it bends there by tens of arc-minutes where the fit on all points, whose
    gaps are one step, does not (docs/model-selection.md). The median of the folds' RMS is then the
    estimate, and the folds that bent and the fitted model's own largest bend between its points
    are stated.
    """
    from ..models import select

    folds = min(select.DEFAULT_FOLDS, max(2, len(cal) // select.MIN_POINTS_PER_FOLD))
    fold = select.interleaved_folds(cal.encoder_deg, folds)
    family = model.kind
    candidate = select.Candidate(family, {k: v for k, v in options.items() if k not in _NOT_FAMILY})
    seed = options.get("rng")
    seeds = np.random.SeedSequence(seed if isinstance(seed, int) else 0).spawn(folds)
    score = select.cross_validate(cal.encoder_deg, cal.errors_arcmin, candidate, fold, seeds=seeds)
    if score.error is not None:
        return {"rms_arcmin": None, "estimator": "interleaved CV", "folds": folds, "error": score.error,
                "text": f"held-out estimate: not available ({score.error})"}
    residual = cal.errors_arcmin - score.predictions
    fold_rms = [float(np.sqrt(np.mean(residual[fold == k] ** 2))) for k in range(folds)]
    low, high = OVERSTATES.get(family, OVERSTATES["fourier"])
    estimate = {"rms_arcmin": score.rms_arcmin, "estimator": "interleaved CV", "folds": folds,
                "fold_rms_arcmin": fold_rms, "pooled_rms_arcmin": score.rms_arcmin}
    overstates = (f"each point held out from a gap twice the calibration's spacing, so it usually overstates the "
                  f"error between the calibrated angles: {low:.1f}-{high:.1f} times the test RMS for {family} on 8 "
                  "simulated resolvers")
    if family not in _NETWORKS:
        estimate["text"] = (f"held-out estimate: RMS {score.rms_arcmin:.4g} arcmin over {folds} interleaved folds "
                            f"of the same method ({overstates})")
        return estimate
    median = float(np.median(fold_rms))
    bent = [rms for rms in fold_rms if rms > _BENT_FOLD * median]
    bend = _bend_between_points(model, cal.encoder_deg)
    estimate.update(rms_arcmin=median, estimator="interleaved CV, median fold", bent_folds=len(bent),
                    bend_between_points_arcmin=bend)
    text = (f"held-out estimate: RMS {median:.4g} arcmin, the median of {folds} interleaved folds of the same "
            f"method ({overstates})")
    if bent:
        text += (f"; the network of {len(bent)} of the {folds} fold refits bent in the gaps the held-out points "
                 f"leave (fold RMS up to {max(bent):.4g}, pooled RMS {score.rms_arcmin:.4g} arcmin), which a fit "
                 "on all points does more rarely")
    text += (f"; the fitted model departs by up to {bend:.3g} arcmin from the straight line between "
             "neighbouring calibrated angles")
    estimate["text"] = text
    return estimate


def _bend_between_points(model, theta_deg):
    """The largest departure (arcmin) of ``model`` between neighbouring calibrated angles from their chord.

    Sampled at eighths of every gap between consecutive distinct angles round the circle; a smooth
    error profile departs from the chord by a fraction of an arc-minute over a few degrees, a network
    that bent between its points by as much as it bent.
    """
    angles = np.unique(np.mod(np.asarray(theta_deg, dtype=float), 360.0))
    following = np.r_[angles[1:], angles[0] + 360.0]
    at_angles, at_following = model.predict(angles), model.predict(np.mod(following, 360.0))
    largest = 0.0
    for fraction in np.arange(1, 8) / 8.0:
        between = model.predict(np.mod(angles + fraction * (following - angles), 360.0))
        chord = (1.0 - fraction) * at_angles + fraction * at_following
        largest = max(largest, float(np.max(np.abs(between - chord))))
    return largest

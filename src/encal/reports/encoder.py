"""The report for the user's own encoder: one self-contained HTML page, and its figures as PNG files.

:func:`encoder_report` measures everything the page shows from one calibration and, optionally, later or
held-out calibrations of the same encoder:

- the error profile, its zero offset stated apart when the reference's zero is arbitrary, and the model
  ``encal fit`` would make (same method, same seed) with its uncertainty band;
- the harmonic amplitudes and phases of the shape;
- the automatic choice's cross-validation table (held-out figures of every candidate);
- errors before and residuals after compensation, on the same axes, on every test calibration (points the
  model never saw) or, without one, on the calibration itself;
- the reversal error (ISO 230-2) when the calibration has a ``direction`` column;
- drift against the first calibration when there are several epochs (an ``epoch`` column, or two or more
  test calibrations).

:func:`write_encoder_report` writes the page with the figures embedded as base64 PNG (it opens without a
network and can be mailed alone) and the same figures as PNG files beside it.
"""

import html
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core import html as _html
from .._core.atomic import atomic_file_set, atomic_write
from .._version import __version__
from .._core.angles import ARCMIN_PER_DEG, lsb_arcmin, resolution_of_readings
from ..data.calibration import READING_NOISE_KEY, Calibration
from .._core.errors import InputError
from .._core.parameters import check_bool, check_choice, check_int, check_type, invalid
from ..analysis.profile import (ARBITRARY_ZERO_ARCMIN, ZERO_MODES, error_stats, harmonics, remove_offset,
                                zero_is_arbitrary, zero_offset_arcmin, zero_sentence)
from .._core.threads import single_blas_thread

__all__ = ["EncoderReport", "encoder_report", "render_encoder_figures", "build_encoder_html",
           "write_encoder_report", "model_comparison", "ENCODER_FIGURES", "COMPARISON_MAX_POINTS"]

#: ``compare='auto'`` leaves the model comparison out above this many calibration points: it refits every
#: candidate family on each fold, and on a dense log that costs minutes (BENCHMARKS.md, "The report on dense
#: logs").
COMPARISON_MAX_POINTS = 5000

#: Figure name -> caption, in page order (a figure is drawn only when its section applies).
ENCODER_FIGURES = {
    "profile": "Error profile against the encoder angle: the calibration points, the model's prediction and "
               "its 95 % band for a new reading.",
    "harmonics": "Harmonic amplitudes of the error profile; the ten largest orders are labelled.",
    "selection": "Model comparison: RMS of every candidate on points it did not see (a test calibration, or "
                 "interleaved cross-validation folds without one); the chosen model in orange.",
    "before_after": "Errors before (raw) and residuals after compensation, on the same axes.",
    "reversal": "Reversal (ISO 230-2): mean deviation approached forward and reverse at each target, and "
                "their difference B_i.",
    "drift": "Drift: each later calibration minus the first at the same shaft positions.",
}


@dataclass(eq=False)
class EncoderReport:
    """Everything the report on one encoder shows.

    Attributes
    ----------
    calibration : Calibration
        The calibration the model is fitted on.
    tests : list of Calibration
        Held-out or later calibrations of the same encoder.
    zero : str
        What was asked for the reference's zero ('auto', 'arbitrary' or 'fixed').
    arbitrary_zero : bool
        Whether the zero offset is stated apart and the statistics are of the shape.
    offset_arcmin : float
        The calibration's zero offset (circular mean of its errors), arcmin.
    stats : ErrorStats
        Statistics of the calibration's errors (of the shape when the zero is arbitrary), arcmin.
    harmonics : Harmonics
        Harmonic analysis of the shape (or of the errors with a fixed zero).
    model : Model
        The model ``encal fit`` makes with the same method and seed.
    fitted : Evaluation
        The model on its own calibration (training points).
    held_out : list of (str, Evaluation)
        The model on each test calibration.
    reversal : ReversalAnalysis or None
        With a ``direction`` column.
    drift : DriftReport or None
        With several epochs.
    comparison : dict or None
        Held-out accuracy of the spectral model and every candidate family of the automatic choice
        (:func:`model_comparison`): on the test calibrations when there are any, else cross-validated; the
        model ``encal fit`` made marked as chosen.
    comparison_note : str
        Why the comparison was left out, or which figure to trust when the comparison cannot judge the
        chosen model; "" when there is nothing to say.
    resolution_bits : int or None
        Given, or inferred from readings on a 2^B grid.
    method : str
    seed : int
    notes : list of str
        Sentences about what was done (the zero, skipped sections).
    """

    calibration: Calibration
    tests: list
    zero: str
    arbitrary_zero: bool
    offset_arcmin: float
    stats: object
    harmonics: object
    model: object
    fitted: object
    held_out: list
    reversal: object = None
    drift: object = None
    comparison: dict | None = None
    comparison_note: str = ""
    resolution_bits: int | None = None
    method: str = "auto"
    seed: int | None = None
    notes: list = field(default_factory=list)

    @property
    def name(self):
        """The encoder's name (the calibration file's stem)."""
        return self.calibration.name or "encoder"

    @property
    def selection(self):
        """The model comparison (:class:`~encal.models.auto.Selection`), or None."""
        from ..models.auto import Selection

        return None if self.comparison is None else Selection(self.comparison)

    def held_out_rms(self):
        """The chosen model's estimated RMS at readings it did not see (arcmin), or None."""
        expected = getattr(self.model, "expected_rms_between_points", None)
        if callable(expected) and expected() is not None:
            return float(expected())
        selection = self.selection
        if selection is None or selection.table.get("scheme") == "tests":
            return None
        row = selection.chosen_row()
        from ..models.uncertainty import with_reference_rms

        return None if row is None else with_reference_rms(row["cv_rms_arcmin"], self.calibration)

    def shape(self, cal):
        """A calibration's errors (arcmin), about its own zero offset when the zero is arbitrary."""
        errors = cal.errors_arcmin
        return remove_offset(errors, zero_offset_arcmin(errors)) if self.arbitrary_zero else errors


@single_blas_thread
def encoder_report(cal, tests=(), *, method="auto", zero="auto", rng=None, uncertainty=True, compare="auto",
                   **fit_options):
    """Measure everything the report on one encoder shows.

    Parameters
    ----------
    cal : Calibration
        The calibration to fit.
    tests : sequence of Calibration, default=()
        Held-out or later calibrations of the same encoder.
    method : str, default='auto'
        Model family, as for :func:`encal.fit`.
    zero : {'auto', 'arbitrary', 'fixed'}, default='auto'
        The reference's zero (see :func:`encal.analysis.profile.error_stats`).
    rng : int, optional
        Seed; drawn and recorded when None, as ``encal fit`` does.
    uncertainty : bool, default=True
        Estimate the model's prediction uncertainty for the band by bootstrap refits of the chosen family; a
        spectral model's band comes from its posterior whatever this is.
    compare : bool or 'auto', default='auto'
        Score the candidate families for the model comparison (:func:`model_comparison`); 'auto' does so up
        to :data:`COMPARISON_MAX_POINTS` calibration points and says why it left it out above.
    **fit_options
        Passed to :func:`encal.fit`.

    Returns
    -------
    EncoderReport
    """
    from ..data.reversal import reversal
    from .drift import _unique_labels, compare_calibrations, split_epochs
    from ..models.fitting import evaluate, fit

    where = "encoder_report"
    check_type(cal, Calibration, "cal", where, "a Calibration")
    try:
        tests = list(tests)
    except TypeError:
        raise invalid("tests", where, "a sequence of Calibrations", tests,
                      shown=f"an object of type {type(tests).__name__}") from None
    for index, test in enumerate(tests):
        check_type(test, Calibration, f"tests[{index}]", where, "a Calibration")
    check_choice(zero, "zero", where, ZERO_MODES)
    uncertainty = check_bool(uncertainty, "uncertainty", where)
    if not (isinstance(compare, str) and compare == "auto"):
        compare = check_bool(compare, "compare", where)
    offset = zero_offset_arcmin(cal.errors_arcmin)
    arbitrary = zero_is_arbitrary(zero, offset, *(zero_offset_arcmin(t.errors_arcmin) for t in tests))
    mode = "arbitrary" if arbitrary else "fixed"
    largest = max([offset, *(zero_offset_arcmin(t.errors_arcmin) for t in tests)], key=abs)
    if arbitrary and abs(offset) <= ARBITRARY_ZERO_ARCMIN < abs(largest):  # arbitrary for a test's offset
        notes = [zero_sentence(zero, largest, arbitrary).replace("zero offset", "largest zero offset (of a test "
                                                                  "calibration)", 1)]
    else:
        notes = [zero_sentence(zero, offset, arbitrary)]
    bits = cal.resolution_bits if cal.resolution_bits is not None else resolution_of_readings(cal.encoder_deg)
    if cal.resolution_bits is None and bits is not None:
        notes.append(f"Every reading lies on a grid of 360/2^{bits} deg: a {bits}-bit encoder "
                     f"(1 LSB = {lsb_arcmin(bits):.4g} arcmin), inferred from the readings.")
    model = fit(cal, method=method, rng=rng, uncertainty=uncertainty, **fit_options)
    seed = model.training.get("seed")
    errors = cal.errors_arcmin
    shape = remove_offset(errors, offset) if arbitrary else errors
    report = EncoderReport(
        calibration=cal, tests=tests, zero=zero, arbitrary_zero=arbitrary, offset_arcmin=offset,
        stats=error_stats(errors, zero=mode),
        harmonics=None if model.range_deg is not None else harmonics(cal.encoder_deg, shape), model=model,
        fitted=evaluate(model, cal, zero=mode),
        held_out=[(t.name or f"test {i + 1}", evaluate(model, t, zero=mode)) for i, t in enumerate(tests)],
        resolution_bits=bits, method=method, seed=seed, notes=notes)
    if compare == "auto" and len(cal) > COMPARISON_MAX_POINTS:
        compare = False
        report.comparison_note = (
            f"The model comparison was left out: it refits {len(_candidates())} candidate families on every "
            f"fold, which on {len(cal)} points costs minutes; the figure above "
            f"is the model's own held-out estimate (encal report --comparison runs it anyway).")
    elif not compare:
        report.comparison_note = "No model comparison (--no-comparison)."
    if compare:
        report.comparison = model_comparison(cal, model, seed, tests=tests, zero=mode)
        report.comparison_note = _trust_sentence(report)
    if cal.direction is not None and np.unique(cal.direction).size == 2:
        report.reversal = reversal(cal)
    epochs = split_epochs(cal)
    runs = epochs + tests if len(epochs) >= 2 else ([cal, *tests] if len(tests) >= 2 else [])
    if len(runs) >= 2:
        labels = [_run_label(run, index) for index, run in enumerate(runs)]
        report.drift = compare_calibrations(runs, offset="remove" if arbitrary else "keep",
                                            labels=_unique_labels(labels))
    return report


def _candidates():
    from ..models import select

    return [select.Candidate("spectral", {}), *select.DEFAULT_CANDIDATES]


def model_comparison(cal, model, seed=None, *, tests=(), zero="fixed"):
    """Held-out accuracy of the spectral model and of every candidate family of the automatic choice.

    With test calibrations, every candidate is fitted on the whole calibration and scored on the tests
    pooled (points none of them saw, each test about its own zero offset when ``zero='arbitrary'``): a
    validation that judges what each candidate predicts between the calibration's points. Without, each is
    fitted on all but one of k interleaved folds and scored on the one left out
    (:func:`encal.models.select.cross_validate`, k = 5 or fewer for small calibrations), which cannot see
    between the points (docs/model-selection.md). Rows of the model's own selection table that are not
    among them are added. Directions of travel are pooled.

    Parameters
    ----------
    cal : Calibration
    model : Model
        The model ``encal fit`` made; its candidate is marked as chosen.
    seed : int, optional
        Seeds the networks.
    tests : sequence of Calibration, default=()
    zero : {'fixed', 'arbitrary'}, default='fixed'

    Returns
    -------
    dict
        ``{'scheme', 'folds', 'table', 'chosen', 'reason'}`` in the shape of a selection table; ``scheme`` is
        'tests' or 'report' (interleaved folds), and the ``cv_*`` figures are those of the scheme.
    """
    from ..models import select

    theta, error = cal.encoder_deg, cal.errors_arcmin
    candidates = _candidates()
    streams = np.random.SeedSequence(seed if isinstance(seed, (int, np.integer)) else 0).spawn(len(candidates))
    if tests:
        table = [_score_on_tests(theta, error, candidate, stream, tests, zero).as_dict()
                 for candidate, stream in zip(candidates, streams)]
        scheme, folds = "tests", 0
    else:
        folds = min(select.DEFAULT_FOLDS, max(2, len(cal) // select.MIN_POINTS_PER_FOLD))
        fold = select.interleaved_folds(theta, folds)
        table = [select.cross_validate(theta, error, candidate, fold, seeds=stream.spawn(folds)).as_dict()
                 for candidate, stream in zip(candidates, streams)]
        scheme = "report"
        own_rows = (model.training.get("selection") or {}).get("table") or []
        labels = {row["label"] for row in table}
        table += [row for row in own_rows if row["label"] not in labels and row.get("family") != "spectral"]
    own = model.training.get("selection") or {}
    if own:
        chosen, reason = own.get("chosen"), f"encal fit chose {own.get('chosen')}: {own.get('reason')}"
    else:
        family = model.training.get("method", model.kind)
        chosen = next((row["label"] for row in table if row["family"] == family), None)
        reason = f"--method {family}: the closest candidate is marked"
    return {"scheme": scheme, "folds": int(folds), "table": table, "chosen": chosen, "reason": reason}


def _score_on_tests(theta, error, candidate, stream, tests, zero):
    """A candidate fitted on the whole calibration, scored on the test calibrations pooled (a CVScore)."""
    import time

    from .._core.errors import EncalError
    from ..models import select

    start = time.perf_counter()
    try:
        fitted = candidate.fit(theta, error, rng=np.random.default_rng(stream))
    except EncalError as exc:
        return select.CVScore(candidate, np.inf, np.inf, np.inf, np.inf, time.perf_counter() - start, error=str(exc))
    residuals = []
    for test in tests:
        residual = test.errors_arcmin - np.asarray(fitted.predict(test.encoder_deg))
        residuals.append(remove_offset(residual, zero_offset_arcmin(residual)) if zero == "arbitrary" else residual)
    residual = np.concatenate(residuals)
    if not np.all(np.isfinite(residual)):
        return select.CVScore(candidate, np.inf, np.inf, np.inf, np.inf, time.perf_counter() - start,
                              error="non-finite predictions")
    return select.CVScore(candidate, float(np.sqrt(np.mean(residual**2))), float(np.mean(np.abs(residual))),
                          float(np.max(np.abs(residual))), float(fitted.free_parameters()),
                          time.perf_counter() - start)


def _trust_sentence(report):
    """One sentence when the page's comparison and encal fit's choice disagree: which figure to trust, and why."""
    from ..models.auto import is_chosen

    table = report.comparison
    rows = sorted((row for row in table["table"] if row.get("cv_rms_arcmin") is not None),
                  key=lambda row: row["cv_rms_arcmin"])
    chosen = next((row for row in rows if is_chosen(row, table)), None)
    if not rows or chosen is None or chosen["cv_rms_arcmin"] <= 1.05 * rows[0]["cv_rms_arcmin"]:
        return ""
    rank = rows.index(chosen) + 1
    if table["scheme"] == "tests":
        return (f"On the test calibrations encal fit's choice ranks {rank} of {len(rows)} "
                f"({chosen['cv_rms_arcmin']:.3g} against {rows[0]['cv_rms_arcmin']:.3g} arcmin for "
                f"{rows[0]['label']}): these points none of the candidates saw are the figure to trust here, so "
                f"fit --method {rows[0]['family']} for this encoder.")
    own = report.model.expected_rms_between_points() if callable(
        getattr(report.model, "expected_rms_between_points", None)) else None
    estimate = f" ({own:.3g} arcmin)" if own is not None else ""
    return (f"Here encal fit's choice ranks {rank} of {len(rows)}, but interleaved folds leave out points that "
            "lie between points still in the fit, so they cannot judge what a model predicts between the "
            f"calibration's points (docs/model-selection.md); trust the model's own held-out estimate{estimate}, "
            "and give a test calibration (encal report CAL.csv TEST.csv) to score every candidate on points "
            "none of them saw.")


def _run_label(cal, index):
    if cal.epoch is not None and np.unique(cal.epoch).size == 1:
        return f"{cal.name} epoch {cal.epoch[0]}" if cal.name else f"epoch {cal.epoch[0]}"
    return cal.name or f"calibration {index + 1}"


# --------------------------------------------------------------------------- figures


def _profile_figure(report):
    from ..figures import draw_points, new_axes, plot_model

    ax = new_axes(figsize=(8.0, 3.8))
    cal = report.calibration
    offset = report.offset_arcmin if report.arbitrary_zero else 0.0
    plot_model(report.model, data=(cal.encoder_deg, cal.errors_arcmin), ax=ax, offset_arcmin=offset,
               title=f"{report.name}: error profile and {report.model.kind} model",
               band_of="a new reading" if _smoothed_calibration(report.model) is None else "the encoder's error")
    for index, (label, evaluation) in enumerate(report.held_out):
        # each test about its own zero offset: a motor calibrated again starts elsewhere
        own = evaluation.before.offset if evaluation.arbitrary_zero else 0.0
        draw_points(ax, evaluation.encoder_deg, _shape_of(evaluation.error_arcmin, own), colour=f"C{index + 2}",
                    label=f"{label} (test)", marker="x")
    ax.legend(fontsize="small", loc="best", frameon=True, framealpha=0.75, edgecolor="none")
    return ax.figure


def _shape_of(errors, offset):
    """Errors (arcmin) minus a zero offset, wrapped to within half a turn."""
    from .._core.angles import wrap180

    return wrap180((np.asarray(errors) - offset) / ARCMIN_PER_DEG) * ARCMIN_PER_DEG


def _harmonics_figure(report):
    from ..figures import new_axes, plot_harmonics

    ax = new_axes(figsize=(8.0, 3.4))
    of_what = "shape (zero offset apart)" if report.arbitrary_zero else "error"
    return plot_harmonics(report.harmonics, ax=ax, title=f"{report.name}: harmonics of the {of_what}").figure


def _selection_figure(report):
    from ..figures import plot_selection

    return plot_selection(report.comparison).figure


def _before_after_figure(report):
    from ..figures import panel_figure, plot_before_after

    panels = dict(report.held_out) if report.held_out else {f"{report.name} (training points)": report.fitted}
    lsb = lsb_arcmin(report.resolution_bits) if report.resolution_bits is not None else None

    def draw(evaluation, ax):
        before, after = evaluation.error_arcmin, evaluation.residual_arcmin
        if evaluation.arbitrary_zero:
            before = remove_offset(before, evaluation.before.offset)
            after = remove_offset(after, evaluation.after.offset)
        plot_before_after(evaluation.encoder_deg, before, after, ax=ax, floor_arcmin=lsb)

    names = iter(panels)

    def draw_named(evaluation, ax):
        draw(evaluation, ax)
        ax.set_title(next(names), fontsize="medium")

    return panel_figure(panels, draw_named, ncols=1, panel_size=(8.0, 3.4), sharey=True)


def _reversal_figure(report):
    from ..figures import new_axes, plot_reversal

    offset = report.offset_arcmin if report.arbitrary_zero else 0.0
    return plot_reversal(report.reversal, ax=new_axes(figsize=(8.0, 3.4)), title=f"{report.name}: reversal",
                         offset_arcmin=offset).figure


def _drift_figure(report):
    from ..figures import new_axes, plot_drift

    return plot_drift(report.drift, ax=new_axes(figsize=(8.0, 3.4)), title=f"{report.name}: drift").figure


_MAKERS = {
    "profile": (_profile_figure, lambda r: True),
    "harmonics": (_harmonics_figure, lambda r: r.harmonics is not None),
    "selection": (_selection_figure, lambda r: r.comparison is not None),
    "before_after": (_before_after_figure, lambda r: True),
    "reversal": (_reversal_figure, lambda r: r.reversal is not None),
    "drift": (_drift_figure, lambda r: r.drift is not None),
}


#: Largest resolution of the report's figures (dots per inch): its largest figure, 8 by 3.8 inches, is then
#: 44 million pixels.
MAX_DPI = 1200


def render_encoder_figures(report, dpi=100):
    """Draw the report's figures.

    Returns
    -------
    dict of str to bytes
        Figure name (a key of :data:`ENCODER_FIGURES`) -> PNG, for the sections that apply.
    """
    from ..figures import detached_figures, figure_png

    check_type(report, EncoderReport, "report", "render_encoder_figures", "an EncoderReport")
    dpi = check_int(dpi, "dpi", "render_encoder_figures", low=1, high=MAX_DPI, note="dots per inch")
    with detached_figures():
        return {name: figure_png(make(report), dpi=dpi) for name, (make, applies) in _MAKERS.items()
                if applies(report)}


# --------------------------------------------------------------------------- the page


def _f(value, digits=4):
    """A number for the page: fixed significant digits, '-' for None or NaN."""
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "-"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return f"{value:.{digits}g}"


def _stats_table(columns, caption):
    """Statistics side by side: ``columns`` maps a heading to an ErrorStats."""
    rows_by_label = {}
    for stats in columns.values():
        for label, value in stats.rows():
            rows_by_label.setdefault(label, [])
    for heading, stats in columns.items():
        values = dict(stats.rows())
        for label in rows_by_label:
            value = values.get(label)
            offset = label.startswith("zero offset") and value is not None
            rows_by_label[label].append(f"{value:+.2f}" if offset else _f(value))
    return _html.table(["arcmin", *columns], [[label, *cells] for label, cells in rows_by_label.items()], caption)


def correction_warnings(report):
    """The sentences saying where the model's correction makes the errors larger than none (held-out calibrations,
    later epochs), each naming the calibration; empty when it nowhere does."""
    found = [f"on {label}, {evaluation.verdict()}" for label, evaluation in report.held_out
             if evaluation.correction_worse]
    found += [epoch.worse_sentence() for epoch in (report.drift.epochs if report.drift is not None else ())
              if epoch.correction_worse and epoch.label not in {label for label, _ in report.held_out}]
    return found


def _summary(report):
    stats, cal = report.stats, report.calibration
    lines = []
    what = "shape (zero offset apart)" if report.arbitrary_zero else "error"
    lines.append(f"{report.name}: {len(cal)} calibration points; the {what} has RMS {stats.rms:.3g} arcmin and "
                 f"peak-to-peak {stats.pp:.3g} arcmin.")
    held_out = report.held_out_rms()
    if held_out is not None:
        lines.append(f"The {report.model.kind} model encal fit makes (--method {report.method}) is expected to "
                     f"leave RMS {held_out:.3g} arcmin at readings it did not see.")
    for label, evaluation in report.held_out:
        lines.append(f"On {label}, which the model never saw: RMS {evaluation.before.rms:.3g} arcmin before, "
                     f"{evaluation.after.rms:.3g} after compensation (max |error| {evaluation.before.max_abs:.3g} -> "
                     f"{evaluation.after.max_abs:.3g}).")
    lines += [f"Warning: {sentence}." for sentence in correction_warnings(report)]
    if not report.held_out:
        lines.append(f"On its own calibration points the model leaves RMS {report.fitted.after.rms:.3g} arcmin; "
                     "give a test calibration (encal report CAL.csv TEST.csv) for a figure on unseen points.")
    return '<ul class="summary">' + "".join(f"<li>{html.escape(line)}</li>" for line in lines) + "</ul>"


def verdict(report):
    """The page's first line: the encoder's error, what is left after correction, how sure, on which data."""
    stats = report.stats
    what = "shape (zero offset apart)" if report.arbitrary_zero else "error"
    head = f"{report.name}: the encoder's {what} is RMS {stats.rms:.3g} arcmin (peak-to-peak {stats.pp:.3g})"
    if report.held_out:
        points = sum(evaluation.after.n for _, evaluation in report.held_out)
        before = _pooled_rms([evaluation.before.rms for _, evaluation in report.held_out],
                             [evaluation.before.n for _, evaluation in report.held_out])
        after = _pooled_rms([evaluation.after.rms for _, evaluation in report.held_out],
                            [evaluation.after.n for _, evaluation in report.held_out])
        worse = " — the correction makes it worse there" if after > before else ""
        left = (f"; after correction RMS {after:.3g} arcmin is left on {points} test points the model never saw "
                f"(RMS {before:.3g} before){worse}")
    elif report.held_out_rms() is not None:
        left = (f"; after correction about RMS {report.held_out_rms():.3g} arcmin is expected at readings it did "
                "not see (the model's own estimate from this one calibration: give a test calibration to measure it)")
    else:
        left = (f"; after correction RMS {report.fitted.after.rms:.3g} arcmin is left on the calibration's own "
                "points (optimistic: give a test calibration to measure it)")
    band = ""
    if getattr(report.model, "uncertainty", None) is not None or getattr(report.model, "has_uncertainty", False):
        from scipy.stats import norm

        _, std = report.model.predict(np.linspace(0.0, 360.0, 721)[:-1], return_std=True)
        half_width = float(norm.ppf(0.975) * np.nanmean(std))  # over the arc of an arc model (NaN outside)
        smoothed = _smoothed_calibration(report.model)
        measured = report.model.uncertainty.get(READING_NOISE_KEY) if isinstance(
            getattr(report.model, "uncertainty", None), dict) else None
        if measured is not None:
            band = (f"; the model's 95 % band for a new reading is ± {half_width:.3g} arcmin on average, with the "
                    f"reading noise the self-calibration measured from its log ({measured:.3g} arcmin RMS)")
        elif smoothed is None:
            band = f"; the model's 95 % band for a new reading is ± {half_width:.3g} arcmin on average"
        else:
            band = (f"; the model's 95 % band for the encoder's error is ± {half_width:.3g} arcmin on average, not "
                    f"for a new reading: the calibration's points scatter by {smoothed[0]:.2g} arcmin, far below "
                    f"their own sigma_arcmin (RMS {smoothed[1]:.3g}), a smoothed curve such as a self-calibration "
                    "writes, so a new reading's own noise comes on top of both figures")
    return head + left + band + "."


#: A calibration whose points scatter about the model by less than this share of their own reference uncertainty
#: (its ``sigma_arcmin``) holds no reading noise: a smoothed curve, as a self-calibration writes.
SMOOTHED_NOISE_SHARE = 0.1


def _smoothed_calibration(model):
    """``(noise, reference)`` (arcmin) when the model's band holds no reading noise, else None.

    A self-calibration's output (``encal selfcal``) is the recovered error on a grid with its ``sigma_arcmin``:
    a smoothed curve, so the noise estimated from its points is nearly 0 and the band is the profile's
    uncertainty alone. On 50 simulated spins (benchmarks/bench_report_band.py) it covered 25 % of new readings of
    an encoder with 2 arcmin of noise, the profile itself 99.5 %.
    """
    uncertainty = getattr(model, "uncertainty", None)
    if not isinstance(uncertainty, dict) or "reference_std_rms_arcmin" not in uncertainty:
        return None
    noise, reference = uncertainty.get("noise_std_arcmin"), uncertainty["reference_std_rms_arcmin"]
    if noise is None or not reference or noise >= SMOOTHED_NOISE_SHARE * reference:
        return None
    return float(noise), float(reference)


def _pooled_rms(values, counts):
    counts = np.asarray(counts, dtype=float)
    return float(np.sqrt(np.sum(np.asarray(values, dtype=float) ** 2 * counts) / np.sum(counts)))


def _harmonics_table(report):
    if report.harmonics is None:  # a calibration over an arc (issue 31)
        return ("<p>The calibration covers one arc of the turn: harmonics of the shaft angle are defined over the "
                "full turn only, so none are computed.</p>")
    rows = [[str(e["order"]), f"{e['amplitude_arcmin']:.4g}", f"{e['phase_deg']:.1f}"]
            for e in report.harmonics.as_list(10)]
    return _html.table(["order", "amplitude (arcmin)", "phase (deg)"], rows,
                       "The ten largest harmonics: error = Σ A_k cos(k θ − φ_k), θ the encoder angle")


def _selection_table(report):
    from ..models.auto import is_chosen

    selection = report.selection
    if selection is None:
        return _html.paragraph(report.comparison_note or "No model comparison.")
    rows = []
    for row in selection.rows():
        name = (f"stack of {len(row['options']['members'])}" if row["family"] == "stack" else row["label"])
        mark = "chosen" if is_chosen(row, selection.table) else ""
        rows.append([name, _f(row.get("cv_rms_arcmin")), _f(row.get("cv_mae_arcmin")),
                     _f(row.get("n_parameters"), 3), mark])
    if selection.table.get("scheme") == "tests":
        headings = ["candidate", "test RMS (arcmin)", "test MAE (arcmin)", "parameters", ""]
        caption = ("Every candidate fitted on the whole calibration and scored on the test calibrations "
                   "(points none of them saw)")
    else:
        headings = ["candidate", "CV RMS (arcmin)", "CV MAE (arcmin)", "parameters", ""]
        caption = f"Cross-validation over {selection.table['folds']} interleaved folds (held-out points)"
    note = _html.paragraph(report.comparison_note) if report.comparison_note else ""
    return _html.table(headings, rows, caption) + _html.paragraph(f"{selection.reason}.") + note


def _held_out_tables(report):
    parts = []
    evaluations = report.held_out or [(f"{report.name} (training points: optimistic)", report.fitted)]
    for label, evaluation in evaluations:
        parts.append(_stats_table({"before": evaluation.before, "after": evaluation.after}, label))
    return "".join(parts)


def _reversal_section(report):
    from ..data.reversal import DEVIATION_SIGN_NOTE

    analysis = report.reversal
    # arc-seconds too: ISO 230-2 states a rotary axis' values in them
    rows = [[key.replace("_arcmin", "").replace("_", " "), _f(value), _f(None if value is None else 60.0 * value)]
            for key, value in analysis.as_dict().items() if key.endswith("_arcmin")]
    offset = report.offset_arcmin if report.arbitrary_zero else 0.0
    mean = lambda values: _f(float(np.mean(remove_offset(values, offset))))  # noqa: E731
    directions = [["forward (+1)", str(int(analysis.n_forward.sum())), mean(analysis.mean_forward_arcmin)],
                  ["reverse (-1)", str(int(analysis.n_reverse.sum())), mean(analysis.mean_reverse_arcmin)]]
    heading = "mean deviation (arcmin)" + (" about the zero offset" if report.arbitrary_zero else "")
    return (_html.table(["direction", "points", heading], directions, "Points per direction")
            + _html.table(["ISO 230-2 value", "arcmin", "arcsec"], rows,
                          f"{analysis.caption()} ({DEVIATION_SIGN_NOTE})"))


def _drift_section(report):
    drift = report.drift
    rows = [[e.label, str(e.difference.n), f"{e.offset_change_arcmin:+.4g}", _f(e.difference.rms),
             _f(e.difference.max_abs), _f(e.residual_rms_arcmin), f"{e.increase_arcmin:+.3g}",
             "holds" if e.holds else "does not hold"] for e in drift.epochs]
    offsets = ("zero offsets removed (arbitrary zero), their changes stated apart" if drift.offset == "remove"
               else "zero offsets kept (fixed zero)")
    return (_html.paragraph(f"Against {drift.baseline_label}; {offsets}. A {drift.method} model of the first "
                            f"calibration leaves RMS {drift.baseline_rms_arcmin:.3g} arcmin there "
                            f"({_f(drift.expected_rms_arcmin)} expected on an unchanged repeat); it holds on a "
                            f"later one when its residual exceeds the expected by at most {drift.tolerance_arcmin:.3g} "
                            "arcmin "
                            f"({drift.tolerance_rule})." )
            + _html.table(["calibration", "n", "offset change", "difference RMS", "max |difference|",
                           "residual RMS", "excess over expected", "verdict"], rows, "Drift (arcmin)"))


def _figure(figures, name):
    return _html.figure(name, figures[name], ENCODER_FIGURES[name]) if name in figures else ""


def build_encoder_html(report, figures):
    """The report as one HTML string (figures embedded as base64 PNG).

    Parameters
    ----------
    report : EncoderReport
    figures : dict of str to bytes
        From :func:`render_encoder_figures`.
    """
    cal, model = report.calibration, report.model
    resolution = (f"{report.resolution_bits}-bit encoder, 1 LSB = {lsb_arcmin(report.resolution_bits):.4g} arcmin"
                  if report.resolution_bits is not None else "resolution unknown")
    seed = f", seed {report.seed}" if report.seed is not None else ""
    stats_columns = {"calibration": report.stats}
    parts = [
        f"<h1>Encoder report: {html.escape(report.name)}</h1>",
        _html.paragraph(f"{cal.source or report.name}: {len(cal)} points; {resolution}. encal {__version__}; "
                        f"model: encal fit --method {report.method}{seed} -> {model.kind}.", "meta"),
        _html.paragraph(verdict(report), "verdict"),
        "<h2>Summary</h2>", _summary(report),
        "<h2>Zero offset</h2>",
        *(_html.paragraph(note) for note in report.notes),
        _html.table(["", "arcmin", "deg"], [["zero offset (circular mean of the error)", f"{report.offset_arcmin:+.4f}",
                                             f"{report.offset_arcmin / ARCMIN_PER_DEG:+.5f}"]],
                    "The offset, stated apart from the shape"),
        "<h2>Error profile and model</h2>",
        _stats_table(stats_columns, "Statistics of the calibration" +
                     (" (of the shape about the zero offset)" if report.arbitrary_zero else "")),
        _figure(figures, "profile"),
        "<h2>Harmonics</h2>", _harmonics_table(report), _figure(figures, "harmonics"),
        "<h2>Model comparison</h2>", _selection_table(report), _figure(figures, "selection"),
        "<h2>Before and after compensation</h2>", _held_out_tables(report), _figure(figures, "before_after"),
    ]
    if report.reversal is not None:
        parts += ["<h2>Reversal (ISO 230-2)</h2>", _reversal_section(report), _figure(figures, "reversal")]
    if report.drift is not None:
        parts += ["<h2>Drift</h2>", _drift_section(report), _figure(figures, "drift")]
    return _html.page(f"encal report: {report.name}", parts)


def write_encoder_report(report, path, *, figures_dir=None, dpi=100):
    """Write the HTML page and its figures as PNG files, all or none.

    Parameters
    ----------
    report : EncoderReport
    path : str or os.PathLike
        The HTML file; its folder must exist.
    figures_dir : str or os.PathLike, optional
        Folder for the PNG files (created); default ``<path stem>_figures`` beside the page.
    dpi : int, default=100

    Returns
    -------
    dict of str to Path
        ``'report'`` and one ``'figure:<name>'`` per figure.
    """
    check_type(report, EncoderReport, "report", "write_encoder_report", "an EncoderReport")
    dpi = check_int(dpi, "dpi", "write_encoder_report", low=1, high=MAX_DPI, note="dots per inch")
    path = Path(path)
    if not path.parent.is_dir():
        raise InputError(f"cannot write {path}: the folder {path.parent} does not exist")
    if path.is_dir():
        raise InputError(f"cannot write {path}: it is a folder; expected the path of an HTML file")
    folder = Path(figures_dir) if figures_dir is not None else path.with_name(f"{path.stem}_figures")
    figures = render_encoder_figures(report, dpi=dpi)
    written = {}
    with atomic_file_set():
        folder.mkdir(parents=True, exist_ok=True)
        for name, png in figures.items():
            written[f"figure:{name}"] = folder / f"{name}.png"
            atomic_write(written[f"figure:{name}"], png)
        atomic_write(path, build_encoder_html(report, figures))
        written["report"] = path
    return written

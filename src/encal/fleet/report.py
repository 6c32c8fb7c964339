"""The HTML page of ``encal fleet report``: one self-contained file with the fleet's figures and tables."""

import datetime

import numpy as np

from .._core import html as _html
from .._core.atomic import atomic_write
from .._version import __version__
from .statistics import DRIFT_MOVED, STANDS_OUT, drift_table, fleet_statistics, latest_per_serial

__all__ = ["write_fleet_report", "fleet_report_html", "MAX_UNIT_ROWS"]

#: Units listed one per row in the page's table of units; a larger fleet lists those that stand out.
MAX_UNIT_ROWS = 500


def _number(value, digits=4):
    return "-" if value is None else f"{value:.{digits}g}"


def _exact(value):
    """A threshold as given (``1.2``, not ``1.2000000000000002`` nor ``1.235`` for ``1.23456``)."""
    return format(value, ".10g")


def _against(value, limits):
    """``value`` (arc-minutes) with as many digits as it takes to fall on the same side of every limit as it does:
    a held-out estimate of 0.50004 beside a limit of 0.5 is shown 0.50004, never 0.5 graded B."""
    if value is None:
        return "-"
    for digits in range(4, 11):
        text = f"{value:.{digits}g}"
        if all((float(text) <= limit) == (value <= limit) for _, limit in limits or ()):
            return text
    return repr(value)


def _limits_text(limits):
    """``A <= 0.5 arcmin, B <= 1 arcmin``: a set of thresholds as the report states it (arc-minutes)."""
    return ", ".join(f"{name} <= {_exact(limit)}" for name, limit in limits) + " arcmin"


def _limit_of(name, limits, short=False):
    """The held-out RMS a grade of ``limits`` stands for: ``<= 1.2 arcmin (0.02 deg)`` (``short``: ``<= 1.2
    arcmin``), ``> ...`` for the grade of a unit that meets none; arc-minutes exact, as the held-out column."""
    from ..store import GRADE_NONE

    sign, limit = (">", max(limit for _, limit in limits)) if name == GRADE_NONE else ("<=", dict(limits)[name])
    return f"{sign} {_exact(limit)} arcmin" + ("" if short else f" ({limit / 60:.4g} deg)")


def _stored_grade(record):
    """``(grade, thresholds)`` of a record as stored; the thresholds None when the record does not hold them (or
    they do not name its grade)."""
    from ..store import GRADE_NONE

    if record.grade is None:
        return None, None
    limits = record.grade_limits()
    if limits is None or record.grade not in [name for name, _ in limits] + [GRADE_NONE]:
        return record.grade, None
    return record.grade, tuple(limits)


def _grades_table(latest, grades):
    """Each unit's grade as its row in the units' table shows it, the thresholds it was given by (or None), and the
    grades table.

    With ``grades`` every unit is graded again by them. Without, each unit's stored grade is counted with the
    thresholds it was given by (:meth:`Record.grade_limits <encal.store.Record.grade_limits>`): units graded by
    different thresholds (two lots, or two epochs, fitted with different ``--grades``) are counted apart, never
    under one limit, and the units' table gives each grade its limit; a grade whose thresholds the record does not
    hold is said to be so.
    """
    from ..store import GRADE_NONE, grade_of

    if grades is not None:
        by_unit = [(grade_of(r.held_out_arcmin, grades), tuple(grades)) for r in latest]
        limit_sets = [tuple(grades)]
    else:
        by_unit = [_stored_grade(r) for r in latest]
        limit_sets = sorted({limits for grade, limits in by_unit if grade is not None},
                            key=lambda limits: (limits is None, limits or ()))
    keys = []
    for limits in limit_sets:
        keys += [(name, limits) for name in ([name for name, _ in limits] + [GRADE_NONE] if limits is not None else
                                             sorted({g for g, its in by_unit if its is None and g is not None}))]
    several = grades is None and len(limit_sets) > 1
    shown = [grade if not several or limits is None else f"{grade} ({_limit_of(grade, limits, short=True)})"
             for grade, limits in by_unit]
    unit_limits = [limits for _, limits in by_unit]
    if not keys:
        return shown, unit_limits, _html.paragraph("No grades: the units were fitted without --grades, and none are "
                                                   "given to this report (--grades A=0.02,B=0.05).", "note")
    counts = {key: by_unit.count(key) for key in keys}
    rows = [[name, "not recorded" if limits is None else _limit_of(name, limits),
             "this report's --grades" if grades is not None else
             "not recorded (fitted by an encal that did not keep them)" if limits is None else _limits_text(limits),
             str(counts[name, limits]), f"{100 * counts[name, limits] / len(latest):.1f}%"] for name, limits in keys]
    ungraded = sum(grade is None for grade, _ in by_unit)
    if ungraded:
        rows.append(["-", "-", "none: fitted without --grades" if grades is None else "none: no held-out estimate",
                     str(ungraded), f"{100 * ungraded / len(latest):.1f}%"])
    table = _html.table(["grade", "held-out RMS", "graded by", "units", "share"], rows,
                        caption="Grades (the latest epoch of each unit)", numeric=[False, False, False, True, True])
    if several:
        table = _html.paragraph(
            f"The units' latest records were graded by {len(limit_sets)} different sets of thresholds (lots or "
            "epochs fitted with different --grades): each grade is counted with the thresholds it was given by, and "
            "the units' table gives each grade its limit. 'encal fleet report --grades ...' grades every unit again "
            "by one set.", "note") + table
    return shown, unit_limits, table


def _figures(stats, drift):
    from ..figures import detached_figures, figure_png, new_figure

    figures = []
    with detached_figures():
        fig = new_figure((7.2, 3.8))
        ax = fig.add_subplot()
        low, high = np.percentile(stats.profiles, [10, 90], axis=0)
        ax.fill_between(stats.grid_deg, low, high, color="#1f77b4", alpha=0.2, label="10-90% of units")
        ax.plot(stats.grid_deg, stats.mean_profile, color="#1f77b4", label="mean profile")
        ax.plot(stats.grid_deg, stats.mean_profile + stats.spread_profile, color="#1f77b4", ls=":", lw=0.8,
                label="mean +- 1 std")
        ax.plot(stats.grid_deg, stats.mean_profile - stats.spread_profile, color="#1f77b4", ls=":", lw=0.8)
        for index, *_ in stats.standing_out()[:5]:
            ax.plot(stats.grid_deg, stats.profiles[index], lw=0.8, label=f"{stats.records[index].serial} (stands out)")
        ax.set_xlabel("encoder angle (deg)")
        ax.set_ylabel("error (arcmin), offset removed")
        ax.set_xlim(0, 360)
        ax.legend(fontsize="small", loc="upper right")
        figures.append(("fleet-profile", figure_png(fig),
                        f"The fleet's mean error profile and its spread across {len(stats.records)} units (the "
                        "latest epoch of each; zero offsets removed), with the units that stand out most."))
        fig = new_figure((7.2, 3.8))
        ax = fig.add_subplot()
        amplitudes = np.abs(stats.coefficients)
        q10, q90 = np.percentile(amplitudes, [10, 90], axis=0)
        ax.fill_between(stats.orders, q10, q90, step="mid", color="#ff7f0e", alpha=0.25, label="10-90% of units")
        ax.plot(stats.orders, stats.amplitude_median, "o-", color="#ff7f0e", ms=3, label="median amplitude")
        ax.plot(stats.orders, stats.mean_amplitude, "s", color="#222222", ms=3, mfc="none",
                label="amplitude of the mean profile")
        ax.set_yscale("log")
        ax.set_xlabel("harmonic order (per turn)")
        ax.set_ylabel("amplitude (arcmin)")
        ax.legend(fontsize="small")
        figures.append(("fleet-orders", figure_png(fig),
                        "Amplitude of each harmonic order across the fleet: the median unit, the 10-90% band, and "
                        "the order's amplitude in the mean profile (lower when the units' phases differ)."))
        fig = new_figure((7.2, 3.2))
        ax = fig.add_subplot()
        scores = np.clip(stats.overall_scores, -10, 50)
        ax.hist(scores, bins=min(60, max(10, len(scores) // 5)), color="#888888")
        ax.axvline(STANDS_OUT, color="#d62728", ls="--", label=f"stands out (> {STANDS_OUT:g})")
        ax.set_xlabel("overall robust score (modified z of the distance from the median profile)")
        ax.set_ylabel("units")
        ax.legend(fontsize="small")
        figures.append(("fleet-scores", figure_png(fig),
                        "Each unit's overall robust score: (d - median d) / (1.4826 MAD d), d the RMS distance of "
                        "its profile from the fleet's median profile (scores clipped to [-10, 50] for the plot)."))
        if drift:
            fig = new_figure((7.2, 3.2))
            ax = fig.add_subplot()
            for row in drift[:20]:
                ax.plot(row["epochs"], row["drift_arcmin"], "o-", ms=3, label=row["serial"])
            ax.set_xlabel("epoch")
            ax.set_ylabel("RMS change from epoch 1 (arcmin)")
            if len(drift) <= 10:
                ax.legend(fontsize="small")
            figures.append(("fleet-drift", figure_png(fig),
                            "Drift: how far each re-calibrated unit's profile moved from its first epoch (RMS, "
                            "zero offset removed; the 20 units that moved most, against their uncertainty, drawn)."))
    return [_html.figure(name, png, caption) for name, png, caption in figures]


_VERDICTS = {"moved": "moved", "within": "not shown to move", None: "no verdict"}


def _ratio(row):
    """A drift row's change over its uncertainty, or None."""
    if row["uncertainty_arcmin"] is None or not row["uncertainty_arcmin"]:
        return None
    return row["drift_arcmin"][-1] / row["uncertainty_arcmin"]


def _drift_rule(drift):
    """The sentence that says how the drift table's verdicts are reached (the store holds models, not readings)."""
    counts = {verdict: sum(row["verdict"] == verdict for row in drift) for verdict in _VERDICTS}
    return (f"{counts['moved']} of {len(drift)} units moved, {counts['within']} not shown to move"
            + (f", {counts[None]} without a verdict" if counts[None] else "") + ". "
            f"The store holds each epoch's model, not its readings: a unit's profile moved when its RMS change from "
            f"the first to the last epoch exceeds {DRIFT_MOVED:g} times the two models' uncertainties combined, "
            "sqrt(u_first^2 + u_last^2), u each model's standard uncertainty of its profile (RMS over the turn; the "
            "held-out estimate, which holds a new reading's noise too, where a model holds no uncertainty). "
            f"Below {DRIFT_MOVED:g} times a change is not shown to be real (unchanged units calibrated twice come "
            "out near 1); the units are listed by that ratio, the largest first. No verdict: a model without either "
            "figure, or one of an arc. 'encal drift FIRST.csv LATER.csv' on the calibrations (each record keeps its "
            "CSV) tests it against the readings.")


def fleet_report_html(records, *, grades=None, store_name="the store"):
    """The fleet report page, and a one-line summary.

    Parameters
    ----------
    records : list of encal.store.Record
        Every record of the store.
    grades : list of (str, float), optional
        Thresholds to grade by (arc-minutes); default the grades stored.
    store_name : str
        How the page names the store.

    Returns
    -------
    (str, str)
        The HTML document and a summary sentence.
    """
    stats = fleet_statistics(records)
    # the most moved (against its uncertainty) first: the figure's 20 units and the table's 200 rows hold them
    drift = sorted(drift_table(records), key=lambda row: (_ratio(row) is None, -(_ratio(row) or 0.0), row["serial"]))
    latest = stats.records  # calibrated over the whole turn: the statistics' units
    every = latest_per_serial(records)  # every unit: its grade and its row (a model of an arc has no score)
    arcs = len(every) - len(latest)
    score_of = {record.serial: score for record, score in zip(latest, stats.overall_scores)}
    unit_grades, unit_limits, grades_part = _grades_table(every, grades)
    standing = stats.standing_out()
    after = np.array([r.rms_after_arcmin for r in every if r.rms_after_arcmin is not None])
    held = np.array([r.held_out_arcmin for r in every if r.held_out_arcmin is not None])
    parts = [f"<h1>Fleet report</h1>",
             _html.paragraph(f"{len(every)} units"
                             + (f" ({arcs} calibrated over an arc, left out of the fleet's profile, spread and scores: "
                                "a model of an arc holds on its arc only)" if arcs else "")
                             + f", {len(records)} records in {store_name}; written "
                             f"{datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds')} by encal "
                             f"{__version__}.", "meta")]
    verdict = (f"{len(standing)} of {len(latest)} units stand out (overall robust score > {STANDS_OUT:g}). "
               f"Median RMS after correction {_number(np.median(after) if after.size else None)} arcmin"
               + (f", median held-out estimate {_number(np.median(held))} arcmin" if held.size else "") + ".")
    parts.append(_html.paragraph(verdict, "verdict"))
    parts.append("<h2>Grades</h2>")
    parts.append(grades_part)
    parts.append("<h2>The fleet's profile and its spread per order</h2>")
    figures = _figures(stats, drift)
    parts += figures[:2]
    rows = [[str(int(k)), _number(m, 3), _number(1.4826 * d, 3), _number(mean, 3), _number(a, 3), str(int(n))]
            for k, m, d, mean, a, n in zip(stats.orders, stats.amplitude_median, stats.amplitude_mad,
                                           stats.amplitude_mean, stats.mean_amplitude, stats.orders_standing_out())]
    parts.append(_html.table(["order", "median |c_k|", "1.4826 MAD", "mean |c_k|", "|mean c_k|", "units > 3.5"],
                             rows[:20], caption="Amplitude per harmonic order across the fleet (arcmin; orders "
                                                "1 to 20)"))
    parts.append("<h2>Units that stand out</h2>")
    parts.append(figures[2])
    if standing:
        parts.append(_html.table(
            ["serial", "epoch", "overall score", "distance (arcmin)", "worst order", "its score"],
            [[latest[i].serial, str(latest[i].epoch), _number(score, 3), _number(stats.distance_arcmin[i], 3),
              str(order), _number(order_score, 3)] for i, score, order, order_score in standing[:100]],
            caption=f"Units whose overall robust score exceeds {STANDS_OUT:g} (at most 100 shown)",
            numeric=[False, True, True, True, True, True]))
    else:
        parts.append(_html.paragraph(f"No unit's overall robust score exceeds {STANDS_OUT:g}.", "note"))
    parts.append("<h2>Drift across epochs</h2>")
    if drift:
        parts.append(figures[3])
        parts.append(_html.paragraph(_drift_rule(drift), "note"))
        parts.append(_html.table(
            ["serial", "epochs", "drift at the last epoch (arcmin)", "uncertainty of the change (arcmin)",
             "drift / uncertainty", "verdict", "order that moved most", "its change (arcmin)"],
            [[row["serial"], str(len(row["epochs"])), _number(row["drift_arcmin"][-1], 3),
              _number(row["uncertainty_arcmin"], 3) + ("" if row["basis"] != "held-out" else " (held-out)"),
              _number(_ratio(row), 3), _VERDICTS[row["verdict"]],
              "-" if row["largest_order"] is None else str(row["largest_order"]),
              _number(row["largest_change_arcmin"], 3)] for row in drift[:200]],
            caption="Units calibrated more than once, the most moved first (at most 200 shown)",
            numeric=[False, True, True, True, True, False, True, True]))
    else:
        parts.append(_html.paragraph("No unit was calibrated more than once.", "note"))
    parts.append("<h2>Units</h2>")
    standing_serials = {latest[i].serial for i, *_ in standing}
    shown = [i for i, record in enumerate(every) if len(every) <= MAX_UNIT_ROWS or record.serial in standing_serials]
    if len(every) > MAX_UNIT_ROWS:
        parts.append(_html.paragraph(f"{len(every)} units: those that stand out are listed; 'encal fleet' keeps "
                                     "every record in the store.", "note"))
    parts.append(_html.table(
        ["serial", "epoch", "station", "points", "RMS before", "RMS after", "held-out", "grade", "score"],
        [[every[i].serial, str(every[i].epoch), every[i].station or "-", str(every[i].n_points or "-"),
          _number(every[i].rms_before_arcmin), _number(every[i].rms_after_arcmin),
          _against(every[i].held_out_arcmin, unit_limits[i]), unit_grades[i] or "-",
          _number(score_of[every[i].serial], 3) if every[i].serial in score_of else "- (an arc)"]
         for i in shown], caption="The latest record of each unit (arcmin)",
        numeric=[False, True, False, True, True, True, True, False, True]))
    summary = (f"{len(every)} units" + (f" ({arcs} over an arc, not scored)" if arcs else "")
               + f", {len(standing)} stand out, {len(drift)} calibrated more than once")
    return _html.page("encal fleet report", parts), summary


def write_fleet_report(records, path, *, grades=None, store_name="the store", progress=None):
    """Write the fleet report page to ``path`` atomically; return its summary sentence."""
    if progress is not None:
        progress.stage("fleet statistics and figures")
    document, summary = fleet_report_html(records, grades=grades, store_name=store_name)
    atomic_write(path, document)
    return summary

"""Figures of the paper's procedure, drawn with Matplotlib.

Every ``plot_*`` function (and every result's ``plot()`` method) draws on ``ax`` and returns it. With
``ax=None`` it follows Matplotlib's own convention: it draws on pyplot's current axes (a new figure when
there is none), so a notebook shows it and ``plt.savefig`` saves it. encal's own reports draw inside
:func:`detached_figures`, where ``ax=None`` makes a :class:`matplotlib.figure.Figure` that pyplot does
not manage: nothing opens a window, and figures made in a loop are freed with their last reference.
The ``*_figure`` functions lay out one panel per encoder, (a)-(d) as in the paper.

The smooth curves through error profiles and residuals (the paper's
"smoothened spline") are periodic smoothing splines, computed by
:func:`encal.numerics.spline.periodic_smoothing_spline`; this module only draws.
"""

import contextlib
import contextvars
import io
import math

import numpy as np

from .._core.atomic import atomic_write
from .._core.errors import InputError
from .._core.parameters import check_number, invalid, real_array
from ..numerics.spline import periodic_smoothing_spline

__all__ = [
    "detached_figures",
    "html_repr",
    "new_axes",
    "panel_figure",
    "save_figure",
    "figure_png",
    "plot_profile",
    "plot_harmonics",
    "plot_error_stats",
    "plot_model",
    "plot_before_after",
    "plot_selection",
    "plot_reversal",
    "plot_drift",
    "plot_sweep",
    "plot_training_curves",
    "plot_algorithms",
    "plot_singular_values",
    "plot_residuals",
    "plot_repeats",
]

_TRAIN_COLOUR = "#1f77b4"
_TEST_COLOUR = "#ff7f0e"
_CURVE_COLOUR = "#222222"
_FLOOR_COLOUR = "#bbbbbb"


_DETACHED = contextvars.ContextVar("encal_detached_figures", default=False)


@contextlib.contextmanager
def detached_figures():
    """Within this context, ``ax=None`` draws on a new Figure that pyplot does not manage.

    encal's reports draw their figures inside it: they never touch the user's pyplot state, open no
    window, and free each figure with its last reference.
    """
    token = _DETACHED.set(True)
    try:
        yield
    finally:
        _DETACHED.reset(token)


def new_figure(figsize=(6.4, 3.6)):
    """A new figure of ``figsize`` inches: detached inside :func:`detached_figures`, else pyplot's."""
    if _DETACHED.get():
        from matplotlib.figure import Figure

        return Figure(figsize=figsize, layout="constrained")
    import matplotlib.pyplot as plt

    return plt.figure(figsize=figsize, layout="constrained")


def new_axes(ax=None, figsize=(6.4, 3.6)):
    """``ax``; else pyplot's current axes (a new figure of ``figsize`` inches when pyplot has none), or,
    inside :func:`detached_figures`, the axes of a new Figure that pyplot does not manage."""
    if ax is not None:
        return ax
    if _DETACHED.get():
        return new_figure(figsize).add_subplot()
    import matplotlib.pyplot as plt

    if not plt.get_fignums():
        new_figure(figsize)
    return plt.gca()


def panel_figure(items, draw, *, title=None, ncols=2, panel_size=(4.6, 3.0), sharey=False):
    """One panel per item, labelled (a), (b), ... as in the paper's figures.

    Parameters
    ----------
    items : mapping of str to object
        Panel name (the encoder) -> what ``draw`` plots.
    draw : callable
        ``draw(obj, ax)``; it sets the panel's own title.
    title : str, optional
        Figure title.
    ncols : int, default=2
    panel_size : (float, float), default=(4.6, 3.0)
        Inches per panel.
    sharey : bool, default=False

    Returns
    -------
    matplotlib.figure.Figure
    """
    names = list(items)
    if not names:
        raise InputError("panel_figure needs at least one item to draw. Got none.")
    ncols = min(ncols, len(names))
    nrows = math.ceil(len(names) / ncols)
    fig = new_figure((panel_size[0] * ncols, panel_size[1] * nrows + (0.4 if title else 0)))
    axes = np.atleast_1d(fig.subplots(nrows, ncols, sharey=sharey, squeeze=False).ravel())
    for index, (name, ax) in enumerate(zip(names, axes)):
        draw(items[name], ax)
        ax.set_title(f"({_panel_label(index)}) {ax.get_title()}", fontsize="medium")
    for ax in axes[len(names):]:
        ax.set_visible(False)
    if title:
        fig.suptitle(title)
    return fig


def html_repr(obj, *, dpi=80):
    """A notebook's rich display of an encal result: its text table and its figure (``obj.plot``).

    The figure is drawn detached from pyplot, so displaying a result leaves the user's figures alone.
    """
    import base64
    import html

    with detached_figures():
        figure = obj.plot().figure
        png = base64.b64encode(figure_png(figure, dpi=dpi)).decode("ascii")
    return (f"<pre>{html.escape(str(obj))}</pre>"
            f'<img alt="{html.escape(type(obj).__name__)}" src="data:image/png;base64,{png}">')


def figure_png(fig, dpi=100):
    """The figure as PNG bytes."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    return buffer.getvalue()


def save_figure(fig, path, dpi=100):
    """Write the figure as a PNG file, atomically; returns the path."""
    atomic_write(path, figure_png(fig, dpi=dpi))
    return path


# --------------------------------------------------------------------------- Fig. 1 and spectra


def _points(caller, **columns):
    """The columns of a set of points as 1-D float arrays of one length (NaN kept: a plot leaves a gap), or the
    sentence saying which one is not numbers or has another length (matplotlib's own error named no parameter)."""
    arrays = [real_array(values, name, caller).reshape(-1) for name, values in columns.items()]
    if len({array.size for array in arrays}) > 1:
        sizes = ", ".join(f"{name} {array.size}" for name, array in zip(columns, arrays))
        raise InputError(f"{caller} expects one value of each per point; got {sizes}")
    return arrays


def plot_profile(theta_deg, error_arcmin, *, test=None, smooth=True, ax=None, title=None, label="calibration",
                 test_label="test"):
    """Fig. 1: an error profile against the encoder angle, with a smooth periodic curve.

    Parameters
    ----------
    theta_deg, error_arcmin : array-like of shape (n,)
        Calibration points: encoder angles (degrees) and errors ``encoder − reference`` (arcmin).
    test : (array-like, array-like), optional
        Test points, drawn in another colour; the curve passes through both sets.
    smooth : bool, default=True
        Draw the periodic smoothing spline through all points.
    ax : matplotlib.axes.Axes, optional
    title : str, optional
    label, test_label : str, default='calibration', 'test'
        Legend labels of the two sets of points (the demo's are 'training grid' and 'test grid').

    Returns
    -------
    matplotlib.axes.Axes
    """
    theta, error = _points("plot_profile", theta_deg=theta_deg, error_arcmin=error_arcmin)
    if test is not None:
        test = _points("plot_profile", test_theta_deg=test[0], test_error_arcmin=test[1])
    ax = new_axes(ax)
    draw_points(ax, theta, error, colour=_TRAIN_COLOUR, label=label)
    all_theta, all_error = theta, error
    if test is not None:
        test_theta, test_error = test
        draw_points(ax, test_theta, test_error, colour=_TEST_COLOUR, label=test_label)
        all_theta, all_error = np.r_[theta, test_theta], np.r_[error, test_error]
    if smooth:
        spline = periodic_smoothing_spline(all_theta, all_error)
        grid = np.linspace(0.0, 360.0, 1441)
        ax.plot(grid, spline(grid), "-", lw=1.0, color=_CURVE_COLOUR, label="smoothing spline")
    _angle_axis(ax)
    ax.set_ylabel("error θ_enc − θ_ref (arcmin)")
    if title is not None:
        ax.set_title(title)
    _legend(ax)
    return ax


def plot_harmonics(harmonics, *, n_label=10, ax=None, title=None):
    """The harmonic spectrum of an error profile: amplitude against order, the largest labelled.

    Parameters
    ----------
    harmonics : Harmonics
        From :func:`encal.harmonics`.
    n_label : int, default=10
        Label the orders of the ``n_label`` largest amplitudes (the paper's top-10 rule).
    ax : matplotlib.axes.Axes, optional
    title : str, optional
    """
    ax = new_axes(ax)
    orders = np.asarray(harmonics.orders)
    amplitude = np.asarray(harmonics.amplitude_arcmin)
    floor = max(amplitude.max() * 1e-4, 1e-6)
    shown = np.maximum(amplitude, floor)
    ax.vlines(orders, floor, shown, color=_TRAIN_COLOUR, lw=0.8)
    top = harmonics.top(n_label)
    ax.plot(top, shown[top], "o", ms=4, color=_TEST_COLOUR,
            label=f"top {len(top)}: {' '.join(str(k) for k in top)}")
    labelled = []
    for k in top:  # largest first; skip a label that would overlap a larger one's
        if all(abs(k - other) >= 0.04 * orders.max() for other in labelled):
            ax.annotate(str(k), (k, shown[k]), textcoords="offset points", xytext=(0, 4), ha="center",
                        fontsize="x-small")
            labelled.append(k)
    ax.set_yscale("log")
    ax.set_ylim(floor, amplitude.max() * 3)
    ax.set_xlim(-1, _orders_that_carry(orders, amplitude, top) + 1)
    ax.set_xlabel("harmonic order (cycles per revolution)")
    ax.set_ylabel("amplitude (arcmin)")
    if title is not None:
        ax.set_title(title)
    ax.legend(loc="upper right", fontsize="small", frameon=False)
    return ax


def _orders_that_carry(orders, amplitude, top):
    """The highest order worth showing: past every order well above the spectrum's noise (five times its
    median amplitude), with a margin; at least 20, at most the highest order. A top-10 order in the noise
    (a profile with fewer lines) stays in the legend but does not stretch the axis."""
    if orders.size <= 20:
        return int(orders.max())
    noise = float(np.median(amplitude[1:]))
    carrying = orders[amplitude > 5.0 * noise]
    last = max(([int(carrying.max())] if carrying.size else []) + [20])
    return int(min(orders.max(), np.ceil(1.15 * last) + 2))


# --------------------------------------------------------------------------- results of the public API


def plot_error_stats(stats, ax=None):
    """MAE, RMS, STD and max |error| of one or more :class:`~encal.analysis.profile.ErrorStats` as grouped bars.

    Parameters
    ----------
    stats : mapping of str to ErrorStats
        Label -> statistics (arcmin), e.g. ``{"before": e.before, "after": e.after}``.
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.axes.Axes
    """
    ax = new_axes(ax)
    names = ("MAE", "RMS", "STD", "max |error|")
    y = np.arange(len(names))
    height = 0.8 / max(len(stats), 1)
    for index, (label, entry) in enumerate(stats.items()):
        values = [entry.mae, entry.rms, entry.std, entry.max_abs]
        bars = ax.barh(y + (index - (len(stats) - 1) / 2) * height, values, height=height, color=f"C{index}",
                       label=label)
        ax.bar_label(bars, fmt="%.3g", fontsize="x-small", padding=2)
    ax.set_yticks(y, names)
    ax.invert_yaxis()
    ax.set_xlabel("arcmin")
    offsets = [e.offset for e in stats.values() if e.offset is not None]
    if offsets:
        ax.set_title(f"about the zero offset ({', '.join(f'{o:+.1f}' for o in offsets)} arcmin, apart)",
                     fontsize="small")
    ax.legend(fontsize="x-small", frameon=False, loc="lower right")
    return ax


def plot_model(model, *, data=None, ax=None, title=None, coverage=0.95, offset_arcmin=0.0, band_of="a new reading"):
    """A model's predicted error against the encoder angle, with its uncertainty band when it has one.

    Parameters
    ----------
    model : Model
        Any encal model (``model.predict(theta_deg) -> arcmin``).
    data : (array-like, array-like), optional
        Calibration points (encoder angles in degrees, errors in arcmin) drawn under the curve.
    ax : matplotlib.axes.Axes, optional
    title : str, optional
    coverage : float, default=0.95
        Coverage of the band ``± z σ`` (normal quantile) drawn when the model carries an uncertainty.
    offset_arcmin : float, default=0.0
        A zero offset subtracted from the curve and the points (an arbitrary zero, stated apart), so
        the figure shows the shape.
    band_of : str, default='a new reading'
        What the band covers, for its legend ("the encoder's error" when the model holds no reading noise).

    Returns
    -------
    matplotlib.axes.Axes
    """
    from scipy.stats import norm

    if not callable(getattr(model, "predict", None)):
        raise invalid("model", "plot_model", "a Model", model, shown=f"an object of type {type(model).__name__}")
    coverage = check_number(coverage, "coverage", "plot_model", low=0.0, high=1.0, low_open=True, high_open=True,
                            note="the share of readings the band covers")
    if data is not None:
        data = _points("plot_model", theta_deg=data[0], error_arcmin=data[1])
    ax = new_axes(ax)
    grid = np.linspace(0.0, 360.0, 1441)
    shift = lambda values: _wrapped_arcmin(np.asarray(values, dtype=float) - offset_arcmin)  # noqa: E731
    if data is not None:
        theta, error = data
        draw_points(ax, theta, shift(error), colour=_TRAIN_COLOUR, label="calibration")
    # a directional model keeps its uncertainty in its parts (has_uncertainty): its band is that of a reading whose
    # direction is unknown, as the report's verdict states it
    if getattr(model, "uncertainty", None) is not None or getattr(model, "has_uncertainty", False):
        mean, std = model.predict(grid, return_std=True)
        mean = shift(mean)
        z = float(norm.ppf(0.5 + coverage / 2))
        ax.fill_between(grid, mean - z * std, mean + z * std, color=_TEST_COLOUR, alpha=0.3, lw=0,
                        label=f"{100 * coverage:.0f} % band of {band_of}")
    else:
        mean = shift(model.predict(grid))
    ax.plot(grid, mean, "-", lw=1.2, color=_CURVE_COLOUR, label=f"{model.kind} model")
    _angle_axis(ax)
    ax.set_ylabel("error θ_enc − θ_ref (arcmin)" if offset_arcmin == 0.0 else
                  f"error − zero offset {offset_arcmin:+.1f} (arcmin)")
    if title is not None:
        ax.set_title(title)
    _legend(ax)
    return ax


def plot_before_after(theta_deg, before_arcmin, after_arcmin, *, ax=None, title=None, floor_arcmin=None,
                      labels=("before", "after")):
    """Errors before and after compensation on the same axes, against the encoder angle.

    Parameters
    ----------
    theta_deg : array-like of shape (n,)
        Encoder angles, degrees.
    before_arcmin, after_arcmin : array-like of shape (n,)
        Raw errors and residuals after compensation, arcmin (same zero convention for both).
    ax : matplotlib.axes.Axes, optional
    title : str, optional
    floor_arcmin : float, optional
        Draw ± this band (a measurement floor or 1 LSB).
    labels : (str, str), default=('before', 'after')

    Returns
    -------
    matplotlib.axes.Axes
    """
    theta, before, after = _points("plot_before_after", theta_deg=theta_deg, before_arcmin=before_arcmin,
                                   after_arcmin=after_arcmin)
    ax = new_axes(ax)
    order = np.argsort(theta)
    if floor_arcmin is not None:
        ax.axhspan(-floor_arcmin, floor_arcmin, color=_FLOOR_COLOUR, alpha=0.35, lw=0,
                   label=f"± {floor_arcmin:.3g} arcmin")
    rms = lambda values: float(np.sqrt(np.mean(values**2)))  # noqa: E731
    draw_points(ax, theta[order], before[order], colour=_TRAIN_COLOUR,
                label=f"{labels[0]} (RMS {rms(before):.3g} arcmin)")
    draw_points(ax, theta[order], after[order], colour=_TEST_COLOUR,
                label=f"{labels[1]} (RMS {rms(after):.3g} arcmin)")
    ax.axhline(0.0, color=_CURVE_COLOUR, lw=0.5)
    _angle_axis(ax)
    ax.set_ylabel("error (arcmin)")
    if title is not None:
        ax.set_title(title)
    _legend(ax)
    return ax


def plot_selection(selection, ax=None):
    """The automatic choice's cross-validation table as bars: CV RMS per candidate, the chosen one marked.

    Parameters
    ----------
    selection : dict
        ``model.training['selection']`` of a model made by ``method='auto'``.
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.axes.Axes
    """
    rows = [row for row in selection.get("table") or [] if row.get("cv_rms_arcmin") is not None]
    ax = new_axes(ax, figsize=(6.4, 0.8 + 0.28 * len(rows)))
    rows.sort(key=lambda row: row["cv_rms_arcmin"])
    y = np.arange(len(rows))
    chosen = selection.get("chosen")
    marked = [row["label"] == chosen or (chosen == "spectral" and row.get("family") == "spectral") for row in rows]
    colours = [_TEST_COLOUR if mark else _TRAIN_COLOUR for mark in marked]
    names = [f"stack of {len(row['options']['members'])}" if row["family"] == "stack" else row["label"]
             for row in rows]
    values = [row["cv_rms_arcmin"] for row in rows]
    bars = ax.barh(y, values, color=colours)
    ax.bar_label(bars, fmt="%.4g", fontsize="x-small", padding=2)
    if values and min(values) > 0 and max(values) > 10 * min(values):
        ax.set_xscale("log")  # one failed family must not flatten the others
    ax.set_yticks(y, names, fontsize="x-small")
    ax.invert_yaxis()
    what = ("RMS on the test calibrations" if selection.get("scheme") == "tests"
            else f"cross-validated RMS over {selection['folds']} folds")
    ax.set_xlabel(f"{what} (arcmin)")
    ax.set_title("encal fit's choice in orange", fontsize="small")
    return ax


# --------------------------------------------------------------------------- Fig. 2 and Table 2


def plot_sweep(sweep, ax=None):
    """Fig. 2a: final training MSE (arcmin²) against the number of hidden nodes, per algorithm.

    Error bars span ± one standard deviation over seeds (none for a single seed). When the sweep measured a
    test calibration, the median final test MSE is drawn dashed in the same colour.
    """
    ax = new_axes(ax)
    for index, algorithm in enumerate(sweep.algorithms):
        colour = f"C{index % 10}"
        mean, std = sweep.mse_mean(algorithm), sweep.mse_std(algorithm)
        ax.errorbar(sweep.hidden, mean, yerr=std if sweep.n_seeds > 1 else None, marker="o", ms=4,
                    capsize=2, lw=1.2, color=colour, label=f"{algorithm}, training")
        test = sweep.test_mse_median(algorithm)
        if test is not None:
            ax.plot(sweep.hidden, test, "--", marker="s", ms=3, mfc="none", lw=1.0, color=colour,
                    label=f"{algorithm}, test (median)")
    if 80 in sweep.hidden:
        ax.axvline(80, color=_FLOOR_COLOUR, ls=":", lw=1, label="paper's choice, N = 80")
    ax.set_yscale("log")
    ax.set_xlabel("hidden nodes N")
    ax.set_ylabel("final MSE (arcmin²)")
    ax.set_title(f"1:N:1 network, {sweep.encoding} input, {sweep.encoder}")
    ax.legend(fontsize="x-small", frameon=False)
    return ax


def plot_training_curves(curves, *, hidden=None, test=None, ax=None):
    """Fig. 2b: training MSE (arcmin²) against epoch, one colour per algorithm (first seed bold).

    Parameters
    ----------
    curves : mapping of str to list of ndarray
        Algorithm -> MSE per epoch (epoch 0 first) of each seed's fit.
    hidden : int, optional
        Hidden-node count, for the title.
    test : mapping of str to list of ndarray, optional
        The same fits' MSE on test points per epoch, drawn dashed.
    ax : matplotlib.axes.Axes, optional
    """
    ax = new_axes(ax)
    for index, (algorithm, runs) in enumerate(curves.items()):
        colour = f"C{index % 10}"
        for kind, style, series in (("training", "-", runs), ("test", "--", (test or {}).get(algorithm))):
            for k, curve in enumerate(r for r in (series or []) if r is not None):
                label = (f"{algorithm}, {kind}" if test else algorithm) if k == 0 else None
                ax.plot(np.arange(curve.size), curve, style, color=colour, lw=1.2 if k == 0 else 0.6,
                        alpha=1.0 if k == 0 else 0.4, label=label)
    ax.set_yscale("log")
    ax.set_xlabel("epoch")
    ax.set_ylabel("MSE (arcmin²)")
    if hidden is not None:
        ax.set_title(f"1:{hidden}:1 network")
    ax.legend(fontsize="x-small", frameon=False, ncols=2)
    return ax


def plot_algorithms(study, ax=None, *, paper_mse=None):
    """Table 2 as a figure: final MSE per algorithm, mean (dot) and range over seeds (bar), paper's value (x).

    ``paper_mse`` (algorithm name -> the paper's final MSE, arcmin²) is drawn as crosses when given; the
    study passes the paper's Table 2 (figures draw what they are given and know no study).
    """
    paper_mse = paper_mse or {}
    ax = new_axes(ax)
    rows = sorted(study.rows, key=lambda r: r.mse_mean, reverse=True)
    y = np.arange(len(rows))
    ax.hlines(y, [r.mse_min for r in rows], [r.mse_max for r in rows], color=_TRAIN_COLOUR, lw=2.5,
              alpha=0.5, label=f"range over {study.n_seeds} seeds")
    ax.plot([r.mse_mean for r in rows], y, "o", color=_TRAIN_COLOUR, ms=5, label="mean")
    paper = [(paper_mse[r.algorithm], i) for i, r in enumerate(rows) if r.algorithm in paper_mse]
    if paper:
        ax.plot(*zip(*paper), "x", color=_TEST_COLOUR, ms=6, mew=1.5, label="paper (one run)")
    ax.set_yticks(y, [r.algorithm for r in rows])
    ax.set_xscale("log")
    ax.set_xlabel("final training MSE (arcmin²)")
    ax.set_title(f"1:{study.hidden}:1, {study.epochs} epochs each, {study.encoder}")
    ax.legend(fontsize="x-small", frameon=False, loc="lower right")
    return ax


# --------------------------------------------------------------------------- Fig. 3


def plot_singular_values(pruning, ax=None):
    """Fig. 3: singular values of the hidden layer before and after the activation, relative to the largest.

    The paper's matrix (before the sigmoid) has rank 2 for one input: its singular values beyond the second
    are rounding noise, drawn at their (tiny) values. After the activation, the significant ones are those
    above the threshold line.
    """
    ax = new_axes(ax)
    index = np.arange(1, pruning.singular_after.size + 1)
    tiny = 1e-17
    before = np.maximum(pruning.singular_before / pruning.singular_before[0], tiny)
    after = np.maximum(pruning.singular_after / pruning.singular_after[0], tiny)
    ax.semilogy(index, before, "s", ms=3, mfc="none", color=_FLOOR_COLOUR,
                label=f"X before sigmoid (paper), rank {pruning.rank_before_activation}")
    ax.semilogy(index, after, "o", ms=3, color=_TRAIN_COLOUR, label="H after sigmoid")
    ax.axhline(pruning.threshold, color=_TEST_COLOUR, ls="--", lw=1,
               label=f"threshold {pruning.threshold:g}: {pruning.significant} significant")
    ax.set_ylim(tiny / 3, 3)
    ax.set_xlabel("singular value index")
    ax.set_ylabel("σ_i / σ_1")
    ax.set_title(f"{pruning.encoder}: 1:{pruning.hidden}:1 {pruning.encoding}")
    ax.legend(fontsize="x-small", frameon=False, loc="center right")
    return ax


# --------------------------------------------------------------------------- Fig. 4


def plot_residuals(comparison, key="ann-paper", ax=None, smooth=True):
    """Fig. 4: one model's residual on the test grid against the encoder angle, with a smooth curve.

    Parameters
    ----------
    comparison : Comparison
        From :func:`encal.paper.studies.comparison.compare_models`.
    key : str, default='ann-paper'
        Which model (``'fourier'``, ``'lut-linear'``, ``'lut-cubic'``, ``'ann-paper'``, ``'ann-periodic'``).
    ax : matplotlib.axes.Axes, optional
    smooth : bool, default=True
        Draw a periodic smoothing spline, to show systematic structure left in the residual.
    """
    ax = new_axes(ax)
    entry = comparison.entry(key)
    theta = comparison.encoder_deg
    if entry.floor_arcmin is not None:
        ax.axhspan(-entry.floor_arcmin, entry.floor_arcmin, color=_FLOOR_COLOUR, alpha=0.35, lw=0,
                   label=f"± measurement floor ({entry.floor_arcmin:.2f})")
    ax.plot(theta, entry.residual_arcmin, ".", ms=3.5, color=_TEST_COLOUR, label="test grid")
    if smooth:
        spline = periodic_smoothing_spline(theta, entry.residual_arcmin)
        grid = np.linspace(0.0, 360.0, 1441)
        ax.plot(grid, spline(grid), "-", lw=1.0, color=_CURVE_COLOUR, label="smoothing spline")
    ax.axhline(0.0, color=_CURVE_COLOUR, lw=0.5)
    _angle_axis(ax)
    ax.set_ylabel("residual (arcmin)")
    ax.set_title(f"{comparison.encoder}: {entry.label}, RMS {entry.stats.rms:.3f}")
    _legend(ax)
    return ax


# --------------------------------------------------------------------------- reproducibility


def plot_repeats(result, ax=None):
    """Repeat calibration minus first calibration against the reference angle, with the ± 1 LSB band."""
    ax = new_axes(ax)
    if result.lsb_arcmin is not None:
        ax.axhspan(-result.lsb_arcmin, result.lsb_arcmin, color=_FLOOR_COLOUR, alpha=0.35, lw=0,
                   label=f"± 1 LSB ({result.lsb_arcmin:.3f})")
    for index, run in enumerate(result.runs):
        ax.plot(run.reference_deg, run.difference_arcmin, ".-", ms=3, lw=0.5, color=f"C{index}",
                label=f"{run.label} − first (RMS {run.difference.rms:.2f})")
    _angle_axis(ax)
    ax.set_xlabel("reference angle (deg)")
    ax.set_ylabel("difference (arcmin)")
    ax.set_title(result.encoder)
    _legend(ax)
    return ax


def plot_reversal(analysis, ax=None, title=None, offset_arcmin=0.0):
    """ISO 230-2 reversal: mean deviations approached forward and reverse against the target, and ``B_i``.

    Parameters
    ----------
    analysis : ReversalAnalysis
        From :func:`encal.data.reversal.reversal`.
    ax : matplotlib.axes.Axes, optional
    title : str, optional
    offset_arcmin : float, default=0.0
        A zero offset subtracted from the mean deviations (an arbitrary zero, stated apart); ``B_i`` does
        not depend on it.

    Returns
    -------
    matplotlib.axes.Axes
    """
    ax = new_axes(ax)
    target = analysis.target_deg
    forward = _wrapped_arcmin(analysis.mean_forward_arcmin - offset_arcmin)
    reverse = _wrapped_arcmin(analysis.mean_reverse_arcmin - offset_arcmin)
    about = "" if offset_arcmin == 0.0 else " − offset"
    ax.plot(target, forward, ".-", ms=3, lw=0.6, color=_TRAIN_COLOUR, label=f"x̄↑ forward{about}")
    ax.plot(target, reverse, ".-", ms=3, lw=0.6, color=_TEST_COLOUR, label=f"x̄↓ reverse{about}")
    ax.plot(target, analysis.reversal_arcmin, "-", lw=1.0, color=_CURVE_COLOUR,
            label=f"B_i = x̄↑ − x̄↓ (B = {analysis.reversal_value:.3g})")
    ax.axhline(0.0, color=_CURVE_COLOUR, lw=0.4)
    _angle_axis(ax)
    ax.set_xlabel("target (reference angle, deg)")
    ax.set_ylabel("deviation (arcmin)")
    if title is not None:
        ax.set_title(title)
    _legend(ax)
    return ax


def plot_drift(report, ax=None, title=None):
    """Each later calibration minus the first at the same positions (arcmin), from a drift report.

    Parameters
    ----------
    report : DriftReport
        From :func:`encal.reports.drift.compare_calibrations`.
    ax : matplotlib.axes.Axes, optional
    title : str, optional

    Returns
    -------
    matplotlib.axes.Axes
    """
    ax = new_axes(ax)
    if report.lsb_arcmin is not None:
        ax.axhspan(-report.lsb_arcmin, report.lsb_arcmin, color=_FLOOR_COLOUR, alpha=0.35, lw=0,
                   label=f"± 1 LSB ({report.lsb_arcmin:.3g})")
    for index, epoch in enumerate(report.epochs):
        order = np.argsort(epoch.angle_deg)
        ax.plot(epoch.angle_deg[order], epoch.difference_arcmin[order], ".", ms=3, color=f"C{index}",
                label=f"{epoch.label} (RMS {epoch.difference.rms:.3g})")
    ax.axhline(0.0, color=_CURVE_COLOUR, lw=0.4)
    _angle_axis(ax)
    ax.set_xlabel("position (reference angle, deg)")
    ax.set_ylabel(f"difference from {report.baseline_label} (arcmin)", fontsize="small")
    if title is not None:
        ax.set_title(title)
    _legend(ax)
    return ax


def _wrapped_arcmin(values):
    """Arc-minutes wrapped to (-10800, 10800] (within half a turn of zero)."""
    return -np.mod(-values + 10800.0, 21600.0) + 10800.0


def _legend(ax):
    """A framed legend, legible at a page's width, that lets the data show through."""
    ax.legend(fontsize="small", loc="best", frameon=True, framealpha=0.75, edgecolor="none")


#: Above this many points a profile is drawn as a band per angle bin instead of one dot per point (dots
#: would merge into a solid blob).
DENSE_POINTS = 2000

def draw_points(ax, theta_deg, values_arcmin, *, colour, label, marker="."):
    """Points of a profile: one dot each, or, above :data:`DENSE_POINTS`, the median and the middle 95 % of
    each bin of angle as a line in a band (a dense log drawn dot by dot is a blob). The bins hold about 25
    points each, between 360 and 3600 bins a turn, so a detent ripple of a 200-step motor stays visible."""
    theta = np.asarray(theta_deg, dtype=float)
    values = np.asarray(values_arcmin, dtype=float)
    if theta.size <= DENSE_POINTS:
        ax.plot(theta, values, marker, ms=3.5, color=colour, label=label, ls="none")
        return
    bins = int(np.clip(theta.size // 25, 360, 3600))
    width = 360.0 / bins
    index = np.clip((np.mod(theta, 360.0) / width).astype(int), 0, bins - 1)
    order = np.argsort(index, kind="stable")
    sorted_index, sorted_values = index[order], values[order]
    starts = np.searchsorted(sorted_index, np.arange(bins + 1))
    low, middle, high = (np.full(bins, np.nan) for _ in range(3))
    for k in np.flatnonzero(np.diff(starts)):
        low[k], middle[k], high[k] = np.percentile(sorted_values[starts[k]:starts[k + 1]], [2.5, 50.0, 97.5])
    centres = (np.arange(bins) + 0.5) * width
    ax.fill_between(centres, low, high, color=colour, alpha=0.35, lw=0,
                    label=f"{label}: median, middle 95 % per {width:.2g}° ({theta.size} points)")
    ax.plot(centres, middle, "-", lw=0.8, color=colour, label="_nolegend_")


def _angle_axis(ax):
    ax.set_xlim(0.0, 360.0)
    ax.set_xticks(np.arange(0, 361, 60))
    ax.set_xlabel("encoder angle θ_enc (deg)")


def _panel_label(index):
    """Panel label of the index-th panel: a ... z, then aa, ab, ... (a fleet may have hundreds of encoders)."""
    label = ""
    index += 1
    while index:
        index, letter = divmod(index - 1, 26)
        label = chr(ord("a") + letter) + label
    return label

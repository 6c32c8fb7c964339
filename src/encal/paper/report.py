"""The demo's report: one self-contained HTML file.

Figures are embedded as base64 PNG and the style sheet is inline, so the file
can be mailed or archived alone and opens without a network. Numbers in the
text come from the same result objects as the tables.
"""

import base64
import html

import numpy as np

from .._core.atomic import atomic_write
from .._core.html import CSS as _CSS
from .._version import __version__

__all__ = ["FIGURES", "render_figures", "build_report", "write_report"]

#: Figure name -> caption, in report order.
FIGURES = {
    "fig1_profiles": "Fig. 1. Error profiles θ_enc − θ_ref against the encoder angle: training grid, test grid and "
                     "a periodic cubic smoothing spline through both (smoothing chosen by generalised "
                     "cross-validation).",
    "harmonics": "Harmonic spectra of the training runs; the ten largest orders (the paper's Fourier-series "
                 "terms) are marked and labelled.",
    "fig2a_sweep": "Fig. 2a. Final training MSE of the 1:N:1 network against N (mean ± standard deviation "
                   "over seeds).",
    "fig2b_training": "Fig. 2b. Training MSE against epoch for N = 80 (first seed solid, others faint).",
    "table2_algorithms": "Table 2 as a figure: final MSE of each algorithm (mean, range over seeds, the "
                         "paper's single value), and MSE against epoch for the first seed.",
    "fig3_singular_values": "Fig. 3. Singular values of the hidden layer of each encoder's 1:80:1 network, "
                            "relative to the largest: the paper's matrix before the sigmoid (grey, rank 2) and "
                            "the hidden-node outputs after it (blue), with the significance threshold.",
    "fig4_residuals": "Fig. 4. Residual error on the test grid of the paper's 1:80:1 raw network, with a "
                      "periodic smoothing spline; the grey band is ± the measurement floor.",
    "before_after": "Errors on the test grid before compensation and residuals after it with the saved model "
                    "(the model file of each encoder, the one encal fit chooses), on the same axes; the grey band "
                    "is ± the measurement floor.",
    "reproducibility": "Repeat calibrations minus the first one at the same reference angles: a later epoch "
                       "and a second decoder; the grey band is ± 1 LSB.",
}


def _profiles(result):
    from .. import figures as plots

    def draw(e, ax):
        plots.plot_profile(e.train.encoder_deg, e.train.errors_arcmin,
                           test=(e.test.encoder_deg, e.test.errors_arcmin), ax=ax, title=e.name,
                           label="training grid", test_label="test grid")

    return plots.panel_figure(result.encoders, draw)


def _spectra(result):
    from .. import figures as plots

    return plots.panel_figure(result.encoders, lambda e, ax: plots.plot_harmonics(e.harmonics, ax=ax, title=e.name))


def _sweep(result):
    return result.sweep.plot().figure


def _training_curves(result):
    return result.sweep.plot_curves().figure


def _algorithms(result):
    from matplotlib.figure import Figure

    from .. import figures as plots

    fig = Figure(figsize=(11.0, 4.2), layout="constrained")
    left, right = fig.subplots(1, 2)
    result.algorithms.plot(ax=left)
    result.algorithms.plot_curves(ax=right)
    return fig


def _singular_values(result):
    from .. import figures as plots

    return plots.panel_figure(result.encoders, lambda e, ax: plots.plot_singular_values(e.pruning, ax=ax))


def _residuals(key):
    def make(result):
        from .. import figures as plots

        return plots.panel_figure(
            result.encoders, lambda e, ax: plots.plot_residuals(e.comparison, key=key, ax=ax), sharey=True)

    return make


def _before_after(result):
    from .. import figures as plots

    def draw(e, ax):
        evaluation = e.saved.evaluation
        plots.plot_before_after(evaluation.encoder_deg, evaluation.error_arcmin, evaluation.residual_arcmin, ax=ax,
                                floor_arcmin=e.floor_arcmin, title=f"{e.name}: {e.saved.model.kind} model")

    return plots.panel_figure(result.encoders, draw, sharey=True)


def _repeats(result):
    from .. import figures as plots

    return plots.panel_figure(result.encoders, lambda e, ax: plots.plot_repeats(e.reproducibility, ax=ax),
                              sharey=True)


#: Figure name -> function drawing it from a DemoResult.
_MAKERS = {
    "fig1_profiles": _profiles,
    "harmonics": _spectra,
    "fig2a_sweep": _sweep,
    "fig2b_training": _training_curves,
    "table2_algorithms": _algorithms,
    "fig3_singular_values": _singular_values,
    "fig4_residuals": _residuals("ann-paper"),
    "before_after": _before_after,
    "reproducibility": _repeats,
}


def _render(task):
    """PNG of one figure (runs in a worker process)."""
    from ..figures import detached_figures, figure_png

    name, result = task
    with detached_figures():
        return figure_png(_MAKERS[name](result))


def render_figures(result, *, workers=0, progress=False):
    """Draw every figure of the demo and return them as PNG bytes.

    Parameters
    ----------
    result : DemoResult
    workers : int, Workers or None, default=0
        Worker processes to draw on (see :func:`encal._core.pool.run_tasks`); 0 draws in this process.
    progress : bool, default=False
        Progress bar on stderr.

    Returns
    -------
    dict of str to bytes
        Figure name (a key of :data:`FIGURES`) -> PNG.
    """
    from .._core.pool import run_tasks

    names = [name for name in FIGURES if not (name == "fig2b_training" and result.sweep.curve_hidden is None)]
    pngs = run_tasks(_render, [(name, result) for name in names], workers=workers, label="figures",
                     progress=progress)
    return dict(zip(names, pngs))




def _figure(figures, name):
    if name not in figures:
        return ""
    data = base64.b64encode(figures[name]).decode("ascii")
    return (f'<figure><img alt="{html.escape(name)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(FIGURES[name])}</figcaption></figure>")


def _table(result, name):
    table = result.tables.get(name)
    return "" if table is None else f'<div class="scroll">{table.to_html()}</div>'


def _p(text):
    return f"<p>{html.escape(text)}</p>"


def _summary(result):
    """One plain-language sentence per encoder: accuracy before and after, on points never fitted."""
    items = []
    for name, encoder in result.encoders.items():
        before = encoder.comparison.entry("before").stats
        after = encoder.saved.stats
        label = encoder.saved.label
        floor = encoder.floor_arcmin
        items.append(
            f"<li><b>{html.escape(name)}</b>: before compensation its readings are off by up to "
            f"{before.max_abs:.2f} arcmin (RMS {before.rms:.2f}). Corrected with its model file "
            f"<code>{html.escape(name)}.json</code> ({html.escape(label)}), "
            f"readings at the {after.n} test angles, "
            f"which the model never saw, are off by at most {after.max_abs:.2f} arcmin (RMS {after.rms:.3f}): "
            f"{before.rms / after.rms:.1f} times smaller in RMS. No model can beat the measurement floor of this "
            f"run, {floor:.3f} arcmin RMS; this one is at {after.rms / floor:.2f} times the floor.</li>")
    return '<ul class="summary">' + "".join(items) + "</ul>"


def _fit_time(result):
    stages = ("encoders", "sweep", "algorithms")
    seconds = sum(result.timings.get(stage, 0.0) for stage in stages)
    return f"the fits took {seconds:.0f} s on {result.workers} worker process(es)"


def _budget(epochs):
    counts = set(epochs.values())
    return str(counts.pop()) if len(counts) == 1 else ", ".join(f"{a} {e}" for a, e in epochs.items())


def _sweep_sentence(sweep):
    """What Fig. 2a shows, in numbers: training MSE keeps falling with N, test MSE does not."""
    if "trainlm" not in sweep.algorithms:
        return ""
    train = sweep.mse_mean("trainlm")
    n = [int(h) for h in sweep.hidden]
    text = (f"The trainlm training MSE falls from {train[0]:.3g} arcmin² at N = {n[0]} to {train[-1]:.3g} at "
            f"N = {n[-1]}")
    test = sweep.test_mse_median("trainlm")
    if test is None:
        return text + "."
    best = int(np.argmin(test))
    return (text + f"; the median test MSE is lowest at N = {n[best]} ({test[best]:.3g} arcmin²) and is "
            f"{test[-1]:.3g} at N = {n[-1]}: beyond a few dozen nodes the network has more weights than there are "
            "training points (3N + 1 against 180) and fits their noise.")


def _test_sentence(study):
    """Which algorithm's networks predict the test grid best, which is not the training-MSE ranking."""
    rows = [r for r in study.rows if r.test_rms_arcmin is not None]
    if not rows:
        return ""
    best = min(rows, key=lambda r: r.test_rms_median)
    lowest = min(rows, key=lambda r: r.mse_mean)
    return (f"On the test grid the lowest median RMS is {best.algorithm}'s ({best.test_rms_median:.3f} arcmin); "
            f"{lowest.algorithm}, lowest in training MSE, has median test RMS {lowest.test_rms_median:.3f} and "
            f"worst {lowest.test_rms_worst:.3f} arcmin.")


def _best_sentences(result):
    """Which model is closest to the floor on each encoder, in words."""
    lines = []
    for name, encoder in result.encoders.items():
        models = [e for e in encoder.comparison.entries if e.key != "before"]
        best = min(models, key=lambda e: e.stats.rms)
        paper = encoder.comparison.entry("ann-paper")
        lines.append(f"{name}: lowest test RMS {best.label} ({best.stats.rms:.3f} arcmin); the paper's 1:80:1 "
                     f"raw network {paper.stats.rms:.3f} arcmin, largest residual {paper.stats.max_abs:.2f} arcmin.")
    return "".join(_p(line) for line in lines)


def build_report(result, figures):
    """The report as one HTML string.

    Parameters
    ----------
    result : DemoResult
    figures : dict of str to bytes
        PNG of each figure (:func:`render_figures`).

    Returns
    -------
    str
    """
    s = result.settings
    sweep, algorithms = result.sweep, result.algorithms
    first = next(iter(result.encoders.values()))
    counts = ", ".join(f"{n} {e.pruning.significant}" for n, e in result.encoders.items())
    ranking = algorithms.ranking()
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        "<title>encal demo report</title>",
        f"<style>{_CSS}</style></head><body>",
        "<h1>encal demo: ANN error compensation of low-cost encoders, reproduced</h1>",
        f'<p class="meta">The whole procedure of Dhar et al. on {len(result.encoders)} simulated 16-bit resolver '
        f"encoders (the built-in demo fleet). encal {html.escape(__version__)}; {_fit_time(result)}.</p>",
        "<h2>Summary</h2>",
        _summary(result),
        _p("All figures below are measured on this run. 'Training grid' is 0, 2, ..., 358 deg, the points a model "
           "is fitted to; 'test grid' is 1, 3, ..., 359 deg, points no model sees, as in the paper."),
        "<h2>1. Error profiles (Table 1, Fig. 1)</h2>",
        _p("Error = encoder angle − reference angle, in arc-minutes, over the training and test points together. "
           "The harmonic orders are those of the training run."),
        _table(result, "table1_profiles"),
        _figure(figures, "fig1_profiles"),
        _figure(figures, "harmonics"),
        "<h2>2. Hidden nodes (Fig. 2)</h2>",
        _p(f"The 1:N:1 network ({sweep.encoding} angle input, tansig hidden layer, linear output) is trained on "
           f"{sweep.encoder}'s training grid for N = {', '.join(str(int(n)) for n in sweep.hidden)}, "
           f"{sweep.n_seeds} seed(s) per point, {_budget(sweep.epochs)} epochs at most. {_sweep_sentence(sweep)}"),
        _table(result, "fig2a_sweep"),
        _figure(figures, "fig2a_sweep"),
        _figure(figures, "fig2b_training"),
        "<h2>3. Training algorithms (Table 2)</h2>",
        _p(f"Every algorithm trains the 1:{algorithms.hidden}:1 network from the same {algorithms.n_seeds} "
           f"initial weight sets with the same budget of {algorithms.epochs} epochs. Lowest mean training MSE: "
           f"{', '.join(ranking[:3])}; highest: {ranking[-1]}. {_test_sentence(algorithms)}"),
        _table(result, "table2_algorithms"),
        _figure(figures, "table2_algorithms"),
        "<h2>4. SVD pruning (Fig. 3)</h2>",
        _p("The paper decomposes X, the hidden nodes' outputs before the sigmoid. With one input every column of X "
           "is w·x + b, a combination of x and 1, so X has rank 2 whatever the weights: it cannot count hidden "
           "nodes. encal decomposes the hidden-node outputs after the sigmoid (Kanjilal & Banerjee 1993), counts "
           f"the singular values above {first.pruning.threshold:g} times the largest ({counts}), and retrains "
           "a network of that size."),
        _table(result, "fig3_pruning"),
        _figure(figures, "fig3_singular_values"),
        "<h2>5. Compensation on the test grid (Table 3, Fig. 4)</h2>",
        _best_sentences(result),
        _table(result, "table3_comparison"),
        _figure(figures, "fig4_residuals"),
        _figure(figures, "before_after"),
        "<h2>6. Reproducibility</h2>",
        _p("A later calibration epoch (the mount and resolver drift a little) and the same resolver read by a second "
           "decoder, compared with the first calibration, and corrected with the model fitted to it."),
        _table(result, "reproducibility"),
        _figure(figures, "reproducibility"),
        "<h2>Where encal departs from the paper</h2>",
        "<ul>",
        "<li>The paper's 'RMS' column is the standard deviation (its encoder 4 has MAE 1.78 > 'RMS' 1.31, "
        "impossible for a root mean square); Table 1 gives both.</li>",
        "<li>Final MSEs are given over several seeds: one training run per algorithm is an anecdote.</li>",
        "<li>SVD pruning decomposes the hidden layer after the activation (section 4).</li>",
        "<li>encal's default network takes (cos θ, sin θ) as input, so it is continuous where the angle wraps at "
        "0/360 deg; the paper's raw-angle network is not.</li>",
        "<li>Accuracy is stated against the measurement floor, the RMS no model can beat on a run.</li>",
        "</ul>",
        f'<p class="meta">Demo settings: {html.escape(s.describe())}.</p>',
        "</body></html>",
    ]
    return "\n".join(part for part in parts if part)


def write_report(result, path, figures):
    """Write :func:`build_report` to ``path`` atomically; returns the path."""
    atomic_write(path, build_report(result, figures))
    return path

"""Figures: drawing only. Each function draws arrays or a result into Matplotlib axes (``ax=None``: pyplot's
current figure, or a detached one inside :func:`detached_figures`) and returns the axes.

They stand below every result that draws itself (``ErrorStats.plot``, ``Model.plot``, ``Evaluation.plot``, a
study's ``plot``), so they import no result: what they draw is passed in. Matplotlib is imported on first use.
"""

from ._plots import (  # noqa: F401
    detached_figures, html_repr, new_axes, panel_figure, save_figure, figure_png, plot_profile, plot_harmonics,
    plot_error_stats, plot_model, plot_before_after, plot_selection, plot_reversal, plot_drift, plot_sweep,
    plot_training_curves, plot_algorithms, plot_singular_values, plot_residuals, plot_repeats, new_figure,
    draw_points,
)

__all__ = [
    "detached_figures", "html_repr", "new_axes", "panel_figure", "save_figure", "figure_png", "plot_profile",
    "plot_harmonics", "plot_error_stats", "plot_model", "plot_before_after", "plot_selection", "plot_reversal",
    "plot_drift", "plot_sweep", "plot_training_curves", "plot_algorithms", "plot_singular_values", "plot_residuals",
    "plot_repeats",
]

"""Figures (encal.figures): every plot draws on the axes it is given, or on a new pyplot-free figure."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from encal import Calibration, harmonics  # noqa: E402
from encal import figures as plots  # noqa: E402
from encal._core.errors import InputError  # noqa: E402
from encal.paper.studies import (  # noqa: E402
    compare_algorithms,
    compare_models,
    hidden_node_sweep,
    reproducibility,
    svd_pruning,
)
from encal.paper.studies.comparison import DEFAULT_MODELS  # noqa: E402

GRID = np.arange(0.0, 360.0, 2.0)
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def profile(theta_deg):
    t = np.radians(theta_deg)
    return 1.2 * np.sin(t) + 0.5 * np.cos(2 * t - 0.4) + 0.3 * np.sin(16 * t)


def calibration(grid, seed):
    """Table angles on ``grid`` and encoder readings off by the profile plus noise (arcmin)."""
    error = profile(grid) + np.random.default_rng(seed).normal(0, 0.05, grid.size)
    return Calibration(grid, grid + error / 60.0, name="enc1", resolution_bits=16)


@pytest.fixture(scope="module")
def runs():
    return calibration(GRID, 1), calibration(GRID + 1.0, 2)


@pytest.fixture(scope="module")
def studies(runs):
    train, test = runs
    sweep = hidden_node_sweep(train, test, hidden=(4, 80), algorithms=("trainlm", "traingd"), epochs=3, seeds=2,
                              workers=0)
    algorithms = compare_algorithms(train, test, algorithms=("trainlm", "trainrp"), hidden=6, epochs=3, seeds=2,
                                    workers=0)
    pruning = svd_pruning(train, test, hidden=10, epochs=3)
    comparison = compare_models(train, test, models=DEFAULT_MODELS[:2], floor_arcmin=0.05)
    repeats = reproducibility(train, {"epoch2": calibration(GRID, 3)},
                              model=comparison.entry("fourier").model)
    return {"sweep": sweep, "algorithms": algorithms, "pruning": pruning, "comparison": comparison,
            "repeats": repeats}


# --------------------------------------------------------------------------- axes-level plots


def _draw_all(runs, studies):
    train, test = runs
    h = harmonics(train.encoder_deg, train.errors_arcmin)
    return {
        "profile": lambda ax: plots.plot_profile(train.encoder_deg, train.errors_arcmin,
                                                 test=(test.encoder_deg, test.errors_arcmin), ax=ax, title="enc1"),
        "harmonics": lambda ax: plots.plot_harmonics(h, ax=ax),
        "sweep": lambda ax: plots.plot_sweep(studies["sweep"], ax=ax),
        "curves": lambda ax: studies["sweep"].plot_curves(ax=ax),
        "algorithms": lambda ax: plots.plot_algorithms(studies["algorithms"], ax=ax),
        "algorithm curves": lambda ax: studies["algorithms"].plot_curves(ax=ax),
        "singular values": lambda ax: plots.plot_singular_values(studies["pruning"], ax=ax),
        "residuals": lambda ax: plots.plot_residuals(studies["comparison"], key="fourier", ax=ax),
        "repeats": lambda ax: plots.plot_repeats(studies["repeats"], ax=ax),
    }


def test_every_plot_draws_on_the_axes_it_is_given(runs, studies):
    for name, draw in _draw_all(runs, studies).items():
        fig = Figure()
        ax = fig.add_subplot()
        assert draw(ax) is ax, name
        assert ax.lines or ax.collections, name


def test_every_plot_in_detached_figures_makes_a_figure_pyplot_does_not_manage(runs, studies):
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    with plots.detached_figures():
        for name, draw in _draw_all(runs, studies).items():
            ax = draw(None)
            assert isinstance(ax, Axes) and isinstance(ax.figure, Figure), name
            assert plots.figure_png(ax.figure).startswith(PNG_MAGIC), name
    assert plt.get_fignums() == before


def test_every_plot_without_axes_draws_on_pyplots_current_figure(runs, studies, tmp_path):
    """Matplotlib's convention, so that a notebook shows the figure and plt.savefig saves it."""
    import matplotlib.pyplot as plt

    for name, draw in _draw_all(runs, studies).items():
        plt.close("all")
        ax = draw(None)
        assert ax is plt.gca() and ax.figure is plt.gcf(), name
        assert ax.lines or ax.collections or ax.patches, name
        path = tmp_path / f"{name}.png"
        plt.savefig(path)
        blank = tmp_path / "blank.png"
        plt.figure().savefig(blank)
        assert path.stat().st_size > 2 * blank.stat().st_size, name  # something drawn, not an empty canvas
    plt.close("all")


def test_a_plot_draws_on_the_users_own_current_axes(runs):
    import matplotlib.pyplot as plt

    train, _ = runs
    fig, (left, right) = plt.subplots(1, 2)
    plt.sca(right)
    ax = plots.plot_profile(train.encoder_deg, train.errors_arcmin)
    assert ax is right and not left.lines
    plt.close(fig)


def test_singular_value_plot_shows_both_matrices_and_the_count(studies):
    ax = plots.plot_singular_values(studies["pruning"])
    labels = [text.get_text() for text in ax.get_legend().get_texts()]
    assert any("before sigmoid" in label and "rank" in label for label in labels)
    assert any(f"{studies['pruning'].significant} significant" in label for label in labels)
    assert ax.get_yscale() == "log"


def test_residual_plot_names_the_model_and_its_rms(studies):
    entry = studies["comparison"].entry("fourier")
    ax = plots.plot_residuals(studies["comparison"], key="fourier")
    assert entry.label in ax.get_title() and f"{entry.stats.rms:.3f}" in ax.get_title()


# --------------------------------------------------------------------------- figures and files


def test_panel_figure_labels_panels_and_hides_the_spare_one(runs):
    train, _ = runs
    items = {f"enc{k}": train for k in range(1, 4)}
    fig = plots.panel_figure(items, lambda cal, ax: plots.plot_profile(cal.encoder_deg, cal.errors_arcmin, ax=ax,
                                                                        title=cal.name), title="Fig. 1")
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title()[:3] for ax in visible] == ["(a)", "(b)", "(c)"]
    assert len(fig.axes) == 4 and not fig.axes[3].get_visible()


def test_panel_figure_needs_items():
    with pytest.raises(InputError, match="at least one item"):
        plots.panel_figure({}, lambda item, ax: None)


def test_save_figure_writes_a_png(tmp_path):
    ax = plots.new_axes()
    ax.plot([0, 1], [0, 1])
    path = plots.save_figure(ax.figure, tmp_path / "line.png")
    assert path.read_bytes().startswith(PNG_MAGIC)
    assert not list(tmp_path.glob(".*.tmp"))


def test_panels_past_z_are_labelled_aa_ab_and_so_on():
    from encal.figures._plots import _panel_label
    assert [_panel_label(i) for i in (0, 25, 26, 27, 51, 52, 701, 702)] == \
        ["a", "z", "aa", "ab", "az", "ba", "zz", "aaa"]


def test_results_display_richly_in_a_notebook_without_touching_pyplot(runs):
    import matplotlib.pyplot as plt

    import encal

    train, test = runs
    model = encal.fit(train, method="fourier", n_orders=8)
    results = {"model": model, "evaluation": encal.evaluate(model, test), "stats": encal.error_stats(train),
               "harmonics": encal.harmonics(train.encoder_deg, train.errors_arcmin)}
    for name, result in results.items():
        page = result._repr_html_()
        assert page.startswith("<pre>") and 'src="data:image/png;base64,' in page, name
        assert str(result).splitlines()[0].strip()[:10] in page, name
    assert plt.get_fignums() == []


def test_a_dense_profile_is_drawn_as_a_band_per_bin_not_a_blob_of_dots():
    rng = np.random.default_rng(0)
    theta = rng.uniform(0.0, 360.0, 50_000)
    error = 2.0 * np.sin(np.radians(theta)) + rng.normal(0.0, 0.1, theta.size)
    with plots.detached_figures():
        ax = plots.plot_profile(theta, error, smooth=False)
    assert not any(line.get_marker() == "." for line in ax.lines)  # no dot per point
    band = ax.collections[0].get_paths()[0].vertices
    assert band[:, 0].min() >= 0.0 and band[:, 0].max() <= 360.0
    median = ax.lines[0].get_ydata()
    assert median.size == 2000  # 25 points a bin
    centres = ax.lines[0].get_xdata()
    np.testing.assert_allclose(median, 2.0 * np.sin(np.radians(centres)), atol=0.15)  # 6 sigma of a median of 25
    assert "middle 95 %" in ax.get_legend_handles_labels()[1][0]


def test_a_sparse_profile_keeps_one_dot_per_point(runs):
    train, _ = runs
    with plots.detached_figures():
        ax = plots.plot_profile(train.encoder_deg, train.errors_arcmin, smooth=False)
    assert ax.lines[0].get_marker() == "." and ax.lines[0].get_xdata().size == len(train)


def test_the_harmonics_chart_spans_the_orders_that_carry_the_error():
    import encal

    rng = np.random.default_rng(1)
    theta = np.arange(16384) * 360.0 / 16384
    error = 3.0 * np.sin(np.radians(theta)) + 0.5 * np.sin(np.radians(200 * theta)) + rng.normal(0, 0.05, 16384)
    with plots.detached_figures():
        ax = plots.plot_harmonics(encal.harmonics(theta, error))
    low, high = ax.get_xlim()
    assert 200 < high < 300  # order 200 shown, not the 8192 orders of the grid


def test_a_floor_and_the_rms_in_a_legend_carry_their_unit(runs):
    train, _ = runs
    with plots.detached_figures():
        ax = plots.plot_before_after(train.encoder_deg, train.errors_arcmin, 0.1 * train.errors_arcmin,
                                     floor_arcmin=1.32)
    labels = ax.get_legend_handles_labels()[1]
    assert "± 1.32 arcmin" in labels and all("arcmin" in label for label in labels)


def test_a_directional_models_band_is_drawn_as_its_verdict_states_it():
    """metrology8: a per-direction model keeps its uncertainty in its parts, so the report's profile figure drew no
    band for it while the page's first line stated one."""
    import encal

    direction = np.repeat([1, -1], GRID.size)
    reference = np.r_[GRID, GRID[::-1]]
    error = profile(reference) + 0.2 * direction + np.random.default_rng(1).normal(0, 0.05, reference.size)
    model = encal.fit(Calibration(reference, reference + error / 60.0, direction=direction), method="fourier",
                      uncertainty=True, rng=0)
    assert model.kind == "directional" and model.uncertainty is None and model.has_uncertainty
    ax = plots.plot_model(model)
    bands = [artist for artist in ax.collections if artist.get_label() == "95 % band of a new reading"]
    assert len(bands) == 1
    grid = np.linspace(0.0, 360.0, 1441)
    mean, std = model.predict(grid, return_std=True)  # direction unknown: half the reversal included
    edge = bands[0].get_paths()[0].vertices[:, 1]
    assert edge.max() == pytest.approx(np.max(mean + 1.959963984540054 * std), abs=1e-9)

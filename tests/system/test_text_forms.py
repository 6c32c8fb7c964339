"""Results that speak: readable ``str()`` tables and ``plot(ax=None)`` for the public result objects."""

import re

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from matplotlib.axes import Axes  # noqa: E402

from encal import Calibration, Selection, error_stats, evaluate, fit, harmonics  # noqa: E402

GRID = np.arange(0.0, 360.0, 2.0)
#: A dataclass repr or a NumPy scalar repr: what a readable text form must not look like.
REPR = re.compile(r"\w+\(n=|np\.float|array\(|\d\.\d{9,}")


def calibration(offset_deg=0.0):
    r = np.radians(GRID)
    error = 2.0 * np.sin(r) + 0.5 * np.cos(3 * r) + 0.05 * np.random.default_rng(0).normal(size=GRID.size)
    return Calibration(GRID, GRID + offset_deg + error / 60.0, name="enc9")


def test_error_stats_prints_a_table_and_plots_bars():
    stats = error_stats(calibration(30.0), zero="auto")
    text = str(stats)
    assert not REPR.search(text)
    lines = text.splitlines()
    assert lines[0].split() == ["statistic", "arcmin"]
    assert lines[2].startswith("zero offset (apart)") and "1800.0" in lines[2]
    assert f"{stats.rms:.3f}" in text
    ax = stats.plot()
    assert isinstance(ax, Axes) and len(ax.patches) == 4  # MAE, RMS, STD, max |error|
    assert stats.plot(ax=ax) is ax


def test_harmonics_print_orders_amplitudes_and_phases():
    text = str(harmonics(GRID, 2.0 * np.cos(np.radians(GRID) - np.radians(40.0))))
    row = text.splitlines()[2].split()
    assert row == ["1", "2.000", "40.0"]
    assert not REPR.search(text)


def test_evaluation_prints_before_and_after_and_plots_them_on_one_axes():
    cal = calibration()
    result = evaluate(fit(cal, method="fourier", orders=[0, 1, 3]), cal)
    text = str(result)
    assert text.splitlines()[0].split() == ["arcmin", "before", "after"]
    assert f"{result.after.rms:.4f}" in text and not REPR.search(text)
    ax = result.plot()
    labels = [line.get_label() for line in ax.get_lines()]
    assert any(label.startswith("before") for label in labels) and any(label.startswith("after") for label in labels)


@pytest.mark.parametrize("method, options", [
    ("fourier", {"orders": [0, 1, 3]}), ("lut", {}), ("ann", {"hidden": 4, "epochs": 20, "rng": 1}),
    ("hybrid", {"rng": 2}),
    ("stack", {"members": [{"family": "fourier"}, {"family": "lut"}], "weights": [0.5, 0.5], "rng": 3})])
def test_every_model_prints_a_table_and_plots_its_curve(method, options):
    cal = calibration()
    model = fit(cal, method=method, **options)
    text = str(model)
    assert not REPR.search(text)
    assert text.splitlines()[0].split() == ["kind", model.kind]
    assert "enc9" in text and "180 points" in text and "peak-to-peak" in text
    ax = model.plot(data=(cal.encoder_deg, cal.errors_arcmin))
    curve = next(line for line in ax.get_lines() if line.get_label() == f"{model.kind} model")
    x, y = curve.get_data()
    np.testing.assert_allclose(y, model.predict(x), atol=1e-12)


def test_the_model_plot_draws_the_uncertainty_band():
    cal = calibration()
    model = fit(cal, method="fourier", orders=[0, 1, 3], uncertainty=True, rng=0)
    ax = model.plot()
    assert any("band" in str(c.get_label()) for c in ax.collections)


def test_selection_prints_the_cv_table_and_plots_bars():
    cal = calibration()
    model = fit(cal, method="auto", rng=0)
    selection = Selection.of(model)
    assert Selection.of(fit(cal, method="lut")) is None
    text = str(selection)
    assert "chosen: " + selection.reason in text
    ax = selection.plot()
    assert len(ax.patches) == sum(row["cv_rms_arcmin"] is not None for row in selection.table["table"])
    # the cross-validated choice among given candidates prints its table too
    cv = Selection.of(fit(cal, method="auto", rng=0, candidates=[{"family": "fourier"}, {"family": "lut"}]))
    assert str(cv).startswith("cross-validation over") and "*" in str(cv)

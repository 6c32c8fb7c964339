"""Model.correct of many angles through a table of the series (issue 30): within the stated bound of the
series evaluated term by term, memory flat, and the series evaluated as it is where no table fits."""

import tracemalloc

import numpy as np
import pytest

from encal._core.angles import wrap180
from encal.models._table import TABLE_MIN_ANGLES, TABLE_TOLERANCE_ARCMIN, series_table, table_points
from encal.models.base import in_chunks
from encal.models.fourier import FourierModel
from encal.models.spectral import SpectralModel
from tests._paths import DATA


def _exact(model, theta):
    return in_chunks(model._correct, np.asarray(theta, dtype=float).reshape(-1))


def _model(orders, amplitudes, seed=0, kind=SpectralModel, **options):
    phase = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, len(orders))
    amplitudes = np.asarray(amplitudes, dtype=float)
    return kind(orders, cos=amplitudes * np.cos(phase), sin=amplitudes * np.sin(phase), **options)


@pytest.mark.parametrize("kind", [SpectralModel, FourierModel])
@pytest.mark.parametrize("sign", [1, -1])
def test_table_within_its_bound_of_the_series(kind, sign):
    model = _model([0, 1, 2, 16, 32, 48, 250], [0.4, 3.0, 1.5, 0.6, 0.3, 0.2, 0.05], kind=kind)
    model.reading_sign = sign
    theta = np.random.default_rng(1).uniform(-1000.0, 1000.0, TABLE_MIN_ANGLES * 2)
    fast = model.correct(theta, table=True)
    assert model._correction_table() is not None
    difference = np.abs(wrap180(fast - _exact(model, theta))) * 60.0
    assert difference.max() <= TABLE_TOLERANCE_ARCMIN
    assert np.all((fast >= 0.0) & (fast < 360.0))


def test_the_bound_is_the_interpolation_error_of_a_single_high_order():
    # one order k of amplitude A: linear interpolation is off by A (1 - cos(k h / 2)) ~ A k^2 h^2 / 8 midway
    order, amplitude = 1000, 10.0
    model = FourierModel([order], cos=[amplitude], sin=[0.0])
    points = table_points([order], [amplitude], [0.0])
    theta = (np.arange(TABLE_MIN_ANGLES * 4) + 0.5) * 360.0 / points  # midway between nodes
    difference = np.abs(wrap180(model.correct(theta, table=True) - _exact(model, theta))) * 60.0
    assert TABLE_TOLERANCE_ARCMIN / 10.0 < difference.max() <= TABLE_TOLERANCE_ARCMIN


def test_table_nodes_are_the_series():
    model = _model([0, 3, 7, 100], [1.0, 2.0, 0.5, 0.1])
    table = series_table(model.orders, model.cos, model.sin)
    nodes = np.arange(table.size) * 360.0 / (table.size - 2)
    np.testing.assert_allclose(table * 60.0, model.predict(nodes), rtol=0, atol=1e-11)


def test_a_series_too_steep_for_a_table_is_evaluated_as_it_is():
    model = _model([4000, 4090], [1e4, 1e4], kind=FourierModel)
    assert table_points(model.orders, model.cos, model.sin) is None
    theta = np.random.default_rng(2).uniform(0.0, 360.0, TABLE_MIN_ANGLES)
    assert model._correction_table() is None
    assert np.array_equal(model.correct(theta, table=True), _exact(model, theta))


def test_shape_kept_and_memory_flat():
    model = _model([1, 2, 16, 32, 48], [3.0, 1.5, 0.6, 0.3, 0.2])
    theta = np.random.default_rng(3).uniform(0.0, 360.0, (1 << 10, 1 << 10))
    model._correction_table()  # built apart: the table is the model's, not the call's
    tracemalloc.start()
    corrected = model.correct(theta, table=True)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert corrected.shape == theta.shape
    assert peak <= theta.nbytes + (2 << 20)  # the result and one chunk's temporaries


@pytest.mark.parametrize("interpolation", ["cubic", "linear"])
def test_lookup_table_model_within_the_bound(interpolation):
    from encal.models.lut import fit_lut

    rng = np.random.default_rng(4)
    stops = np.arange(0.0, 360.0, 2.0)
    error = (3.0 * np.sin(np.radians(stops)) + 0.6 * np.sin(np.radians(16 * stops) + 1.0)
             + rng.normal(0, 0.1, stops.size))
    model = fit_lut(stops, error, interpolation=interpolation)
    theta = rng.uniform(-360.0, 720.0, TABLE_MIN_ANGLES * 2)
    fast = model.correct(theta, table=True)
    if interpolation == "linear":  # no table: as cheap evaluated as it is
        assert model._correction_table() is None and np.array_equal(fast, _exact(model, theta))
    else:
        assert model._correction_table() is not None
        assert np.abs(wrap180(fast - _exact(model, theta))).max() * 60.0 <= TABLE_TOLERANCE_ARCMIN


@pytest.mark.parametrize("name", ["ann", "hybrid", "stack", "lut", "fourier", "spectral"])
def test_every_stored_kind_within_the_bound(name):
    from encal.deploy import load_model

    model = load_model(DATA / f"model_v1_{name}.json")
    theta = np.random.default_rng(5).uniform(0.0, 360.0, TABLE_MIN_ANGLES * 2)
    fast = model.correct(theta, table=True)
    if name != "lut" or model.interpolation == "cubic":
        assert model._correction_table() is not None
    assert np.abs(wrap180(fast - _exact(model, theta))).max() * 60.0 <= TABLE_TOLERANCE_ARCMIN


def test_raw_network_has_no_table():
    from encal.deploy import load_model

    model = load_model(DATA / "model_v1_ann.json")
    model.encoding = "raw"  # the raw encoding jumps at 0/360 degrees: no bound on f''
    assert model._table_bound() is None and model._correction_table() is None


def test_a_model_over_an_arc_is_not_tabled():
    # outside its arc a model answers NaN (encal._core.arcs): the table would answer numbers there
    model = _model([1, 2], [3.0, 1.0], kind=FourierModel)
    model.range_deg = [10.0, 100.0]
    corrected = model.correct(np.linspace(0.0, 359.0, TABLE_MIN_ANGLES), table=True)
    assert np.isnan(corrected[0]) and np.isfinite(corrected[TABLE_MIN_ANGLES // 10])


def test_by_default_an_angle_is_corrected_by_the_formula_whatever_the_array_it_comes_in():
    """The table is asked for: encal correct streams chunks of any size, and must answer each angle the same."""
    model = _model([0, 1, 2, 16, 250], [0.4, 3.0, 1.5, 0.6, 0.05])
    theta = np.random.default_rng(6).uniform(0.0, 360.0, TABLE_MIN_ANGLES * 2)
    assert np.array_equal(model.correct(theta), _exact(model, theta))
    assert np.array_equal(model.correct(theta)[:10], model.correct(theta[:10]))

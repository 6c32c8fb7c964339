"""Models evaluate large arrays of angles chunk by chunk: the same values, memory bounded by a chunk."""

import tracemalloc

import numpy as np

from encal.models.ann import ANNModel, fit_ann
from encal.models.base import CHUNK_ANGLES
from encal.models.fourier import FourierModel


def test_a_chunked_prediction_is_the_closed_form_in_the_callers_shape():
    model = FourierModel([1, 3, 40], [2.0, -0.5, 0.25], [1.0, 0.0, -0.125])
    theta = np.linspace(-720.0, 1080.0, 3 * CHUNK_ANGLES + 5).reshape(-1, 1)
    r = np.radians(theta)
    expected = 2.0 * np.cos(r) + np.sin(r) - 0.5 * np.cos(3 * r) + 0.25 * np.cos(40 * r) - 0.125 * np.sin(40 * r)
    predicted = model.predict(theta)
    assert predicted.shape == theta.shape
    assert np.abs(predicted - expected).max() <= 1e-11
    corrected = model.correct(theta)
    assert corrected.shape == theta.shape
    assert np.abs((corrected - (theta - expected / 60.0) + 180.0) % 360.0 - 180.0).max() <= 1e-11
    assert float(model.correct(10.0)) == float(model.correct(np.array([10.0]))[0])


def test_correcting_many_angles_with_a_wide_network_needs_no_angles_by_neurons_array():
    theta = np.arange(0.0, 360.0, 2.0)
    model = fit_ann(theta, np.sin(np.radians(theta)), hidden=80, encoding="raw", rng=0, epochs=2)
    assert isinstance(model, ANNModel)
    angles = np.random.default_rng(0).uniform(0.0, 360.0, 200_000)
    tracemalloc.start()
    model.correct(angles)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    # The dense evaluation held several 200,000 x 80 arrays (128 MB each); a chunk's are 5.2 MB.
    # Bound: the result and a few copies of the angles (1.6 MB each) plus a few chunks' temporaries.
    assert peak <= 6 * angles.nbytes + 8 * CHUNK_ANGLES * 80 * 8


def test_a_directional_model_corrects_chunk_by_chunk_with_the_values_of_its_predictions():
    """Issue 30: a directional model's correct() held the whole array several times (382 MiB for 10^7 angles)."""
    from encal._core.angles import wrap360
    from encal.models.directional import DirectionalModel

    forward = FourierModel([1, 2], [2.0, -0.5], [1.0, 0.25])
    reverse = FourierModel([1, 3], [1.5, 0.4], [-1.0, 0.1])
    model = DirectionalModel(forward, reverse)
    theta = np.linspace(-720.0, 1080.0, 3 * CHUNK_ANGLES + 5)
    direction = np.where(np.arange(theta.size) % 3 == 0, 1, -1)
    for given in (None, direction, -1):
        expected = wrap360(theta - model.predict(theta, direction=given) / 60.0)
        corrected = model.correct(theta, direction=given)
        assert np.abs((corrected - expected + 180.0) % 360.0 - 180.0).max() <= 1e-12
    angles = np.random.default_rng(0).uniform(0.0, 360.0, 200_000)
    tracemalloc.start()
    model.correct(angles)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak <= 2 * angles.nbytes + 16 * CHUNK_ANGLES * 8  # the result, its reshape, a few chunks' temporaries

"""Numerical building blocks (encal.numerics): the periodic smoothing spline, and predicting with a network
without the optimisers."""

import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from encal._core.errors import InputError
from encal.numerics.spline import periodic_smoothing_spline
from tests._paths import DATA

GRID = np.arange(0.0, 360.0, 2.0)


def profile(theta_deg):
    t = np.radians(theta_deg)
    return 1.2 * np.sin(t) + 0.5 * np.cos(2 * t - 0.4) + 0.3 * np.sin(16 * t)


# --------------------------------------------------------------------------- smoothing spline



def test_smoothing_spline_reproduces_a_noise_free_trigonometric_polynomial():
    spline = periodic_smoothing_spline(GRID, profile(GRID))
    fine = np.linspace(0.0, 360.0, 721)
    assert_allclose(spline(fine), profile(fine), atol=1e-4)


@pytest.mark.parametrize("seed", range(5))
def test_smoothing_spline_removes_noise(seed):
    theta = np.r_[GRID, GRID + 1.0]
    noisy = profile(theta) + np.random.default_rng(seed).normal(0, 0.2, theta.size)
    spline = periodic_smoothing_spline(theta, noisy)
    error = np.sqrt(np.mean((spline(theta) - profile(theta)) ** 2))
    assert error < 0.1  # half the noise RMS; typically a third of that
    assert 5 < spline.edf < 100


SPLINE = periodic_smoothing_spline(GRID, profile(GRID) + np.cos(np.radians(GRID)) ** 7)


@settings(max_examples=50, deadline=None)
@given(theta=st.floats(-1e4, 1e4, allow_nan=False), turns=st.integers(-3, 3))
def test_smoothing_spline_is_periodic(theta, turns):
    assert_allclose(SPLINE(theta + 360.0 * turns), SPLINE(theta), atol=1e-9)


def test_smoothing_spline_needs_enough_points():
    with pytest.raises(InputError, match="at least 8 finite values"):
        periodic_smoothing_spline([0.0, 90.0], [1.0, 2.0])


# --------------------------------------------------------------------------- the network's forward pass


def test_predicting_with_a_network_loads_no_optimiser():
    """Loading a network's model file and predicting imports encal.numerics, never encal.training."""
    expected = json.loads((DATA / "expected_v1.json").read_text(encoding="utf-8"))["model_v1_ann.json"]
    script = ("import sys, json, encal; model = encal.load_model(sys.argv[1]); "
              "values = model.predict(json.loads(sys.argv[2])).tolist(); "
              "print(json.dumps([values, sorted(m for m in sys.modules if m.startswith('encal.training'))]))")
    done = subprocess.run([sys.executable, "-c", script, str(DATA / "model_v1_ann.json"),
                           json.dumps(expected["theta_deg"])], capture_output=True, text=True, check=True)
    values, training_modules = json.loads(done.stdout)
    assert training_modules == []
    assert_allclose(values, expected["predict_arcmin"], rtol=0, atol=1e-9)

"""The harmonic analysis of many non-uniform angles takes its sums from the non-uniform FFT."""

import numpy as np
import pytest

import encal.analysis.profile as profile
from encal._core.errors import InputError


def jittered(n, seed=4):
    rng = np.random.default_rng(seed)
    return np.arange(n) * (360.0 / n) + rng.uniform(-0.3, 0.3, n) * (360.0 / n)


def test_large_sums_agree_with_the_exact_products(monkeypatch):
    theta = np.radians(jittered(30_000))
    error = np.random.default_rng(1).normal(0.0, 2.0, theta.size)
    assert theta.size * 201 > profile._NUFFT_ABOVE
    moments, projections = profile._trigonometric_sums(theta, error, 201, 101)
    monkeypatch.setattr(profile, "_NUFFT_ABOVE", np.inf)
    exact_moments, exact_projections = profile._trigonometric_sums(theta, error, 201, 101)
    assert np.abs(moments - exact_moments).max() <= 1e-13 * theta.size
    assert np.abs(projections - exact_projections).max() <= 1e-13 * np.abs(error).sum()


def test_harmonics_of_many_jittered_angles_recover_a_known_profile():
    theta = jittered(40_000)
    r = np.radians(theta)
    error = 1.5 + 3.0 * np.cos(r - 0.4) + 0.8 * np.sin(7 * r) + 0.05 * np.cos(45 * r + 1.0)
    h = profile.harmonics(theta, error, 60)  # 40,000 angles x 121 sums: the non-uniform FFT
    assert theta.size * 121 > profile._NUFFT_ABOVE
    expected = np.zeros(61)
    expected[[0, 1, 7, 45]] = [1.5, 3.0, 0.8, 0.05]
    assert np.abs(h.amplitude_arcmin - expected).max() <= 1e-9
    assert h.top(4) == [1, 0, 7, 45]


# ---------------------------------------------------------------- a grid within a stated tolerance

def _sums_at_the_angles(theta_deg, error, max_order):
    """The known truth: ``c_k Σ w_i ε_i e^{-ikθ_i}`` at the readings' own angles, by direct products (one
    reading per node: w_i = 1/N; c_k = 2, 1 for order 0 and the Nyquist order)."""
    theta = np.radians(theta_deg)
    orders = np.arange(max_order + 1)
    sums = np.exp(-1j * np.multiply.outer(orders, theta)) @ error / theta.size
    factor = np.where((orders == 0) | (orders == theta.size // 2), 1.0, 2.0)
    return factor * sums


def _jittered_grid(points, offset_deg, seed):
    rng = np.random.default_rng(seed)
    nodes = np.arange(points) * (360.0 / points)
    theta = nodes + rng.uniform(-offset_deg, offset_deg, points)
    error = 3.0 * np.sin(np.radians(2 * nodes) + 0.4) + rng.normal(0.0, 0.5, points)
    return theta, error


@pytest.mark.parametrize("offset_deg", [1e-7, 1e-4, 1e-2])
def test_fft_on_a_grid_within_the_tolerance_stays_within_its_stated_bound(offset_deg):
    theta, error = _jittered_grid(180, offset_deg, seed=3)
    tolerance = 2.0 * offset_deg  # the fitted grid's phase moves a little: offsets from it grow a little
    result = profile.harmonics(theta, error, grid_tolerance_deg=tolerance)
    assert result.grid_bound_arcmin is not None  # the FFT path was taken
    exact = _sums_at_the_angles(theta, error, result.max_order)
    change = np.abs((result.cos_arcmin - 1j * result.sin_arcmin) - exact)
    assert np.all(change <= result.grid_bound_arcmin + 1e-12)
    assert result.grid_bound_arcmin[0] == 0.0
    # the bound is 2 k δ mean|ε| (δ in radians, at most the tolerance)
    assert result.grid_bound_arcmin[1] <= 2.0 * np.radians(tolerance) * np.mean(np.abs(error)) * (1 + 1e-9)


def test_the_bound_is_reached_by_one_reading_off_its_node():
    """One error, at the one reading moved off its node by δ: its sum changes by 2|ε| 2 sin(kδ/2) / N,
    the bound's 2 k δ |ε| / N to within (kδ)²/24."""
    points, moved = 360, 0.01  # degrees
    theta = np.arange(points) * (360.0 / points)
    theta[100] += moved
    error = np.zeros(points)
    error[100] = 5.0
    result = profile.harmonics(theta, error, 60, grid_tolerance_deg=0.01)
    exact = _sums_at_the_angles(theta, error, 60)
    change = np.abs((result.cos_arcmin - 1j * result.sin_arcmin) - exact)
    bound = result.grid_bound_arcmin
    assert np.all(change <= bound + 1e-15)
    # the fitted grid's phase moves by δ/N: the reading is δ(1 - 1/N) off its node
    assert np.all(change[1:] >= 0.99 * bound[1:])


def test_outside_the_tolerance_the_angles_are_used_as_they_are():
    theta, error = _jittered_grid(180, 1e-4, seed=4)
    exact_path = profile.harmonics(theta, error)  # default tolerance 1e-9 deg: not a grid
    assert exact_path.grid_bound_arcmin is None
    on_grid = profile.harmonics(np.round(theta, 0), error)  # exactly on the 2-degree grid
    assert on_grid.grid_bound_arcmin is not None and np.all(on_grid.grid_bound_arcmin < 1e-12)  # rounding only


@pytest.mark.parametrize("tolerance", [-1e-3, 180.0, float("nan"), "0.1", True])
def test_a_bad_grid_tolerance_is_one_sentence(tolerance):
    theta, error = _jittered_grid(36, 0.0, seed=5)
    with pytest.raises(InputError, match="grid_tolerance_deg"):
        profile.harmonics(theta, error, grid_tolerance_deg=tolerance)

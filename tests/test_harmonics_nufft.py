"""The harmonic analysis of many non-uniform angles takes its sums from the non-uniform FFT."""

import numpy as np

import encal.profile as profile


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

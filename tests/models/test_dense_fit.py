"""`encal fit` of dense files (issue 30): the spectral fit sorts each set of angles once, with the same numbers.

A dense sweep (passes over the same stops, the readings off any grid) takes the Fourier-feature path, capped,
with the scan above the cap. Before, the reference angles were sorted four times (the identical repeats, the
stops, the repeats' noise, the alias coherence) and the encoder angles twice (the uniform nodes, the scan's
identifiable order); each sort of 10^6 angles is tens of milliseconds.
"""

import numpy as np
import pytest

from encal.analysis import profile
from encal.analysis.profile import identifiable_order
from encal.models import spectral
from encal.models.spectral import _alias_coherence, fit_spectral, repeat_noise


def _sweep(stops=4000, passes=5, seed=3):
    rng = np.random.default_rng(seed)
    reference = np.tile(np.arange(stops) * 360.0 / stops, passes)
    error = 3.0 * np.cos(np.radians(reference) + 0.3) + 0.6 * np.cos(np.radians(16 * reference) + 2.0) \
        + 0.3 * np.cos(np.radians(230 * reference)) + rng.normal(0.0, 0.1, reference.size)
    return np.mod(reference + error / 60.0, 360.0), error


def test_a_dense_sweep_sorts_each_set_of_angles_once(monkeypatch):
    theta, error = _sweep()
    sorted_sizes = []
    plain = profile.stable_argsort

    def counted(values, *args, **kwargs):
        sorted_sizes.append(np.asarray(values).size)
        return plain(values, *args, **kwargs)

    monkeypatch.setattr(profile, "stable_argsort", counted)
    model = fit_spectral(theta, error)
    assert model.training["path"] == "fourier-features" and "orders_above_cap" in model.training  # 230 found
    # three fits (the first, and a refit after each of two scans above the cap), each sorting the reference
    # angles once and the encoder angles once (20 sorts before); the stops' own angles (4000) apart
    assert model.training["orders_above_cap"]["orders"] == [214, 229, 230, 231, 246]
    assert sorted_sizes.count(theta.size) == 3 * 2


def test_the_shared_sorts_give_the_figures_of_the_plain_functions():
    theta, error = _sweep()
    model = fit_spectral(theta, error)
    reference = np.mod(theta - error / 60.0, 360.0)
    std, dof = repeat_noise(reference, error)
    noise = model.training["noise"]
    assert noise["source"] == "repeated readings"
    assert noise["repeat_std_arcmin"] == std and noise["repeat_dof"] == dof
    assert model.training["alias_coherence"] == _alias_coherence(spectral.wrap360(theta - error / 60.0))
    # the scan ran to the order the encoder angles identify (its own sort), as before
    assert identifiable_order(theta) == profile.angles_and_grid(theta)[2].stable_order


@pytest.mark.parametrize("angles", [np.arange(0.0, 360.0, 2.0), np.r_[0:300:2.0], [0.0, 10.0, 20.0, 30.0, 50.0]])
def test_angles_and_grid_agrees_with_uniform_grid_and_identifiable_order(angles):
    distinct, group, grid = profile.angles_and_grid(angles)
    plain_distinct, plain_group = profile.distinct_angles(angles)
    np.testing.assert_array_equal(distinct, plain_distinct)
    np.testing.assert_array_equal(group, plain_group)
    assert grid.stable_order == identifiable_order(angles)
    assert (grid.phase_rad is None) == (profile.uniform_grid(distinct) is None)


def test_nodes_are_np_mod_of_the_rounded_position_bit_for_bit():
    from encal.numerics.trigsums import _nodes

    rng = np.random.default_rng(0)
    theta = np.r_[rng.uniform(0.0, 2.0 * np.pi, 10_000), 0.0, -0.0, 2.0 * np.pi, np.nextafter(2.0 * np.pi, 0.0),
                  -3.0, 7.0, 123456.7, -1e300, 1e300]
    for size in (16, 4096, 32768):
        position = theta * (size / (2.0 * np.pi))
        node = np.round(position)
        index, offset = _nodes(theta, size)
        np.testing.assert_array_equal(index, np.mod(node, size).astype(np.int64))
        np.testing.assert_array_equal(offset.view(np.int64), (position - node).view(np.int64))
        small, small_offset = _nodes(theta[:-2], size)  # every position exact as an int64: the low bits
        np.testing.assert_array_equal(small, index[:-2])
        np.testing.assert_array_equal(small_offset, offset[:-2])


@pytest.mark.parametrize("stops", ["sweep", "random"])
def test_a_dense_sweep_fit_holds_no_copy_it_no_longer_needs(stops):
    import tracemalloc

    import scipy.linalg  # noqa: F401  (imported by the first fit: not the fit's own memory)
    import scipy.optimize  # noqa: F401

    rng = np.random.default_rng(1)
    n = 200_000
    reference = np.tile(np.arange(n // 5) * 360.0 / (n // 5), 5) if stops == "sweep" else rng.uniform(0, 360, n)
    error = 3.0 * np.cos(np.radians(reference)) + 0.5 * np.cos(np.radians(16 * reference)) + rng.normal(0.0, 0.1, n)
    theta = np.mod(reference + error / 60.0, 360.0)
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        fit_spectral(theta, error)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    # the scan above the cap was the peak: 105.3 bytes a reading while the fit still held the reference angles and
    # the centred errors, 98.1 without them (the command line's 10^6-row random file: 211 -> 195 MiB resident);
    # 88.5 with the angles given used as they are and the scan's prediction in chunks. On random stops the alias
    # coherence's temporaries, 121.1 with the stops' groups held, 98.4 now (the random file: 204-216 -> 178 MiB).
    assert peak / n < (91.0 if stops == "sweep" else 101.0)


@pytest.mark.parametrize("case", ["copied rows", "repeats that differ", "no repeats"])
def test_identical_repeats_are_dropped_as_np_unique_finds_the_first_readings(case):
    from encal.models.spectral import _without_identical_repeats

    rng = np.random.default_rng(2)
    stops = rng.permutation(np.arange(0.0, 360.0, 2.0))  # the first reading of a stop is not the lowest angle's
    reference = np.r_[stops, stops[::-1]] if case != "no repeats" else stops
    error = np.cos(np.radians(reference))
    if case == "repeats that differ":
        error = error + rng.normal(0.0, 0.01, error.size)
    theta = np.mod(reference + error / 60.0, 360.0)
    kept_theta, kept_error, dropped = _without_identical_repeats(theta, error)
    _, group = profile.distinct_angles(np.mod(theta - error / 60.0, 360.0))
    first = np.sort(np.unique(group, return_index=True)[1])
    if case == "copied rows":
        assert dropped == stops.size
        np.testing.assert_array_equal(kept_theta, theta[first])
        np.testing.assert_array_equal(kept_error, error[first])
    else:
        assert dropped == 0 and kept_theta is theta and kept_error is error


def test_fit_of_one_run_takes_the_turn_check_and_the_errors_from_one_mean_phasor(monkeypatch):
    """``encal.fit`` of a calibration of one run: the coherence of the turn check and the errors' circular mean
    come from one mean phasor (two passes of 10^6 cosines and sines before), the model that of its errors."""
    from encal import Calibration, fit
    from encal.data import calibration

    theta, error = _sweep(stops=500, passes=2)
    cal = Calibration(np.mod(theta - error / 60.0, 360.0), theta)
    calls = []
    plain_phasor = calibration._mean_phasor

    def counted(*args):
        calls.append(1)
        return plain_phasor(*args)

    monkeypatch.setattr(calibration, "_mean_phasor", counted)
    model = fit(cal, method="spectral")
    assert len(calls) == 1
    direct = fit_spectral(cal.encoder_deg, cal.errors_arcmin)
    assert np.array_equal(model.cos, direct.cos) and np.array_equal(model.sin, direct.sin)


def _read_only(*arrays):
    copies = [np.array(a, dtype=float) for a in arrays]
    for a in copies:
        a.flags.writeable = False
    return copies


@pytest.mark.parametrize("case", ["dense sweep", "grid", "quantised grid", "random stops", "jittered stops"])
def test_fit_spectral_reads_its_angles_without_copying_or_writing_them(case, monkeypatch):
    """The angles given (in [0, 360) already) are used as they are, never written: read-only arrays fit the same
    model as writable copies on each path (the scan above the cap, the FFT path, the rounding's, random stops)."""
    rng = np.random.default_rng(7)
    if case == "dense sweep":
        theta, error = _sweep(stops=3000, passes=3)
    else:
        reference = {"random stops": np.sort(rng.uniform(0.0, 360.0, 3000)),
                     "jittered stops": np.arange(180) * 2.0 + rng.uniform(-0.6, 0.6, 180)}.get(case, np.arange(360.0))
        reference = np.mod(reference, 360.0)
        error = 2.0 * np.sin(np.radians(reference)) + rng.normal(0.0, 0.05, reference.size)
        theta = np.mod(reference + error / 60.0, 360.0)
        if case == "quantised grid":
            theta = np.round(theta * 2**14 / 360.0) % 2**14 * 360.0 / 2**14
            error = (theta - reference + 180.0) % 360.0 * 60.0 - 10800.0
    copied = []
    plain = profile.wrap360

    def counted(angles):
        copied.append(np.array_equal(np.asarray(angles), theta))
        return plain(angles)

    monkeypatch.setattr(profile, "wrap360", counted)
    model = fit_spectral(*_read_only(theta, error))
    assert not any(copied)  # the encoder angles were not wrapped into a copy
    if case == "jittered stops":  # blind off a grid: a first fit to Nyquist, then the orders beyond it
        assert "beyond_nyquist" in model.training
    writable = fit_spectral(theta.copy(), error.copy())
    assert np.array_equal(model.cos, writable.cos) and np.array_equal(model.sin, writable.sin)

"""The spectral fit's reuse across evaluations (issue 32): a work buffer, kept results, kept exponentials.

Each shortcut must give the numbers of the plain computation: the evidence against its formulas written
out with dense NumPy, results that stay put when the buffer is reused, the jitter retried on a rebuilt
matrix, and trigonometric moments from kept exponentials equal to fresh ones bit for bit.
"""

import math

import numpy as np
import pytest

from encal.models import _evidence
from encal.models.spectral import _columns, _general_design, fit_spectral
from encal.numerics import trigsums


def _jittered_design(seed=5, stops=120, highest=40):
    rng = np.random.default_rng(seed)
    theta = np.sort(np.radians(np.arange(stops) * 360.0 / stops + rng.uniform(-1.0, 1.0, stops)))
    error = 2.0 * np.cos(theta) + 0.5 * np.sin(7 * theta) + 0.1 * rng.normal(size=stops)
    orders, shifts, lineable = _columns(highest, None, 0.0)
    return _general_design(theta, error - error.mean(), orders, shifts, lineable)


def _direct(design, s, sigma2):
    """The evidence, posterior and gradients written out with dense NumPy (inverse and slogdet)."""
    d = np.sqrt(s)
    b = np.eye(s.size) + d[:, None] * design.gram * d[None, :] / sigma2
    inverse = np.linalg.inv(b)
    u = d * design.projection / sigma2
    z = inverse @ u
    log_p = -0.5 * (design.n * math.log(2 * math.pi * sigma2) + np.linalg.slogdet(b)[1] + design.yy / sigma2 - u @ z)
    mean = d * z
    residual2 = design.yy - 2 * design.projection @ mean + mean @ design.gram @ mean
    grad_s = 0.5 * (z**2 + np.diag(inverse) - 1.0)
    grad_noise = 0.5 * (residual2 / sigma2 + s.size - np.trace(inverse) - design.n)
    return log_p, mean, d[:, None] * inverse * d[None, :], grad_s, grad_noise


@pytest.mark.parametrize("covariance", [True, False])
def test_general_evidence_matches_its_formulas(covariance):
    design = _jittered_design()
    hyper = _evidence.Hyper(0.3, 2.2, 0.02, {1: 3.0, 7: 0.2}, False)
    s = hyper.variances(design)
    post = _evidence.evidence(design, s, hyper.noise_var, covariance=covariance)
    log_p, mean, cov, grad_s, grad_noise = _direct(design, s, hyper.noise_var)
    assert post.log_evidence == pytest.approx(log_p, rel=1e-12)
    np.testing.assert_allclose(post.mean, mean, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(post.grad_log_variance, grad_s, rtol=1e-9, atol=1e-11)
    assert post.grad_log_noise == pytest.approx(grad_noise, rel=1e-9)
    if covariance:
        np.testing.assert_allclose(post.covariance, cov, rtol=1e-9, atol=1e-14)
        assert post.covariance.flags.c_contiguous  # as before: the later matrix products round by the layout
    else:
        assert post.covariance is None


def test_results_stay_put_when_the_buffer_is_reused():
    design = _jittered_design()
    hyper = _evidence.Hyper(0.3, 2.2, 0.02, {1: 3.0}, False)
    first = _evidence.evidence(design, hyper.variances(design), hyper.noise_var)
    kept = [first.mean.copy(), first.covariance.copy(), first.grad_log_variance.copy()]
    for noise in (0.01, 0.03, 0.05, 0.08):  # more points than the results kept: the first is computed again
        _evidence.evidence(design, hyper.variances(design), noise, covariance=False)
        _evidence.evidence(design, hyper.variances(design), noise)
    for array, copy in zip((first.mean, first.covariance, first.grad_log_variance), kept):
        np.testing.assert_array_equal(array, copy)
    again = _evidence.evidence(design, hyper.variances(design), hyper.noise_var)
    assert again is not first and again.log_evidence == first.log_evidence
    np.testing.assert_array_equal(again.covariance, first.covariance)
    # a point asked for again at once is the result kept, and each kind of evaluation is kept apart
    assert _evidence.evidence(design, hyper.variances(design), hyper.noise_var) is again
    assert _evidence.evidence(design, hyper.variances(design), hyper.noise_var, covariance=False).covariance is None


def test_the_jitter_is_added_to_a_rebuilt_matrix():
    # indefinite by 1e-15, which the first jitter (1e-14 of the diagonal) repairs; the failed factorisation
    # overwrote the buffer, so each try must write the matrix again
    matrix = np.array([[1.0, 1.0], [1.0, 1.0]]) - 1e-15 * np.eye(2)
    writes = []

    def fill(out):
        writes.append(1)
        out[...] = matrix
        return out

    factor = _evidence._cholesky(fill, np.empty((2, 2), order="F"))
    assert len(writes) == 2
    np.testing.assert_allclose(np.tril(factor) @ np.tril(factor).T, matrix + 1e-14 * np.eye(2), rtol=0, atol=1e-15)
    def fill_indefinite(out):  # an eigenvalue of -1: no jitter up to 1e-8 of the diagonal repairs it
        out[...] = [[1.0, 2.0], [2.0, 1.0]]
        return out

    with pytest.raises(np.linalg.LinAlgError):
        _evidence._cholesky(fill_indefinite, np.empty((2, 2), order="F"))


def test_moments_from_kept_exponentials_are_those_computed_afresh():
    rng = np.random.default_rng(2)
    theta = rng.uniform(0.0, 2 * math.pi, 150)
    weights = rng.normal(size=150)
    trigsums.trig_moments(theta, np.ones(150), 120)  # keeps the exponentials up to order 120
    fresh = np.exp(1j * np.multiply.outer(np.arange(61), theta)) @ weights
    np.testing.assert_array_equal(trigsums.trig_moments(theta, weights, 60), fresh)
    other = theta.copy()
    other[3] += 1e-9  # other angles are never served the kept matrix
    np.testing.assert_array_equal(trigsums.trig_moments(other, weights, 60),
                                  np.exp(1j * np.multiply.outer(np.arange(61), other)) @ weights)
    theta[0] = 1.0  # nor the same array changed in place
    np.testing.assert_array_equal(trigsums.trig_moments(theta, weights, 60),
                                  np.exp(1j * np.multiply.outer(np.arange(61), theta)) @ weights)


def test_seed_lines_starts_lines_where_the_evidence_asks_for_them():
    # Issue 27: a refit after the scan above the cap starts with lines at the orders the scan found. Known truth:
    # order 35 carries 0.8 arcmin, order 30 nothing. At a start without a line at 35 the seed adds one there, with
    # about the variance of its coefficients (0.8² / 2 per column). The orders are judged all at once, so an order
    # that only shows order 35's leakage off the grid may be seeded too (the search drops it); once 35 has its
    # line, order 30 is not seeded.
    rng = np.random.default_rng(11)
    theta = np.sort(rng.uniform(0.0, 2.0 * math.pi, 3000))
    error = 2.0 * np.cos(theta) + 0.8 * np.cos(35 * theta + 0.7) + 0.1 * rng.normal(size=theta.size)
    orders, shifts, lineable = _columns(40, None, 0.0)
    design = _general_design(theta, error - error.mean(), orders, shifts, lineable)
    start = _evidence.Hyper(1e-3, 2.0, 0.01, {1: 2.0}, False)
    seeded = _evidence.seed_lines(design, start, [30, 35])
    assert 35 in seeded.lines and seeded.lines[1] == 2.0
    assert 0.1 < seeded.lines[35] < 1.0  # the grid of variances is spaced by a factor 1.78; 0.32 the truth
    assert start.lines == {1: 2.0}  # the start is not changed
    with_line = _evidence.Hyper(1e-3, 2.0, 0.01, {1: 2.0, 35: 0.32}, False)
    assert _evidence.seed_lines(design, with_line, [30, 35]).lines == {1: 2.0, 35: 0.32}
    hyper, _ = _evidence.fit_hyperparameters(design, start=seeded)
    assert sorted(hyper.lines) == [1, 35]


def test_the_refit_above_the_cap_starts_with_the_lines_found(monkeypatch):
    # Without them the background rose to explain the new orders, the lines below the cap were dropped, and
    # the refit of a 10^5-reading stepper sweep took 434 evaluations in its first optimisation (61 before it).
    rng = np.random.default_rng(0)
    reference = np.sort(rng.uniform(0.0, 360.0, 10_000))
    r = np.radians(reference)
    error = 3.0 * np.sin(r) + np.cos(200 * r) + 0.8 * np.sin(250 * r + 0.4) + rng.normal(0.0, 0.2, r.size)
    starts = []
    optimise = _evidence._optimise

    def spy(design, hyper):
        starts.append((design.orders.size, set(hyper.lines)))
        return optimise(design, hyper)

    monkeypatch.setattr(_evidence, "_optimise", spy)
    model = fit_spectral(reference + error / 60.0, error)
    found = model.training["orders_above_cap"]["orders"]
    assert {249, 250, 251} <= set(found)
    wider = next(lines for size, lines in starts if size > 401)  # the first search with columns above the cap
    assert {250} <= wider and {1, 200} <= wider


def test_lines_at_orders_a_scan_picked_are_no_collapse():
    # Issue 27: lines on more than a third of the orders mean a collapsed search (repeated from a power law),
    # but orders carried above the cap were picked for their lines. A 2·10^5-reading stepper sweep with 150 of
    # them had the whole search repeated (17 s instead of 4.9) for the lines it was meant to have.
    design = _jittered_design(highest=40)
    hyper = _evidence.Hyper(0.3, 2.0, 0.01, {k: 1.0 for k in range(21, 41)}, False)
    assert _evidence._collapsed(design, hyper)  # 20 lines on 40 orders
    design.picked = np.arange(26, 41)  # 15 of them picked by a scan: 5 lines on 25 orders
    assert not _evidence._collapsed(design, hyper)
    hyper.lines.update({k: 1.0 for k in range(1, 5)})  # 9 lines on 25 orders
    assert _evidence._collapsed(design, hyper)


def _smooth_profile_readings(seed, jittered):
    """180 readings of a ν⁻¹ profile (orders 1-90) and 0.05 arcmin of noise: on a 2° grid, or at random angles."""
    rng = np.random.default_rng(seed)
    theta = np.sort(rng.uniform(0.0, 360.0, 180)) if jittered else np.arange(180) * 2.0
    orders = np.arange(1, 91)
    amplitude, phase = 2.0 * rng.normal(size=90) / orders, rng.uniform(0.0, 2.0 * math.pi, 90)
    error = (amplitude[:, None] * np.cos(orders[:, None] * np.radians(theta) + phase[:, None])).sum(0) \
        + 0.05 * rng.normal(size=theta.size)
    return theta + error / 60.0, error


@pytest.mark.parametrize("seed, jittered, raised", [(0, True, False), (5, False, True)])
def test_the_noise_is_raised_after_a_collapse_only_where_the_evidence_allows(seed, jittered, raised, monkeypatch):
    # At random angles a strong order's leakage lifts the periodogram's flat level far above the noise (2 against
    # 0.05² here); the blind maximum then looks like a collapse, and five optimisations along the ridge came back
    # to it. The smallest raise is now tried first and, as it costs more than the slack, the maximum stands after
    # one. On the 2° grid (seed 5) σ² collapses (to 2e-7 or less) and is raised as before, to about 0.01.
    calls, results = [], []
    profile, prefer = _evidence._profile, _evidence._prefer_noise

    def counted(*args):
        calls.append(args[2])
        return profile(*args)

    def recorded(design, hyper, *args):
        result = prefer(design, hyper, *args)
        results.append((hyper.noise_fixed, hyper.noise_var, result.noise_var))
        return result

    monkeypatch.setattr(_evidence, "_profile", counted)
    monkeypatch.setattr(_evidence, "_prefer_noise", recorded)
    fit_spectral(*_smooth_profile_readings(seed, jittered))
    fixed, maximum, chosen = next(result for result in results if not result[0])
    if raised:
        assert maximum < 1e-5 and 5e-3 < chosen < 2e-2 and len(calls) == 6  # the probe, the top, 4 bisections
    else:
        assert chosen == maximum and len(calls) == 1


def test_the_stops_angles_are_the_readings_own_when_each_stop_has_one():
    from encal.models.spectral import _stops

    theta = np.array([10.0, 359.999, 0.001, 200.0])
    group = np.array([1, 3, 0, 2])
    np.testing.assert_array_equal(_stops(theta, group), [0.001, 10.0, 200.0, 359.999])
    # two readings at a stop across 0/360: their circular mean
    means = _stops(np.array([359.0, 1.0, 90.0]), np.array([0, 0, 1]))
    assert min(abs(means[0]), abs(means[0] - 360.0)) < 1e-12 and abs(means[1] - 90.0) < 1e-12

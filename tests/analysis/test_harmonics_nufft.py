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


# ---------------------------------------------------------------- the normal equations at NumPy speed (harmonics10)

def _normal_equations_answers(monkeypatch):
    """A list that records, for every call of ``_series_by_normal_equations``, whether it answered (not the QR)."""
    answers = []
    solve = profile._series_by_normal_equations

    def spy(*args):
        result = solve(*args)
        answers.append(result is not None)
        return result

    monkeypatch.setattr(profile, "_series_by_normal_equations", spy)
    return answers


def _dense_cases(case):
    """Angles (degrees), errors (arcmin) and the order of one of the dense layouts the normal equations solve."""
    rng = np.random.default_rng(10)
    if case == "random":
        theta, max_order = rng.uniform(0.0, 360.0, 3000), 100
    elif case == "sweep":  # three revolutions over 1000 stops, read by an encoder with a first-harmonic error
        reference = np.tile(np.arange(1000) * 0.36, 3)
        theta, max_order = np.mod(reference + 0.05 * np.sin(np.radians(reference)) + rng.normal(0, 1e-3, 3000),
                                  360.0), 100
    else:  # a jittered grid of 601 (odd) or 600 (even: the Nyquist term) nodes, every node read, no arc
        nodes = 601 if case == "jittered grid" else 600
        spacing = 360.0 / nodes
        theta = np.mod(0.37 + (np.arange(nodes) + rng.uniform(-0.2, 0.2, nodes)) * spacing, 360.0)  # Kadec: < 1/4
        max_order = None  # the identifiable order, the Nyquist order of the grid
    r = np.radians(theta)
    error = 2.0 * np.cos(r + 0.3) + 0.5 * np.sin(17 * r) + 0.1 * np.cos(40 * r) + rng.normal(0.0, 0.2, theta.size)
    return theta, error, max_order


@pytest.mark.parametrize("case", ["random", "sweep", "jittered grid", "jittered grid, Nyquist"])
def test_normal_equations_give_the_qr_answer_and_its_ranking(case, monkeypatch):
    """Known truth: the least squares of the QR (``fit_harmonic_series``) to 1e-10 of the largest coefficient, and the
    same ranking of every order. The spy checks that conjugate gradients answered: a wrong product or
    preconditioner would not converge and leave the answer to the QR, hiding the fault."""
    theta, error, max_order = _dense_cases(case)
    answered = _normal_equations_answers(monkeypatch)
    result = profile.harmonics(theta, error, max_order)
    assert answered == [True]
    grid = profile._grid(theta)
    assert (grid.nyquist_order == result.max_order) == (case == "jittered grid, Nyquist")
    assert case in ("random", "sweep") or (result.max_order == theta.size // 2 and not grid.uniform)
    cos, sin = profile.fit_harmonic_series(theta, error, range(result.max_order + 1))
    scale = np.abs(cos - 1j * sin).max()
    assert np.abs((result.cos_arcmin - cos) + 1j * (result.sin_arcmin - sin)).max() <= 1e-10 * scale
    by_qr = profile.Harmonics(result.orders, cos, sin, theta.size)
    assert np.array_equal(result.ranked(), by_qr.ranked())
    assert profile.rank_orders(theta, error, max_order)[:10] == [int(k) for k in by_qr.ranked()[:10]]


@pytest.mark.parametrize("half", [0, 1, 7, 40])
def test_the_toeplitz_product_is_the_dense_matrix_product(half):
    """``Σ_k s_{k-j} x_k`` over ``|k| <= L`` for vectors with ``x_{-k} = conj(x_k)``, against the dense matrix."""
    rng = np.random.default_rng(half)
    moments = rng.normal(size=2 * half + 1) + 1j * rng.normal(size=2 * half + 1)
    moments[0] = moments[0].real
    x = rng.normal(size=half + 1) + 1j * rng.normal(size=half + 1)
    x[0] = x[0].real
    index = np.arange(-half, half + 1)
    difference = index[np.newaxis, :] - index[:, np.newaxis]  # k - j
    matrix = np.where(difference >= 0, moments[np.abs(difference)], np.conj(moments[np.abs(difference)]))
    whole = np.r_[np.conj(x[:0:-1]), x]
    expected = (matrix @ whole)[half:]
    assert np.abs(profile._toeplitz_product(moments, half)(x) - expected).max() <= 1e-13 * np.abs(matrix).sum()


def test_the_fast_length_is_the_smallest_5_smooth_length():
    def smooth(n):
        for factor in (2, 3, 5):
            while n % factor == 0:
                n //= factor
        return n == 1

    lengths = [profile._fast_length(n) for n in range(1, 3001)]
    expected = [next(m for m in range(n, 2 * n + 1) if smooth(m)) for n in range(1, 3001)]
    assert lengths == expected
    assert profile._fast_length(147_285) == 147_456  # 4L + 1 for 10^6 random angles' identifiable order


def test_moments_by_real_ffts_agree_with_the_exponentials():
    from encal.numerics.trigsums import trig_moments_real

    rng = np.random.default_rng(12)
    theta = rng.uniform(-1.0, 7.0, 1500)  # outside [0, 2π) too
    weights = rng.normal(size=theta.size)
    highest = 1201
    assert highest > profile._REAL_FFT_ABOVE_ORDER
    exact = np.exp(1j * np.multiply.outer(np.arange(highest + 1), theta)) @ weights
    assert np.abs(trig_moments_real(theta, weights, highest) - exact).max() <= 1e-13 * np.abs(weights).sum()


def test_harmonics_to_a_high_order_recover_a_trigonometric_polynomial(monkeypatch):
    """20,000 random angles, every order to 600 (moments to 1200: the real FFTs of ``trig_moments_real``), no
    noise: the least squares is the polynomial itself."""
    rng = np.random.default_rng(13)
    theta = rng.uniform(0.0, 360.0, 20_000)
    order = 600
    assert order <= profile.identifiable_order(theta)
    coefficients = rng.normal(size=order + 1) + 1j * rng.normal(size=order + 1)  # a_k - i b_k
    coefficients[0] = coefficients[0].real
    z = np.exp(1j * np.radians(theta))
    series = np.zeros(theta.size, dtype=complex)
    for c in coefficients[::-1]:  # Horner: Σ c_k z^k
        series = series * z + c
    error = series.real - 0.5 * coefficients[0].real  # a_0 once, a_k cos + b_k sin from Re(c_k z^k) for k > 0
    answered = _normal_equations_answers(monkeypatch)
    result = profile.harmonics(theta, error, order)
    assert answered == [True]
    expected = coefficients.copy()
    expected[0] *= 0.5
    assert np.abs((result.cos_arcmin - 1j * result.sin_arcmin) - expected).max() <= 1e-10 * np.abs(expected).max()

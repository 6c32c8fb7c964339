"""Error statistics and harmonic analysis (encal.analysis.profile)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from encal import Calibration, ErrorStats, Harmonics, error_stats, harmonics, wrap180
from encal._core.errors import InputError
from encal.analysis.profile import distinct_angles, fit_harmonic_series, identifiable_order

finite_errors = st.lists(st.floats(-1e4, 1e4, allow_nan=False), min_size=1, max_size=200)


# --------------------------------------------------------------------------- error_stats


def test_error_stats_of_known_values():
    stats = error_stats([-4.0, 0.0, 1.0, 3.0])
    assert stats.n == 4
    assert stats.mae == pytest.approx(2.0)
    assert stats.rms == pytest.approx(np.sqrt(26 / 4))
    assert stats.std == pytest.approx(np.sqrt(np.mean((np.array([-4, 0, 1, 3]) - 0.0) ** 2)))
    assert (stats.min, stats.max, stats.pp, stats.max_abs) == (-4.0, 3.0, 7.0, 4.0)


def test_std_is_the_rms_about_the_mean():
    stats = error_stats([10.0, 12.0])
    assert stats.rms == pytest.approx(np.sqrt(122.0))
    assert stats.std == pytest.approx(1.0)


def test_error_stats_of_a_calibration_uses_its_errors():
    ref = np.arange(0.0, 360.0, 2.0)
    cal = Calibration(ref, ref + np.sin(np.radians(ref)) / 60.0)  # 1 arcmin first harmonic
    stats = error_stats(cal)
    assert stats.n == 180
    assert stats.rms == pytest.approx(np.sqrt(0.5), rel=1e-9)
    assert stats.mae == pytest.approx(2 / np.pi, rel=1e-3)
    assert stats == error_stats(cal.errors_arcmin)


def test_as_dict_has_the_contract_keys_and_plain_types():
    record = error_stats(np.array([1.0, -2.0])).as_dict()
    assert set(record) == {"n", "mae_arcmin", "rms_arcmin", "std_arcmin", "min_arcmin",
                           "max_arcmin", "max_abs_arcmin", "pp_arcmin"}
    assert type(record["n"]) is int
    assert all(type(value) is float for key, value in record.items() if key != "n")
    assert record["max_abs_arcmin"] == 2.0


def test_error_stats_is_frozen():
    with pytest.raises(AttributeError):
        error_stats([1.0]).rms = 0.0  # type: ignore[misc]
    assert isinstance(error_stats([1.0]), ErrorStats)


@pytest.mark.parametrize("bad", [[], [1.0, np.nan], [np.inf]])
def test_error_stats_refuses_empty_or_non_finite(bad):
    with pytest.raises(InputError, match="error_stats expects"):
        error_stats(bad)


@given(finite_errors)
def test_rms_decomposes_into_mean_and_std_and_bounds_mae(errors):
    stats = error_stats(errors)
    mean = float(np.mean(errors))
    scale = max(1.0, stats.max_abs)
    assert stats.rms**2 == pytest.approx(mean**2 + stats.std**2, rel=1e-9, abs=1e-9 * scale**2)
    # MAE <= RMS about zero always (Jensen): why the paper's "RMS" below its MAE must be a STD.
    assert stats.mae <= stats.rms * (1 + 1e-12) + 1e-12
    assert stats.min <= mean + 1e-9 * scale and mean <= stats.max + 1e-9 * scale
    assert stats.pp == pytest.approx(stats.max - stats.min)


def test_a_profile_like_the_papers_encoder_4_has_std_below_mae():
    """Table 1, encoder 4: MAE 1.78 > "RMS" 1.31 -- possible only for the RMS about the mean."""
    theta = np.radians(np.arange(0.0, 360.0, 2.0))
    errors = -1.5 + 1.31 * np.sqrt(2) * np.cos(theta)  # an offset and a first harmonic
    stats = error_stats(errors)
    assert stats.std == pytest.approx(1.31, rel=1e-9)
    assert stats.mae > stats.std
    assert stats.rms > stats.mae


# --------------------------------------------------------------------------- harmonics


def dft_amplitudes(values):
    n = values.size
    spectrum = np.fft.rfft(values) / n
    amplitude = 2.0 * np.abs(spectrum)
    amplitude[0] /= 2.0
    if n % 2 == 0:
        amplitude[-1] /= 2.0
    return spectrum, amplitude


@pytest.mark.parametrize("n, offset_deg", [(180, 0.0), (180, 1.0), (25, 0.0), (24, 7.3), (2, 0.0), (1, 5.0)])
@pytest.mark.parametrize("seed", range(3))
def test_harmonics_on_a_uniform_grid_equal_the_dft(n, offset_deg, seed):
    rng = np.random.default_rng(seed)
    theta = offset_deg + 360.0 * np.arange(n) / n
    errors = rng.normal(size=n) * 3.0
    _, amplitude = dft_amplitudes(errors)
    shuffle = rng.permutation(n)  # the analysis must not depend on the order of the points
    result = harmonics(theta[shuffle], errors[shuffle])
    assert result.max_order == n // 2
    assert_allclose(result.amplitude_arcmin, amplitude, rtol=0, atol=1e-10)


def test_harmonic_coefficients_on_a_grid_from_zero_are_the_dft_coefficients():
    n = 180
    theta = 360.0 * np.arange(n) / n
    errors = np.random.default_rng(7).normal(size=n)
    spectrum, _ = dft_amplitudes(errors)
    result = harmonics(theta, errors)
    expected_cos = 2.0 * spectrum.real
    expected_sin = -2.0 * spectrum.imag
    expected_cos[0] /= 2.0
    expected_cos[-1] /= 2.0  # Nyquist: one cosine term, sin identically zero at the samples
    expected_sin[-1] = 0.0
    assert_allclose(result.cos_arcmin, expected_cos, rtol=0, atol=1e-10)
    assert_allclose(result.sin_arcmin, expected_sin, rtol=0, atol=1e-10)


def test_nyquist_term_on_the_papers_test_grid_is_a_sine():
    theta = np.arange(1.0, 360.0, 2.0)  # 1, 3, ..., 359: cos(90 θ) vanishes here, sin(90 θ) = ±1
    errors = 0.7 * np.sin(np.radians(90 * theta))
    result = harmonics(theta, errors)
    assert result.top(1) == [90]
    assert result.sin_arcmin[90] == pytest.approx(0.7, abs=1e-12)
    assert result.cos_arcmin[90] == pytest.approx(0.0, abs=1e-12)


def test_harmonics_recover_a_profile_on_an_irregular_grid():
    rng = np.random.default_rng(3)
    theta = np.sort(rng.uniform(0.0, 360.0, 61))
    cos = np.array([0.5, 2.0, -1.0, 0.0, 0.3])
    sin = np.array([0.0, 1.0, 0.25, -0.7, 0.0])
    k = np.arange(5)
    errors = (np.cos(np.radians(np.outer(theta, k))) @ cos + np.sin(np.radians(np.outer(theta, k))) @ sin)
    result = harmonics(theta, errors, max_order=12)
    assert_allclose(result.cos_arcmin[:5], cos, atol=1e-10)
    assert_allclose(result.sin_arcmin[:5], sin, atol=1e-10)
    assert_allclose(result.amplitude_arcmin[5:], 0.0, atol=1e-10)
    largest_gap = np.max(np.diff(np.r_[theta, theta[0] + 360.0]))
    default = harmonics(theta, errors).max_order
    assert default * largest_gap < 180.0 <= (default + 1) * largest_gap  # the gap rule


def test_harmonic_series_interpolates_the_points_at_the_identifiable_order():
    theta = np.arange(0.0, 360.0, 10.0)
    errors = np.random.default_rng(1).normal(size=theta.size)
    assert_allclose(harmonics(theta, errors)(theta), errors, atol=1e-10)


def test_amplitude_and_phase_describe_a_shifted_cosine():
    theta = np.arange(0.0, 360.0, 2.0)
    result = harmonics(theta, -0.4 + 3.0 * np.cos(np.radians(2 * theta - 40.0)))
    assert result.amplitude_arcmin[2] == pytest.approx(3.0, abs=1e-12)
    assert np.degrees(result.phase_rad[2]) == pytest.approx(40.0, abs=1e-9)
    assert result.amplitude_arcmin[0] == pytest.approx(0.4, abs=1e-12)
    assert result.phase_rad[0] == pytest.approx(np.pi)


def test_top_lists_the_largest_orders_first_as_the_paper_does():
    theta = np.arange(0.0, 360.0, 2.0)
    amplitudes = {1: 3.0, 2: 2.5, 16: 1.2, 0: 1.0, 14: 0.8, 48: 0.5}
    errors = sum(a * np.cos(np.radians(k * theta + 10.0 * k)) for k, a in amplitudes.items())
    result = harmonics(theta, errors)
    assert result.top(6) == [1, 2, 16, 0, 14, 48]
    assert result.top(0) == []
    assert len(result.top(1000)) == 91
    listed = result.as_list()
    assert [entry["order"] for entry in listed[:6]] == [1, 2, 16, 0, 14, 48]
    # cos(kθ + 10k°) = cos(kθ - φ_k) with φ_k = -10k°
    assert listed[0] == {"order": 1, "amplitude_arcmin": pytest.approx(3.0), "phase_deg": pytest.approx(-10.0)}
    assert listed[2]["phase_deg"] == pytest.approx(wrap180(-160.0))
    assert all(type(e["order"]) is int and type(e["amplitude_arcmin"]) is float for e in listed)
    assert [e["order"] for e in result.as_list(3)] == [1, 2, 16]
    with pytest.raises(InputError):
        result.top(-1)


def test_equal_amplitudes_rank_the_lower_order_first():
    theta = np.arange(0.0, 360.0, 10.0)
    result = harmonics(theta, np.cos(np.radians(5 * theta)) + np.sin(np.radians(3 * theta)))
    assert result.top(2) == [3, 5]


def test_harmonics_refuse_orders_the_points_cannot_identify():
    theta = [0.0, 10.0, 20.0, 30.0, 50.0, 100.0]  # 6 irregular angles identify order 2
    with pytest.raises(InputError) as info:
        harmonics(theta, np.zeros(6), max_order=3)
    assert str(info.value) == ("The 'max_order' parameter of harmonics must be an int from 0 to 2 (the highest "
                               "order 6 distinct encoder angles can determine), or None. Got 3 instead.")
    with pytest.raises(InputError, match="cannot identify"):
        fit_harmonic_series(np.arange(0.0, 360.0, 36.0), np.zeros(10), [1, 9])  # 9 aliases to 1


@pytest.mark.parametrize("theta, errors", [([], []), ([1.0, 2.0], [1.0]), ([np.nan], [1.0])])
def test_harmonics_refuse_bad_arrays(theta, errors):
    with pytest.raises(InputError, match="harmonics expects"):
        harmonics(theta, errors)


def test_repeated_angles_do_not_count_towards_the_identifiable_order():
    grid = np.arange(0.0, 360.0, 2.0)
    assert identifiable_order(grid) == 90
    assert identifiable_order(np.r_[grid, grid]) == 90
    assert identifiable_order(np.r_[grid, grid + 1e-12, 360.0 - 1e-12]) == 90
    assert identifiable_order(np.r_[grid, 1.0]) == 89  # irregular, largest gap 2°: 89 * 2° < 180°
    assert identifiable_order(grid + 0.2 * np.sin(np.radians(grid))) == 90  # within 1/4 spacing
    assert identifiable_order(grid + 0.8 * np.sin(np.radians(grid))) == 88  # irregular, gap 2.03°
    assert identifiable_order(np.arange(0.0, 300.0, 2.0)) == 2  # a 62° gap hides order 3


def test_orders_above_the_stable_default_can_be_asked_for():
    theta = np.r_[np.arange(0.0, 300.0, 2.0), 330.0]  # 151 angles, largest gap 30°: default 5
    errors = np.cos(np.radians(7 * theta))
    assert harmonics(theta, errors).max_order == 5
    result = harmonics(theta, errors, max_order=7)
    assert result.top(1) == [7]
    assert_allclose(result.amplitude_arcmin, np.eye(8)[7], atol=1e-9)


def test_two_epochs_on_one_grid_average_in_the_analysis():
    theta = np.arange(0.0, 360.0, 2.0)
    first = np.cos(np.radians(theta))
    result = harmonics(np.r_[theta, theta], np.r_[first + 0.5, first - 0.5])
    assert_allclose(result.amplitude_arcmin[:2], [0.0, 1.0], atol=1e-12)


def test_distinct_angles_merge_repeats_also_across_zero():
    angles, group = distinct_angles(np.array([359.9999999999, 0.0, 180.0, 180.0]))
    assert angles.tolist() == [0.0, 180.0]
    assert group.tolist() == [0, 0, 1, 1]


def test_harmonics_is_a_public_type():
    theta = np.arange(0.0, 360.0, 30.0)
    assert isinstance(harmonics(theta, np.zeros(12)), Harmonics)


@settings(max_examples=50, deadline=None)
@given(
    n=st.integers(3, 120),
    offset=st.floats(0.0, 360.0, exclude_max=True),
    rotation=st.integers(-3, 3),
)
def test_harmonic_amplitudes_do_not_depend_on_where_the_grid_starts(n, offset, rotation):
    rng = np.random.default_rng(n)
    errors = rng.normal(size=n)
    theta = offset + 360.0 * np.arange(n) / n + 360.0 * rotation
    _, amplitude = dft_amplitudes(errors)
    assert_allclose(harmonics(theta, errors).amplitude_arcmin, amplitude, atol=1e-9)


# --------------------------------------------------------------------------- how the least squares is solved


def _encoder_grid(n, error_amplitude_arcmin):
    """Encoder readings of a uniform reference grid with a first-harmonic error: a smooth, irregular grid."""
    reference = 360.0 * np.arange(n) / n
    return reference + error_amplitude_arcmin / 60.0 * np.sin(np.radians(reference) + 0.3)


GRIDS = {
    "regular, even (Nyquist term)": _encoder_grid(600, 2.0),
    "regular, odd": _encoder_grid(601, 2.0),
    "irregular, smooth": _encoder_grid(1000, 20.0),
    "irregular, one extra angle": np.r_[np.arange(0.0, 360.0, 2.0), 1.0],
    "random": np.random.default_rng(5).uniform(0.0, 360.0, 500),
    "clustered": np.r_[np.random.default_rng(6).uniform(0.0, 10.0, 900), np.linspace(10.0, 360.0, 100, False)],
    "uniform, unequal repeats": np.r_[np.arange(0.0, 360.0, 2.0), np.arange(0.0, 180.0, 2.0)],
    "uniform, shifted": 0.37 + np.arange(0.0, 360.0, 2.0),
}


@pytest.mark.parametrize("grid", GRIDS)
@pytest.mark.parametrize("below", [0, 3])
def test_harmonics_equal_the_qr_least_squares(grid, below):
    """The FFT and the normal equations give the least-squares answer of the QR (fit_harmonic_series)."""
    theta = GRIDS[grid]
    errors = np.random.default_rng(below).normal(size=theta.size) + 3.0 * np.cos(np.radians(theta))
    max_order = identifiable_order(theta) - below
    result = harmonics(theta, errors, max_order)
    cos, sin = fit_harmonic_series(theta, errors, range(max_order + 1))
    assert_allclose(result.cos_arcmin, cos, rtol=0, atol=1e-12)
    assert_allclose(result.sin_arcmin, sin, rtol=0, atol=1e-12)


@pytest.mark.parametrize("error_amplitude_arcmin", [0.0, 2.0])
def test_harmonics_of_ten_thousand_points_recover_a_noise_free_profile(error_amplitude_arcmin):
    """10,000 points, uniform (FFT) or with a 2 arcmin error that makes the grid irregular (normal equations)."""
    theta = _encoder_grid(10_000, error_amplitude_arcmin)
    orders = np.array([0, 1, 2, 16, 1024, 4000])
    cos = np.array([0.5, 2.0, -1.0, 0.3, 0.2, 0.1])
    sin = np.array([0.0, 1.0, 0.25, -0.7, 0.05, -0.1])
    phase = np.radians(np.outer(theta, orders))
    result = harmonics(theta, np.cos(phase) @ cos + np.sin(phase) @ sin)
    assert result.max_order >= 4997
    expected_cos, expected_sin = np.zeros(result.max_order + 1), np.zeros(result.max_order + 1)
    expected_cos[orders], expected_sin[orders] = cos, sin
    assert_allclose(result.cos_arcmin, expected_cos, rtol=0, atol=1e-10)
    assert_allclose(result.sin_arcmin, expected_sin, rtol=0, atol=1e-10)


def test_orders_above_what_the_angles_determine_are_refused_with_the_limit():
    theta = _encoder_grid(180, 2.0)  # regular, not uniform: the QR alone would accept order 179
    with pytest.raises(InputError, match=r"order 179 from 180 .* is 90, .* order 179 looks like order 1\)"):
        fit_harmonic_series(theta, np.zeros(180), [0, 1, 179])
    with pytest.raises(InputError, match=r"orders \[91, 120\] .* is 90"):
        fit_harmonic_series(theta, np.zeros(180), [1, 91, 120])
    irregular = np.random.default_rng(0).uniform(0.0, 360.0, 50)
    with pytest.raises(InputError, match=r"order 30 from 50 distinct encoder angles: the highest order they "
                                         r"determine is 24, and above it an order aliases a lower one$"):
        fit_harmonic_series(irregular, np.zeros(50), [1, 30])


def test_harmonics_fall_back_on_the_qr_when_conjugate_gradients_do_not_converge(monkeypatch):
    theta = GRIDS["random"]
    errors = np.cos(np.radians(3.0 * theta))
    expected = harmonics(theta, errors)
    monkeypatch.setattr("encal.analysis.profile._CG_MAX_ITER", 1)
    result = harmonics(theta, errors)
    assert_allclose(result.cos_arcmin, expected.cos_arcmin, rtol=0, atol=1e-12)
    assert_allclose(result.sin_arcmin, expected.sin_arcmin, rtol=0, atol=1e-12)


# -- issue 30 (dense30): angles plainly off every grid skip the grid fit ------------------------------------------

def _grid_the_long_way(theta_deg):
    """``angles_and_grid``'s grid computed by ``_fit_grid`` whatever the gaps (the code before the shortcut)."""
    from encal.analysis import profile

    distinct = distinct_angles(theta_deg)[0]
    m = distinct.size
    phase, deviation, regular = profile._fit_grid(distinct, m)
    return regular, (phase if regular else None), regular and deviation * 360.0 / m <= profile.ANGLE_TOLERANCE_DEG


@pytest.mark.parametrize("case", ["random", "grid", "jitter 0.2", "jitter 0.3", "jitter 0.37", "one node missing",
                                  "two per node"])
def test_grid_shortcut_agrees_with_the_grid_fit(case):
    """The shortcut (a gap over 1.75 spacings: on no grid of as many nodes as angles) answers as ``_fit_grid``."""
    from encal.analysis.profile import angles_and_grid, uniform_grid

    rng = np.random.default_rng(30)
    m = 720
    nodes = np.arange(m) * 360.0 / m
    spacing = 360.0 / m
    theta = {"random": rng.uniform(0.0, 360.0, 5000),
             "grid": nodes,
             "jitter 0.2": nodes + rng.uniform(-0.2, 0.2, m) * spacing,
             "jitter 0.3": nodes + rng.uniform(-0.3, 0.3, m) * spacing,
             "jitter 0.37": nodes + rng.choice([-0.37, 0.37], m) * spacing,
             "one node missing": np.delete(nodes, 100),
             "two per node": np.r_[nodes, nodes + 0.1 * spacing]}[case] % 360.0
    regular, phase, uniform = _grid_the_long_way(theta)
    grid = angles_and_grid(theta)[2]
    assert (grid.phase_rad is None) == (phase is None) and grid.uniform == uniform
    if phase is not None:
        assert grid.phase_rad == phase
    assert (uniform_grid(theta) is None) == (not regular)


def test_random_angles_skip_the_grid_fit(monkeypatch):
    """10^4 random angles (gaps of many spacings) are no uniform grid of 10^4 nodes without the grid fit's passes."""
    from encal.analysis import profile

    def refuse(*args):
        raise AssertionError("_fit_grid called for angles plainly off every grid")

    monkeypatch.setattr(profile, "_fit_grid", refuse)
    theta = np.random.default_rng(1).uniform(0.0, 360.0, 10_000)
    assert profile.angles_and_grid(theta)[2].phase_rad is None
    assert profile.uniform_grid(theta) is None


def _qr_only(monkeypatch):
    from encal.analysis import profile

    monkeypatch.setattr(profile, "_GRAM_ABOVE", 10**12)


@pytest.mark.parametrize("case", ["random", "grid with its Nyquist term", "sorted sweep"])
def test_many_readings_are_fitted_from_the_normal_equations_as_the_qr_fits_them(case, monkeypatch):
    # From _GRAM_ABOVE readings the least squares is solved from trigonometric moments (no design matrix); its
    # coefficients agree with the QR's to rounding, the Nyquist term locked to its grid included.
    rng = np.random.default_rng(3)
    grid_deg = None
    if case == "random":
        theta = rng.uniform(0.0, 360.0, 40_000)
        orders = [0, 1, 2, 5, 16, 33]
    elif case == "sorted sweep":
        theta = np.sort(rng.uniform(0.0, 360.0, 40_000))
        orders = list(range(17))
    else:  # 40,000 readings at 400 nodes of a grid starting at 0.3 degrees, 100 each
        grid_deg = 0.3 + np.arange(400) * 0.9
        theta = np.repeat(grid_deg, 100) + rng.uniform(-0.2, 0.2, 40_000)
        orders = [1, 3, 200]
    errors = 2.0 * np.cos(np.radians(theta) + 0.3) + 0.4 * np.sin(np.radians(16 * theta)) \
        + rng.normal(0.0, 0.1, theta.size)
    by_gram = fit_harmonic_series(theta, errors, orders, grid_deg=grid_deg)
    _qr_only(monkeypatch)
    by_qr = fit_harmonic_series(theta, errors, orders, grid_deg=grid_deg)
    assert_allclose(by_gram, by_qr, rtol=0, atol=1e-12)


def test_many_readings_on_an_arc_are_left_to_the_qr_and_its_rank_test(monkeypatch):
    # On an arc low orders are far from orthogonal, past the normal equations' condition limit: the QR solves them
    # (120 degrees, orders 0 to 3), and refuses orders it cannot tell apart as it always did (30 degrees, 0 to 8).
    from encal.analysis import profile

    rng = np.random.default_rng(5)
    theta = rng.uniform(100.0, 220.0, 30_000)
    errors = np.cos(np.radians(theta)) + rng.normal(0.0, 0.01, theta.size)
    columns = profile._column_phasors(range(4), profile._grid(theta))[:2]
    assert profile._well_conditioned(profile._gram(np.radians(theta), np.ones(theta.size), *columns)) is None
    fitted = fit_harmonic_series(theta, errors, range(4))
    narrow = rng.uniform(100.0, 130.0, 30_000)
    with pytest.raises(InputError, match="rank-deficient least squares"):
        fit_harmonic_series(narrow, np.cos(np.radians(narrow)), range(9))
    _qr_only(monkeypatch)
    assert_allclose(fitted, fit_harmonic_series(theta, errors, range(4)), rtol=0, atol=0)


def test_harmonic_series_and_order_are_those_of_the_two_functions():
    from encal.analysis.profile import harmonic_series_and_order

    rng = np.random.default_rng(8)
    for theta in (rng.uniform(0.0, 360.0, 500), rng.uniform(0.0, 360.0, 30_000), np.arange(0.0, 360.0, 2.0)):
        errors = np.sin(np.radians(3 * theta)) + rng.normal(0.0, 0.05, theta.size)
        cos, sin, order = harmonic_series_and_order(theta, errors, [0, 1, 3])
        assert_allclose((cos, sin), fit_harmonic_series(theta, errors, [0, 1, 3]), rtol=0, atol=0)
        assert order == identifiable_order(theta)


@pytest.mark.parametrize("case", ["random", "repeats", "across zero", "one angle", "sweep"])
def test_the_distinct_values_are_those_of_distinct_angles(case):
    from encal.analysis.profile import _distinct_values

    rng = np.random.default_rng(9)
    theta = {"random": rng.uniform(0.0, 360.0, 5000),
             "repeats": np.repeat(rng.uniform(0.0, 360.0, 50), 7) + rng.choice([0.0, 4e-10], 350),
             "across zero": np.r_[0.0, 2e-10, 359.9999999999, 10.0, 10.0, 200.0],
             "one angle": np.array([5.0, 5.0, 5.0 + 1e-10]),
             "sweep": np.tile(np.arange(0.0, 360.0, 0.5), 3)}[case]
    np.testing.assert_array_equal(_distinct_values(theta), distinct_angles(theta)[0])

"""The fleet prior (issue 32): a unit of a known fleet calibrated from a quarter turn."""

import numpy as np
import pytest

from encal._core.errors import InputError
from encal.fleet.prior import fit_with_prior, fleet_prior
from encal.models.fourier import FourierModel
from encal.models.spectral import fit_spectral

MEAN = {1: (3.0, 0.0), 2: (0.0, 1.0), 5: (0.5, 0.2)}  # order: (cos, sin), arcmin


def _unit(rng, spread=0.05):
    cos, sin = np.zeros(8), np.zeros(8)
    for order, (c, s) in MEAN.items():
        cos[order], sin[order] = c, s
    cos[1:] += spread * rng.standard_normal(7)
    sin[1:] += spread * rng.standard_normal(7)
    return FourierModel(np.arange(8), cos, sin)


def test_a_quarter_turn_with_the_fleet_prior_recovers_the_whole_profile():
    rng = np.random.default_rng(3)
    prior = fleet_prior([_unit(rng) for _ in range(30)], orders=20)
    assert prior.mean_cos[0] == pytest.approx(3.0, abs=0.05) and prior.mean_sin[1] == pytest.approx(1.0, abs=0.05)
    assert np.sqrt(prior.variance[0]) == pytest.approx(0.05, rel=0.5)
    unit = _unit(rng)
    theta = np.arange(0.0, 90.0, 2.0)
    error = unit.predict(theta) + 7.0 + 0.02 * rng.standard_normal(theta.size)  # an arbitrary zero offset
    grid = np.arange(0.0, 360.0, 0.5)
    truth = unit.predict(grid)

    def rms_about_offset(model):
        difference = model.predict(grid) - truth
        return float(np.sqrt(np.mean((difference - difference.mean()) ** 2)))

    with_prior = fit_with_prior(theta, error, prior)
    alone = fit_spectral(theta, error)
    assert rms_about_offset(with_prior) < 0.1 < 1.0 < rms_about_offset(alone)
    assert with_prior.training["noise"]["std_arcmin"] == pytest.approx(0.02, rel=0.4)
    assert with_prior.expected_rms_between_points() < 0.2  # its posterior knows it
    assert "fleet" in with_prior.training["prior"]


def test_the_prior_needs_a_few_units_and_finite_readings():
    rng = np.random.default_rng(0)
    with pytest.raises(InputError, match="5 or more units"):
        fleet_prior([_unit(rng) for _ in range(3)])
    prior = fleet_prior([_unit(rng) for _ in range(6)], orders=10)
    with pytest.raises(InputError, match="finite readings"):
        fit_with_prior([0.0, np.nan], [1.0, 2.0], prior)


def _profile_rms_about_offset(model, coefficients, grid=np.arange(0.0, 360.0, 0.5)):
    """RMS (arcmin) of a model minus a profile {order: (cos, sin)}, zero offset removed."""
    angles = np.radians(grid)
    truth = sum(c * np.cos(k * angles) + s * np.sin(k * angles) for k, (c, s) in coefficients.items())
    difference = model.predict(grid) - truth
    return float(np.sqrt(np.mean((difference - difference.mean()) ** 2)))


def _fourier(coefficients, highest):
    cos, sin = np.zeros(highest + 1), np.zeros(highest + 1)
    for order, (c, s) in coefficients.items():
        cos[order], sin[order] = c, s
    return FourierModel(np.arange(highest + 1), cos, sin)


def test_a_lot_without_unit_variation_is_recovered_from_a_quarter_of_the_points():
    """Units of one design and nothing else: the fleet's profile, orders past the coarse grid's Nyquist order
    included (32 and 48 on 45 stops), comes back from every 4th point to within the noise's share."""
    design = {1: (2.0, -1.0), 2: (0.4, 0.3), 16: (0.3, -0.2), 32: (0.15, 0.1), 48: (-0.1, 0.08)}
    prior = fleet_prior([_fourier(design, 60) for _ in range(10)], orders=60)
    rng = np.random.default_rng(11)
    theta = np.arange(0.0, 360.0, 8.0)  # 45 stops: Nyquist order 22
    error = _fourier(design, 60).predict(theta) - 3.0 + 0.05 * rng.standard_normal(theta.size)
    assert _profile_rms_about_offset(fit_with_prior(theta, error, prior), design) < 0.01


def test_an_order_past_the_nyquist_order_that_the_fleet_shows_louder_than_its_alias_takes_the_aliased_data():
    """Order 32 with a phase of its own in every unit, its alias on 45 stops (order 13) quiet: from every 4th
    point the data at the alias are order 32's, and the prior knows it (held at the fleet's mean, it was 0.35')."""
    rng = np.random.default_rng(5)

    def unit():
        return {1: tuple(rng.normal(0.0, 1.0, 2)), 32: tuple(rng.normal(0.0, 0.5, 2)),
                13: tuple(rng.normal(0.0, 0.01, 2))}

    prior = fleet_prior([_fourier(unit(), 60) for _ in range(40)], orders=60)
    truth = unit()
    theta = np.arange(0.0, 360.0, 8.0)
    error = _fourier(truth, 60).predict(theta) + 0.02 * rng.standard_normal(theta.size)
    model = fit_with_prior(theta, error, prior)
    assert _profile_rms_about_offset(model, truth) < 0.05
    assert 32 not in model.training["fleet_prior"]["held_orders"] and 40 in model.training["fleet_prior"]["held_orders"]


def test_the_prior_learns_each_orders_cos_and_sin_spread_and_their_correlation():
    """Order 2 of a line: a gain that moves its cos part (σ 0.5'), a quadrature its sin part less (σ 0.1'),
    correlated 0.6; order 1 a mount of any phase (σ 1' each part, uncorrelated)."""
    rng = np.random.default_rng(8)
    covariance = np.array([[0.25, 0.6 * 0.05], [0.6 * 0.05, 0.01]])
    units = []
    for _ in range(400):
        c2, s2 = rng.multivariate_normal([1.0, 0.2], covariance)
        units.append(_fourier({1: tuple(rng.normal(0.0, 1.0, 2)), 2: (c2, s2)}, 4))
    prior = fleet_prior(units, orders=4)
    cos, sin, cross = prior.blocks()
    assert prior.mean_cos[1] == pytest.approx(1.0, abs=0.06) and prior.mean_sin[1] == pytest.approx(0.2, abs=0.015)
    assert np.sqrt(cos[:2]) == pytest.approx([1.0, 0.5], rel=0.2)  # a MAD of 400 units: about 6 % sampling error
    assert np.sqrt(sin[:2]) == pytest.approx([1.0, 0.1], rel=0.2)
    assert cross[1] / np.sqrt(cos[1] * sin[1]) == pytest.approx(0.6, abs=0.1)
    assert abs(cross[0]) / np.sqrt(cos[0] * sin[0]) < 0.15


def test_a_line_whose_gain_moves_one_direction_of_an_order_is_recovered_better_with_the_2x2_prior():
    """Orders 2 and 3 of a line move along one direction each (a gain, a quadrature: cos and sin together),
    order 1 (the mount) any way. From a quarter turn the 2x2 prior knows the directions; the same prior with one
    variance per order (cos and sin alike and independent, as before) leaves about twice the error (known truth:
    the whole profile)."""
    import dataclasses

    rng = np.random.default_rng(1)

    def unit():
        gain, quadrature = rng.normal(0.0, 1.0, 2)
        return {1: tuple(rng.normal(0.0, 1.0, 2)), 2: (0.5 + 0.6 * gain, 0.2 + 0.6 * gain),
                3: (0.3 + 0.5 * quadrature, -0.1 - 0.5 * quadrature), 5: (0.2, 0.1)}

    prior = fleet_prior([_fourier(unit(), 10) for _ in range(60)], orders=10)
    alike = dataclasses.replace(prior, variance_cos=None, variance_sin=None, covariance_cos_sin=None)
    theta = np.arange(0.0, 90.0, 2.0)
    errors = {"2x2": [], "alike": []}
    for _ in range(12):
        truth = unit()
        error = _fourier(truth, 10).predict(theta) + 0.05 * rng.standard_normal(theta.size)
        for label, which in (("2x2", prior), ("alike", alike)):
            errors[label].append(_profile_rms_about_offset(fit_with_prior(theta, error, which), truth))
    assert np.median(errors["2x2"]) < 0.55 < np.median(errors["alike"])


# prior8: the claim (held-out estimate) and the ±2σ band of units fitted under the prior, against known truth


def _gaussian_unit(rng, orders=8):
    """A unit of a Gaussian fleet: a shared design plus N(0, (0.3/k)²) arcmin on each part of order k."""
    cos, sin = np.zeros(orders + 1), np.zeros(orders + 1)
    for order, (c, s) in MEAN.items():
        cos[order], sin[order] = c, s
    spread = 0.3 / np.arange(1, orders + 1)
    cos[1:] += spread * rng.standard_normal(orders)
    sin[1:] += spread * rng.standard_normal(orders)
    return FourierModel(np.arange(orders + 1), cos, sin)


def test_units_fitted_from_a_quarter_turn_claim_what_they_are_and_their_band_covers_the_unseen_angles():
    """120 new units of three Gaussian lots (40 learned from each), each from a quarter turn: the true error after
    correction (the noise included, as the claim) over the claim, and the ±2σ band at the unseen 270°. One best
    scale of the fleet's spread per unit (before prior8) shrank where a quarter turn says little: 6.7 % of the units
    were over 2x their claim, the band covered 89.8 %; averaged over the fleet's own spread of scales 2.5 % and
    95.3 %."""
    theta, every, unseen = np.arange(0.0, 90.0, 2.0), np.arange(1.0, 360.0, 2.0), np.arange(91.0, 360.0, 2.0)
    ratios, covered = [], []
    for seed in range(3):
        rng = np.random.default_rng(seed)
        prior = fleet_prior([_gaussian_unit(rng) for _ in range(40)], orders=12)
        for _ in range(40):
            unit = _gaussian_unit(rng)
            model = fit_with_prior(theta, unit.predict(theta) + 0.02 * rng.standard_normal(theta.size), prior)
            difference = model.predict(every) - unit.predict(every)
            offset = difference.mean()  # the claim and the band are of the shape about the offset (claim9)
            true = np.sqrt(np.mean((difference - offset) ** 2) + 0.02**2)
            ratios.append(true / model.expected_rms_between_points())
            predicted, std = model.predict(unseen, return_std=True, include_noise=False)
            covered.append(np.mean(np.abs(predicted - unit.predict(unseen) - offset) <= 2.0 * std))
    assert np.mean(np.array(ratios) > 2.0) <= 0.05
    assert 0.92 <= np.mean(covered) <= 0.99
    # claim9: the claim held the offset's posterior variance, which a quarter turn leaves large, and the median unit's
    # shape was 0.73 of its claim (coverage of the shape 91.0 %); of the shape alone 0.90 (95.4 %)
    assert np.median(ratios) > 0.85


def test_the_claim_and_the_band_do_not_depend_on_the_units_arbitrary_zero():
    """A motor's zero is arbitrary: a unit's readings shifted by -3792 arcmin (a real board's) claim what they claim
    at zero. The band's moments over the unit's scale were raw (second minus mean squared) with weights summing to
    1 - ε (those under 1e-6 skipped), and the offset's square leaked into the band: a phantom 6.4 arcmin on a real
    board, the claim 2.5 times its truth (claim9)."""
    rng = np.random.default_rng(9)
    prior = fleet_prior([_gaussian_unit(rng) for _ in range(40)], orders=12)
    unit = _gaussian_unit(rng)
    theta = np.arange(0.0, 360.0, 8.0)
    error = unit.predict(theta) + 0.02 * rng.standard_normal(theta.size)
    at_zero, shifted = fit_with_prior(theta, error, prior), fit_with_prior(theta, error - 3792.0, prior)
    assert shifted.expected_rms_between_points() == pytest.approx(at_zero.expected_rms_between_points(), rel=1e-2)
    assert shifted.predict(theta) == pytest.approx(at_zero.predict(theta) - 3792.0, abs=1e-3)
    offset_std = shifted.training["fleet_prior"]["offset_std_arcmin"]
    assert offset_std == pytest.approx(at_zero.training["fleet_prior"]["offset_std_arcmin"], rel=1e-2)
    assert offset_std < 0.02  # about σ/√45 on stops over the whole turn


def test_the_fleet_says_how_loud_its_units_are():
    """A Gaussian fleet's units are as loud as its robust spread says (log scale about 0, spread small); a fleet
    with heavier tails (Student's t, 3 degrees of freedom: a variance 2.3 times its MAD's) is louder than it says."""
    rng = np.random.default_rng(4)
    gaussian = fleet_prior([_gaussian_unit(rng) for _ in range(200)], orders=12)
    assert abs(gaussian.log_scale_mean) < 0.15 and gaussian.log_scale_std < 0.4

    def heavy_unit():
        cos, sin = np.zeros(9), np.zeros(9)
        cos[1:], sin[1:] = (0.3 / np.arange(1, 9) * rng.standard_t(3, 8) for _ in range(2))
        return FourierModel(np.arange(9), cos, sin)

    heavy = fleet_prior([heavy_unit() for _ in range(200)], orders=12)
    assert heavy.log_scale_mean > gaussian.log_scale_mean + 0.3


def test_the_band_holds_what_an_order_held_at_the_fleets_mean_leaves_between_the_stops():
    """Order 40 spreads (σ 0.1') less than its alias on 45 stops, order 5 (σ 0.3'): it is held at the fleet's mean,
    and between the stops the unit's own order 40 is an error the posterior of the fitted orders does not see. The
    band covers it: 93.8 % of the angles halfway between the stops (before prior8 it claimed the fitted orders'
    posterior alone and covered 6 %)."""
    rng = np.random.default_rng(6)

    def unit():
        return {1: tuple(rng.normal(0.0, 1.0, 2)), 5: tuple(rng.normal(0.0, 0.3, 2)),
                40: tuple(rng.normal(0.0, 0.1, 2))}

    prior = fleet_prior([_fourier(unit(), 60) for _ in range(40)], orders=60)
    theta, between = np.arange(0.0, 360.0, 8.0), np.arange(4.0, 360.0, 8.0)
    covered = []
    for _ in range(10):
        truth = _fourier(unit(), 60)
        model = fit_with_prior(theta, truth.predict(theta) + 0.02 * rng.standard_normal(theta.size), prior)
        assert 40 in model.training["fleet_prior"]["held_orders"]
        predicted, std = model.predict(between, return_std=True, include_noise=False)
        covered.append(np.mean(np.abs(predicted - truth.predict(between)) <= 2.0 * std))
    assert np.mean(covered) > 0.9

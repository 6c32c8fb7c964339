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

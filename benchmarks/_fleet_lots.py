"""Simulated lots for the fleet prior's benchmark, each with its generating distribution.

A lot is a list of units: training run (encoder angles in degrees, errors in arc-minutes, table angles),
test run (encoder angles and the noise-free error there) and the noise of one reading. With each lot goes
``draw_profiles(count, seed)``: noise-free error profiles of fresh units from the lot's own generating
distribution, on a uniform grid, so that the true mean and covariance of the Fourier coefficients across
units can be estimated as closely as wanted (the informed bound of bench_fleet_prior.py).

Lots:

- ``simulated``: encal.simulate's fleet (seed 32), the spec's resolver encoder. Every parameter of every unit
  is drawn afresh: the winding harmonics, the slot harmonics, the converter's nonlinearity, all with random
  phases, zero mean. No two units share a design: the fleet's mean profile is zero at every order.
- ``production``: a resolver line written from the physics (benchmarks/_physics_world.py, the R/D converter
  of shared/reference/resolver-error-model.md). One design drawn once (seed 3201): its winding and slot
  harmonics, the converter type's multiplier nonlinearity, the windings' imbalance and quadrature are shared
  by every unit, each unit varying by 10 % of the design spread. Each unit has a mounting of its own
  (eccentricity N_c(0, 0.5'), order 1; a coupling misalignment beta ~ |N(0, 0.5 deg)| giving beta^2/4 at
  order 2 with a random phase), its own converter gain (+-100 ppm) and offsets (+-200 ppm, order 1), zero
  and noise (0.25-0.4 LSB).
"""

import math

import numpy as np

import _physics_world as world

ARCMIN_PER_RAD = world.ARCMIN_PER_RAD
PPM = world.PPM
TRAIN_GRID_DEG = np.arange(0.0, 360.0, 2.0)
TEST_GRID_DEG = np.arange(1.0, 360.0, 2.0)
#: Fraction of the design's spread by which a unit of the production line departs from the design.
UNIT_VARIATION = 0.10


def _wrap_arcmin(radians):
    return np.angle(np.exp(1j * radians)) * ARCMIN_PER_RAD


# -- encal.simulate's lot -------------------------------------------------------------------------------

def simulated_lot(count, seed=32):
    """encal.simulate's fleet: units as dicts (see the module's docstring)."""
    from encal.simulate import simulate_fleet
    from encal.simulate._run import measurement_floor

    units = []
    for member in simulate_fleet(count, seed=seed):
        train, test = member.train, member.test
        units.append({"theta": train.calibration.encoder_deg, "y": train.calibration.errors_arcmin,
                      "reference": train.calibration.reference_deg, "theta_test": test.calibration.encoder_deg,
                      "truth_test": test.noise_free_error_arcmin, "sigma": measurement_floor(train)})
    return units


def simulated_profiles(count, points=720, seed=3232):
    """Noise-free error profiles (arcmin) of ``count`` fresh units of encal.simulate, at ``points`` table angles."""
    from encal.simulate._encoder import draw_encoder
    from encal.simulate._signal import converter_angle

    grid = np.arange(points) * (2.0 * math.pi / points)
    profiles = np.empty((count, points))
    for i in range(count):
        encoder = draw_encoder(np.random.default_rng([seed, i]))
        profiles[i] = _wrap_arcmin(converter_angle(encoder.state(), grid, None) - grid)
    return profiles


# -- a production line ------------------------------------------------------------------------------------

def _design(seed=3201):
    return world._resolver_parameters(np.random.default_rng(seed))


def _unit_parameters(design, rng):
    """One unit of the line: the design's resolver and converter type, its own mounting and electronics."""
    spread = dict(world._RESOLVER_HARMONICS)
    harmonics = {}
    for nu, (first, second) in design["harmonics"].items():
        balanced, unbalanced = spread[nu]
        sigma_first, sigma_second = (balanced, unbalanced) if nu % 4 != 3 else (unbalanced, balanced)
        harmonics[nu] = (first + world._complex_normal(rng, UNIT_VARIATION * sigma_first * PPM),
                         second + world._complex_normal(rng, UNIT_VARIATION * sigma_second * PPM))
    beta = abs(rng.normal(0.0, math.radians(0.5)))
    return {
        "zero": rng.uniform(-1.0, 1.0) / ARCMIN_PER_RAD,
        "eccentricity": world._complex_normal(rng, 0.5 / ARCMIN_PER_RAD),
        "tilt": beta**2 / 4.0 * np.exp(1j * rng.uniform(0.0, 2.0 * math.pi)),
        "imbalance": design["imbalance"] + rng.normal(0.0, 100 * PPM),
        "quadrature": design["quadrature"] + rng.normal(0.0, UNIT_VARIATION * 250 * PPM),
        "offsets": rng.normal(0.0, 200 * PPM, 2),
        "harmonics": harmonics,
        "octants": design["octants"] + world._complex_normal(rng, UNIT_VARIATION * 5 * PPM, 4),
        "noise_lsb": rng.uniform(0.25, 0.4),
    }


def _unit_angle(p, table_rad):
    """The decoded angle (rad, before noise): the coupling's tilt moves the shaft, then the resolver reads it."""
    shaft = table_rad + np.imag(p["tilt"] * np.exp(2j * table_rad))
    return world._resolver_angle(p, shaft)


def production_lot(count, seed=3202):
    """Units of one production line (see the module's docstring)."""
    design = _design()
    units = []
    for i in range(count):
        p = _unit_parameters(design, np.random.default_rng([seed, i]))
        case = world._case(lambda t, q=p: _unit_angle(q, t), TRAIN_GRID_DEG, TEST_GRID_DEG, world._RESOLVER_BITS,
                           p["noise_lsb"], np.random.default_rng([seed, i, 1]))
        units.append({"theta": case["theta"], "y": case["y"], "reference": TRAIN_GRID_DEG,
                      "theta_test": case["theta_test"], "truth_test": case["truth"](TEST_GRID_DEG),
                      "sigma": case["sigma"]})
    return units


def production_profiles(count, points=720, seed=3203):
    """Noise-free error profiles (arcmin) of ``count`` fresh units of the production line."""
    design = _design()
    grid = np.arange(points) * (2.0 * math.pi / points)
    profiles = np.empty((count, points))
    for i in range(count):
        p = _unit_parameters(design, np.random.default_rng([seed, i]))
        profiles[i] = _wrap_arcmin(_unit_angle(p, grid) - grid)
    return profiles


LOTS = {"simulated": (simulated_lot, simulated_profiles), "production": (production_lot, production_profiles)}

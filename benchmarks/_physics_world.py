"""A second simulated world, written from the physics and not from ``encal.simulate``.

Issue 27: the spectral model was tuned on the project's own simulated fleets. These encoders are
drawn from the physics references (shared/reference/resolver-error-model.md for a resolver read by a
16-bit R/D converter; the textbook error terms of a magnetic encoder on a motor shaft; a 200-step
stepper as the reference of a dense sweep), with their own simplifications and parameters, and
with independent noise in the training and the test runs. Nothing here reads ``encal.simulate``.

Each case is a dict: ``theta``/``y`` (training encoder angles in degrees, errors ``encoder -
reference`` in arc-minutes), ``theta_test``/``y_test`` (the test run), ``floor`` (RMS of the test
run's noise and rounding: what a perfect correction leaves), ``sigma`` (the training run's noise
standard deviation, rounding included, in arc-minutes: what "noise supplied" passes) and ``truth``
(the noise-free error as a function of the angle in degrees, or None where it is too costly to
use).

Cases (``physics_cases(name)``):

- ``resolver``: 12 resolvers, the paper's grid (trained at 0:2:358°, tested at 1:2:359°);
- ``resolver-epoch``: the same resolvers tested at a later epoch (small drifts of every coefficient);
- ``resolver-36``: the same resolvers trained on 36 points (0:10:350°), tested at 1:2:359°;
- ``resolver-rough``: the resolvers with a flat roughness, orders 1-90, 1.5 times the noise power per order;
- ``magnetic``: 12 magnetic encoders (14 bits) on a motor: eccentricity and tilt of the magnet, few orders;
- ``12bit-physics``: 12 magnetic encoders read at 12 bits (the rounding dominates the noise);
- ``stepper-dense``: 8 dense sweeps (2·10^4-2·10^5 samples) of a 14-bit magnetic encoder behind a
  200-step stepper whose detent and microstep error (orders 50, 100, 200 and sidebands) the
  reference carries; tested on a fresh sweep.
"""

import math

import numpy as np

ARCMIN_PER_RAD = 60.0 * 180.0 / math.pi
PPM = 1e-6


def _complex_normal(rng, sigma, size=None):
    return rng.normal(0.0, sigma, size) + 1j * rng.normal(0.0, sigma, size)


# -- a resolver and its R/D converter --------------------------------------------------------------

#: spatial harmonic ν of the windings -> (σ of the balanced part, σ of the unbalanced part), ppm.
#: Own choice of slots: 16 stator slots, 12 rotor slots; the rest from the winding distribution.
_RESOLVER_HARMONICS = {2: (20, 20), 3: (30, 12), 5: (12, 12), 7: (10, 10), 9: (5, 8), 11: (15, 10), 13: (12, 25),
                       15: (80, 40), 17: (50, 15), 31: (35, 8), 33: (25, 6), 47: (25, 6), 49: (18, 5)}
_RESOLVER_BITS = 16


def _resolver_parameters(rng):
    harmonics = {}
    for nu, (balanced, unbalanced) in _RESOLVER_HARMONICS.items():
        first, second = _complex_normal(rng, balanced * PPM), _complex_normal(rng, unbalanced * PPM)
        if nu % 2 == 0:
            harmonics[nu] = (first, second)
        elif nu % 4 == 1:
            harmonics[nu] = (first, second)  # (P_ν, N_ν): balanced is positive sequence
        else:
            harmonics[nu] = (second, first)  # balanced is negative sequence
    return {
        "zero": rng.uniform(-1.0, 1.0) / ARCMIN_PER_RAD,
        "eccentricity": _complex_normal(rng, 0.5 / ARCMIN_PER_RAD),
        "imbalance": rng.normal(0.0, 300 * PPM),  # transformation ratio and converter gain, lumped
        "quadrature": rng.normal(0.0, 250 * PPM),
        "offsets": rng.normal(0.0, 200 * PPM, 2),  # envelope offsets (null voltage, demodulator)
        "harmonics": harmonics,
        "octants": _complex_normal(rng, 5 * PPM, 4),  # converter multiplier nonlinearity, orders 8k
        "noise_lsb": rng.uniform(0.25, 0.4),
    }


def _drift(rng, p):
    """A later epoch: every coefficient x(1 + N(0, 2 %)), the zero moved a little."""
    q = dict(p)
    scale = lambda value: value * (1.0 + rng.normal(0.0, 0.02))  # noqa: E731
    q["zero"] = p["zero"] + rng.normal(0.0, 0.05) / ARCMIN_PER_RAD
    q["imbalance"], q["quadrature"] = scale(p["imbalance"]), scale(p["quadrature"])
    q["offsets"] = p["offsets"] * (1.0 + rng.normal(0.0, 0.02, 2))
    q["harmonics"] = {nu: (scale(a), scale(b)) for nu, (a, b) in p["harmonics"].items()}
    return q


def _resolver_angle(p, table_rad):
    """The decoded angle (rad, before noise and quantisation) at table angles: exact atan2."""
    theta = table_rad + p["zero"] + np.imag(p["eccentricity"] * np.exp(1j * table_rad))
    z = np.zeros(theta.shape, dtype=complex)
    for nu, (positive, negative) in p["harmonics"].items():
        z += positive * np.exp(1j * nu * theta) + negative * np.exp(-1j * nu * theta)
    alpha, phi = p["imbalance"], p["quadrature"]
    s = (1.0 + alpha / 2.0) * np.sin(theta + phi / 2.0) + z.imag + p["offsets"][0]
    c = (1.0 - alpha / 2.0) * np.cos(theta - phi / 2.0) + z.real + p["offsets"][1]
    angle = np.arctan2(s, c)
    for k, kappa in enumerate(p["octants"], start=1):
        angle = angle + np.imag(kappa * np.exp(1j * 8 * k * angle))
    return angle


def _read_quantised(angle_rad, table_rad, bits, noise_lsb, rng, truncate=True):
    """Readings of a ``bits``-bit converter with noise: error ``reading - table`` in arcmin, and readings in degrees.

    ``truncate``: a tracking converter's ±1 LSB hysteresis, the table always stepping forward, truncates.
    """
    lsb = 2.0 * math.pi / 2**bits
    x = (angle_rad + rng.normal(0.0, noise_lsb * lsb, angle_rad.shape)) / lsb
    code = np.floor(x) if truncate else np.round(x)
    reading = np.mod(code * lsb, 2.0 * math.pi)
    error = (np.angle(np.exp(1j * (reading - table_rad)))) * ARCMIN_PER_RAD
    return np.degrees(reading), error


def _case(truth_angle, table_train_deg, table_test_deg, bits, noise_lsb, rng, truncate=True,
          test_angle=None, roughness=None):
    """Train and test runs of one encoder; ``truth_angle(table_rad)`` the noise-free reading in rad."""
    test_angle = test_angle or truth_angle
    tr, te = np.radians(table_train_deg), np.radians(table_test_deg)
    extra = roughness or (lambda t: 0.0)
    angle_train = truth_angle(tr) + extra(tr) / ARCMIN_PER_RAD
    angle_test = test_angle(te) + extra(te) / ARCMIN_PER_RAD
    theta, y = _read_quantised(angle_train, tr, bits, noise_lsb, rng, truncate)
    theta_test, y_test = _read_quantised(angle_test, te, bits, noise_lsb, rng, truncate)
    clean_test = np.angle(np.exp(1j * (angle_test - te))) * ARCMIN_PER_RAD
    clean_train = np.angle(np.exp(1j * (angle_train - tr))) * ARCMIN_PER_RAD
    # rounding by truncation is a -0.5 LSB bias, part of the profile (order 0)
    bias = -0.5 * 360.0 * 60.0 / 2**bits if truncate else 0.0

    def truth(t_deg):
        t = np.radians(np.asarray(t_deg, dtype=float))
        return np.angle(np.exp(1j * (truth_angle(t) + extra(t) / ARCMIN_PER_RAD - t))) * ARCMIN_PER_RAD + bias

    return {"theta": theta, "y": y, "theta_test": theta_test, "y_test": y_test,
            "floor": float(np.sqrt(np.mean((y_test - clean_test - bias) ** 2))),
            "sigma": float(np.std(y - clean_train - bias)), "truth": truth}


def _roughness(rng, noise_arcmin, points=180, highest=90, factor=1.5):
    orders = np.arange(1, highest + 1)
    std = math.sqrt(factor * 2.0 * noise_arcmin**2 / points)
    a, b = rng.normal(0.0, std, (2, orders.size))

    def rough(t_rad):
        r = np.asarray(t_rad, dtype=float)[..., None]
        return np.cos(orders * r) @ a + np.sin(orders * r) @ b

    return rough


def resolver_cases(kind, count=12, seed=27):
    train_grid = np.arange(0.0, 360.0, 10.0 if kind == "resolver-36" else 2.0)
    test_grid = np.arange(1.0, 360.0, 2.0)
    for i in range(count):
        rng = np.random.default_rng([seed, i])
        p = _resolver_parameters(rng)
        noise_rng = np.random.default_rng([seed, i, {"resolver": 0, "resolver-epoch": 1, "resolver-36": 2,
                                                     "resolver-rough": 3}[kind]])
        test = None
        if kind == "resolver-epoch":
            later = _drift(np.random.default_rng([seed, i, 99]), p)
            test = lambda t, q=later: _resolver_angle(q, t)  # noqa: E731
        rough = None
        if kind == "resolver-rough":
            lsb_arcmin = 360.0 * 60.0 / 2**_RESOLVER_BITS
            noise = lsb_arcmin * math.sqrt(p["noise_lsb"] ** 2 + 1.0 / 12.0)
            rough = _roughness(np.random.default_rng([seed, i, 7]), noise)
        yield f"R{i:02d}", _case(lambda t, q=p: _resolver_angle(q, t), train_grid, test_grid, _RESOLVER_BITS,
                                 p["noise_lsb"], noise_rng, test_angle=test, roughness=rough)


# -- a magnetic encoder on a motor shaft -------------------------------------------------------------

def _magnetic_parameters(rng):
    """Magnet eccentricity (order 1), tilt of magnet or sensor (order 2), the field's and the sensor's
    nonlinearity (orders 3, 4, decaying): a few orders, in arcmin of error."""
    return {"zero": rng.uniform(-30.0, 30.0),
            "terms": {1: _complex_normal(rng, 12.0), 2: _complex_normal(rng, 4.0), 3: _complex_normal(rng, 1.2),
                      4: _complex_normal(rng, 0.8), 6: _complex_normal(rng, 0.2)}}


def _magnetic_angle(p, table_rad):
    error = p["zero"] + sum(np.imag(c * np.exp(1j * k * table_rad)) for k, c in p["terms"].items())
    return table_rad + error / ARCMIN_PER_RAD


def magnetic_cases(bits, count=12, seed=270):
    train_grid, test_grid = np.arange(0.0, 360.0, 2.0), np.arange(1.0, 360.0, 2.0)
    for i in range(count):
        rng = np.random.default_rng([seed, bits, i])
        p = _magnetic_parameters(rng)
        noise_lsb = rng.uniform(0.6, 1.2) if bits >= 14 else rng.uniform(0.1, 0.3)
        yield f"M{bits}-{i:02d}", _case(lambda t, q=p: _magnetic_angle(q, t), train_grid, test_grid, bits,
                                         noise_lsb, np.random.default_rng([seed, bits, i, 1]), truncate=False)


# -- a dense sweep behind a 200-step stepper ----------------------------------------------------------

def _stepper_parameters(rng):
    """The rotor's lag behind the commanded microstep (arcmin, a function of the commanded angle):
    phase-current offset (order 50), amplitude mismatch (100), detent and the current's shape (200), each
    modulated by the rotor's once- and twice-per-revolution air-gap variation (sidebands ±1, ±2)."""
    terms = {50: _complex_normal(rng, 0.8), 100: _complex_normal(rng, 1.0), 200: _complex_normal(rng, 2.5),
             400: _complex_normal(rng, 0.4)}
    modulation = {1: _complex_normal(rng, 0.12), 2: _complex_normal(rng, 0.05)}
    return terms, modulation


def _stepper_error(params, commanded_rad):
    terms, modulation = params
    envelope = 1.0 + sum(np.real(m * np.exp(1j * k * commanded_rad)) for k, m in modulation.items())
    return envelope * sum(np.imag(c * np.exp(1j * k * commanded_rad)) for k, c in terms.items())


def stepper_cases(sizes=(20_000, 50_000, 100_000, 200_000), repeats=2, seed=2700, test_points=20_000):
    for size in sizes:
        for r in range(repeats):
            rng = np.random.default_rng([seed, size, r])
            encoder, stepper = _magnetic_parameters(rng), _stepper_parameters(rng)
            noise_lsb = rng.uniform(0.6, 1.2)

            def shaft(t, q=encoder, s=stepper):  # the encoder's noise-free reading at commanded angle t
                rotor = t + _stepper_error(s, t) / ARCMIN_PER_RAD
                return _magnetic_angle(q, rotor)

            # a continuous sweep sampled asynchronously: commanded angles spread over the circle
            train = np.sort(rng.uniform(0.0, 360.0, size))
            test = rng.uniform(0.0, 360.0, test_points)
            yield f"S{size // 1000}k-{r}", _case(shaft, train, test, 14, noise_lsb,
                                                  np.random.default_rng([seed, size, r, 1]), truncate=False)


PHYSICS_SUITES = ("resolver", "resolver-epoch", "resolver-36", "resolver-rough", "magnetic", "12bit-physics",
                  "stepper-dense")


def physics_cases(name, fresh=0):
    """``(encoder name, case)`` of one suite of this world; ``fresh`` > 0 draws other encoders of the same
    physics (seeds moved by ``100_000 * fresh``), ones no rule was chosen on."""
    shift = 100_000 * fresh
    if name.startswith("resolver"):
        yield from resolver_cases(name, seed=27 + shift)
    elif name == "magnetic":
        yield from magnetic_cases(14, seed=270 + shift)
    elif name == "12bit-physics":
        yield from magnetic_cases(12, seed=270 + shift)
    elif name == "stepper-dense":
        yield from stepper_cases(seed=2700 + shift)
    else:
        raise ValueError(f"unknown suite {name!r}")

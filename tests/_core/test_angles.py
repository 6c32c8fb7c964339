import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from encal._core.angles import angle_difference, arcmin_to_lsb, lsb_arcmin, wrap180, wrap360

finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)


@given(finite)
def test_wrap360_range_and_congruence(angle):
    wrapped = wrap360(angle)
    assert 0.0 <= wrapped < 360.0
    assert abs(wrap180(wrapped - angle)) < 1e-6


@given(finite)
def test_wrap180_range_and_congruence(angle):
    wrapped = wrap180(angle)
    assert -180.0 < wrapped <= 180.0
    assert abs(wrap180(wrapped - angle)) < 1e-6


@given(finite, st.integers(-5, 5))
def test_wrap_is_periodic(angle, turns):
    assert abs(wrap180(wrap360(angle + 360.0 * turns) - wrap360(angle))) < 1e-6


def test_wrap_edges():
    assert wrap360(360.0) == 0.0
    assert wrap360(-1e-17) == 0.0  # np.mod alone gives 360.0 here
    assert wrap180(-180.0) == 180.0
    assert wrap180(180.0) == 180.0
    assert wrap180(540.0) == 180.0
    assert_allclose(wrap180([179.0, 181.0, -181.0]), [179.0, -179.0, 179.0])


def test_angle_difference_across_zero():
    assert_allclose(angle_difference(0.5, 359.5), 1.0)
    assert_allclose(angle_difference(359.5, 0.5), -1.0)


def test_units():
    assert lsb_arcmin(16) == 21600 / 65536
    assert_allclose(lsb_arcmin(14), 1.318359375)
    assert_allclose(arcmin_to_lsb(lsb_arcmin(12) * 3, 12), 3.0)


def test_scalar_in_scalar_out():
    assert isinstance(wrap360(10.0), float)
    assert np.shape(wrap180(np.zeros((2, 3)))) == (2, 3)


def test_wrap360_is_np_mod_bit_for_bit():
    """The vectorised wrap (no fmod) gives np.mod's value, the sign of zero and the 360 -> 0 rule included."""
    rng = np.random.default_rng(0)
    turns = [k * 360.0 for k in range(-20, 21)]
    edges = turns + [np.nextafter(t, side) for t in turns for side in (-np.inf, np.inf)] + [
        0.0, -0.0, -1e-17, 1e-17, 5e-324, -5e-324, -1e-300, 719.9999999999999, -359.99999999999994]
    for angles in (np.array(edges * 3), rng.uniform(0.0, 360.0, 10_000), rng.uniform(-360.0, 720.0, 10_000),
                   rng.uniform(-1e4, 1e4, 10_000),
                   rng.uniform(-1.0, 1.0, 10_000) * 10.0 ** rng.integers(-300, 12, 10_000),
                   rng.uniform(-1e-12, 1e-12, 1000), 360.0 + rng.uniform(-1e-12, 1e-12, 1000),
                   rng.uniform(-2.0**40, 2.0**40, 1000), rng.uniform(-1e300, 1e300, 1000), np.array([-0.0] * 100)):
        expected = np.mod(angles, 360.0)
        expected = np.where(expected >= 360.0, 0.0, expected)
        np.testing.assert_array_equal(wrap360(angles).view(np.int64), expected.view(np.int64))


# -- issue 30 (dense30): resolution_of_readings wraps the readings only when the first ones show a resolution ------

def _resolution_before(angles_deg, min_bits=8, max_bits=24, tolerance_counts=1e-3):
    """The function before: every reading wrapped by np.mod first."""
    angles = np.asarray(angles_deg, dtype=float).reshape(-1)
    if angles.size == 0 or not np.all(np.isfinite(angles)):
        return None
    angles = np.mod(angles, 360.0)

    def whole(values, bits):
        counts = values * (2**bits / 360.0)
        return bool(np.all(np.abs(counts - np.round(counts)) < tolerance_counts))

    for bits in range(min_bits, max_bits + 1):
        if whole(angles[:1024], bits) and whole(angles, bits):
            return bits
    return None


@pytest.mark.parametrize("case", ["14-bit codes", "codes past a turn", "negative codes", "-0.0 and 360", "noisy",
                                  "codes then noise", "12-bit with decimals", "few"])
def test_resolution_of_readings_as_before(case):
    from encal._core.angles import resolution_of_readings

    rng = np.random.default_rng(30)
    codes = rng.integers(0, 2**14, 5000) * 360.0 / 2**14
    angles = {"14-bit codes": codes,
              "codes past a turn": codes + 360.0 * rng.integers(-3, 4, codes.size),
              "negative codes": -codes,
              "-0.0 and 360": np.r_[-0.0, 360.0, codes],
              "noisy": rng.uniform(0.0, 360.0, 5000),
              "codes then noise": np.r_[codes[:2000], rng.uniform(0.0, 360.0, 10)],
              "12-bit with decimals": np.round(rng.integers(0, 4096, 3000) * 360.0 / 4096, 4),
              "few": codes[:5]}[case]
    assert resolution_of_readings(angles) == _resolution_before(angles)


def test_readings_the_first_ones_refuse_are_not_all_wrapped(monkeypatch):
    """10^5 readings that are no whole codes: refused on the first 1024, without a wrap of them all."""
    from encal._core import angles as module

    wrapped = []
    plain = module.wrap360
    monkeypatch.setattr(module, "wrap360", lambda a: wrapped.append(np.size(a)) or plain(a))
    plain_mod = np.mod
    monkeypatch.setattr(module.np, "mod", lambda a, b: wrapped.append(np.size(a)) or plain_mod(a, b))
    assert module.resolution_of_readings(np.random.default_rng(1).uniform(0.0, 360.0, 100_000)) is None
    assert max(wrapped, default=0) <= 1024

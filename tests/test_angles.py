import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from encal.angles import angle_difference, arcmin_to_lsb, lsb_arcmin, wrap180, wrap360

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

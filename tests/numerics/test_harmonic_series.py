"""The Fourier series by the direct form, an addition chain or tables (encal.numerics.harmonic_series).

The bound checked here, stated in the module's docstring: at an angle θ in [0, 360) degrees, a series of
m orders is within ``u Σ_k (|a_k| + |b_k|) (20 k + m + 2)`` (``u = 2^-53``; at most
``(20 K + m + 2) u Σ(|a_k| + |b_k|)`` for the highest order K) of the exact series at θ, evaluated in
extended precision, by each of the three forms. A reading outside [0, 360) is wrapped first,
as it always was, which adds ``4.5 k u`` per unit coefficient (the wrap rounds to half an ulp of 360):
``20 k`` becomes ``25 k`` from the exact series at the exact reduction of the reading.
"""

import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from encal.models.base import CHUNK_ANGLES, CHUNK_NUMBERS
from encal.models.fourier import MAX_ORDER, FourierModel
from encal.numerics.harmonic_series import HarmonicSeries, plan_products

U = 2.0**-53
EXTENDED = np.finfo(np.longdouble).eps < 1e-18
PI = np.longdouble("3.141592653589793238462643383279502884")

ORDER_SETS = {
    "the stored test model's": [0, 1, 2, 3, 4, 8, 16, 50, 97],
    "dense to 200": list(range(201)),
    "sparse, up to the largest": [1, 1000, 5000, 20011, MAX_ORDER],
    "random, up to the largest": sorted(np.random.default_rng(7).choice(MAX_ORDER + 1, 300, replace=False).tolist()),
    "the two largest": [MAX_ORDER - 1, MAX_ORDER],
    "one high order": [0, MAX_ORDER],
}


def _made_by(steps):
    made = {1}
    for k, i, j in steps:
        assert i + j == k and i in made and j in made, (k, i, j)
        made.add(k)
    return made


@pytest.mark.parametrize("orders", list(ORDER_SETS.values()), ids=list(ORDER_SETS))
def test_the_chain_reaches_every_order_from_powers_made_before(orders):
    steps = plan_products(orders)
    assert {k for k in orders if k > 0} <= _made_by(steps)
    assert len({k for k, _, _ in steps}) == len(steps)  # nothing made twice


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, MAX_ORDER), max_size=40))
def test_any_set_of_orders_gets_a_valid_chain_of_at_most_the_binary_methods_products(orders):
    steps = plan_products(orders)
    assert {k for k in orders if k > 0} <= _made_by(steps)
    # each order costs at most its own binary method: squarings to its top bit, one product per other set bit
    assert len(steps) <= sum(k.bit_length() + bin(k).count("1") - 2 for k in set(orders) if k > 0)


def test_a_dense_run_costs_one_product_per_order_and_a_sparse_order_its_binary_digits():
    assert len(plan_products(range(51))) == 49
    # 14 squarings to 2^14 and 14 products of the 15 set bits (or z^(K-1) so, times z: as many)
    assert len(plan_products([MAX_ORDER], routes=("squaring",))) == len(plan_products([MAX_ORDER])) == 28
    assert len(plan_products([1 << 14])) == 14
    # the stored model's 8 positive orders up to 97: 11 products (the recurrence through every order: 96)
    orders = ORDER_SETS["the stored test model's"]
    assert len(plan_products(orders)) == len(plan_products(orders, routes=("squaring",))) == 11
    assert len(plan_products(orders, routes=("difference",))) == 12
    # a dense run and sparse high orders: fewer products than either route alone
    orders = list(range(1, 11)) + [1000, 1001, 1002, 4095]
    assert [len(plan_products(orders, routes)) for routes in
            (("difference", "squaring"), ("difference",), ("squaring",))] == [28, 30, 41]


def test_the_cheaper_form_is_chosen():
    def method(orders):
        orders = np.asarray(orders)
        return HarmonicSeries(orders, np.ones(orders.size), np.ones(orders.size)).method

    assert method(ORDER_SETS["the stored test model's"]) == "taylor"  # 11 products cost more than its lookups
    assert method(range(201)) == "taylor"
    # 7 and 3 products cost more than the lookups in small tables (measured: 45 and 39 ns against 24 and 28)
    assert method([0, 97]) == method([1, 2, 3, 4]) == method([1, 2, 3, 2500]) == "taylor"
    assert method(ORDER_SETS["random, up to the largest"]) == "recurrence"  # the Taylor tables would be 33 MB
    assert method([0, MAX_ORDER]) == "direct"  # 28 products against a second cos and sin and a row sum
    assert method([12345]) == method([1]) == method([0]) == "direct"  # one order: its cos and sin, no sum


def _exact(theta_deg, orders, a, b):
    """The series in extended precision at the angles (degrees, taken exactly), rounded to double."""
    phase = np.multiply.outer(np.asarray(theta_deg, dtype=np.longdouble) * (PI / 180),
                              np.asarray(orders, dtype=np.longdouble))
    exact = np.cos(phase) * a.astype(np.longdouble) + np.sin(phase) * b.astype(np.longdouble)
    return exact.sum(axis=1)


def _bound(orders, a, b, per_order):
    orders = np.asarray(orders)
    return U * np.sum((np.abs(a) + np.abs(b)) * (per_order * orders + orders.size + 2))


def _coefficients(orders, seed):
    rng = np.random.default_rng(seed)
    scale = 1.0 / (1.0 + np.asarray(orders))  # a profile's harmonics fall with the order
    return rng.standard_normal(len(orders)) * scale, rng.standard_normal(len(orders)) * scale


@pytest.mark.skipif(not EXTENDED, reason="needs an extended-precision long double for the reference")
@pytest.mark.parametrize("form", ["recurrence", "taylor", "direct"])
@pytest.mark.parametrize("orders", list(ORDER_SETS.values()), ids=list(ORDER_SETS))
def test_within_the_stated_bound_of_the_exact_series_in_one_turn(orders, form):
    a, b = _coefficients(orders, 1)
    b = np.where(np.asarray(orders) == 0, 0.0, b)
    rng = np.random.default_rng(2)
    theta = np.concatenate([rng.uniform(0.0, 360.0, 3000), [0.0, 1e-300, 1e-9, 90.0, 180.0, 359.99999999999994]])
    series = HarmonicSeries(np.asarray(orders), a, b, method=form)
    error = np.abs(series(np.radians(theta)) - _exact(theta, orders, a, b)).astype(float)
    assert error.max() <= _bound(orders, a, b, 20)


@pytest.mark.skipif(not EXTENDED, reason="needs an extended-precision long double for the reference")
@pytest.mark.parametrize("orders", list(ORDER_SETS.values()), ids=list(ORDER_SETS))
def test_a_model_is_within_the_bound_for_readings_of_many_turns(orders):
    a, b = _coefficients(orders, 3)
    model = FourierModel(orders, a, b)
    rng = np.random.default_rng(4)
    readings = np.concatenate([rng.uniform(-1e6, 1e6, 3000), rng.integers(-2777, 2777, 50) * 360.0,
                               [-1e6, 1e6, -1e-12, 360.0 * 2777 - 1e-10]])
    reduced = np.fmod(readings.astype(np.longdouble), 360)  # exact
    reduced[reduced < 0] += 360
    error = np.abs(model.predict(readings) - _exact(reduced, orders, a, model.sin)).astype(float)
    assert error.max() <= _bound(orders, a, model.sin, 25)


@pytest.mark.parametrize("form", ["recurrence", "taylor"])
@pytest.mark.parametrize("orders", list(ORDER_SETS.values()), ids=list(ORDER_SETS))
def test_the_faster_forms_and_the_direct_form_agree_to_the_bound(orders, form):
    a, b = _coefficients(orders, 5)
    theta = np.radians(np.random.default_rng(6).uniform(0.0, 360.0, 2000))
    faster = HarmonicSeries(np.asarray(orders), a, b, method=form)(theta)
    direct = HarmonicSeries(np.asarray(orders), a, b, method="direct")(theta)
    assert np.max(np.abs(faster - direct)) <= 2 * _bound(orders, a, b, 20)


def test_a_pure_harmonic_of_the_largest_order_is_exact_at_the_grid_it_repeats_on():
    # cos(K θ) at θ = 360 j / K is 1: the recurrence keeps it to the bound, with no growth of |z^K|
    model = FourierModel([MAX_ORDER], [1.0], [0.0])
    series = HarmonicSeries(model.orders, model.cos, model.sin, method="recurrence")
    theta = 360.0 * np.arange(0, MAX_ORDER, 97) / MAX_ORDER
    assert np.max(np.abs(series(np.radians(theta)) - 1.0)) <= (20 * MAX_ORDER + 3) * U


@pytest.mark.parametrize("orders, form", [(ORDER_SETS["the stored test model's"], "taylor"),
                                         (ORDER_SETS["the stored test model's"], "recurrence"),
                                         (ORDER_SETS["random, up to the largest"], "recurrence")],
                         ids=["stored-taylor", "stored-recurrence", "random-recurrence"])
def test_an_angle_gives_the_same_bits_alone_and_anywhere_in_a_block(orders, form):
    a, b = _coefficients(orders, 8)
    model = FourierModel(orders, a, b)
    model._harmonics = HarmonicSeries(model.orders, model.cos, model.sin, method=form)
    angles = np.random.default_rng(9).uniform(-720.0, 720.0, 3000)
    block = model.predict(angles)
    alone = np.array([model.predict(angle) for angle in angles[:100]])
    np.testing.assert_array_equal(block[:100], alone)
    for start in (1, 3, 5, 7, 13):
        np.testing.assert_array_equal(model.predict(angles[start:]), block[start:])
    # a chunk boundary falls elsewhere for each of these sizes
    for size in (CHUNK_ANGLES - 1, CHUNK_ANGLES + 5, 2 * CHUNK_ANGLES + 3):
        many = np.resize(angles, size)
        np.testing.assert_array_equal(model.predict(many)[-3000:], np.resize(block, size)[-3000:])


@pytest.mark.parametrize("name, form", [("random, up to the largest", "recurrence"), ("dense to 200", "taylor")])
def test_memory_is_the_result_and_one_chunk_of_the_stated_width(name, form):
    orders = ORDER_SETS[name]
    a, b = _coefficients(orders, 10)
    model = FourierModel(orders, a, b)
    model.predict(0.0)  # the evaluator's tables are made once, on first use
    assert model._series_evaluator().method == form
    width = model.evaluation_width
    assert width == model._series_evaluator().width < 2 * len(orders)  # fewer live pairs than orders
    angles = np.random.default_rng(11).uniform(0.0, 360.0, 50_000)
    tracemalloc.start()
    model.correct(angles)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    chunk = min(CHUNK_ANGLES, CHUNK_NUMBERS // width)
    # the result, its wrap and the chunk's radians and corrections (a few arrays of 8 bytes per angle)
    # and the chunk's temporaries, 8 bytes per number
    assert peak <= 4 * 8 * angles.size + 8 * width * chunk + 8 * 6 * chunk


def test_a_chain_that_misses_an_order_or_uses_an_unmade_power_is_refused():
    with pytest.raises(ValueError, match="does not reach the orders \\[5\\]"):
        HarmonicSeries(np.array([1, 4, 5]), np.ones(3), np.ones(3), method="recurrence",
                       chain=[(2, 1, 1), (4, 2, 2)])
    with pytest.raises(ValueError, match="both powers made before it"):
        HarmonicSeries(np.array([4]), np.ones(1), np.ones(1), method="recurrence", chain=[(4, 2, 2)])
    with pytest.raises(ValueError, match="routes must be 'difference' or 'squaring'; got 'fast'"):
        plan_products([5], routes=("fast",))
    with pytest.raises(ValueError, match="method must be"):
        HarmonicSeries(np.array([4]), np.ones(1), np.ones(1), method="fast")

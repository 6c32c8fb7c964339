"""The trigonometric moments of many angles against their direct sums."""

import numpy as np
import pytest

from encal.numerics import trigsums
from encal.numerics.trigsums import trig_moments


@pytest.mark.parametrize("highest", [32, 400, 700])  # 9, 15 and 14 Taylor terms (the last one term at a time)
@pytest.mark.parametrize("order_of_angles", ["sorted", "random"])
def test_moments_of_many_angles_are_their_direct_sums(highest, order_of_angles):
    rng = np.random.default_rng(2)
    theta = rng.uniform(0.0, 2.0 * np.pi, 40_000)
    if order_of_angles == "sorted":  # a sweep: thousands of consecutive angles in one node of the fine grid
        theta.sort()
    weights = rng.normal(size=theta.size)
    assert trigsums._fine_grid(highest, trigsums._MOMENTS_NODES)[0] == (4096 if highest < 652 else 8192)
    direct = np.exp(1j * np.outer(np.arange(highest + 1), theta)) @ weights
    assert np.abs(trig_moments(theta, weights, highest) - direct).max() <= 1e-13 * np.abs(weights).sum()


def test_a_sweeps_angles_are_binned_by_runs_and_sum_as_they_do_one_by_one():
    rng = np.random.default_rng(4)
    theta = np.repeat(np.sort(rng.uniform(0.0, 2.0 * np.pi, 4000)), 10)  # ten readings at each of 4000 stops
    weights = rng.normal(size=theta.size)
    node = trigsums._nodes(theta[: trigsums._BLOCK_ANGLES], 4096)[0]
    assert trigsums._runs(node) is not None
    direct = np.exp(1j * np.outer(np.arange(33), theta)) @ weights
    assert np.abs(trig_moments(theta, weights, 32) - direct).max() <= 1e-13 * np.abs(weights).sum()

"""``encal._core.arcs``: the arc a set of angles covers (issue 30, dense30: a full turn told without a sort)."""

import numpy as np
import pytest

from encal._core import arcs
from encal._core.angles import wrap360


def _arc_by_sort(angles_deg, max_gap_deg):
    """``arc_of`` as it was: the distinct angles sorted, then their gaps."""
    angles = np.unique(wrap360(np.asarray(angles_deg, dtype=float)))
    if angles.size < 2:
        return None
    gaps = np.diff(np.concatenate([angles, angles[:1] + 360.0]))
    large = np.flatnonzero(gaps > max_gap_deg + 1e-9)
    if large.size != 1:
        return None
    before = int(large[0])
    return float(angles[(before + 1) % angles.size]), float(angles[before])


@pytest.mark.parametrize("case", ["random turn", "sweep", "arc of 300", "gap of 30.5", "gap of 29.9",
                                  "two gaps", "gap across 0", "past a turn", "few"])
@pytest.mark.parametrize("max_gap", [30.0, 7.0])
def test_arc_of_as_by_sort(case, max_gap):
    rng = np.random.default_rng(30)
    turn = rng.uniform(0.0, 360.0, 20_000)
    angles = {"random turn": turn,
              "sweep": np.tile(np.linspace(0.0, 360.0, 5000, endpoint=False), 3),
              "arc of 300": rng.uniform(20.0, 320.0, 20_000),
              "gap of 30.5": np.r_[rng.uniform(100.5, 360.0, 20_000), 100.5, 70.0, rng.uniform(0.0, 70.0, 5000)],
              "gap of 29.9": np.r_[rng.uniform(99.9, 360.0, 20_000), 99.9, 70.0, rng.uniform(0.0, 70.0, 5000)],
              "two gaps": turn[(turn < 100.0) | ((turn > 140.0) & (turn < 250.0)) | (turn > 300.0)],
              "gap across 0": rng.uniform(20.0, 340.0, 20_000) + 180.0,
              "past a turn": turn + 360.0 * rng.integers(-2, 3, turn.size),
              "few": turn[:50]}[case]
    assert arcs.arc_of(angles, max_gap) == _arc_by_sort(angles, max_gap)


def test_a_full_turn_of_dense_angles_is_told_without_a_sort(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("sorted")

    monkeypatch.setattr(arcs.np, "unique", refuse)
    assert arcs.arc_of(np.random.default_rng(1).uniform(0.0, 360.0, 100_000), 30.0) is None


@pytest.mark.parametrize("seed", range(20))
def test_no_gap_over_says_true_only_when_every_gap_is_within_the_bound(seed):
    rng = np.random.default_rng(seed)
    angles = np.mod(rng.uniform(0.0, 360.0, 60) + rng.uniform(0.0, 360.0), 360.0)  # about as sparse as a bin each
    ordered = np.sort(angles)
    largest = float(np.diff(np.r_[ordered, ordered[0] + 360.0]).max())
    if arcs.no_gap_over(angles, 30.0):
        assert largest <= 30.0
    dense = rng.uniform(0.0, 360.0, 5000)
    assert arcs.no_gap_over(dense, 30.0) and not arcs.no_gap_over(dense[dense < 300.0], 30.0)


# -- task arcc6: the codes of an encoder inside a range, as encal tells each code's reading ------------------------

def _codes_by_asking_each(range_deg, bits, reading_sign):
    codes = np.arange(1 << bits)
    held = arcs.inside(wrap360(reading_sign * codes * (360.0 / (1 << bits))), range_deg)
    return codes[held]


@pytest.mark.parametrize("bits", [12, 14])
@pytest.mark.parametrize("reading_sign", [1, -1])
def test_codes_in_range_are_the_codes_whose_readings_are_inside(bits, reading_sign):
    # floor() of the ends took the code just below a start between two codes as inside
    step = 360.0 / (1 << bits)
    rng = np.random.default_rng(6)
    ranges = [[100 * step, 1500 * step], [(100 + 0.3) * step, (1501 + 0.6) * step],  # on codes, between codes
              [4000 * step, 700 * step], [(4000 + 0.3) * step, (700 + 0.6) * step],  # through 0
              [100 * step + 5e-10, 1500 * step - 5e-10], [100 * step - 2e-9, 1500 * step + 2e-9],  # tolerance
              *[sorted(rng.uniform(0.0, 360.0, 2).tolist(), reverse=k % 2 == 1) for k in range(20)]]
    for range_deg in ranges:
        expected = _codes_by_asking_each(range_deg, bits, reading_sign)
        first, last = arcs.codes_in_range(range_deg, bits, reading_sign)
        span = (last - first) % (1 << bits)
        got = np.mod(first + np.arange(span + 1), 1 << bits)
        assert np.array_equal(np.sort(got), expected), range_deg


def test_codes_in_range_of_an_arc_narrower_than_a_code_and_of_a_gap_narrower_than_one():
    step = 360.0 / 4096
    assert arcs.codes_in_range([(114 + 0.2) * step, (114 + 0.7) * step], 12) is None  # between two codes
    assert arcs.codes_in_range([(114 - 0.2) * step, (114 + 0.7) * step], 12) == (114, 114)
    assert arcs.codes_in_range([(114 + 0.7) * step, (114 + 0.2) * step], 12) == (0, 4095)  # a gap between two
    assert arcs.codes_in_range([(114 + 0.7) * step, (114 - 0.2) * step], 12) == (115, 113)

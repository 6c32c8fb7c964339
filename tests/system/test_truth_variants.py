"""Known truth through harmless forms of one calibration (task truth8; ``benchmarks/truth_variants.py``).

The benchmark writes one simulated calibration, whose error profile is known, in about 100 equivalent forms and runs
``encal fit``, ``correct``, ``evaluate`` and ``profile`` on each, then the exports on every code; all of it agreed
when it was written (its table is in BENCHMARKS.md). These tests keep a few forms of each kind, so that a change of
a reader that makes one form read other numbers is seen in the suite: the corrected angles of dense noise-free
readings must be the plain form's (within 1e-5 arcmin) and the truth's (the reference angle of each reading).
"""


import numpy as np
import pytest

from tests._benchmarks import load_benchmark


tv = load_benchmark("truth_variants")
CASES = {case.name: case for case in tv.cases()}
KEPT = {
    "plain": ["rows shuffled", "all at once", "radians (-pi, pi] --unit rad", "encoder counting back, --reverse"],
    "two passes": ["two passes interleaved", "two passes as a 2-turn sweep"],
    "bidirectional": ["bidirectional cw/ccw", "bidirectional shuffled"],
    "14-bit": ["14-bit signed counts (-8192, 8192]", "14-bit radians (-pi, pi], shuffled"],
    # its lookup table moved by 0.27 arcmin before the bins of a dense table took a code a hair below its edge as
    # the edge's (tests/models/test_lut.py)
    "sweep": ["sweep, (-180, 180], radians"],
    "arc": ["arc in (-180, 180]"],
}
FIRSTS = {"plain": "plain", "two passes": "two passes in blocks", "bidirectional": "bidirectional +1/-1",
          "14-bit": "14-bit codes in degrees", "sweep": "sweep of 3 turns, unwrapped",
          "arc": "arc -60 to 60 deg in [0, 360)"}


@pytest.fixture(scope="module")
def firsts(tmp_path_factory):
    folder = tmp_path_factory.mktemp("firsts")
    return {group: tv.outcome(CASES[name], folder) for group, name in FIRSTS.items()}


@pytest.mark.parametrize("name", [name for names in KEPT.values() for name in names])
def test_a_harmless_form_gives_the_plain_forms_numbers_and_the_truth(name, firsts, tmp_path):
    case = CASES[name]
    result = tv.outcome(case, tmp_path)
    assert not isinstance(result, str), result
    ok, rms, largest, same, notes = tv.compare(case, result, firsts[case.group])
    assert ok, (notes, rms, largest, same)
    assert same <= tv.SAME_ARCMIN and rms <= case.truth_rms


def test_shuffled_passes_are_refused_with_the_way_out(tmp_path):
    """Two passes in random order are refused (documented: repeats in a row or in passes), naming
    --keep-duplicates; with it they are read as the passes in blocks."""
    result = tv.outcome(CASES["two passes shuffled"], tmp_path)
    assert isinstance(result, str) and "--keep-duplicates" in result


def test_encal_correct_reads_every_form_of_its_input_as_the_same_angles(tmp_path):
    rows = tv.correct_rows(tmp_path)
    assert len(rows) >= 15 and all(ok for _, _, ok in rows), rows


def test_selfcal_steps_writes_the_same_calibration_from_every_form(tmp_path):
    rows = tv.steps_rows(tmp_path)
    assert all(ok for _, _, ok in rows), rows


def test_the_truth_inverts_the_profile():
    """The harness's own truth: the reference angle it gives a reading reads back as that reading."""
    rows = tv.simulate(1)
    readings = np.linspace(0.0, 360.0, 50, endpoint=False)
    reference = tv.reference_of(readings, rows, 1)
    assert np.max(np.abs(tv.wrap_arcmin(reference + tv.truth_error(reference) / 60.0 - readings))) < 1e-9


def test_selfcal_spin_writes_the_same_calibration_from_every_form_and_the_truth(tmp_path):
    """Unwrapped, wrapped, (-180, 180], radians, counts: the same errors, within 0.1 arcmin RMS of the truth less
    the orders one speed cannot see."""
    rows = tv.spin_rows(tmp_path)
    assert all(ok for _, _, ok in rows), rows


def test_fit_repeat_reads_the_second_pass_in_every_form(tmp_path):
    rows = tv.repeat_rows(tmp_path)
    assert all(ok for _, _, ok in rows), rows

"""Automatic model choice (encal.models.select): folds, tie rule, known-truth choices, records."""

import dataclasses
import json
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import encal
from encal.cli import main
from encal._core.errors import EncalWarning, InputError
from encal.models import select
from encal.models.fourier import fit_fourier
from encal.models.kind import REGISTERED
from encal.models.select import (
    DEFAULT_CANDIDATES,
    Candidate,
    CVScore,
    choose,
    cross_validate,
    cross_validate_stack,
    fit_auto,
    format_selection,
    interleaved_folds,
    stack_weights,
)
from encal.simulate import demo_fleet

GRID = np.arange(0.0, 360.0, 2.0)  # the paper's training grid
#: Fourier and lookup tables only: fast, for the tests of what is recorded rather than what is chosen.
CLOSED_FORM = DEFAULT_CANDIDATES[:4]


def harmonic_profile(theta_deg):
    """A noise-free resolver-like profile: orders 0, 1, 2 and 16, arcmin."""
    r = np.radians(theta_deg)
    return 0.4 + 3.0 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r) + 0.7 * np.sin(16 * r + 1.0)


def narrow_bump(theta_deg, centre=100.0, width=3.0, height=3.0):
    """A local defect: a Gaussian bump of ``height`` arcmin and ``width`` degrees (sigma)."""
    distance = (np.asarray(theta_deg) - centre + 180.0) % 360.0 - 180.0
    return height * np.exp(-0.5 * (distance / width) ** 2)


def per_step_pattern(theta_deg, seed, step=10.0):
    """Linear within each ``step`` of the circle, a random kink (arcmin) at every step boundary."""
    knots = np.arange(0.0, 360.0 + step, step)
    values = np.random.default_rng(seed).normal(size=knots.size)
    values[-1] = values[0]
    return np.interp(theta_deg, knots, values) + 3.0 * np.sin(np.radians(theta_deg))


def score(family, rms, n_parameters, options=None):
    return CVScore(Candidate(family, options or {}), rms, rms, rms, n_parameters, 0.0)


# --------------------------------------------------------------------------- folds


def test_interleaved_folds_deal_points_round_robin_by_angle():
    theta = np.array([350.0, 10.0, 90.0, 30.0, 270.0, 180.0])
    # increasing order 10, 30, 90, 180, 270, 350 -> folds 0, 1, 2, 0, 1, 2
    assert interleaved_folds(theta, 3).tolist() == [2, 0, 2, 1, 1, 0]


@settings(max_examples=50, deadline=None)
@given(n=st.integers(8, 400), folds=st.integers(2, 8), offset=st.floats(0.0, 360.0))
def test_every_fold_is_spread_round_the_circle(n, folds, offset):
    theta = (offset + np.linspace(0.0, 360.0, n, endpoint=False)) % 360.0
    fold = interleaved_folds(theta, folds)
    sizes = np.bincount(fold, minlength=folds)
    assert sizes.max() - sizes.min() <= 1
    # Consecutive held-out points of a fold are exactly `folds` points apart, except across the
    # seam where the dealing restarts (fewer than 2 * folds when n is not a multiple of folds).
    order = np.argsort(theta)
    for k in range(folds):
        position = np.flatnonzero(fold[order] == k)
        assert np.all(np.diff(position) == folds)
        assert position[0] + n - position[-1] < 2 * folds


def test_repeated_readings_of_one_angle_share_a_fold():
    theta = np.r_[GRID, GRID[::3]]
    fold = interleaved_folds(theta, 5)
    assert np.array_equal(fold[GRID.size:], fold[:GRID.size][::3])


def test_every_fold_fit_sees_exactly_the_other_folds(monkeypatch):
    seen = []

    def spy(theta_deg, error_arcmin, **options):
        seen.append(np.sort(theta_deg))
        return encal.models.fourier.FourierModel([0], [float(np.mean(error_arcmin))], [0.0])

    import encal.models.fourier

    monkeypatch.setitem(REGISTERED, "fourier", dataclasses.replace(REGISTERED["fourier"], fit=spy))
    fold = interleaved_folds(GRID, 5)
    seeds = np.random.SeedSequence(0).spawn(5)
    cross_validate(GRID, harmonic_profile(GRID), Candidate("fourier"), fold, seeds=seeds)
    assert len(seen) == 5
    for k, training in enumerate(seen):
        assert np.array_equal(training, GRID[fold != k])


# --------------------------------------------------------------------------- tie rule


def test_the_lowest_cv_rms_wins_outside_the_tolerance():
    chosen, reason = choose([score("fourier", 1.05, 10), score("ann", 1.0, 50)], tolerance=0.01)
    assert chosen.candidate.family == "ann"
    assert "lowest CV RMS" in reason


def test_the_simplest_family_wins_within_the_tolerance():
    scores = [score("ann", 1.0, 25), score("lut", 1.008, 180), score("fourier", 1.009, 20),
              score("hybrid", 1.0, 40)]
    chosen, reason = choose(scores, tolerance=0.01)
    assert chosen.candidate.family == "fourier"
    assert "simpler" in reason and "within 1%" in reason


def test_within_a_family_fewer_parameters_win_a_tie():
    chosen, _ = choose([score("fourier", 1.0, 40), score("fourier", 1.005, 12)], tolerance=0.01)
    assert chosen.n_parameters == 12


def test_failed_candidates_are_skipped_and_all_failing_is_an_error():
    failed = CVScore(Candidate("ann"), np.inf, np.inf, np.inf, np.inf, 0.0, error="no")
    assert choose([failed, score("lut", 2.0, 180)])[0].candidate.family == "lut"
    with pytest.raises(InputError, match="no candidate model could be fitted"):
        choose([failed])


# --------------------------------------------------------------------------- known truth


def test_noise_free_fourier_profile_picks_fourier_and_recovers_it():
    model = fit_auto(GRID, harmonic_profile(GRID), rng=0)
    assert model.kind == "fourier"
    dense = np.linspace(0.0, 360.0, 1441)
    np.testing.assert_allclose(model.predict(dense), harmonic_profile(dense), rtol=0, atol=1e-10)
    assert sorted(model.orders.tolist()) == [0, 1, 2, 16]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_narrow_local_defect_is_not_left_to_a_low_order_fourier_series(seed):
    truth = lambda t: harmonic_profile(t) + narrow_bump(t)  # noqa: E731
    noisy = truth(GRID) + 0.05 * np.random.default_rng(seed).normal(size=GRID.size)
    model = fit_auto(GRID, noisy, rng=seed)
    assert not (model.kind == "fourier" and model.orders.max() <= 16)
    near_defect = np.arange(85.0, 115.0, 0.25)
    # A low-order series misses the 3-arcmin bump by about 1 arcmin; the chosen model follows it.
    assert np.max(np.abs(model.predict(near_defect) - truth(near_defect))) < 0.3
    fourier_top10 = encal.models.fourier.fit_fourier(GRID, noisy, n_orders=10)
    assert np.max(np.abs(fourier_top10.predict(near_defect) - truth(near_defect))) > 0.6


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_piecewise_linear_per_step_pattern_picks_the_lookup_table(seed):
    theta = np.arange(0.0, 360.0, 1.0)
    model = fit_auto(theta, per_step_pattern(theta, seed), rng=seed)
    assert model.kind == "lut"


def stepped_profile(seed, sigma=0.05):
    """Readings within 0.02° of a stepper's 200 full steps: orders 1, 2, 16, a ±2-arcmin
    alternation (-1)^k from step to step, and white noise. Returns (angles, errors, truth at the steps)."""
    rng = np.random.default_rng(seed)
    steps = np.arange(200) * 1.8
    r = np.radians(steps)
    truth = 3.0 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r) + 0.7 * np.sin(16 * r) + 2.0 * (-1.0) ** np.arange(200)
    return steps + rng.normal(0.0, 0.02, 200), truth + rng.normal(0.0, sigma, 200), truth


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_per_step_alternation_is_cross_validated_at_the_grid_nyquist_order(seed):
    # Each fold's training part misses every fifth step; the Fourier candidates are told the
    # calibration's 200-step grid, so they may fit order 100 and predict the held-out steps'
    # alternation. Measured over seeds 0-5: CV RMS of the chosen (Fourier) candidate 1.07-1.38
    # times the noise (0.05), its error at the steps 0.024-0.030 arcmin; bounds 1.5x and 0.04.
    theta, observed, truth = stepped_profile(seed)
    model = fit_auto(theta, observed, rng=seed, use_grid=True)
    selection = model.training["selection"]
    table = {row["label"]: row["cv_rms_arcmin"] for row in selection["table"]}
    assert model.kind == "fourier" and 100 in model.orders.tolist()
    assert table[selection["chosen"]] < 1.5 * 0.05
    assert min(table[label] for label in table if not label.startswith("fourier")) > 1.0  # none sees it
    assert np.sqrt(np.mean((model.predict(np.arange(200) * 1.8) - truth) ** 2)) < 0.04


def test_the_even_steps_of_a_stepped_calibration_are_a_grid_of_their_own():
    # 100 rows at 3.6°: the fold fits may go up to order 50 (the alternation is an offset there).
    theta, observed, _ = stepped_profile(3)
    model = fit_auto(theta[::2], observed[::2], rng=0, candidates=CLOSED_FORM[:2], use_grid=True)
    assert model.kind == "fourier" and model.orders.max() <= 50 and 0 in model.orders.tolist()


def test_fold_fits_are_told_the_grid_only_for_a_calibration_on_one(monkeypatch):
    told = []

    def spy(theta_deg, error_arcmin, **options):
        told.append(options.get("grid_points"))
        return encal.models.fourier.FourierModel([0], [float(np.mean(error_arcmin))], [0.0])

    import encal.models.fourier

    monkeypatch.setitem(REGISTERED, "fourier", dataclasses.replace(REGISTERED["fourier"], fit=spy))
    irregular = np.sort(np.random.default_rng(0).uniform(0.0, 360.0, 180))
    fit_auto(GRID, harmonic_profile(GRID), candidates=[Candidate("fourier")], use_grid=True)
    with pytest.warns(EncalWarning, match=r"use_grid \(--at-steps\) has no effect: the 180 encoder angles do not "
                                          "lie on a uniform grid"):
        fit_auto(irregular, harmonic_profile(irregular), candidates=[Candidate("fourier")], use_grid=True)
    fit_auto(GRID, harmonic_profile(GRID), candidates=[Candidate("fourier")], use_grid=False)
    assert told == [180] * 5 + [None] + [None] * 12  # 5 folds and the refit, three times


def test_by_default_the_alternation_is_not_validated_at_the_steps():
    # Readings between the steps are the default use: the folds keep the limit of their gaps
    # (order 49), so no Fourier fold fit predicts the alternation and the smooth fit is kept.
    theta, observed, _ = stepped_profile(0)
    model = fit_auto(theta, observed, rng=0, candidates=CLOSED_FORM[:2])
    table = {row["label"]: row["cv_rms_arcmin"] for row in model.training["selection"]["table"]}
    assert table["fourier select=cv"] > 1.5  # the ±2-arcmin alternation is in every residual
    assert "use_grid" not in model.training["fit_options"]


def test_same_seed_gives_the_same_choice_and_predictions():
    noisy = harmonic_profile(GRID) + narrow_bump(GRID) + 0.05 * np.random.default_rng(5).normal(size=GRID.size)
    candidates = [c for c in DEFAULT_CANDIDATES if c.family in ("fourier", "hybrid")] + [
        Candidate("ann", {"hidden": 6, "epochs": 100})]
    first, second = (fit_auto(GRID, noisy, rng=7, candidates=candidates) for _ in range(2))
    assert first.training["selection"]["chosen"] == second.training["selection"]["chosen"]
    dense = np.linspace(0.0, 360.0, 721)
    assert np.array_equal(first.predict(dense), second.predict(dense))
    strip = lambda table: [{k: v for k, v in row.items() if k != "time_s"} for row in table]  # noqa: E731
    assert strip(first.training["selection"]["table"]) == strip(second.training["selection"]["table"])


def test_a_generator_is_accepted_as_rng():
    model = fit_auto(GRID, harmonic_profile(GRID), rng=np.random.default_rng(3),
                     candidates=[Candidate("fourier", {"select": "cv"}), Candidate("ann", {"hidden": 3, "epochs": 5})])
    assert model.kind == "fourier"
    assert model.training["seed"] is None


@pytest.mark.parametrize("rng", [-1, True, 1.5, "0"])
def test_an_invalid_rng_is_refused_in_one_sentence(rng):
    with pytest.raises(InputError, match=rf"^The 'rng' parameter of fit_auto must be None, an int >= 0 or a "
                                         rf"numpy.random.Generator. "
                                         rf"Got {re.escape(repr(rng))} instead.$"):
        fit_auto(GRID, harmonic_profile(GRID), rng=rng, candidates=CLOSED_FORM)


# --------------------------------------------------------------------------- records


def test_the_cv_table_and_reason_are_recorded():
    candidates = CLOSED_FORM
    model = fit_auto(GRID, harmonic_profile(GRID), rng=0, candidates=candidates)
    selection = model.training["selection"]
    assert selection["folds"] == 5
    singles = [row for row in selection["table"] if row["family"] != "stack"]
    assert [row["label"] for row in singles] == [c.label for c in candidates]
    for row in selection["table"]:
        assert set(row) >= {"family", "options", "label", "cv_rms_arcmin", "cv_mae_arcmin", "n_parameters",
                            "time_s"}
        assert row["cv_mae_arcmin"] <= row["cv_rms_arcmin"]
    assert selection["chosen"] in selection["reason"]
    json.dumps(selection)  # JSON data only


def test_a_candidate_that_cannot_be_fitted_is_reported_not_fatal():
    bad = Candidate("fourier", {"n_orders": 0})
    model = fit_auto(GRID, harmonic_profile(GRID), rng=0, candidates=[bad, Candidate("lut")])
    assert model.kind == "lut"
    row = model.training["selection"]["table"][0]
    assert row["cv_rms_arcmin"] is None and "n_orders" in row["error"]


def test_candidates_may_be_given_as_dicts_and_are_recorded_as_such():
    cubic_table = {"family": "lut", "options": {"interpolation": "cubic"}}
    model = fit_auto(GRID, harmonic_profile(GRID), candidates=[cubic_table])
    assert model.kind == "lut" and model.interpolation == "cubic"
    assert model.training["fit_options"]["candidates"] == [cubic_table]


def test_fit_with_method_auto_records_the_method_and_seed():
    cal = encal.Calibration(GRID, GRID + harmonic_profile(GRID) / 60.0, name="enc")
    model = encal.fit(cal, method="auto", rng=4, candidates=CLOSED_FORM)
    assert model.training["method"] == "auto"
    assert model.training["seed"] == 4
    assert model.training["selection"]["chosen"]


def test_the_cv_table_survives_save_and_load(tmp_path):
    cal = encal.Calibration(GRID, GRID + harmonic_profile(GRID) / 60.0, name="enc")
    model = encal.fit(cal, method="auto", rng=0, candidates=CLOSED_FORM)
    loaded = encal.load_model(model.save(tmp_path / "m.json"))
    assert loaded.training["selection"] == json.loads(json.dumps(model.training["selection"]))
    assert format_selection(loaded.training["selection"]) == format_selection(model.training["selection"])


def test_encal_fit_prints_the_table_and_the_reason(tmp_path, capsys):
    path = tmp_path / "cal.csv"
    rows = [f"{r!r},{r + e / 60.0!r}" for r, e in zip(GRID.tolist(), harmonic_profile(GRID).tolist())]
    path.write_text("reference_deg,encoder_deg\n" + "\n".join(rows) + "\n", encoding="utf-8")
    assert main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--seed", "0", "--folds", "5"]) == 0
    out = capsys.readouterr().out
    assert "cross-validation over 5 interleaved folds" in out
    assert "* fourier" in out and "chosen: fourier" in out


# --------------------------------------------------------------------------- bad options


@pytest.mark.parametrize("folds", [1, 46, 2.5, True])
def test_folds_out_of_range_is_refused(folds):
    with pytest.raises(InputError, match="'folds' parameter of fit_auto must be an int from 2 to 45"):
        fit_auto(GRID, harmonic_profile(GRID), folds=folds)


@pytest.mark.parametrize("candidates", [[], ["fourier"], [{"family": "lut", "interpolation": "linear"}]])
def test_candidates_must_be_candidate_objects(candidates):
    with pytest.raises(InputError, match="'candidates' parameter of fit_auto"):
        fit_auto(GRID, harmonic_profile(GRID), candidates=candidates)


def test_unknown_family_and_bad_tolerance_are_refused():
    with pytest.raises(InputError, match="family must be one of fourier, lut, hybrid, ann, stack. Got 'spline'"):
        fit_auto(GRID, harmonic_profile(GRID), candidates=[Candidate("spline")])
    with pytest.raises(InputError, match="'tolerance' parameter"):
        fit_auto(GRID, harmonic_profile(GRID), tolerance=1.5)


# --------------------------------------------------------------------------- stacking


def test_stack_weights_recover_a_convex_combination():
    rng = np.random.default_rng(0)
    predictions = rng.normal(size=(3, 200))
    weights = stack_weights(predictions, 0.2 * predictions[0] + 0.5 * predictions[1] + 0.3 * predictions[2])
    np.testing.assert_allclose(weights, [0.2, 0.5, 0.3], rtol=0, atol=1e-9)


def test_stack_weights_stay_in_the_simplex():
    a, b = np.random.default_rng(1).normal(size=(2, 100))
    # 1.5 a - 0.5 b is outside the convex hull of a and b: the nearest convex combination is a alone.
    np.testing.assert_allclose(stack_weights(np.array([a, b]), 1.5 * a - 0.5 * b), [1.0, 0.0], atol=1e-9)


def test_stack_weights_drop_small_shares_and_keep_at_most_three_members():
    rng = np.random.default_rng(2)
    predictions = rng.normal(size=(4, 500))
    target = np.array([0.97, 0.03, 0.0, 0.0]) @ predictions
    np.testing.assert_allclose(stack_weights(predictions, target), [1.0, 0.0, 0.0, 0.0], atol=1e-9)
    weights = stack_weights(predictions, 0.25 * predictions.sum(axis=0))
    assert np.count_nonzero(weights) == 3
    assert weights.sum() == pytest.approx(1.0, abs=1e-12) and np.all(weights[weights > 0] >= select.STACK_MIN_WEIGHT)


def test_readings_at_one_angle_cannot_be_cross_validated():
    with pytest.raises(InputError, match=r"^fit_auto expects at least 2 distinct encoder angles to cross-validate; "
                                         r"got 20 readings all at 45 degrees$"):
        fit_auto(np.full(20, 45.0), np.linspace(0.5, 0.6, 20), rng=0)
    with pytest.raises(InputError, match=r"^cross-validation expects at least 2 distinct encoder angles; "
                                         r"got 20 readings all at 45 degrees$"):
        fit_fourier(np.full(20, 45.0), np.linspace(0.5, 0.6, 20), select="cv")


def test_stack_weights_of_an_all_zero_profile_are_one_member():
    weights = stack_weights(np.zeros((3, 10)), np.zeros(10))
    assert weights.tolist() == [1.0, 0.0, 0.0]


@pytest.mark.parametrize("constant", [0.0, 30.0])
def test_auto_on_few_points_of_a_constant_profile_is_that_constant(constant):
    theta = np.arange(8) * 45.0
    model = fit_auto(theta, np.full(8, constant), rng=0)
    np.testing.assert_allclose(model.predict(np.linspace(0.0, 360.0, 3601)), constant, rtol=0, atol=1e-12)


def test_the_stack_of_two_independent_errors_halves_their_variance_in_cross_validation():
    n = 4000
    theta = np.arange(n) * 360.0 / n
    error = np.zeros(n)
    first, second = np.random.default_rng(3).normal(size=(2, n))
    scores = [CVScore(Candidate("fourier"), 1.0, 1.0, 1.0, 3, 0.0, predictions=first),
              CVScore(Candidate("lut"), 1.0, 1.0, 1.0, 3, 0.0, predictions=second)]
    stacked = cross_validate_stack(error, scores, interleaved_folds(theta, 5))
    assert stacked.candidate.family == "stack"
    np.testing.assert_allclose(stacked.candidate.options["weights"], [0.5, 0.5], atol=0.03)
    # Each weight's standard error is about 0.006 with 4000 points; the RMS of the mean is 1/sqrt(2).
    assert stacked.rms_arcmin == pytest.approx(np.sqrt(np.mean(((first + second) / 2) ** 2)), rel=0.01)
    assert stacked.rms_arcmin == pytest.approx(1 / np.sqrt(2), rel=0.05)
    assert stacked.candidate.label.startswith("stack 0.5")


def test_one_candidate_that_explains_everything_is_not_stacked():
    error = np.sin(np.radians(GRID))
    scores = [CVScore(Candidate("fourier"), 0.0, 0.0, 0.0, 3, 0.0, predictions=error.copy()),
              CVScore(Candidate("lut"), 1.0, 1.0, 1.0, 3, 0.0, predictions=np.zeros_like(error))]
    assert cross_validate_stack(error, scores, interleaved_folds(GRID, 5)) is None


@pytest.fixture(scope="module")
def resolver():
    """The second demo encoder: its training run (0:2:358 degrees) and its test run (1:2:359)."""
    encoder = demo_fleet(2)[1]
    return encoder.train.calibration, encoder.test.calibration


def test_on_a_simulated_resolver_auto_stacks_a_series_and_a_table_and_beats_both(resolver):
    train, test = resolver
    candidates = CLOSED_FORM
    model = fit_auto(train.encoder_deg, train.errors_arcmin, rng=0, candidates=candidates)
    assert model.kind == "stack"
    assert {member.kind for member in model.members} == {"fourier", "lut"}
    single = [encal.evaluate(c.fit(train.encoder_deg, train.errors_arcmin), test).after.rms for c in candidates]
    stacked = encal.evaluate(model, test).after.rms
    # Measured: 0.1582 arcmin against 0.1728 (fourier cv) and 0.1788 (cubic table) on this test run.
    assert stacked < 0.95 * min(single)
    # The final stack is its members, each refitted on all points, in the chosen proportions.
    options = model.training["options"]
    members = [Candidate(**m).fit(train.encoder_deg, train.errors_arcmin) for m in options["members"]]
    dense = np.linspace(0.0, 360.0, 1441)
    expected = sum(w * m.predict(dense) for w, m in zip(options["weights"], members))
    np.testing.assert_allclose(model.predict(dense), expected, rtol=0, atol=1e-12)
    selection = model.training["selection"]
    assert selection["chosen"].startswith("stack ") and selection["table"][-1]["label"] == selection["chosen"]


def test_without_stacking_auto_chooses_one_family(resolver):
    train, _ = resolver
    model = fit_auto(train.encoder_deg, train.errors_arcmin, rng=0, candidates=CLOSED_FORM, stack=False)
    assert model.kind in {"fourier", "lut"}
    assert all(row["family"] != "stack" for row in model.training["selection"]["table"])
    assert model.training["fit_options"]["stack"] is False
    with pytest.raises(InputError, match="'stack' parameter of fit_auto must be True or False"):
        fit_auto(train.encoder_deg, train.errors_arcmin, stack="no")


def test_a_stacked_auto_model_survives_save_load_and_gets_an_uncertainty(resolver, tmp_path):
    train, test = resolver
    model = encal.fit(train, rng=0, candidates=CLOSED_FORM, uncertainty=True)
    assert model.kind == "stack"
    loaded = encal.load_model(model.save(tmp_path / "m.json"))
    dense = np.linspace(0.0, 360.0, 721)
    assert np.array_equal(loaded.predict(dense), model.predict(dense))
    residual = encal.evaluate(loaded, test).residual_arcmin
    _, std = loaded.predict(test.encoder_deg, return_std=True)
    # The +-2 sigma band should hold about 95 % of the test residuals; 90 test points.
    assert np.mean(np.abs(residual) <= 2 * std) >= 0.9


def test_encal_fit_no_stack_applies_to_auto_only(tmp_path, capsys):
    path = tmp_path / "cal.csv"
    rows = [f"{r!r},{r + e / 60.0!r}" for r, e in zip(GRID.tolist(), harmonic_profile(GRID).tolist())]
    path.write_text("reference_deg,encoder_deg\n" + "\n".join(rows) + "\n", encoding="utf-8")
    assert main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--no-stack", "--seed", "0"]) == 0
    out = capsys.readouterr().out
    assert "cross-validation over" in out and " stack 0." not in out
    with pytest.raises(SystemExit) as info:  # a usage error
        main(["fit", str(path), "-o", str(tmp_path / "m.json"), "--no-stack", "--method", "fourier"])
    assert info.value.code == 2
    assert "--no-stack applies to --method auto, not fourier" in capsys.readouterr().err


def test_the_printed_table_names_a_stack_briefly_and_lists_its_members(resolver):
    train, _ = resolver
    model = fit_auto(train.encoder_deg, train.errors_arcmin, rng=0, candidates=CLOSED_FORM)
    text = format_selection(model.training["selection"])
    weights = model.training["options"]["weights"]
    members = model.training["options"]["members"]
    assert f"  * stack of {len(members)} (below)" in text
    listed = " + ".join(f"{w:.2f} x ({Candidate(**m).label})" for w, m in zip(weights, members))
    assert f"stack of {len(members)}: {listed}" in text
    assert f"chosen: the stack of {len(members)} has the lowest CV RMS" in text


def test_a_candidates_label_shows_a_float_option_to_four_digits():
    # the spectral reference of auto --networks carries the fitted noise, printed in the table
    assert Candidate("spectral", {"noise_arcmin": 0.17180339817719387}).label == "spectral noise_arcmin=0.1718"
    assert Candidate("ann", {"hidden": 12, "algorithm": "trainlm"}).label == "ann hidden=12 algorithm=trainlm"

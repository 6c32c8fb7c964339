"""The paper's studies (encal.paper.studies): sweep, algorithm table, SVD pruning, comparison, reproducibility,
tables."""

import csv
import io
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

from encal import Calibration, error_stats
from encal._core.angles import lsb_arcmin
from encal._core.errors import InputError, TrainingLimitWarning
from encal.models.ann import ANNModel
from encal.paper.studies import (
    DEFAULT_MODELS,
    compare_algorithms,
    compare_models,
    hidden_node_sweep,
    reproducibility,
    significant_count,
    svd_pruning,
)
from encal.paper.studies._fits import hidden_layer, task_seed
from encal._core.pool import Workers, run_tasks
from encal.paper.studies.reproducibility import matched_difference
from encal.paper.studies.tables import Column, Table, profile_table
from encal._core.progress import Progress

TRAIN_GRID = np.arange(0.0, 360.0, 2.0)
TEST_GRID = np.arange(1.0, 360.0, 2.0)


def harmonic_error(theta_deg):
    """A resolver-like profile in arcmin: orders 0, 1, 2 and 16."""
    t = np.radians(theta_deg)
    return 0.4 + 1.5 * np.sin(t + 0.3) + 0.6 * np.cos(2 * t) + 0.4 * np.sin(16 * t)


def calibration(grid, noise_arcmin=0.0, seed=0, name="enc"):
    """A calibration whose encoder angles are exactly ``grid`` and whose error is the harmonic profile."""
    error = harmonic_error(grid) + np.random.default_rng(seed).normal(0.0, noise_arcmin, grid.size)
    return Calibration(grid - error / 60.0, grid, name=name, resolution_bits=16)


@pytest.fixture(scope="module")
def train():
    return calibration(TRAIN_GRID, noise_arcmin=0.05, seed=1)


@pytest.fixture(scope="module")
def test():
    return calibration(TEST_GRID, noise_arcmin=0.05, seed=2)


# --------------------------------------------------------------------------- seeds and workers


def test_task_seed_depends_on_what_the_fit_is():
    assert task_seed(0, 80, 1) == task_seed(0, 80, 1)
    assert len({task_seed(0, 80, k) for k in range(20)}) == 20
    assert task_seed(0, 80, 0) != task_seed(1, 80, 0)


def _negate(x):
    return -x


def test_run_tasks_keeps_task_order_in_this_process():
    assert run_tasks(_negate, [3, 1, 2], workers=0) == [-3, -1, -2]
    with Workers(0) as workers:
        assert workers.executor() is None
        assert run_tasks(_negate, [], workers=workers) == []


@pytest.mark.parametrize("bad", [-1, 1.5, "2", True])
def test_workers_must_be_a_count(bad):
    with pytest.raises(InputError) as info:
        Workers(bad)
    assert str(info.value) == ("The 'workers' parameter of Workers must be an int from 0 to 64 (worker processes: "
                               f"each is a Python interpreter; the studies' fits are small). Got {bad!r} instead.")


def test_progress_prints_one_line_when_not_a_terminal():
    out = io.StringIO()
    with Progress(2, "fits", stream=out) as bar:
        bar.advance()
        bar.advance()
    assert out.getvalue().count("\n") == 1
    assert out.getvalue().startswith("fits: 2/2 done in ")


def test_progress_redraws_in_place_on_a_terminal():
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    out = Terminal()
    with Progress(4, "fits", stream=out) as bar:
        for _ in range(4):
            bar.advance()
    text = out.getvalue()
    assert text.count("\r") == 6  # the empty bar, four advances, the final line
    assert text.endswith("\n") and " 4/4 " in text.rsplit("\r", 1)[1]


def test_progress_disabled_prints_nothing():
    out = io.StringIO()
    with Progress(3, "fits", stream=out, enabled=False) as bar:
        bar.advance(3)
    assert out.getvalue() == ""


# --------------------------------------------------------------------------- sweep


def test_sweep_records_every_fit_and_the_curves(train, test):
    sweep = hidden_node_sweep(train, test, hidden=(4, 8), algorithms=("trainlm", "traingd"), epochs=6, seeds=2,
                              curve_hidden=8, workers=0)
    assert sweep.hidden.tolist() == [4, 8] and sweep.n_seeds == 2
    for algorithm in ("trainlm", "traingd"):
        assert sweep.mse_arcmin2[algorithm].shape == (2, 2)
        assert np.all(sweep.mse_arcmin2[algorithm] > 0)
        assert np.all(sweep.epochs_run[algorithm] <= 6)
        assert sweep.test_mse_arcmin2[algorithm].shape == (2, 2)
        for k in range(2):
            curve = sweep.curves_arcmin2[algorithm][k]
            assert curve.size == sweep.epochs_run[algorithm][1, k] + 1
            # The curve is in the same unit as the final MSE: its last point is the final training MSE.
            assert_allclose(curve[-1], sweep.mse_arcmin2[algorithm][1, k], rtol=1e-9)
            assert_allclose(sweep.test_curves_arcmin2[algorithm][k][-1], sweep.test_mse_arcmin2[algorithm][1, k],
                            rtol=1e-9)
    # Both algorithms start every (N, seed) from the same weights: the same initial MSE.
    assert_allclose(sweep.curves_arcmin2["trainlm"][0][0], sweep.curves_arcmin2["traingd"][0][0], rtol=1e-12)
    assert "Fig. 2a" in sweep.table().title


def test_measuring_the_test_points_does_not_change_the_networks(train, test):
    kwargs = {"hidden": (6,), "algorithms": ("trainlm",), "epochs": 30, "curve_hidden": 6, "workers": 0}
    blind, watched = hidden_node_sweep(train, **kwargs), hidden_node_sweep(train, test, **kwargs)
    assert_array_equal(blind.mse_arcmin2["trainlm"], watched.mse_arcmin2["trainlm"])
    assert_array_equal(blind.curves_arcmin2["trainlm"][0], watched.curves_arcmin2["trainlm"][0])


def test_sweep_is_reproducible(train):
    a = hidden_node_sweep(train, hidden=(4,), algorithms=("trainlm",), epochs=5, seeds=2, curve_hidden=None,
                          workers=0)
    b = hidden_node_sweep(train, hidden=(4,), algorithms=("trainlm",), epochs=5, seeds=2, curve_hidden=None,
                          workers=0)
    assert_array_equal(a.mse_arcmin2["trainlm"], b.mse_arcmin2["trainlm"])
    assert a.curves_arcmin2 == {}


def test_sweep_gives_the_same_numbers_on_one_or_two_worker_processes(train):
    runs = [hidden_node_sweep(train, hidden=(3, 6), algorithms=("trainlm", "trainrp"), epochs=20, seeds=2,
                              curve_hidden=6, workers=workers) for workers in (1, 2)]
    for algorithm in ("trainlm", "trainrp"):
        assert_array_equal(runs[0].mse_arcmin2[algorithm], runs[1].mse_arcmin2[algorithm])
        assert_array_equal(runs[0].curves_arcmin2[algorithm][1], runs[1].curves_arcmin2[algorithm][1])


LIMIT = {"hidden": "hidden nodes: a 1:N:1 network trains with a (3N+1)-square matrix every epoch and its C export "
                   "checks it on 65,536 angles (N = 100,000 needed 48.8 GiB); the paper's sweep ends at 110",
         "epochs": "epochs: a million is hours of training for a network, far past where any stops",
         "seeds": "seeds: each is one more training of every network of the study"}


@pytest.mark.parametrize("options, message", [
    ({"hidden": ()}, "The 'hidden' parameter of hidden_node_sweep must be a non-empty sequence of ints from 1 to "
                     "1000. Got () instead."),
    ({"hidden": (0, 10)}, "The 'hidden' parameter of hidden_node_sweep must be a non-empty sequence of ints from "
                          "1 to 1000. Got (0, 10) instead."),
    ({"seeds": 0}, f"The 'seeds' parameter of hidden_node_sweep must be an int from 1 to 1000 ({LIMIT['seeds']}). "
                   "Got 0 instead."),
    ({"epochs": 0}, f"The 'epochs' parameter of hidden_node_sweep must be an int from 1 to 1000000 "
                    f"({LIMIT['epochs']}). Got 0 instead."),
    ({"epochs": {"trainrp": 3}}, f"The 'epochs[trainlm]' parameter of hidden_node_sweep must be an int from 1 to "
                                 f"1000000 ({LIMIT['epochs']}). Got None instead."),
    ({"curve_hidden": 50}, "The 'curve_hidden' parameter of hidden_node_sweep must be one of 4, None. "
                           "Got 50 instead."),
    ({"rng": -1}, "The 'rng' parameter of hidden_node_sweep must be an int >= 0 (the study's seed). "
                  "Got -1 instead."),
    ({"algorithms": ("trainlx",)}, "The 'algorithms' parameter of hidden_node_sweep must be one of 'trainbfg', "
                                   "'trainbr', 'traincgf', 'traincgp', 'traingd', 'traingdx', 'trainlm', 'trainoss', "
                                   "'trainrp', 'trainscg'. Got 'trainlx' instead."),
    ({"encoding": "sincos"}, "The 'encoding' parameter of hidden_node_sweep must be one of 'periodic', 'raw'. "
                             "Got 'sincos' instead."),
])
def test_sweep_refuses_bad_options(train, options, message):
    kwargs = {"hidden": (4,), "algorithms": ("trainlm",), "epochs": 2, "curve_hidden": 4, "workers": 0,
              **options}
    with pytest.raises(InputError) as info:
        hidden_node_sweep(train, **kwargs)
    assert str(info.value) == message


def test_sweep_refuses_what_is_not_a_calibration():
    with pytest.raises(InputError) as info:
        hidden_node_sweep(np.zeros(10), workers=0)
    assert str(info.value) == ("The 'cal' parameter of hidden_node_sweep must be a Calibration. "
                               "Got an object of type ndarray instead.")


def test_sweep_statistics_over_seeds():
    from encal.paper.studies import SweepResult

    mse = np.array([[1.0], [0.1], [0.011], [0.01]])
    sweep = SweepResult(encoder="enc", hidden=np.array([10, 20, 30, 40]), algorithms=("trainlm",), encoding="raw",
                        seeds=np.zeros((4, 1), dtype=int), epochs={"trainlm": 1}, mse_arcmin2={"trainlm": mse},
                        epochs_run={}, time_s={}, cpu_s={}, curve_hidden=None, curves_arcmin2={})
    assert_allclose(sweep.mse_mean("trainlm"), mse[:, 0])
    assert_allclose(sweep.mse_std("trainlm"), 0.0)
    assert sweep.test_mse_median("trainlm") is None


# --------------------------------------------------------------------------- algorithm table


def test_algorithm_table_fits_every_algorithm_from_the_same_weights(train, test):
    study = compare_algorithms(train, test, algorithms=("trainlm", "trainrp", "traingd"), hidden=6, epochs=8,
                               seeds=3, workers=0)
    assert [row.algorithm for row in study.rows] == ["trainlm", "trainrp", "traingd"]
    assert study.n_seeds == 3 and study.epochs == 8
    first_mse = {row.algorithm: row.curve_arcmin2[0] for row in study.rows}
    assert_allclose(first_mse["trainlm"], first_mse["trainrp"], rtol=1e-12)
    for row in study.rows:
        assert row.mse_arcmin2.shape == (3,) and row.test_rms_arcmin.shape == (3,)
        assert row.mse_min <= row.mse_mean <= row.mse_max
        assert np.all(row.epochs <= 8)
    assert study.row("trainlm").paper_name == "Levenberg-Marquardt"
    assert study.row("traingd").paper_name is None
    assert sorted(study.ranking()) == ["traingd", "trainlm", "trainrp"]
    text = study.table().to_text()
    assert "0.0083" in text and "Levenberg-Marquardt" in text


def test_the_papers_fixed_epoch_studies_train_without_a_limit_warning(train):
    # The sweep, Table 2 and the pruning study run a budget of epochs on purpose: the fits below stop on it
    # while still improving, which without epochs= would be warned about (TrainingLimitWarning).
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sweep = hidden_node_sweep(train, hidden=(4,), algorithms=("traingd",), epochs=20, curve_hidden=4,
                                  workers=0)
        study = compare_algorithms(train, algorithms=("traingd", "trainrp"), hidden=4, epochs=20, seeds=1,
                                   workers=0)
        pruning = svd_pruning(train, hidden=6, epochs=20)
    assert [str(w.message) for w in caught if issubclass(w.category, TrainingLimitWarning)] == []
    assert sweep.epochs_run["traingd"].tolist() == [[20]]
    assert all(row.epochs.tolist() == [20] for row in study.rows)
    assert pruning.pruned_model.training["epochs"] <= 20


@pytest.mark.parametrize("options, message", [
    ({"epochs": {"trainlm": 5, "trainrp": 9}}, "The 'epochs' parameter of compare_algorithms must be one int >= 1, "
                                               "the same budget for every algorithm. Got a dict instead."),
    ({"hidden": 0}, f"The 'hidden' parameter of compare_algorithms must be an int from 1 to 1000 "
                    f"({LIMIT['hidden']}). Got 0 instead."),
    ({"seeds": 2000}, f"The 'seeds' parameter of compare_algorithms must be an int from 1 to 1000 "
                      f"({LIMIT['seeds']}). Got 2000 instead."),
    ({"algorithms": ()}, "The 'algorithms' parameter of compare_algorithms must be a non-empty sequence of "
                         "training algorithms. Got () instead."),
    ({"progress": "yes"}, "The 'progress' parameter of compare_algorithms must be True or False. "
                          "Got 'yes' instead."),
])
def test_algorithm_table_refuses_bad_options(train, options, message):
    kwargs = {"algorithms": ("trainlm", "trainrp"), "hidden": 4, "epochs": 2, "seeds": 1, "workers": 0, **options}
    with pytest.raises(InputError) as info:
        compare_algorithms(train, **kwargs)
    assert str(info.value) == message


# --------------------------------------------------------------------------- SVD pruning


def _raw_network(hidden, seed):
    rng = np.random.default_rng(seed)
    return ANNModel(rng.normal(0, 20, (hidden, 1)), rng.normal(0, 5, hidden), rng.normal(0, 1, hidden), 0.1,
                    encoding="raw", activation="tansig", input_offset=[0.0], input_gain=[2 / 358],
                    target_offset=-2.0, target_gain=0.5)


@settings(max_examples=25, deadline=None)
@given(hidden=st.integers(3, 40), seed=st.integers(0, 2**32 - 1))
def test_the_papers_matrix_before_the_sigmoid_has_rank_two(hidden, seed):
    before, after = hidden_layer(_raw_network(hidden, seed), TRAIN_GRID)
    assert before.shape == after.shape == (180, hidden)
    assert np.linalg.matrix_rank(before) <= 2
    assert_allclose(after, np.tanh(before))


def test_the_hidden_outputs_after_the_sigmoid_have_full_rank_for_distinct_nodes():
    before, after = hidden_layer(_raw_network(30, 3), TRAIN_GRID)
    assert np.linalg.matrix_rank(before) == 2
    assert np.linalg.matrix_rank(after) > 20


def test_significant_count_is_relative_to_the_largest():
    assert significant_count([10.0, 1.0, 0.02, 0.001], threshold=1e-3) == 3
    assert significant_count([10.0, 1.0, 0.02, 0.001], threshold=1e-2) == 2
    assert significant_count([5.0, 0.05], threshold=1e-2) == 1  # strictly above
    assert significant_count([], threshold=1e-2) == 0


def test_pruning_counts_and_retrains_at_that_size(train, test):
    result = svd_pruning(train, test, hidden=12, epochs=15, threshold=1e-2)
    assert result.singular_before.size == result.singular_after.size == 12
    assert result.rank_before_activation <= 2
    assert 1 <= result.significant <= 12
    assert result.pruned_model.hidden == result.significant
    assert result.counts[1e-2] == result.significant
    assert result.counts[1e-2] <= result.counts[1e-3] <= result.counts[1e-4]
    assert result.full_mse > 0 and result.pruned_test_rms > 0


def test_pruning_analyses_a_given_network_and_retrains_it_the_same_way(train):
    from encal.models.ann import fit_ann

    model = fit_ann(train.encoder_deg, train.errors_arcmin, hidden=10, encoding="periodic", rng=4, epochs=7)
    result = svd_pruning(train, model=model, epochs=7)
    assert result.hidden == 10 and result.encoding == "periodic"
    assert result.full_model is model
    assert result.pruned_model.encoding == "periodic"
    assert result.rank_before_activation <= 3  # two inputs and a bias
    assert result.full_test_rms is None


@pytest.mark.parametrize("threshold", [0.0, 1.0, -1e-3, "1e-2"])
def test_pruning_threshold_must_be_a_fraction(train, threshold):
    with pytest.raises(InputError) as info:
        svd_pruning(train, hidden=4, epochs=2, threshold=threshold)
    assert str(info.value) == (f"The 'threshold' parameter of svd_pruning must be a finite number in (0, 1). "
                               f"Got {threshold!r} instead.")


@pytest.mark.parametrize("options, message", [
    ({"epochs": 0}, f"The 'epochs' parameter of svd_pruning must be an int from 1 to 1000000 ({LIMIT['epochs']}). "
                    "Got 0 instead."),
    ({"model": "net"}, "The 'model' parameter of svd_pruning must be an ANNModel (a trained 1:N:1 network) or None. "
                       "Got an object of type str instead."),
    ({"rng": 1.5}, "The 'rng' parameter of svd_pruning must be an int >= 0 (the study's seed). Got 1.5 instead."),
])
def test_pruning_refuses_bad_options(train, options, message):
    with pytest.raises(InputError) as info:
        svd_pruning(train, **{"hidden": 4, "epochs": 2, **options})
    assert str(info.value) == message


# --------------------------------------------------------------------------- Table 3


def test_comparison_recovers_a_noise_free_harmonic_profile():
    train, test = calibration(TRAIN_GRID), calibration(TEST_GRID)
    models = [spec for spec in DEFAULT_MODELS if spec.key in ("fourier", "lut-linear", "lut-cubic")]
    comparison = compare_models(train, test, models=models, floor_arcmin=0.1)
    assert [e.key for e in comparison.entries] == ["before", "fourier", "lut-linear", "lut-cubic"]
    before = comparison.entry("before")
    assert before.model is None
    assert before.stats == error_stats(test)
    assert comparison.entry("fourier").stats.max_abs < 1e-9  # the profile is four harmonics
    assert comparison.entry("lut-cubic").stats.rms < comparison.entry("lut-linear").stats.rms < 0.1
    assert comparison.entry("fourier").rms_over_floor == pytest.approx(comparison.entry("fourier").stats.rms / 0.1)
    data = comparison.as_dict()
    assert data["models"][0]["model"] == "before" and "rms_over_floor" in data["models"][1]


def test_comparison_trains_both_networks_reproducibly(train, test):
    models = [spec for spec in DEFAULT_MODELS if spec.key.startswith("ann")]
    a = compare_models(train, test, models=models, epochs=5, rng=3)
    b = compare_models(train, test, models=models, epochs=5, rng=3)
    paper = a.entry("ann-paper").model
    assert paper.hidden == 80 and paper.encoding == "raw" and paper.training["algorithm"] == "trainlm"
    assert a.entry("ann-periodic").model.encoding == "periodic"
    for key in ("ann-paper", "ann-periodic"):
        assert_array_equal(a.entry(key).residual_arcmin, b.entry(key).residual_arcmin)
    assert a.entry("ann-paper").rms_over_floor is None
    assert "Table 3" in a.table().title


def test_comparison_refuses_duplicate_model_keys(train, test):
    with pytest.raises(InputError) as info:
        compare_models(train, test, models=(DEFAULT_MODELS[0], DEFAULT_MODELS[0]))
    assert str(info.value) == ("The 'models' parameter of compare_models must be a sequence of ModelSpec whose keys "
                               "are distinct and not 'before'. Got the keys ['fourier', 'fourier'] instead.")


@pytest.mark.parametrize("floor", [0.0, -1.0, float("nan")])
def test_comparison_floor_must_be_positive(train, test, floor):
    with pytest.raises(InputError) as info:
        compare_models(train, test, models=DEFAULT_MODELS[:1], floor_arcmin=floor)
    assert str(info.value) == ("The 'floor_arcmin' parameter of compare_models must be a finite number > 0 "
                               f"(arc-minutes, or None). Got {floor!r} instead.")


def test_comparison_refuses_a_bad_budget(train, test):
    with pytest.raises(InputError) as info:
        compare_models(train, test, models=DEFAULT_MODELS[:1], epochs=-3)
    assert str(info.value) == (f"The 'epochs' parameter of compare_models must be an int from 1 to 1000000 "
                               f"({LIMIT['epochs']}). Got -3 instead.")


# --------------------------------------------------------------------------- reproducibility


def _shifted(cal, lsb_count, name):
    lsb_deg = lsb_arcmin(16) / 60.0
    return Calibration(cal.reference_deg, cal.encoder_deg + lsb_count * lsb_deg, name=name, resolution_bits=16)


def test_reproducibility_of_repeats_one_and_two_lsb_away(train, test):
    from encal import fit

    model = fit(train, "fourier")
    result = reproducibility(train, {"same": train, "one": _shifted(train, 1, "one"),
                                     "two": _shifted(train, -2, "two")}, model=model, test=test)
    same, one, two = (result.run(label) for label in ("same", "one", "two"))
    assert_allclose(same.difference_arcmin, 0.0, atol=1e-9)
    assert same.within_one_lsb == 1.0 and one.within_one_lsb == 1.0 and two.within_one_lsb == 0.0
    assert_allclose(two.difference_arcmin, -2 * lsb_arcmin(16), rtol=1e-6)
    assert result.lsb_arcmin == pytest.approx(lsb_arcmin(16))
    assert one.model_residual.rms > same.model_residual.rms
    assert result.first_test_residual is not None
    assert "1 LSB = 0.3296 arcmin" in result.table().to_text()


def test_reproducibility_needs_common_reference_angles(train, test):
    with pytest.raises(InputError, match="shares 0 reference angles"):
        matched_difference(train, test)
    with pytest.raises(InputError) as info:
        matched_difference(train, test, tolerance_deg=0)
    assert str(info.value) == ("The 'tolerance_deg' parameter of matched_difference must be a finite number > 0. "
                               "Got 0 instead.")


@pytest.mark.parametrize("repeats, options, message", [
    ({}, {}, "The 'repeats' parameter of reproducibility must be a mapping of labels to repeat Calibrations, at "
             "least one. Got {} instead."),
    ("enc1", {}, "The 'repeats' parameter of reproducibility must be a mapping of labels to repeat Calibrations. "
                 "Got an object of type str instead."),
    ({"b": "x"}, {}, "The 'repeats[b]' parameter of reproducibility must be a Calibration. "
                     "Got an object of type str instead."),
    (None, {"resolution_bits": 40}, "The 'resolution_bits' parameter of reproducibility must be an int from 1 to "
                                    "32 (or None: the first calibration's). Got 40 instead."),
    (None, {"floors": {"b": -1.0}}, "The 'floors[b]' parameter of reproducibility must be a finite number >= 0 "
                                    "(arc-minutes). Got -1.0 instead."),
    (None, {"model": "fourier"}, "The 'model' parameter of reproducibility must be a Model or None. "
                                 "Got an object of type str instead."),
])
def test_reproducibility_refuses_bad_options(train, repeats, options, message):
    with pytest.raises(InputError) as info:
        reproducibility(train, {"b": train} if repeats is None else repeats, **options)
    assert str(info.value) == message


# --------------------------------------------------------------------------- tables


def test_table_text_is_aligned_and_csv_reads_back(tmp_path):
    table = Table("demo", "Demo (arcmin)", (Column("encoder", "encoder", "{}"), Column("rms_arcmin", "RMS"),
                                             Column("share", "share", "{:.0%}")),
                  (("enc1", 1.23456, 0.5), ("encoder2", None, 1.0)), notes=("a note",))
    lines = table.to_text().splitlines()
    assert lines[0] == "Demo (arcmin)"
    assert len({len(line) for line in lines[1:4]}) == 1  # header, rule and first row line up
    assert lines[4].split() == ["encoder2", "-", "100%"]
    assert lines[-1] == "Note: a note"
    path = table.write_csv(tmp_path / "demo.csv")
    rows = list(csv.reader(path.read_text().splitlines()))
    assert rows == [["encoder", "rms_arcmin", "share"], ["enc1", "1.23456", "0.5"], ["encoder2", "", "1"]]
    assert table.records()[0] == {"encoder": "enc1", "rms_arcmin": 1.23456, "share": 0.5}


def test_table_html_escapes_text():
    html = Table("t", "a < b", (Column("x", "x & y", "{}"),), (("<script>",),)).to_html()
    assert "<script>" not in html and "&lt;script&gt;" in html and "x &amp; y" in html


def test_table_refuses_ragged_rows():
    with pytest.raises(ValueError, match="a row has 1 values for 2 columns"):
        Table("t", "t", (Column("a", "a"), Column("b", "b")), ((1.0,),))


def test_table1_says_the_papers_rms_is_the_std(train):
    from encal import harmonics

    table = profile_table({"enc": error_stats(train)}, {"enc": harmonics(train.encoder_deg, train.errors_arcmin)})
    record = table.records()[0]
    assert record["top_orders"].split()[:2] == ["1", "2"]
    assert record["rms_arcmin"] >= record["mae_arcmin"]
    assert any("'RMS' column is the STD" in note for note in table.notes)

"""Sizes that can run, and parameters that make sense (issue 17, items 8 and 10).

Every size option is bounded by what a workstation can run (``encal._core.limits``), with one sentence;
a model file edited by hand and re-signed is held to a range for every parameter, so that it can
neither give NaN with exit status 0 nor a traceback; and a wide model is evaluated in chunks, in
bounded memory.
"""

import json
import tracemalloc

import numpy as np
import pytest

import encal
from encal._core import limits as _limits
from encal.cli import main
from encal.deploy import runtime
from encal._core.errors import InputError, ModelFileError
from encal.models.ann import ANNModel

from tests.conftest import grid_csv


@pytest.fixture
def calibration(tmp_path):
    path = tmp_path / "cal.csv"
    path.write_text(grid_csv())
    return path


# ------------------------------------------------------------------ item 8: size options

@pytest.mark.parametrize("argv, status, words", [
    (["fit", "{cal}", "-o", "{out}/m.json", "--method", "ann", "--hidden", "1000000000"], 2,
     ["--hidden", "from 1 to 1000", "1000000000"]),
    (["fit", "{cal}", "-o", "{out}/m.json", "--method", "ann", "--hidden", "1001"], 2, ["from 1 to 1000"]),
    (["fit", "{cal}", "-o", "{out}/m.json", "--method", "ann", "--epochs", "10000000"], 2, ["--epochs"]),
    (["fit", "{cal}", "-o", "{out}/m.json", "--method", "fourier", "--n-orders", "40000"], 2, ["--n-orders"]),
    (["fit", "{cal}", "-o", "{out}/m.json", "--folds", "5000"], 2, ["--folds"]),
    (["demo", "--encoders", "100000", "--out", "{out}/d"], 2, ["--encoders", "from 1 to 1000"]),
    (["demo", "--workers", "1000", "--out", "{out}/d"], 2, ["--workers", "from 0 to 64"]),
    (["compare", "{cal}", "{cal}", "--epochs", "1000000000"], 2, ["--epochs"]),
    (["study", "sweep", "{cal}", "--seeds", "100000"], 2, ["--seeds"]),
    (["study", "sweep", "{cal}", "--hidden", "10,100000"], 1, ["--hidden", "from 1 to 1000"]),
    (["study", "prune", "{cal}", "--hidden", "5000"], 1, ["--hidden", "from 1 to 1000"]),
    (["selfcal", "spin", "{cal}", "--pole-pairs", "1000000", "-o", "{out}/s.csv"], 2, ["--pole-pairs"]),
])
def test_size_options_are_bounded_with_a_sentence(calibration, tmp_path, capsys, argv, status, words):
    argv = [part.format(cal=calibration, out=tmp_path) for part in argv]
    with pytest.raises(SystemExit) if status == 2 else _no_exit():
        assert main(argv) == status
    err = capsys.readouterr().err
    assert "Traceback" not in err
    for word in words:
        assert word in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.csv"]


class _no_exit:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def test_the_largest_size_is_accepted_by_the_parser():
    from encal.cli._common import size_option

    assert size_option("hidden")("1000") == 1000
    assert size_option("workers", 0)("0") == 0


def test_library_entry_points_share_the_bounds():
    with pytest.raises(InputError, match="'hidden' parameter of fit_ann must be an int from 1 to 1000"):
        encal.fit(encal.Calibration(np.arange(0, 360, 10.0), np.arange(0, 360, 10.0)), "ann", hidden=1001)
    from encal._core.pool import Workers

    with pytest.raises(InputError, match="'workers' parameter of Workers"):
        Workers(10**4)


def test_limits_table_says_why():
    for name, (largest, why) in _limits.SIZE_LIMITS.items():
        assert largest >= 1 and len(why) > 20, name


def test_a_wide_model_is_evaluated_in_bounded_memory():
    """A 1:2000:1 network on 20,000 angles would need 320 MB for its hidden layer in one piece."""
    rng = np.random.default_rng(0)
    hidden = 2000
    model = ANNModel(rng.normal(size=(hidden, 2)), rng.normal(size=hidden), rng.normal(size=hidden) / hidden, 0.1,
                     encoding="periodic", activation="tansig", input_offset=[-1.0, -1.0], input_gain=[1.0, 1.0],
                     target_offset=-1.0,
                     target_gain=1.0)
    angles = np.linspace(0.0, 360.0, 20_000)
    tracemalloc.start()
    try:
        first = model.predict(angles)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 120e6, f"peak {peak / 1e6:.0f} MB"
    np.testing.assert_array_equal(first[:50], model.predict(angles[:50]))


# ------------------------------------------------------------------ item 10: re-signed parameters

def _fitted(tmp_path, method, **options):
    ref = np.arange(0.0, 360.0, 2.0)
    cal = encal.Calibration(ref, ref + np.sin(np.radians(ref)) / 60.0)
    return json.loads(encal.fit(cal, method, **options).save(tmp_path / "m.json").read_text())


def _edited(tmp_path, document, edit):
    document = json.loads(json.dumps(document))
    edit(document)
    document.pop("sha256")
    document["sha256"] = runtime.content_sha256(document)
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(document))
    return path


def _set_target_gain(value):
    def edit(d):
        d["parameters"]["target_gain"] = value
        d["normalisation"]["target_gain"] = value
    return edit


def _set_input_gain(value):
    def edit(d):
        d["parameters"]["input_gain"][0] = value
        d["normalisation"]["input_gain"][0] = value
    return edit


def _set(path, value):
    def edit(d):
        where = d["parameters"]
        for key in path[:-1]:
            where = where[key]
        where[path[-1]] = value
    return edit


ANN_EDITS = {
    "target_gain-1e-300": (_set_target_gain(1e-300), "target_gain"),
    "target_gain--1e-200": (_set_target_gain(-1e-200), "target_gain"),
    "input_gain-1e-300": (_set_input_gain(1e-300), "input_gain"),
    "b2-10^400": (_set(["b2"], 10**400), "b2"),
    "W2-10^400": (_set(["W2", 0], -(10**400)), "W2"),
    "W1-1e101": (_set(["W1", 0, 0], 1e101), "W1"),
    "target_gain-10^400": (_set_target_gain(10**400), "target_gain"),
}
FOURIER_EDITS = {
    "cos-10^400": (_set(["cos", 0], 10**400), "cos"),
    "order-10^400": (_set(["orders", 0], 10**400), "orders"),
    "sin-true": (_set(["sin", 0], True), "sin"),
}


@pytest.fixture(scope="module")
def documents(tmp_path_factory):
    folder = tmp_path_factory.mktemp("documents")
    return {"ann": _fitted(folder, "ann", hidden=3, epochs=5, rng=0), "fourier": _fitted(folder, "fourier")}


@pytest.mark.parametrize("kind, case",
                         [("ann", key) for key in ANN_EDITS] + [("fourier", key) for key in FOURIER_EDITS])
def test_a_resigned_out_of_range_parameter_is_refused(documents, tmp_path, capsys, kind, case):
    edit, field = {**ANN_EDITS, **FOURIER_EDITS}[case]
    path = _edited(tmp_path, documents[kind], edit)
    with pytest.raises(runtime.ModelFileError, match=field):
        runtime.load(path)
    with pytest.raises(ModelFileError, match=field):
        encal.load_model(path)
    angles = tmp_path / "angles.txt"
    angles.write_text("10\n20\n")
    assert main(["correct", str(path), str(angles)]) == 1
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1 and field in captured.err


def test_gains_of_real_data_are_accepted(documents, tmp_path):
    """A profile of 1e-12 arcmin has a target gain of 2e12; a constant one a gain of 1."""
    for value in (2e12, 1.0, -0.5, 1e-100):
        path = _edited(tmp_path, documents["ann"], _set_target_gain(value))
        assert np.isfinite(runtime.load(path).correct_deg(12.5))

"""Determinism: the same data, options and seed give byte-identical model files, for every method.

The model file records when it was written (``training.date``); ``reproducible=True`` (``encal fit
--reproducible``) or the SOURCE_DATE_EPOCH environment variable fixes that field, and then nothing else
may differ: not between two fits in one process, not between two processes with different hash seeds,
whatever the method (the randomised ones, ``ann``, ``hybrid`` and ``auto``, included).
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import encal
from encal.cli import main
from encal.models.select import Candidate
from tests._paths import REPO

QUICK_AUTO = (
    Candidate("fourier", {"select": "top", "n_orders": 10}),
    Candidate("lut", {"interpolation": "cubic"}),
    Candidate("ann", {"hidden": 6, "algorithm": "trainlm", "epochs": 40}),
    Candidate("hybrid", {"hidden": 4, "epochs": 30}),
)

#: id -> (method, options); ``rng`` is added for the randomised methods.
METHODS = {
    "fourier-top": ("fourier", {}),
    "fourier-cv": ("fourier", {"select": "cv"}),
    "fourier-orders": ("fourier", {"orders": [0, 1, 2, 16]}),
    "lut-linear": ("lut", {"interpolation": "linear"}),
    "lut-cubic": ("lut", {"interpolation": "cubic"}),
    "ann-trainlm": ("ann", {"hidden": 6, "epochs": 40}),
    "ann-raw": ("ann", {"hidden": 6, "epochs": 40, "encoding": "raw"}),
    "ann-trainscg": ("ann", {"hidden": 6, "epochs": 40, "algorithm": "trainscg"}),
    "ann-trainbr": ("ann", {"hidden": 6, "epochs": 20, "algorithm": "trainbr"}),
    "ann-traingdx": ("ann", {"hidden": 6, "epochs": 40, "algorithm": "traingdx"}),
    "hybrid": ("hybrid", {"hidden": 4, "epochs": 30}),
    "auto-quick": ("auto", {"candidates": QUICK_AUTO}),
    "auto-default": ("auto", {}),
}
RANDOMISED = {"ann", "hybrid", "auto"}


def _calibration_text():
    """A noisy resolver-like calibration (the noise is part of the data, drawn once from a fixed seed)."""
    reference = np.arange(0.0, 360.0, 4.0)
    theta = np.radians(reference)
    error = 2.0 * np.sin(theta + 0.3) + 0.5 * np.cos(2 * theta) + 0.2 * np.sin(16 * theta)
    error = error + np.random.default_rng(12345).normal(0.0, 0.05, reference.size)
    rows = [f"{r!r},{e!r}" for r, e in zip(reference.tolist(), (reference + error / 60.0).tolist())]
    return "# resolution_bits: 16\nreference_deg,encoder_deg\n" + "\n".join(rows) + "\n"


@pytest.fixture(scope="module")
def calibration_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("determinism") / "enc.csv"
    path.write_text(_calibration_text(), encoding="utf-8")
    return path


def _fit_and_save(calibration_path, key, path, seed=7, **save_options):
    method, options = METHODS[key]
    options = dict(options, rng=seed) if method in RANDOMISED else dict(options)
    cal = encal.read_calibration(calibration_path)  # a fresh read: nothing shared between the two fits
    return encal.fit(cal, method=method, **options).save(path, **save_options)


def _without_timings(value):
    if isinstance(value, dict):
        return {key: None if key == "time_s" else _without_timings(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_without_timings(item) for item in value]
    return value


def _without_date(text):
    """The content of a model file but its date, wall-clock timings (auto's table) and checksum."""
    document = json.loads(text)
    document["training"].pop("date")
    document.pop("sha256")
    return _without_timings(document)


@pytest.mark.parametrize("key", [key for key in METHODS if key != "auto-default"])
def test_same_seed_gives_identical_bytes(key, calibration_path, tmp_path):
    """Two fits in one process (auto with its default candidates: in test_identical_across_processes)."""
    first = _fit_and_save(calibration_path, key, tmp_path / "a.json", reproducible=True)
    second = _fit_and_save(calibration_path, key, tmp_path / "b.json", reproducible=True)
    assert first.read_bytes() == second.read_bytes()


@pytest.mark.parametrize("key", ["fourier-top", "ann-trainlm", "auto-quick"])
def test_only_the_date_differs_without_reproducible(key, calibration_path, tmp_path, monkeypatch):
    """Without the option the files differ at most in the date, auto's wall-clock timings and the checksum."""
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    first = _fit_and_save(calibration_path, key, tmp_path / "a.json")
    second = _fit_and_save(calibration_path, key, tmp_path / "b.json")
    assert _without_date(first.read_text()) == _without_date(second.read_text())
    changed = [a for a, b in zip(first.read_text().splitlines(), second.read_text().splitlines()) if a != b]
    assert all(any(f'"{name}"' in line for name in ("date", "sha256", "time_s")) for line in changed), changed


@pytest.mark.parametrize("key", ["lut-cubic", "hybrid", "auto-quick"])
def test_source_date_epoch_fixes_the_date(key, calibration_path, tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    first = _fit_and_save(calibration_path, key, tmp_path / "a.json")
    second = _fit_and_save(calibration_path, key, tmp_path / "b.json")
    assert first.read_bytes() == second.read_bytes()
    assert json.loads(first.read_text())["training"]["date"] == "2023-11-14T22:13:20Z"


@pytest.mark.parametrize("key", ["ann-trainlm", "hybrid", "auto-quick"])
def test_the_seed_matters(key, calibration_path, tmp_path):
    """Different seeds give different networks: identical files above are not identical by accident."""
    first = _fit_and_save(calibration_path, key, tmp_path / "a.json", seed=1, reproducible=True)
    second = _fit_and_save(calibration_path, key, tmp_path / "b.json", seed=2, reproducible=True)
    assert _without_date(first.read_text())["training"]["seed"] != \
        _without_date(second.read_text())["training"]["seed"]


def test_recorded_seed_reproduces_an_unseeded_network(calibration_path):
    """A network fitted without a seed records the one it drew; fitting again with it gives the same model."""
    cal = encal.read_calibration(calibration_path)
    drawn = encal.fit(cal, method="ann", hidden=6, epochs=30)
    seed = drawn.training["seed"]
    assert isinstance(seed, int)
    again = encal.fit(cal, method="ann", hidden=6, epochs=30, rng=seed)
    assert again.parameters() == drawn.parameters()


@pytest.mark.parametrize("argv", [
    ["--method", "ann", "--hidden", "6", "--epochs", "30", "--seed", "3", "--reproducible"],
    ["--method", "fourier", "--reproducible"],
    ["--method", "hybrid", "--hidden", "4", "--epochs", "20", "--seed", "3"],  # date fixed by SOURCE_DATE_EPOCH
])
def test_cli_fit_is_byte_identical(argv, calibration_path, tmp_path, monkeypatch, capsys):
    if "--reproducible" not in argv:
        monkeypatch.setenv("SOURCE_DATE_EPOCH", "0")
    paths = [tmp_path / "a.json", tmp_path / "b.json"]
    for path in paths:
        assert main(["fit", str(calibration_path), "-o", str(path), *argv]) == 0
    assert paths[0].read_bytes() == paths[1].read_bytes()


_FIT_ALL = r'''
import importlib, sys
sys.path.insert(0, sys.argv[3])
t = importlib.import_module(sys.argv[4])
for key in t.METHODS:
    t._fit_and_save(sys.argv[1], key, f"{sys.argv[2]}/{key}.json", reproducible=True)
'''


@pytest.fixture(scope="module")
def two_processes(calibration_path, tmp_path_factory):
    """The folders of model files written by two processes with different hash seeds (every method)."""
    folders, processes = [], []
    for hash_seed in ("1", "2"):  # side by side: the two processes share nothing
        folder = tmp_path_factory.mktemp(f"process{hash_seed}")
        env = dict(os.environ, PYTHONHASHSEED=hash_seed)
        processes.append(subprocess.Popen([sys.executable, "-c", _FIT_ALL, str(calibration_path), str(folder),
                                           str(REPO), __name__], env=env))
        folders.append(folder)
    try:
        for process in processes:
            assert process.wait(timeout=300) == 0
    finally:
        for process in processes:
            if process.poll() is None:
                process.kill()
                process.wait()
    return folders


@pytest.mark.parametrize("key", METHODS)
def test_identical_across_processes(key, two_processes):
    """Two processes with different hash seeds write the same bytes."""
    first, second = two_processes
    assert (first / f"{key}.json").read_bytes() == (second / f"{key}.json").read_bytes()

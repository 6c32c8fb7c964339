"""Known truth through the public Python API (task pyapi; ``benchmarks/api_variants.py``).

The benchmark fits one simulated calibration, whose error is known, with every method, in harmless forms of the
calibration and of the readings, and calls the API with harmful inputs; all of it agreed when it was written (its
table is in benchmarks/results/api_variants.md). These tests keep a few harmless forms of each kind and every
harmful input: each must be refused in one sentence by an encal error (35 of them were a NumPy traceback, a NumPy
warning or a number before the audit).
"""


import numpy as np
import pytest

from tests._benchmarks import load_benchmark


av = load_benchmark("api_variants")
CASES = {f"{case.group}: {case.name}": case for case in av.cases()}
KEPT = [
    "fit: truth: auto on a 1-degree grid",
    "fit: truth: lut on 720 random angles",
    "fit: calibration form: auto, strided arrays",
    "fit: calibration form: auto, angles 3 turns down",
    "fit: calibration form: fourier, written and read back",
    "fit: calibration form: lut, written with a comment of two lines",
    "fit: calibration form: lut, rows shuffled",
    "fit: float32 calibration, truth: lut cubic, float32 arrays",
    "inputs: correct: auto, 0-d array",
    "inputs: correct: auto, 2-D Fortran order",
    "inputs: correct: auto, read-only",
    "inputs: Compensator.correct: auto, (-180, 180]",
    "inputs: predict: auto, (n, 1) column",
    "inputs: large arrays: lut, correct table=True",
    "model file: lut, runtime.load",
    "model file: auto, compile_table 14 bits",
    "analysis: harmonics: lists, shuffled, 2 turns up",
    "arc: auto: rows shuffled",
    "14-bit codes: auto: float32",
    "directional: fourier: calibration rows shuffled",
    "simulate / selfcal: selfcal.steps, rows shuffled",
    # task storeapi: the store and the firmware exporters from Python
    "store: write and read back: model as a Model object",
    "store: write and read back: serial decomposed (NFD, from a Mac), read composed",
    "store: epochs: the same calibration twice under one serial",
    "store: drift: first order grown by 1 arcmin",
    "store: grades: grade_of at and about the limits",
    "firmware: moteus: reversed reading: the table applied, to Model.correct",
    "firmware: tinymovr: 14-bit codes: the table applied, to Model.correct",
    "firmware: mechaduino: bidirectional (the mean of its directions): the table applied, to Model.correct",
    "firmware: klipper: reversed reading: the table applied, to Model.correct",
    "firmware: simplefoc: 14-bit codes: model file path as str",
    "firmware: C: 14-bit codes: Compensator(path)",
]


@pytest.mark.parametrize("name", KEPT)
def test_a_harmless_form_gives_the_same_numbers_and_the_truth(name, tmp_path):
    difference, limit, note = av.outcome(CASES[name], tmp_path)
    assert difference <= limit, note


@pytest.mark.parametrize("name", list(av.HARMFUL))
def test_a_harmful_input_is_refused_in_one_sentence(name):
    assert av.refused(av.HARMFUL[name]) == ""


def test_the_readings_given_are_left_as_they_were():
    readings = np.linspace(-400.0, 400.0, 9000).reshape(3, -1, order="F")
    before = readings.copy()
    model = av.model("lut")
    first = model.correct(readings)
    assert np.array_equal(readings, before) and np.array_equal(model.correct(readings), first)
    assert first.shape == readings.shape

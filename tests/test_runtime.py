"""The standalone runtime: standard library only, and the same answers as the NumPy models."""

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from encal import runtime
from encal.deploy import Compensator, load_model, save_model
from encal.models.ann import fit_ann
from encal.models.hybrid import fit_hybrid
from encal.runtime import ModelFileError
from encal._core.errors import InputError
from tests._paths import DATA

V1_FILES = sorted(DATA.glob("model_v1_*.json"))
EXPECTED = json.loads((DATA / "expected_v1.json").read_text(encoding="utf-8"))
RUNTIME_SOURCE = Path(runtime.__file__)

angles = st.one_of(
    st.sampled_from([0.0, -0.0, 360.0, -360.0, 359.9999999999999, 1e-300, -1e-17, 720.0, 1e15,
                     -1e300, 1e300, 180.0, 2.0, 358.0]),
    st.floats(-1080.0, 1080.0),
    st.floats(allow_nan=False, allow_infinity=False),
)


def circular_difference_deg(a, b):
    return abs((np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0)


def trained(kind):
    """A model trained on a synthetic profile (real weights, not hand-made ones)."""
    theta = np.arange(0.0, 360.0, 2.0)
    r = np.radians(theta)
    error = 4.0 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r) - 0.6 * np.sin(4 * r)
    if kind == "ann_raw":
        return fit_ann(theta, error, hidden=80, encoding="raw", rng=0, epochs=20)
    if kind == "ann_periodic_logsig":
        return fit_ann(theta, error, hidden=12, activation="logsig", rng=1, epochs=50)
    return fit_hybrid(theta, error + 0.3 * np.exp(-0.5 * ((theta - 200.0) / 6.0) ** 2), rng=2,
                      epochs=50)


SOURCES = [*(p.name for p in V1_FILES), "ann_raw", "ann_periodic_logsig", "hybrid"]


@pytest.fixture(scope="module", params=SOURCES)
def both(request, tmp_path_factory):
    """The NumPy model and the runtime model of one stored or freshly trained model file."""
    if request.param.endswith(".json"):
        path = DATA / request.param
    else:
        path = save_model(trained(request.param), tmp_path_factory.mktemp("m") / "m.json")
    return load_model(path), runtime.load(path)


@settings(max_examples=150, deadline=None)
@given(theta=angles)
@example(theta=0.0)
@example(theta=360.0)
@example(theta=-1.0)
@example(theta=1e300)
def test_runtime_agrees_with_numpy(both, theta):
    model, stored = both
    assert abs(stored.predict_arcmin(theta) - float(model.predict(theta))) <= 1e-9
    assert circular_difference_deg(stored.correct_deg(theta), model.correct(theta)) <= 1e-9 / 60
    assert 0.0 <= stored.correct_deg(theta) < 360.0


def test_runtime_agrees_on_a_dense_grid(both):
    model, stored = both
    theta = np.linspace(-2.0, 362.0, 3001)
    ours = np.array([stored.predict_arcmin(t) for t in theta])
    np.testing.assert_allclose(ours, model.predict(theta), rtol=0, atol=1e-9)


@pytest.mark.parametrize("path", V1_FILES, ids=lambda p: p.name)
def test_runtime_predicts_the_stored_values(path):
    expected = EXPECTED[path.name]
    stored = runtime.load(path)
    for theta, error, corrected in zip(expected["theta_deg"], expected["predict_arcmin"],
                                       expected["correct_deg"]):
        assert stored.predict_arcmin(theta) == pytest.approx(error, abs=1e-12)
        assert stored.correct_deg(theta) == pytest.approx(corrected, abs=1e-12)


def test_runtime_is_periodic():
    stored = runtime.load(DATA / "model_v1_lut_linear.json")
    for theta in (0.0, 1.0, 0.5, 359.75, 123.0):
        assert stored.predict_arcmin(theta + 360.0) == pytest.approx(stored.predict_arcmin(theta),
                                                                     abs=1e-9)


def test_directional_models_take_a_direction():
    stored = runtime.load(DATA / "model_v1_directional.json")
    forward, reverse = stored.predict_arcmin(10.0, 1), stored.predict_arcmin(10.0, -1)
    assert forward != reverse
    assert stored.predict_arcmin(10.0) == pytest.approx(0.5 * (forward + reverse), abs=1e-12)
    with pytest.raises(ValueError, match="direction"):
        stored.predict_arcmin(10.0, 0)


def test_other_kinds_ignore_the_direction():
    stored = runtime.load(DATA / "model_v1_fourier.json")
    assert stored.correct_deg(10.0, -1) == stored.correct_deg(10.0)


@pytest.mark.parametrize("bad", [math.nan, math.inf, "ten"])
def test_runtime_refuses_non_finite_angles(bad):
    stored = runtime.load(DATA / "model_v1_fourier.json")
    with pytest.raises(ValueError):
        stored.correct_deg(bad)


def test_logsig_does_not_overflow():
    assert runtime._logsig(-1000.0) == 0.0 and runtime._logsig(1000.0) == 1.0


def test_runtime_verifies_the_checksum(tmp_path):
    path = tmp_path / "m.json"
    text = (DATA / "model_v1_fourier.json").read_text(encoding="utf-8")
    document = json.loads(text)
    document["parameters"]["cos"][1] += 1e-9
    path.write_text(json.dumps(document), encoding="utf-8")
    with pytest.raises(ModelFileError, match="altered"):
        runtime.load(path)


def test_a_bad_row_is_described_not_quoted(tmp_path):
    """Task fuzz5: a list holding a row where a number belongs quoted the row whole (180 numbers, 3 kB)."""
    document = json.loads((DATA / "model_v1_lut.json").read_text(encoding="utf-8"))
    coefficients = document["parameters"]["coefficients"]
    coefficients[1] = 0.5  # a number in place of a row: the other rows are the list's values that are no number
    document["sha256"] = runtime.content_sha256({k: v for k, v in document.items() if k != "sha256"})
    path = tmp_path / "m.json"
    path.write_text(json.dumps(document), encoding="utf-8")
    with pytest.raises(ModelFileError, match=r"including a list of \d+ values$") as refused:
        runtime.load(path)
    assert len(str(refused.value)) < 300


def test_runtime_errors_are_value_errors():
    assert issubclass(ModelFileError, ValueError)


def test_runtime_metadata():
    stored = runtime.load(DATA / "model_v1_ann.json")
    assert stored.kind == "ann" and stored.encoder["resolution_bits"] == 16
    assert stored.sha256 == json.loads((DATA / "model_v1_ann.json").read_text())["sha256"]
    assert "ann" in repr(stored)


def test_runtime_imports_only_the_standard_library(tmp_path):
    # As a user would: the one file copied into another folder, run in isolated mode.
    shutil.copy(RUNTIME_SOURCE, tmp_path / "encal_runtime.py")
    script = f"""
import sys
sys.path[:] = [p for p in sys.path if 'site-packages' not in p and 'dist-packages' not in p]
sys.path.insert(0, {str(tmp_path)!r})
before = set(sys.modules)
import encal_runtime
for name in {[p.name for p in V1_FILES]!r}:
    model = encal_runtime.load({str(DATA)!r} + '/' + name)
    print(name, repr(model.correct_deg(123.456)), repr(model.predict_arcmin(-1.0)))
loaded = {{m.split('.')[0] for m in set(sys.modules) - before}} - {{'encal_runtime'}}
foreign = sorted(m for m in loaded if m not in sys.stdlib_module_names)
print('FOREIGN', foreign)
"""
    result = subprocess.run([sys.executable, "-I", "-c", script], capture_output=True, text=True,
                            timeout=60, check=True)
    lines = result.stdout.splitlines()
    assert lines[-1] == "FOREIGN []"
    for line in lines[:-1]:
        name, corrected, error = line.split()
        assert float(corrected) == pytest.approx(runtime.load(DATA / name).correct_deg(123.456),
                                                 abs=0)
        assert float(error) == runtime.load(DATA / name).predict_arcmin(-1.0)


def test_runtime_source_names_no_third_party_module():
    source = RUNTIME_SOURCE.read_text(encoding="utf-8")
    imports = {line.split()[1].split(".")[0] for line in source.splitlines()
               if line.startswith(("import ", "from "))}
    assert imports <= {"bisect", "hashlib", "json", "math"}


# -- the NumPy compensator (the vectorised online path) ---------------------------------

def test_compensator_from_a_file_or_a_model():
    path = DATA / "model_v1_hybrid.json"
    from_file, model = Compensator(path), load_model(path)
    from_model = Compensator(model)
    theta = np.linspace(-10.0, 370.0, 777)
    np.testing.assert_array_equal(from_file.correct(theta), model.correct(theta))
    np.testing.assert_array_equal(from_model(theta), model.correct(theta))
    grid = theta.reshape(7, 111)  # any shape in, the same shape out
    np.testing.assert_array_equal(from_file.correct(grid), model.correct(theta).reshape(7, 111))
    assert isinstance(from_file.correct(10.0), float)
    assert from_file.sha256 == json.loads(path.read_text())["sha256"] == from_model.sha256
    assert from_file.source == str(path) and from_model.source is None
    assert from_file.kind == "hybrid" and from_file.encoder["name"] == "v1-hybrid"
    assert "hybrid" in repr(from_file).lower()


def test_compensator_of_an_unsaved_model_has_no_checksum():
    from encal.models.fourier import FourierModel

    assert Compensator(FourierModel([1], [1.0], [0.0])).sha256 is None


def test_compensator_direction():
    directional = Compensator(DATA / "model_v1_directional.json")
    stored = runtime.load(DATA / "model_v1_directional.json")
    theta = np.array([10.0, 20.0, 30.0])
    for direction in (1, -1):
        expected = [stored.correct_deg(t, direction) for t in theta]
        np.testing.assert_allclose(directional.correct(theta, direction), expected, atol=1e-12)
    mixed = directional.predict(theta, direction=[1, -1, 1])
    assert mixed[1] == pytest.approx(stored.predict_arcmin(20.0, -1), abs=1e-12)
    plain = Compensator(DATA / "model_v1_fourier.json")
    np.testing.assert_array_equal(plain.correct(theta, direction=-1), plain.correct(theta))


@pytest.mark.parametrize("direction, message", [
    (0, "The 'direction' parameter of predict must be +1 (forward), -1 (reverse) or None (unknown), one value or "
        "one per reading. Got the values [0] instead."),
    ([1, -1], "The 'direction' parameter of predict must be +1 (forward), -1 (reverse) or None (unknown), one value "
              "or one per reading (the shape (3,) of the encoder angles). Got the shape (2,) instead."),
])
def test_compensator_refuses_bad_directions(direction, message):
    with pytest.raises(InputError) as info:
        Compensator(DATA / "model_v1_fourier.json").correct([1.0, 2.0, 3.0], direction)
    assert str(info.value) == message


def test_compensator_uncertainty():
    comp = Compensator(DATA / "model_v1_ann.json")
    mean, std = comp.predict([0.0, 180.0], return_std=True)
    np.testing.assert_array_equal(mean, comp.predict([0.0, 180.0]))
    assert np.all(std >= 0.14)


def test_compensator_refuses_other_things():
    with pytest.raises(InputError) as info:
        Compensator(42)
    assert str(info.value) == ("The 'model' parameter of Compensator must be a Model or the path of a model file. "
                               "Got an object of type int instead.")
    with pytest.raises(InputError, match="finite"):
        Compensator(DATA / "model_v1_fourier.json").correct([1.0, np.nan])


# -- task runtime6: the runtime refuses what encal refuses, and offers encal correct's rules outside an arc ----------

@pytest.mark.parametrize("bad", [None, pytest.param(10**400, id="10**400"), "ten", 1j, math.nan, -math.inf])
def test_the_runtime_refuses_every_angle_encal_refuses_in_one_sentence(bad):
    """None raised a TypeError and 10**400 an OverflowError, from float(): neither the runtime's sentence."""
    stored, model = runtime.load(DATA / "model_v1_fourier.json"), load_model(DATA / "model_v1_fourier.json")
    with pytest.raises(InputError):
        model.predict(bad)
    for call in (stored.predict_arcmin, stored.correct_deg):
        with pytest.raises(ValueError, match=r"^expected a finite encoder angle in degrees, got .{1,60}$"):
            call(bad)


@pytest.mark.parametrize("name", ["model_v1_fourier.json", "model_v1_directional.json"])
@pytest.mark.parametrize("bad", [0, 2, True, np.True_, "1", 1j, [1]])
def test_the_runtime_refuses_every_direction_encal_refuses(name, bad):
    """A direction of 0 was ignored by a one-profile model, and True taken for +1 by a directional one: encal
    refuses both."""
    stored, model = runtime.load(DATA / name), load_model(DATA / name)
    with pytest.raises(InputError):
        model.predict(10.0, direction=bad)
    for call in (stored.predict_arcmin, stored.correct_deg):
        with pytest.raises(ValueError, match="^expected a direction of [+]1, -1 or None, got "):
            call(10.0, bad)


@pytest.mark.parametrize("good", [1, -1, 1.0, -1.0, np.int8(-1), np.float64(1.0)])
def test_the_runtime_takes_the_directions_encal_takes(good):
    stored, model = runtime.load(DATA / "model_v1_directional.json"), load_model(DATA / "model_v1_directional.json")
    assert stored.predict_arcmin(10.0, good) == pytest.approx(float(model.predict(10.0, direction=good)), abs=1e-12)


def hand_arc_models(tmp_path):
    """Arc models made by hand (known values): a first harmonic plus 0.5 arcmin over [20, 140] degrees, reversed or
    not, and a directional one over [300, 60] (through 0) whose parts differ by a constant 0.6 arcmin (a reversal)."""
    from encal.models.directional import DirectionalModel
    from encal.models.fourier import FourierModel

    paths = {}
    for sign in (1, -1):
        model = FourierModel([0, 1], [0.5, 2.0], [0.0, 3.0])
        model.range_deg, model.reading_sign = [20.0, 140.0], sign
        paths[f"fourier{sign:+d}"] = save_model(model, tmp_path / f"arc{sign:+d}.json")
    forward, reverse = FourierModel([0, 1], [0.3, 2.0], [0.0, 3.0]), FourierModel([0, 1], [-0.3, 2.0], [0.0, 3.0])
    model = DirectionalModel(forward, reverse)
    model.range_deg = [300.0, 60.0]  # through 0
    paths["directional"] = save_model(model, tmp_path / "arc-directional.json")
    return paths


@pytest.mark.parametrize("rule", ["clamp", "pass"])
def test_the_runtime_corrects_outside_an_arc_as_encal_correct_does(tmp_path, rule):
    """runtime.correct_deg(..., outside=rule) is apply_outside_rule's (encal correct --outside rule), end by end and
    direction by direction; known truth for the harmonic: clamp uses its error at the nearer end, pass none."""
    from encal._core.arcs import apply_outside_rule

    readings = [0.0, 10.0, 79.999, 80.0, 80.001, 150.0, 200.0, 259.9, 260.0, 260.1, 290.0, 359.0, -100.0, 500.0]
    for name, path in hand_arc_models(tmp_path).items():
        stored, model = runtime.load(path), load_model(path)
        for direction in ((None, 1, -1) if name == "directional" else (None,)):
            expected = apply_outside_rule(model, readings, rule, direction=direction)
            ours = [stored.correct_deg(theta, direction, outside=rule) for theta in readings]
            np.testing.assert_allclose(ours, expected, rtol=0, atol=1e-12)
    stored = runtime.load(hand_arc_models(tmp_path)["fourier+1"])
    error_at = {end: 0.5 + 2.0 * math.cos(math.radians(end)) + 3.0 * math.sin(math.radians(end)) for end in (20, 140)}
    held = {200.0: 140, 259.9: 140, 260.0: 140, 260.1: 20, 10.0: 20}  # 260: the middle of the gap, a tie: the end
    for theta, end in held.items():
        expected = theta - (error_at[end] / 60.0 if rule == "clamp" else 0.0)
        assert stored.correct_deg(theta, outside=rule) == pytest.approx(expected, abs=1e-12)
    assert stored.correct_deg(80.0, outside=rule) == stored.correct_deg(80.0)  # inside: the rule does not apply


def test_the_runtime_outside_rules_nan_and_error(tmp_path):
    stored = runtime.load(hand_arc_models(tmp_path)["fourier-1"])
    assert math.isnan(stored.correct_deg(-200.0)) and math.isnan(stored.correct_deg(-200.0, outside="nan"))
    assert math.isfinite(stored.correct_deg(-100.0, outside="error"))  # -(-100) = 100: inside
    with pytest.raises(ValueError, match=r"^the reading -200.0 deg is outside the calibrated range 20.0 to 140.0 deg"):
        stored.correct_deg(-200.0, outside="error")
    with pytest.raises(ValueError, match="^expected outside to be one of 'nan', 'error', 'clamp', 'pass', got 'wrap'$"):
        stored.correct_deg(100.0, outside="wrap")
    full = runtime.load(DATA / "model_v1_fourier.json")
    assert full.correct_deg(200.0, outside="error") == full.correct_deg(200.0)  # a full turn has no outside


def test_the_runtime_alone_loads_checks_and_refuses_in_one_sentence(tmp_path):
    """runtime.py copied alone into an empty folder, run by a Python with no site-packages (-I -S: neither NumPy
    nor encal importable): it corrects every frozen file as encal's copy does, and refuses each corrupted file
    with its ModelFileError, one sentence naming the file."""
    alone = tmp_path / "alone"
    alone.mkdir()
    shutil.copy(RUNTIME_SOURCE, alone / "rt.py")
    good = json.loads((DATA / "model_v1_fourier.json").read_text(encoding="utf-8"))

    def corrupted(name, change, resign=True):
        document = json.loads(json.dumps(good))
        change(document)
        if resign:  # json's default allows NaN, as a hand-made file might hold it
            content = {key: value for key, value in document.items() if key != "sha256"}
            text = json.dumps(content, sort_keys=True, separators=(",", ":"))
            document["sha256"] = __import__("hashlib").sha256(text.encode("ascii")).hexdigest()
        (tmp_path / name).write_text(json.dumps(document), encoding="utf-8")
        return name

    bad = {
        corrupted("altered.json", lambda d: d["parameters"]["cos"].__setitem__(1, 9.0), resign=False): "was altered",
        corrupted("missing.json", lambda d: d.pop("training")): "but training is missing",
        corrupted("nan.json", lambda d: d["parameters"]["sin"].__setitem__(1, math.nan)): "NaN or Infinity",
        corrupted("kind.json", lambda d: d.update(kind="wavelet")): 'got "wavelet"',
        corrupted("newer.json", lambda d: d.update(version=5)): "newer than version 4",
        corrupted("shape.json", lambda d: d["parameters"]["cos"].pop()): "parameters.cos to be a list of",
    }
    frozen = [p.name for p in sorted(DATA.glob("model_v*.json"))]
    script = f"""
import sys
sys.path[:] = [{str(alone)!r}] + [p for p in sys.path if p.startswith(sys.base_prefix)]
for name in ('numpy', 'encal'):
    try:
        __import__(name)
        print('IMPORTABLE', name)
    except ImportError:
        pass
import rt
for name in {frozen!r}:
    model = rt.load({str(DATA)!r} + '/' + name)
    print('OK', name, repr(model.correct_deg(123.456)), repr(model.correct_deg(-1.0, outside='clamp')))
for name in {sorted(bad)!r}:
    try:
        rt.load({str(tmp_path)!r} + '/' + name)
        print('LOADED', name)
    except rt.ModelFileError as exc:
        print('REFUSED', name, str(exc).replace(chr(10), ' '))
"""
    result = subprocess.run([sys.executable, "-I", "-S", "-c", script], capture_output=True, text=True, timeout=60,
                            cwd=alone, env={})
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert not [line for line in lines if line.startswith(("IMPORTABLE", "LOADED"))], lines
    corrected = {line.split()[1]: line.split()[2:] for line in lines if line.startswith("OK")}
    assert sorted(corrected) == frozen
    for name, (at_123, at_minus_1) in corrected.items():
        ours = runtime.load(DATA / name)
        assert float(at_123) == ours.correct_deg(123.456)
        assert float(at_minus_1) == ours.correct_deg(-1.0, outside="clamp")
    refused = {line.split()[1]: line.split(" ", 2)[2] for line in lines if line.startswith("REFUSED")}
    assert sorted(refused) == sorted(bad)
    for name, message in refused.items():
        assert message.startswith(f"{tmp_path}/{name}: ") and bad[name] in message and message.count(". ") == 0

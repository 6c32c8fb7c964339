"""The model file: save/load round trips, reproducibility, and every refusal."""

import json
import math
import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import encal
from encal.deploy import load_model, model_from_dict, model_to_dict, read_model, save_model
from encal.models.modelfile import dumps
from encal import runtime
from encal.runtime import content_sha256
from encal._core.errors import InputError, ModelFileError
from encal.models.base import Model
from encal.models.fourier import FourierModel
from encal.models.lut import fit_lut
from tests._paths import DATA

V1_FILES = sorted(DATA.glob("model_v1_*.json"))
EXPECTED = DATA / "expected_v1.json"
V3_FILES = sorted(DATA.glob("model_v3_*.json"))


def example_fourier():
    return FourierModel([0, 1, 2, 4, 97], [12.5, 3.25, -1.5, 0.25, 0.01],
                        [0.0, -2.0, 0.75, 0.125, -0.02],
                        encoder={"name": "enc1", "resolution_bits": 16},
                        training={"method": "fourier", "n_points": 180, "seed": np.int64(3),
                                  "options": {"n_orders": 5, "weights": np.array([1.0, 2.0])}})


def example_lut():
    theta = np.arange(0.0, 360.0, 2.0)
    model = fit_lut(theta, 3.0 * np.sin(np.radians(theta)) + np.cos(np.radians(4 * theta)),
                    interpolation="cubic")
    model.encoder = {"name": "enc2", "resolution_bits": 14}
    return model


@pytest.fixture(params=["fourier", "lut", *(p.name for p in V1_FILES)])
def model(request):
    """A model of every kind: made here, or read from the stored version-1 files."""
    makers = {"fourier": example_fourier, "lut": example_lut}
    if request.param in makers:
        return makers[request.param]()
    return load_model(DATA / request.param)


def same_floats(a, b):
    """Bitwise equality of nested JSON data (so -0.0 differs from 0.0)."""
    if isinstance(a, float) or isinstance(b, float):
        return type(a) is type(b) and struct.pack("<d", a) == struct.pack("<d", b)
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same_floats(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(map(same_floats, a, b))
    return a == b


def write_document(path, document, *, resign=True):
    if resign:
        document = {k: v for k, v in document.items() if k != "sha256"}
        document["sha256"] = content_sha256(document)
    path.write_text(json.dumps(document), encoding="utf-8")
    return path


# -- round trips ------------------------------------------------------------------------

def test_save_load_round_trip(model, tmp_path):
    path = save_model(model, tmp_path / "m.json")
    loaded = load_model(path)
    assert type(loaded) is type(model)
    assert same_floats(loaded.parameters(), model.parameters())
    assert loaded.encoder == {"name": model.encoder["name"],
                              "resolution_bits": model.encoder["resolution_bits"]}
    assert loaded.uncertainty == model.uncertainty
    theta = np.linspace(-720.0, 720.0, 1001)
    np.testing.assert_array_equal(loaded.predict(theta), model.predict(theta))


def test_uncertainty_is_kept(tmp_path):
    model = load_model(DATA / "model_v1_ann.json")
    assert model.uncertainty["noise_std_arcmin"] == 0.14
    mean, std = load_model(save_model(model, tmp_path / "m.json")).predict([0.0, 90.0],
                                                                           return_std=True)
    assert np.all(std > 0.14)
    assert "uncertainty" not in model_to_dict(example_fourier())


def test_refuses_malformed_uncertainty(tmp_path):
    document = model_to_dict(load_model(DATA / "model_v1_ann.json"))
    document["uncertainty"]["model_std_arcmin"].pop()
    assert "uncertainty.model_std_arcmin" in refusal(write_document(tmp_path / "u.json", document))
    document["uncertainty"] = {"method": "x"}
    assert "grid_step_deg" in refusal(write_document(tmp_path / "u.json", document))


def test_file_layout_follows_the_contract(tmp_path):
    path = example_fourier().save(tmp_path / "m.json")
    document = json.loads(path.read_text(encoding="utf-8"))
    assert list(document) == ["format", "version", "kind", "encoder", "units", "normalisation",
                              "parameters", "training", "sha256"]
    assert document["format"] == "encal.model" and document["version"] == 1
    assert document["units"] == {"input": "deg", "output": "arcmin",
                                 "error": "encoder - reference"}
    assert document["normalisation"] == {}
    training = document["training"]
    for key in ("method", "algorithm", "epochs", "seed", "data_sha256", "n_points", "date",
                "encal_version", "options"):
        assert key in training
    assert training["seed"] == 3 and training["options"]["weights"] == [1.0, 2.0]
    assert training["encal_version"] == encal.__version__
    assert document["sha256"] == content_sha256(document)


def test_number_arrays_stay_on_one_line(tmp_path):
    text = example_lut().save(tmp_path / "m.json").read_text(encoding="utf-8")
    assert len(text.splitlines()) < 40  # 180 breaks and 4 x 180 coefficients
    assert text.endswith("}\n")


# every finite double a model may hold (the loader refuses |x| > 1e100, see runtime.MAX_PARAMETER_MAGNITUDE)
finite = st.floats(min_value=-1e100, max_value=1e100, allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(cos=st.lists(finite, min_size=1, max_size=6), data=st.data())
def test_floats_round_trip_exactly(tmp_path_factory, cos, data):
    sin = data.draw(st.lists(finite, min_size=len(cos), max_size=len(cos)))
    model = FourierModel(list(range(1, len(cos) + 1)), cos, sin)
    path = save_model(model, tmp_path_factory.mktemp("rt") / "m.json")
    assert same_floats(load_model(path).parameters(), model.parameters())


@settings(max_examples=40, deadline=None)
@given(values=st.lists(finite, min_size=2, max_size=6))
def test_dict_round_trip_is_exact(values):
    model = FourierModel(range(len(values)), values, values[::-1])
    document = model_to_dict(model)
    again = model_to_dict(model_from_dict(json.loads(dumps(document))))
    assert same_floats(again, document)


def test_resaving_a_loaded_model_gives_the_same_bytes(model, tmp_path):
    first = save_model(model, tmp_path / "a.json")
    second = save_model(load_model(first), tmp_path / "b.json")
    assert first.read_bytes() == second.read_bytes()


def test_model_to_dict_and_back():
    model = example_fourier()
    document = model_to_dict(model)
    assert document["kind"] == "fourier"
    rebuilt = model_from_dict(document)
    assert rebuilt.parameters() == model.parameters()


def test_hand_made_dict_loads_without_checksum():
    document = model_to_dict(example_fourier())
    del document["sha256"]
    with pytest.raises(ModelFileError, match="sha256"):
        model_from_dict(document)
    assert model_from_dict(document, verify_checksum=False).kind == "fourier"


def test_read_model_returns_the_checksum(tmp_path):
    path = save_model(example_fourier(), tmp_path / "m.json")
    model, sha = read_model(path)
    assert sha == json.loads(path.read_text())["sha256"] and len(sha) == 64


def test_public_names_are_exported_lazily():
    assert encal.save_model is save_model and encal.load_model is load_model
    assert encal.Compensator.__name__ == "Compensator"


# -- dates and reproducibility ---------------------------------------------------------

def test_reproducible_files_are_byte_identical(tmp_path, monkeypatch):
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    a = save_model(example_fourier(), tmp_path / "a.json", reproducible=True)
    b = example_fourier().save(tmp_path / "b.json", reproducible=True)
    assert a.read_bytes() == b.read_bytes()
    assert json.loads(a.read_text())["training"]["date"] == "1970-01-01T00:00:00Z"


def test_source_date_epoch_fixes_the_date(tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1800000000")
    a = save_model(example_fourier(), tmp_path / "a.json")
    b = save_model(example_fourier(), tmp_path / "b.json")
    assert a.read_bytes() == b.read_bytes()
    assert json.loads(a.read_text())["training"]["date"] == "2027-01-15T08:00:00Z"


def test_bad_source_date_epoch_is_refused(tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "yesterday")
    with pytest.raises(InputError, match="SOURCE_DATE_EPOCH"):
        save_model(example_fourier(), tmp_path / "a.json")


def test_date_is_utc_now_otherwise(tmp_path, monkeypatch):
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    path = save_model(example_fourier(), tmp_path / "a.json")
    date = json.loads(path.read_text())["training"]["date"]
    assert date.endswith("Z") and date > "2020" and len(date) == 20


# -- writing is atomic and refuses broken models ---------------------------------------

def test_save_into_missing_folder_fails_cleanly(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        save_model(example_fourier(), tmp_path / "missing" / "m.json")


class _BrokenFourier(FourierModel):
    kind = "fourier"

    def parameters(self):
        params = super().parameters()
        params["cos"][0] = math.nan
        return params


def test_non_finite_parameters_are_refused_and_nothing_is_written(tmp_path):
    path = save_model(example_fourier(), tmp_path / "m.json")
    before = path.read_bytes()
    with pytest.raises(ModelFileError, match=r"parameters\.cos"):
        save_model(_BrokenFourier([1], [1.0], [0.0]), path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["m.json"]


class _OtherKind(Model):
    kind = "polynomial"

    def _predict(self, theta_deg):
        return 0.0 * theta_deg

    def parameters(self):
        return {}

    def free_parameters(self):
        return 0

    @classmethod
    def from_parameters(cls, parameters, *, encoder=None, training=None):
        return cls(encoder=encoder, training=training)


def test_kinds_outside_the_format_are_refused(tmp_path):
    with pytest.raises(ModelFileError, match="polynomial"):
        save_model(_OtherKind(), tmp_path / "m.json")
    assert not (tmp_path / "m.json").exists()


def test_non_json_metadata_is_refused():
    model = example_fourier()
    model.training["rng"] = np.random.default_rng(0)
    with pytest.raises(InputError, match="training.rng"):
        model_to_dict(model)


def test_non_finite_metadata_becomes_null():
    model = example_fourier()
    model.training["final_mse"] = float("nan")
    assert model_to_dict(model)["training"]["final_mse"] is None


def test_only_models_are_saved(tmp_path):
    with pytest.raises(InputError, match="Model"):
        save_model({"kind": "fourier"}, tmp_path / "m.json")


# -- refusals on load: one sentence naming the file ------------------------------------

@pytest.fixture
def saved(tmp_path):
    path = save_model(example_fourier(), tmp_path / "m.json")
    return path, json.loads(path.read_text(encoding="utf-8"))


def refusal(path):
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    message = str(info.value)
    assert str(path) in message and "\n" not in message
    return message


def test_refuses_non_json_with_line_and_column(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text('{\n  "format": "encal.model",\n  oops\n}\n', encoding="utf-8")
    message = refusal(path)
    assert "line 3 column 3" in message


def test_refuses_non_utf8(tmp_path):
    path = tmp_path / "bad.json"
    path.write_bytes(b'{"format": "\xff"}')
    assert "UTF-8" in refusal(path)


def test_refuses_a_json_array(tmp_path):
    path = tmp_path / "list.json"
    path.write_text("[1, 2]", encoding="utf-8")
    assert "JSON object" in refusal(path) and "array" in refusal(path)


def test_refuses_another_format(saved):
    path, document = saved
    document["format"] = "sklearn.pickle"
    assert '"sklearn.pickle"' in refusal(write_document(path, document))


def test_refuses_a_file_without_format(saved):
    path, document = saved
    del document["format"]
    assert "no 'format' field" in refusal(write_document(path, document))


def test_refuses_a_newer_version(saved):
    path, document = saved
    document["version"] = 2
    assert "newer" in refusal(write_document(path, document))


@pytest.mark.parametrize("version", [0, "1", 1.0, None])
def test_refuses_invalid_versions(saved, version):
    path, document = saved
    document["version"] = version
    assert "version" in refusal(write_document(path, document))


def test_refuses_an_altered_file(saved):
    path, _ = saved
    text = path.read_text(encoding="utf-8").replace("3.25", "3.26")
    path.write_text(text, encoding="utf-8")
    assert "altered" in refusal(path)


def test_refuses_a_missing_checksum(saved):
    path, document = saved
    del document["sha256"]
    assert "sha256" in refusal(write_document(path, document, resign=False))


@pytest.mark.parametrize("field", ["encoder", "units", "normalisation", "parameters", "training",
                                   "kind"])
def test_refuses_missing_fields(saved, field):
    path, document = saved
    del document[field]
    assert f"{field} is missing" in refusal(write_document(path, document))


def test_refuses_missing_training_fields(saved):
    path, document = saved
    del document["training"]["date"]
    assert "date is missing" in refusal(write_document(path, document))


def test_refuses_an_unknown_kind(saved):
    path, document = saved
    document["kind"] = "spline"
    assert '"spline"' in refusal(write_document(path, document))


def test_refuses_other_units(saved):
    path, document = saved
    document["units"]["output"] = "arcsec"
    assert "units" in refusal(write_document(path, document))


@pytest.mark.parametrize("bits", [0, 33, 16.0, "16"])
def test_refuses_bad_resolution(saved, bits):
    path, document = saved
    document["encoder"]["resolution_bits"] = bits
    assert "resolution_bits" in refusal(write_document(path, document))


@pytest.mark.parametrize("change, field", [
    (lambda p: p["cos"].pop(), "parameters.cos"),
    (lambda p: p.update(sin="0"), "parameters.sin"),
    (lambda p: p["orders"].__setitem__(0, -1), "parameters.orders"),
    (lambda p: p["orders"].__setitem__(0, 1.5), "parameters.orders"),
    (lambda p: p["cos"].__setitem__(0, True), "parameters.cos"),
    (lambda p: p.pop("orders"), "parameters.orders"),
])
def test_refuses_wrong_parameter_shapes(saved, change, field):
    path, document = saved
    change(document["parameters"])
    assert field in refusal(write_document(path, document))


@pytest.mark.parametrize("orders", [[1, 1], [1, 32768], [1, 10**30]])
def test_runtime_and_encal_refuse_the_same_fourier_orders(saved, orders):
    # Repeated orders would be summed by one reader and refused by the other; orders beyond a C int
    # would be exported wrongly. Both readers refuse them, in the same sentence naming the file.
    path, document = saved
    document["parameters"].update(orders=orders, cos=[1.0, 2.0], sin=[0.0, 0.5])
    message = refusal(write_document(path, document))
    assert "parameters.orders to be a non-empty list of distinct integers from 0 to 32767" in message
    with pytest.raises(runtime.ModelFileError) as info:
        runtime.load(path)
    assert str(info.value) == message
    assert runtime.MAX_FOURIER_ORDER == encal.models.fourier.MAX_ORDER
    with pytest.raises(InputError, match="distinct integer orders from 0 to 32767"):
        FourierModel(orders[:2] if orders[1] != 10**30 else [1, 32768], [1.0, 2.0], [0.0, 0.5])


def test_a_model_class_refusal_names_the_file(saved, monkeypatch):
    path, _ = saved

    def refuse(cls, parameters, **kwargs):
        raise ModelFileError("fourier model parameters are odd")
    monkeypatch.setattr(FourierModel, "from_parameters", classmethod(refuse))
    assert refusal(path) == f"{path}: fourier model parameters are odd"


def test_refuses_non_finite_numbers(saved):
    path, document = saved
    text = path.read_text(encoding="utf-8").replace("3.25", "NaN")
    path.write_text(text, encoding="utf-8")
    assert "NaN" in refusal(path)


def test_refuses_normalisation_that_disagrees(saved):
    path, document = saved
    document["normalisation"] = {"input_gain": [1.0]}
    assert "normalisation" in refusal(write_document(path, document))


@pytest.mark.parametrize("change, field", [
    (lambda p: p.update(interpolation="quintic"), "interpolation"),
    (lambda p: p["breaks_deg"].reverse(), "increasing"),
    (lambda p: p["breaks_deg"].__setitem__(-1, 359.0), "one turn"),
    (lambda p: p["coefficients"].pop(), "coefficients"),
    (lambda p: p["coefficients"][0].pop(), "coefficients"),
])
def test_refuses_malformed_lookup_tables(tmp_path, change, field):
    document = model_to_dict(example_lut())
    change(document["parameters"])
    assert field in refusal(write_document(tmp_path / "lut.json", document))


def test_missing_file_is_a_model_file_error(tmp_path):
    """A missing file, a folder, None: encal's error naming it (issue 25), not the system's OSError or TypeError."""
    with pytest.raises(ModelFileError, match="nope.json: no such file; expected a model file"):
        load_model(tmp_path / "nope.json")
    with pytest.raises(ModelFileError, match="is a folder; expected a model file"):
        load_model(tmp_path)
    with pytest.raises(ModelFileError, match="expected the path of a model file .* got None"):
        load_model(None)


# -- the stored files of every format version ------------------------------------------

def test_stored_files_cover_every_kind():
    kinds = {json.loads(p.read_text(encoding="utf-8"))["kind"] for p in V1_FILES}
    assert kinds == {"fourier", "lut", "ann", "hybrid", "directional", "stack", "spectral"}
    assert kinds | {"arc"} == set(runtime.KINDS)  # arc: format version 4, tests/data/model_v4_arc.json


@pytest.mark.parametrize("path", V1_FILES, ids=lambda p: p.name)
def test_stored_files_load_and_predict_the_stored_values(path):
    expected = json.loads(EXPECTED.read_text(encoding="utf-8"))[path.name]
    model = load_model(path)
    np.testing.assert_allclose(model.predict(expected["theta_deg"]), expected["predict_arcmin"],
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(model.correct(expected["theta_deg"]), expected["correct_deg"],
                               rtol=0, atol=1e-9 / 60)


@pytest.mark.parametrize("path", V3_FILES, ids=lambda p: p.name)
def test_stored_files_of_version_3_run_in_the_runtime_by_their_form(path):
    # A kind encal does not know ('sine'), stored as a Fourier series: the standalone runtime evaluates it;
    # encal, which rebuilds models through its registry, says which kind it lacks.
    expected = json.loads((DATA / "expected_v3.json").read_text(encoding="utf-8"))[path.name]
    stored = runtime.load(path)
    np.testing.assert_allclose([stored.predict_arcmin(t) for t in expected["theta_deg"]], expected["predict_arcmin"],
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose([stored.correct_deg(t) for t in expected["theta_deg"]], expected["correct_deg"],
                               rtol=0, atol=1e-9 / 60)
    with pytest.raises(ModelFileError, match=r"'sine'"):
        load_model(path)


@pytest.mark.parametrize("change, field", [
    (lambda p: p["forward"].update(kind="directional"), "parameters.forward.kind"),
    (lambda p: p.pop("reverse"), "parameters.reverse"),
    (lambda p: p["reverse"]["parameters"].pop("breaks_deg"), "parameters.reverse.parameters"),
    (lambda p: p["forward"]["uncertainty"].update(noise_std_arcmin=-1.0), "uncertainties"),
])
def test_refuses_malformed_directional_models(tmp_path, change, field):
    document = json.loads((DATA / "model_v1_directional.json").read_text(encoding="utf-8"))
    change(document["parameters"])  # the parameters are checked before the normalisation
    assert field in refusal(write_document(tmp_path / "d.json", document))


@pytest.mark.parametrize("text, words", [
    ("[" * 100_000 + "]" * 100_000, "nested too deeply to read"),
    ('{"format": "encal.model", "version": 1' + "0" * 5000 + "}", "a number too long to read"),
])
def test_json_that_the_parser_cannot_hold_is_refused_in_one_sentence(tmp_path, text, words):
    path = tmp_path / "odd.json"
    path.write_text(text, encoding="utf-8")
    assert words in refusal(path)
    with pytest.raises(runtime.ModelFileError, match=words):
        runtime.load(path)

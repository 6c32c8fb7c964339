"""The registry of model kinds (encal.models.kind, encal.models.registry): one entry serves every user."""

import dataclasses
import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

import encal
from encal import runtime
from encal.deploy.cexport import export_c
from encal._core.errors import InputError
from encal.models import Model, ModelKind, kind_names, model_kind
from encal.models.kind import REGISTERED, register_kind
from encal.models.select import Candidate, families, fit_auto
from encal.models.stack import fit_stack

GRID = np.arange(0.0, 360.0, 2.0)


def test_every_kind_a_file_holds_is_registered_with_its_class():
    held = [name for name in kind_names() if model_kind(name).model_class is not None]
    assert sorted(held) == sorted(runtime.KINDS)
    for name in held:
        assert model_kind(name).model_class.kind == name
    assert sorted(kind_names(stack_member=True)) == sorted(runtime.MEMBER_KINDS)
    assert sorted(kind_names(directional_part=True)) == sorted(runtime.PART_KINDS)


def test_the_tie_rule_ranks_the_families_from_the_registry():
    assert families() == ("fourier", "lut", "hybrid", "ann", "stack")


def test_an_unknown_name_is_refused_with_the_known_ones():
    with pytest.raises(InputError, match=r"^The stack member must be one of fourier, spectral, lut, hybrid, ann\. "
                                         r"Got 'stack' instead\.$"):
        model_kind("stack", role="stack member", stack_member=True)
    with pytest.raises(InputError, match="must be a ModelKind"):
        register_kind(("toy", None, None))


class ConstantModel(Model):
    """A kind defined outside encal: predicts one constant (arcmin), stored as a Fourier series of order 0."""

    kind = "constant"
    form = "fourier"

    def __init__(self, value, *, encoder=None, training=None):
        super().__init__(encoder=encoder, training=training)
        self.value = float(value)

    def _predict(self, theta_deg):
        return np.full(np.shape(theta_deg), self.value)

    def free_parameters(self):
        return 1

    def parameters(self):
        return {"orders": [0], "cos": [self.value], "sin": [0.0]}

    @classmethod
    def from_parameters(cls, parameters, *, encoder=None, training=None):
        return cls(parameters["cos"][0], encoder=encoder, training=training)


def fit_constant(theta_enc_deg, error_arcmin):
    return ConstantModel(np.mean(error_arcmin))


@pytest.fixture
def constant_kind(monkeypatch):
    """The ``constant`` kind registered for one test, as its one registry entry would register it."""
    monkeypatch.setattr("encal.models.kind.REGISTERED", dict(REGISTERED))
    register_kind(ModelKind("constant", ConstantModel, fit_constant, simplicity=5, stack_member=True,
                            directional_part=True))


def test_one_registry_entry_makes_a_kind_usable_everywhere(constant_kind):
    error = 0.7 + 0.01 * np.sin(np.radians(GRID))
    cal = encal.Calibration(GRID, GRID + error / 60)
    fitted = encal.fit(cal, method="constant")
    assert fitted.kind == "constant" and fitted.value == pytest.approx(0.7, abs=1e-12)
    assert families()[0] == "constant"
    auto = fit_auto(GRID, error, candidates=[Candidate("constant"), Candidate("lut")], stack=False, rng=0)
    assert [row["family"] for row in auto.training["selection"]["table"]] == ["constant", "lut"]
    stack = fit_stack(GRID, error, members=[{"family": "constant"}, {"family": "lut"}], weights=[0.5, 0.5])
    assert stack.predict(2.0) == pytest.approx(0.5 * 0.7 + 0.5 * error[1], abs=1e-12)
    again = model_kind("stack").read(stack.parameters())
    assert again.members[0].kind == "constant"
    directional = model_kind("directional").read(
        {"forward": {"kind": "constant", "parameters": ConstantModel(0.3).parameters()},
         "reverse": {"kind": "constant", "parameters": ConstantModel(-0.3).parameters()}})
    assert float(directional.predict(10.0, direction=-1)) == -0.3


def _saved_and_run(model, path, directions=(None,)):
    """The model saved, loaded by encal and by the standalone runtime: their predictions at a few angles."""
    model.save(path)
    document = json.loads(path.read_text(encoding="utf-8"))
    theta = np.array([0.0, 1.0, 123.4, 359.9])
    loaded, standalone = encal.load_model(path), runtime.load(path)
    for direction in directions:
        expected = model.predict(theta, direction=direction)
        assert_allclose(loaded.predict(theta, direction=direction), expected, rtol=0, atol=1e-12)
        assert_allclose([standalone.predict_arcmin(t, direction) for t in theta], expected, rtol=0, atol=1e-12)
    return document, loaded


def test_a_new_kind_stored_in_an_existing_form_is_saved_and_run_without_a_runtime_change(constant_kind,
                                                                                         tmp_path):
    # runtime.py names neither the kind nor this test: the file names the form the runtime evaluates.
    assert "constant" not in runtime.KIND_FORMS
    document, loaded = _saved_and_run(ConstantModel(0.7, encoder={"name": "enc"}), tmp_path / "constant.json")
    assert (document["kind"], document["form"], document["version"], document["reading_sign"]) == \
        ("constant", "fourier", 3, 1)
    assert type(loaded) is ConstantModel and loaded.value == 0.7
    assert runtime.load(tmp_path / "constant.json").form == "fourier"

    stack = fit_stack(GRID, 0.7 + np.sin(np.radians(GRID)), members=[{"family": "constant"}, {"family": "fourier"}],
                      weights=[0.25, 0.75])
    document, loaded = _saved_and_run(stack, tmp_path / "stack.json")
    assert document["version"] == 3 and "form" not in document
    assert document["parameters"]["members"][0]["form"] == "fourier"
    assert "form" not in document["parameters"]["members"][1] and loaded.members[0].kind == "constant"

    directional = model_kind("directional").model_class(ConstantModel(0.3), ConstantModel(-0.3))
    document, _ = _saved_and_run(directional, tmp_path / "directional.json", directions=(1, -1, None))
    assert document["version"] == 3 and document["parameters"]["reverse"]["form"] == "fourier"

    source = export_c(ConstantModel(0.7), constants="double")["encal.c"]  # the formula of its form
    assert "static const double model_cos[1] = {\n    0.69999999999999996\n};" in source


def test_a_kind_stored_in_no_form_is_refused_by_save_in_one_sentence(constant_kind, tmp_path, monkeypatch):
    monkeypatch.setattr(ConstantModel, "form", None)
    with pytest.raises(encal.ModelFileError) as info:
        ConstantModel(0.7).save(tmp_path / "constant.json")
    assert str(info.value) == (
        "the constant model of an unnamed encoder: format version 4 holds the model kinds ann, arc, directional, "
        "fourier, hybrid, lut, spectral, stack, and other kinds stored in one of the forms ann, directional, "
        "fourier, hybrid, lut, stack (the class's 'form'); 'constant' gives no form")
    assert not (tmp_path / "constant.json").exists()


def test_the_files_of_the_kinds_the_format_names_carry_no_form(tmp_path):
    model = encal.fit(encal.Calibration(GRID, GRID + np.sin(np.radians(GRID)) / 60), method="fourier")
    document, _ = _saved_and_run(model, tmp_path / "fourier.json")
    assert "form" not in document and document["version"] == 1


@pytest.mark.parametrize("change, message", [
    (lambda d: d.update(version=2, reading_sign=1),
     "expected kind to be one of ann, arc, directional, fourier, hybrid, lut, spectral, stack, got \"constant\" (or, "
     "from format version 3, another kind's name with a form among ann, directional, fourier, hybrid, lut, stack)"),
    (lambda d: d.update(form="spline"),
     "expected form, the form the kind 'constant' is stored in, to be one of ann, directional, fourier, hybrid, "
     "lut, stack, got \"spline\""),
    (lambda d: d.update(kind="fourier"),
     "expected no form for the kind 'fourier', stored in its own form (fourier), got \"fourier\""),
])
def test_the_runtime_checks_a_files_kind_and_form(constant_kind, tmp_path, change, message):
    ConstantModel(0.7).save(tmp_path / "constant.json")
    document = json.loads((tmp_path / "constant.json").read_text(encoding="utf-8"))
    change(document)
    document["sha256"] = runtime.content_sha256(document)
    with pytest.raises(runtime.ModelFileError) as info:
        runtime.check_document(document, "constant.json")
    assert str(info.value) == f"constant.json: {message}"


def test_a_kind_is_a_frozen_record():
    with pytest.raises(dataclasses.FrozenInstanceError):
        model_kind("fourier").randomised = True


def test_a_kind_named_in_its_module_is_imported_on_first_use_and_checked_then(monkeypatch):
    import encal.models.kind

    registered = dict(REGISTERED, fourier=dataclasses.replace(REGISTERED["fourier"], model_class="FourierModel",
                                                              fit="fit_fourier"))
    monkeypatch.setattr("encal.models.kind.REGISTERED", registered)
    entry = register_kind(ModelKind("series", "FourierModel", "fit_fourier", module="encal.models.fourier"))
    assert registered["series"] is entry and entry.model_class == "FourierModel"  # nothing imported yet
    with pytest.raises(InputError, match=r"^the model class of kind 'series' must have kind = 'series'\. "
                                         r"Got 'fourier' instead\.$"):
        model_kind("series")
    loaded = model_kind("fourier")
    assert loaded.model_class.__name__ == "FourierModel" and callable(loaded.fit)
    assert encal.models.kind.REGISTERED["fourier"] is loaded and model_kind("fourier") is loaded


def test_a_kind_named_without_its_module_is_refused():
    with pytest.raises(InputError, match=r"^the model_class and fit of kind 'toy' given by name need the module "
                                         r"that defines them\. Got module=None instead\.$"):
        register_kind(ModelKind("toy", "ToyModel", "fit_toy"))

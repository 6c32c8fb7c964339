"""The registry of model kinds (encal.models.kind, encal.models.registry): one entry serves every user."""

import dataclasses

import numpy as np
import pytest

import encal
from encal import runtime
from encal.errors import InputError
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
    """A kind defined outside encal: predicts one constant (arcmin)."""

    kind = "constant"

    def __init__(self, value, *, encoder=None, training=None):
        super().__init__(encoder=encoder, training=training)
        self.value = float(value)

    def _predict(self, theta_deg):
        return np.full(np.shape(theta_deg), self.value)

    def free_parameters(self):
        return 1

    def parameters(self):
        return {"value": self.value}

    @classmethod
    def from_parameters(cls, parameters, *, encoder=None, training=None):
        return cls(parameters["value"], encoder=encoder, training=training)


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
        {"forward": {"kind": "constant", "parameters": {"value": 0.3}},
         "reverse": {"kind": "constant", "parameters": {"value": -0.3}}})
    assert float(directional.predict(10.0, direction=-1)) == -0.3


def test_a_kind_is_a_frozen_record():
    with pytest.raises(dataclasses.FrozenInstanceError):
        model_kind("fourier").randomised = True

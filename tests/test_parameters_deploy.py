"""The deployment's entry points check their options with encal's one message template (encal.parameters)."""

import numpy as np
import pytest

from encal.deploy import export_c
from encal.errors import InputError
from encal.models.base import Model
from encal.models.fourier import FourierModel

MODEL = FourierModel([1, 2], [3.0, 0.5], [-1.0, 0.25], encoder={"resolution_bits": 12})


@pytest.mark.parametrize(("call", "message"), [
    (lambda: export_c(MODEL, constants="single"),
     "The 'constants' parameter of export_c must be one of 'auto', 'float', 'double'. Got 'single' instead."),
    (lambda: export_c(MODEL, table="int8"),
     "The 'table' parameter of export_c must be one of None, 'int16', 'float32'. Got 'int8' instead."),
    (lambda: export_c(MODEL, bits=0),
     "The 'bits' parameter of export_c must be an int from 1 to 32 (the encoder resolution). Got 0 instead."),
    (lambda: export_c(MODEL, bits=12.0),
     "The 'bits' parameter of export_c must be an int from 1 to 32 (the encoder resolution). Got 12.0 instead."),
    (lambda: export_c(MODEL, bits=30, table="int16"),
     "The 'bits' parameter of export_c must be an int from 1 to 20 (the encoder resolution of a C table). "
     "Got 30 instead."),
    (lambda: export_c(MODEL, prefix="2fast"),
     "The 'prefix' parameter of export_c must be a C identifier (letters, digits, '_', not starting with a "
     "digit, '__' or '_' + capital, not a keyword). Got '2fast' instead."),
])
def test_export_c_uses_the_template(call, message):
    with pytest.raises(InputError) as info:
        call()
    assert str(info.value) == message


class _Sine(Model):
    """A kind outside encal's registry, stored in the Fourier form (one sine, arcmin)."""

    kind = "unregistered-sine"
    form = "fourier"

    def _predict(self, theta_deg):
        return 2.0 * np.sin(np.radians(theta_deg)) + 0.1

    def free_parameters(self):
        return 2

    def parameters(self):
        return {"orders": [0, 1], "cos": [0.1, 0.0], "sin": [0.0, 2.0]}

    @classmethod
    def from_parameters(cls, parameters, *, encoder=None, training=None):
        return cls(encoder=encoder, training=training)


def test_export_c_checks_float_constants_of_a_kind_outside_the_registry_by_its_form():
    # The check evaluates the form the C code evaluates; the unknown kind is not mistaken for constants that
    # float32 cannot hold.
    source = export_c(_Sine(encoder={"resolution_bits": 12}))["encal.c"]
    assert "static const float model_cos[2]" in source
    assert "constants stored as float (they change the model by at most" in source
    assert "float32 cannot hold them" not in source

"""The deployment's entry points check their options with encal's one message template (encal._core.parameters)."""

import io

import numpy as np
import pytest

from encal.deploy import Compensator, export_c, save_table
from encal.deploy.stream import correct_stream
from encal.deploy.firmware import (export_klipper, export_mechaduino, export_moteus, export_simplefoc,
                                   export_tinymovr, read_cal_capture, read_moteus_conf, read_tinymovr)
from encal._core.errors import InputError
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


@pytest.mark.parametrize(("call", "message"), [
    (lambda: export_klipper(MODEL, full_steps=4),
     "The 'full_steps' parameter of export_klipper must be an int from 8 to 4096 (full steps per turn). "
     "Got 4 instead."),
    (lambda: export_klipper(MODEL, full_steps=200.0),
     "The 'full_steps' parameter of export_klipper must be an int from 8 to 4096 (full steps per turn). "
     "Got 200.0 instead."),
    (lambda: export_mechaduino(MODEL, bits=16),
     "The 'bits' parameter of export_mechaduino must be 14 or None (Mechaduino's lookup[16384] is for its 14-bit "
     "AS5047D; default the model file's resolution). Got 16 instead."),
    (lambda: export_moteus(MODEL, source=3),
     "The 'source' parameter of export_moteus must be an int from 0 to 2 (moteus's motor_position.sources.K). "
     "Got 3 instead."),
    (lambda: export_moteus(MODEL, bits=0),
     "moteus: a 0-bit encoder cannot hold the table; expected --bits from 8 (its 256 nodes need at least 256 codes) "
     "to 24 (the largest cpr moteus handles)"),
    (lambda: read_moteus_conf("", source=-1),
     "The 'source' parameter of read_moteus_conf must be an int from 0 to 2 (moteus's motor_position.sources.K, "
     "or None for the only one). Got -1 instead."),
    (lambda: read_cal_capture("capture.log", pole_pairs=0),
     "The 'pole_pairs' parameter of read_cal_capture must be an int from 1 to 1000 (pole pairs: no motor has "
     "more). Got 0 instead."),
    (lambda: export_simplefoc(MODEL, nodes=1),
     "The 'nodes' parameter of export_simplefoc must be an int from 2 to 4096 (CalibratedSensor's n_lut, at most "
     "one per code of the 12-bit grid). Got 1 instead."),
    (lambda: export_simplefoc(MODEL, bits=True),
     "The 'bits' parameter of export_simplefoc must be an int from 1 to 32 (the encoder resolution, or None for "
     "the model file's, else 16). Got True instead."),
    (lambda: export_tinymovr(MODEL, bits=25),
     "The 'bits' parameter of export_tinymovr must be an int from 6 to 24 (the sensor resolution; Tinymovr's rule "
     "works in ticks of 2^bits per turn). Got 25 instead."),
    (lambda: read_tinymovr("int16_t rec_table[1] = {0};", bits=5),
     "The 'bits' parameter of read_tinymovr must be an int from 6 to 24 (the sensor resolution; Tinymovr's rule "
     "works in ticks of 2^bits per turn). Got 5 instead."),
])
def test_the_firmware_exports_and_imports_use_the_template(call, message):
    with pytest.raises(InputError) as info:
        call()
    assert str(info.value) == message


@pytest.mark.parametrize(("options", "message"), [
    ({"skip_bad": "yes"}, "The 'skip_bad' parameter of correct_stream must be True or False. Got 'yes' instead."),
    ({"exact": 1}, "The 'exact' parameter of correct_stream must be True or False. Got 1 instead."),
    ({"direction": 0},
     "The 'direction' parameter of correct_stream must be +1 (forward), -1 (reverse) or None (unknown). "
     "Got 0 instead."),
    ({"direction": np.array([1, -1])},
     "The 'direction' parameter of correct_stream must be +1 (forward), -1 (reverse) or None (unknown). "
     "Got array([ 1, -1]) instead."),
    ({"name": 3}, "The 'name' parameter of correct_stream must be a str. Got an object of type int instead."),
])
def test_correct_stream_uses_the_template_and_writes_nothing(options, message):
    sink = io.BytesIO()
    with pytest.raises(InputError) as info:
        correct_stream(Compensator(MODEL), io.BytesIO(b"1.0\n2.0\n"), sink, **options)
    assert str(info.value) == message
    assert sink.getvalue() == b""


def test_the_compensator_and_the_table_file_check_their_arguments(tmp_path):
    with pytest.raises(InputError) as info:
        Compensator(MODEL).predict([1.0, 2.0], return_std="yes")
    assert str(info.value) == "The 'return_std' parameter of predict must be True or False. Got 'yes' instead."
    with pytest.raises(InputError) as info:
        save_table(np.zeros(256, dtype=np.int16), tmp_path / "t.bin")
    assert str(info.value) == ("The 'table' parameter of save_table must be a CorrectionTable. "
                               "Got an object of type ndarray instead.")
    assert list(tmp_path.iterdir()) == []

"""Dense per-code correction tables: bounds on their deviation from the model, and the file."""

import struct
import zlib

import numpy as np
import pytest

from encal.deploy import Compensator, CorrectionTable, compile_table, load_table, save_table
from encal._core.errors import InputError, ModelFileError
from encal.models.fourier import FourierModel
from tests._paths import DATA

FILES = {"fourier": DATA / "model_v1_fourier.json", "lut": DATA / "model_v1_lut.json",
         "lut_linear": DATA / "model_v1_lut_linear.json",
         "directional": DATA / "model_v1_directional.json"}


@pytest.fixture(scope="module", params=sorted(FILES))
def compensator(request):
    return Compensator(FILES[request.param])


@pytest.fixture(scope="module", params=["int16", "float32"])
def table(request, compensator):
    return compile_table(compensator, 16, dtype=request.param), compensator


def test_table_matches_the_model_at_every_code_within_its_quantisation(table):
    table, comp = table
    codes = np.arange(2**16)
    exact = comp.predict(codes * (360.0 / 2**16))
    deviation = np.abs(table.predict_counts(codes) - exact)
    assert deviation.max() == pytest.approx(table.quantisation_arcmin, rel=1e-12, abs=1e-300)
    if table.dtype == "int16":
        assert table.quantisation_arcmin <= table.scale_arcmin / 2
    else:
        assert table.quantisation_arcmin <= np.abs(exact).max() * 2.0**-24
    corrected = comp.correct(codes * (360.0 / 2**16))
    difference = (table.correct_counts(codes) - corrected + 180.0) % 360.0 - 180.0
    assert np.abs(difference).max() <= table.quantisation_arcmin / 60 + 1e-12


def test_between_codes_deviation_bounds_nearest_code_lookups(table):
    table, comp = table
    # Four angles per code step, spread over whole steps: 0, 1/4, 1/2, 3/4 of a step.
    theta = np.arange(4 * 2**16) * (360.0 / 2**18)
    deviation = np.abs(table.predict(theta) - comp.predict(theta))
    assert deviation.max() <= table.quantisation_arcmin + table.between_codes_arcmin + 1e-12
    assert table.between_codes_arcmin > 0


def test_int16_unit_is_the_finest_power_of_two_that_fits(compensator):
    table = compile_table(compensator, 12, dtype="int16")
    exponent = np.log2(table.scale_arcmin)
    assert exponent == int(exponent)
    largest = np.abs(table.error_arcmin).max()
    assert largest / table.scale_arcmin <= 32767
    assert largest / (table.scale_arcmin / 2) > 32767 - 1  # half the unit would not fit


def test_bits_default_to_the_model_file(compensator):
    assert compile_table(compensator).bits == 16


def test_small_and_zero_models():
    zero = FourierModel([1], [0.0], [0.0])
    table = compile_table(zero, 4)
    assert table.values.size == 16 and not table.values.any() and table.quantisation_arcmin == 0
    assert np.all(table.correct_counts(np.arange(16)) == np.arange(16) * 22.5)


def test_corrected_angles_are_in_range():
    model = FourierModel([0], [30.0], [0.0])  # +30 arcmin: code 0 corrects to 359.5 deg
    table = compile_table(model, 8)
    assert table.correct_counts(0) == pytest.approx(359.5)
    corrected = table.correct_counts(np.arange(256, dtype=np.uint16))
    assert np.all((corrected >= 0) & (corrected < 360))


def test_far_readings_keep_their_correction():
    # At 4e14 degrees neighbouring doubles are 0.0625 degrees apart, more than a 1 arcmin correction:
    # subtracting it before wrapping would lose it. The correction must hold at any turn.
    model = FourierModel([0], [1.0], [0.0])
    table = compile_table(model, 16)
    for turns in (0, 2**20, 2**40, -(2**40)):
        reading = 90.0 + 360.0 * turns
        assert table.correct(reading) == pytest.approx(90.0 - 1.0 / 60.0, abs=1e-9)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int32, np.int64, np.uint64])
def test_any_integer_code_type(dtype):
    table = compile_table(FILES["fourier"], 8)
    codes = np.arange(256).astype(dtype)
    np.testing.assert_array_equal(table.correct_counts(codes), table.correct_counts(np.arange(256)))


@pytest.mark.parametrize("codes, message", [
    (np.array([1.5]), "integer"), (np.array([-1]), "from 0 to 255"),
    (np.array([256]), "from 0 to 255"), (np.array([70000], dtype=np.uint32), "from 0 to 255"),
])
def test_invalid_codes_are_refused(codes, message):
    table = compile_table(FILES["fourier"], 8)
    with pytest.raises(InputError, match=message):
        table.correct_counts(codes)


@pytest.mark.parametrize("bits", [0, 25, 16.0, True])
def test_invalid_bits_are_refused(bits):
    with pytest.raises(InputError) as info:
        compile_table(FILES["fourier"], bits)
    assert str(info.value) == ("The 'bits' parameter of compile_table must be an int from 1 to 24 (the encoder "
                               f"resolution, or None for the model file's). Got {bits!r} instead.")


def test_missing_bits_are_refused():
    with pytest.raises(InputError, match="pass bits"):
        compile_table(FourierModel([1], [1.0], [0.0]))


def test_unknown_dtype_is_refused():
    with pytest.raises(InputError) as info:
        compile_table(FILES["fourier"], 8, dtype="int8")
    assert str(info.value) == "The 'dtype' parameter of compile_table must be one of 'int16', 'float32'. Got 'int8' " \
                              "instead."


@pytest.mark.parametrize(("change", "message"), [
    ({"bits": 25}, "The 'bits' parameter of CorrectionTable must be an int from 1 to 24. Got 25 instead."),
    ({"values": np.zeros(255, dtype=np.int16)},
     "The 'values' parameter of CorrectionTable must be an int16 or float32 array of 2^bits = 256 entries. "
     "Got an array of int16 and shape (255,) instead."),
    ({"values": np.zeros(256)},
     "The 'values' parameter of CorrectionTable must be an int16 or float32 array of 2^bits = 256 entries. "
     "Got an array of float64 and shape (256,) instead."),
    ({"values": [0] * 256}, "The 'values' parameter of CorrectionTable must be an ndarray. "
                            "Got an object of type list instead."),
    ({"scale_arcmin": 0.0},
     "The 'scale_arcmin' parameter of CorrectionTable must be a finite number > 0 (arc-minutes). Got 0.0 instead."),
    ({"between_codes_arcmin": float("nan")},
     "The 'between_codes_arcmin' parameter of CorrectionTable must be a finite number >= 0 (arc-minutes). "
     "Got nan instead."),
    ({"reading_sign": 0}, "The 'reading_sign' parameter of CorrectionTable must be 1 or -1. Got 0 instead."),
])
def test_the_constructor_checks_its_fields(change, message):
    fields = {"bits": 8, "values": np.zeros(256, dtype=np.int16), "scale_arcmin": 2.0**-10,
              "quantisation_arcmin": 0.0, "between_codes_arcmin": 0.0, **change}
    with pytest.raises(InputError) as info:
        CorrectionTable(**fields)
    assert str(info.value) == message


# -- the file ---------------------------------------------------------------------------

@pytest.mark.parametrize("dtype", ["int16", "float32"])
def test_file_round_trip(tmp_path, dtype):
    table = compile_table(FILES["lut"], 12, dtype=dtype)
    path = save_table(table, tmp_path / "t.bin")
    assert path.stat().st_size == 80 + 2**12 * table.values.itemsize
    again = load_table(path)
    np.testing.assert_array_equal(again.values, table.values)
    assert again.values.dtype == table.values.dtype
    for name in ("bits", "scale_arcmin", "quantisation_arcmin", "between_codes_arcmin",
                 "model_sha256"):
        assert getattr(again, name) == getattr(table, name)
    assert again.model_sha256 == Compensator(FILES["lut"]).sha256


def test_file_layout_is_as_documented(tmp_path):
    table = compile_table(FILES["fourier"], 10)
    raw = table.save(tmp_path / "t.bin").read_bytes()
    magic, version, bits, code, header, entries, crc = struct.unpack_from("<8sHBBIII", raw)
    assert (magic, version, bits, code, header, entries) == (b"ENCALTAB", 1, 10, 1, 80, 1024)
    scale, quantisation, between = struct.unpack_from("<ddd", raw, 24)
    assert scale == table.scale_arcmin and quantisation == table.quantisation_arcmin
    assert raw[48:80].hex() == table.model_sha256
    values = np.frombuffer(raw, dtype="<i2", offset=80)
    assert zlib.crc32(raw[80:]) == crc
    np.testing.assert_allclose(values * scale, table.error_arcmin)


def test_unknown_model_checksum_is_stored_as_zeros(tmp_path):
    table = compile_table(FourierModel([1], [1.0], [0.0]), 6)
    assert table.model_sha256 is None
    assert load_table(table.save(tmp_path / "t.bin")).model_sha256 is None


@pytest.mark.parametrize("damage, message", [
    (lambda raw: b"NOTATABL" + raw[8:], "ENCALTAB"),
    (lambda raw: raw[:-2], "truncated"),
    (lambda raw: raw[:-1] + bytes([raw[-1] ^ 1]), "CRC-32"),
    (lambda raw: raw[:8] + struct.pack("<H", 3) + raw[10:], "newer"),
    (lambda raw: raw[:8] + struct.pack("<H", 2) + raw[10:], "header of at least 88 bytes"),
    (lambda raw: raw[:11] + bytes([7]) + raw[12:], "dtype code"),
    (lambda raw: raw[:20], "ENCALTAB"),
    (lambda raw: raw[:24] + struct.pack("<d", float("inf")) + raw[32:],
     "the table header is damaged: The 'scale_arcmin' parameter of CorrectionTable must be a finite number > 0 "
     r"\(arc-minutes\). Got inf instead."),
])
def test_damaged_files_are_refused(tmp_path, damage, message):
    path = compile_table(FILES["fourier"], 8).save(tmp_path / "t.bin")
    path.write_bytes(damage(path.read_bytes()))
    with pytest.raises(ModelFileError, match=message) as info:
        load_table(path)
    assert str(path) in str(info.value)

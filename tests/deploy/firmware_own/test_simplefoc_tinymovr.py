"""SimpleFOC and Tinymovr exports through the firmwares' own code (issue 26).

The harnesses (``tests/deploy/firmware_own/simplefoc.py``, ``tinymovr.py``) compile Arduino-FOC-drivers'
``CalibratedSensor.cpp`` (1.0.8, 1.0.9) with the core's ``Sensor.cpp``, and Tinymovr's ``sensor.h``,
from ``../shared/firmware/``; every code of a 14- and 16-bit encoder goes through them. Each row of the
matrix (bits, reversed encoder, reference zero from 0 to 30 degrees, each SimpleFOC version) must state
the round trip the firmware's own code gives (RMS within 5 %), or be refused.
"""

import numpy as np
import pytest

from encal.deploy import Compensator
from encal.deploy.firmware import export_simplefoc, export_tinymovr, read_simplefoc, read_tinymovr
from encal._core.errors import InputError
from tests.deploy.firmware_own import agrees
from tests.deploy.firmware_own import simplefoc as sfoc
from tests.deploy.firmware_own import tinymovr as tiny

needs_simplefoc = pytest.mark.skipif(sfoc.unavailable() is not None, reason=str(sfoc.unavailable()))
needs_tinymovr = pytest.mark.skipif(tiny.unavailable() is not None, reason=str(tiny.unavailable()))


@needs_simplefoc
@pytest.mark.parametrize("version", sfoc.VERSIONS)
@pytest.mark.parametrize("bits", sfoc.BITS)
@pytest.mark.parametrize("reading_sign", [1, -1])
@pytest.mark.parametrize("zero_deg", [0.0, 30.0])
def test_simplefoc_states_what_its_own_code_does(version, bits, reading_sign, zero_deg):
    row = sfoc.row(version, bits, zero_deg, reading_sign)
    assert not row.refused and agrees(row), row
    assert row.measured_max <= row.stated_max * 1.05 + 1e-3


@needs_simplefoc
@pytest.mark.slow
def test_simplefoc_matrix():
    rows = list(sfoc.matrix())
    assert len(rows) == 3 * 2 * 2 * 8
    assert all(agrees(row) for row in rows), [row for row in rows if not agrees(row)]


@needs_tinymovr
@pytest.mark.parametrize("bits", sfoc.BITS)
@pytest.mark.parametrize("reading_sign", [1, -1])
def test_tinymovr_matrix(bits, reading_sign):
    for zero_deg in sfoc.ZEROS_DEG:
        row = tiny.row(bits, zero_deg, reading_sign)
        assert not row.refused and agrees(row), row


@needs_simplefoc
def test_a_1_0_8_table_through_1_0_9_doubles_the_error():
    """What the issue measured: 1.0.9 subtracts the LUT, so a table of corrections adds the error twice."""
    model = sfoc.profile_model(14, 0.0, 1)
    old = export_simplefoc(model, firmware_version="1.0.8")
    through_1_0_8 = sfoc.measured(model, sfoc.firmware_angles("1.0.8", sfoc.lut_values(old.text, "1.0.8"), 14),
                                  old.offset_arcmin, 14)[0]
    # the same 128 values given to 1.0.9's constructor
    through_1_0_9 = sfoc.measured(model, sfoc.firmware_angles("1.0.9", sfoc.lut_values(old.text, "1.0.8"), 14),
                                  old.offset_arcmin, 14)[0]
    # the raw angles themselves miss the model's correction by the correction
    correction_rms = sfoc.measured(model, np.arange(2**14) * (2 * np.pi / 2**14), old.offset_arcmin, 14)[0]
    assert through_1_0_8 < 0.2 * correction_rms
    assert through_1_0_9 == pytest.approx(2 * correction_rms, rel=0.1)


@needs_simplefoc
@pytest.mark.parametrize("version", ["1.0.8", "1.0.9"])
def test_the_core_drops_a_negative_angle_so_node_0_holds_zero(version):
    """Known truth of the compiled core: a LUT that puts the angle below 0 near raw 0 leaves it stale there."""
    sign = 1.0 if version == "1.0.8" else -1.0
    lut = np.full(128 if version == "1.0.8" else 200, sign * -0.01, dtype=np.float32)  # 0.01 rad below raw
    angles = sfoc.firmware_angles(version, lut, 14)
    raw = np.arange(2**14) * (2 * np.pi / 2**14)
    stale = raw < 0.01
    assert np.all(angles[stale] == angles[-1])  # the last code's angle, read before code 0
    assert np.allclose(angles[~stale], raw[~stale] - 0.01, atol=1e-6)
    # encal's tables hold 0 at node 0: every angle of every code is its own (none stale, none negative)
    out = export_simplefoc(sfoc.profile_model(14, 30.0, 1), firmware_version=version)
    values = sfoc.lut_values(out.text, version)
    assert values[0] == 0.0
    assert np.all(np.diff(sfoc.firmware_angles(version, values, 14)) > 0)


def test_uint16_model_decodes_as_the_forks_code():
    """The uint16 rule: 32767 is 0 rad; one count is 1/10430.2191955 rad, subtracted."""
    lut = np.full(200, 32767 + 10, dtype=np.uint16)
    angles = sfoc.uint16_model_angles(lut, 14)
    raw = (np.arange(2**14).astype(np.float32) / np.float32(2**14)) * np.float32(6.28318530718)
    late = raw > 0.01
    assert np.allclose(angles[late], raw[late] - 10 / 10430.2191955, atol=1e-6)
    assert np.all(angles >= 0)  # normalised into [0, 2 pi)


def test_versions_default_nodes_and_load_instructions():
    model = sfoc.profile_model(14, 0.0, 1)
    assert "float calibrationLut[200]" in export_simplefoc(model).text  # default: the 1.0.9 release
    text_108 = export_simplefoc(model, firmware_version="1.0.8").text
    assert "float calibrationLut[128]" in text_108 and "firmware_version=1.0.8" in text_108
    text_u16 = export_simplefoc(model, firmware_version="uint16").text
    assert "uint16_t calibrationLut[200]" in text_u16
    assert "CalibratedSensor sensor_calibrated(sensor, 200, calibrationLut)" in text_u16
    with pytest.raises(InputError, match="firmware_version"):
        export_simplefoc(model, firmware_version="1.0.10")


def test_read_simplefoc_applies_each_version_as_its_code_does():
    model = sfoc.profile_model(14, 0.0, 1)
    theta = np.arange(0.0, 360.0, 0.5)
    for version in sfoc.VERSIONS:
        out = export_simplefoc(model, firmware_version=version)
        reread = read_simplefoc(out.text)  # the file says its version
        gap = reread.predict(theta) - out.offset_arcmin - model.predict(theta)
        assert np.sqrt(np.mean(gap**2)) <= out.rms_error_arcmin * 2 + 0.05, version
        # what the firmware itself prints, without encal's comment
        bare = out.text[out.text.index("float" if version != "uint16" else "uint16_t"):]
        if version == "uint16":
            printed = read_simplefoc("// Calibrated Sensor LUT\n" + bare)
            assert np.allclose(printed.predict(theta), reread.predict(theta))
        else:
            with pytest.raises(InputError, match="--firmware-version"):
                read_simplefoc(bare)
            assert np.allclose(read_simplefoc(bare, firmware_version=version).predict(theta), reread.predict(theta))


def test_read_simplefoc_1_0_9_print_out_is_the_error():
    """1.0.9's calibrate() prints its LUT (the error) with these lines around it; the sign is not flipped."""
    printed = ("Constructing LUT.\n\nfloat calibrationLut[4] = {\n0.001000, 0.000000, -0.001000, 0.000000};\n"
               "float zero_electric_angle = 1.234567;\nDirection sensor_direction = Direction::CW;\n")
    model = read_simplefoc(printed)
    assert model.predict(np.array([0.0]))[0] == pytest.approx(np.degrees(0.001) * 60)  # error = +LUT
    with pytest.raises(InputError, match="1.0.9, not 1.0.8"):
        read_simplefoc(printed, firmware_version="1.0.8")


def test_read_simplefoc_uint16_print_out_decoded():
    printed = "// Calibrated Sensor LUT\nuint16_t calibrationLut[2] = {\n32777, 32767\n};\n"
    model = read_simplefoc(printed)
    assert model.predict(np.array([0.0]))[0] == pytest.approx(np.degrees(10 / 10430.2191955) * 60, rel=1e-6)
    with pytest.raises(InputError, match="uint16"):
        read_simplefoc("uint16_t calibrationLut[2] = {70000, 1};")
    with pytest.raises(InputError, match="uint16, not 1.0.9"):
        read_simplefoc(printed, firmware_version="1.0.9")


@pytest.mark.parametrize("text, message", [
    ("float calibrationLut[2] = {};\n", "holds no values"),
    ("float calibrationLut[2] = {0.1,\n nan};\n", "line 2: element 1 of calibrationLut.. is 'nan', expected a finite"),
    ("float calibrationLut[2] = {1e999, 0.1};\n", "element 0 .* expected a finite"),
])
def test_read_simplefoc_refuses_empty_and_non_finite(text, message):
    with pytest.raises(InputError, match=message):
        read_simplefoc(text, firmware_version="1.0.9")


def test_read_tinymovr_refuses_non_finite():
    with pytest.raises(InputError, match="element 3 of rec_table.. is 'inf'|element 3 of rec_table"):
        read_tinymovr("int32_t rec_table[64] = {0, 1, 2, inf};\n", bits=14)


@needs_tinymovr
@pytest.mark.parametrize("bits", [21, 24])
def test_tinymovr_above_20_bits_states_what_its_own_code_does(bits):
    """Issue 25: 21 to 24 bits failed with a broadcast error; the round trip is measured on 2^20 codes."""
    model = sfoc.profile_model(bits, 0.0, 1)
    out = export_tinymovr(model, bits=bits)
    assert "int32_t rec_table[64]" in out.text and f"native ticks of the {bits}-bit sensor" in out.text
    codes = np.arange(2**20, dtype=np.int64) << (bits - 20)
    angles = tiny.rectified(tiny.table_values(out.text), bits, codes) * (2 * np.pi / 2**bits)
    expected = Compensator(model).correct(codes * (360.0 / 2**bits)) - out.offset_arcmin / 60
    gap = ((np.degrees(angles) - expected + 180) % 360 - 180) * 60
    assert np.sqrt(np.mean(gap**2)) == pytest.approx(out.rms_error_arcmin, rel=0.05)


def test_tinymovr_table_fits_int32_arithmetic():
    from encal.models.fourier import FourierModel

    huge = FourierModel([1], [0.0], [3000.0], encoder={"resolution_bits": 24})  # 50 degrees of error
    with pytest.raises(InputError, match="int32_t"):
        export_tinymovr(huge, bits=24)

"""Known truth through fit, export and each firmware's own code (task edge5).

The harnesses beside this file measure a written table against the *model* encal exported. Here the model is
fitted first, to a calibration whose error is known exactly (a profile of the reference angle and a zero offset
of 40 arcmin, an encoder counting with or against its reference), and every 14-bit code goes through the
firmware's own run-time code (moteus's ``motor_position.h``, SimpleFOC 1.0.9's ``CalibratedSensor``,
Tinymovr's ``sensor.h``, Klipper's ``angle.py``; Mechaduino's ``lookup[]`` is read as its controller reads it):
the angle the firmware then holds must be the *reference* angle of that code, less the constant encal says it
left out, within the round trip encal printed plus the fit's own error. That is also the sign convention
checked from first principles: error = encoder - reference, and a flashed table moves each reading toward the
reference (about the constant left out, the raw readings are up to 4.6 arcmin off it, RMS 2.4; the firmware's
RMS 0.16 of that for Tinymovr, which stores whole ticks of 1.3 arcmin, less for the others; a table of the wrong
sign would double the profile).
"""

import numpy as np
import pytest

import encal
from encal.deploy import Compensator
from encal.deploy.firmware import (export_klipper, export_mechaduino, export_moteus, export_simplefoc,
                                   export_tinymovr)
from tests.deploy.firmware_own import klipper as kl
from tests.deploy.firmware_own import mechaduino as mech
from tests.deploy.firmware_own import moteus as mot
from tests.deploy.firmware_own import simplefoc as sfoc
from tests.deploy.firmware_own import tinymovr as tiny

BITS = 14
CODES = np.arange(2**BITS)
OFFSET_ARCMIN = 40.0


def profile(reference_deg):
    """The encoder's error at a reference angle, arc-minutes: a zero offset and a smooth profile."""
    r = np.radians(reference_deg)
    return OFFSET_ARCMIN + 3.0 * np.sin(r + 0.4) + 1.5 * np.cos(2 * r) + 0.5 * np.sin(3 * r + 1.0)


def reference_of(reading_deg, sign):
    """The reference angle whose reading (``sign`` -1: counting against the reference) is ``reading_deg``."""
    target = sign * np.asarray(reading_deg, dtype=float)
    reference = target.copy()
    for _ in range(60):  # reference + profile(reference) / 60 = target, a contraction
        reference = target - profile(reference) / 60.0
    return reference % 360.0


def gap_arcmin(angle_deg, truth_deg, period=360.0):
    return ((np.asarray(angle_deg) - truth_deg + period / 2) % period - period / 2) * 60.0


@pytest.fixture(scope="module", params=[1, -1], ids=["forward", "reversed"])
def fitted(request, tmp_path_factory):
    """(Compensator, sign, truth of every code, the fit's own largest error against it, arcmin)."""
    sign = request.param
    reference = np.arange(0.0, 360.0, 1.0) + 0.3
    reading = (sign * (reference + profile(reference) / 60.0)) % 360.0
    path = tmp_path_factory.mktemp("truth") / "cal.csv"
    path.write_text("reference_deg,encoder_deg\n" + "".join(f"{r!r},{e!r}\n" for r, e in
                                                            zip(reference.tolist(), reading.tolist())))
    comp = Compensator(encal.fit(encal.read_calibration(path, reverse=sign == -1, resolution_bits=BITS),
                                 "spectral"))
    truth = reference_of(CODES * 360.0 / 2**BITS, sign)
    fit_error = float(np.max(np.abs(gap_arcmin(comp.correct(CODES * 360.0 / 2**BITS), truth))))
    assert fit_error < 1e-3
    return comp, sign, truth, fit_error


def check(firmware_deg, truth_deg, written, fit_error, period=360.0, raw_deg=None):
    """The firmware's angle is the truth less the constant left out, within the stated round trip; and, given
    the raw readings in the same frame, far nearer the truth than they are (the table's sign)."""
    gap = gap_arcmin(firmware_deg, truth_deg, period) + written.offset_arcmin
    assert np.max(np.abs(gap)) <= written.max_error_arcmin + fit_error + 1e-3, (np.max(np.abs(gap)), written)
    if raw_deg is not None:
        raw = gap_arcmin(raw_deg, truth_deg, period) + written.offset_arcmin  # the profile, about its mean
        assert np.sqrt(np.mean(gap**2)) < 0.25 * np.sqrt(np.mean(raw**2))  # Tinymovr 0.16 (whole ticks), others less
    return gap


@pytest.mark.skipif(mot.unavailable() is not None, reason=str(mot.unavailable()))
def test_moteus_holds_the_reference(fitted):
    comp, sign, truth, fit_error = fitted
    written = export_moteus(comp, bits=BITS)
    table, scale = mot._table_and_scale(mot.device_commands(written.text), 0)
    _, compensated = mot.firmware_correction(table, scale, BITS, 1, 0)
    # the firmware works in the reading's sense: its angle is sign x the reference's
    check(compensated * 360.0 / 2**BITS, sign * truth, written, fit_error, raw_deg=CODES * 360.0 / 2**BITS)
    assert written.offset_arcmin == pytest.approx(sign * -OFFSET_ARCMIN, abs=0.01)  # the mean correction


@pytest.mark.skipif(sfoc.unavailable() is not None, reason=str(sfoc.unavailable()))
def test_simplefoc_holds_the_reference(fitted):
    comp, sign, truth, fit_error = fitted
    written = export_simplefoc(comp, bits=BITS, firmware_version="1.0.9")
    angles = sfoc.firmware_angles("1.0.9", sfoc.lut_values(written.text, "1.0.9"), BITS)
    check(np.degrees(angles.astype(float)), sign * truth, written, fit_error, raw_deg=CODES * 360.0 / 2**BITS)


@pytest.mark.skipif(tiny.unavailable() is not None, reason=str(tiny.unavailable()))
def test_tinymovr_holds_the_reference(fitted):
    comp, sign, truth, fit_error = fitted
    written = export_tinymovr(comp, bits=BITS)
    ticks = tiny.rectified(tiny.table_values(written.text), BITS, CODES)
    check(ticks * 360.0 / 2**BITS, sign * truth, written, fit_error, raw_deg=CODES * 360.0 / 2**BITS)


@pytest.mark.skipif(kl.unavailable() is not None, reason=str(kl.unavailable()))
@pytest.mark.parametrize("step_zero, direction", [(0.0, 1), (0.9, 1), (0.0, -1)])
def test_klipper_holds_the_stepper_angle(fitted, tmp_path, step_zero, direction):
    comp, sign, truth, fit_error = fitted
    written = export_klipper(comp, full_steps=kl.FULL_STEPS, step_zero_deg=step_zero, step_direction=direction,
                             bits=BITS)
    path = tmp_path / "printer.cfg"
    path.write_text(kl.printer_cfg(written.text))
    calibration, _ = kl.load_klipper(path)
    position = (kl.klipper_positions(calibration, CODES.astype(np.int64) << (16 - BITS))
                + calibration.angle_phase_offset) * (360.0 / 65536)
    # Klipper's angle is the stepper's, from its step 0, modulo the driver's cycle of 4 full steps
    check(position, direction * (truth - step_zero), written, fit_error, period=4 * 360.0 / kl.FULL_STEPS)


@pytest.mark.parametrize("step_zero", [0.0, 0.9])
def test_mechaduino_holds_the_angle_from_step_zero(fitted, step_zero):
    comp, sign, truth, fit_error = fitted
    written = export_mechaduino(comp, step_zero_deg=step_zero)
    # Controller.cpp: y = lookup[readEncoder()], in the encoder's counting direction from full step 0
    check(mech.read_lookup(written.text).astype(float), sign * (truth - step_zero), written, fit_error)

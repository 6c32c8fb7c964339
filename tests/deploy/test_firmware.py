"""Firmware formats: each written table, run through that firmware's own rule (re-implemented here from
its source, independently of encal's copy), gives the model's correction within the stated error on
every code; each format reads back.

Sources: moteus fw/motor_position.h (lerp), SimpleFOC CalibratedSensor.cpp (getSensorAngle), Klipper
klippy/extras/angle.py (load_calibration, apply_calibration), Mechaduino Controller.cpp
(y = lookup[readEncoder()]), Tinymovr firmware/src/sensor/sensor.h (sensor_get_angle_rectified).
"""

import math
import re

import numpy as np
import pytest

from encal.deploy import Compensator
from encal.deploy.firmware import (export_klipper, export_mechaduino, export_moteus, export_simplefoc,
                                   export_tinymovr, read_cal_capture, read_compare_encoders, read_klipper,
                                   read_mechaduino, read_moteus_conf, read_simplefoc, read_tinymovr)
from encal._core.errors import CalibrationError, EncalError, InputError
from encal.models.fourier import FourierModel
from tests._paths import DATA

KINDS = ["fourier", "lut", "ann", "stack"]


def model(kind):
    return Compensator(DATA / f"model_v1_{kind}.json")


def correction_arcmin(comp, angles_deg):
    """What a firmware must add to the raw reading: minus the error (reading_sign 1)."""
    return -np.asarray(comp.predict(angles_deg))


# -- moteus: fw/motor_position.h ------------------------------------------------------------------------

def moteus_lerp(array, scale, ratio):
    """MotorPosition::lerp, float arithmetic as in C++."""
    f = np.float32
    size = len(array)
    left = np.minimum(size - 1, (ratio * f(size)).astype(np.int64))
    right = (left + 1) % size
    fraction = (ratio - left.astype(f) / f(size)) * f(size)
    a = np.asarray(array, dtype=f)
    return (a[left] * scale) * (f(1) - fraction) + (a[right] * scale) * fraction


@pytest.mark.parametrize("kind", KINDS)
def test_moteus_round_trip(kind):
    comp = model(kind)
    out = export_moteus(comp, source=1, style="console")
    table = [0] * 256
    scale = None
    for line in out.text.splitlines():
        match = re.fullmatch(r"conf set motor_position\.sources\.1\.compensation_(?:table\.(\d+) (-?\d+)|scale (\S+))",
                             line)
        assert match, line
        if match.group(1):
            table[int(match.group(1))] = int(match.group(2))
        else:
            scale = float(match.group(3))
    # the scale is the largest node rounded up to six decimals: nearly the full int8 range
    assert 126 <= max(abs(v) for v in table) <= 127
    cpr = 65536
    offset_value = np.arange(cpr, dtype=np.float32)
    revolutions = moteus_lerp(table, np.float32(scale) / np.float32(127.0), offset_value * np.float32(1.0 / cpr))
    gap = np.abs(revolutions.astype(float) * 21600.0 + out.offset_arcmin
                 - correction_arcmin(comp, np.arange(cpr) * 360.0 / cpr))
    # encal's figure also holds the float32 rounding of compensated_value (half an ulp at 65536 counts)
    assert gap.max() <= out.max_error_arcmin + 0.5 * 2.0**-7 * 21600 / cpr
    assert scale == float(f"{scale:.6f}")  # what conf get's %f keeps: a dump and restore leaves it
    # the error is the int8 rounding plus 256-node interpolation; rounding alone is at most half a step
    assert out.quantisation_arcmin == pytest.approx(0.5 * scale / 127 * 21600)
    reread = read_moteus_conf(out.text)
    theta = np.arange(0, 360, 0.25)
    assert np.max(np.abs(reread.predict(theta) - out.offset_arcmin - comp.predict(theta))) \
        <= out.max_error_arcmin + 1e-6


def test_moteus_rounds_rather_than_truncates():
    comp = Compensator(FourierModel([1], [5.0], [0.0], encoder={"resolution_bits": 14}))
    out = export_moteus(comp)
    values = [int(line.split()[-1]) for line in out.text.splitlines() if ".compensation_table." in line]
    revolutions = -5.0 * np.cos(np.radians(np.arange(256) * 360 / 256)) / 21600
    # least-squares nodes differ from the samples by under one int8 step; truncation would bias them
    assert np.mean(np.asarray(values) - revolutions / np.max(np.abs(revolutions)) * 127) == pytest.approx(0, abs=0.1)


def moteus_lines(values, scale=None, source=0, prefix=""):
    lines = [f"{prefix}motor_position.sources.{source}.compensation_table.{i} {v}" for i, v in enumerate(values)]
    if scale is not None:
        lines.append(f"{prefix}motor_position.sources.{source}.compensation_scale {scale}")
    return "\n".join(lines) + "\n"


def test_moteus_table_for_the_sources_sign_and_offset():
    """Issue 26: the table is indexed by offset_value = wrap((raw + offset) * sign): the node at offset value v holds
    sign times the correction at raw = sign * v - offset."""
    comp = Compensator(FourierModel([1, 3], [4.0, 1.0], [1.0, -0.5], encoder={"resolution_bits": 14}))
    plain = read_moteus_conf(export_moteus(comp).text)
    for sign, offset in ((-1, 0), (1, 1000), (-1, 1000)):
        out = export_moteus(comp, sign=sign, offset=offset)
        assert f"sign {sign} and motor_position.sources.0.offset {offset}" in out.text.splitlines()[1]
        table = read_moteus_conf(out.text)  # an error model of the offset value
        offset_value = np.arange(0, 16384, 16)
        raw = (sign * offset_value - offset) % 16384
        at_offset_value = -table.predict(offset_value * 360 / 16384)
        at_raw = -plain.predict(raw * 360 / 16384)
        assert np.max(np.abs(at_offset_value - sign * at_raw)) < 0.05
    assert export_moteus(comp, offset=1000.9).text == export_moteus(comp, offset=1000).text  # int32_t(offset)


def test_moteus_refuses_what_it_cannot_write():
    """Issue 25: --bits outside 8..24 and a correction that is not a correction are one sentence each."""
    comp = Compensator(FourierModel([1], [1e100], [0.0], encoder={"resolution_bits": 14}))
    with pytest.raises(InputError, match="under half a turn"):
        export_moteus(comp)
    for bits in (1, 4, 7, 25):
        with pytest.raises(InputError, match=f"a {bits}-bit encoder cannot hold the table; expected --bits from 8"):
            export_moteus(model("lut"), bits=bits)
    with pytest.raises(InputError, match="'sign' parameter"):
        export_moteus(model("lut"), sign=0)


def test_read_moteus_conf_formats_and_refusals(tmp_path):
    values = [int(round(100 * math.sin(2 * math.pi * i / 256))) for i in range(256)]
    for prefix in ("", "conf set "):
        reread = read_moteus_conf(moteus_lines(values, "0.001000", prefix=prefix))
        assert reread.predict(np.array([90.0]))[0] == pytest.approx(-100 * 0.001 / 127 * 21600)
    # firmware before 0x0109: 32 float bins, revolutions, no scale
    old = read_moteus_conf(moteus_lines([0.001 * math.cos(2 * math.pi * i / 32) for i in range(32)]))
    assert old.predict(np.array([0.0, 90.0]))[0] == pytest.approx(-0.001 * 21600)
    # issue 25: 256 entries without a scale were read as revolutions (10 deg corrected to 50)
    with pytest.raises(InputError, match="has no motor_position.sources.0.compensation_scale line"):
        read_moteus_conf(moteus_lines(values))
    with pytest.raises(InputError, match="32-entry table .* with a compensation_scale"):
        read_moteus_conf(moteus_lines([0.0] * 32, "0.5"))
    two = moteus_lines(values, "0.001") + moteus_lines([0] * 256, "0", source=1)
    with pytest.raises(InputError, match=r"sources 0, 1 \(non-zero: 0\); expected one, so pass --source K"):
        read_moteus_conf(two)
    assert read_moteus_conf(two, source=0).predict(np.array([90.0]))[0] != 0
    mixed = moteus_lines(values) + "motor_position.sources.1.compensation_scale 0.001\n"
    with pytest.raises(InputError, match="the compensation_scale is of source 1 and the table of source 0.*--source"):
        read_moteus_conf(mixed)
    path = tmp_path / "bad.cfg"
    for bad, line, words in (("inf", 257, "compensation_scale is 'inf'; expected a finite number"),
                             ("nan", 257, "compensation_scale is 'nan'"),):
        path.write_text(moteus_lines(values, bad))
        with pytest.raises(InputError, match=f"bad.cfg, line {line}: .*{words}"):
            read_moteus_conf(path)
    path.write_text(moteus_lines(values[:5] + ["1e999"] + values[6:], "0.001"))
    with pytest.raises(InputError, match="bad.cfg, line 6: motor_position.sources.0.compensation_table.5 is '1e999'"):
        read_moteus_conf(path)
    path.write_text(moteus_lines(values[:5] + [300] + values[6:], "0.001"))
    with pytest.raises(InputError, match="line 6: compensation_table.5 is 300; expected a whole number from -128"):
        read_moteus_conf(path)


def test_read_moteus_source_config():
    from encal.deploy.firmware.moteus import read_moteus_source_config

    dump = ("motor_position.sources.0.cpr 16384\nmotor_position.sources.0.offset 1000.000000\n"
            "motor_position.sources.0.sign -1\nmotor_position.sources.1.sign 1\nmotor_position.commutation_source 0\n"
            + moteus_lines([0] * 256, "0.000000"))
    assert read_moteus_source_config(dump) == {"bits": 14, "offset": 1000.0, "sign": -1, "commutation_source": 0,
                                               "table_entries": 256}
    with pytest.raises(InputError, match="line 1: motor_position.sources.0.cpr is 1000; expected a power of two"):
        read_moteus_source_config("motor_position.sources.0.cpr 1000\n")


def test_compare_encoders_output(tmp_path):
    ref = np.linspace(0, 2, 400, endpoint=False)  # two revolutions
    measured = ref + 0.001 * np.sin(2 * np.pi * ref) + 0.25
    path = tmp_path / "cmp.txt"
    path.write_text("".join(f"{r} {m}\n" for r, m in zip(ref, measured)))
    cal = read_compare_encoders(path)
    assert len(cal) == 400
    error = cal.errors_arcmin - 0.25 * 21600
    assert np.max(np.abs(error - 0.001 * 21600 * np.sin(2 * np.pi * ref))) < 1e-6
    path.write_text("0,1 0,2\n")  # issue 25: decimal commas were read as four numbers, the first two kept
    with pytest.raises(CalibrationError, match="line 1: '0,1 0,2' has decimal commas"):
        read_compare_encoders(path)
    path.write_text("0.1 0.2\n0.2 inf\n")
    with pytest.raises(CalibrationError, match="line 2, column 2: expected a finite number, got 'inf'"):
        read_compare_encoders(path)
    path.write_text("0.1 0.2\n0.2 x\n")
    with pytest.raises(CalibrationError, match="line 2, column 2: expected a finite number"):
        read_compare_encoders(path)


def cal_capture(pole_pairs=7, error_amplitude_count=40.0, lag_deg=0.0):
    """A moteus capture of a motor whose encoder has a first-harmonic error (counts), the rotor ``lag_deg``
    (mechanical) behind the command in the direction of travel."""
    lines = ["CAL start"]
    electrical_turns = pole_pairs
    steps = electrical_turns * 64
    for direction, order in ((1, range(steps)), (2, range(steps - 1, -1, -1))):
        for i in order:
            phase = i * 65536.0 / 64  # 64 samples per electrical turn
            travel = 1 if direction == 1 else -1
            mechanical = phase / 65536.0 / pole_pairs - travel * lag_deg / 360.0  # revolutions
            encoder = (mechanical * 65536 + error_amplitude_count * math.sin(2 * math.pi * mechanical)) % 65536
            lines.append(f"{direction} {int(phase) % 65536} {int(round(encoder))} i1=100 i2=-50 i3=-50")
    lines.append("CAL done")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("lag_deg", [0.0, 0.5])
def test_moteus_cal_capture_gives_the_encoder_error(tmp_path, lag_deg):
    """Issue 25: a rotor lagging the command (here 0.5 deg, 3.5 deg electrical) is taken out, as selfcal sweep
    takes it out, so the calibration is the encoder's error in both directions (it profiles and fits)."""
    path = tmp_path / "cal.log"
    path.write_text(cal_capture(lag_deg=lag_deg))
    cal = read_cal_capture(path)
    assert cal.metadata["pole_pairs"] == 7 and set(cal.direction.tolist()) == {1, -1}
    assert cal.metadata["lag_arcmin"] == pytest.approx(lag_deg * 60, abs=0.05)
    # the reference is the rotor's angle: the commanded phase / p less the lag along the travel
    truth = 40.0 * 21600 / 65536 * np.sin(np.radians(cal.reference_deg))
    error = cal.errors_arcmin - np.mean(cal.errors_arcmin)
    assert np.max(np.abs(error - truth)) <= 0.5 * 21600 / 65536 + 0.05  # whole encoder counts, the lag's estimate
    # no angle repeats within a direction: the closing sample of the turn is left out
    assert len(cal) == 2 * (7 * 64) - 4


def test_moteus_cal_capture_import_profiles_and_fits_a_lagging_rotor(tmp_path, capsys):
    from encal.cli import main

    path = tmp_path / "cal.log"
    path.write_text(cal_capture(lag_deg=0.5))
    assert main(["import", "moteus-cal", str(path), "-o", str(tmp_path / "cal.csv")]) == 0
    assert main(["profile", str(tmp_path / "cal.csv")]) == 0
    assert main(["fit", str(tmp_path / "cal.csv"), "-o", str(tmp_path / "m.json"), "--method", "fourier"]) == 0
    assert "error" not in capsys.readouterr().err


def test_moteus_cal_capture_of_an_encoder_counting_against_the_phase(tmp_path, capsys):
    """The phase's sense is the wiring's: the reference is taken in the encoder's sense, as selfcal sweep takes it."""
    from encal.cli import main

    lines = cal_capture(lag_deg=0.5).splitlines()
    mirrored = [line if line.startswith("CAL") else " ".join([*line.split()[:2], str(-int(line.split()[2]) % 65536)])
                for line in lines]
    path = tmp_path / "cal.log"
    path.write_text("\n".join(mirrored) + "\n")
    cal = read_cal_capture(path)
    assert cal.metadata["encoder_counts_against_phase"]
    assert cal.metadata["lag_arcmin"] == pytest.approx(30, abs=0.05)
    # the mirrored encoder's error at reading r is minus the error at 360 - r
    truth = -40.0 * 21600 / 65536 * np.sin(np.radians(-cal.reference_deg))
    error = cal.errors_arcmin - np.mean(cal.errors_arcmin)
    assert np.max(np.abs(error - truth)) <= 0.5 * 21600 / 65536 + 0.05
    assert main(["import", "moteus-cal", str(path), "-o", str(tmp_path / "cal.csv")]) == 0
    assert main(["profile", str(tmp_path / "cal.csv")]) == 0 and "--reverse" not in capsys.readouterr().err


def test_moteus_cal_capture_refuses_the_pole_pairs_selfcal_sweep_refuses(tmp_path):
    """Issue 25: one reader, one check: --pole-pairs 8 on a 7-pole-pair capture is refused by both."""
    from encal.selfcal.moteus_capture import read_moteus_capture
    from encal.selfcal.sweep import sweep_capture

    path = tmp_path / "cal.log"
    path.write_text(cal_capture())
    with pytest.raises(InputError) as imported:
        read_cal_capture(path, pole_pairs=8)
    with pytest.raises(InputError) as swept:
        sweep_capture(read_moteus_capture(path), 8)
    assert "is the pole-pair count 7?" in str(imported.value)
    assert str(imported.value).split(";")[1] == str(swept.value).split(";")[1]


def test_moteus_cal_capture_refuses_less_than_one_inferred_pole_pair(tmp_path):
    # the phase turns a tenth of the encoder's travel: no whole number of pole pairs >= 1 fits
    up = [f"1 {100 * i} {1000 * i}" for i in range(10)]
    down = [f"2 {100 * i} {1000 * i}" for i in range(9, -1, -1)]
    path = tmp_path / "cal.log"
    path.write_text("\n".join(["CAL start", *up, *down, "CAL done"]) + "\n")
    with pytest.raises(CalibrationError) as info:
        read_cal_capture(path)
    assert str(info.value) == (f"{path}: the electrical phase turned 0.1 times the encoder travel while turning up; "
                               "expected at least one pole pair (or pass pole_pairs)")
    with pytest.raises(InputError, match="the encoder turned"):  # nor does one pole pair fit its travel
        read_cal_capture(path, pole_pairs=1)


def test_moteus_cal_capture_refusals(tmp_path):
    path = tmp_path / "cal.log"
    path.write_text("1 2 3\nCAL done\n")
    with pytest.raises(EncalError, match="begin with 'CAL start'"):
        read_cal_capture(path)
    path.write_text(cal_capture().replace("CAL done\n", ""))
    with pytest.raises(EncalError, match="without 'CAL done'"):
        read_cal_capture(path)
    path.write_text("CAL start\n1 70000 3\nCAL done\n")
    with pytest.raises(EncalError, match="line 2"):
        read_cal_capture(path)


# -- SimpleFOC: CalibratedSensor::getSensorAngle --------------------------------------------------------

def simplefoc_angle(lut, raw, version):
    """CalibratedSensor::getSensorAngle of drivers 1.0.8 (raw + lut) and 1.0.9 (raw - lut), float32."""
    f = np.float32
    two_pi = f(6.28318530718)
    n = len(lut)
    width = two_pi / f(n)
    if version == "1.0.8":
        bucket = np.floor(raw / width).astype(np.int64)
        remainder = raw - width * bucket.astype(f)
        return raw + (((width - remainder) / width) * lut[bucket] + (remainder / width) * lut[(bucket + 1) % n])
    index = (raw / width).astype(np.int64)
    distance = (raw - index.astype(f) * width) / width
    return raw - ((f(1) - distance) * lut[index] + distance * lut[(index + 1) % n])


@pytest.mark.parametrize("version, nodes", [("1.0.8", 128), ("1.0.9", 200)])
@pytest.mark.parametrize("kind", KINDS)
def test_simplefoc_round_trip(kind, version, nodes):
    comp = model(kind)
    out = export_simplefoc(comp, firmware_version=version)
    lut = np.array([float(v.strip().rstrip("f")) for v in re.search(r"\{(.*)\}", out.text, re.S).group(1).split(",")],
                   dtype=np.float32)
    assert lut.size == nodes and f"float calibrationLut[{nodes}]" in out.text and lut[0] == 0
    codes = np.arange(65536)
    raw = (codes.astype(np.float32) / np.float32(65536)) * np.float32(6.28318530718)
    angle = simplefoc_angle(lut, raw, version)
    assert np.all(angle >= 0)  # Sensor::update would drop a negative one
    applied_arcmin = np.degrees(angle.astype(float) - codes * (2 * np.pi / 65536)) * 60
    gap = np.abs(applied_arcmin + out.offset_arcmin - correction_arcmin(comp, codes * 360.0 / 65536))
    assert gap.max() <= out.max_error_arcmin * (1 + 1e-6) + 1e-9
    reread = read_simplefoc(out.text)
    theta = np.arange(0, 360, 0.5)
    gap = np.abs(reread.predict(theta) - out.offset_arcmin - comp.predict(theta))
    assert np.max(gap) <= out.max_error_arcmin + 1e-5


# -- Klipper: klippy/extras/angle.py ----------------------------------------------------------------------

def klipper_calibration(angles):
    angle_max, count = 1 << 16, 1 << 6
    bucket_size = angle_max // count
    full_steps = len(angles)
    nominal_step = float(angle_max) / full_steps
    reversed_ = angles[-2] > angles[-1]
    if reversed_:
        angles = list(reversed(angles))
    first_step = angles.index(min(angles))
    angles = angles[first_step:] + angles[:first_step]
    eqs = np.zeros((full_steps, count))
    ans = np.zeros((full_steps,))
    for step, angle in enumerate(angles):
        int_angle = int(angle + .5) % angle_max
        bucket = int(int_angle / bucket_size)
        ang_diff_per = (angle - bucket * bucket_size) / bucket_size
        eqs[step][bucket] = 1. - ang_diff_per
        eqs[step][(bucket + 1) % count] = ang_diff_per
        ans[step] = float(step * nominal_step)
        if bucket + 1 >= count:
            ans[step] -= ang_diff_per * angle_max
    sol = np.linalg.lstsq(eqs, ans, rcond=None)[0]
    isol = [int(s + .5) for s in sol]
    return isol + [isol[0] + angle_max], reversed_


def klipper_new_angle(calibration, reversed_, angle):
    bucket = (angle & 0xffff) >> 10
    cal1, cal2 = calibration[bucket], calibration[bucket + 1]
    adj = cal1 + (((angle & 0x3ff) * (cal2 - cal1) + 512) >> 10)
    angle_diff = (adj - angle) & 0xffff
    angle_diff -= (angle_diff & 0x8000) << 1
    new_angle = angle + angle_diff
    return -new_angle if reversed_ else new_angle


@pytest.mark.parametrize("direction", [1, -1])  # task klipper-dir: the stepper's positive steps raise or lower
@pytest.mark.parametrize("kind", ["fourier", "lut"])
def test_klipper_round_trip(kind, direction):
    comp = model(kind)
    out = export_klipper(comp, full_steps=200, step_zero_deg=0.9, step_direction=direction)
    assert out.text.startswith("calibrate:\n")
    angles = [float(v) for v in out.text.split(":", 1)[1].replace("\n", " ").split(",")]
    assert len(angles) == 200
    calibration, reversed_ = klipper_calibration(angles)
    assert reversed_ == (direction == -1)  # the sensor counts with the reference: against a stepper turning back
    phase_offset = (angles.index(min(angles)) & 3) * 65536 / 200  # angle_phase_offset
    new = np.array([klipper_new_angle(calibration, reversed_, a) for a in range(65536)])
    position = (new + phase_offset) * (360 / 65536)
    # the stepper's position from step 0 (at 0.9 deg of the reference), modulo the driver's 4-step cycle
    stepper = direction * (comp.correct(np.arange(65536) * 360 / 65536) - 0.9)
    gap = ((position - stepper + 3.6) % 7.2 - 3.6) * 60
    assert np.max(np.abs(gap)) == pytest.approx(out.max_error_arcmin, rel=1e-9)
    assert np.sqrt(np.mean(gap**2)) == pytest.approx(out.rms_error_arcmin, rel=1e-9)
    # what 64 buckets lose: under the profile's own size
    assert out.max_error_arcmin < 0.5 * np.ptp(comp.predict(np.arange(0, 360, 0.1)))
    cal = read_klipper(out.text)
    assert len(cal) == 200
    # the list starts at a multiple of 4 steps from step 0: its index i is at 0.9 + direction * (i + 4k) * 1.8 deg
    readings = cal.reading_sign * np.asarray(cal.encoder_deg)
    shift = (direction * (comp.correct(readings) - 0.9) - cal.reference_deg + 180) % 360 - 180
    k4 = np.round(np.median(shift) / 7.2) * 7.2
    assert np.max(np.abs(shift - k4)) * 60 < 1.01 * 0.05 * 21600 / 65536  # "%.1f" of 16-bit units (times the slope)


def test_klipper_list_starts_as_angle_calibrate_orders_it():
    # the sensor's zero 3 deg ahead: the step at 358.2 deg reads past the wrap; Klipper's reverse test
    # angles[-2] > angles[-1] would read the list backwards (issue 26: RMS 1171 arcmin with exit 0)
    comp = Compensator(FourierModel([0, 1], [180.0, 20.0], [0.0, 0.0], encoder={"resolution_bits": 16}))
    out = export_klipper(comp, step_zero_deg=0.0, step_direction=1)
    angles = [float(v) for v in out.text.split(":", 1)[1].replace("\n", " ").split(",")]
    assert angles.index(min(angles)) < 4 and angles[-2] < angles[-1]
    assert out.rms_error_arcmin < 1.0


def test_klipper_needs_a_stepper_of_whole_electrical_cycles():
    with pytest.raises(InputError, match="multiple of 4"):
        export_klipper(model("fourier"), full_steps=202, step_zero_deg=0.0, step_direction=1)


def test_klipper_list_in_a_config_section(tmp_path):
    path = tmp_path / "printer.cfg"
    values = ", ".join(f"{i * 327.68 + 3:.1f}" for i in range(200))
    path.write_text(f"[angle my_sensor]\nsensor_type: a1333\ncalibrate:\n    {values}\n[stepper_x]\nstep_pin: PA1\n")
    cal = read_klipper(path)
    assert len(cal) == 200 and cal.metadata["full_steps"] == 200 and cal.metadata["section"] == "angle my_sensor"
    path.write_text("calibrate:\n    1.0, 2.0, banana\n")
    with pytest.raises(InputError, match="line 2: expected a number"):
        read_klipper(path)


def klipper_save_config(values, section="angle my_sensor"):
    """A printer.cfg whose calibration is in the SAVE_CONFIG block, as Klipper's configfile.py writes it."""
    rows = [",".join(f"{v:.1f}" for v in values[i:i + 8]) for i in range(0, len(values), 8)]
    body = ",\n".join(f"#*# \t{row}" for row in rows)
    return ("[stepper_x]\nstep_pin: PA1\n\n[angle my_sensor]\nsensor_type: as5047d\nstepper: stepper_x\n\n"
            "#*# <---------------------- SAVE_CONFIG ---------------------->\n"
            "#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n#*#\n"
            f"#*# [{section}]\n#*# calibrate =\n{body}\n")


def test_klipper_save_config_block_read_whole(tmp_path):
    # issue 26: 175 of 200 points read silently, or an error at the [angle] header
    values = [(i * 327.68 + 3.0) % 65536 for i in range(200)]
    path = tmp_path / "printer.cfg"
    path.write_text(klipper_save_config(values))
    cal = read_klipper(path)
    assert len(cal) == 200 and cal.reading_sign == 1
    assert np.allclose(cal.encoder_deg * 65536 / 360, np.round(values, 1), atol=1e-6)
    path.write_text(klipper_save_config(values[::-1]))  # a sensor counting against the stepper
    cal = read_klipper(path)
    assert len(cal) == 200 and cal.reading_sign == -1
    # a line of the block edited without its prefix: Klipper ignores the whole block, encal refuses
    path.write_text(klipper_save_config(values).replace("#*# \t", "\t", 1))
    with pytest.raises(InputError, match="line 13: expected every line of the SAVE_CONFIG block to start"):
        read_klipper(path)


@pytest.mark.parametrize("item", ["nan", "inf", "-Infinity"])
def test_klipper_non_finite_refused_with_its_line(tmp_path, item):
    values = [f"{i * 327.68:.1f}" for i in range(16)]
    values[11] = item
    path = tmp_path / "k.cfg"
    path.write_text("[angle s]\ncalibrate:\n    " + ", ".join(values[:8]) + ",\n    " + ", ".join(values[8:]) + "\n")
    with pytest.raises(InputError, match=rf"k.cfg, line 4: expected a finite angle in the calibrate list, got "
                                         rf"'{item}'"):
        read_klipper(path)


def test_klipper_lists_that_klipper_would_not_read_as_written_are_refused(tmp_path):
    path = tmp_path / "k.cfg"
    path.write_text("calibrate:\n    1.0, 2.0\n    3.0, 4.0\n")  # no comma at the line's end
    with pytest.raises(InputError, match="line 3: expected a comma after the last angle of line 2"):
        read_klipper(path)
    # rising, with the sensor's wrap between its last two: Klipper's angles[-2] > angles[-1] reads it backwards
    values = ", ".join(f"{(i * 327.68 + 400.0) % 65536:.1f}" for i in range(200))
    path.write_text(f"calibrate:\n    {values}\n")
    with pytest.raises(InputError, match="make Klipper read it as reversed; rotate it to start at its lowest"):
        read_klipper(path)
    path.write_text("[angle a]\ncalibrate: 1, 2, 3, 4, 5, 6, 7, 8\n[angle b]\ncalibrate: 1, 2, 3, 4, 5, 6, 7, 8\n")
    with pytest.raises(InputError, match=r"expected one \[angle\] section with a calibrate list, got 2"):
        read_klipper(path)
    path.write_text("[angle a]\nsensor_type: as5047d\n")
    with pytest.raises(InputError, match="expected a 'calibrate' option in an \\[angle\\] section"):
        read_klipper(path)
    path.write_text("[include angle.cfg]\n[stepper_x]\nstep_pin: PA1\n")
    with pytest.raises(InputError, match="files are not followed: pass the file that holds it"):
        read_klipper(path)


# -- Mechaduino: y = lookup[readEncoder()] ---------------------------------------------------------------

@pytest.mark.parametrize("step_zero", [0.0, 2.5])
def test_mechaduino_round_trip(step_zero):
    comp = Compensator(FourierModel([1, 2, 4], [30.0, -12.0, 3.0], [10.0, 4.0, -1.0],
                                    encoder={"resolution_bits": 14}))
    out = export_mechaduino(comp, step_zero_deg=step_zero)
    lookup = np.array([float(v) for v in re.search(r"\{(.*)\}", out.text, re.S).group(1).split(",")],
                      dtype=np.float32)
    assert lookup.size == 16384 and "lookup[16384]" in out.text
    y = lookup[np.arange(16384)].astype(float)  # the firmware's rule: one entry per raw count
    gap = ((y - (comp.correct(np.arange(16384) * 360 / 16384) - step_zero) + 180) % 360 - 180) * 60
    assert np.max(np.abs(gap)) <= out.max_error_arcmin + 1e-9 <= out.quantisation_arcmin
    assert out.quantisation_arcmin == pytest.approx((0.0005 + 2**-16) * 60)  # 0.001 degree, then float32
    cal = read_mechaduino(out.text)
    assert len(cal) == 16384 and cal.resolution_bits == 14 and cal.reading_sign == 1
    assert np.max(np.abs(cal.errors_arcmin - step_zero * 60 - comp.predict(cal.encoder_deg))) <= out.quantisation_arcmin


def test_mechaduino_needs_14_bits():
    with pytest.raises(InputError, match="14-bit"):
        export_mechaduino(model("fourier"), step_zero_deg=0.0)


def mechaduino_text(values):
    return ("const float lookup[16384] = {\n" + ", ".join(f"{v:.3f}" if isinstance(v, float) else v for v in values)
            + "\n};\n")


def test_mechaduino_decreasing_table_read_as_an_encoder_counting_against_it():
    angles = np.arange(16384) * 360 / 16384 + 0.1 * np.sin(np.radians(np.arange(16384) * 360 / 16384))
    cal = read_mechaduino(mechaduino_text(list((-angles) % 360)))
    assert cal.reading_sign == -1
    assert np.max(np.abs(cal.errors_arcmin - 0.1 * 60 * np.sin(np.radians(-cal.encoder_deg)))) < 0.05


def test_mechaduino_refuses_what_is_not_one_turn_and_non_finite_elements():
    with pytest.raises(InputError, match=r"expected a lookup\[\] that goes once round the turn.*got one that goes \+0"):
        read_mechaduino(mechaduino_text([1.0] * 16384))
    values = [f"{v:.3f}" for v in np.arange(16384) * 360 / 16384]
    values[517] = "NAN"
    with pytest.raises(InputError, match=r"line 2: element 517 of lookup\[\] is .NAN., expected a finite number"):
        read_mechaduino(mechaduino_text(values))


# -- Tinymovr: sensor_get_angle_rectified -----------------------------------------------------------------

def tinymovr_rectified(table, angle, bits):
    offset_bits = bits - 6
    off_1 = table[angle >> offset_bits]
    off_2 = table[((angle >> offset_bits) + 1) % 64]
    off_interp = off_1 + ((off_2 - off_1) * (angle - ((angle >> offset_bits) << offset_bits)) >> offset_bits)
    return angle + off_interp


@pytest.mark.parametrize("kind", KINDS)
def test_tinymovr_round_trip(kind):
    comp = model(kind)
    out = export_tinymovr(comp, bits=13)
    table = np.array([int(v) for v in re.search(r"\{(.*)\}", out.text, re.S).group(1).split(",")])
    assert table.size == 64 and "int32_t rec_table[64]" in out.text
    angles = np.arange(1 << 13)
    rectified = tinymovr_rectified(table, angles, 13)
    gap = np.abs((rectified - angles) * (21600 / 8192) + out.offset_arcmin
                 - correction_arcmin(comp, angles * 360 / 8192))
    assert gap.max() <= out.max_error_arcmin + 1e-9
    reread = read_tinymovr(out.text, bits=13)
    theta = np.arange(0, 360, 0.5)
    gap = np.abs(reread.predict(theta) - out.offset_arcmin - comp.predict(theta))
    assert np.max(gap) <= out.max_error_arcmin + 1e-6


def test_reading_sign_flips_the_correction():
    forward = FourierModel([1], [3.0], [1.0], encoder={"resolution_bits": 14})
    backward = FourierModel([1], [3.0], [1.0], encoder={"resolution_bits": 14})
    backward.reading_sign = -1
    a = read_moteus_conf(export_moteus(forward).text)
    b = read_moteus_conf(export_moteus(backward).text)
    theta = np.arange(0, 360, 1.0)
    # the firmware adds +error in the reading's own sense when the encoder counts against the reference
    assert np.max(np.abs(b.predict(theta) + Compensator(backward).predict(theta))) < 0.03
    assert np.max(np.abs(a.predict(theta) - Compensator(forward).predict(theta))) < 0.03


def test_the_zero_offset_is_left_out_of_int8_tables():
    """A reference with an arbitrary zero puts a large constant into the correction: it stays out of the table."""
    comp = Compensator(FourierModel([0, 1, 2], [1500.0, 30.0, 10.0], [0.0, 5.0, -8.0],
                                    encoder={"resolution_bits": 14}))
    out = export_moteus(comp)
    assert out.offset_arcmin == pytest.approx(-1500.0, abs=1e-6) and "left out" in out.describe()
    # int8 steps of the 30-arcmin profile, not of 1500 arcmin
    assert out.quantisation_arcmin < 0.5 * 45 / 127 and out.max_error_arcmin < 0.5  # the profile peaks below 45


def piecewise_linear(nodes, bits, seed):
    """A model that is exactly linear between ``nodes`` evenly spaced nodes: every format with those nodes holds it."""
    from encal.models.lut import LookupTableModel

    values = np.random.default_rng(seed).uniform(-8.0, 8.0, nodes)
    breaks = np.arange(nodes + 1) * (360.0 / nodes)
    slopes = (np.roll(values, -1) - values) / (360.0 / nodes)
    return Compensator(LookupTableModel(breaks, [slopes, values], "linear", encoder={"resolution_bits": bits}))


def test_a_profile_the_formats_can_hold_round_trips_within_their_storage_rounding():
    """Known truth: linear between the firmware's own nodes, so only the stored values' rounding is left."""
    moteus = export_moteus(piecewise_linear(256, 16, 1))
    # float32 arithmetic of the rule, and compensated_value rounded to float32 (half an ulp at 65536 counts)
    assert moteus.max_error_arcmin <= moteus.quantisation_arcmin + 1e-4 + 0.5 * 2.0**-7 * 21600 / 65536
    simplefoc = export_simplefoc(piecewise_linear(128, 16, 2), firmware_version="1.0.8")
    # SimpleFOC finds the position within a bucket in float32 (ulps of 5e-7 rad over 0.049-rad buckets); the
    # float32 raw and returned angles are in quantisation_arcmin
    assert simplefoc.max_error_arcmin <= simplefoc.quantisation_arcmin + 1e-3
    assert export_simplefoc(piecewise_linear(200, 16, 2)).max_error_arcmin <= simplefoc.quantisation_arcmin + 1e-3
    tinymovr = export_tinymovr(piecewise_linear(64, 13, 3), bits=13)
    assert tinymovr.max_error_arcmin <= tinymovr.quantisation_arcmin + 1e-9
    # and the rounding is all there is: a table with twice the nodes' detail cannot be held
    assert export_tinymovr(piecewise_linear(128, 13, 4), bits=13).max_error_arcmin > tinymovr.quantisation_arcmin


def test_a_long_c_array_is_read_in_linear_time():
    """Task fuzz5: 5 million one-digit elements on one line took minutes (the line of every element was counted from
    the start of the text). 300,000 took 27 s of CPU time before the fix, 0.24 s after."""
    import time

    from encal.deploy.firmware._common import read_c_array

    text = "float calibrationLut[] = {\n" + "1," * 300_000 + "2};\n"
    start = time.process_time()
    values = read_c_array(text, "calibrationLut")
    assert values.size == 300_001 and values[-1] == 2.0
    assert time.process_time() - start < 5.0
    with pytest.raises(InputError, match=r"line 3: element 300001 of calibrationLut\[\] is 'x'"):
        read_c_array(text.replace("2};", "2,\nx};"), "calibrationLut")


# strict6: a C array element is a C literal in plain ASCII: not '1_0' (float() reads 10), not a full-width digit, not
# an octal integer (C reads 010 as 8, float() as 10)
@pytest.mark.parametrize("element, why", [("1_0.0f", r"underscore"), ("\uff12.0f", r"U\+FF12"),
                                          ("010", r"octal \(010 is 8\)"), ("-07", "octal")])
def test_a_c_element_only_python_reads_is_refused(element, why):
    from encal.deploy.firmware import read_c_array

    with pytest.raises(InputError, match=rf"^text: line 2: element 2 of a\[\] is .*{why}"):
        read_c_array(f"const float a[] = {{0.5f,\n 0, {element}, 1}};\n", "a")
    assert read_c_array("const int a[] = {0, 00, 10u, 0x10, -5, 1e3f, .5};\n", "a").tolist() == [0, 0, 10, 16, -5,
                                                                                                 1000, 0.5]

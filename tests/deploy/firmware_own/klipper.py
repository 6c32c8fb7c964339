"""Klipper's own code applying encal's ``calibrate:`` list: ``klippy/extras/angle.py`` and ``klippy/configfile.py``.

Both files are imported from ``../shared/firmware/klipper/`` (Klipper3d/klipper, the commit in its ``SOURCE``),
unmodified; only what they import from the rest of Klipper is stubbed (``extras.bus`` and
``extras.bulk_sensor``, which the angle sensor's SPI side uses, and the printer object). Each row:

1. encal writes the list (``export_klipper``) for a model of the matrix;
2. the list is pasted into the ``[angle my_sensor]`` section of a ``printer.cfg`` that Klipper's own
   ``ConfigAutoSave.load_main_config`` reads; Klipper's own ``AngleCalibration(config)`` loads it
   (``load_calibration``: the buckets, ``calibration_reversed``, ``angle_phase_offset``);
3. Klipper's own ``apply_calibration`` corrects every 16-bit angle the sensor can give (the codes of a
   14-bit sensor are its angles shifted left by 2), and the stepper position it stands for
   (``new_angle + angle_phase_offset``) is compared with the model's corrected angle from the step at driver
   phase 0 (``step_direction`` times it: the stepper's angle), modulo the driver's electrical cycle (4 full
   steps);
4. Klipper's own ``calc_mcu_pos_offset`` aligns the sensor with the driver's phase at every full step of a
   simulated stepper (the sensor reading at each step from the model inverted): the phase error, in full
   steps, is how far the stepper position Klipper derives from the sensor is from the stepper's.

:func:`saved_printer_cfg` runs Klipper's own ``ANGLE_CALIBRATE`` (its sweep replaced by the simulated sensor)
and ``SAVE_CONFIG``, for the import's round trip through the ``#*#`` block.
"""

import importlib.util
import sys
import tempfile
import types
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import FIRMWARE, Row

KLIPPY = FIRMWARE / "klipper" / "klippy"
FULL_STEPS = 200
MICROSTEPS = 16
ZEROS_DEG = (0.0, 0.45, 0.9, 1.8, 2.5, 3.6, 7.2, 30.0)

__all__ = ["unavailable", "matrix", "cases", "Case", "load_klipper", "saved_printer_cfg", "model_for", "run_case",
           "phase_errors", "printer_cfg", "step_readings_of", "measure"]


def unavailable():
    missing = [p for p in (KLIPPY / "extras" / "angle.py", KLIPPY / "configfile.py") if not p.is_file()]
    if missing:
        return f"Klipper's own code is not beside this repository ({missing[0]} is missing)"
    try:
        import numpy  # noqa: F401  (load_calibration needs it)
    except ImportError:  # pragma: no cover
        return "Klipper's load_calibration needs numpy"
    return None


_MODULES = {}


def _klipper_modules():
    """Klipper's ``configfile`` and ``extras.angle`` modules, imported once from shared/ with stubs."""
    if _MODULES:
        return _MODULES["configfile"], _MODULES["angle"]
    package = types.ModuleType("_encal_klippy_extras")
    package.__path__ = []  # a package, so that angle.py's "from . import bus, bulk_sensor" resolves here
    for stub in ("bus", "bulk_sensor"):
        module = types.ModuleType(f"_encal_klippy_extras.{stub}")
        sys.modules[module.__name__] = module
        setattr(package, stub, module)
    package.bulk_sensor.MAX_BULK_MSG_SIZE = 51  # klippy/extras/bulk_sensor.py's value; sizes a block at import
    sys.modules[package.__name__] = package
    loaded = {}
    for name, path in (("_encal_klippy_configfile", KLIPPY / "configfile.py"),
                       ("_encal_klippy_extras.angle", KLIPPY / "extras" / "angle.py")):
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        loaded[name] = module
    _MODULES["configfile"] = loaded["_encal_klippy_configfile"]
    _MODULES["angle"] = loaded["_encal_klippy_extras.angle"]
    return _MODULES["configfile"], _MODULES["angle"]


class _Gcode:
    def register_command(self, *args, **kwargs):
        pass

    def register_mux_command(self, *args, **kwargs):
        pass

    def request_restart(self, *args):
        pass


class _Printer:
    """What AngleCalibration and ConfigAutoSave ask of Klipper's printer object."""

    command_error = RuntimeError

    def __init__(self, config_file):
        self.config_file = str(config_file)
        self.objects = {"gcode": _Gcode()}

    def get_start_args(self):
        return {"config_file": self.config_file}

    def lookup_object(self, name, default=None):
        return self.objects.get(name, default)

    def register_event_handler(self, *args):
        pass


class _Gcmd:
    def __init__(self):
        self.said = []

    def respond_info(self, text):
        self.said.append(text)

    def error(self, text):
        return RuntimeError(text)


def printer_cfg(calibrate_text, section="angle my_sensor"):
    """A ``printer.cfg`` with encal's ``calibrate:`` text pasted into the ``[angle]`` section."""
    return (f"[stepper_x]\nstep_pin: PA1\nmicrosteps: {MICROSTEPS}\nfull_steps_per_rotation: {FULL_STEPS}\n\n"
            f"[{section}]\nsensor_type: as5047d\ncs_pin: PA2\nstepper: stepper_x\n{calibrate_text}")


def load_klipper(path, section="angle my_sensor"):
    """Klipper's own ``AngleCalibration`` for the ``[angle]`` section of the config file at ``path``."""
    configfile, angle = _klipper_modules()
    printer = _Printer(path)
    printer.objects["configfile"] = pconfig = configfile.PrinterConfig(printer)
    config = pconfig.read_main_config()
    calibration = angle.AngleCalibration(config.getsection(section))
    calibration.get_microsteps = lambda: (MICROSTEPS, FULL_STEPS)
    return calibration, printer


class _Stepper:
    def __init__(self):
        self.position = 0

    def get_past_mcu_position(self, when):
        return self.position

    def mcu_to_commanded_position(self, offset):
        return offset


class _Tmc:
    def get_phase_offset(self):
        return 0, 4 * MICROSTEPS  # the driver's phase is the mcu position modulo one electrical cycle


def klipper_positions(calibration, angles):
    """Klipper's own ``apply_calibration`` on 16-bit ``angles``: the corrected angles (16-bit units)."""
    calibration.mcu_pos_offset = 0  # skip the phase alignment here (measured by phase_errors)
    if calibration.mcu_stepper is None:
        calibration.mcu_stepper = _Stepper()
    samples = [(0.0, int(a)) for a in angles]
    calibration.apply_calibration(samples)
    return np.array([angle for _, angle in samples], dtype=np.int64)


def phase_errors(calibration, readings_units):
    """Klipper's own ``calc_mcu_pos_offset`` at full step ``k`` (mcu position ``k * microsteps``, driver phase
    ``k mod 4``) from the sensor's reading there: the error of the stepper position Klipper derives, full steps."""
    calibration.tmc_module = _Tmc()
    stepper = calibration.mcu_stepper = _Stepper()
    errors = []
    for k, reading in enumerate(readings_units):
        calibration.mcu_pos_offset = 0
        corrected = klipper_positions(calibration, [int(np.floor(reading)) % 65536])[0]
        stepper.position = k * MICROSTEPS
        calibration.mcu_pos_offset = None
        calibration.calc_mcu_pos_offset((0.0, int(corrected)))
        angle_mpos = corrected * FULL_STEPS * MICROSTEPS / 65536.0
        errors.append((angle_mpos + calibration.mcu_pos_offset - stepper.position) / MICROSTEPS)
    return np.asarray(errors)


def step_readings_of(comp, theta_deg):
    """The sensor's angle (16-bit units, continuous) where the model's corrected angle is ``theta_deg``."""
    theta_deg = np.asarray(theta_deg, dtype=float)
    sign = comp.reading_sign
    reading = sign * theta_deg % 360.0
    for _ in range(60):  # corrected = sign * reading - error / 60, so reading = sign * (theta + error / 60)
        reading = sign * (theta_deg + np.asarray(comp.predict(reading)) / 60.0) % 360.0
    return reading * (65536 / 360.0)


def model_for(bits, reversed_, encoder_zero_deg, high_order=False):
    """The matrix's model: an error of a few tens of arcmin (orders 1-3, or a 90th order Klipper's 64 buckets
    cannot hold), the encoder's zero ``encoder_zero_deg`` ahead of the reference's."""
    from encal.deploy import Compensator
    from encal.models.fourier import FourierModel

    orders, cos, sin = [0, 1, 2, 3], [encoder_zero_deg * 60.0, 30.0, -12.0, 3.0], [0.0, 10.0, 4.0, -1.0]
    if high_order:
        orders, cos, sin = orders + [90], cos + [20.0], sin + [0.0]
    model = FourierModel(orders, cos, sin, encoder={"resolution_bits": bits})
    model.reading_sign = -1 if reversed_ else 1
    return Compensator(model)


@dataclass(frozen=True)
class Case:
    """A row, with what Klipper's code derives about the stepper's phase."""

    row: Row
    phase_error_steps: float | None  # largest |error| of the stepper position Klipper derives, full steps
    reversed_as_klipper_reads: bool | None


def _configurations():
    for direction in (1, -1):  # task klipper-dir: the stepper's positive steps raise, or lower, the reference
        for bits in (14, 16):
            for reversed_ in (False, True):
                for zero in ZEROS_DEG:
                    yield bits, reversed_, zero, 0.0, direction, f"encoder zero {zero:g} deg ahead, step 0 at 0"
                for zero in ZEROS_DEG[1:]:
                    yield bits, reversed_, 0.0, zero, direction, f"step 0 at {zero:g} deg"


def cases():
    """Every configuration of the matrix through Klipper's own code."""
    for bits, reversed_, encoder_zero, step_zero, direction, what in _configurations():
        label = (f"{bits}-bit, {'reversed, ' if reversed_ else ''}{what}"
                 + (", stepper against the reference (--step-direction -1)" if direction == -1 else ""))
        yield run_case(model_for(bits, reversed_, encoder_zero), bits, step_zero, label, direction)
    yield run_case(model_for(16, False, 0.0), 16, None, "16-bit, no --step-zero")
    yield run_case(model_for(16, False, 0.0, high_order=True), 16, 0.0,
                   "16-bit, a 90th order Klipper's 64 buckets cannot hold")


def run_case(comp, bits, step_zero, label, direction=1):
    """One export of ``comp`` (``step_zero`` the reference angle of step 0, or None; the stepper's positive steps
    turning the reference the way ``direction`` says) through Klipper's code."""
    from encal.deploy.firmware import export_klipper
    from encal._core.errors import InputError

    try:
        written = export_klipper(comp, full_steps=FULL_STEPS, step_zero_deg=step_zero, step_direction=direction)
    except InputError as error:
        return Case(Row("klipper", label, None, None, None, None, str(error)), None, None)
    rms, largest, phase, reversed_ = measure(comp, bits, step_zero, written.text, direction)
    row = Row("klipper", label, written.rms_error_arcmin, written.max_error_arcmin, rms, largest)
    return Case(row, phase, reversed_)


def measure(comp, bits, step_zero, calibrate_text, direction=1):
    """A ``calibrate:`` text through Klipper's own code: (RMS, max) arcmin of the stepper position it gives
    against the model's from step 0 (modulo 4 full steps) on every code, the largest phase error (full
    steps) of ``calc_mcu_pos_offset`` over the full steps, and whether Klipper reads the list as reversed.

    ``direction`` is which way the stepper's positive full steps turn the reference (1 raise its angle, -1
    lower it): the stepper's angle is ``direction * (theta - step_zero)``, its full step ``k`` at reference
    angle ``step_zero + direction * k * 360 / steps``."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "printer.cfg"
        path.write_text(printer_cfg(calibrate_text))
        calibration, _ = load_klipper(path)
    codes = np.arange(2**bits, dtype=np.int64) << (16 - bits)
    position = (klipper_positions(calibration, codes) + calibration.angle_phase_offset) * (360.0 / 65536)
    expected = direction * (np.asarray(comp.correct(codes * (360.0 / 65536))) - step_zero)
    period = 4 * 360.0 / FULL_STEPS
    gap = ((position - expected + period / 2) % period - period / 2) * 60.0
    steps = step_zero + direction * np.arange(FULL_STEPS) * (360.0 / FULL_STEPS)
    phase = phase_errors(calibration, step_readings_of(comp, steps))
    return (float(np.sqrt(np.mean(gap**2))), float(np.max(np.abs(gap))), float(np.max(np.abs(phase))),
            bool(calibration.calibration_reversed))


def matrix():
    for case in cases():
        yield case.row


def saved_printer_cfg(folder, comp, step_zero_deg, *, first_step=100, direction=1):
    """A ``printer.cfg`` as Klipper's own ``ANGLE_CALIBRATE`` then ``SAVE_CONFIG`` leave it.

    The sweep (``do_calibration_moves``) is replaced by the sensor's readings from the model inverted at
    each full step ``first_step + i`` from a step at driver phase 0 (``ANGLE_CALIBRATE`` samples from half a
    turn past its phase-0 start), full step ``k`` at reference angle ``step_zero_deg + direction * k * 360 /
    steps``; the rest is Klipper's code: averaging, ordering, writing the option, and ``SAVE_CONFIG`` writing
    the ``#*#`` block.
    """
    path = Path(folder) / "printer.cfg"
    path.write_text(printer_cfg("") + "\n[printer]\nkinematics: none\n")
    calibration, printer = load_klipper(path)
    steps = step_zero_deg + direction * (first_step + np.arange(FULL_STEPS)) * (360.0 / FULL_STEPS)
    readings = step_readings_of(comp, steps)
    measured = {i: [float(r)] for i, r in enumerate(readings)}
    calibration.do_calibration_moves = lambda: (measured, measured)
    gcmd = _Gcmd()
    calibration.cmd_ANGLE_CALIBRATE(gcmd)
    printer.lookup_object("configfile").autosave.cmd_SAVE_CONFIG(gcmd)
    return path

"""moteus: encal's table through moteus's own ``fw/motor_position.h``, compiled with g++.

``moteus_driver.cc`` includes the unmodified header from ``../shared/firmware/moteus`` (stub headers of
our own in ``moteus_stubs/`` stand in for mjlib and the board: ``aux_common.h``, ``bldc_servo_structs.h``,
``ccm.h``, ``math.h``), configures one SPI source with the table, scale, sign, offset and cpr, and runs
``MotorPosition::ISR_Update`` once per raw code: the firmware's own ``ISR_UpdateAbsoluteSource``
(``offset_value = WrapIntCpr((raw + offset) * sign)``), ``lerp`` and ``WrapCpr`` give
``compensated_value``. The written file is read as the device gets it: ``moteus_tool --restore-config``
drops what follows a ``#`` and prefixes ``conf set`` (``do_restore_config``); console lines are sent as
they are. The driver is compiled once per session (cached by the hash of its sources in the temporary
folder).
"""

import functools
import hashlib
import math
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from . import FIRMWARE, Row

MOTEUS = FIRMWARE / "moteus"
HEADER = MOTEUS / "fw" / "motor_position.h"
HERE = Path(__file__).resolve().parent
STUBS = HERE / "moteus_stubs"
DRIVER = HERE / "moteus_driver.cc"
ZEROS_DEG = (0.0, 0.45, 0.9, 1.8, 2.5, 3.6, 7.2, 30.0)

__all__ = ["unavailable", "matrix", "firmware_correction", "device_commands", "measure"]


def unavailable():
    """None when moteus's header and g++ are here, else why not (one sentence)."""
    if not HEADER.is_file():
        return f"moteus's fw/motor_position.h is not at {HEADER} (../shared/firmware/moteus)"
    if shutil.which("g++") is None:
        return "g++ is not installed, so moteus's fw/motor_position.h cannot be compiled"
    return None


@functools.lru_cache(maxsize=None)
def _binary():
    """The compiled driver (compiled once; reused across processes while its sources are unchanged)."""
    digest = hashlib.sha256()
    for path in [HEADER, DRIVER, *sorted(STUBS.rglob("*.h"))]:
        digest.update(path.read_bytes())
    target = Path(tempfile.gettempdir()) / f"encal-moteus-driver-{digest.hexdigest()[:16]}"
    if not target.is_file():
        partial = target.with_suffix(f".{np.random.default_rng().integers(1 << 30)}.tmp")
        result = subprocess.run(["g++", "-std=c++17", "-O2", f"-I{STUBS}", f"-I{MOTEUS}", str(DRIVER), "-o",
                                 str(partial)], capture_output=True, text=True)
        if result.returncode != 0:
            raise RuntimeError(f"g++ could not compile moteus's fw/motor_position.h with the stubs:\n{result.stderr}")
        partial.replace(target)
    return target


def device_commands(text):
    """The commands the device receives for a written file: ``--restore-config``'s rule for lines without
    ``conf set`` (moteus_tool.py ``do_restore_config``: cut at ``#``, strip the right, skip empty, prefix
    ``conf set``), console lines as they are."""
    commands = []
    for line in text.splitlines():
        if line.startswith("conf set "):
            commands.append(line)
            continue
        if "#" in line:
            line = line[:line.index("#")]
        line = line.rstrip()
        if line:
            commands.append(f"conf set {line}")
    return commands


def _table_and_scale(commands, source):
    key = re.escape(f"motor_position.sources.{source}.")
    table, scale = [None] * 256, None
    for command in commands:
        match = re.fullmatch(rf"conf set {key}compensation_(?:table\.(\d+)|scale) (\S+)", command)
        if not match:
            raise AssertionError(f"the device would refuse {command!r}")
        if match.group(1) is None:
            scale = match.group(2)
        else:
            table[int(match.group(1))] = int(match.group(2))
    assert None not in table and scale is not None
    return table, scale


def firmware_correction(table, scale_text, bits, sign, offset):
    """moteus's own code over every raw code: ``(offset_value, compensated_value)`` arrays."""
    cpr = 1 << bits
    request = f"{bits} {sign} {offset!r} {scale_text} " + " ".join(map(str, table)) + "\n"
    result = subprocess.run([str(_binary())], input=request.encode(), capture_output=True, check=True)
    offset_value = np.frombuffer(result.stdout[:4 * cpr], dtype=np.uint32)
    compensated = np.frombuffer(result.stdout[4 * cpr:], dtype=np.float32)
    return offset_value.astype(np.int64), compensated.astype(float)


def measure(written, model, bits, sign=1, offset=0, source=0, dump_and_restore=False):
    """(RMS, max) arcmin of moteus's own correction against the model's, over every raw code.

    ``dump_and_restore``: the scale as a ``conf enumerate`` dump and restore leaves it (``%f``).
    """
    table, scale_text = _table_and_scale(device_commands(written.text), source)
    if dump_and_restore:
        scale_text = f"{float(np.float32(float(scale_text))):f}"
    offset_value, compensated = firmware_correction(table, scale_text, bits, sign, offset)
    cpr = 1 << bits
    raw = np.arange(cpr)
    assert np.array_equal(offset_value, ((raw + math.trunc(offset)) * sign) % cpr)
    moved = (compensated - offset_value + cpr / 2) % cpr - cpr / 2
    applied = sign * moved * (21600.0 / cpr)  # in the raw reading's sense
    wanted = -model.reading_sign * np.asarray(model.predict(raw * (360.0 / cpr))) - written.offset_arcmin
    gap = applied - wanted
    return float(np.sqrt(np.mean(gap**2))), float(np.max(np.abs(gap)))


def _model(bits, reversed_reading, zero_deg):
    from encal.deploy import Compensator
    from encal.models.fourier import FourierModel

    model = FourierModel([0, 1, 2, 3, 7, 14], [zero_deg * 60.0, 2.0, -0.8, 0.3, 0.25, 0.1],
                         [0.0, 1.1, 0.5, -0.2, 0.15, -0.05], encoder={"resolution_bits": bits})
    if reversed_reading:
        model.reading_sign = -1
    return Compensator(model)


def _configurations():
    for bits in (14, 16):
        for reversed_reading in (False, True):
            for zero in ZEROS_DEG:
                yield bits, reversed_reading, zero, 1, 0, "restore", False
            for sign, offset in ((-1, 0), (1, 1000), (-1, 1000)):
                yield bits, reversed_reading, 0.0, sign, offset, "restore", False
        yield bits, False, 0.0, -1, 1000, "console", False
        yield bits, False, 0.0, -1, 1000, "restore", True


def matrix():
    """One row per configuration: 14/16 bits, reversed, reference zero, sign, offset, file style, dump."""
    from encal.deploy.firmware import export_moteus
    from encal._core.errors import EncalError

    for bits, reversed_reading, zero, sign, offset, style, dump in _configurations():
        name = (f"{bits}-bit{', reversed' if reversed_reading else ''}, zero {zero:g} deg, sign {sign}, "
                f"offset {offset}, {style}" + (", after a conf dump/restore (%f)" if dump else ""))
        model = _model(bits, reversed_reading, zero)
        try:
            written = export_moteus(model, bits=bits, sign=sign, offset=offset, style=style)
        except EncalError as error:
            yield Row("moteus", name, None, None, None, None, str(error))
            continue
        rms, largest = measure(written, model, bits, sign, offset, dump_and_restore=dump)
        yield Row("moteus", name, written.rms_error_arcmin, written.max_error_arcmin, rms, largest)

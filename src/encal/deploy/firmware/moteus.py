"""moteus (mjbots): the encoder compensation table, and moteus's calibration outputs as calibrations.

Format (``fw/motor_position.h`` of github.com/mjbots/moteus, ``SourceConfig`` and
``MotorPosition::lerp``; ``utils/compensate_encoder.py`` writes it)::

    conf set motor_position.sources.K.compensation_table.I <int8>     I = 0 .. 255
    conf set motor_position.sources.K.compensation_scale <float>

Node ``I`` is at ``I / 256`` revolutions; its value in revolutions is ``table[I] * scale / 127``.
At run time ``ratio = offset_value / cpr``, ``left = min(255, int(ratio * 256))``,
``fraction = (ratio - left / 256) * 256``, the correction is
``(table[left] * s) * (1 - fraction) + (table[(left + 1) % 256] * s) * fraction`` with
``s = scale / 127``, in revolutions, and ``compensated = offset_value + correction * cpr``
(all in float32). encal rounds the int8 values (``compensate_encoder.py`` truncates).

Read back: the same lines (an existing correction, :func:`read_moteus_conf`), the output
file of ``utils/compare_encoders.py -o`` (one ``reference measured`` pair per line, in
revolutions; :func:`read_compare_encoders`), and the raw commutation capture that
``moteus_tool --calibrate`` records (``CAL start`` ... ``CAL done``; lines
``dir phase encoder [i1=.. i2=.. i3=..]``, phase and encoder uint16, dir 1 or 3 turning
the phase up, 2 or 4 down; ``lib/python/moteus/calibrate_encoder.py`` parses it; encal's
parser is :mod:`encal.selfcal.moteus_capture`): :func:`read_cal_capture` (the reference is the
unwrapped electrical phase over the pole pairs).
"""

import re

import numpy as np

from ...calibration import Calibration
from ...errors import CalibrationError, InputError
from ...selfcal.moteus_capture import UP_CODES, read_moteus_capture
from ..._limits import check_size
from ...parameters import check_int
from ._common import (FirmwareExport, checked, compensator, correction_model, correction_nodes, grid_bits, read_text,
                      round_trip)

__all__ = ["export_moteus", "moteus_rule", "read_moteus_conf", "read_compare_encoders", "read_cal_capture",
           "NODES"]

NODES = 256


def moteus_rule(table, scale, offset_value, cpr):
    """moteus's correction in revolutions (float32) at raw readings ``offset_value`` of ``cpr`` counts."""
    f32 = np.float32
    table = np.asarray(table, dtype=f32)
    ratio = np.asarray(offset_value, dtype=f32) * f32(1.0 / cpr)
    left = np.minimum(NODES - 1, (ratio * f32(NODES)).astype(np.int64))
    right = (left + 1) % NODES
    fraction = (ratio - left.astype(f32) / f32(NODES)) * f32(NODES)
    s = f32(scale) / f32(127.0)
    left_comp = table[left] * s
    right_comp = table[right] * s
    return left_comp * (f32(1.0) - fraction) + right_comp * fraction


def export_moteus(model, *, source=0, bits=None):
    """The ``conf set`` lines of a moteus compensation table for ``model``.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
    source : int, default=0
        ``motor_position.sources.K``.
    bits : int, optional
        Resolution of the encoder (cpr = 2^bits); default the model file's, else 16.

    Returns
    -------
    FirmwareExport
    """
    check_int(source, "source", "export_moteus", low=0, high=2, note="moteus's motor_position.sources.K")
    comp = compensator(model)
    grid = grid_bits(comp, bits, "export_moteus")
    nodes, target, offset = correction_nodes(comp, NODES, grid)
    revolutions = nodes / 21600.0
    scale = float(np.float32(np.max(np.abs(revolutions)))) or 1.0
    values = np.clip(np.rint(revolutions / scale * 127.0), -127, 127).astype(int)
    cpr = 2**grid
    deployed = moteus_rule(values, scale, np.arange(cpr), cpr).astype(float) * 21600.0
    max_error, rms_error = round_trip(deployed, target)
    prefix = f"conf set motor_position.sources.{source}"
    lines = [f"{prefix}.compensation_table.{i} {v}" for i, v in enumerate(values)]
    lines.append(f"{prefix}.compensation_scale {scale:.9g}")
    note = "send the lines with moteus_tool --console (or tview), then 'conf write'"
    return checked(FirmwareExport("moteus", "\n".join(lines) + "\n", max_error, rms_error,
                          0.5 * scale / 127.0 * 21600.0, cpr, note, offset), target)


_CONF = re.compile(r"^\s*(?:conf\s+set\s+)?motor_position\.sources\.(\d+)\.compensation_(table\.(\d+)|scale)\s+(\S+)\s*$")


def read_moteus_conf(source_text, *, source=None):
    """An existing moteus compensation (``conf set`` lines or ``conf enumerate`` output) as an encal model.

    Returns
    -------
    LookupTableModel
        The firmware's correction as an error model (nodes at I/256 revolutions, linear with wrap).
    """
    if source is not None:
        check_int(source, "source", "read_moteus_conf", low=0, high=2,
                  note="moteus's motor_position.sources.K, or None for the first")
    text, where = read_text(source_text)
    table, scale = {}, {}
    for number, line in enumerate(text.splitlines(), start=1):
        match = _CONF.match(line)
        if not match:
            continue
        k = int(match.group(1))
        if source is not None and k != source:
            continue
        try:
            value = float(match.group(4))
        except ValueError:
            raise InputError(f"{where}, line {number}: expected a number after {match.group(2)}, "
                             f"got {match.group(4)!r}") from None
        if match.group(3) is None:
            scale[k] = value
        else:
            table.setdefault(k, {})[int(match.group(3))] = value
    if not table:
        raise InputError(f"{where}: expected motor_position.sources.K.compensation_table lines, found none")
    k = min(table)
    if set(table[k]) != set(range(NODES)):
        raise InputError(f"{where}: expected compensation_table.0 to .255 of source {k}, got "
                         f"{len(table[k])} entries")
    values = np.array([table[k][i] for i in range(NODES)])
    # Without a scale (older firmware) the entries are revolutions themselves.
    revolutions = values * scale[k] / 127.0 if k in scale else values
    return correction_model(revolutions * 21600.0, name=f"moteus source {k}",
                            note="moteus compensation_table")


def _number_fields(where, number, line, count):
    fields = line.replace(",", " ").split()
    if len(fields) < count:
        raise CalibrationError(f"{where}, line {number}: expected {count} numbers, got {line.strip()!r}")
    values = []
    for column, field in enumerate(fields[:count], start=1):
        try:
            values.append(float(field))
        except ValueError:
            raise CalibrationError(f"{where}, line {number}, column {column}: expected a number, "
                                   f"got {field!r}") from None
    return values


def read_compare_encoders(source_text, *, name=None):
    """The output of moteus ``utils/compare_encoders.py -o FILE`` as a calibration.

    Each line is ``reference measured`` in revolutions (the reference encoder first).

    Returns
    -------
    Calibration
    """
    text, where = read_text(source_text)
    pairs = [_number_fields(where, number, line, 2)
             for number, line in enumerate(text.splitlines(), start=1)
             if line.strip() and not line.lstrip().startswith("#")]
    if len(pairs) < 8:
        raise CalibrationError(f"{where}: expected at least 8 'reference measured' lines, got {len(pairs)}")
    pairs = np.asarray(pairs)
    return Calibration(pairs[:, 0] * 360.0, pairs[:, 1] * 360.0, name=name or where, source=where)


def read_cal_capture(source, *, pole_pairs=None, name=None):
    """A moteus raw commutation capture (``CAL start`` ... ``CAL done``) as a calibration.

    The file is parsed by :func:`encal.selfcal.moteus_capture.read_moteus_capture` (one parser
    for the format); this turns it into a plain calibration against the commanded phase.
    ``encal selfcal sweep`` separates the motor's own error from the encoder's instead.

    Parameters
    ----------
    source : str or os.PathLike
        The capture file.
    pole_pairs : int, optional
        Motor pole pairs; default: the nearest whole ratio of the electrical phase travelled
        to the encoder travel while turning up (as moteus's calibrate_encoder.py finds it).
    name : str, optional

    Returns
    -------
    Calibration
        ``reference_deg`` = unwrapped electrical phase / pole pairs (its zero is arbitrary),
        ``encoder_deg`` = encoder * 360 / 65536, ``direction`` +1 for dir 1 and 3, -1 for 2 and 4.
    """
    if pole_pairs is not None:
        pole_pairs = check_size("pole_pairs", pole_pairs, "read_cal_capture")
    capture = read_moteus_capture(source)
    where = capture.source
    if capture.phase.size < 8:
        raise CalibrationError(f"{where}: expected at least 8 capture lines, got {capture.phase.size}")
    phase = _unwrap_counts(capture.phase)
    encoder = _unwrap_counts(capture.encoder)
    up = np.isin(capture.direction, UP_CODES)
    if pole_pairs is None:
        travel = encoder[up][-1] - encoder[up][0]
        if travel == 0:
            raise CalibrationError(f"{where}: the encoder did not move while the phase turned up; "
                                   "expected a capture of a turning motor (or pass pole_pairs)")
        ratio = abs((phase[up][-1] - phase[up][0]) / travel)
        pole_pairs = int(round(ratio))
        if pole_pairs < 1:
            raise CalibrationError(f"{where}: the electrical phase turned {ratio:.3g} times the encoder travel "
                                   "while turning up; expected at least one pole pair (or pass pole_pairs)")
    reference = phase * (360.0 / 65536.0) / pole_pairs
    return Calibration(reference, capture.encoder_deg, direction=np.where(up, 1, -1),
                       name=name or where, source=where, resolution_bits=16,
                       metadata={"pole_pairs": int(pole_pairs), "format": "moteus CAL capture"})


def _unwrap_counts(values):
    """uint16 counts made continuous (steps of more than half a turn are wraps)."""
    values = np.asarray(values, dtype=np.int64)
    steps = (np.diff(values) + 32768) % 65536 - 32768
    return np.concatenate([values[:1], values[0] + np.cumsum(steps)])

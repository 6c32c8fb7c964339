"""moteus (mjbots): the encoder compensation table, and moteus's calibration outputs as calibrations.

Format (``fw/motor_position.h`` of github.com/mjbots/moteus, ``SourceConfig`` and
``MotorPosition::lerp``; ``utils/compensate_encoder.py`` writes it), firmware 0x0109 (2024-10) and later::

    motor_position.sources.K.compensation_table.I <int8>     I = 0 .. 255
    motor_position.sources.K.compensation_scale <float>

as ``moteus_tool --restore-config FILE`` reads them (it prefixes each line with ``conf set`` itself,
drops what follows a ``#``, and ends with ``conf write``), or each line prefixed with ``conf set``
for a console (``moteus_tool --console``, tview).

The table is indexed by the source's ``offset_value = WrapIntCpr((raw + offset) * sign, cpr)``
(``ISR_UpdateAbsoluteSource``), not by the raw code: a table for a source with ``sign`` -1 or an
``offset`` is written for them (``export_moteus(..., sign=, offset=)``). Node ``I`` is at ``I / 256``
of the cpr; its value in revolutions is ``table[I] * scale / 127``. At run time
``ratio = offset_value * (1 / cpr)``, ``left = min(255, int(ratio * 256))``,
``fraction = (ratio - left / 256) * 256``, the correction is
``(table[left] * s) * (1 - fraction) + (table[(left + 1) % 256] * s) * fraction`` with
``s = scale / 127``, in revolutions, and ``compensated = WrapCpr(offset_value + correction * cpr)``
(all in float32). encal rounds the int8 values (``compensate_encoder.py`` truncates). ``conf get``
and ``conf enumerate`` print floats with ``%f``, so a configuration dump and restore (also the
automatic one of ``moteus_tool --flash``) keeps six decimals of the scale: encal writes the scale
rounded up to six decimals and states the round trip of that scale.

Firmware before 0x0109 held 32 float bins (revolutions) and no scale; :func:`read_moteus_conf`
reads them, encal writes only the 0x0109 format.

Read back: the same lines (an existing correction, :func:`read_moteus_conf`), the output
file of ``utils/compare_encoders.py -o`` (one ``reference measured`` pair per line, in
revolutions; :func:`read_compare_encoders`), and the raw commutation capture that
``moteus_tool --calibrate`` records (``CAL start`` ... ``CAL done``; lines
``dir phase encoder [i1=.. i2=.. i3=..]``, phase and encoder uint16, dir 1 or 3 turning
the phase up, 2 or 4 down; ``lib/python/moteus/calibrate_encoder.py`` parses it; encal's
parser is :mod:`encal.selfcal.moteus_capture`): :func:`read_cal_capture` (the reference is the
unwrapped electrical phase over the pole pairs).
"""

import math
import re

import numpy as np

from ...data.calibration import MAX_ABS_DEG, Calibration
from ..._core.errors import CalibrationError, InputError
from ..._core.number_cells import not_plain_note, read_number
from ...selfcal.moteus_capture import UP_CODES, read_moteus_capture
from ...selfcal.sweep import DEFAULT_SKIP, check_sweep_travel
from ..._core.limits import check_size
from ..._core.parameters import check_choice, check_int, check_number
from ..compact import _least_squares_nodes, evaluation_bits
from ._common import FirmwareExport, checked, compensator, correction_model, read_text, round_trip

__all__ = ["export_moteus", "moteus_rule", "moteus_compensated", "read_moteus_conf", "read_moteus_source_config",
           "read_compare_encoders", "read_cal_capture", "NODES", "OLD_NODES", "STYLES"]

NODES = 256
#: Bins of the float table of firmware before 0x0109 (no compensation_scale).
OLD_NODES = 32
#: How the lines are written: for ``moteus_tool --restore-config`` (no prefix) or a console (``conf set``).
STYLES = ("restore", "console")
#: Encoder resolutions a moteus table can be written for: 256 nodes need 256 codes; 2^24 (the iC-PZ) is the
#: largest cpr moteus handles, and beyond it its float32 position loses whole counts.
MIN_BITS, MAX_BITS = 8, 24


def moteus_rule(table, scale, offset_value, cpr):
    """moteus's correction in revolutions (float32) at offset values ``offset_value`` of ``cpr`` counts.

    ``MotorPosition::lerp(compensation_table, compensation_scale / 127.0f, offset_value * inv_cpr)``.
    """
    f32 = np.float32
    table = np.asarray(table, dtype=f32)
    nodes = table.size
    ratio = np.asarray(offset_value, dtype=f32) * (f32(1.0) / f32(cpr))
    left = np.minimum(nodes - 1, (ratio * f32(nodes)).astype(np.int64))
    right = (left + 1) % nodes
    fraction = (ratio - left.astype(f32) / f32(nodes)) * f32(nodes)
    s = f32(scale) / f32(127.0)
    left_comp = table[left] * s
    right_comp = table[right] * s
    return left_comp * (f32(1.0) - fraction) + right_comp * fraction


def moteus_compensated(table, scale, offset_value, cpr):
    """moteus's ``compensated_value`` (float32 counts): ``WrapCpr(offset_value + lerp(...) * cpr, cpr, inv_cpr)``."""
    f32 = np.float32
    cpr32 = f32(cpr)
    value = np.asarray(offset_value, dtype=f32) + moteus_rule(table, scale, offset_value, cpr) * cpr32
    divisor = (value * (f32(1.0) / cpr32)).astype(np.int64).astype(f32)  # static_cast<int>: towards zero
    mod = value - divisor * cpr32
    return np.where(mod >= f32(0.0), mod, mod + cpr32)


def _offset_counts(offset):
    """The offset the firmware adds: the float ``offset`` field converted to ``int32_t`` (towards zero)."""
    return int(np.trunc(np.float32(offset)))


def _correction_on_offset_values(comp, bits, grid, sign, offset):
    """The correction (arcmin) the table must add at each offset value of the evaluation grid, in the
    offset value's sense: ``sign`` times the correction at the raw code ``(sign * offset_value - offset) mod cpr``."""
    cpr = 2**bits
    offset_value = np.arange(2**grid, dtype=np.int64) << (bits - grid)
    raw = (sign * offset_value - _offset_counts(offset)) % cpr
    theta = raw * (360.0 / cpr)
    chunk = 1 << 16
    error = np.concatenate([np.asarray(comp.predict(theta[i:i + chunk]), dtype=float)
                            for i in range(0, theta.size, chunk)])
    return offset_value, sign * -comp.reading_sign * error


def _scale_text(largest_revolutions):
    """The scale as written: rounded up to the six decimals ``conf get`` (``%f``) keeps, at least 1e-6."""
    return f"{max(1, math.ceil(largest_revolutions * 1e6)) / 1e6:.6f}"


def export_moteus(model, *, source=0, bits=None, sign=1, offset=0, style="restore", commutation_source=None):
    """A moteus compensation table for ``model``, for ``moteus_tool --restore-config`` or a console.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
    source : int, default=0
        ``motor_position.sources.K``.
    bits : int, optional
        Resolution of the encoder (cpr = 2^bits), 8 to 24; default the model file's, else 16.
    sign : {1, -1}, default=1
        The source's ``motor_position.sources.K.sign``.
    offset : float, default=0
        The source's ``motor_position.sources.K.offset``, counts (the firmware truncates it to an integer).
    style : {'restore', 'console'}, default='restore'
        ``'restore'``: lines without ``conf set`` and ``#`` comments, for ``moteus_tool --restore-config``;
        ``'console'``: ``conf set`` lines and no comment, to send at a console, then ``conf write``.
    commutation_source : int, optional
        ``motor_position.commutation_source``, when known: the note says whether the commutation must be
        calibrated again.

    Returns
    -------
    FirmwareExport
        Its round trip is measured over every offset value, with the scale as the device holds it.

    Raises
    ------
    InputError
        For a correction that is not finite or reaches half a turn, or one the table cannot hold
        (see :func:`~encal.deploy.firmware._common.checked`).
    """
    check_int(source, "source", "export_moteus", low=0, high=2, note="moteus's motor_position.sources.K")
    if isinstance(sign, bool) or sign not in (1, -1):
        raise InputError(f"The 'sign' parameter of export_moteus must be 1 or -1 (moteus's "
                         f"motor_position.sources.K.sign). Got {sign!r} instead.")
    sign = int(sign)
    check_number(offset, "offset", "export_moteus", low=-2.0**30, high=2.0**30,
                 note="moteus's motor_position.sources.K.offset, counts")
    check_choice(style, "style", "export_moteus", STYLES)
    comp = compensator(model)
    resolved = comp.encoder.get("resolution_bits") if bits is None else bits
    resolved = 16 if resolved is None else resolved
    if isinstance(resolved, bool) or not isinstance(resolved, (int, np.integer)) or \
            not MIN_BITS <= resolved <= MAX_BITS:
        raise InputError(f"moteus: a {resolved!r}-bit encoder{'' if bits is not None else ' (the model file)'} "
                         f"cannot hold the table; expected --bits from {MIN_BITS} (its {NODES} nodes need at least "
                         f"{NODES} codes) to {MAX_BITS} (the largest cpr moteus handles)")
    resolved = int(resolved)
    grid = evaluation_bits(resolved)
    cpr = 2**resolved
    offset_value, target = _correction_on_offset_values(comp, resolved, grid, sign, offset)
    if not np.all(np.isfinite(target)):
        bad = int(np.flatnonzero(~np.isfinite(target))[0])
        raise InputError(f"moteus: the model's correction is {target[bad]} at offset value {int(offset_value[bad])}; "
                         "expected a finite correction, so no file was written")
    mean = float(np.mean(target))
    target = target - mean
    nodes = _least_squares_nodes(target, NODES)
    largest = float(np.max(np.abs(nodes))) / 21600.0
    if not largest < 0.5:
        raise InputError(f"moteus: the table would hold a correction of {largest * 360.0:.6g} deg; expected under "
                         "half a turn (180 deg), which is what a correction table can mean, so no file was written")
    scale_text = _scale_text(largest)
    scale = np.float32(float(scale_text))  # what the device holds, parsed or restored from %f
    values = np.clip(np.rint(nodes / 21600.0 / float(scale) * 127.0), -127, 127).astype(int)
    compensated = moteus_compensated(values, scale, offset_value, cpr).astype(float)
    moved = (compensated - offset_value + cpr / 2) % cpr - cpr / 2
    deployed = moved * (21600.0 / cpr)
    max_error, rms_error = round_trip(deployed, target)
    key = f"motor_position.sources.{source}"
    lines = [f"{key}.compensation_table.{i} {v}" for i, v in enumerate(values)]
    lines.append(f"{key}.compensation_scale {scale_text}")
    assumption = (f"the table is indexed by offset_value = wrap((raw + offset) * sign) and written for "
                  f"{key}.sign {sign} and {key}.offset {_offset_counts(offset)} on a {resolved}-bit encoder "
                  "(check them with 'conf get' and export again if they differ)")
    if commutation_source is None:
        commutation = (f"if source {source} is the commutation source (motor_position.commutation_source), "
                       "calibrate the commutation again afterwards (moteus_tool --calibrate)")
    elif commutation_source == source:
        commutation = (f"source {source} is the commutation source: calibrate the commutation again afterwards "
                       "(moteus_tool --calibrate)")
    else:
        commutation = ""
    if style == "restore":
        header = ["# encal: moteus encoder compensation (firmware 0x0109 or later: 256 int8 bins and a scale)",
                  f"# {assumption}",
                  "# load with: moteus_tool -t ID --restore-config FILE (it adds 'conf set' and ends with "
                  "'conf write')"]
        if commutation:
            header.append(f"# {commutation}")
        text = "\n".join(header + lines) + "\n"
        how = "load it with moteus_tool --restore-config (it writes the configuration)"
    else:
        text = "\n".join(f"conf set {line}" for line in lines) + "\n"
        how = "send the lines at a console (moteus_tool --console or tview), then 'conf write'"
    note = "; ".join(part for part in (assumption, how, commutation) if part)
    return checked(FirmwareExport("moteus", text, max_error, rms_error, 0.5 * float(scale) / 127.0 * 21600.0,
                                  offset_value.size, note, sign * mean), target)


_KEY = re.compile(r"^motor_position\.(?:sources\.(\d+)\.)?([A-Za-z_][\w.]*)$", re.ASCII)  # ASCII digits only


def _conf_items(text):
    """``(line number, source or None, field, value text)`` of each ``motor_position.`` line of a dump, a
    ``--restore-config`` file or ``conf set`` lines (what follows a ``#`` dropped, as moteus_tool does)."""
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.split("#", 1)[0].strip()
        line = re.sub(r"^conf\s+set\s+", "", line)
        parts = line.split()
        if len(parts) != 2:
            continue
        match = _KEY.match(parts[0])
        if match:
            yield number, (None if match.group(1) is None else int(match.group(1))), match.group(2), parts[1]


def _conf_number(where, number, field, text, *, whole=False):
    try:
        value = read_number(text)
    except ValueError:
        value = None
    if value is None or not math.isfinite(value) or (whole and value != int(value)):
        expected = "a whole number" if whole else "a finite number"
        raise InputError(f"{where}, line {number}: {field} is {text[:40]!r}; expected {expected}"
                         f"{not_plain_note(text)}")
    return value


def read_moteus_source_config(source_text, *, source=0):
    """The settings of ``motor_position.sources.K`` an export depends on, from a ``conf enumerate`` dump.

    Returns
    -------
    dict
        Those present of ``sign`` (1 or -1, as the firmware takes it), ``offset`` (counts), ``bits``
        (from ``cpr``, a power of two), ``commutation_source``, and ``table_entries`` (how many
        ``compensation_table`` entries the dump holds for the source: 32 before firmware 0x0109).
    """
    check_int(source, "source", "read_moteus_source_config", low=0, high=2, note="moteus's motor_position.sources.K")
    text, where = read_text(source_text)
    found, entries = {}, 0
    for number, k, field, value in _conf_items(text):
        if k is None:
            if field == "commutation_source":
                found["commutation_source"] = int(_conf_number(where, number, field, value, whole=True))
            continue
        if k != source:
            continue
        if field == "sign":
            found["sign"] = 1 if _conf_number(where, number, field, value, whole=True) >= 0 else -1
        elif field == "offset":
            found["offset"] = _conf_number(where, number, field, value)
            if abs(found["offset"]) > 2.0**30:  # as export_moteus checks it, here naming the line
                raise InputError(f"{where}, line {number}: offset is {value[:40]!r}; expected counts within "
                                 f"+-2^30 ({2.0**30:g})")
        elif field == "cpr":
            cpr = int(_conf_number(where, number, field, value, whole=True))
            if cpr < 1 or cpr & (cpr - 1):
                raise InputError(f"{where}, line {number}: motor_position.sources.{source}.cpr is {cpr}; expected a "
                                 "power of two (encal's tables are for encoders of 2^B counts)")
            found["bits"] = cpr.bit_length() - 1
        elif field.startswith("compensation_table."):
            entries += 1
    if not found:
        raise InputError(f"{where}: expected motor_position.sources.{source}.sign, .offset or .cpr lines "
                         "(the output of 'conf enumerate'), found none")
    found["table_entries"] = entries
    return found


def read_moteus_conf(source_text, *, source=None):
    """An existing moteus compensation (a ``--restore-config`` file, ``conf set`` lines or ``conf enumerate``
    output) as an encal model.

    Reads the 256 int8 entries and the scale of firmware 0x0109 and later, or the 32 float entries
    (revolutions, no scale) of earlier firmware.

    Parameters
    ----------
    source_text : str or os.PathLike
    source : int, optional
        ``motor_position.sources.K``; required when the text holds the tables of several sources.

    Returns
    -------
    LookupTableModel
        The firmware's correction as an error model (nodes at I/N of a turn, linear with wrap), as a
        function of the source's offset value (the raw reading when its sign is 1 and offset 0).

    Raises
    ------
    InputError
        For a table without its scale, tables of several sources without ``source``, a scale of another
        source than the table, a missing or extra entry, a value that is not a finite number (naming the
        file and line), or an int8 entry out of range.
    """
    if source is not None:
        check_int(source, "source", "read_moteus_conf", low=0, high=2,
                  note="moteus's motor_position.sources.K, or None for the only one")
    text, where = read_text(source_text)
    table, scale = {}, {}
    for number, k, field, value in _conf_items(text):
        if k is None or not field.startswith("compensation_"):
            continue
        match = re.fullmatch(r"compensation_(?:table\.(\d+)|scale)", field, flags=re.ASCII)
        if not match:
            continue
        number_value = _conf_number(where, number, f"motor_position.sources.{k}.{field}", value)
        if match.group(1) is None:
            scale[k] = (number_value, number)
        else:
            table.setdefault(k, {})[int(match.group(1))] = (number_value, number)
    if source is None and len(table) > 1:
        nonzero = [k for k in sorted(table) if any(v for v, _ in table[k].values())]
        raise InputError(f"{where}: holds the compensation tables of sources {', '.join(map(str, sorted(table)))} "
                         f"(non-zero: {', '.join(map(str, nonzero)) or 'none'}); expected one, so pass --source K")
    if source is not None:
        table = {k: v for k, v in table.items() if k == source}
    if not table:
        wanted = "K" if source is None else source
        raise InputError(f"{where}: expected motor_position.sources.{wanted}.compensation_table lines, found none")
    k = next(iter(table))
    others = sorted(set(scale) - {k})
    if others and source is None:
        raise InputError(f"{where}: the compensation_scale is of source {others[0]} and the table of source {k}; "
                         "expected both of one source, so pass --source K")
    entries = table[k]
    if set(entries) == set(range(OLD_NODES)):
        if k in scale:
            raise InputError(f"{where}, line {scale[k][1]}: a 32-entry table (firmware before 0x0109, revolutions) "
                             "with a compensation_scale; expected 256 entries with a scale, or 32 without")
        revolutions = np.array([entries[i][0] for i in range(OLD_NODES)])
        note = "moteus compensation_table, 32 float bins (firmware before 0x0109)"
        scaled = " revolutions"
    elif set(entries) == set(range(NODES)):
        if k not in scale:
            raise InputError(f"{where}: the 256-entry compensation_table of source {k} has no "
                             f"motor_position.sources.{k}.compensation_scale line; expected one (without it the "
                             "entries' size is unknown)")
        for i in range(NODES):
            value, number = entries[i]
            if value != int(value) or not -128 <= value <= 127:
                raise InputError(f"{where}, line {number}: compensation_table.{i} is {value:g}; expected a whole "
                                 "number from -128 to 127 (an int8)")
        with np.errstate(over="ignore"):  # a scale of 1e308 is refused below, as a correction beyond half a turn
            revolutions = np.array([entries[i][0] for i in range(NODES)]) * scale[k][0] / 127.0
        note = "moteus compensation_table"
        scaled = f" times compensation_scale {scale[k][0]:g} / 127, line {scale[k][1]}"
    else:
        raise InputError(f"{where}: expected compensation_table.0 to .255 of source {k} (firmware 0x0109 or later) "
                         f"or .0 to .31 (earlier), got {len(entries)} entries")
    with np.errstate(over="ignore"):
        correction_arcmin = revolutions * 21600.0
    return correction_model(correction_arcmin, name=f"moteus source {k}", note=note, where=where,
                            entry=lambda i: f"compensation_table.{i} on line {entries[i][1]} "
                                            f"({entries[i][0]:g}{scaled})")


_DECIMAL_COMMA = re.compile(r"\d,\d")


def _pair_fields(where, number, line):
    """The two numbers of a ``reference measured`` line (space- or comma-separated, finite)."""
    fields = [field for field in re.split(r"[\s,]+", line.strip()) if field]
    if len(fields) != 2:
        if _DECIMAL_COMMA.search(line) and len(line.split()) >= 2:
            raise CalibrationError(f"{where}, line {number}: {line.strip()[:60]!r} has decimal commas; expected two "
                                   "numbers with decimal points, as compare_encoders.py writes them")
        raise CalibrationError(f"{where}, line {number}: expected 2 numbers 'reference measured', got "
                               f"{line.strip()[:60]!r}")
    values = []
    for column, field in enumerate(fields, start=1):
        try:
            value = read_number(field)
        except ValueError:
            value = None
        if value is None or not math.isfinite(value):
            raise CalibrationError(f"{where}, line {number}, column {column}: expected a finite number, "
                                   f"got {field[:40]!r}{not_plain_note(field)}")
        if abs(value) * 360.0 > MAX_ABS_DEG:  # fuzz5: -1e308 revolutions was -inf degrees, a message naming no line
            raise CalibrationError(f"{where}, line {number}, column {column}: expected revolutions within "
                                   f"+-{MAX_ABS_DEG / 360.0:.4g} (+-{MAX_ABS_DEG:g} degrees, as in a calibration CSV), "
                                   f"got {field[:40]!r}")
        values.append(value)
    return values


def read_compare_encoders(source_text, *, name=None):
    """The output of moteus ``utils/compare_encoders.py -o FILE`` as a calibration.

    Each line is ``reference measured`` in revolutions (the reference encoder first), as Python's
    ``print(r, m)`` writes them; a comma between the two is accepted, decimal commas are refused.

    Returns
    -------
    Calibration
    """
    text, where = read_text(source_text)
    pairs = [_pair_fields(where, number, line)
             for number, line in enumerate(text.splitlines(), start=1)
             if line.strip() and not line.lstrip().startswith("#")]
    if len(pairs) < 8:
        raise CalibrationError(f"{where}: expected at least 8 'reference measured' lines, got {len(pairs)}")
    pairs = np.asarray(pairs)
    return Calibration(pairs[:, 0] * 360.0, pairs[:, 1] * 360.0, name=name or where, source=where)


def read_cal_capture(source, *, pole_pairs=None, name=None):
    """A moteus raw commutation capture (``CAL start`` ... ``CAL done``) as a calibration.

    The file is parsed by :func:`encal.selfcal.moteus_capture.read_moteus_capture` and its pole pairs
    checked by :func:`encal.selfcal.sweep.check_sweep_travel`, as ``encal selfcal sweep`` does; this
    turns it into a plain calibration against the commanded phase, where ``encal selfcal sweep``
    separates the motor's own error from the encoder's. As the sweep does, it leaves out the first
    samples (the rotor settling), takes the reference in the encoder's sense (the phase's sense is the
    wiring's), and removes the rotor's lag behind the command: half the difference of the mean error
    going down and going up, subtracted from the reference along the direction of travel.

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
        ``reference_deg`` = unwrapped electrical phase / pole pairs (its zero is arbitrary), negated when
        the encoder counts against the phase, minus the lag along the travel; ``encoder_deg`` = encoder *
        360 / 65536; ``direction`` +1 where the reference increases. A sample that repeats an angle of its
        pass (the closing sample of a whole turn) is left out; the passes of directions 3 and 4 are epoch
        ``'pass 2'``. ``metadata`` holds the pole pairs, the lag (arcmin) and the sense.

    Raises
    ------
    InputError, CalibrationError
        For a capture the parser refuses, fewer than 8 samples, or a pole-pair count the encoder's travel
        does not match (the message names the count that fits).
    """
    if pole_pairs is not None:
        pole_pairs = check_size("pole_pairs", pole_pairs, "read_cal_capture")
    capture = read_moteus_capture(source)
    where = capture.source
    skip = DEFAULT_SKIP
    if capture.phase.size - skip < 8:
        raise CalibrationError(f"{where}: expected at least {8 + skip} capture lines (the first {skip} are the rotor "
                               f"settling), got {capture.phase.size}")
    phase = _unwrap_counts(capture.phase)[skip:]
    encoder = _unwrap_counts(capture.encoder)[skip:]
    codes = capture.direction[skip:]
    up = np.isin(codes, UP_CODES)
    for mask, label in ((up, "up (direction 1 or 3)"), (~up, "down (direction 2 or 4)")):
        if np.count_nonzero(mask) < 2:
            raise CalibrationError(f"{where}: after the {skip} settling samples the pass {label} has "
                                   f"{np.count_nonzero(mask)} samples; expected at least 2")
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
    reading = encoder * (360.0 / 65536.0)
    against = False
    for mask, label in ((up, "up"), (~up, "down")):
        against = check_sweep_travel(where, label, reference[mask], reading[mask], pole_pairs)
    sense = -1.0 if against else 1.0
    reference = sense * reference
    direction = np.where(up, 1, -1) * int(sense)
    error = reading - reference
    lag = 0.5 * (np.mean(error[direction == -1]) - np.mean(error[direction == 1]))
    reference = reference - direction * lag
    epoch = np.where(np.isin(codes, (3, 4)), "pass 2", "pass 1") if np.isin(codes, (3, 4)).any() else None
    keys = np.round(np.mod(reference, 360.0), 9)
    passes = epoch if epoch is not None else np.full(keys.size, "")
    seen, keep = set(), []
    for index, key in enumerate(zip(direction.tolist(), passes.tolist(), keys.tolist())):
        if key not in seen:
            seen.add(key)
            keep.append(index)
    keep = np.asarray(keep)
    return Calibration(reference[keep], reading[keep], direction=direction[keep],
                       epoch=None if epoch is None else epoch[keep],
                       name=name or where, source=where, resolution_bits=16,
                       metadata={"pole_pairs": int(pole_pairs), "format": "moteus CAL capture",
                                 "lag_arcmin": float(lag * 60.0), "encoder_counts_against_phase": bool(against),
                                 "settling_samples_left_out": skip})


def _unwrap_counts(values):
    """uint16 counts made continuous (steps of more than half a turn are wraps)."""
    values = np.asarray(values, dtype=np.int64)
    steps = (np.diff(values) + 32768) % 65536 - 32768
    return np.concatenate([values[:1], values[0] + np.cumsum(steps)])

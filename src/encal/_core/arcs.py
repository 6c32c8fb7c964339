"""Calibrations over an arc: the range a calibration covers, and the rule for a reading outside it.

A joint that cannot turn a full revolution (a robot arm, a gimbal) is calibrated over an arc. The model
then knows the error only there: its ``range_deg = [start, end]`` (degrees of the model's input angle,
going forward round the circle from ``start`` to ``end``; ``None`` for a full turn) is recorded in the
model file, and a reading outside it is never corrected silently:

- the Python API (``Model.predict``, ``Model.correct``, the runtime) answers NaN there;
- ``encal correct --outside error|clamp|pass`` refuses it (default), uses the correction of the nearer
  end of the arc (``clamp``), or leaves the reading uncorrected (``pass``);
- the exports (dense table, C, firmware tables, all periodic) refuse an arc model unless given
  ``--outside clamp`` or ``--outside pass``, which they honour exactly (docs/in-place.md).
"""


import numpy as np

from .angles import ARCMIN_PER_DEG, model_input, wrap360
from .errors import InputError, ModelFileError

__all__ = ["arc_of", "no_gap_over", "inside", "clamp_to_range", "check_range", "describe_range", "OUTSIDE_RULES",
           "apply_outside_rule", "OutsideRule", "refuse_arc", "periodic_for_export",
           "within_model_range", "codes_in_range"]

#: What to do with a reading outside a model's calibrated range.
OUTSIDE_RULES = ("error", "clamp", "pass")
#: An angle this close to an end of the range (degrees) counts as inside: a reading at the end itself, rounded.
RANGE_TOLERANCE_DEG = 1e-9
#: The same in a float header (cortex-m4f): two float steps near 360 degrees, 2^-14 degree (0.22 arc-seconds); 1e-6
#: was below a float's step there, and a reading at the end rounded outside on about one arc in four.
FLOAT_RANGE_TOLERANCE_DEG = 2.0**-14


def arc_of(angles_deg, max_gap_deg):
    """The arc ``(start, end)`` in degrees that angles cover when they leave exactly one gap over
    ``max_gap_deg`` round the circle, else None (a full turn, or several gaps: scattered data).

    Examples
    --------
    >>> arc_of([10.0, 40.0, 70.0, 100.0, 130.0], 30.0)
    (10.0, 130.0)
    >>> arc_of([350.0, 0.0, 20.0], 30.0)
    (350.0, 20.0)
    >>> arc_of(np.arange(0.0, 360.0, 10.0), 30.0) is None
    True
    """
    angles = wrap360(np.asarray(angles_deg, dtype=float)).reshape(-1)
    if angles.size > _FEW and _every_bin_filled(angles, max_gap_deg / 2.0):
        return None  # no gap over max_gap_deg: a full turn, told without a sort of the angles
    angles = np.unique(angles)
    if angles.size < 2:
        return None
    gaps = np.diff(np.concatenate([angles, angles[:1] + 360.0]))
    large = np.flatnonzero(gaps > max_gap_deg + 1e-9)
    if large.size != 1:
        return None
    before = int(large[0])
    return float(angles[(before + 1) % angles.size]), float(angles[before])


def no_gap_over(angles_deg, max_gap_deg):
    """True when the angles (degrees in [0, 360)) fill every bin of half ``max_gap_deg`` round the circle: then no
    gap between neighbouring angles exceeds ``max_gap_deg`` (a longer one would hold a whole bin), and
    :func:`arc_of` is None. False says nothing (the angles may still leave no such gap): one pass, no sort.

    Examples
    --------
    >>> no_gap_over(np.arange(0.0, 360.0, 1.0), 30.0), no_gap_over(np.arange(0.0, 300.0, 1.0), 30.0)
    (True, False)
    """
    angles = np.asarray(angles_deg, dtype=float).reshape(-1)
    return _every_bin_filled(angles, max_gap_deg / 2.0)


#: Angles from which :func:`arc_of` first looks for a gap by bins.
_FEW = 4096


def _every_bin_filled(angles, width_deg):
    """Whether every bin of ``width_deg`` degrees round the circle (the last one shorter) holds one of the angles
    (in [0, 360)). Then no gap between neighbouring angles exceeds ``2 width_deg``: a longer one would hold a whole
    bin. One pass, against the sort of 10^6 angles (12 ms for a sweep's, 70 ms for random ones)."""
    if not width_deg > 0.0:
        return False
    bins = int(np.ceil(360.0 / width_deg))
    if bins > angles.size:
        return False
    index = (angles / width_deg).astype(np.intp)
    if index.min() < 0:  # NaN: left to the sort
        return False
    np.minimum(index, bins - 1, out=index)  # an angle just under 360 whose quotient rounds up
    return bool(np.bincount(index, minlength=bins).all())


def span_of(range_deg):
    """Degrees from the start of ``range_deg`` forward to its end (360 for None)."""
    if range_deg is None:
        return 360.0
    return float((range_deg[1] - range_deg[0]) % 360.0)


def inside(theta_deg, range_deg):
    """True where the model-input angle ``theta_deg`` lies in ``range_deg`` (everywhere for None)."""
    theta = np.asarray(theta_deg, dtype=float)
    if range_deg is None:
        return np.ones(theta.shape, dtype=bool)
    offset = np.mod(theta - range_deg[0], 360.0)
    span = span_of(range_deg)
    return (offset <= span + RANGE_TOLERANCE_DEG) | (offset >= 360.0 - RANGE_TOLERANCE_DEG)


def clamp_to_range(theta_deg, range_deg):
    """Each angle, or the nearer end of ``range_deg`` (round the circle) for one outside it."""
    theta = np.asarray(theta_deg, dtype=float)
    if range_deg is None:
        return theta
    start, end = float(range_deg[0]), float(range_deg[1])
    after_end = np.mod(theta - end, 360.0)
    before_start = np.mod(start - theta, 360.0)
    clamped = np.where(after_end <= before_start, end, start)
    return np.where(inside(theta, range_deg), theta, clamped)


def check_range(value, where):
    """A model file's ``range_deg``: None or two finite numbers of degrees in [0, 360) that differ."""
    if value is None:
        return None
    if (not isinstance(value, (list, tuple)) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in value)
            or not all(0.0 <= v < 360.0 for v in value) or value[0] == value[1]):
        raise ModelFileError(f"{where}: expected range_deg to be null or [start, end], two different numbers of "
                             f"degrees in [0, 360), got {value!r}")
    return [float(value[0]), float(value[1])]


def describe_range(range_deg):
    """``'10 to 130 deg'``, or ``'the full turn'``."""
    if range_deg is None:
        return "the full turn"
    return f"{range_deg[0]:.6g} to {range_deg[1]:.6g} deg (an arc of {span_of(range_deg):.6g} deg)"


def apply_outside_rule(model, theta_enc_deg, rule, *, where="reading", direction=None):
    """Corrected angles (degrees) of ``model``, with ``rule`` for the readings outside its range.

    Parameters
    ----------
    model : Model or Compensator
        Anything with ``correct``, ``predict``, ``reading_sign`` and ``range_deg`` (through ``model``).
    theta_enc_deg : array-like
        Encoder readings, degrees.
    rule : {'error', 'clamp', 'pass'}
        ``error``: InputError naming the first reading outside; ``clamp``: the correction of the nearer end
        of the range; ``pass``: the reading uncorrected (in the model's sense of the angle).
    """
    target = getattr(model, "model", model)
    range_deg = getattr(target, "range_deg", None)
    theta = np.asarray(theta_enc_deg, dtype=float)
    corrected = np.asarray(model.correct(theta) if direction is None else model.correct(theta, direction),
                           dtype=float)
    if range_deg is None:
        return corrected
    wrapped = model_input(theta, target.reading_sign)  # one rounding, as the model's own (wrapped first: two)
    outside = ~inside(wrapped, range_deg)
    if not outside.any():
        return corrected
    if rule == "error":
        first = theta.reshape(-1)[int(np.flatnonzero(outside.reshape(-1))[0])]
        raise InputError(f"the {where} {first:.10g} deg is outside the calibrated range {describe_range(range_deg)}; "
                         "expected readings inside it (pass --outside clamp to use the correction of the nearer "
                         "end, or --outside pass to leave such readings uncorrected)")
    corrected = np.array(corrected, dtype=float, copy=True)
    if rule == "pass":
        corrected[outside] = wrapped[outside]
        return corrected[()]
    held = clamp_to_range(wrapped[outside], range_deg)
    # the model sees model-input angles; feed it readings that map onto the held angles exactly (-held for a
    # reversed encoder: negated and wrapped, it is held again, where 360 - held would round)
    readings = held if target.reading_sign == 1 else -held
    if direction is None:
        error = np.asarray(target.predict(readings), dtype=float)
    else:  # a directional model: each reading's own direction's correction at the nearer end, not their mean
        directions = np.broadcast_to(np.asarray(direction), theta.shape)[outside]
        error = np.asarray(target.predict(readings, direction=directions), dtype=float)
    corrected[outside] = wrap360(wrapped[outside] - error / ARCMIN_PER_DEG)
    return corrected[()]


class OutsideRule:
    """A compensator that applies ``rule`` to readings outside the model's range (for ``encal correct``)."""

    def __init__(self, compensator, rule, where="reading"):
        if rule not in OUTSIDE_RULES:
            raise InputError(f"expected --outside to be one of {', '.join(OUTSIDE_RULES)}, got {rule!r}")
        self.compensator, self.rule, self.where = compensator, rule, where

    def correct(self, theta_deg, direction=None):
        return apply_outside_rule(self.compensator, theta_deg, self.rule, where=self.where, direction=direction)

    def __getattr__(self, name):
        return getattr(self.compensator, name)


def refuse_arc(compensator, what):
    """InputError when the model of ``compensator`` holds only over an arc: ``what`` (a periodic table or
    formula of the whole turn) cannot say "outside"; :func:`periodic_for_export` makes one that honours a rule."""
    model = getattr(compensator, "model", compensator)
    if getattr(model, "range_deg", None) is not None:
        source = getattr(compensator, "source", None) or "the model"
        raise InputError(f"{source} is calibrated over {describe_range(model.range_deg)} only, and {what} covers "
                         "the whole turn with no way to say 'outside'; expected a rule for the rest of the turn "
                         "(pass --outside clamp to hold the nearer end's correction, or --outside pass for none; "
                         "in Python, export model.full_turn('clamp') or model.full_turn('pass'))")


def periodic_for_export(model, rule):
    """A full-turn model equal to ``model`` on its arc and following ``rule`` ('clamp' or 'pass') outside it,
    for the periodic exports (dense table, C, firmware tables).

    Only the ``arc`` kind can be extended exactly (its pieces outside the arc are replaced); a model of
    another kind fitted over an arc is refused in one sentence.
    """
    if getattr(model, "range_deg", None) is None:
        return model
    if rule not in ("clamp", "pass"):
        raise InputError(f"expected --outside clamp or pass for an export of a model calibrated over an arc, "
                         f"got {rule!r}: a periodic table cannot refuse a reading")
    if getattr(model, "kind", None) != "arc":
        raise InputError(f"the {model.kind} model is calibrated over {describe_range(model.range_deg)}, and only "
                         "an arc model (the default of encal fit on an arc) can be extended to the whole turn by "
                         "--outside; expected one (refit with --method arc)")
    return model.full_turn(rule)


def within_model_range(model, cal):
    """Mask of the points of ``cal`` inside the range of ``model`` (all for a full-turn model), for statistics
    over the arc; warns once naming how many are left out, and refuses a calibration with none inside."""
    import warnings

    from .errors import CalibrationError, EncalWarning

    range_deg = getattr(model, "range_deg", None)
    keep = inside(cal.encoder_deg, range_deg)
    where = cal.source or cal.name or "the calibration"
    if not keep.any():
        raise CalibrationError(f"{where}: none of its {keep.size} encoder angles lies in the model's calibrated "
                               f"range {describe_range(range_deg)}; expected readings inside it")
    if not keep.all():
        warnings.warn(EncalWarning(f"{where}: {int((~keep).sum())} of {keep.size} readings lie outside the model's "
                                   f"calibrated range {describe_range(range_deg)} and are left out of the "
                                   "statistics"))
    return keep


def codes_in_range(range_deg, bits, reading_sign=1):
    """The first and the last code of a ``bits``-bit encoder (going forward) whose reading, ``code * 360 / 2^bits``
    degrees, lies in ``range_deg`` as :func:`inside` of its model input tells; ``(0, 2^bits - 1)`` when every code
    does, None when none does (an arc narrower than a code, between two).

    Each code near an end is asked, not the end's floor: a code just below a start between two codes is outside.

    Examples
    --------
    >>> codes_in_range([10.0, 20.0], 12), codes_in_range([10.0, 20.0], 12, reading_sign=-1)
    ((114, 227), (3869, 3982))
    """
    codes = 1 << int(bits)
    step = 360.0 / codes
    ends = np.asarray(range_deg, dtype=float) if reading_sign == 1 else np.mod(-np.asarray(range_deg)[::-1], 360.0)
    near = np.floor(ends / step).astype(np.int64)[:, None] + np.arange(-2, 4)  # each end's neighbours, in order
    candidates = np.mod(near, codes)
    held = inside(model_input(candidates * step, reading_sign), range_deg)
    before = inside(model_input(np.mod(candidates - 1, codes) * step, reading_sign), range_deg)
    after = inside(model_input(np.mod(candidates + 1, codes) * step, reading_sign), range_deg)
    firsts, lasts = candidates[held & ~before], candidates[held & ~after]
    if firsts.size and lasts.size:
        return int(firsts[0]), int(lasts[-1])
    # no end among the neighbours: every code is inside (a gap narrower than a code) or none
    return (0, codes - 1) if bool(held.any()) else None


def with_range_in_header(files, prefix, target, range_deg, rule, bits=None, reading_sign=1):
    """The C files of an export of an arc model, its header stating the range and a test of it.

    The export itself covers the whole turn and follows ``rule`` outside the arc; the header adds
    ``PREFIX_RANGE_START_DEG``, ``PREFIX_RANGE_END_DEG`` and ``PREFIX_in_range(angle)`` (1 inside, 0 outside;
    ``float`` for cortex-m4f, ``double`` for host; not for ``fixed``, integers only), and with the resolution
    (``bits``; required for ``fixed``) the range in codes and ``PREFIX_in_range_code(code)``, exactly the codes
    whose readings encal takes as inside (:func:`codes_in_range`), so that firmware can tell a reading the
    calibration did not cover.
    """
    name = f"{prefix}.h"
    upper = prefix.upper()
    start, end = float(range_deg[0]), float(range_deg[1])
    if reading_sign == -1:  # the range is of the negated reading: in the encoder's own sense it runs -end .. -start
        start, end = float(np.mod(-end, 360.0)), float(np.mod(-start, 360.0))
    span = span_of(range_deg)
    meaning = "the nearer end's correction" if rule == "clamp" else "no correction"
    test = f"{prefix}_in_range{'_code' if bits is not None else ''}()"
    lines = [f"/* Calibrated over an arc only (encal, issue 31): encoder readings from {start!r} to {end!r} deg,",
             "   going forward (through 0 when the start is the larger). Outside it the functions below follow",
             f"   the rule --outside {rule} ({meaning}), which is no calibration: test {test} first. */",
             f"#define {upper}_RANGE_START_DEG {start!r}",
             f"#define {upper}_RANGE_END_DEG {end!r}"]
    if target == "fixed" and bits is None:
        raise InputError("the fixed-point export of an arc model needs the encoder resolution to state its "
                         "range in codes; pass --bits B")
    if target != "fixed":
        real, suffix = ("float", "f") if target == "cortex-m4f" else ("double", "")
        # within the tolerance of an end is inside: in double the model's own (RANGE_TOLERANCE_DEG); in float two
        # of its steps near 360 degrees (2^-14), since the reading, the start and the span are each rounded to one
        tolerance = repr(RANGE_TOLERANCE_DEG) if real == "double" else repr(FLOAT_RANGE_TOLERANCE_DEG)
        # A reading outside [0, 360) (in (-180, 180], or unwrapped) is wrapped as the correction wraps it: only
        # one turn was added, and -170 deg on an arc of 210..330 deg was inside (arc8). No libm (the header
        # includes only stdint.h); NaN, infinity and |offset| over 1e15 deg are outside, with no undefined cast.
        lines += ["/* 1 when the reading (degrees, any turn) lies in the calibrated range, else 0. */",
                  f"static inline int {prefix}_in_range({real} angle_deg) {{",
                  f"    {real} offset = angle_deg - ({real}){start!r}{suffix};",
                  f"    if (!(offset >= -360.0{suffix} && offset < 360.0{suffix})) {{",
                  f"        if (!(offset > -1e15{suffix} && offset < 1e15{suffix})) return 0;",
                  f"        offset -= 360.0{suffix} * ({real})(long long)(offset / 360.0{suffix});",
                  "    }",
                  f"    if (offset < 0.0{suffix}) offset += 360.0{suffix};",
                  f"    return offset <= ({real}){span!r}{suffix} + {tolerance}{suffix}"
                  f" || offset >= 360.0{suffix} - {tolerance}{suffix};",
                  "}"]
    if bits is not None:  # the test of a code, exact in integers, wherever the code functions are exported
        codes = 1 << int(bits)
        held = codes_in_range(range_deg, bits, reading_sign)
        if held is None:  # an arc between two codes: no code's reading is inside
            first, last, code_test = 1, 0, "(void)code;\n    return 0;"
        else:
            first, last = held
            code_test = (f"return ((code - {upper}_RANGE_START_CODE) & {codes - 1}u) <= "
                         f"(({upper}_RANGE_END_CODE - {upper}_RANGE_START_CODE) & {codes - 1}u);")
        none = " None is: START is past END." if held is None else ""
        lines += [f"/* The first and the last code whose reading, code * 360 / 2^{bits} deg, encal takes as inside",
                  f"   (within 1e-9 deg of an end), as the functions below correct it.{none} */",
                  f"#define {upper}_RANGE_START_CODE {first}u",
                  f"#define {upper}_RANGE_END_CODE {last}u",
                  f"/* 1 when the code (0 .. 2^{bits} - 1) lies in the calibrated range, else 0. */",
                  f"static inline int {prefix}_in_range_code(uint32_t code) {{",
                  f"    {code_test}",
                  "}"]
    block = "\n".join(lines) + "\n"
    header = files[name]
    marker = "#ifdef __cplusplus\n}"
    at = header.rfind(marker)
    if at < 0:
        raise InputError(f"the header {name} has no closing extern block to add the range before")
    return {**files, name: header[:at] + block + "\n" + header[at:]}

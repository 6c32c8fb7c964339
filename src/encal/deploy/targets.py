"""C for a deployment target: ``host`` (double), ``cortex-m4f`` (float32 only), ``fixed`` (integers only).

- ``host``: :func:`encal.deploy.cexport.export_c`, the model's formula in double
  (or its dense per-code table).
- ``cortex-m4f``: single precision only, for processors whose FPU has no
  double (Cortex-M4F, M33, ESP32): no ``double`` anywhere; it compiles
  with ``-Wdouble-promotion -Werror``. Either a compact table
  (:mod:`encal.deploy.compact`; every kind; linear or cubic B-spline
  interpolation) or, for a Fourier series, the
  series itself (``form='formula'``), its phases taken exactly as 32-bit
  binary angles (``k * theta`` modulo one turn is an integer product).
- ``fixed``: int32/int16 arithmetic only, for processors without an FPU: a
  compact integer table interpolated in fixed point (linear or cubic B-spline).

Every target takes and returns encoder codes as well as angles::

    cortex-m4f                                   fixed
    float P_predict_arcmin(float theta_deg);     int32_t  P_error_bam32(uint32_t angle);
    float P_correct_deg(float theta_deg);        uint32_t P_correct_bam32(uint32_t angle);
    float P_error_lsb(uint32_t code);            int32_t  P_error_lsb_q8(uint32_t code);
    uint32_t P_correct_code(uint32_t code);      uint32_t P_correct_code(uint32_t code);
    float P_correct_counts(uint32_t code);

(a 32-bit binary angle is a fraction of a turn times 2^32; ``q8``: 1/256 LSB).
The code functions need the encoder resolution; without it they are left
out and the banner says so. The arithmetic here is exactly what
:func:`encal.deploy.compact.predict_float32`, :func:`~encal.deploy.compact.predict_fixed`
and :func:`fourier_float32` compute, step by step, so their stated deployed
errors are those of the compiled code.
"""

import math

import numpy as np

from .._core.atomic import write_file_set
from .._core.errors import InputError
from .._core.parameters import check_choice, check_int, check_number, invalid
from .cexport import _banner, _check_identifier, host_export
from .deployment import COSTS, choose_deployment
from .compact import (BAM_ARCMIN, CUBIC_FRACTION_BITS, FIXED_FRACTION_BITS, INTERPOLATIONS, MAX_NODES,
                      MIN_NODES, MIN_TABLE_BITS, NODE_DTYPES, check_exportable, check_nodes, choose_compact,
                      compile_compact, default_tolerance_arcmin, evaluation_bits, model_on_codes)
from .compensator import Compensator
from .costs import OPERATIONS, reading_cost_key
from .series32 import fourier_float32, fourier_terms

__all__ = ["TARGETS", "FORMS", "export_target", "write_target", "describe"]

TARGETS = ("host", "cortex-m4f", "fixed")
FORMS = ("table", "formula")
_MAX_FIXED_COUNT_BITS = 24

def export_target(model, target="host", *, prefix="encal", bits=None, form="table", nodes=None,
                  dtype=None, tolerance_arcmin=None, cost=None, interpolation=None, **host_options):
    """C source for a deployment target.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
    target : {'host', 'cortex-m4f', 'fixed'}, default='host'
    prefix : str, default='encal'
        Prefix of the files and exported identifiers; a C identifier.
    bits : int, optional
        Encoder resolution; default the model file's. Without it (cortex-m4f,
        fixed) the code functions are left out.
    form : {'table', 'formula'}, default='table'
        cortex-m4f: a compact table, or the model's Fourier series itself.
    nodes : int, optional
        Nodes of the compact table (a power of two); default the fewest that
        meet ``tolerance_arcmin``.
    dtype : {'int8', 'int16', 'float32'}, optional
        Storage of the nodes; default the cheapest in bytes that meets the tolerance.
    tolerance_arcmin : float, optional
        Largest deployed error allowed when choosing the table (default a tenth of an LSB).
    interpolation : {'linear', 'cubic'}, optional
        Of the compact table; default the cheaper in bytes that meets the tolerance (linear when
        both are as small).
    cost : {'bytes', 'entries', 'operations'}, optional
        Choose among every deployment of the target (tables and, for a Fourier series,
        the formula) the cheapest in this cost within the tolerance
        (:func:`encal.deploy.deployment.choose_deployment`). Without it, and without
        ``nodes``/``dtype``, the deployment recorded by ``encal fit --budget`` is used
        when there is one for this target, else the smallest table within the tolerance.
    **host_options
        ``table`` and ``constants`` of :func:`~encal.deploy.cexport.export_c` (host only).

    Returns
    -------
    files : dict of str to str
        ``{'<prefix>.h': ..., '<prefix>.c': ...}``.
    summary : dict
        What was exported: ``target, form, nodes, dtype, table_bytes,
        max_error_arcmin, rms_error_arcmin, operations, bits, note``.
    """
    caller = "export_target"
    check_choice(target, "target", caller, TARGETS)
    check_choice(form, "form", caller, FORMS)
    _check_identifier(prefix, caller)
    check_choice(dtype, "dtype", caller, (None, *NODE_DTYPES))
    check_choice(interpolation, "interpolation", caller, (None, *INTERPOLATIONS))
    check_choice(cost, "cost", caller, (None, *COSTS))
    if tolerance_arcmin is not None:
        check_number(tolerance_arcmin, "tolerance_arcmin", caller, low=0.0, low_open=True,
                     note="arc-minutes, or None")
    comp = model if isinstance(model, Compensator) else Compensator(model)
    from .._core.arcs import refuse_arc

    refuse_arc(comp, "the C export")  # periodic: it cannot say "outside" (see encal._core.arcs)
    if target == "host":
        if nodes is not None or tolerance_arcmin is not None or form != "table":
            raise InputError("--nodes, --tolerance and --form apply to the cortex-m4f and fixed targets, "
                             "not host (its C evaluates the formula in double, or --table)")
        files, how = host_export(comp, prefix=prefix, bits=bits, **host_options)
        known = bits is not None or comp.encoder.get("resolution_bits") is not None
        note = None if known else ("the encoder resolution is unknown (pass bits=, --bits): the formula is "
                                   f"exported without {prefix}_correct_counts")
        return files, {"target": "host", "form": "table" if host_options.get("table") else "formula",
                       "how": how.split(";\n")[0], "note": note}
    if host_options:
        raise InputError(f"{', '.join(sorted(host_options))} apply to the host target only")
    bits = _bits(comp, bits, target, form)
    if nodes is not None:
        check_nodes(nodes, bits, caller)
    chosen = _chosen(comp, target, bits, form, nodes, dtype, tolerance_arcmin, cost, interpolation)
    if chosen is not None:
        form, nodes, dtype = chosen["form"], chosen["nodes"], chosen["dtype"]
    note = None if bits is not None else (
        "the encoder resolution is unknown (pass bits=, --bits): only the angle functions are "
        "exported, without the code functions")
    if form == "formula":
        if target != "cortex-m4f":
            raise InputError("form='formula' is for the cortex-m4f target; the fixed target uses a table")
        terms = fourier_terms(comp)
        if terms is None:
            raise InputError(f"expected a Fourier series for form='formula' on cortex-m4f, got a "
                             f"{comp.kind} model; use form='table' (a compact table serves every kind)")
        files, summary = _fourier_files(comp, prefix, bits, terms, note)
        return files, {**summary, **(chosen or {})}
    if chosen is not None and chosen.get("interpolation"):
        interpolation = chosen["interpolation"]
    table, met = _table(comp, target, bits, nodes, dtype, tolerance_arcmin, interpolation)
    if target == "fixed":
        _check_int32(comp, table)
    files = (_float_table_files if target == "cortex-m4f" else _fixed_table_files)(comp, prefix, bits, table)
    fixed = target == "fixed"
    summary = {"target": target, "form": "table", "nodes": table.nodes, "dtype": table.dtype,
               "interpolation": table.interpolation,
               "table_bytes": table.table_bytes, "bits": bits, "note": note, "tolerance_met": met,
               "max_error_arcmin": table.fixed_max_error_arcmin if fixed else table.max_error_arcmin,
               "rms_error_arcmin": table.fixed_rms_error_arcmin if fixed else table.rms_error_arcmin,
               "operations": OPERATIONS[(target, "cubic" if table.interpolation == "cubic" else "table",
                                         reading_cost_key(target, bits))],
               "table": table}
    if chosen is not None:
        summary.update(tolerance_met=chosen.get("met", met), **{k: v for k, v in chosen.items()
                                                                 if k in ("gave_up", "recorded")})
    return files, summary


def write_target(model, directory, target="host", **options):
    """Write the files of :func:`export_target` into ``directory`` (created if missing), both or neither.

    Returns
    -------
    paths : list of pathlib.Path
    summary : dict
        As :func:`export_target`.
    """
    files, summary = export_target(model, target, **options)
    return write_file_set(directory, files), summary


def describe(summary):
    """One line about an export (what it is, bytes, operations, deployed error)."""
    if summary["target"] == "host":
        text = f"host C ({summary['form']}, double precision)"
        if summary.get("how"):
            text += f": {summary['how']}"
        if summary["form"] == "formula":
            text += ("; the formula costs sines and cosines in double at every reading: for a microcontroller, "
                     "--target cortex-m4f writes a float32 compact table "
                     f"({OPERATIONS[('cortex-m4f', 'table', 'correct_deg')]} to "
                     f"{OPERATIONS[('cortex-m4f', 'cubic', 'correct_deg')]} C operations to correct a reading in "
                     "degrees, linear or cubic B-spline) and --target fixed one in integers")
        return text + (f"; note: {summary['note']}" if summary.get("note") else "")
    bits = summary.get("bits")
    where = f"all {2**evaluation_bits(bits)} codes" if bits else "65536 angles"
    if summary["form"] == "formula":
        what = f"{summary['terms']}-term Fourier series in float32"
        cost = f"{summary['operations']} operations and {2 * summary['terms']} sinf/cosf calls per reading"
    else:
        cubic = " cubic B-spline" if summary.get("interpolation") == "cubic" else ""
        what = f"{summary['nodes']}-node {summary['dtype']}{cubic} table, {summary['table_bytes']} bytes"
        cost = f"{summary['operations']} operations per reading"
    text = (f"{summary['target']}: {what}, {cost}; deployed error against the model over {where}: "
            f"max {summary['max_error_arcmin']:.3g}, RMS {summary['rms_error_arcmin']:.3g} arcmin")
    if summary.get("tolerance_met") is False:
        text += " (more than the tolerance: no deployment tried meets it)"
    if summary.get("recorded"):
        text += f"; {summary['recorded']}"
    if summary.get("gave_up"):
        text += f"; {summary['gave_up']}"
    if summary.get("note"):
        text += f"; note: {summary['note']}"
    return text


def _bits(comp, bits, target, form="table"):
    bits = comp.encoder.get("resolution_bits") if bits is None else bits
    if bits is None:
        return None
    # a compact table has at least MIN_NODES nodes, at most one per code; the formula takes any code
    low = 1 if form == "formula" else MIN_TABLE_BITS
    table = ("" if form == "formula"
             else f"; a compact table has at least {2**MIN_TABLE_BITS} nodes, one per code at most")
    return check_int(bits, "bits", "export_target", low=low, high=_MAX_FIXED_COUNT_BITS if target == "fixed" else 32,
                     note=f"the encoder resolution for the {target} target{table}; or None for the model file's")


def _check_int32(comp, table):
    """Refuse a fixed-point table whose mean error (OFFSET_BAM, an int32 binary angle) would be clipped.

    The fixed target's sums are congruent modulo a turn (2^32 binary-angle units), so a profile reaching
    past half a turn still corrects rightly; its constant offset must hold in int32 itself, else
    :func:`encal.deploy.compact.compile_compact` clips it and every correction is wrong by the excess.
    """
    if abs(table.offset_arcmin) / BAM_ARCMIN > 2**31:  # clipped by one unit (5e-6 arcmin) at most: a rounding
        where = comp.source or "the model given to export_target"
        raise InputError(f"{where}: the model's mean error, {table.offset_arcmin:.6g} arcmin, is beyond the fixed "
                         f"target's int32 binary angles (half a turn, {2**31 * BAM_ARCMIN:g} arcmin); expected a "
                         "mean error within half a turn (a zero offset of at most 180 degrees), or --target cortex-m4f")


def _chosen(comp, target, bits, form, nodes, dtype, tolerance, cost, interpolation=None):
    """The deployment to export when the caller left the choice to encal, or None for the default."""
    if nodes is not None or dtype is not None or form != "table" or interpolation is not None:
        if cost is not None:
            raise InputError("cost= chooses the deployment; expected it without nodes=, dtype=, form= "
                             "or interpolation=")
        return None
    if cost is not None:
        tolerance = default_tolerance_arcmin(bits) if tolerance is None else tolerance
        deployment, report = choose_deployment(comp, tolerance_arcmin=tolerance, cost=cost, target=target,
                                               bits=bits)
        return {"form": deployment.form, "nodes": deployment.nodes, "dtype": deployment.dtype,
                "interpolation": deployment.interpolation, "met": report["met"], "gave_up": report["gave_up"]}
    recorded = comp.model.training.get("deployment")
    if tolerance is None and isinstance(recorded, dict) and recorded.get("target") == target \
            and recorded.get("form") in FORMS:
        _check_recorded(comp, recorded, target, bits)
        return {"form": recorded["form"], "nodes": recorded.get("nodes"), "dtype": recorded.get("dtype"),
                "interpolation": recorded.get("interpolation") or "linear",
                "recorded": f"the deployment chosen by encal fit --budget {recorded.get('budget', '')}".rstrip()}
    return None


def _check_recorded(comp, recorded, target, bits):
    """Refuse a deployment recorded in the model file (``encal fit --budget``) that ``target`` cannot export.

    A file edited by hand and re-signed can hold any value there; the message names the file and the field
    rather than a parameter the user never gave.
    """
    dtypes = ("int8", "int16") if target == "fixed" else NODE_DTYPES
    largest = min(MAX_NODES, 2**evaluation_bits(bits))
    nodes = recorded.get("nodes")
    checks = [("form", recorded["form"] == "table" or target == "cortex-m4f", "'table' (or 'formula' for cortex-m4f)"),
              ("budget", isinstance(recorded.get("budget", ""), str) and recorded.get("budget", "").isprintable()
               and len(recorded.get("budget", "")) <= 64, "the text of --budget")]
    if recorded["form"] == "table":
        checks += [
            ("nodes", nodes is None or (isinstance(nodes, int) and not isinstance(nodes, bool) and MIN_NODES <= nodes
                                        <= largest and nodes & (nodes - 1) == 0),
             f"a power of two from {MIN_NODES} to {largest}"),
            ("dtype", recorded.get("dtype") in (None, *dtypes), " or ".join(map(repr, dtypes))),
            ("interpolation", recorded.get("interpolation") in (None, *INTERPOLATIONS),
             " or ".join(map(repr, INTERPOLATIONS)))]
    for field, ok, expected in checks:
        if not ok:
            shown = repr(recorded.get(field))
            shown = shown if len(shown) <= 40 else shown[:37] + "..."
            raise InputError(f"{comp.source or 'the model given to export_target'}: expected the training.deployment "
                             f"recorded by 'encal fit --budget' to hold {field} {expected} for the {target} target, "
                             f"got {shown}; fit again with --budget, or choose with --nodes, --dtype or --tolerance")


def _table(comp, target, bits, nodes, dtype, tolerance, interpolation=None):
    if target == "fixed" and dtype == "float32":
        raise invalid("dtype", "export_target", "an integer node dtype, 'int8' or 'int16', for the fixed target "
                      "(or None)", dtype)
    if nodes is not None:
        return compile_compact(comp, nodes, dtype=dtype or "int16", bits=bits,
                               interpolation=interpolation or "linear"), None
    dtypes = (dtype,) if dtype else ("int8", "int16") if target == "fixed" else ("int8", "int16", "float32")
    interpolations = (interpolation,) if interpolation else INTERPOLATIONS
    return choose_compact(comp, tolerance_arcmin=tolerance, bits=bits, dtypes=dtypes, target=target,
                          interpolations=interpolations)


# -- C text ----------------------------------------------------------------------------------

def _check_float32(comp, arrays):
    """Refuse constants that float32 cannot hold (they would be written as ``inff``, not C)."""
    for name, values in arrays.items():
        values = np.asarray(values, dtype=float)
        with np.errstate(over="ignore"):
            bad = ~np.isfinite(values.astype(np.float32))
        if np.any(bad):
            where = comp.source or "the model given to export_target"
            raise InputError(f"{where}: the Fourier coefficient {name}[{int(np.argmax(bad))}] = "
                             f"{values[np.argmax(bad)]:.4g} arcmin is beyond float32's range (3.4e38); expected "
                             "coefficients a float32 holds for the cortex-m4f formula")


def _float(value):
    """A float32 C literal that reads back to float32(value)."""
    with np.errstate(over="ignore"):
        rounded = float(np.float32(value))
    if not math.isfinite(rounded):  # 'inff' or 'nanf' is no C: the callers check their values first
        raise InputError(f"expected a number a float32 holds for the C source, got {float(value):.4g}")
    text = f"{rounded:.9g}"
    if not any(c in text for c in ".eEn"):
        text += ".0"
    return text + "f"


def _rows(items, per_line):
    return ",\n    ".join(", ".join(items[i:i + per_line]) for i in range(0, len(items), per_line))


def _node_array(table):
    if table.dtype == "float32":
        items, ctype, per_line = [_float(v) for v in table.values], "float", 6
    else:
        items, ctype, per_line = [str(int(v)) for v in table.values], f"{table.dtype}_t", 16
    return f"static const {ctype} node[{table.nodes}] = {{\n    {_rows(items, per_line)}\n}};\n"


def _header(prefix, bits, banner, declarations):
    guard = f"{prefix.upper()}_H"
    resolution = "" if bits is None else (f"\n/* Resolution of the encoder codes, in bits. */\n"
                                          f"#define {prefix.upper()}_BITS {bits}u\n")
    return f"""\
{banner}
#ifndef {guard}
#define {guard}

#include <stdint.h>

#ifdef __cplusplus
extern "C" {{
#endif
{resolution}
{declarations}
#ifdef __cplusplus
}}
#endif

#endif /* {guard} */
"""


_FLOAT_ANGLE_DECLARATIONS = """\
/* Predicted error (arc-minutes) at the encoder reading theta_deg (degrees, any finite value);
   NaN for a NaN or infinite reading, here and in {p}_correct_deg. */
float {p}_predict_arcmin(float theta_deg);

/* Corrected angle, in [0, 360) degrees, of the encoder reading theta_deg (degrees). */
float {p}_correct_deg(float theta_deg);
"""

_FLOAT_CODE_DECLARATIONS = """
/* For a raw code of a {P}_BITS-bit encoder (higher bits ignored): */
/* the predicted error in LSB (codes), */
float {p}_error_lsb(uint32_t code);
/* the corrected code, code - round(error), modulo 2^{P}_BITS, */
uint32_t {p}_correct_code(uint32_t code);
/* the corrected angle in [0, 360) degrees. */
float {p}_correct_counts(uint32_t code);
"""

#: The deployed error is computed for float32 operations rounded one by one (and the tests compare the
#: C with that arithmetic bit for bit); a compiler that fuses ``a * b + c`` into one rounding (GCC in
#: its GNU dialects, its default, and clang: VFMA on a Cortex-M4F) would round differently.
_NO_FUSED_MULTIPLY_ADD = """\
/* Each float operation rounded on its own, as the deployed error above was computed: no fused multiply-add. */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize ("fp-contract=off")
#endif
"""

_FLOAT_COMMON = """\
/* theta in [0, 360); NaN stays NaN */
static float wrap360f(float angle)
{
    float t = angle;
    if (!(t >= 0.0f && t < 360.0f)) {
        t = fmodf(t, 360.0f);
        if (t < 0.0f) t += 360.0f;
        if (t >= 360.0f) t = 0.0f; /* -1e-9 + 360 rounds to 360 */
    }
    return t;
}

/* (angle - error / 60) wrapped to [0, 360) */
static float corrected_deg(float theta, float error_arcmin)
{
    float c = theta - error_arcmin * (1.0f / 60.0f);
    if (c < 0.0f) c += 360.0f;
    if (c >= 360.0f) c -= 360.0f;
    return c >= 360.0f ? 0.0f : c;
}
"""

_FLOAT_CODE_FUNCTIONS = """
uint32_t {p}_correct_code(uint32_t code)
{{
    const float shifted = {p}_error_lsb(code) + 0.5f;
    int32_t rounded = (int32_t)shifted; /* toward zero, then down: floor(error + 1/2) */
    if ((float)rounded > shifted) rounded -= 1;
    return ({code_in} - (uint32_t)rounded) & CODE_MASK;
}}

float {p}_correct_counts(uint32_t code)
{{
    const uint32_t k = {code_in} & CODE_MASK;
    return corrected_deg((float)k * STEP_DEG, {p}_error_lsb(code) * LSB_ARCMIN);
}}
"""


def _sign_parts(comp):
    """C for the model's input of a reading: the reading, or its negative (reading_sign -1)."""
    if comp.reading_sign == -1:
        return {"code_in": "(0u - code)", "angle_in": "(t == 0.0f ? 0.0f : 360.0f - t)",
                "bam_in": "(0u - angle)"}
    return {"code_in": "code", "angle_in": "t", "bam_in": "angle"}


def _sign_note(comp):
    if comp.reading_sign == -1:
        return ("; the encoder counts against its reference (reading_sign -1): corrected angles and "
                "codes are of the negated reading, in the reference's sense")
    return ""


def _code_macros(bits):
    mask = "0xFFFFFFFFu" if bits == 32 else f"0x{(1 << bits) - 1:X}u"
    return (f"#define CODE_MASK {mask}\n"
            f"#define STEP_DEG {_float(360.0 / 2**bits)} /* degrees per code */\n"
            f"#define LSB_ARCMIN {_float(21600.0 / 2**bits)} /* arc-minutes per code */\n")


_LINEAR_NODE_VALUE = """\
/* node i: the error at i * 360 / NODES degrees less OFFSET_ARCMIN, in stored units */
{array}
/* linear interpolation between node i and the next, wrapping at NODES */
static float node_value(uint32_t i, float fraction)
{{
    const float left = (float)node[i];
    return left + fraction * ((float)node[(i + 1u) & (NODES - 1u)] - left);
}}
"""

_CUBIC_NODE_VALUE = """\
/* node i: the coefficient of the cubic B-spline centred at i * 360 / NODES degrees ({unit}) */
{array}
/* the uniform cubic B-spline of nodes i-1 .. i+2 (with wrap) at fraction of segment i:
   p0 + f (p1 + f (p2 + f p3)) is six times its value, in units of 1/6 of a node */
static float node_value(uint32_t i, float fraction)
{{
    const {ctype} a = node[(i - 1u) & (NODES - 1u)];
    const {ctype} b = node[i];
    const {ctype} c = node[(i + 1u) & (NODES - 1u)];
    const {ctype} d = node[(i + 2u) & (NODES - 1u)];
    const float p0 = {p0};
    const float p1 = {p1};
    const float p2 = {p2};
    const float p3 = {p3};
    return p0 + fraction * (p1 + fraction * (p2 + fraction * p3));
}}
"""


def _node_value(table):
    """C of the node array and of node_value(i, fraction), the interpolated value in units of SCALE."""
    array = _node_array(table)
    if table.interpolation == "linear":
        return _LINEAR_NODE_VALUE.format(array=array)
    if table.dtype == "float32":
        return _CUBIC_NODE_VALUE.format(
            array=array, ctype="float", unit="arc-minutes over 6; the mean error kept out",
            p0="a + 4.0f * b + c", p1="3.0f * (c - a)", p2="3.0f * (a + c) - 6.0f * b",
            p3="d - a + 3.0f * (b - c)")
    # integer nodes: p0..p3 exact in int32, each converted to float exactly (below 2^24)
    return _CUBIC_NODE_VALUE.format(
        array=array, ctype="int32_t", unit="in units of 6 * SCALE, the mean error kept out",
        p0="(float)(a + 4 * b + c)", p1="(float)(3 * (c - a))", p2="(float)(3 * (a + c) - 6 * b)",
        p3="(float)(d - a + 3 * (b - c))")


def _float_table_files(comp, prefix, bits, table):
    n = table.nodes.bit_length() - 1
    sign = _sign_parts(comp)
    interpolation = "cubic B-spline" if table.interpolation == "cubic" else "linear"
    how = (f"a {table.nodes}-node {table.dtype} table with {interpolation} interpolation in float32 "
           f"({table.table_bytes} bytes; deployed error against the model max {table.max_error_arcmin:.3g}, "
           f"RMS {table.rms_error_arcmin:.3g} arcmin){_sign_note(comp)}")
    banner = _banner(comp, prefix, how)
    declarations = _FLOAT_ANGLE_DECLARATIONS.format(p=prefix)
    if bits is not None:
        declarations += _FLOAT_CODE_DECLARATIONS.format(p=prefix, P=prefix.upper())
    lsb_scale = table.scale_arcmin / (21600.0 / 2**bits) if bits else None
    code_part = "" if bits is None else f"""
{_code_macros(bits)}#define NODE_SHIFT {bits - n}u /* code bits below the node index */
#define FRACTION_MASK 0x{(1 << (bits - n)) - 1:X}u
#define FRACTION_SCALE {_float(2.0 ** -(bits - n))}
#define SCALE_LSB {_float(lsb_scale)} /* LSB per unit of node_value */
#define OFFSET_LSB {_float(table.offset_arcmin / (21600.0 / 2**bits))} /* the mean error, LSB */

float {prefix}_error_lsb(uint32_t code)
{{
    const uint32_t k = code & CODE_MASK;
    return node_value(k >> NODE_SHIFT, (float)(k & FRACTION_MASK) * FRACTION_SCALE) * SCALE_LSB + OFFSET_LSB;
}}
{_FLOAT_CODE_FUNCTIONS.format(p=prefix, **sign)}"""
    source = f"""\
{banner}
#include "{prefix}.h"

#include <math.h>
#include <stdint.h>

{_NO_FUSED_MULTIPLY_ADD}
#define NODES {table.nodes}u
#define NODES_PER_DEG {_float(table.nodes / 360.0)}
#define SCALE_ARCMIN {_float(table.scale_arcmin)} /* arc-minutes per unit of node_value */
#define OFFSET_ARCMIN {_float(table.offset_arcmin)} /* the mean error, kept out of the nodes */

{_node_value(table)}
{_FLOAT_COMMON}
float {prefix}_predict_arcmin(float theta_deg)
{{
    const float t = wrap360f(theta_deg);
    float x, fraction;
    uint32_t i;
    if (t != t) return t;
    x = t * NODES_PER_DEG;
    i = (uint32_t)x;
    fraction = x - (float)i;
    if (i >= NODES) {{ /* t just below 360 rounded up */
        i = 0u;
        fraction = 0.0f;
    }}
    return node_value(i, fraction) * SCALE_ARCMIN + OFFSET_ARCMIN;
}}

float {prefix}_correct_deg(float theta_deg)
{{
    const float t = wrap360f(theta_deg);
    if (t != t) return t;
    return corrected_deg({sign["angle_in"]}, {prefix}_predict_arcmin(t));
}}
{code_part}"""
    return {f"{prefix}.h": _header(prefix, bits, banner, declarations), f"{prefix}.c": source}


def _fourier_files(comp, prefix, bits, terms, note):
    orders, cos, sin = terms
    grid = evaluation_bits(bits)
    codes = np.arange(2**grid, dtype=np.int64)
    reference = check_exportable(model_on_codes(comp, bits), comp, "export_target")
    _check_float32(comp, {"cos": cos, "sin": sin})
    deployed = fourier_float32(orders, cos, sin, codes << (32 - grid)).astype(float)
    max_error = float(np.max(np.abs(deployed - reference)))
    rms_error = float(np.sqrt(np.mean((deployed - reference) ** 2)))
    sign = _sign_parts(comp)
    how = (f"the model's {orders.size}-term Fourier series in float32 (deployed error against the model "
           f"max {max_error:.3g}, RMS {rms_error:.3g} arcmin){_sign_note(comp)}")
    banner = _banner(comp, prefix, how)
    declarations = _FLOAT_ANGLE_DECLARATIONS.format(p=prefix)
    if bits is not None:
        declarations += _FLOAT_CODE_DECLARATIONS.format(p=prefix, P=prefix.upper())
    order_items = [f"{int(k)}u" for k in orders]
    code_part = "" if bits is None else f"""
{_code_macros(bits)}
float {prefix}_error_lsb(uint32_t code)
{{
    return series((code & CODE_MASK) << {32 - bits}u) * (1.0f / LSB_ARCMIN);
}}
{_FLOAT_CODE_FUNCTIONS.format(p=prefix, **sign)}"""
    source = f"""\
{banner}
#include "{prefix}.h"

#include <math.h>
#include <stdint.h>

{_NO_FUSED_MULTIPLY_ADD}
#define TERMS {orders.size}
#define PHASE_STEP {_float(2.0 * math.pi / 2**24)} /* radians per unit of a 24-bit phase */

static const uint32_t order[TERMS] = {{
    {_rows(order_items, 12)}
}};
static const float coef_cos[TERMS] = {{
    {_rows([_float(v) for v in cos], 6)}
}};
static const float coef_sin[TERMS] = {{
    {_rows([_float(v) for v in sin], 6)}
}};

{_FLOAT_COMMON}
/* the error (arc-minutes) at a 32-bit binary angle: k * angle modulo one turn is an exact
   integer product, so high orders lose nothing */
static float series(uint32_t angle)
{{
    float sum = 0.0f;
    int i;
    for (i = 0; i < TERMS; ++i) {{
        const float phase = (float)((order[i] * angle) >> 8) * PHASE_STEP;
        sum += coef_cos[i] * cosf(phase) + coef_sin[i] * sinf(phase);
    }}
    return sum;
}}

#define TWO_TO_32_PER_DEG 11930464.7f /* 2^32 / 360: degrees to a 32-bit binary angle */

static uint32_t binary_angle(float t) /* t in [0, 360) */
{{
    const float x = t * TWO_TO_32_PER_DEG;
    return x >= 4294967296.0f ? 0u : (uint32_t)x;
}}

float {prefix}_predict_arcmin(float theta_deg)
{{
    const float t = wrap360f(theta_deg);
    if (t != t) return t;
    return series(binary_angle(t));
}}

float {prefix}_correct_deg(float theta_deg)
{{
    const float t = wrap360f(theta_deg);
    if (t != t) return t;
    return corrected_deg({sign["angle_in"]}, series(binary_angle(t)));
}}
{code_part}"""
    files = {f"{prefix}.h": _header(prefix, bits, banner, declarations), f"{prefix}.c": source}
    summary = {"target": "cortex-m4f", "form": "formula", "terms": int(orders.size), "bits": bits,
               "note": note, "max_error_arcmin": max_error, "rms_error_arcmin": rms_error,
               "operations": OPERATIONS[("cortex-m4f", "formula", "per_term")] * int(orders.size),
               "table_bytes": int(orders.size) * 12}
    return files, summary


_FIXED_DECLARATIONS = """\
/* Angles as 32-bit binary angles: a fraction of a turn times 2^32 (degrees * 2^32 / 360). */
/* The predicted error, in units of a 32-bit binary angle, at angle. */
int32_t {p}_error_bam32(uint32_t angle);
/* The corrected angle, angle - error, modulo one turn. */
uint32_t {p}_correct_bam32(uint32_t angle);
"""

_FIXED_CODE_DECLARATIONS = """
/* For a raw code of a {P}_BITS-bit encoder (higher bits ignored): */
/* the predicted error in 1/256 LSB, */
int32_t {p}_error_lsb_q8(uint32_t code);
/* the corrected code, code - round(error), modulo 2^{P}_BITS. */
uint32_t {p}_correct_code(uint32_t code);
"""


def _scale_by_power_of_two(expression, shift):
    """C for round(expression / 2^shift) (a right shift), or expression * 2^-shift."""
    if shift > 0:
        return f"shift_round({expression}, {shift}u)"
    if shift == 0:
        return expression
    return f"({expression}) * {1 << -shift}"


def _fixed_table_files(comp, prefix, bits, table):
    n = table.nodes.bit_length() - 1
    sign = _sign_parts(comp)
    cubic = table.interpolation == "cubic"
    how = (f"a {table.nodes}-node {table.dtype} table with {'cubic B-spline' if cubic else 'linear'} "
           f"interpolation in int32 fixed point "
           f"({table.table_bytes} bytes; deployed error against the model max "
           f"{table.fixed_max_error_arcmin:.3g}, RMS {table.fixed_rms_error_arcmin:.3g} arcmin){_sign_note(comp)}")
    banner = _banner(comp, prefix, how)
    declarations = _FIXED_DECLARATIONS.format(p=prefix)
    if bits is not None:
        declarations += _FIXED_CODE_DECLARATIONS.format(p=prefix, P=prefix.upper())
    fb = CUBIC_FRACTION_BITS if cubic else FIXED_FRACTION_BITS
    if cubic:
        unit = f"6 * 2^{table.scale_exponent} / 2^32 turns; B-spline coefficients"
        body = f"""\
    const uint32_t i = angle >> {32 - n}u;
    const int32_t fraction = (int32_t)((angle >> {32 - n - fb}u) & ((1u << FRACTION_BITS) - 1u));
    const int32_t a = node[(i - 1u) & (NODES - 1u)];
    const int32_t b = node[i];
    const int32_t c = node[(i + 1u) & (NODES - 1u)];
    const int32_t d = node[(i + 2u) & (NODES - 1u)];
    /* Horner's rule on p3 .. p0: six times the B-spline, in units of 2^{table.scale_exponent} / 2^32 turns */
    int32_t v = d - a + 3 * (b - c);
    v = 3 * (a + c) - 6 * b + shift_round(v * fraction, FRACTION_BITS);
    v = 3 * (c - a) + shift_round(v * fraction, FRACTION_BITS);
    v = a + 4 * b + c + shift_round(v * fraction, FRACTION_BITS);
    return {_scale_by_power_of_two("v", -table.scale_exponent)} + OFFSET_BAM;"""
    else:
        unit = f"2^{table.scale_exponent} / 2^32 turns; the error at i * 360 / NODES degrees"
        body = f"""\
    const uint32_t i = angle >> {32 - n}u;
    const int32_t fraction = (int32_t)((angle >> {32 - n - fb}u) & ((1u << FRACTION_BITS) - 1u));
    const int32_t left = node[i];
    const int32_t step = (int32_t)node[(i + 1u) & (NODES - 1u)] - left;
    const int32_t scaled = left * (1 << FRACTION_BITS) + step * fraction;
    return {_scale_by_power_of_two("scaled", fb - table.scale_exponent)} + OFFSET_BAM;"""
    code_part = "" if bits is None else f"""
#define CODE_MASK {"0xFFFFFFFFu" if bits == 32 else f"0x{(1 << bits) - 1:X}u"}

int32_t {prefix}_error_lsb_q8(uint32_t code)
{{
    return {_scale_by_power_of_two(f"{prefix}_error_bam32((code & CODE_MASK) << {32 - bits}u)", 32 - bits - 8)};
}}

uint32_t {prefix}_correct_code(uint32_t code)
{{
    return ({sign["code_in"]} - (uint32_t)shift_round({prefix}_error_lsb_q8(code), 8u)) & CODE_MASK;
}}
"""
    source = f"""\
{banner}
#include "{prefix}.h"

#include <stdint.h>

#define NODES {table.nodes}u
#define FRACTION_BITS {fb}u
#define OFFSET_BAM ((int32_t){table.offset_bam}) /* the mean error, kept out of the nodes */

/* node i, less OFFSET_BAM, in units of {unit} */
{_node_array(table)}
/* round(value / 2^shift), halves up, for 1 <= shift <= 30, without shifting a negative number */
static int32_t shift_round(int32_t value, uint32_t shift)
{{
    const uint32_t biased = (uint32_t)value + 0x80000000u + (1u << (shift - 1u));
    return (int32_t)(biased >> shift) - (int32_t)(0x80000000u >> shift);
}}

int32_t {prefix}_error_bam32(uint32_t angle)
{{
{body}
}}

uint32_t {prefix}_correct_bam32(uint32_t angle)
{{
    return {sign["bam_in"]} - (uint32_t){prefix}_error_bam32(angle);
}}
{code_part}"""
    return {f"{prefix}.h": _header(prefix, bits, banner, declarations), f"{prefix}.c": source}


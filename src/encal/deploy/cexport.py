"""C source for firmware: a model (or its dense table) as ``PREFIX.h`` and ``PREFIX.c``.

The generated code is plain C99 with ``<math.h>`` and ``<stdint.h>``; it
defines, for a prefix such as ``encal``::

    float encal_predict_arcmin(float theta_deg);   /* predicted error, arc-minutes */
    float encal_correct_deg(float theta_deg);      /* corrected angle, [0, 360) degrees */
    float encal_correct_counts(uint32_t code);     /* same for a raw B-bit code */

Two ways of evaluating the model:

- the model's formula (Fourier series, piecewise polynomial, 1:N:1 network
  with its input and output scaling, their sum, or a stack's weighted sum),
  computed in ``double``.
  A Fourier series costs one ``cos`` and one ``sin`` per reading: the
  harmonics ``k * theta`` follow by the double-angle and angle-addition
  formulas, exact to a few ``k * 1e-16`` (relative), so orders of several
  hundred lose nothing. Readings within one turn of [0, 360) are wrapped
  without ``fmod``. Constants are stored as ``float`` (printed
  ``%.9g``, which round-trips float32) when that changes the model by at most
  :data:`FLOAT32_BUDGET_ARCMIN` on a dense grid, else as ``double`` (``%.17g``);
- the dense per-code table of :mod:`encal.deploy.table` (``table='int16'`` or
  ``'float32'``): one lookup per reading, no transcendental functions, for
  processors without a double-precision unit. Angles that are not codes are
  looked up at the nearest code.

Only the return value is a float: the corrected angle is rounded once, to
float32, at the end (at most 2^-16 degrees = 0.00092 arcmin near 360).
"""

import dataclasses
import json
import re

import numpy as np

from .. import runtime
from .._core.atomic import write_file_set
from .._version import __version__
from .._core.errors import InputError, ModelFileError
from ..models import model_kind
from .._core.parameters import check_choice, check_int, invalid
from .compact import check_exportable
from .compensator import Compensator
from .table import compile_table

__all__ = ["export_c", "write_c", "FLOAT32_BUDGET_ARCMIN", "C_KEYWORDS"]

#: Largest change of the model, in arc-minutes, that storing its constants as
#: float32 may cause; beyond it they are stored as double.
FLOAT32_BUDGET_ARCMIN = 1e-4
_CHECK_POINTS = 1 << 16  # grid on which the float32 rounding of the constants is measured
_MAX_C_TABLE_BITS = 20

C_KEYWORDS = frozenset("""auto break case char const continue default do double else enum extern
float for goto if inline int long register restrict return short signed sizeof static struct
switch typedef union unsigned void volatile while _Bool _Complex _Imaginary""".split())


def export_c(model, *, prefix="encal", bits=None, table=None, constants="auto"):
    """C source that corrects encoder angles with ``model``.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
        The model, or its model file.
    prefix : str, default='encal'
        Prefix of the file names and of every exported C identifier; a valid C identifier.
    bits : int, optional
        Encoder resolution for ``<prefix>_correct_counts``. Default: the
        model's ``encoder.resolution_bits``.
    table : {None, 'int16', 'float32'}, default=None
        Evaluate the formula (None), or look up a dense table of this dtype.
    constants : {'auto', 'float', 'double'}, default='auto'
        Storage of the formula's constants; 'auto' chooses float when the
        model then changes by at most :data:`FLOAT32_BUDGET_ARCMIN`.

    Returns
    -------
    dict of str to str
        ``{'<prefix>.h': text, '<prefix>.c': text}``.

    Raises
    ------
    InputError
        If ``prefix`` is not a valid C identifier, or an option is invalid.
    """
    return host_export(model, prefix=prefix, bits=bits, table=table, constants=constants)[0]


def host_export(model, *, prefix="encal", bits=None, table=None, constants="auto"):
    """:func:`export_c`'s files and the sentence of its banner that says how the C computes and how far from
    the model (the constants' change, or the dense table's deviation at and between the codes)."""
    _check_identifier(prefix, "export_c")
    check_choice(table, "table", "export_c", (None, "int16", "float32"))
    check_choice(constants, "constants", "export_c", ("auto", "float", "double"))
    comp = model if isinstance(model, Compensator) else Compensator(model)
    bits = comp.encoder.get("resolution_bits") if bits is None else bits
    # Without a resolution, the formula is still exported: only the code functions are left out.
    bits = None if bits is None and table is None else _check_bits(bits, table, "export_c")
    if table is None:
        _check_profiles(comp)
        ctype, deviation = _constant_type(comp, constants)
        body = _formula_source(_form(comp), comp.model.parameters(), _Literals(ctype))
        if ctype == "float" or np.isfinite(deviation):
            change = f"{'they change' if ctype == 'float' else 'float would change'} the model by at most " \
                     f"{deviation:.3g} arcmin on {_CHECK_POINTS} angles" + (
                         " and at the breaks" if _breaks(comp.model.parameters()) else "")
        else:
            change = "float32 cannot hold them"
        how = f"the model's formula in double; constants stored as {ctype} ({change})"
    else:
        compiled = _in_model_input_order(compile_table(comp, bits, dtype=table))
        body = _table_source(compiled)
        how = (f"a {bits}-bit {table} table: {compiled.quantisation_arcmin:.3g} arcmin from the "
               f"model at the codes, plus up to {compiled.between_codes_arcmin:.3g} arcmin "
               "for angles between codes (looked up at the nearest code)")
    if comp.reading_sign == -1:
        how += ("; the encoder counts against its reference (reading_sign -1): readings are negated "
                "before the model sees them, and corrected angles are in the reference's sense")
    if bits is None:
        how += (";\n * the encoder resolution is unknown (pass bits=, --bits), so the code function "
                f"{prefix}_correct_counts is left out")
    banner = _banner(comp, prefix, how)
    directed = table is None and _form(comp) == "directional"
    return {f"{prefix}.h": _header(prefix, bits, banner, directed),
            f"{prefix}.c": _source(prefix, bits, banner, body, directed, comp.reading_sign)}, how


def _in_model_input_order(table):
    """``table`` indexed by the model's input code: the C maps a reading to the model's input first.

    Entry ``k`` of a table is the error at raw code ``k``; for a model that negates readings the
    model's input for code ``k`` is code ``-k mod 2^B``, so the entries are permuted, not re-evaluated.
    """
    if table.reading_sign == 1:
        return table
    values = table.values[(-np.arange(table.values.size)) % table.values.size]
    return dataclasses.replace(table, values=values, reading_sign=1)


def write_c(model, directory, **options):
    """Write the files of :func:`export_c` into ``directory`` (created if missing); return their paths.

    The header and the source are written as one set (see
    :func:`encal._core.atomic.atomic_file_set`): both or neither.
    """
    files = export_c(model, **options)
    return write_file_set(directory, files)


def _check_identifier(prefix, caller):
    valid = isinstance(prefix, str) and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", prefix)
    reserved = valid and (prefix.startswith("__") or re.match(r"_[A-Z]", prefix))
    if not valid or reserved or prefix in C_KEYWORDS:
        raise invalid("prefix", caller, "a C identifier (letters, digits, '_', not starting with a digit, "
                      "'__' or '_' + capital, not a keyword)", prefix)


def _check_bits(bits, table, caller):
    if bits is None:
        raise InputError("expected the encoder resolution in bits (the model file does not "
                         "record it), got none; pass bits= (--bits on the command line)")
    return check_int(bits, "bits", caller, low=1, high=_MAX_C_TABLE_BITS if table else 32,
                     note="the encoder resolution of a C table" if table else "the encoder resolution")


# -- constants as float or double -------------------------------------------------------

def _constant_type(comp, constants):
    """'float' or 'double', and the measured model change (arcmin) of float32 constants."""
    if constants == "double":
        return "double", 0.0
    theta = np.arange(_CHECK_POINTS) * (360.0 / _CHECK_POINTS)
    parameters = comp.model.parameters()
    with np.errstate(over="ignore"):
        rounded = _map_floats(parameters, lambda v: float(np.float32(v)))
    merged = False
    if _all_finite(rounded):
        form = _form(comp)
        # a piecewise model is probed at its breaks too, as stored and as float32 moves them: where its pieces
        # step (an arc's export, encal._core.arcs), a moved break changes the model there by the whole step,
        # which the grid alone meets only when a break lies on it
        theta = np.concatenate([theta, np.mod(_breaks(parameters) + _breaks(rounded), 360.0)])
        try:
            deviation = max(float(np.max(np.abs(approximate - exact))) for approximate, exact in
                            zip(_profiles(form, rounded, theta), _profiles(form, parameters, theta)))
        except ModelFileError:  # float32 merges two breaks (an arc's piece of 1e-9 degree at an end)
            deviation, merged = np.inf, True
    else:  # a constant beyond float32's range
        deviation = np.inf
    if constants == "float":
        if merged:
            raise InputError("expected model constants that float32 holds, got breaks of a piecewise model "
                             "closer than float32 tells apart; use constants='double'")
        if not np.isfinite(deviation):
            raise InputError("expected model constants within float32's range, got larger "
                             "ones; use constants='double'")
        return "float", deviation
    return ("float", deviation) if deviation <= FLOAT32_BUDGET_ARCMIN else ("double", deviation)


def _breaks(parameters):
    """Every ``breaks_deg`` value in the (nested) parameters of a model, as a list of degrees."""
    if isinstance(parameters, dict):
        return [float(v) for v in parameters.get("breaks_deg", [])] + [
            v for key, item in parameters.items() if key != "breaks_deg" for v in _breaks(item)]
    if isinstance(parameters, list):
        return [v for item in parameters if isinstance(item, (dict, list)) for v in _breaks(item)]
    return []


def _check_profiles(comp):
    """Refuse a formula whose error (each direction's, as the C evaluates it) leaves a turn anywhere on the grid."""
    theta = np.arange(_CHECK_POINTS) * (360.0 / _CHECK_POINTS)
    with np.errstate(all="ignore"):
        profiles = _profiles(_form(comp), comp.model.parameters(), theta)
    for profile in profiles:
        check_exportable(profile, comp, "export_c", theta)


def _profiles(form, parameters, theta):
    """The error profiles (arcmin at ``theta``) that the C formula of ``form`` evaluates: one per direction.

    The profiles are those of the form, as the C code evaluates it, not of the model's kind: a kind
    stored in another's form (``spectral`` as ``fourier``, a user's kind) is checked like that form.
    """
    if form == "directional":
        return [_profile(runtime.form_of(parameters[part]), parameters[part]["parameters"], theta)
                for part in ("forward", "reverse")]
    return [_profile(form, parameters, theta)]


def _profile(form, parameters, theta):
    if form == "stack":  # float32 weights need not sum to 1 as a StackModel's must: add them up as the C does
        return sum(weight * _profile(runtime.form_of(member), member["parameters"], theta)
                   for member, weight in zip(parameters["members"], parameters["weights"]))
    if form == "lut":
        # float32 breaks need not span exactly 360 degrees as a LookupTableModel's must. The C code wraps
        # with the first break and 360 and finds the segment by bisection, so the last break only ends the
        # last segment, where the pieces meet: closing the span at first + 360 changes nothing measurable.
        breaks = list(parameters["breaks_deg"])
        parameters = {**parameters, "breaks_deg": breaks[:-1] + [breaks[0] + 360.0]}
    return model_kind(form).read(parameters).predict(theta)


def _all_finite(value):
    """True if every number in ``value`` (nested dicts and lists of model parameters) is finite."""
    if isinstance(value, dict):
        return all(_all_finite(item) for item in value.values())
    if isinstance(value, list):
        return all(_all_finite(item) for item in value)
    return not isinstance(value, float) or np.isfinite(value)


def _map_floats(value, function):
    if isinstance(value, dict):
        return {key: _map_floats(item, function) for key, item in value.items()}
    if isinstance(value, list):
        return [_map_floats(item, function) for item in value]
    return function(value) if isinstance(value, float) else value


class _Literals:
    """C literals and array definitions of one storage type."""

    def __init__(self, ctype):
        self.ctype = ctype

    def number(self, value):
        text = f"{value:.9g}" if self.ctype == "float" else f"{value:.17g}"
        if not re.search(r"[.eEn]", text):  # '5' -> '5.0': '5f' is not a C literal
            text += ".0"
        return text + ("f" if self.ctype == "float" else "")

    def array(self, name, values, per_line=4, ctype=None, number=None):
        values = list(values)
        number = number or self.number
        rows = [", ".join(number(v) for v in values[i:i + per_line])
                for i in range(0, len(values), per_line)]
        return (f"static const {ctype or self.ctype} {name}[{len(values)}] = {{\n    "
                + ",\n    ".join(rows) + "\n};\n")


# -- formula of each kind ---------------------------------------------------------------
# Each generator returns C defining `static double <tag>_error_arcmin(double theta)` for
# theta in [0, 360) degrees, and the static data it needs, named <tag>_...

def _fourier_source(p, literals, tag):
    orders = [int(k) for k in p["orders"]]
    powers = max(max(orders, default=0).bit_length(), 1)
    return f"""\
{literals.array(f"{tag}_order", orders, per_line=12, ctype="int", number=str)}
{literals.array(f"{tag}_cos", p["cos"])}
{literals.array(f"{tag}_sin", p["sin"])}
static double {tag}_error_arcmin(double theta)
{{
    /* One cos and one sin per reading: (c[m], s[m]) = (cos, sin)(2^m theta) by the double-angle
       formulas, then (cos, sin)(k theta) by the angle-addition formula over the set bits of k.
       Each product adds a rounding of order 1e-16, so (cos, sin)(k theta) are exact to a few
       k * 1e-16 (1e-11 at the largest order, 32767): far below float32 constants' rounding. */
    double c[{powers}], s[{powers}];
    double sum = 0.0;
    int i, m;
    c[0] = cos(theta * DEG_TO_RAD);
    s[0] = sin(theta * DEG_TO_RAD);
    for (m = 1; m < {powers}; ++m) {{
        c[m] = c[m - 1] * c[m - 1] - s[m - 1] * s[m - 1];
        s[m] = 2.0 * s[m - 1] * c[m - 1];
    }}
    for (i = 0; i < {len(orders)}; ++i) {{
        double ck = 1.0, sk = 0.0;
        int k = {tag}_order[i];
        for (m = 0; k != 0; ++m, k >>= 1) {{
            if (k & 1) {{
                const double t = ck * c[m] - sk * s[m];
                sk = ck * s[m] + sk * c[m];
                ck = t;
            }}
        }}
        sum += (double){tag}_cos[i] * ck + (double){tag}_sin[i] * sk;
    }}
    return sum;
}}
"""


def _lut_source(p, literals, tag):
    degree = len(p["coefficients"]) - 1
    n = len(p["breaks_deg"]) - 1
    arrays = "".join(literals.array(f"{tag}_c{m}", row) for m, row in enumerate(p["coefficients"]))
    horner = f"(double){tag}_c0[i]"
    for m in range(1, degree + 1):
        horner = f"({horner}) * dx + (double){tag}_c{m}[i]"
    return f"""\
{literals.array(f"{tag}_breaks", p["breaks_deg"])}
{arrays}
static double {tag}_error_arcmin(double theta)
{{
    /* into [x_0, x_0 + 360), then the interval i with x_i <= x < x_(i+1) by bisection */
    const double x = theta - 360.0 * floor((theta - (double){tag}_breaks[0]) / 360.0);
    int lo = 0, hi = {n}, i;
    double dx;
    while (hi - lo > 1) {{
        const int mid = (lo + hi) / 2;
        if ((double){tag}_breaks[mid] <= x) lo = mid; else hi = mid;
    }}
    i = lo;
    dx = x - (double){tag}_breaks[i];
    return {horner};
}}
"""


def _ann_source(p, literals, tag):
    hidden = len(p["b1"])
    periodic = p["encoding"] == "periodic"
    inputs = ("const double u[2] = {cos(theta * DEG_TO_RAD), sin(theta * DEG_TO_RAD)};"
              if periodic else "const double u[1] = {theta};")
    n_inputs = 2 if periodic else 1
    activation = ("tanh(z)" if p["activation"] == "tansig"
                  else "(z >= 0.0 ? 1.0 / (1.0 + exp(-z)) : exp(z) / (1.0 + exp(z)))")
    return f"""\
{literals.array(f"{tag}_input_offset", p["input_offset"])}
{literals.array(f"{tag}_input_gain", p["input_gain"])}
{literals.array(f"{tag}_W1", [w for row in p["W1"] for w in row])}
{literals.array(f"{tag}_b1", p["b1"])}
{literals.array(f"{tag}_W2", p["W2"])}
static const {literals.ctype} {tag}_b2 = {literals.number(p["b2"])};
static const {literals.ctype} {tag}_target_offset = {literals.number(p["target_offset"])};
static const {literals.ctype} {tag}_target_gain = {literals.number(p["target_gain"])};

static double {tag}_error_arcmin(double theta)
{{
    {inputs}
    double x[{n_inputs}];
    double y = (double){tag}_b2;
    int i, j;
    for (i = 0; i < {n_inputs}; ++i) {{ /* mapminmax */
        x[i] = (double){tag}_input_gain[i] * (u[i] - (double){tag}_input_offset[i]) - 1.0;
    }}
    for (j = 0; j < {hidden}; ++j) {{
        double z = (double){tag}_b1[j];
        for (i = 0; i < {n_inputs}; ++i) {{
            z += (double){tag}_W1[j * {n_inputs} + i] * x[i];
        }}
        y += (double){tag}_W2[j] * {activation};
    }}
    return (y + 1.0) / (double){tag}_target_gain + (double){tag}_target_offset;
}}
"""


def _hybrid_source(p, literals, tag):
    return (_fourier_source(p["fourier"], literals, f"{tag}_fourier") + "\n"
            + _ann_source(p["ann"], literals, f"{tag}_ann") + f"""
static double {tag}_error_arcmin(double theta)
{{
    return {tag}_fourier_error_arcmin(theta) + {tag}_ann_error_arcmin(theta);
}}
""")


def _stack_source(p, literals, tag):
    members = [_FORMULA[runtime.form_of(member)](member["parameters"], literals, f"{tag}_m{i}")
               for i, member in enumerate(p["members"])]
    terms = "\n        + ".join(f"(double){tag}_weight[{i}] * {tag}_m{i}_error_arcmin(theta)"
                                for i in range(len(members)))
    return "\n".join(members) + f"""
{literals.array(f"{tag}_weight", p["weights"])}
static double {tag}_error_arcmin(double theta)
{{
    return {terms};
}}
"""


def _directional_source(p, literals, tag):
    parts = [_FORMULA[runtime.form_of(p[part])](p[part]["parameters"], literals, f"{tag}_{part}")
             for part in ("forward", "reverse")]
    return "\n".join(parts) + f"""
/* direction +1: turning forward, -1: turning back, 0: unknown (the mean of both) */
static double {tag}_directed_error_arcmin(double theta, int direction)
{{
    if (direction > 0) return {tag}_forward_error_arcmin(theta);
    if (direction < 0) return {tag}_reverse_error_arcmin(theta);
    return 0.5 * ({tag}_forward_error_arcmin(theta) + {tag}_reverse_error_arcmin(theta));
}}

static double {tag}_error_arcmin(double theta)
{{
    return {tag}_directed_error_arcmin(theta, 0);
}}
"""


#: form (:data:`encal.runtime.FORMS`) -> C source of a model stored in it
_FORMULA = {"fourier": _fourier_source, "lut": _lut_source, "ann": _ann_source, "hybrid": _hybrid_source,
            "stack": _stack_source, "directional": _directional_source}


def _form(comp):
    """The form of the compensator's model: a kind the model file names has its own, any other names it."""
    return runtime.form_of({"kind": comp.kind, "form": comp.model.form})


def _formula_source(form, parameters, literals):
    return _FORMULA[form](parameters, literals, "model") + """
static double error_arcmin(double theta)
{
    return model_error_arcmin(theta);
}
"""


def _table_source(table):
    ctype = {"int16": "int16_t", "float32": "float"}[table.dtype]
    if table.dtype == "int16":
        items = [str(int(v)) for v in table.values]
        per_line = 12
    else:
        items = [_Literals("float").number(float(v)) for v in table.values]
        per_line = 6
    rows = ",\n    ".join(", ".join(items[i:i + per_line]) for i in range(0, len(items), per_line))
    scale = _Literals("double").number(table.scale_arcmin)
    return f"""\
/* predicted error at code k, in units of TABLE_SCALE_ARCMIN arc-minutes */
static const {ctype} error_table[{table.values.size}] = {{
    {rows}
}};
#define TABLE_SCALE_ARCMIN {scale}

static double code_error_arcmin(uint32_t code)
{{
    return (double)error_table[code & CODE_MASK] * TABLE_SCALE_ARCMIN;
}}

static double error_arcmin(double theta)
{{
    if (isnan(theta)) return theta; /* a NaN or infinite reading, wrapped: no code to look up */
    /* nearest code: theta is wrapped into [0, 360), so theta / STEP_DEG + 0.5 lies in
       [0.5, 2^BITS + 0.5) and truncation is floor, without the libm call */
    return code_error_arcmin((uint32_t)(theta / STEP_DEG + 0.5));
}}
"""


# -- files ------------------------------------------------------------------------------

def _comment_text(value):
    """``value`` as a JSON string literal that is safe inside a C block comment.

    A model file's names are any text: ``*/`` would end the comment, ``/*`` inside it is a warning
    (an error with ``-Werror``), ``??/`` is a trigraph (a line splice in C99), a newline, a control or
    a non-ASCII character may not survive the compiler's character set. JSON's escapes take them all
    out (``\\u002a`` for ``*``, ``\\u003f`` for ``?``, ``\\n``), and the text still decodes
    (``json.loads``) to the original. For comments only: a C string literal may not spell ``*`` so.
    """
    text = json.dumps(str(value), ensure_ascii=True)
    return text.replace("*", "\\u002a").replace("?", "\\u003f")


def _banner(comp, prefix, how):
    name = _comment_text(comp.encoder.get("name") or "")
    kind = comp.kind if re.fullmatch(r"[A-Za-z0-9_.+-]+", comp.kind) else _comment_text(comp.kind)
    sha = comp.sha256 or "none (the model was not saved to a file)"
    return f"""\
/*
 * {prefix}: encoder error compensation, generated by encal {__version__}. Do not edit.
 * Model: kind {kind}, encoder {name}, sha256 {sha}.
 * Evaluates {how}.
 * Angles in degrees, errors in arc-minutes (error = encoder - reference);
 * corrected angle = (theta - error / 60) mod 360.
 */
"""


def _header(prefix, bits, banner, directed):
    guard = f"{prefix.upper()}_H"
    macro = prefix.upper()
    directed_api = "" if not directed else f"""
/* The same for a known direction of travel into the reading: +1 turning forward,
   -1 turning back, 0 unknown (the mean of both, as the functions above). */
float {prefix}_correct_deg_directed(float theta_deg, int direction);
""" + ("" if bits is None else f"float {prefix}_correct_counts_directed(uint32_t code, int direction);\n")
    counts_api = "" if bits is None else f"""
/* Corrected angle, in [0, 360) degrees, of the raw code of a {macro}_BITS-bit encoder
   (the angle code * 360 / 2^{macro}_BITS; higher bits are ignored). */
float {prefix}_correct_counts(uint32_t code);
"""
    bits_macro = "" if bits is None else f"""
/* Resolution of the encoder codes taken by {prefix}_correct_counts, in bits. */
#define {macro}_BITS {bits}u
"""
    return f"""\
{banner}
#ifndef {guard}
#define {guard}

#include <stdint.h>

#ifdef __cplusplus
extern "C" {{
#endif
{bits_macro}
/* Predicted error (arc-minutes) at the encoder reading theta_deg (degrees, any finite value).
   A NaN or infinite theta_deg gives NaN, here and in {prefix}_correct_deg. */
float {prefix}_predict_arcmin(float theta_deg);

/* Corrected angle, in [0, 360) degrees, of the encoder reading theta_deg (degrees). */
float {prefix}_correct_deg(float theta_deg);
{counts_api}{directed_api}
#ifdef __cplusplus
}}
#endif

#endif /* {guard} */
"""


def _source(prefix, bits, banner, body, directed, reading_sign=1):
    step = None if bits is None else _Literals("double").number(360.0 / 2**bits)
    # The model's input is the reading, or its negative when the encoder counts against its reference.
    negate = "-" if reading_sign == -1 else ""
    input_code = "(0u - code)" if reading_sign == -1 else "code"
    directed_api = "" if not directed else f"""
float {prefix}_correct_deg_directed(float theta_deg, int direction)
{{
    const double theta = wrap360({negate}(double)theta_deg);
    return to_float_angle(wrap360(theta - model_directed_error_arcmin(theta, direction) / 60.0));
}}
""" + ("" if bits is None else f"""
float {prefix}_correct_counts_directed(uint32_t code, int direction)
{{
    const double theta = (double)({input_code} & CODE_MASK) * STEP_DEG;
    return to_float_angle(wrap360(theta - model_directed_error_arcmin(theta, direction) / 60.0));
}}
""")
    counts_error = ("code_error_arcmin(k)" if "code_error_arcmin" in body
                    else "error_arcmin(theta)")
    code_macros = "" if bits is None else f"""
#define CODE_MASK ((uint32_t)((((uint64_t)1) << {bits}) - 1u))
#define STEP_DEG {step} /* 360 / 2^{bits} degrees per code */"""
    counts_function = "" if bits is None else f"""
float {prefix}_correct_counts(uint32_t code)
{{
    const uint32_t k = {input_code} & CODE_MASK;
    const double theta = (double)k * STEP_DEG;
    return to_float_angle(wrap360(theta - {counts_error} / 60.0));
}}
"""
    return f"""\
{banner}
#include "{prefix}.h"

#include <math.h>
#include <stdint.h>

#define DEG_TO_RAD 0.017453292519943295{code_macros}

static double wrap360(double angle)
{{
    double wrapped;
    if (angle >= 0.0 && angle < 360.0) return angle;
    /* Within one turn of [0, 360) a subtraction gives exactly what fmod gives (360 - 720 is exact,
       -360 < angle < 0 rounds once, as fmod's result plus 360 does), without the libm call. */
    if (angle > -360.0 && angle < 720.0) {{
        wrapped = angle < 0.0 ? angle + 360.0 : angle - 360.0;
    }} else {{
        wrapped = fmod(angle, 360.0);
        if (wrapped < 0.0) wrapped += 360.0;
    }}
    return wrapped >= 360.0 ? 0.0 : wrapped;
}}

static float to_float_angle(double angle)
{{
    float rounded = (float)angle; /* 359.99999999 rounds to 360.0f: keep [0, 360) */
    return rounded >= 360.0f ? 0.0f : rounded;
}}

{body}
float {prefix}_predict_arcmin(float theta_deg)
{{
    return (float)error_arcmin(wrap360({negate}(double)theta_deg));
}}

float {prefix}_correct_deg(float theta_deg)
{{
    /* Wrap first: far from 0 a float's spacing exceeds the correction, which would be lost. */
    const double theta = wrap360({negate}(double)theta_deg);
    return to_float_angle(wrap360(theta - error_arcmin(theta) / 60.0));
}}
{counts_function}{directed_api}"""

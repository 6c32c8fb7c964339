"""Compact periodic tables: a model as N nodes, interpolated linearly or by a cubic B-spline, with wrap.

A compact table holds ``N`` values at evenly spaced angles ``i * 360 / N``
degrees (``N`` a power of two), interpolated with wrap (node ``N - 1`` is
followed by node 0) in one of two ways:

- ``'linear'``: node ``i`` is the error at its angle; between nodes the error
  is interpolated linearly (2 nodes per reading);
- ``'cubic'``: the nodes are the coefficients of a periodic uniform cubic
  B-spline (4 nodes per reading). Its error against a smooth profile falls
  with the fourth power of the node spacing instead of the second, so a
  profile with high harmonics needs far fewer nodes (``BENCHMARKS.md``).

The node values are a least-squares fit of the interpolated curve to the
model at every code of the encoder (the normal equations are circulant and
are solved with two FFTs; for linear interpolation, the curve through the
model's own values at the nodes would be about twice as far from it), then
stored as

- ``int8`` or ``int16`` in a unit of ``2^e`` turns / 2^32 (a power of two
  of a 32-bit binary angle, ``BAM_ARCMIN`` arc-minutes): the smallest such
  unit with which every node fits, so that a fixed-point processor converts to
  encoder counts with shifts alone, and a float one with one exact multiply; or
- ``float32`` arc-minutes.

A cubic table's integer nodes are in units of ``6 * 2^e`` binary-angle units
(float32 nodes: the coefficient / 6, arc-minutes), so that its run-time sum
``p0 + f (p1 + f (p2 + f p3))`` of integer combinations of the four nodes
(:func:`cubic_terms`) is the error in units of ``2^e`` without a division.

Each table states its *deployed* error: the largest and the RMS difference
between what the run-time rule of a target (:func:`predict_float32` for a
processor with a single-precision FPU, :func:`predict_fixed` for integer
arithmetic) returns and the model, over all ``2^B`` codes of the encoder
(65,536 evenly spaced angles when the resolution is unknown). The rules here
are the exact arithmetic of the exported C (:mod:`encal.deploy.targets`),
rounding step by rounding step, so the stated error is that of the firmware.
"""

import math
from dataclasses import dataclass

import numpy as np

from .._core.errors import InputError
from .._core.parameters import check_choice, check_int, check_number, invalid
from .compensator import Compensator

__all__ = ["CompactTable", "compile_compact", "choose_compact", "predict_float32", "predict_fixed",
           "error_lsb_float32", "cubic_terms",
           "NODE_DTYPES", "INTERPOLATIONS", "BAM_ARCMIN", "FIXED_FRACTION_BITS", "CUBIC_FRACTION_BITS", "MIN_NODES",
           "MAX_NODES",
           "default_tolerance_arcmin", "evaluation_bits", "model_on_codes", "check_nodes",
           "MIN_TABLE_BITS", "MAX_EXPORT_ERROR_ARCMIN", "check_table_bits", "check_exportable"]

NODE_DTYPES = ("int8", "int16", "float32")
#: Interpolation between nodes: piecewise linear (2 nodes per reading) or a cubic B-spline (4).
INTERPOLATIONS = ("linear", "cubic")
_INT_LIMIT = {"int8": 127, "int16": 32767}
#: One unit of a 32-bit binary angle (2^32 per turn), in arc-minutes.
BAM_ARCMIN = 21600.0 / 2**32
#: Bits of the interpolation fraction in the fixed-point rule (products stay below 2^31).
FIXED_FRACTION_BITS = 14
#: The same for cubic tables: Horner's partial sums of int16 nodes stay below 2^19.7, times 2^11.
CUBIC_FRACTION_BITS = 11
MIN_NODES = 4
MAX_NODES = 1 << 16
#: Fewest encoder bits a compact table serves: :data:`MIN_NODES` nodes, at most one per code.
MIN_TABLE_BITS = MIN_NODES.bit_length() - 1
#: Largest model error, in arc-minutes, that an export writes: one turn. An encoder's error is an angle
#: difference within a turn (a fitted model's stays within about half a turn of zero); beyond it the
#: exported arithmetic is wrong (the float32 targets wrap a corrected angle once, the fixed target's
#: int32 binary angles hold half a turn) or meaningless (a correction of 1e30 arcmin modulo 360 degrees).
MAX_EXPORT_ERROR_ARCMIN = 21600.0
_UNKNOWN_RESOLUTION_BITS = 16  # angles on which a table is measured when the resolution is unknown
_MAX_EVALUATION_BITS = 20      # beyond, the error is measured on 2^20 evenly spaced codes


@dataclass(frozen=True, eq=False)
class CompactTable:
    """A model as ``N`` nodes, interpolated linearly or by a cubic B-spline, with wrap.

    Attributes
    ----------
    values : ndarray of shape (N,), int8, int16 or float32
        Stored node values. Linear: node ``i`` is the error at ``i * 360 / N``
        degrees. Cubic: the B-spline coefficient centred there (see the module).
    scale_exponent : int or None
        Integer tables: the interpolated value is in units of
        ``2^scale_exponent * BAM_ARCMIN`` arc-minutes (linear: a stored unit;
        cubic: a stored unit is 6 of them). None for float32 tables (arc-minutes).
    bits : int or None
        Encoder resolution on whose codes the table was fitted and measured.
    max_error_arcmin, rms_error_arcmin : float
        Deployed error of the float32 rule against the model, over all codes.
    fixed_max_error_arcmin, fixed_rms_error_arcmin : float or None
        The same for the integer rule (integer tables only).
    model_sha256 : str or None
    offset_arcmin : float
        A constant added to every interpolated value (float32 rule; a float32 number): the
        model's mean error, kept out of the nodes so that their int8/int16 steps resolve the
        profile rather than a reference's arbitrary zero.
    offset_bam : int
        The same constant in units of a 32-bit binary angle (integer rule).
    interpolation : {'linear', 'cubic'}
    """

    values: np.ndarray
    scale_exponent: int | None
    bits: int | None
    max_error_arcmin: float
    rms_error_arcmin: float
    fixed_max_error_arcmin: float | None = None
    fixed_rms_error_arcmin: float | None = None
    model_sha256: str | None = None
    offset_arcmin: float = 0.0
    offset_bam: int = 0
    interpolation: str = "linear"

    @property
    def nodes(self):
        """Number of nodes N."""
        return int(self.values.size)

    @property
    def dtype(self):
        """``'int8'``, ``'int16'`` or ``'float32'``."""
        return self.values.dtype.name

    @property
    def scale_arcmin(self):
        """Arc-minutes per unit of the interpolated value (exact in float32); linear: per stored unit."""
        return 1.0 if self.scale_exponent is None else math.ldexp(BAM_ARCMIN, self.scale_exponent)

    @property
    def table_bytes(self):
        """Bytes of the node array in flash."""
        return int(self.values.nbytes)

    @property
    def error_arcmin(self):
        """The interpolated error at the nodes' angles, in arc-minutes (float64), the offset included."""
        return _at_nodes(self) * self.scale_arcmin + self.offset_arcmin

    @property
    def kind(self):
        """``'N-node int16 table'``, or ``'N-node int16 cubic table'``."""
        cubic = " cubic" if self.interpolation == "cubic" else ""
        return f"{self.nodes}-node {self.dtype}{cubic} table"

    def describe(self):
        """One line: nodes, storage, bytes and deployed error."""
        where = f"all {2**self.bits} codes" if self.bits else f"{2**_UNKNOWN_RESOLUTION_BITS} angles"
        return (f"{self.kind}, {self.table_bytes} bytes; deployed error against "
                f"the model over {where}: max {self.max_error_arcmin:.3g}, RMS {self.rms_error_arcmin:.3g} "
                "arcmin")


def evaluation_bits(bits):
    """Bits of the code grid on which tables are fitted and measured."""
    return _UNKNOWN_RESOLUTION_BITS if bits is None else min(int(bits), _MAX_EVALUATION_BITS)


def model_on_codes(model, bits):
    """The model's error (arcmin) at every code of the evaluation grid of ``bits``."""
    comp = model if isinstance(model, Compensator) else Compensator(model)
    grid = evaluation_bits(bits)
    theta = np.arange(2**grid, dtype=float) * (360.0 / 2**grid)
    chunk = 1 << 16
    return np.concatenate([np.asarray(comp.predict(theta[i:i + chunk]), dtype=float)
                           for i in range(0, theta.size, chunk)])


def check_exportable(error_arcmin, comp, caller, angles_deg=None):
    """Refuse model errors an export cannot write: NaN, infinite, or beyond :data:`MAX_EXPORT_ERROR_ARCMIN`.

    Parameters
    ----------
    error_arcmin : ndarray
        The model's error at the angles the export is evaluated on, arc-minutes.
    comp : Compensator
        The model (its file is named in the message).
    caller : str
        The function named in the message when the model has no file.
    angles_deg : ndarray, optional
        Those angles, degrees; default ``error_arcmin.size`` evenly spaced angles over a turn.

    Returns
    -------
    ndarray
        ``error_arcmin``, unchanged.

    Raises
    ------
    InputError
        At the first such error, naming its value and angle (a model file edited by hand and re-signed
        can hold coefficients up to 1e100).
    """
    values = np.asarray(error_arcmin, dtype=float)
    bad = ~(np.abs(values) <= MAX_EXPORT_ERROR_ARCMIN)  # NaN included
    if np.any(bad):
        first = int(np.argmax(bad))
        angle = (first * 360.0 / values.size if angles_deg is None
                 else float(np.asarray(angles_deg, dtype=float).reshape(-1)[first]))
        where = comp.source if comp.source else f"the model given to {caller}"
        raise InputError(f"{where}: the model predicts an error of {values.reshape(-1)[first]:.4g} arcmin at "
                         f"{angle:.6g} deg; expected errors within one turn (|error| <= "
                         f"{MAX_EXPORT_ERROR_ARCMIN:g} arcmin) to export, since an encoder's error is an angle "
                         "difference within a turn and the exported arithmetic holds no more (was the model "
                         "file edited by hand?)")
    return error_arcmin


def check_table_bits(bits, caller):
    """``bits`` as an int from :data:`MIN_TABLE_BITS` to 32, or None: the resolution of a compact table."""
    if bits is None:
        return None
    return check_int(bits, "bits", caller, low=MIN_TABLE_BITS, high=32,
                     note=f"the encoder resolution: a compact table has at least {MIN_NODES} nodes and at most "
                          "one per code; or None for the model file's")


def default_tolerance_arcmin(bits):
    """The default deployed-error tolerance: a tenth of an LSB, or 0.01 arcmin when the resolution is unknown."""
    return 0.01 if bits is None else 0.1 * 21600.0 / 2**bits


def compile_compact(model, nodes, *, dtype="int16", bits=None, reference=None, interpolation="linear"):
    """Fit a compact table of ``nodes`` nodes to a model and measure its deployed error.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
    nodes : int
        N, a power of two from 4 to 65,536 (and at most 2^B).
    dtype : {'int8', 'int16', 'float32'}, default='int16'
    bits : int, optional
        Encoder resolution; default the model file's. Without one the table is
        fitted and measured on 65,536 evenly spaced angles.
    reference : ndarray, optional
        The model at every code (:func:`model_on_codes`), when already computed.
    interpolation : {'linear', 'cubic'}, default='linear'

    Returns
    -------
    CompactTable
    """
    check_choice(dtype, "dtype", "compile_compact", NODE_DTYPES)
    check_choice(interpolation, "interpolation", "compile_compact", INTERPOLATIONS)
    comp = model if isinstance(model, Compensator) else Compensator(model)
    bits = _resolution(comp, bits, "compile_compact")
    grid = evaluation_bits(bits)
    nodes = check_nodes(nodes, bits, "compile_compact")
    cubic = interpolation == "cubic"
    target = check_exportable(model_on_codes(comp, bits), comp, "compile_compact") if reference is None \
        else reference
    mean = float(np.mean(target))
    offsets = {"offset_arcmin": float(np.float32(mean)),
               "offset_bam": int(np.clip(np.rint(mean / BAM_ARCMIN), -(2**31 - 1), 2**31 - 1))}
    fitted = _least_squares_nodes(target - offsets["offset_arcmin"], nodes, interpolation)
    # a cubic table's sum of integer combinations is 6 times the B-spline's value
    per_unit = 6.0 if cubic else 1.0
    if dtype == "float32":
        values, exponent = (fitted / per_unit).astype(np.float32), None
    else:
        # at least 2^-16: the fixed-point rule shifts by FIXED_FRACTION_BITS - e <= 30
        exponent = max(_scale_exponent(np.max(np.abs(fitted)) / (per_unit * BAM_ARCMIN), _INT_LIMIT[dtype]),
                       FIXED_FRACTION_BITS - 30)
        values = np.rint(fitted / (per_unit * math.ldexp(BAM_ARCMIN, exponent))).astype(dtype)
    table = CompactTable(values, exponent, bits, 0.0, 0.0, **offsets, interpolation=interpolation)
    codes = np.arange(2**grid, dtype=np.int64)
    deployed = predict_float32(table, codes, grid).astype(float)
    stats = {"max_error_arcmin": float(np.max(np.abs(deployed - target))),
             "rms_error_arcmin": float(np.sqrt(np.mean((deployed - target) ** 2)))}
    if dtype != "float32":
        fixed = predict_fixed(table, codes, grid)
        stats.update(fixed_max_error_arcmin=float(np.max(np.abs(fixed - target))),
                     fixed_rms_error_arcmin=float(np.sqrt(np.mean((fixed - target) ** 2))))
    return CompactTable(values, exponent, bits, model_sha256=comp.sha256, **stats, **offsets,
                        interpolation=interpolation)


def choose_compact(model, *, tolerance_arcmin=None, bits=None, cost="bytes", dtypes=NODE_DTYPES,
                   target="cortex-m4f", interpolations=INTERPOLATIONS):
    """The cheapest compact table whose deployed error stays within a tolerance of the model.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
    tolerance_arcmin : float, optional
        Largest deployed error (max over all codes) allowed, arc-minutes.
        Default :func:`default_tolerance_arcmin` (a tenth of an LSB).
    bits : int, optional
        Encoder resolution; default the model file's.
    cost : {'bytes', 'entries'}, default='bytes'
        What "cheapest" means: flash bytes of the table, or its number of nodes
        (ties go to the smaller table in bytes, then to linear interpolation,
        the fewer operations). The operations per reading of a table do not
        depend on N.
    dtypes : sequence of str, default=NODE_DTYPES
    target : {'cortex-m4f', 'fixed'}, default='cortex-m4f'
        Whose run-time rule's error counts (fixed allows integer dtypes only).
    interpolations : sequence of str, default=INTERPOLATIONS

    Returns
    -------
    table : CompactTable
        The cheapest table within the tolerance, or the most accurate one tried
        when none is.
    met : bool
        Whether the tolerance is met.
    """
    caller = "choose_compact"
    if tolerance_arcmin is not None:
        check_number(tolerance_arcmin, "tolerance_arcmin", caller, low=0.0, low_open=True,
                     note="arc-minutes, or None")
    check_choice(cost, "cost", caller, ("bytes", "entries"))
    check_choice(target, "target", caller, ("cortex-m4f", "fixed"))
    dtypes = _check_sequence(dtypes, "dtypes", caller, NODE_DTYPES)
    interpolations = _check_sequence(interpolations, "interpolations", caller, INTERPOLATIONS)
    comp = model if isinstance(model, Compensator) else Compensator(model)
    bits = _resolution(comp, bits, caller)
    tolerance = default_tolerance_arcmin(bits) if tolerance_arcmin is None else float(tolerance_arcmin)
    if target == "fixed":
        if set(dtypes) == {"float32"}:
            raise invalid("dtypes", caller, "a sequence with 'int8' or 'int16' for the fixed target", dtypes)
        dtypes = [d for d in dtypes if d != "float32"]
    reference = check_exportable(model_on_codes(comp, bits), comp, caller)
    largest = min(MAX_NODES, 2**evaluation_bits(bits))
    best, met = None, False
    candidates = []
    for interpolation in interpolations:
        for dtype in dtypes:
            nodes = MIN_NODES
            while nodes <= largest:
                table = compile_compact(comp, nodes, dtype=dtype, bits=bits, reference=reference,
                                        interpolation=interpolation)
                error = _error(table, target)
                if best is None or error < _error(best, target):
                    best = table
                if error <= tolerance:
                    candidates.append(table)
                    break
                nodes *= 2
    if candidates:
        cubic = {"linear": 0, "cubic": 1}
        key = ((lambda t: (t.table_bytes, cubic[t.interpolation], t.nodes)) if cost == "bytes"
               else (lambda t: (t.nodes, t.table_bytes, cubic[t.interpolation])))
        best, met = min(candidates, key=key), True
    return best, met


def _error(table, target):
    return table.fixed_max_error_arcmin if target == "fixed" else table.max_error_arcmin


def _resolution(comp, bits, caller):
    """The encoder resolution: ``bits``, else the model file's (None when neither knows it)."""
    return check_table_bits(comp.encoder.get("resolution_bits") if bits is None else bits, caller)


def check_nodes(nodes, bits, caller):
    """``nodes`` as an int: a power of two from :data:`MIN_NODES` to :data:`MAX_NODES`, at most 2^bits.

    ``bits`` is the encoder resolution (None when unknown); ``caller`` the function named in the message.
    """
    largest = min(MAX_NODES, 2**evaluation_bits(bits))
    valid = isinstance(nodes, (int, np.integer)) and not isinstance(nodes, bool) \
        and MIN_NODES <= nodes <= largest and nodes & (nodes - 1) == 0
    if not valid:
        note = f" (for a {bits}-bit encoder)" if largest < MAX_NODES else ""
        raise invalid("nodes", caller, f"a power of two from {MIN_NODES} to {largest}{note}", nodes)
    return int(nodes)


def _check_sequence(values, name, caller, choices):
    """``values`` as a non-empty tuple, each one of ``choices``."""
    if isinstance(values, str):
        values = (values,)
    try:
        values = tuple(values)
    except TypeError:
        raise invalid(name, caller, f"a non-empty sequence of {', '.join(map(repr, choices))}", values) from None
    if not values:
        raise invalid(name, caller, f"a non-empty sequence of {', '.join(map(repr, choices))}", values)
    return tuple(check_choice(value, name, caller, choices) for value in values)


def _basis(interpolation, t):
    """The weights of the nodes ``i + m`` at fractions ``t`` of segment ``i``: ``{m: weights}``."""
    if interpolation == "linear":
        return {0: 1.0 - t, 1: t}
    return {-1: (1.0 - t) ** 3 / 6.0, 0: (3.0 * t**3 - 6.0 * t**2 + 4.0) / 6.0,
            1: (-3.0 * t**3 + 3.0 * t**2 + 3.0 * t + 1.0) / 6.0, 2: t**3 / 6.0}


def _least_squares_nodes(target, nodes, interpolation="linear"):
    """Node values of the periodic interpolated curve closest (least squares) to ``target``.

    ``target`` holds ``M`` evenly spaced samples, ``M`` a multiple of ``nodes``:
    every segment sees the same sample positions, so the normal equations are
    circulant and are solved with two FFTs. For the cubic B-spline the values
    are its coefficients (arc-minutes).
    """
    per_segment = target.size // nodes
    weights = _basis(interpolation, np.arange(per_segment) / per_segment)
    samples = target.reshape(nodes, per_segment)
    rhs = np.zeros(nodes)
    row = np.zeros(nodes)
    for m, w in weights.items():
        rhs += np.roll(samples @ w, m)   # segment i's weight on node i + m
        for m2, w2 in weights.items():
            row[(m2 - m) % nodes] += w @ w2
    return np.real(np.fft.ifft(np.fft.fft(rhs) / np.fft.fft(row)))


def _scale_exponent(largest_units, limit):
    """The smallest ``e`` with ``rint(largest / 2^e) <= limit``: every rounded node fits."""
    if largest_units == 0.0:
        return 0
    exponent = math.floor(math.log2(largest_units / limit)) - 1
    while np.rint(largest_units / 2.0**exponent) > limit:
        exponent += 1
    return exponent


# -- the run-time rules, exactly as the exported C computes them ----------------------------

def cubic_terms(values, index):
    """The cubic rule's ``p0..p3`` (float32) for the segments ``index`` of a cubic table's node values.

    With ``a, b, c, d`` the nodes ``i-1 .. i+2`` (with wrap): ``p0 = a + 4b + c``,
    ``p1 = 3(c - a)``, ``p2 = 3(a + c) - 6b``, ``p3 = (d - a) + 3(b - c)``, six
    times the B-spline's polynomial in the fraction. Integer nodes: exact in
    int32, then converted (exactly: below 2^24); float32 nodes: in float32, in
    this order, as the C computes them.
    """
    index = np.asarray(index, dtype=np.int64)
    if values.dtype == np.float32:
        a, b, c, d = (values[(index + m) & (values.size - 1)] for m in (-1, 0, 1, 2))
        three, four, six = np.float32(3.0), np.float32(4.0), np.float32(6.0)
        return ((a + four * b) + c, three * (c - a), three * (a + c) - six * b, (d - a) + three * (b - c))
    return tuple(p.astype(np.float32) for p in _cubic_integer_terms(values, index))


def _cubic_integer_terms(values, index):
    """``p0..p3`` of integer nodes, exact (int64; they fit int32: below 12 * 32767)."""
    a, b, c, d = (values.astype(np.int64)[(index + m) & (values.size - 1)] for m in (-1, 0, 1, 2))
    return a + 4 * b + c, 3 * (c - a), 3 * (a + c) - 6 * b, (d - a) + 3 * (b - c)


def _interpolate_float32(table, index, fraction):
    """The interpolated value (units of ``scale_arcmin``, float32) in segments ``index`` at ``fraction``."""
    if table.interpolation == "cubic":
        p0, p1, p2, p3 = cubic_terms(table.values, index)
        return p0 + fraction * (p1 + fraction * (p2 + fraction * p3))
    stored = table.values.astype(np.float32)
    left = stored[index]
    return left + fraction * (stored[(index + 1) & (table.nodes - 1)] - left)


def _at_nodes(table):
    """The interpolated value at each node (fraction 0), float64, units of ``scale_arcmin``."""
    if table.interpolation == "cubic":
        values = table.values.astype(float)
        return np.roll(values, 1) + 4.0 * values + np.roll(values, -1)
    return table.values.astype(float)


def units_float32(table, codes, bits):
    """The float32 rule's interpolated value (units of ``scale_arcmin``, float32) at codes of a ``bits``-bit encoder.

    ``i = k >> (B - n)``, ``f = (k & (2^(B-n) - 1)) * 2^-(B-n)``, then linear:
    ``u = t[i] + f * (t[(i+1) mod N] - t[i])``; cubic: ``u = p0 + f (p1 + f (p2 + f p3))``
    (:func:`cubic_terms`); every step in float32.
    """
    codes = np.asarray(codes, dtype=np.int64)
    n = table.nodes.bit_length() - 1
    shift = bits - n
    index = codes >> shift
    fraction = (codes & ((1 << shift) - 1)).astype(np.float32) * np.float32(2.0**-shift)
    return _interpolate_float32(table, index, fraction)


def predict_float32(table, codes, bits):
    """The float32 rule: error in arcmin (float32) at codes, ``units * scale_arcmin + offset_arcmin``."""
    return units_float32(table, codes, bits) * np.float32(table.scale_arcmin) + np.float32(table.offset_arcmin)


def error_lsb_float32(table, codes, bits):
    """The float32 rule's error in LSB at codes: ``units * scale_lsb + offset_lsb`` (float32 constants)."""
    lsb = 21600.0 / 2**bits
    return (units_float32(table, codes, bits) * np.float32(table.scale_arcmin / lsb)
            + np.float32(table.offset_arcmin / lsb))


def predict_float32_angle(table, theta_deg):
    """The float32 rule for an angle in degrees (float32 in [0, 360)); error in arcmin (float32)."""
    theta = np.asarray(theta_deg, dtype=np.float32)
    x = theta * np.float32(table.nodes / 360.0)
    index = x.astype(np.int64)
    fraction = x - index.astype(np.float32)
    wrapped = index >= table.nodes
    index = np.where(wrapped, 0, index)
    fraction = np.where(wrapped, np.float32(0.0), fraction).astype(np.float32)
    units = _interpolate_float32(table, index, fraction)
    return units * np.float32(table.scale_arcmin) + np.float32(table.offset_arcmin)


def shift_round(value, shift):
    """``round(value / 2^shift)`` (halves up) for integers, as the C helper computes it."""
    value = np.asarray(value, dtype=np.int64)
    if shift <= 0:
        return value << -shift
    return (value + (1 << (shift - 1))) >> shift


def correction_bam(table, angles):
    """The integer rule: the error in units of a 32-bit binary angle at 32-bit angles.

    Linear: ``(t[i] * 2^14 + (t[i+1] - t[i]) * f)`` with a 14-bit fraction ``f``, then a rounding
    shift to binary-angle units. Cubic: Horner's rule on ``p3 .. p0`` (:func:`cubic_terms`) with an
    11-bit fraction, each product brought back by a rounding shift, then scaled by ``2^e``.
    """
    if table.dtype == "float32":
        raise InputError("expected an int8 or int16 table for the integer rule, got float32")
    angles = np.asarray(angles, dtype=np.int64) & 0xFFFFFFFF
    n = table.nodes.bit_length() - 1
    if table.interpolation == "cubic":
        bits = CUBIC_FRACTION_BITS
        index = angles >> (32 - n)
        fraction = (angles >> (32 - n - bits)) & ((1 << bits) - 1)
        p0, p1, p2, p3 = _cubic_integer_terms(table.values, index)
        value = p3
        for p in (p2, p1, p0):
            value = p + shift_round(value * fraction, bits)
        return shift_round(value, -table.scale_exponent) + table.offset_bam
    index = angles >> (32 - n)
    fraction = (angles >> (32 - n - FIXED_FRACTION_BITS)) & ((1 << FIXED_FRACTION_BITS) - 1)
    stored = table.values.astype(np.int64)
    left = stored[index]
    right = stored[(index + 1) & (table.nodes - 1)]
    scaled = left * (1 << FIXED_FRACTION_BITS) + (right - left) * fraction
    return shift_round(scaled, FIXED_FRACTION_BITS - table.scale_exponent) + table.offset_bam


def correction_lsb_q8(table, codes, bits):
    """The integer rule at codes: the error in 1/256 of an LSB."""
    angles = np.asarray(codes, dtype=np.int64) << (32 - bits)
    return shift_round(correction_bam(table, angles), 32 - bits - 8)


def predict_fixed(table, codes, bits):
    """The integer rule: error (arcmin, float64 of the integer result) at codes of a ``bits``-bit encoder."""
    return correction_lsb_q8(table, codes, bits).astype(float) * (21600.0 / 2**bits / 256.0)

"""Known truth through every harmless form of one calibration (task truth8).

A simulated encoder has a known error profile (a sum of harmonics, fixed seeds) and Gaussian reading noise. The
same calibration is written in many equivalent forms (rows shuffled, reversed, sorted by encoder angle or starting
at another angle; angles in [0, 360), (-180, 180], several turns, radians, turns, counts; columns swapped, extra
columns, CRLF, a BOM, comments, trailing blank lines, scientific notation, semicolons with decimal commas, tabs,
blanks; repeats in blocks or interleaved; a direction column as +1/-1 or cw/ccw; 12- and 14-bit codes as degrees or
counts), and the real command line (``encal.cli.main`` in this process) runs on each:

- ``encal fit --reproducible`` (the default method, auto, and ``--method lut``), then ``encal correct`` of dense
  noise-free readings: the corrected angles must agree with the plain form's (same numbers: within
  ``SAME_ARCMIN``) and with the truth (the reference angle of each reading: RMS within the case's tolerance);
- ``encal evaluate --json`` of the model on a test calibration written in the same form, ``encal profile --json``
  of the form itself: every statistic and the harmonics as the plain form's;
- the model file's resolution as the truth's (a table is exported for it).

The same for ``encal correct``'s own input (a reading a line, a CSV column, units, line ends, a BOM), for ``encal
selfcal steps`` on the README's stepper (rows shuffled, columns swapped, radians, counts as degrees) and for ``encal
selfcal spin`` on a spin log of the truth's encoder (unwrapped, wrapped, radians, counts; its calibration also
against the truth, less the orders one speed cannot see) and for the second pass of ``encal fit --repeat``. Then the
exports: ``encal export --format c`` (host, cortex-m4f, fixed; compiled with gcc and run on every code),
``--format table``, and moteus, SimpleFOC 1.0.9, Tinymovr, Klipper and Mechaduino through their own run-time code
(the harnesses of ``tests/deploy/firmware_own``; Klipper and Mechaduino in the stepper's frame, step 0 at the
reference's 0 degree), on the codes of a 14-bit encoder: the corrected error against the truth must be the
one ``encal correct`` gives, within the resolution the export states.

Usage::

    PYTHONPATH=src OMP_NUM_THREADS=1 python benchmarks/truth_variants.py [--only NAME,...] [--no-export]

Prints one Markdown table row per case and exits 1 if any case disagrees (about 20 s of CPU). A case documented as
refused (repeats in random order, without ``--keep-duplicates``) agrees when it is refused with its way out.
"""

import argparse
import json
import math
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from fuzz_session6 import run as run_with_traceback  # noqa: E402

# the encoder's error at a reference angle: (order, amplitude arcmin, phase rad); a zero offset of 3 arcmin
HARMONICS = ((1, 12.0, 0.3), (2, 5.0, 1.1), (3, 2.0, 2.0), (4, 1.5, -0.4), (7, 0.8, 0.9), (16, 0.5, 0.2))
OFFSET_ARCMIN = 3.0
NOISE_ARCMIN = 0.05
REVERSAL_ARCMIN = 1.2  # a bidirectional encoder reads this much more going forward than going back
# the same numbers read in another form: the corrected angles within this. The spectral fit's optimiser ends within
# about 1e-6 arcmin of its optimum, a little differently when the same readings come in another order (a 3-turn
# sweep written backwards: 1.8e-6)
SAME_ARCMIN = 1e-5
TRUTH_RMS_ARCMIN = 0.06  # corrected dense readings against the truth, noise 0.05 arcmin on a 1-degree grid
TRUTH_MAX_ARCMIN = 0.2
# the fits run on every form: a label and its options (the first one's model is also evaluated)
FITS = {
    "auto": ["--method", "auto"],
    "lut": ["--method", "lut"],
    "auto --folds 5": ["--method", "auto", "--folds", "5", "--seed", "0"],
    "ann 1:8:1": ["--method", "ann", "--hidden", "8", "--seed", "0", "--epochs", "200"],
    "fourier": ["--method", "fourier", "--n-orders", "8"],
    "hybrid": ["--method", "hybrid", "--seed", "0"],
    "auto, mean of both directions": ["--method", "auto", "--bidirectional", "mean"],
    "lut cubic": ["--method", "lut", "--interpolation", "cubic"],
}
# a looser truth for a fit that cannot follow the profile: a 1:8:1 network of 200 epochs misses part of the 16th
# harmonic (0.27 arcmin RMS, 0.77 at most, in every form)
FIT_TRUTH = {"ann 1:8:1": (0.4, 1.2)}
STAT_KEYS = ("n", "mae_arcmin", "rms_arcmin", "max_abs_arcmin", "min_arcmin", "max_arcmin")


def truth_error(reference_deg, direction=None):
    """The encoder's error at a reference angle, arc-minutes (``direction`` +1/-1: half the reversal added)."""
    theta = np.radians(reference_deg)
    error = OFFSET_ARCMIN + sum(a * np.cos(k * theta + p) for k, a, p in HARMONICS)
    if direction is not None:
        error = error + np.asarray(direction) * REVERSAL_ARCMIN / 2
    return error


def wrap_arcmin(delta_deg):
    return ((np.asarray(delta_deg) + 180.0) % 360.0 - 180.0) * 60.0


def run(argv, stdin_text=None):
    """(status, stdout, stderr) of ``encal argv`` in this process; a traceback is returned as stderr, status None."""
    status, out, err, trace = run_with_traceback([str(a) for a in argv], stdin_text)
    return status, out, err if trace is None else trace


# ------------------------------------------------------------------------------------------------- the data


@dataclass
class Rows:
    """One calibration as numbers: reference and encoder angles (degrees), optional direction and extra columns."""

    reference: np.ndarray
    encoder: np.ndarray
    direction: np.ndarray = None
    bits: int = None  # the encoder's resolution when its readings are whole codes
    zero_deg: float = 0.0  # the encoder's zero against the reference's (a motor's arbitrary zero)
    arc: tuple = None  # (start, span) degrees of a calibration over one arc


def simulate(seed, *, start=0.0, step=1.0, passes=1, bidirectional=False, bits=None, noise=NOISE_ARCMIN, zero_deg=0.0,
             span=None):
    """A calibration of the truth's encoder at ``start + k * step`` degrees, ``passes`` times (each direction); over
    the whole turn, or over the arc of ``span`` degrees from ``start`` (both ends included)."""
    rng = np.random.default_rng(seed)
    grid = start + (np.arange(0.0, 360.0, step) if span is None else np.arange(0.0, span + step / 2, step))
    references, directions = [], []
    for _ in range(passes):
        for direction in ((1, -1) if bidirectional else (None,)):
            references.append(grid if direction != -1 else grid[::-1])
            directions.append(np.full(grid.size, direction if direction else 0))
    reference = np.concatenate(references)
    direction = np.concatenate(directions) if bidirectional else None
    encoder = reference + zero_deg + (truth_error(reference, direction) + rng.normal(0.0, noise, reference.size)) / 60.0
    if bits:
        lsb = 360.0 / 2**bits
        encoder = np.round(encoder / lsb) * lsb
    return Rows(reference % 360.0, encoder % 360.0, direction, bits, zero_deg, None if span is None else (start, span))


def simulate_sweep(seed, *, turns=3, n=6007, reference_bits=17, bits=14, noise=NOISE_ARCMIN):
    """A continuous log of ``turns`` turns of the encoder (``bits`` bits) against a ``reference_bits``-bit reference,
    unwrapped; ``n`` readings, a step that does not divide the turn (every reference code is read once)."""
    rng = np.random.default_rng(seed)
    shaft = np.linspace(0.0, 360.0 * turns, n, endpoint=False) + 0.05
    reference_lsb, lsb = 360.0 / 2**reference_bits, 360.0 / 2**bits
    reference = np.round(shaft / reference_lsb) * reference_lsb
    encoder = np.round((shaft + (truth_error(shaft) + rng.normal(0.0, noise, n)) / 60.0) / lsb) * lsb
    return Rows(reference, encoder, None, bits)


@dataclass
class Form:
    """How one calibration is written: every field a harmless change of the plain form."""

    order: str = "as-is"  # as-is, shuffled, reversed, by-encoder, rotated, interleaved
    ref_wrap: str = "0-360"  # 0-360, pm180, turns (k*360 added row by row), plus720
    enc_wrap: str = "0-360"
    unit: str = "deg"  # both columns: deg, rad, rev
    ref_unit: str = None
    enc_unit: str = None  # also counts:B
    number: str = "repr"  # repr, fixed10, sci, plus
    separator: str = ","
    decimal_comma: bool = False
    header: tuple = ("reference_deg", "encoder_deg")  # the names in the file's column order
    swap: bool = False
    extra: bool = False  # an index column before and a temperature column after
    quoted: bool = False
    line_end: str = "\n"
    bom: bool = False
    comments: bool = False  # comment lines at the top and among the rows
    trailing_blank: bool = False
    direction_words: bool = False  # cw/ccw instead of +1/-1
    bits_comment: bool = False
    padded: bool = False  # blanks around every cell, as printf("%12.6f, ...") writes
    mixed_line_ends: bool = False  # CRLF and LF alternating
    no_final_line_end: bool = False
    reverse: bool = False  # the encoder mounted to count against the reference: readings negated, --reverse
    one_direction_column: bool = False  # a direction column that says +1 on every row
    epoch_column: bool = False  # an epoch column with one label (two when the rows are two passes)
    epoch_labels: tuple = ("2026-11-28 run A", "2026-11-28 run B")
    options: tuple = ()  # command-line options this form needs (fit, evaluate, profile)


UNIT_SCALE = {"deg": 1.0, "rad": math.pi / 180.0, "rev": 1.0 / 360.0}


def _convert(values_deg, unit, bits):
    if unit.startswith("counts:"):
        b = int(unit.split(":")[1])
        return values_deg / (360.0 / 2**b)
    return values_deg * UNIT_SCALE[unit]


def _wrap(values, how, rng):
    if how == "keep":  # angles already unwrapped as they are to be written (a sweep of several turns)
        return values
    if how == "0-360":
        return values % 360.0
    if how == "pm180":
        return 180.0 - (180.0 - values) % 360.0  # (-180, 180]
    if how == "turns":
        return values % 360.0 + 360.0 * rng.integers(-3, 4, values.size)
    if how == "plus720":
        return values % 360.0 + 720.0
    raise ValueError(how)


def _number(value, how, decimal_comma):
    if how == "repr":
        text = repr(float(value))
    elif how.startswith("fixed"):
        text = f"{value:.{int(how[5:])}f}"
    elif how == "sci":
        text = f"{value:.16e}"
    elif how == "plus":
        text = ("+" if value >= 0 else "") + repr(float(value))
    elif how == "int":
        text = str(int(round(value)))
    else:
        raise ValueError(how)
    return text.replace(".", ",") if decimal_comma else text


def write(rows, form, path, seed=7):
    """Write ``rows`` in ``form`` to ``path``."""
    rng = np.random.default_rng(seed)
    n = rows.reference.size
    index = np.arange(n)
    if form.order == "shuffled":
        index = rng.permutation(n)
    elif form.order == "reversed":
        index = index[::-1]
    elif form.order == "by-encoder":
        index = np.argsort(rows.encoder, kind="stable")
    elif form.order == "rotated":
        index = np.roll(index, -int(n * 0.381))
    elif form.order == "interleaved":  # passes in blocks become each angle's readings in a row
        passes = n // np.unique(rows.reference).size
        index = index.reshape(passes, -1).T.ravel()
    ref_unit = form.ref_unit or form.unit
    enc_unit = form.enc_unit or form.unit
    reference = _convert(_wrap(rows.reference, form.ref_wrap, rng), ref_unit, rows.bits)
    encoder = _convert(_wrap(-rows.encoder if form.reverse else rows.encoder, form.enc_wrap, rng), enc_unit, rows.bits)
    enc_number = "int" if enc_unit.startswith("counts:") and rows.bits else form.number
    columns = [("ref", form.header[0]), ("enc", form.header[1])]
    if form.swap:
        columns.reverse()
    if rows.direction is not None or form.one_direction_column:
        columns.append(("dir", "direction"))
    if form.epoch_column:
        columns.append(("epoch", "epoch"))
    if form.extra:
        columns = [("idx", "index")] + columns + [("temp", "temperature_c")]
    sep = form.separator

    def cell(text):
        text = f'"{text}"' if form.quoted else text
        return f"  {text} " if form.padded else text

    lines = []
    if form.comments:
        lines += ["# calibration of a simulated encoder", "# written by truth_variants.py"]
    if form.bits_comment and rows.bits:
        lines.append(f"# resolution_bits: {rows.bits}")
    lines.append(sep.join(cell(name) for _, name in columns))
    for position, i in enumerate(index):
        if form.comments and position == n // 2:
            lines.append("# half way")
        cells = []
        for key, _ in columns:
            if key == "ref":
                cells.append(_number(reference[i], form.number, form.decimal_comma))
            elif key == "enc":
                cells.append(_number(encoder[i], enc_number, form.decimal_comma))
            elif key == "dir":
                d = 1 if rows.direction is None else int(rows.direction[i])
                cells.append(("cw" if d > 0 else "ccw") if form.direction_words else f"{d:+d}")
            elif key == "epoch":
                passes = n // np.unique(np.round(rows.reference, 9)).size
                cells.append(form.epoch_labels[int(i) * passes // n if passes == 2 else 0])
            elif key == "idx":
                cells.append(str(position))
            else:
                cells.append(_number(21.5 + 0.01 * position, "fixed10", form.decimal_comma))
        lines.append(sep.join(cell(c) for c in cells))
    if form.mixed_line_ends:
        text = "".join(line + ("\r\n" if k % 2 else "\n") for k, line in enumerate(lines))
    else:
        text = form.line_end.join(lines) + ("" if form.no_final_line_end else form.line_end)
    if form.trailing_blank:
        text += form.line_end * 3
    data = text.encode("utf-8")
    if form.bom:
        data = b"\xef\xbb\xbf" + data
    Path(path).write_bytes(data)


def unit_options(form):
    options = []
    if form.unit != "deg":
        options += ["--unit", form.unit]
    if form.ref_unit:
        options += ["--ref-unit", form.ref_unit]
    if form.enc_unit:
        options += ["--enc-unit", form.enc_unit]
    if form.swap or form.header != ("reference_deg", "encoder_deg"):
        if form.header[0].lower() != "reference_deg":
            options += ["--ref-col", form.header[0]]
        if form.header[1].lower() != "encoder_deg":
            options += ["--enc-col", form.header[1]]
    if form.reverse:
        options.append("--reverse")
    return options + list(form.options)


# ------------------------------------------------------------------------------------------------- the cases


@dataclass
class Case:
    name: str
    group: str  # cases of one group hold the same numbers: they must agree with the group's first case
    train: Rows
    test: Rows
    form: Form = field(default_factory=Form)
    truth_rms: float = TRUTH_RMS_ARCMIN
    truth_max: float = TRUTH_MAX_ARCMIN
    same: float = SAME_ARCMIN
    fits: tuple = ("auto", "lut")
    bits_optional: bool = False  # the written digits no longer hold whole codes: an unknown resolution is right
    refused: str = None  # the form is documented as refused, with a message holding this text


def cases():
    plain = simulate(1), simulate(2, start=0.5)
    two_passes = simulate(3, passes=2), simulate(4, start=0.5)
    bidirectional = simulate(5, bidirectional=True), simulate(6, start=0.5, bidirectional=True)
    motor = simulate(12, zero_deg=97.3), simulate(13, start=0.5, zero_deg=97.3)
    half_turn = simulate(14, zero_deg=179.99), simulate(15, start=0.5, zero_deg=179.99)
    bits14 = simulate(8, bits=14), simulate(9, start=0.5, bits=14)
    bits12 = simulate(10, bits=12), simulate(11, start=0.5, bits=12)
    out = []

    def add(name, group, data, tolerance=None, bits_optional=False, refused=None, fits=("auto", "lut"), **form):
        rms, peak = tolerance or (TRUTH_RMS_ARCMIN, TRUTH_MAX_ARCMIN)
        out.append(Case(name, group, data[0], data[1], Form(**form), rms, peak, fits=fits,
                        bits_optional=bits_optional, refused=refused))

    add("plain", "plain", plain)
    add("rows shuffled", "plain", plain, order="shuffled")
    add("rows reversed", "plain", plain, order="reversed")
    add("rows sorted by encoder", "plain", plain, order="by-encoder")
    add("file starting at 137 deg", "plain", plain, order="rotated")
    add("both (-180, 180]", "plain", plain, ref_wrap="pm180", enc_wrap="pm180")
    add("encoder (-180, 180]", "plain", plain, enc_wrap="pm180")
    add("both +720 deg", "plain", plain, ref_wrap="plus720", enc_wrap="plus720")
    add("turns added row by row", "plain", plain, ref_wrap="turns", enc_wrap="turns")
    add("radians --unit rad", "plain", plain, unit="rad")
    add("radians (-pi, pi] --unit rad", "plain", plain, unit="rad", ref_wrap="pm180", enc_wrap="pm180")
    add("turns --unit rev", "plain", plain, unit="rev")
    add("reference rad, encoder deg", "plain", plain, ref_unit="rad", enc_unit="deg")
    add("encoder counts:24 (fractional)", "plain", plain, enc_unit="counts:24")
    add("columns swapped", "plain", plain, swap=True)
    add("header in capitals", "plain", plain, header=("REFERENCE_DEG", "Encoder_Deg"))
    add("other names --ref-col/--enc-col", "plain", plain, header=("table", "sensor"))
    add("extra columns", "plain", plain, extra=True)
    add("quoted cells", "plain", plain, quoted=True)
    add("CRLF", "plain", plain, line_end="\r\n")
    add("CR", "plain", plain, line_end="\r")
    add("UTF-8 BOM", "plain", plain, bom=True)
    add("comment lines", "plain", plain, comments=True)
    add("trailing blank lines", "plain", plain, trailing_blank=True)
    add("scientific notation", "plain", plain, number="sci")
    add("blanks around cells", "plain", plain, padded=True)
    add("blanks around quoted cells, semicolons", "plain", plain, padded=True, quoted=True, separator=";",
        decimal_comma=True)
    add("CRLF and LF mixed", "plain", plain, mixed_line_ends=True)
    add("no line end after the last row", "plain", plain, no_final_line_end=True)
    add("plus signs", "plain", plain, number="plus")
    add("semicolons, decimal comma", "plain", plain, separator=";", decimal_comma=True)
    add("tabs, decimal comma", "plain", plain, separator="\t", decimal_comma=True, quoted=True)
    add("tabs, decimal point", "plain", plain, separator="\t", quoted=True)
    add("blanks", "plain", plain, separator="   ")
    add("all at once", "plain", plain, order="shuffled", ref_wrap="turns", enc_wrap="pm180", swap=True, extra=True,
        line_end="\r\n", bom=True, comments=True, trailing_blank=True, number="sci", separator=";",
        decimal_comma=True)
    add("a direction column, +1 throughout", "plain", plain, one_direction_column=True)
    add("an epoch column, one label", "plain", plain, epoch_column=True)
    add("encoder counting back, --reverse", "plain", plain, reverse=True)
    add("encoder counting back, (-180, 180], rad", "plain", plain, reverse=True, unit="rad", ref_wrap="pm180",
        enc_wrap="pm180")
    add("encoder zero at 97.3 deg", "zero 97.3", motor)
    add("zero 97.3, shuffled, (-180, 180]", "zero 97.3", motor, order="shuffled", ref_wrap="pm180", enc_wrap="pm180")
    add("zero 97.3, --zero arbitrary", "zero 97.3", motor, options=("--zero", "arbitrary"))
    add("zero 97.3, counting back", "zero 97.3", motor, reverse=True)
    add("zero 97.3, turns", "zero 97.3", motor, unit="rev", ref_wrap="turns", enc_wrap="turns")
    add("encoder zero at 179.99 deg", "zero 179.99", half_turn)
    add("zero 179.99, (-180, 180]", "zero 179.99", half_turn, ref_wrap="pm180", enc_wrap="pm180")
    add("zero 179.99, by encoder, rad", "zero 179.99", half_turn, order="by-encoder", unit="rad")
    add("zero 179.99, counting back", "zero 179.99", half_turn, reverse=True)
    # 15 points 24 degrees apart: they alias the truth's harmonics above the 7th (measured 0.65 arcmin RMS, 1.6 at
    # most, against the truth); the forms must agree with each other
    coarse = simulate(18, step=24.0), simulate(19, start=12.0, step=24.0)
    loose = (1.0, 3.0)
    add("15 points, 24 deg apart", "15 points", coarse, loose)
    add("15 points in radians", "15 points", coarse, loose, unit="rad")
    add("15 points in radians (-pi, pi]", "15 points", coarse, loose, unit="rad", ref_wrap="pm180", enc_wrap="pm180")
    add("15 points in turns, turns added", "15 points", coarse, loose, unit="rev", ref_wrap="turns", enc_wrap="turns")
    add("15 points, reversed, counting back", "15 points", coarse, loose, order="reversed", reverse=True)
    add("15 points, encoder zero 97.3", "15 points zero", (simulate(18, step=24.0, zero_deg=97.3),
                                                           simulate(19, start=12.0, step=24.0, zero_deg=97.3)), loose)
    add("15 points, zero 97.3, radians (-pi, pi]", "15 points zero", (simulate(18, step=24.0, zero_deg=97.3),
                                                                      simulate(19, start=12.0, step=24.0,
                                                                               zero_deg=97.3)), loose,
        unit="rad", ref_wrap="pm180", enc_wrap="pm180")
    others = ("auto --folds 5", "ann 1:8:1", "fourier", "hybrid")
    add("other fits", "other fits", plain, fits=others)
    add("other fits, rows shuffled", "other fits", plain, fits=others, order="shuffled")
    add("other fits, rows reversed", "other fits", plain, fits=others, order="reversed")
    add("other fits, (-180, 180], radians", "other fits", plain, fits=others, ref_wrap="pm180", enc_wrap="pm180",
        unit="rad")
    add("fixed 10 decimals", "plain 10 decimals", plain, number="fixed10")
    add("fixed 10 decimals, CRLF, shuffled", "plain 10 decimals", plain, number="fixed10", order="shuffled",
        line_end="\r\n")

    add("two passes in blocks", "two passes", two_passes)
    add("two passes interleaved", "two passes", two_passes, order="interleaved")
    add("two passes shuffled", "two passes", two_passes, order="shuffled", refused="use --keep-duplicates")
    add("two passes shuffled --keep-duplicates", "two passes", two_passes, order="shuffled",
        options=("--keep-duplicates",))
    add("two passes reversed", "two passes", two_passes, order="reversed")
    add("two passes, several turns", "two passes", two_passes, ref_wrap="turns", enc_wrap="turns")
    add("two passes as a 2-turn sweep", "two passes", two_passes, ref_wrap="sweep", enc_wrap="sweep")
    add("two epochs in blocks", "two epochs", two_passes, epoch_column=True)
    add("two epochs interleaved", "two epochs", two_passes, epoch_column=True, order="interleaved")
    add("two epochs shuffled", "two epochs", two_passes, epoch_column=True, order="shuffled")
    add("two epochs labelled 1 and 2, radians", "two epochs", two_passes, epoch_column=True, epoch_labels=("1", "2"),
        unit="rad", ref_wrap="pm180", enc_wrap="pm180")

    add("bidirectional +1/-1", "bidirectional", bidirectional)
    mean = ("auto, mean of both directions",)
    add("bidirectional, the mean of both directions", "bidirectional mean", bidirectional, fits=mean)
    add("bidirectional mean, cw/ccw, shuffled", "bidirectional mean", bidirectional, fits=mean, direction_words=True,
        order="shuffled")
    add("bidirectional mean, counting back, rad", "bidirectional mean", bidirectional, fits=mean, reverse=True,
        unit="rad")
    add("bidirectional cw/ccw", "bidirectional", bidirectional, direction_words=True)
    add("bidirectional shuffled", "bidirectional", bidirectional, order="shuffled")
    add("bidirectional (-180, 180], rad", "bidirectional", bidirectional, ref_wrap="pm180", enc_wrap="pm180",
        unit="rad")
    add("bidirectional semicolons", "bidirectional", bidirectional, separator=";", decimal_comma=True,
        line_end="\r\n")
    add("bidirectional, counting back", "bidirectional", bidirectional, reverse=True)
    add("bidirectional, turns added", "bidirectional", bidirectional, ref_wrap="turns", enc_wrap="turns", unit="rev")

    lsb14, lsb12 = 21600 / 2**14, 21600 / 2**12
    tol14 = (lsb14 / math.sqrt(12), 2 * lsb14)
    tol12 = (lsb12 / math.sqrt(12), 2 * lsb12)
    add("14-bit codes in degrees", "14-bit", bits14, tol14)
    add("14-bit, resolution comment", "14-bit", bits14, tol14, bits_comment=True)
    add("14-bit codes as counts:14", "14-bit", bits14, tol14, enc_unit="counts:14")
    add("14-bit counts, shuffled, CRLF", "14-bit", bits14, tol14, enc_unit="counts:14", order="shuffled",
        line_end="\r\n")
    add("14-bit degrees (-180, 180]", "14-bit", bits14, tol14, ref_wrap="pm180", enc_wrap="pm180")
    add("14-bit degrees to 6 decimals", "14-bit 6 decimals", bits14, tol14, number="fixed6")
    add("14-bit degrees to 6 decimals, shuffled", "14-bit 6 decimals", bits14, tol14, number="fixed6",
        order="shuffled")
    add("14-bit degrees to 4 decimals", "14-bit 4 decimals", bits14, tol14, number="fixed4", bits_optional=True)
    add("14-bit codes in radians", "14-bit", bits14, tol14, unit="rad")
    add("14-bit radians (-pi, pi], shuffled", "14-bit", bits14, tol14, unit="rad", ref_wrap="pm180", enc_wrap="pm180",
        order="shuffled")
    add("14-bit signed counts (-8192, 8192]", "14-bit", bits14, tol14, enc_unit="counts:14", enc_wrap="pm180")
    add("14-bit counts, reference in turns", "14-bit", bits14, tol14, ref_unit="rev", enc_unit="counts:14")
    add("14-bit counts counting back", "14-bit", bits14, tol14, enc_unit="counts:14", reverse=True)
    add("14-bit counts, turns added row by row", "14-bit", bits14, tol14, enc_unit="counts:14", ref_wrap="turns",
        enc_wrap="turns")
    add("14-bit degrees counting back", "14-bit", bits14, tol14, reverse=True)
    add("12-bit codes in degrees", "12-bit", bits12, tol12)
    add("12-bit degrees to 4 decimals", "12-bit 4 decimals", bits12, tol12, number="fixed4", bits_optional=True)
    add("12-bit degrees to 3 decimals", "12-bit 3 decimals", bits12, tol12, number="fixed3", bits_optional=True)
    add("12-bit codes as counts:12", "12-bit", bits12, tol12, enc_unit="counts:12")
    add("12-bit, resolution comment, blanks", "12-bit", bits12, tol12, bits_comment=True, separator=" ")
    add("12-bit degrees as turns", "12-bit", bits12, tol12, unit="rev")
    sweep = simulate_sweep(17), bits14[1]
    keep = dict(ref_wrap="keep", enc_wrap="keep")
    add("sweep of 3 turns, unwrapped", "sweep", sweep, tol14, **keep)
    cubic = ("auto", "lut", "lut cubic")
    add("sweep, cubic table", "sweep cubic", sweep, tol14, fits=cubic, **keep)
    add("sweep, cubic table, (-180, 180], radians", "sweep cubic", sweep, tol14, fits=cubic, ref_wrap="pm180",
        enc_wrap="pm180", unit="rad")
    add("sweep, cubic table, shuffled", "sweep cubic", sweep, tol14, fits=cubic, order="shuffled")
    add("14-bit, cubic table", "14-bit cubic", bits14, tol14, fits=cubic)
    add("14-bit, cubic table, radians (-pi, pi]", "14-bit cubic", bits14, tol14, fits=cubic, unit="rad",
        ref_wrap="pm180", enc_wrap="pm180")
    add("sweep wrapped to [0, 360)", "sweep", sweep, tol14)
    add("sweep, encoder wrapped, reference not", "sweep", sweep, tol14, ref_wrap="keep")
    add("sweep, reference counts:17 unwrapped", "sweep", sweep, tol14, ref_unit="counts:17", **keep)
    add("sweep, both in counts", "sweep", sweep, tol14, ref_unit="counts:17", enc_unit="counts:14", ref_wrap="keep")
    add("sweep, multi-turn counters (both unwrapped counts)", "sweep", sweep, tol14, ref_unit="counts:17",
        enc_unit="counts:14", **keep)
    add("sweep, reference counts wrapped, encoder counts unwrapped", "sweep", sweep, tol14, ref_unit="counts:17",
        enc_unit="counts:14", ref_wrap="0-360", enc_wrap="keep")
    add("sweep, semicolons, decimal comma", "sweep", sweep, tol14, separator=";", decimal_comma=True, **keep)
    add("sweep, an epoch column", "sweep", sweep, tol14, epoch_column=True, **keep)
    add("sweep, comments, CRLF, BOM", "sweep", sweep, tol14, comments=True, line_end="\r\n", bom=True, **keep)
    add("sweep, (-180, 180], radians", "sweep", sweep, tol14, ref_wrap="pm180", enc_wrap="pm180", unit="rad")
    add("sweep shuffled", "sweep", sweep, tol14, order="shuffled")
    add("sweep reversed", "sweep", sweep, tol14, order="reversed", **keep)
    add("sweep sorted by encoder", "sweep", sweep, tol14, order="by-encoder")
    for path in REAL_FILES:  # real AS5047D calibrations (no truth: only the forms' agreement)
        real = read_real(path)
        if real is None:
            continue
        label = f"real {path.stem.split('_')[1]}"
        unknown = (math.inf, math.inf)
        add(f"{label}, its 14-bit codes in degrees", label, real, unknown)
        add(f"{label}, 8 decimals as in the file", label, real, unknown, number="fixed8")
        add(f"{label}, shuffled, (-180, 180]", label, real, unknown, order="shuffled", ref_wrap="pm180",
            enc_wrap="pm180")
        add(f"{label}, radians, semicolons", label, real, unknown, unit="rad", separator=";", decimal_comma=True)
        add(f"{label}, encoder counts:14, reversed", label, real, unknown, enc_unit="counts:14", order="reversed")
        add(f"{label}, sorted by encoder, counting back", label, real, unknown, order="by-encoder", reverse=True)
    arc = simulate(20, start=-60.0, span=120.0), simulate(21, start=-59.5, span=119.0)
    add("arc -60 to 60 deg in [0, 360)", "arc", arc)
    add("arc in (-180, 180]", "arc", arc, ref_wrap="pm180", enc_wrap="pm180")
    add("arc, reference (-180, 180], encoder [0, 360)", "arc", arc, ref_wrap="pm180")
    add("arc, turns added", "arc", arc, ref_wrap="turns", enc_wrap="turns")
    add("arc shuffled, radians", "arc", arc, order="shuffled", unit="rad")
    add("arc reversed, (-pi, pi]", "arc", arc, order="reversed", unit="rad", ref_wrap="pm180", enc_wrap="pm180")
    add("arc counting back", "arc", arc, reverse=True)
    add("arc +720", "arc", arc, ref_wrap="plus720", enc_wrap="plus720")
    return out


REAL = ROOT.parent / "shared" / "data" / "real" / "mechaduino"
REAL_FILES = [REAL / name for name in ("mech_cejosey_2019-01-01_f7b12b5a.csv",
                                       "mech_charlesblouin_2020-10-17_a0185230.csv",
                                       "mech_deezmaker_2017-06-14_999aedda.csv")]


def read_real(path):
    """(calibration rows, the same as its test) of a real calibration file, or None when it is absent. A real
    file has no held-out half here: the test is the file itself."""
    if not path.exists():
        return None
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    lsb = 360.0 / 2**14
    codes = np.round(table[:, 1] / lsb)
    bits = 14 if np.max(np.abs(table[:, 1] - codes * lsb)) < 1e-6 else None
    rows = Rows(table[:, 0], codes * lsb if bits else table[:, 1], None, bits)
    return rows, rows


def _sweep(case):
    """A two-pass calibration written as one sweep of two turns (reference and encoder unwrapped)."""
    turn = np.repeat([0.0, 360.0], case.train.reference.size // 2)
    return turn


# ------------------------------------------------------------------------------------------------- running


def dense_readings(zero_deg=0.0, direction=None, sign=1, arc=None):
    """Noise-free readings of the truth's encoder at 0.25-degree steps of the reference (over the turn, or within
    the arc ``(start, span)`` half a degree from its ends); the reference angles."""
    reference = np.arange(0.125, 360.0, 0.25) if arc is None else np.arange(arc[0] + 0.5, arc[0] + arc[1] - 0.5,
                                                                            0.25) % 360.0
    return (sign * (reference + zero_deg + truth_error(reference, direction) / 60.0)) % 360.0, reference


def corrected(model, readings, direction=None):
    argv = ["correct", model, "-"] + (["--direction", f"{direction:+d}"] if direction else [])
    status, out, err = run(argv, "".join(f"{x!r}\n" for x in readings.tolist()))
    if status != 0:
        raise RuntimeError(f"encal {' '.join(map(str, argv))}: status {status}: {err.strip()[-300:]}")
    return np.array(out.split(), dtype=float)


def model_bits(model):
    return json.loads(Path(model).read_text())["encoder"].get("resolution_bits")


def outcome(case, folder):
    """The case's figures: a dict, or a refusal string."""
    stem = "".join(c if c.isalnum() else "_" for c in case.name)
    train, test = folder / f"{stem}_train.csv", folder / f"{stem}_test.csv"
    rows_train, rows_test = case.train, case.test
    form = case.form
    if form.ref_wrap == "sweep":  # the passes' angles unwrapped into successive turns
        turn = _sweep(case)
        rows_train = Rows(rows_train.reference + turn, rows_train.encoder + turn, rows_train.direction, rows_train.bits)
        form = Form(**{**form.__dict__, "ref_wrap": "keep", "enc_wrap": "keep"})
    write(rows_train, form, train)
    write(rows_test, form, test)
    options = unit_options(case.form)
    result = {"options": " ".join(options)}
    sign = -1 if case.form.reverse else 1
    for method in case.fits:
        model = folder / "model.json"
        model.unlink(missing_ok=True)
        status, out, err = run(["fit", train, "-o", model, "--reproducible"] + FITS[method] + options)
        if status != 0:
            return f"fit --method {method}: status {status}: {err.strip().splitlines()[-1] if err.strip() else ''}"
        directions = (1, -1) if case.train.direction is not None and "mean" not in FITS[method] else (None,)
        angles = {}
        for d in directions:
            dense, reference = dense_readings(case.train.zero_deg, d, sign, case.train.arc)
            angles[d] = corrected(model, dense, d)
            gap = wrap_arcmin(angles[d] - reference)
            result[f"{method} truth rms {d}"] = float(np.sqrt(np.mean(gap**2)))
            result[f"{method} truth max {d}"] = float(np.max(np.abs(gap)))
        result[f"{method} corrected"] = angles
        result[f"{method} bits"] = model_bits(model)
        if method == case.fits[0]:
            status, out, err = run(["evaluate", model, test, "--json"] + options)
            if status != 0:
                return f"evaluate: status {status}: {err.strip()[-200:]}"
            result["evaluate"] = json.loads(out)
    status, out, err = run(["profile", train, "--json"] + options)
    if status != 0:
        return f"profile: status {status}: {err.strip()[-200:]}"
    result["profile"] = json.loads(out)
    return result


def _shown(message):
    """A refusal in a table cell: its sentence without the temporary folder."""
    return re.sub(r"\S*/(?=\w+\.(csv|json))", "", message).replace("|", "/")


def _stat_gap(a, b):
    return max(abs(a[k] - b[k]) for k in STAT_KEYS)


def compare(case, result, first):
    """(agrees?, text of the largest gaps) of a case's result against its group's first result and the truth."""
    notes, ok = [], True
    truth_rms = max(v for k, v in result.items() if "truth rms" in k)
    truth_max = max(v for k, v in result.items() if "truth max" in k)
    for fit in case.fits:
        rms_bound, max_bound = FIT_TRUTH.get(fit, (case.truth_rms, case.truth_max))
        for key, value in result.items():
            if key.startswith(f"{fit} truth rms") and value > rms_bound or \
                    key.startswith(f"{fit} truth max") and value > max_bound:
                ok = False
                notes.append(f"TRUTH {fit}")
    expected_bits = case.train.bits
    enc_unit = case.form.enc_unit or case.form.unit
    if expected_bits is None and enc_unit.startswith("counts:"):  # the user says the readings are B-bit counts
        expected_bits = int(enc_unit.split(":")[1])
    result["profile bits"] = result["profile"].get("resolution_bits")
    for what in case.fits + ("profile",):
        bits = result[f"{what} bits"]
        if bits != expected_bits and not (case.bits_optional and bits is None):
            ok = False
            notes.append(f"{what} bits {bits} (truth {expected_bits})")
    same = 0.0
    if first is not None:
        for method in case.fits:
            for d, angles in result[f"{method} corrected"].items():
                same = max(same, float(np.max(np.abs(wrap_arcmin(angles - first[f"{method} corrected"][d])))))
        same = max(same, _stat_gap(result["evaluate"], first["evaluate"]),
                   _stat_gap(result["evaluate"]["before"], first["evaluate"]["before"]),
                   _stat_gap(result["profile"], first["profile"]))
        if (result["profile"]["harmonics"] is None) != (first["profile"]["harmonics"] is None):
            same = math.inf  # an arc has no harmonics: both or neither
        for mine, theirs in zip(result["profile"]["harmonics"] or [], (first["profile"]["harmonics"] or [])[:6]):
            if mine["order"] != theirs["order"]:
                same = math.inf
            same = max(same, abs(mine["amplitude_arcmin"] - theirs["amplitude_arcmin"]))
        if same > case.same:
            ok = False
            notes.append("DIFFERS")
    return ok, truth_rms, truth_max, same, ", ".join(notes)

# ------------------------------------------------------------------------------------------------- the exports

EXPORT_BITS = 14
C_DRIVER = r"""
#include <stdio.h>
#include <stdint.h>
#include "encal.h"
int main(void) {
    for (uint32_t code = 0; code < (1u << ENCAL_BITS); code++) {
#if defined(FIXED)
        printf("%.17g\n", (double)encal_correct_code(code) * 360.0 / (double)(1u << ENCAL_BITS));
#elif defined(DIRECTED)
        printf("%.17g\n", (double)encal_correct_counts_directed(code, DIRECTED));
#else
        printf("%.17g\n", (double)encal_correct_counts(code));
#endif
    }
    return 0;
}
"""
# what each export states as its distance from the model (the number in its output that the pattern's group holds),
# and what
# its result adds: the float32 rounding of a returned angle (2^-16 degree below 512), half a code for a code
EXPORTS = {
    "table (int16)": (["--format", "table"], r"deviation from the model (\S+) arcmin", 0.0),
    "table float32": (["--format", "table", "--dtype", "float32"], r"deviation from the model (\S+) arcmin", 0.0),
    "C host formula": (["--format", "c"], r"by at most (\S+) arcmin", 60 * 2.0**-16),
    "C host table": (["--format", "c", "--table"], r"(\S+) arcmin from the model at the codes", 60 * 2.0**-16),
    "C cortex-m4f": (["--format", "c", "--target", "cortex-m4f"], r"codes: max (\S+),", 60 * 2.0**-16),
    "C fixed (codes)": (["--format", "c", "--target", "fixed"], r"codes: max (\S+),",
                        21600.0 / 2**EXPORT_BITS / 2),
    "C cortex-m4f formula": (["--format", "c", "--target", "cortex-m4f", "--form", "formula"], r"codes: max (\S+),",
                             60 * 2.0**-16),
    "C cortex-m4f, 64 float32 nodes, linear": (["--format", "c", "--target", "cortex-m4f", "--nodes", "64",
                                                "--interpolation", "linear", "--dtype", "float32"],
                                               r"codes: max (\S+),", 60 * 2.0**-16),
    "C cortex-m4f, 128 int8 nodes": (["--format", "c", "--target", "cortex-m4f", "--nodes", "128", "--dtype", "int8"],
                                     r"codes: max (\S+),", 60 * 2.0**-16),
    "C fixed, 256 int8 nodes (codes)": (["--format", "c", "--target", "fixed", "--nodes", "256", "--dtype", "int8"],
                                        r"codes: max (\S+),", 21600.0 / 2**EXPORT_BITS / 2),
}
# the exports only some kinds of model have: --form formula is a Fourier series itself
EXPORT_KINDS = {"C cortex-m4f formula": ("spectral", "fourier")}


# firmware formats, applied by the firmware's own run-time code (tests/deploy/firmware_own): the angle it holds is
# the reading's corrected angle in the reading's sense, less the constant the export says it left out
FIRMWARES = {
    "moteus": ["--format", "moteus"],
    "simplefoc 1.0.9": ["--format", "simplefoc", "--firmware-version", "1.0.9"],
    "tinymovr": ["--format", "tinymovr"],
    # the stepper's frame: full step 0 at the reference's 0 degree, its positive steps raising the reference angle
    "klipper": ["--format", "klipper", "--step-zero", "0", "--step-direction", "1"],
    "mechaduino": ["--format", "mechaduino", "--step-zero", "0"],
}
FIRMWARE_STATED = r"within max (\S+), RMS"
FULL_STEPS = 200  # Klipper's stepper (tests/deploy/firmware_own/klipper.py)
# a stated figure is printed to 3 significant digits (1.97 for 1.9724): within half a unit of its last digit
STATED_DIGITS = 1.005
FIRMWARE_CONSTANT = r"a constant (\S+) arcmin"


def firmware_angles(name, text):
    """Degrees that the firmware's own code holds at every 14-bit code (in the reading's sense; Klipper's in the
    stepper's, modulo 4 full steps); or a reason it cannot run here."""
    from tests.deploy.firmware_own import klipper, mechaduino, moteus, simplefoc, tinymovr

    module = {"moteus": moteus, "simplefoc 1.0.9": simplefoc, "tinymovr": tinymovr, "klipper": klipper,
              "mechaduino": mechaduino}[name]
    reason = module.unavailable()
    if reason:
        return reason
    codes = np.arange(2**EXPORT_BITS)
    if name == "klipper":
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "printer.cfg"
            path.write_text(klipper.printer_cfg(text))
            calibration, _ = klipper.load_klipper(path)
        sixteen_bit = codes.astype(np.int64) << (16 - EXPORT_BITS)
        return (klipper.klipper_positions(calibration, sixteen_bit) + calibration.angle_phase_offset) * (360.0 / 65536)
    if name == "mechaduino":  # Controller.cpp: y = lookup[readEncoder()], from full step 0
        return mechaduino.read_lookup(text).astype(float)
    if name == "moteus":
        table, scale = moteus._table_and_scale(moteus.device_commands(text), 0)
        _, compensated = moteus.firmware_correction(table, scale, EXPORT_BITS, 1, 0)
        return compensated * 360.0 / 2**EXPORT_BITS
    if name == "tinymovr":
        return tinymovr.rectified(tinymovr.table_values(text), EXPORT_BITS, codes) * 360.0 / 2**EXPORT_BITS
    angles = simplefoc.firmware_angles("1.0.9", simplefoc.lut_values(text, "1.0.9"), EXPORT_BITS)
    return np.degrees(angles.astype(float))


def reference_of(readings_deg, rows, sign, direction=None):
    """The reference angle at which the truth's encoder (no noise, not quantised; going in ``direction``, or the
    mean of both) reads ``readings_deg``."""
    target = sign * np.asarray(readings_deg, dtype=float) - rows.zero_deg
    reference = target.copy()
    for _ in range(60):  # reference + error(reference) / 60 = target: a contraction (the error's slope << 60)
        reference = target - truth_error(reference, direction) / 60.0
    return reference % 360.0


def _stated(text, pattern):
    match = re.search(pattern, text)
    return float(match.group(1)) if match else math.nan


def _table_angles(path):
    """Corrected angle of every code from a dense table file, read as docs/deployment.md describes it."""
    data = Path(path).read_bytes()
    version, bits, dtype, header = np.frombuffer(data[8:10], "<u2")[0], data[10], data[11], \
        int(np.frombuffer(data[12:16], "<u4")[0])
    scale = float(np.frombuffer(data[24:32], "<f8")[0])
    sign = int(np.frombuffer(data[80:81], "<i1")[0]) if version == 2 else 1
    table = np.frombuffer(data[header:], "<i2" if dtype == 1 else "<f4").astype(float)
    codes = np.arange(2**bits)
    return (sign * codes * 360.0 / 2**bits - table * scale / 60.0) % 360.0


def _c_angles(folder, fixed, direction=None):
    if shutil.which("gcc") is None:
        raise RuntimeError("gcc not found")
    (folder / "main.c").write_text(C_DRIVER)
    binary = folder / "main"
    defines = (["-DFIXED"] if fixed else []) + ([f"-DDIRECTED=({direction})"] if direction else [])
    subprocess.run(["gcc", "-std=c99", "-O1", "-I", str(folder), *defines,
                    str(folder / "main.c"), str(folder / "encal.c"), "-lm", "-o", str(binary)], check=True)
    out = subprocess.run([str(binary)], check=True, capture_output=True, text=True).stdout
    return np.array(out.split(), dtype=float)


def export_rows(folder):
    """One row per (model, export): the export's corrected angles on every code against encal correct's and the
    truth's."""
    bits14 = simulate(8, bits=EXPORT_BITS)
    motor = simulate(16, bits=EXPORT_BITS, zero_deg=97.3)
    models = [("14-bit, auto", bits14, Form(), "auto"),
              ("14-bit counting back, auto", bits14, Form(reverse=True), "auto"),
              ("14-bit zero 97.3, lut", motor, Form(enc_unit=f"counts:{EXPORT_BITS}", order="shuffled"), "lut"),
              # one model a direction; without a direction, everything corrects by the mean of the two
              ("14-bit bidirectional, auto", simulate(23, bits=EXPORT_BITS, bidirectional=True),
               Form(order="shuffled", direction_words=True), "auto")]
    codes = np.arange(2**EXPORT_BITS)
    readings = codes * 360.0 / 2**EXPORT_BITS
    rows = []
    for label, data, form, method in models:
        sign = -1 if form.reverse else 1
        calibration, model = folder / "export_cal.csv", folder / "export_model.json"
        write(data, form, calibration)
        model.unlink(missing_ok=True)
        status, out, err = run(["fit", calibration, "-o", model, "--reproducible"] + FITS[method] + unit_options(form))
        if status != 0:
            rows.append((label, "fit", f"refused: {_shown(err.strip())}", False))
            continue
        reference = corrected(model, readings)
        truth = reference_of(readings, data, sign)
        truth_gap = wrap_arcmin(reference - truth)
        kind = json.loads(model.read_text())["kind"]
        for name, (options, words, adds) in EXPORTS.items():
            if name in EXPORT_KINDS and kind not in EXPORT_KINDS[name]:
                continue
            target = folder / ("export_out" if "C " in name else "export_out.tab")
            shutil.rmtree(target, ignore_errors=True) if target.is_dir() else target.unlink(missing_ok=True)
            status, out, err = run(["export", model, "-o", target] + options)
            if status != 0:
                rows.append((label, name, f"refused: {_shown(err.strip())}", False))
                continue
            angles = _table_angles(target) if "table" in name and "C " not in name else _c_angles(target,
                                                                                                  "fixed" in name)
            stated = _stated(out, words)
            gap = wrap_arcmin(angles - reference)
            bound = stated * STATED_DIGITS + adds + 1e-6
            ok = bool(np.max(np.abs(gap)) <= bound)
            exported_truth = wrap_arcmin(angles - truth)
            rows.append((label, name, f"{np.max(np.abs(gap)):.3g} (stated {stated:.3g} + {adds:.2g}) | "
                         f"{np.sqrt(np.mean(truth_gap**2)):.3g} / {np.sqrt(np.mean(exported_truth**2)):.3g}", ok))
            if name == "C host formula" and data.direction is not None:  # each direction's own correction
                for direction in (1, -1):
                    angles = _c_angles(target, False, direction)
                    directed = corrected(model, readings, direction)
                    directed_truth = reference_of(readings, data, sign, direction)
                    gap = wrap_arcmin(angles - directed)
                    ok = bool(np.max(np.abs(gap)) <= bound)
                    rms = [np.sqrt(np.mean(wrap_arcmin(a - directed_truth)**2)) for a in (directed, angles)]
                    rows.append((label, f"C host formula, direction {direction:+d}",
                                 f"{np.max(np.abs(gap)):.3g} (stated {stated:.3g} + {adds:.2g}) | "
                                 f"{rms[0]:.3g} / {rms[1]:.3g}", ok))
        for name, options in FIRMWARES.items():
            target = folder / "firmware_out.txt"
            target.unlink(missing_ok=True)
            status, out, err = run(["export", model, "-o", target, "--bits", EXPORT_BITS] + options)
            if status != 0:
                rows.append((label, name, f"refused: {_shown(err.strip())}", False))
                continue
            angles = firmware_angles(name, target.read_text())
            if isinstance(angles, str):
                rows.append((label, name, f"skipped: {angles}", True))
                continue
            stated, constant = _stated(out, FIRMWARE_STATED), _stated(out, FIRMWARE_CONSTANT)
            constant = 0.0 if math.isnan(constant) else constant
            if name == "klipper":  # the stepper's angle from step 0, modulo the 4 full steps of its phase
                period = 4 * 360.0 / FULL_STEPS

                def wrapped(delta_deg):
                    return ((delta_deg + period / 2) % period - period / 2) * 60.0

                gap, exported_truth = wrapped(angles - reference), wrapped(angles - truth)
            else:
                gap = wrap_arcmin(angles - sign * reference) + constant
                exported_truth = wrap_arcmin(angles - sign * truth) + constant
            ok = bool(np.max(np.abs(gap)) <= stated * STATED_DIGITS + 1e-5)
            rows.append((label, name, f"{np.max(np.abs(gap)):.3g} (stated {stated:.3g}; constant left out "
                         f"{constant:.4g}) | {np.sqrt(np.mean(truth_gap**2)):.3g} / "
                         f"{np.sqrt(np.mean(exported_truth**2)):.3g}", ok))
    return rows


# ---------------------------------------------------------------------------------------------- encal correct's input


def _lines(values, how):
    return "".join(_number(v, how, False) + "\n" for v in values)


def correct_forms():
    """(name, input text, options) of one set of readings in equivalent forms of ``encal correct``'s input."""
    readings, _ = dense_readings()
    rng = np.random.default_rng(3)
    pm180 = 180.0 - (180.0 - readings) % 360.0
    csv = "".join(f"{i},{v!r},21.5\r\n" for i, v in enumerate(readings.tolist()))
    swapped = "".join(f'"{v!r}",{i}\n' for i, v in enumerate(readings.tolist()))
    return [
        ("one reading a line", _lines(readings, "repr"), []),
        ("a UTF-8 BOM", "\ufeff" + _lines(readings, "repr"), []),
        ("CR line ends", _lines(readings, "repr").replace("\n", "\r"), []),
        ("CSV with a BOM", "\ufeffencoder_deg\n" + _lines(readings, "repr"), []),
        ("(-180, 180]", _lines(pm180, "repr"), []),
        ("turns added", _lines(readings + 360.0 * rng.integers(-3, 4, readings.size), "repr"), []),
        ("scientific notation", _lines(readings, "sci"), []),
        ("plus signs, CRLF", _lines(readings, "plus").replace("\n", "\r\n"), []),
        ("comments and blank lines", "# readings\n\n" + _lines(readings, "repr") + "\n\n", []),
        ("CSV, extra columns, CRLF", "index,encoder_deg,temperature_c\r\n" + csv, []),
        ("CSV, quoted, columns swapped", 'Encoder_Deg,"index"\n' + swapped, []),
        ("CSV, another name", "index,sensor,temperature_c\n" + csv.replace("\r\n", "\n"), ["--enc-col", "sensor"]),
        ("radians", _lines(np.radians(readings), "repr"), ["--enc-unit", "rad"]),
        ("radians (-pi, pi]", _lines(np.radians(pm180), "repr"), ["--enc-unit", "rad"]),
        ("turns", _lines(readings / 360.0, "repr"), ["--enc-unit", "rev"]),
        ("counts:24 (fractional)", _lines(readings / 360.0 * 2**24, "repr"), ["--enc-unit", "counts:24"]),
        ("counts:24, a multi-turn counter", _lines((readings / 360.0 + rng.integers(-3, 4, readings.size)) * 2**24,
                                                  "repr"), ["--enc-unit", "counts:24"]),
    ]


def correct_rows(folder):
    """One row per form of ``encal correct``'s input: its answers against the first form's."""
    calibration, model = folder / "correct_cal.csv", folder / "correct_model.json"
    write(simulate(1), Form(), calibration)
    model.unlink(missing_ok=True)
    status, _, err = run(["fit", calibration, "-o", model, "--reproducible"])
    if status != 0:
        return [("fit", f"refused: {_shown(err.strip())}", False)]
    rows, first = [], None
    for name, text, options in correct_forms():
        status, out, err = run(["correct", model, "-"] + options, text)
        if status != 0:
            rows.append((name, f"refused: {_shown(err.strip())}", False))
            continue
        angles = np.array(out.split(), dtype=float)
        first = angles if first is None else first
        gap = float(np.max(np.abs(wrap_arcmin(angles - first)))) if angles.size == first.size else math.inf
        rows.append((name, f"{gap:.2g}", gap <= SAME_ARCMIN))
    return rows


# ------------------------------------------------------------------------------------------------- encal selfcal steps

STEPPER = ROOT / "examples" / "stepper.csv"


def steps_forms():
    """(name, text, options) of the README's stepper calibration (200 full steps, 14-bit counts) in other forms."""
    lines = [line for line in STEPPER.read_text().splitlines() if line and not line.startswith("#")]
    steps = np.array([float(line.split(",")[0]) for line in lines[1:]])
    counts = np.array([int(line.split(",")[1]) for line in lines[1:]])
    order = np.random.default_rng(5).permutation(steps.size)
    degrees = counts * 360.0 / 2**14

    def table(header, first, second, index=slice(None), end="\n"):
        return end.join([header] + [f"{a},{b}" for a, b in zip(first[index], second[index])]) + end

    plain = ["--ref-col", "step_deg", "--enc-col", "counts", "--enc-unit", "counts:14"]
    return [
        ("as in examples/", STEPPER.read_text(), plain),
        ("rows shuffled", table("step_deg,counts", steps, counts, order), plain),
        ("rows reversed, CRLF, BOM", "\ufeff" + table("step_deg,counts", steps, counts, slice(None, None, -1),
                                                      "\r\n"), plain),
        ("columns swapped", table("counts,step_deg", counts, steps), plain),
        ("steps in radians", table("step_deg,counts", [repr(float(x)) for x in np.radians(steps)], counts),
         plain + ["--ref-unit", "rad"]),
        ("counts as degrees", table("reference_deg,encoder_deg", steps, [repr(float(x)) for x in degrees]), []),
        ("counts as degrees, (-180, 180]", table("reference_deg,encoder_deg", 180.0 - (180.0 - steps) % 360.0,
                                                 [repr(float(x)) for x in 180.0 - (180.0 - degrees) % 360.0]), []),
    ]


def _selfcal_outputs(folder, forms, command):
    """``(name, calibration or None, refusal)`` of ``encal selfcal COMMAND`` on each form (its input written to
    ``folder``), the calibration it wrote sorted by reference angle."""
    import encal

    for name, text, options in forms:
        source, output = folder / "selfcal_in.csv", folder / "selfcal_out.csv"
        source.write_text(text, newline="")
        output.unlink(missing_ok=True)
        status, out, err = run(["selfcal", *command[:1], source, "-o", output, *command[1:], *options])
        if status != 0:
            yield name, None, f"refused: {_shown(err.strip())}"
            continue
        cal = encal.read_calibration(output)
        yield name, cal.subset(np.argsort(cal.reference_deg)), None


def _gap(errors, first):
    return float(np.max(np.abs(errors - first))) if errors.size == first.size else math.inf


def steps_rows(folder):
    """One row per form of ``encal selfcal steps``'s input: the written calibration against the first form's."""
    rows, first = [], None
    for name, cal, refusal in _selfcal_outputs(folder, steps_forms(), ["steps"]):
        if cal is None:
            rows.append((name, refusal, False))
            continue
        first = cal.errors_arcmin if first is None else first
        gap = _gap(cal.errors_arcmin, first)
        rows.append((name, f"{gap:.2g}", gap <= SAME_ARCMIN))
    return rows


# ---------------------------------------------------------------------------------------------- encal selfcal spin


SPIN_TRUTH = (0.1, 0.3)  # arcmin, RMS and max of the written errors against the truth (0.5 arcmin of noise, 14 bits)


def spin_log(seconds=8.0, rate_hz=2000.0, bits=14, seed=5):
    """A spin of a 7-pole-pair motor (a slowly rising speed, a ripple of 20 arcmin at order 7) read by the truth's
    encoder (``bits`` bits, 0.5 arcmin of noise): time (s) and the unwrapped reading (degrees)."""
    rng = np.random.default_rng(seed)
    time = np.arange(0.0, seconds, 1.0 / rate_hz)
    nominal = 360.0 * 5.0 * time * (1 + 0.001 * time) + 33.0
    rotor = nominal + 20.0 / 60.0 * np.cos(np.radians(7 * nominal) + 2.8)
    reading = rotor + (truth_error(rotor) + rng.normal(0.0, 0.5, time.size)) / 60.0
    step = 360.0 / 2**bits
    return time, np.unwrap(np.round(np.mod(reading, 360.0) / step) * step, period=360.0)


def spin_forms():
    """(name, text, options) of one spin log in equivalent forms."""
    time, reading = spin_log()
    codes = np.round(np.mod(reading, 360.0) / (360.0 / 2**14)).astype(int)

    def table(header, columns, end="\n"):
        return end.join([header] + [",".join(cells) for cells in zip(*columns)]) + end

    t = [repr(float(x)) for x in time]
    return [
        ("unwrapped degrees", table("time_s,encoder_deg", [t, [repr(float(x)) for x in reading]]), []),
        ("wrapped to [0, 360)", table("time_s,encoder_deg", [t, [repr(float(x)) for x in reading % 360.0]]), []),
        ("(-180, 180], CRLF, BOM", "\ufeff" + table("time_s,encoder_deg", [t, [repr(float(x)) for x in
                                                                              180.0 - (180.0 - reading) % 360.0]],
                                                   "\r\n"), []),
        ("columns swapped, extra column, comments", "# a spin at 5 rev/s\n" + table(
            "encoder_deg,time_s,current_a", [[repr(float(x)) for x in reading], t, ["0.5"] * time.size]), []),
        ("radians", table("time_s,encoder_deg", [t, [repr(float(x)) for x in np.radians(reading)]]),
         ["--enc-unit", "rad"]),
        ("counts:14", table("time_s,counts", [t, [str(c) for c in codes]]), ["--enc-col", "counts", "--enc-unit",
                                                                              "counts:14"]),
        ("scientific notation", table(
            "time_s,encoder_deg", [[f"{x:.16e}" for x in time], [f"{x:.16e}" for x in reading]]), []),
    ]


def spin_rows(folder):
    """One row per form of ``encal selfcal spin``'s log: the written calibration against the first form's."""
    rows, first = [], None
    for name, cal, refusal in _selfcal_outputs(folder, spin_forms(), ["spin", "--pole-pairs", "7", "--bits", "14"]):
        if cal is None:
            rows.append((name, refusal, False))
            continue
        errors = cal.errors_arcmin
        first = errors if first is None else first
        gap = _gap(errors, first)
        # the truth without the orders one speed cannot see (multiples of the pole pairs) and without its mean
        # (the rotor's zero is arbitrary)
        theta = np.radians(cal.reference_deg)
        truth = sum(a * np.cos(k * theta + p) for k, a, p in HARMONICS if k % 7)
        miss = (errors - errors.mean()) - (truth - truth.mean())
        rms, largest = float(np.sqrt(np.mean(miss**2))), float(np.max(np.abs(miss)))
        rows.append((name, f"{gap:.2g} | {rms:.3g} / {largest:.3g}",
                     gap <= SAME_ARCMIN and rms <= SPIN_TRUTH[0] and largest <= SPIN_TRUTH[1]))
    return rows


# ---------------------------------------------------------------------------------------------- encal fit --repeat


def repeat_rows(folder):
    """One row per form of the second pass given with ``encal fit --repeat`` (the first pass plain): the corrected
    dense readings against the plain second pass's and the truth."""
    first_pass, second_pass = simulate(21), simulate(22)
    calibration, repeat, model = folder / "repeat_a.csv", folder / "repeat_b.csv", folder / "repeat_model.json"
    write(first_pass, Form(), calibration)
    forms = [("plain", Form()), ("shuffled", Form(order="shuffled")), ("reversed", Form(order="reversed")),
             ("starting at 137 deg", Form(order="rotated")), ("(-180, 180]", Form(ref_wrap="pm180", enc_wrap="pm180")),
             ("turns added", Form(ref_wrap="turns", enc_wrap="turns")),
             ("by encoder, CRLF, semicolons", Form(order="by-encoder", line_end="\r\n", separator=";",
                                                   decimal_comma=True))]
    dense, reference = dense_readings()
    rows, first = [], None
    for name, form in forms:
        write(second_pass, form, repeat, seed=9)
        model.unlink(missing_ok=True)
        status, _, err = run(["fit", calibration, "--repeat", repeat, "-o", model, "--method", "spectral",
                              "--reproducible"])
        if status != 0:
            rows.append((name, f"refused: {_shown(err.strip())}", False))
            continue
        angles = corrected(model, dense)
        first = angles if first is None else first
        gap = float(np.max(np.abs(wrap_arcmin(angles - first))))
        miss = wrap_arcmin(angles - reference)
        rms, largest = float(np.sqrt(np.mean(miss**2))), float(np.max(np.abs(miss)))
        rows.append((name, f"{gap:.2g} | {rms:.3g} / {largest:.3g}",
                     gap <= SAME_ARCMIN and rms <= TRUTH_RMS_ARCMIN and largest <= TRUTH_MAX_ARCMIN))
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="comma-separated case names (substrings)")
    parser.add_argument("--no-export", action="store_true", help="leave out the exports' part")
    args = parser.parse_args(argv)
    selected = cases()
    if args.only:
        keys = args.only.split(",")
        selected = [c for c in selected if any(k in c.name for k in keys)]
    failures = 0
    firsts = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        print("| case | group | fits | options | bits recorded | truth RMS / max, arcmin | largest gap to the group's "
              "first, arcmin | agrees |")
        print("|---|---|---|---|---|---|---|---|")
        for case in selected:
            result = outcome(case, folder)
            if isinstance(result, str):
                ok = case.refused is not None and case.refused in result
                failures += not ok
                print(f"| {case.name} | {case.group} | | | | refused: {_shown(result)} | | "
                      f"{'yes (documented)' if ok else 'NO'} |")
                continue
            if case.refused:
                failures += 1
                print(f"| {case.name} | {case.group} | | | | accepted, expected a refusal | | NO |")
                continue
            first = firsts.setdefault(case.group, result)
            ok, rms, peak, same, notes = compare(case, result, None if first is result else first)
            failures += not ok
            gap = "(first)" if first is result else f"{same:.2g}"
            bits = " / ".join(str(result[f"{fit} bits"]) for fit in case.fits)
            truth = "no truth" if math.isinf(case.truth_rms) else f"{rms:.3g} / {peak:.3g}"
            print(f"| {case.name} | {case.group} | {', '.join(case.fits)} | {result['options']} | {bits} | "
                  f"{truth} | {gap} | {'yes' if ok else 'NO ' + notes} |",
                  flush=True)
        tables = [
            ("encal correct's input | largest gap to the first form's answers, arcmin", correct_rows),
            ("encal selfcal steps input | largest gap of the written errors to the first form's, arcmin", steps_rows),
            ("encal selfcal spin log | largest gap of the written errors to the first form's, arcmin | against the "
             "truth without orders 7k and its mean: RMS / max, arcmin", spin_rows),
            ("encal fit --repeat: the second pass | largest gap to the plain pass's model, arcmin | against the "
             "truth: RMS / max, arcmin", repeat_rows),
        ]
        if not args.no_export:
            tables.append((f"model | export | largest gap to encal correct on every {EXPORT_BITS}-bit code, arcmin | "
                           "RMS against the truth, encal correct / the export, arcmin", export_rows))
        for header, rows in tables:
            print(f"\n| {header} | agrees |\n" + "|---" * (header.count("|") + 2) + "|")
            for *cells, ok in rows(folder):
                failures += not ok
                print(f"| {' | '.join(cells)} | {'yes' if ok else 'NO'} |", flush=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

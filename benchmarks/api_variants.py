"""Known truth through the public Python API in harmless and harmful forms (task pyapi).

``benchmarks/truth_variants.py`` audits the command line; this audits what a notebook or a test-bench script calls.
A simulated encoder has a known error (a few harmonics and a zero offset, arc-minutes, as a function of the
reference angle; a 1-degree grid with 0.05 arcmin of reading noise, fixed seeds). Then:

- **fits**: ``encal.fit`` with every method the docs list, on the calibration built in harmless forms (lists,
  read-only, strided, float32, angles in (-180, 180] or turns away, rows shuffled or reversed, written and read
  back with ``write_calibration``/``read_calibration``, ``subset`` of all of it): the corrected angles of dense
  noise-free readings must be the plain form's (``SAME_ARCMIN``; float32: the truth)
  and the truth's (the reference angle of each reading);
- **inputs**: ``Model.predict``/``correct``, ``Compensator`` and the standalone ``encal.runtime`` on readings in
  harmless forms (scalar, 0-d, lists, ints, float32, 2-D C and Fortran order, strided, read-only, turns away,
  (-180, 180], 10**6 + 1 readings across chunk boundaries, ``table=True``): the same numbers in the same shape,
  the input untouched, a second call the same;
- **files**: the model saved and loaded, ``Compensator(path)``, ``compile_table`` on 14-bit codes, ``export_c``
  of the model in memory, loaded and by its path (the same C);
- **analysis**: ``evaluate``, ``error_stats``, ``harmonics`` on harmless forms; a bidirectional calibration, an
  arc across the zero and 14-bit codes in harmless forms; the simulators twice;
  ``encal.selfcal.steps`` on a shuffled calibration; ``fit`` with no BLAS thread variables (another process);
- **store** (task storeapi): ``encal.store`` from Python: the model written by serial number and read back in
  harmless forms (a ``str`` or ``Path`` store, a ``Model`` or its file's text, serials with spaces, decomposed (NFD),
  in other scripts, the store opened again, ``history``/``latest_records``): the model in memory's corrected angles
  exactly; epochs (a unit written twice, the same calibration twice), the drift of a unit recalibrated unchanged and
  of one whose first order grew by 1 arcmin (``drift_table``: the known change within 3 u, the verdict), grades, and
  ``fit_batch`` from Python against ``encal.fit`` of each file;
- **firmware** (task storeapi): each exporter of ``encal.deploy.firmware`` on the model of 14-bit codes, of an encoder
  counting against the reference and of a bidirectional calibration: the table applied through the project's own
  reader of the format against ``Model.correct``, within the round trip the export reports (Mechaduino: its stated
  rounding; Klipper: the list's ``%.1f``); and the same text for the model given as an object, a Compensator, a path
  (str, Path), ``load_model`` of it, or ``bits=14`` given (the C export too);
- **refused**: harmful inputs (NaN, infinity, strings, complex numbers, wrong shapes, mismatched lengths, empty
  arrays, radians where degrees are expected; for the store a missing folder, a serial not there, a model that is no
  model file; for the exporters wrong bits, no step zero, a model of an arc): each must be an encal error in one
  sentence, never a NumPy traceback or a number.

Usage::

    PYTHONPATH=src OMP_NUM_THREADS=1 python benchmarks/api_variants.py [--only TEXT,...]

Prints one Markdown table row per case and exits 1 if any case disagrees (about 15 s of CPU).
"""

import argparse
import math
import os
import subprocess
import sys
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

import encal  # noqa: E402
from encal import runtime  # noqa: E402
from encal._core.errors import EncalError  # noqa: E402

# the encoder's error at a reference angle: (order, amplitude arcmin, phase rad); a zero offset of 3 arcmin
HARMONICS = ((1, 12.0, 0.3), (2, 5.0, 1.1), (3, 2.0, 2.0), (4, 1.5, -0.4), (7, 0.8, 0.9), (16, 0.5, 0.2))
OFFSET_ARCMIN = 3.0
NOISE_ARCMIN = 0.05
#: the same numbers in another harmless form: the corrected angles within this (arc-minutes). The spectral fit's
#: optimiser ends within about 1e-6 arcmin of its optimum, a little differently for rows in another order.
SAME_ARCMIN = 1e-5
#: corrected dense readings against the truth, per method (RMS, max; arc-minutes). A 1:8:1 network of 200 epochs
#: cannot follow the 16th harmonic (0.23 arcmin RMS); a lookup table interpolates between 1-degree nodes.
TRUTH = {"auto": (0.05, 0.15), "fourier": (0.05, 0.15), "spectral": (0.05, 0.15), "lut": (0.06, 0.2),
         "lut cubic": (0.06, 0.2), "hybrid": (0.05, 0.15), "ann": (0.3, 0.8), "stack": (0.05, 0.15)}
METHODS = {
    "auto": ("auto", {}),
    "fourier": ("fourier", {"n_orders": 8}),
    "spectral": ("spectral", {}),
    "lut": ("lut", {}),
    "lut cubic": ("lut", {"interpolation": "cubic"}),
    "hybrid": ("hybrid", {"rng": 0}),
    "ann": ("ann", {"hidden": 8, "epochs": 200, "rng": 0}),
    "stack": ("stack", {"members": [{"family": "fourier", "options": {"n_orders": 8}},
                                    {"family": "lut", "options": {"interpolation": "cubic"}}],
                        "weights": [0.5, 0.5], "rng": 0}),
}
BIG = 10**6 + 1  # readings in one call: across the chunks of 8192 angles and a table's threshold


def truth_error(reference_deg):
    """The encoder's error at a reference angle, arc-minutes."""
    theta = np.radians(reference_deg)
    return OFFSET_ARCMIN + sum(a * np.sin(k * theta + p) for k, a, p in HARMONICS)


def arcmin_apart(a_deg, b_deg):
    """Largest |a - b| in arc-minutes, angles compared on the circle; inf when the shapes differ."""
    a, b = np.asarray(a_deg, dtype=float), np.asarray(b_deg, dtype=float)
    if a.shape != b.shape:
        return math.inf
    if a.size == 0:
        return 0.0
    return float(np.max(np.abs((a - b + 180.0) % 360.0 - 180.0)) * 60.0)


def largest(a, b):
    """Largest |a - b| of two arrays of the same shape (inf when the shapes differ)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return math.inf if a.shape != b.shape else float(np.max(np.abs(a - b), initial=0.0))


# ------------------------------------------------------------------------------------------------- the data


def grid_calibration(seed=1, step=1.0):
    """(reference, encoder) in degrees: the truth's encoder on a grid, with reading noise."""
    reference = np.arange(0.0, 360.0, step)
    noise = np.random.default_rng(seed).normal(0.0, NOISE_ARCMIN, reference.size)
    return reference, reference + (truth_error(reference) + noise) / 60.0


REFERENCE, ENCODER = grid_calibration()
TEST_REFERENCE = np.random.default_rng(2).uniform(0.0, 360.0, 4001)
TEST_ENCODER = TEST_REFERENCE + truth_error(TEST_REFERENCE) / 60.0  # noise-free readings
RANDOM_REFERENCE = np.random.default_rng(3).uniform(0.0, 360.0, 720)  # a calibration at random angles
RANDOM_ENCODER = RANDOM_REFERENCE + (truth_error(RANDOM_REFERENCE)
                                     + np.random.default_rng(4).normal(0.0, NOISE_ARCMIN, 720)) / 60.0


def read_only(values):
    values = np.array(values)
    values.flags.writeable = False
    return values


def strided(values):
    """The same values as every other element of an array twice the size."""
    values = np.asarray(values)
    double = np.empty(2 * values.size, dtype=values.dtype)
    double[::2], double[1::2] = values, -1.0
    return double[::2]


def written_and_read(reference, encoder, folder, comments=()):
    path = Path(folder) / "cal.csv"
    encal.write_calibration(path, encal.Calibration(reference, encoder), comments=comments)
    return encal.read_calibration(path)


ORDER = np.random.default_rng(5).permutation(REFERENCE.size)
#: harmless forms of one calibration: name -> a function of a temporary folder giving the Calibration
CALIBRATIONS = {
    "arrays (the plain form)": lambda _: encal.Calibration(REFERENCE, ENCODER),
    "lists": lambda _: encal.Calibration(REFERENCE.tolist(), ENCODER.tolist()),
    "read-only arrays": lambda _: encal.Calibration(read_only(REFERENCE), read_only(ENCODER)),
    "strided arrays": lambda _: encal.Calibration(strided(REFERENCE), strided(ENCODER)),
    "angles in (-180, 180]": lambda _: encal.Calibration(encal.wrap180(REFERENCE), encal.wrap180(ENCODER)),
    "angles 2 turns up": lambda _: encal.Calibration(REFERENCE + 720.0, ENCODER + 720.0),
    "angles 3 turns down": lambda _: encal.Calibration(REFERENCE - 1080.0, ENCODER - 1080.0),
    "rows shuffled": lambda _: encal.Calibration(REFERENCE[ORDER], ENCODER[ORDER]),
    "rows reversed": lambda _: encal.Calibration(REFERENCE[::-1], ENCODER[::-1]),
    "written and read back": lambda folder: written_and_read(REFERENCE, ENCODER, folder),
    "written with a comment of two lines": lambda folder: written_and_read(REFERENCE, ENCODER, folder,
                                                                          ["bench 3\nrun 2"]),
    "subset of all of it": lambda _: encal.Calibration(REFERENCE, ENCODER).subset(np.ones(REFERENCE.size, bool)),
    "float32 arrays": lambda _: encal.Calibration(REFERENCE.astype(np.float32), ENCODER.astype(np.float32)),
}


# ------------------------------------------------------------------------------------------------- the cases


@dataclass
class Case:
    group: str
    name: str
    run: object  # a function of a temporary folder -> (difference, limit, note)


def _fit(cal, label):
    method, options = METHODS[label]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a stack's members may warn of their own limits; not the question here
        return encal.fit(cal, method, **options)


_PLAIN = {}


def plain_correction(label):
    """The plain form's corrected test readings for a method (computed once)."""
    if label not in _PLAIN:
        _PLAIN[label] = _fit(encal.Calibration(REFERENCE, ENCODER), label).correct(TEST_ENCODER)
    return _PLAIN[label]


def truth_of(corrected_deg):
    """(RMS, max) in arc-minutes of corrected test readings against their reference angles."""
    delta = ((corrected_deg - TEST_REFERENCE + 180.0) % 360.0 - 180.0) * 60.0
    return float(np.sqrt(np.mean(delta**2))), float(np.max(np.abs(delta)))


def truth_case(label, reference, encoder, where):
    def run(_):
        rms, peak = truth_of(_fit(encal.Calibration(reference, encoder), label).correct(TEST_ENCODER))
        limit_rms, limit_max = TRUTH[label]
        ok = rms <= limit_rms and peak <= limit_max
        return (rms if ok else math.inf), limit_rms, f"truth: RMS {rms:.3g}, max {peak:.3g} arcmin ({where})"
    return Case("fit: truth", f"{label} on {where}", run)


def form_case(label, form):
    def run(folder):
        corrected = _fit(CALIBRATIONS[form](folder), label).correct(TEST_ENCODER)
        apart = arcmin_apart(corrected, plain_correction(label))
        if "float32" not in form:
            return apart, SAME_ARCMIN, "to the plain form's corrected angles"
        # float32 moves each angle by up to 0.0009 arcmin: a randomised fit's optimiser may end elsewhere (hybrid:
        # 0.07 arcmin away, as near the truth), so its measure is the truth, the plain form's distance a note
        rms, peak = truth_of(corrected)
        limit_rms, limit_max = TRUTH[label]
        return ((rms if peak <= limit_max else math.inf), limit_rms,
                f"truth: RMS {rms:.3g}, max {peak:.3g} arcmin; {apart:.2g} arcmin from the plain form's")
    return Case("fit: float32 calibration, truth" if "float32" in form else "fit: calibration form", f"{label}, {form}",
                run)


_MODELS = {}


def model(label="auto"):
    if label not in _MODELS:
        _MODELS[label] = _fit(encal.Calibration(REFERENCE, ENCODER), label)
    return _MODELS[label]


def fortran(values):
    return np.asfortranarray(np.asarray(values).reshape(3, -1))


READINGS = TEST_ENCODER[:3000]
#: harmless forms of readings: name -> (the readings, the same readings as a float64 array of the expected shape)
INPUTS = {
    "python float": (float(READINGS[7]), np.float64(READINGS[7])),
    "0-d array": (np.array(READINGS[7]), np.float64(READINGS[7])),
    "numpy float32 scalar": (np.float32(READINGS[7]), np.float64(np.float32(READINGS[7]))),
    "python int": (123, np.float64(123.0)),
    "list of floats": (READINGS.tolist(), READINGS),
    "int array (whole degrees)": (np.arange(-720, 720), np.arange(-720, 720, dtype=float)),
    "float32 array": (READINGS.astype(np.float32), READINGS.astype(np.float32).astype(float)),
    "2-D C order": (READINGS.reshape(3, -1), READINGS.reshape(3, -1)),
    "2-D Fortran order": (fortran(READINGS), READINGS.reshape(3, -1)),
    "strided": (strided(READINGS), READINGS),
    "read-only": (read_only(READINGS), READINGS),
    "(-180, 180]": (encal.wrap180(READINGS), READINGS),
    "5 turns up": (READINGS + 1800.0, READINGS),
    "7 turns down": (READINGS - 2520.0, READINGS),
    "1-element list": ([READINGS[7]], READINGS[7:8]),
    "empty array": (np.array([]), np.array([])),
    "(n, 1) column": (READINGS.reshape(-1, 1), READINGS.reshape(-1, 1)),
}
# turns away or in (-180, 180]: the readings plus k * 360 round to other doubles; the model's input is wrapped first,
# so the corrected angle moves by the rounding of the sum (1800 deg: 2.3e-13 deg)
TURNS_ARCMIN = 1e-9


def input_case(label, form, how):
    def run(_):
        given, expected = INPUTS[form]
        before = np.array(given, copy=True) if isinstance(given, np.ndarray) else None
        m = model(label)
        calls = {
            "predict": lambda x: m.predict(x),
            "correct": lambda x: m.correct(x),
            "Compensator.correct": lambda x: encal.Compensator(m).correct(x),
            "Compensator.predict": lambda x: encal.Compensator(m).predict(x),
        }
        first, second = calls[how](given), calls[how](given)
        wanted = calls[how](np.asarray(expected, dtype=float))
        difference = (arcmin_apart if "correct" in how else largest)(first, wanted)
        notes = []
        if np.shape(first) != np.shape(expected):
            notes.append(f"shape {np.shape(first)}, expected {np.shape(expected)}")
            difference = math.inf
        if np.ndim(expected) == 0 and not np.isscalar(first) and not isinstance(first, np.floating):
            notes.append(f"a {type(first).__name__} for a scalar")
            difference = math.inf
        if largest(first, second) > 0:
            notes.append("a second call differs")
            difference = math.inf
        if before is not None and not np.array_equal(before, given):
            notes.append("the input was modified")
            difference = math.inf
        limit = TURNS_ARCMIN if "turns" in form or "180" in form else 0.0
        return difference, limit, "; ".join(notes) or f"to float64 {np.shape(expected)} readings"
    return Case(f"inputs: {how}", f"{label}, {form}", run)


def big_case(label, how):
    def run(_):
        readings = np.random.default_rng(6).uniform(-720.0, 720.0, BIG)
        m = model(label)
        if how == "correct, 10**6 + 1 readings":
            whole = m.correct(readings)
            pieces = np.concatenate([m.correct(piece) for piece in np.array_split(readings, 977)])
            return arcmin_apart(whole, pieces), 0.0, "to the same readings in 977 calls"
        if how == "predict, 10**6 + 1 readings":
            whole = m.predict(readings)
            pieces = np.concatenate([m.predict(piece) for piece in np.array_split(readings, 977)])
            return largest(whole, pieces), 0.0, "to the same readings in 977 calls"
        from encal.models._table import TABLE_TOLERANCE_ARCMIN

        return (arcmin_apart(m.correct(readings, table=True), m.correct(readings)), TABLE_TOLERANCE_ARCMIN,
                "table=True to the formula (its documented tolerance)")
    return Case("inputs: large arrays", f"{label}, {how}", run)


def file_case(label, how):
    def run(folder):
        m = model(label)
        path = Path(folder) / f"{label.replace(' ', '_')}.json"
        m.save(path)
        plain = m.correct(TEST_ENCODER)
        if how == "load_model":
            return arcmin_apart(encal.load_model(path).correct(TEST_ENCODER), plain), 0.0, "loaded to in memory"
        if how == "Compensator(path)":
            return arcmin_apart(encal.Compensator(path).correct(TEST_ENCODER), plain), 0.0, "file to in memory"
        if how == "runtime.load":
            loaded = runtime.load(path)
            corrected = [loaded.correct_deg(float(theta)) for theta in TEST_ENCODER[:500]]
            return arcmin_apart(corrected, plain[:500]), 1e-9, "standalone runtime, one reading a call"
        if how == "export_c: in memory, loaded, path":
            from encal.deploy import export_c

            def code(source):  # the header names the model file's checksum, which a model in memory has not
                return {name: [line for line in text.splitlines() if "sha256" not in line]
                        for name, text in export_c(source, bits=14).items()}

            same = code(m) == code(encal.load_model(path)) == code(str(path))
            return (0.0 if same else math.inf), 0.0, "the C files' text, but for the checksum line"
        # compile_table: a 14-bit table against the formula at the codes, within half its int16 unit (rounding)
        from encal.deploy import compile_table

        table = compile_table(m, 14)
        codes = np.arange(2**14) * 360.0 / 2**14
        error = table.values.astype(float) * table.scale_arcmin
        apart = largest(error, m.predict(codes))
        return (apart if apart <= table.quantisation_arcmin else math.inf), table.scale_arcmin / 2, (
            f"table at the codes to predict(), within half its unit and its stated {table.quantisation_arcmin:.3g}")
    return Case("model file", f"{label}, {how}", run)


def analysis_cases():
    cal = encal.Calibration(REFERENCE, ENCODER)
    test = encal.Calibration(TEST_REFERENCE, TEST_ENCODER)
    errors = cal.errors_arcmin

    def stats(s):
        return np.array([s.n, s.mae, s.rms, s.std, s.min, s.max, s.pp])

    def amplitudes(h):
        return np.asarray(h.amplitude_arcmin)[:40]

    def evaluation(e):
        return np.concatenate([stats(e.before), stats(e.after)])

    def case(name, value, reference, limit=1e-9, note=""):
        return Case("analysis", name, lambda _: (largest(value(), reference()), limit, note))

    m = model("auto")
    truth_amplitudes = np.zeros(40)
    truth_amplitudes[0] = OFFSET_ARCMIN
    for k, a, _ in HARMONICS:
        truth_amplitudes[k] = a
    return [
        case("error_stats: Calibration, errors array, list", lambda: [stats(encal.error_stats(errors)),
                                                                       stats(encal.error_stats(errors.tolist()))],
             lambda: [stats(encal.error_stats(cal))] * 2),
        case("error_stats: rows shuffled", lambda: stats(encal.error_stats(errors[ORDER])),
             lambda: stats(encal.error_stats(errors))),
        case("harmonics: against the truth's amplitudes", lambda: amplitudes(encal.harmonics(REFERENCE, errors)),
             lambda: truth_amplitudes, 0.02, "noise 0.05 arcmin on 360 points"),
        case("harmonics: lists, shuffled, 2 turns up", lambda: amplitudes(encal.harmonics(
            (REFERENCE[ORDER] + 720).tolist(), errors[ORDER].tolist())),
            lambda: amplitudes(encal.harmonics(REFERENCE, errors))),
        case("harmonics: random angles, against the truth", lambda: amplitudes(encal.harmonics(
            RANDOM_REFERENCE, encal.Calibration(RANDOM_REFERENCE, RANDOM_ENCODER).errors_arcmin, 39)),
            lambda: truth_amplitudes, 0.03, "720 random angles, noise 0.05 arcmin"),
        case("evaluate: test calibration rows reversed, lists", lambda: evaluation(encal.evaluate(
            m, encal.Calibration(TEST_REFERENCE[::-1].tolist(), TEST_ENCODER[::-1].tolist()))),
            lambda: evaluation(encal.evaluate(m, test)), 1e-9),
        case("evaluate: after against the truth (noise-free test)", lambda: encal.evaluate(m, test).after.rms,
             lambda: 0.0, TRUTH["auto"][0]),
        case("evaluate: loaded model", lambda: evaluation(encal.evaluate(_saved_and_loaded(m), test)),
             lambda: evaluation(encal.evaluate(m, test))),
    ]


def _saved_and_loaded(m):
    with tempfile.TemporaryDirectory() as folder:
        m.save(Path(folder) / "m.json")
        return encal.load_model(Path(folder) / "m.json")


_PRIOR = []


def the_prior():
    """A fleet prior of 6 units, the truth's error scaled by 0.8 to 1.3 (made once)."""
    from encal.fleet.prior import fleet_prior

    if not _PRIOR:
        units = [encal.fit(encal.Calibration(REFERENCE, REFERENCE + (truth_error(REFERENCE) * scale) / 60.0),
                           "fourier", n_orders=8) for scale in (0.8, 0.9, 1.0, 1.1, 1.2, 1.3)]
        _PRIOR.append(fleet_prior(units))
    return _PRIOR[0]


def with_prior(form):
    """``fit_with_prior`` on a quarter turn of the truth's encoder, its prediction at the test readings."""
    from encal.fleet.prior import fit_with_prior

    cal = encal.Calibration(REFERENCE, ENCODER)
    keep = np.flatnonzero(REFERENCE < 90.0)
    if form == "lists":
        keep = keep[::-1]
        theta, error = cal.encoder_deg[keep].tolist(), cal.errors_arcmin[keep].tolist()
    else:
        theta, error = cal.encoder_deg[keep], cal.errors_arcmin[keep]
    return fit_with_prior(theta, error, the_prior()).predict(TEST_ENCODER[:500])


def simulate_cases():
    def floors():
        fleet = encal.demo_fleet(2)
        return [encal.measurement_floor(run.test) for run in fleet] + [
            float(fleet[0].train.calibration.errors_arcmin.sum())]

    def simulated():
        fleet = encal.simulate_fleet(2, seed=3)
        return [float(run.train.calibration.errors_arcmin.sum()) for run in fleet]

    def steps(order):
        from encal.selfcal import steps as steps_method

        reference = np.arange(200) * 1.8
        # a 1.8-degree stepper's full steps read by the truth's encoder (its own error left out: known truth)
        encoder = reference + truth_error(reference) / 60.0
        result = steps_method(encal.Calibration(reference[order], encoder[order]), max_order=16)
        return result.error_arcmin(TEST_ENCODER[:500])

    def swept(form):
        from encal.selfcal import sweep

        # an ideal 7-pole-pair motor swept up and down once; the encoder reads the truth's error
        up = np.linspace(0.0, 360.0 * 7, 3001)[:-1]
        phase, travel = np.r_[up, up[::-1]], np.r_[np.ones(up.size), -np.ones(up.size)]
        encoder = phase / 7 + truth_error(phase / 7) / 60.0
        given = {"arrays": (phase, encoder, travel), "lists": (phase.tolist(), encoder.tolist(), travel.tolist()),
                 "wrapped": (phase % 360.0, encoder % 360.0, travel),
                 "turns away": (phase - 720.0, encoder + 360.0, travel)}[form]
        return sweep(*given, 7).error_arcmin(TEST_ENCODER[:500])

    # the orders a sweep cannot see (the pole pairs' multiples: order 7 of the truth) and the constant left out
    swept_truth = truth_error(TEST_REFERENCE[:500]) - OFFSET_ARCMIN - 0.8 * np.sin(7 * np.radians(TEST_REFERENCE[:500])
                                                                                  + 0.9)
    plain_order = np.arange(200)
    shuffled = np.random.default_rng(7).permutation(200)
    truth = truth_error(TEST_REFERENCE[:500]) - OFFSET_ARCMIN  # the constant is not the steps method's
    return [
        Case("simulate / selfcal", "demo_fleet twice", lambda _: (largest(floors(), floors()), 0.0, "")),
        Case("simulate / selfcal", "simulate_fleet(seed=3) twice", lambda _: (largest(simulated(), simulated()), 0.0,
                                                                              "")),
        Case("simulate / selfcal", "selfcal.steps, rows shuffled", lambda _: (
            largest(steps(shuffled), steps(plain_order)), 1e-9, "to the rows in order")),
        Case("simulate / selfcal", "selfcal.sweep against the truth", lambda _: (
            largest(swept("arrays"), swept_truth), 0.02, "the truth less its constant and order 7, noise-free")),
        *[Case("simulate / selfcal", f"selfcal.sweep, {form}", lambda _, f=form: (
            largest(swept(f), swept("arrays")), 1e-9, "to the arrays'"))
          for form in ("lists", "wrapped", "turns away")],
        Case("simulate / selfcal", "fit_with_prior: lists, rows shuffled", lambda _: (
            largest(with_prior("lists"), with_prior("arrays")), 1e-9, "a quarter turn under a prior of 6 units")),
        Case("simulate / selfcal", "selfcal.steps against the truth", lambda _: (
            largest(steps(plain_order), truth), 0.05, "the truth less its constant, 200 noise-free steps")),
    ]


REVERSAL_ARCMIN = 1.2  # the encoder reads this much more going forward than going back
BIDIRECTIONAL_REFERENCE = np.concatenate([REFERENCE, REFERENCE[::-1]])
BIDIRECTIONAL_DIRECTION = np.repeat([1, -1], REFERENCE.size)
BIDIRECTIONAL_ENCODER = BIDIRECTIONAL_REFERENCE + (
    truth_error(BIDIRECTIONAL_REFERENCE) + BIDIRECTIONAL_DIRECTION * REVERSAL_ARCMIN / 2
    + np.random.default_rng(8).normal(0.0, NOISE_ARCMIN, BIDIRECTIONAL_REFERENCE.size)) / 60.0
TEST_DIRECTION = np.where(np.arange(TEST_REFERENCE.size) % 2 == 0, 1, -1)
TEST_DIRECTIONAL_ENCODER = TEST_ENCODER + TEST_DIRECTION * REVERSAL_ARCMIN / 2 / 60.0
BIDIRECTIONAL_ORDER = np.random.default_rng(9).permutation(BIDIRECTIONAL_REFERENCE.size)
#: a bidirectional calibration in harmless forms (its direction column too)
BIDIRECTIONAL_FORMS = {
    "arrays": lambda: encal.Calibration(BIDIRECTIONAL_REFERENCE, BIDIRECTIONAL_ENCODER,
                                        direction=BIDIRECTIONAL_DIRECTION),
    "rows shuffled": lambda: encal.Calibration(BIDIRECTIONAL_REFERENCE[BIDIRECTIONAL_ORDER],
                                               BIDIRECTIONAL_ENCODER[BIDIRECTIONAL_ORDER],
                                               direction=BIDIRECTIONAL_DIRECTION[BIDIRECTIONAL_ORDER]),
    "direction as a list": lambda: encal.Calibration(BIDIRECTIONAL_REFERENCE, BIDIRECTIONAL_ENCODER,
                                                     direction=BIDIRECTIONAL_DIRECTION.tolist()),
    "direction as floats +-1.0": lambda: encal.Calibration(BIDIRECTIONAL_REFERENCE, BIDIRECTIONAL_ENCODER,
                                                           direction=BIDIRECTIONAL_DIRECTION.astype(float)),
}
#: the test readings' directions in harmless forms
DIRECTIONS = {
    "int array": TEST_DIRECTION,
    "list": TEST_DIRECTION.tolist(),
    "int8 array": TEST_DIRECTION.astype(np.int8),
    "floats +-1.0": TEST_DIRECTION.astype(float),
    "read-only": read_only(TEST_DIRECTION),
}


def directional_cases():
    def fitted(form, method):
        return encal.fit(BIDIRECTIONAL_FORMS[form](), method, **({"n_orders": 8} if method == "fourier" else {}))

    def plain(method):
        return fitted("arrays", method).correct(TEST_DIRECTIONAL_ENCODER, direction=TEST_DIRECTION)

    def truth(method):
        rms, peak = truth_of(plain(method))
        return (rms if peak <= TRUTH[method][1] else math.inf), TRUTH[method][0], (
            f"truth: RMS {rms:.3g}, max {peak:.3g} arcmin, each reading its direction")

    def form(method, name):
        corrected = fitted(name, method).correct(TEST_DIRECTIONAL_ENCODER, direction=TEST_DIRECTION)
        return arcmin_apart(corrected, plain(method)), SAME_ARCMIN, "to the plain form's corrected angles"

    def direction(name, how):
        m = fitted("arrays", "lut")
        given = DIRECTIONS[name]
        if how == "Compensator":
            corrected = encal.Compensator(m).correct(TEST_DIRECTIONAL_ENCODER, direction=given)
        else:
            corrected = m.correct(TEST_DIRECTIONAL_ENCODER, direction=given)
        return arcmin_apart(corrected, plain("lut")), 0.0, "to the int array's"

    found = [Case("directional", f"{method}: truth", lambda _, m=method: truth(m)) for method in ("fourier", "lut")]
    found += [Case("directional", f"fourier: calibration {name}", lambda _, n=name: form("fourier", n))
              for name in BIDIRECTIONAL_FORMS if name != "arrays"]
    found += [Case("directional", f"lut: direction {name} ({how})", lambda _, n=name, h=how: direction(n, h))
              for name in DIRECTIONS for how in ("correct", "Compensator")]
    return found


ARC_REFERENCE = np.arange(-60.0, 60.5, 1.0)  # a joint of limited travel: an arc of 120 degrees across the zero
ARC_ENCODER = ARC_REFERENCE + (truth_error(ARC_REFERENCE)
                               + np.random.default_rng(10).normal(0.0, NOISE_ARCMIN, ARC_REFERENCE.size)) / 60.0
ARC_ORDER = np.random.default_rng(11).permutation(ARC_REFERENCE.size)
ARC_FORMS = {
    "(-180, 180]": lambda: (ARC_REFERENCE, ARC_ENCODER),
    "[0, 360)": lambda: (ARC_REFERENCE % 360.0, ARC_ENCODER % 360.0),
    "rows shuffled": lambda: (ARC_REFERENCE[ARC_ORDER], ARC_ENCODER[ARC_ORDER]),
    "lists": lambda: (ARC_REFERENCE.tolist(), ARC_ENCODER.tolist()),
    "2 turns up": lambda: (ARC_REFERENCE + 720.0, ARC_ENCODER + 720.0),
}
#: test readings well inside the arc, and well outside it (NaN there: never a number where it was not calibrated)
ARC_INSIDE = (TEST_REFERENCE < 55.0) | (TEST_REFERENCE > 305.0)
ARC_OUTSIDE = (TEST_REFERENCE > 65.0) & (TEST_REFERENCE < 295.0)


def arc_cases():
    def corrected(form, method):
        return encal.fit(encal.Calibration(*ARC_FORMS[form]()), method).correct(TEST_ENCODER)

    def truth(method):
        answer = corrected("(-180, 180]", method)
        delta = ((answer[ARC_INSIDE] - TEST_REFERENCE[ARC_INSIDE] + 180.0) % 360.0 - 180.0) * 60.0
        rms, peak = float(np.sqrt(np.mean(delta**2))), float(np.max(np.abs(delta)))
        nan_outside = bool(np.all(np.isnan(answer[ARC_OUTSIDE])))
        ok = peak <= TRUTH[method][1] and nan_outside
        return (rms if ok else math.inf), TRUTH[method][0], (
            f"truth inside the arc: RMS {rms:.3g}, max {peak:.3g} arcmin; NaN outside: {nan_outside}")

    def form(name):
        answer, plain = corrected(name, "auto"), corrected("(-180, 180]", "auto")
        if not np.array_equal(np.isnan(answer), np.isnan(plain)):
            return math.inf, SAME_ARCMIN, "NaN at other readings"
        keep = ~np.isnan(plain)
        return arcmin_apart(answer[keep], plain[keep]), SAME_ARCMIN, "to the (-180, 180] form's corrected angles"

    return [Case("arc", f"{method}: truth", lambda _, m=method: truth(m)) for method in ("auto", "lut")] + [
        Case("arc", f"auto: {name}", lambda _, n=name: form(n)) for name in ARC_FORMS if name != "(-180, 180]"]


LSB_DEG = 360.0 / 2**14  # a 14-bit encoder: its readings are whole codes
CODES_ENCODER = np.round(ENCODER / LSB_DEG) * LSB_DEG
CODES_TEST = np.round(TEST_ENCODER / LSB_DEG) * LSB_DEG
#: 14-bit codes as degrees in harmless forms (float32 holds them exactly: 14 bits times 45 * 2**-11)
CODES_FORMS = {
    "arrays": lambda: (REFERENCE, CODES_ENCODER),
    "float32": lambda: (REFERENCE.astype(np.float32), CODES_ENCODER.astype(np.float32)),
    "lists": lambda: (REFERENCE.tolist(), CODES_ENCODER.tolist()),
    "(-180, 180]": lambda: (encal.wrap180(REFERENCE), encal.wrap180(CODES_ENCODER)),
    "2 turns up": lambda: (REFERENCE + 720.0, CODES_ENCODER + 720.0),
}
#: the corrected quantised readings against the truth: the quantisation of the test readings, LSB / sqrt(12) RMS,
#: a tenth more for the fit, and 1 LSB at most
CODES_TRUTH = (1.1 * LSB_DEG * 60.0 / math.sqrt(12.0), LSB_DEG * 60.0)


def codes_cases():
    def fitted(form):
        return encal.fit(encal.Calibration(*CODES_FORMS[form]()), "auto")

    def truth(_):
        m = fitted("arrays")
        rms, peak = truth_of(m.correct(CODES_TEST))
        ok = peak <= CODES_TRUTH[1] and m.encoder["resolution_bits"] == 14
        return (rms if ok else math.inf), CODES_TRUTH[0], (
            f"truth: RMS {rms:.3g}, max {peak:.3g} arcmin; resolution recorded {m.encoder['resolution_bits']} bits")

    def form(name):
        m = fitted(name)
        apart = arcmin_apart(m.correct(CODES_TEST), fitted("arrays").correct(CODES_TEST))
        bits = m.encoder["resolution_bits"]
        return (apart if bits == 14 else math.inf), SAME_ARCMIN, f"to the arrays'; resolution recorded {bits} bits"

    return [Case("14-bit codes", "auto: truth", truth)] + [
        Case("14-bit codes", f"auto: {name}", lambda _, n=name: form(n)) for name in CODES_FORMS if name != "arrays"]


def uncertainty_cases():
    def stds(reference, encoder, readings):
        m = encal.fit(encal.Calibration(reference, encoder), "fourier", n_orders=8, uncertainty=True, rng=0)
        return m.predict(readings, return_std=True)[1]

    plain = lambda: stds(REFERENCE, ENCODER, READINGS)  # noqa: E731
    return [
        Case("uncertainty", "fourier uncertainty=True, rng=0: from lists, twice", lambda _: (
            max(largest(stds(REFERENCE.tolist(), ENCODER.tolist(), READINGS), plain()),
                largest(plain(), plain())), 0.0, "predict(return_std=True)'s std to the arrays'")),
        Case("uncertainty", "spectral return_std: 2-D Fortran readings keep their shape", lambda _: (
            largest(model("spectral").predict(fortran(READINGS), return_std=True)[1],
                    model("spectral").predict(READINGS, return_std=True)[1].reshape(3, -1)), 0.0,
            "std of (3, 1000) Fortran readings to the 1-D readings' reshaped")),
    ]


def threads_case():
    """``fit`` in a process with no BLAS thread variable set against this one's (pinned by the caller)."""
    code = ("import sys, numpy as np; sys.path.insert(0, sys.argv[1]); sys.path.insert(0, sys.argv[2]);"
            "import api_variants as v, encal;"
            "m = encal.fit(encal.Calibration(v.REFERENCE, v.ENCODER), 'auto');"
            "print(repr(float(np.sum(m.correct(v.TEST_ENCODER) * np.arange(v.TEST_ENCODER.size)))))")

    def run(_):
        env = {key: value for key, value in os.environ.items()
               if not key.endswith("_NUM_THREADS") and key not in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}
        out = subprocess.run([sys.executable, "-c", code, str(ROOT / "src"), str(Path(__file__).parent)], env=env,
                             capture_output=True, text=True, check=True).stdout
        here = float(np.sum(model("auto").correct(TEST_ENCODER) * np.arange(TEST_ENCODER.size)))
        return abs(float(out) - here), 0.0, "weighted sum of corrected angles, degrees"
    return Case("threads", "auto fit, no thread variables set vs this process", run)


# ------------------------------------------------------------------------------------------------- the store (storeapi)
# ``encal.store`` from Python: a unit's model and calibration written by serial number, read back, listed; epochs,
# drift and grades; the batch ``encal.fleet.batch.fit_batch`` from Python. Known truth: the stored model corrects the
# noise-free test readings exactly as the model in memory does (0 difference), and so to their reference angles.

_SCRATCH = []


def scratch():
    """A folder for the harmful calls (they take no folder), removed when the process ends."""
    if not _SCRATCH:
        _SCRATCH.append(tempfile.TemporaryDirectory())
    return Path(_SCRATCH[0].name)


def _store():
    import encal.store as module

    return module


def model_text(m):
    from encal.models.modelfile import dumps, model_to_dict

    return dumps(model_to_dict(m))


CALIBRATION_CSV = "reference_deg,encoder_deg\n" + "".join(f"{float(r)!r},{float(e)!r}\n"
                                                           for r, e in zip(REFERENCE, ENCODER))


def _fresh(folder, name):
    """The path of a store not written yet in ``folder``."""
    path = Path(folder) / f"{name}.sqlite"
    for suffix in ("", "-wal", "-shm"):
        Path(f"{path}{suffix}").unlink(missing_ok=True)
    return path


#: harmless ways to write the unit and read it back: name -> (store location form, model form, serial written,
#: serial read). Each must give the model in memory's corrected readings exactly.
STORE_FORMS = {
    "store path as str, model as its text": ("str", "text", "SN0042", "SN0042"),
    "store path as Path": ("Path", "text", "SN0042", "SN0042"),
    "model as its saved file's text": ("str", "file text", "SN0042", "SN0042"),
    "model as a Model object": ("str", "object", "SN0042", "SN0042"),
    "serial with spaces inside and around, read without those around": ("str", "text", "  SN 0042 ", "SN 0042"),
    "serial decomposed (NFD, from a Mac), read composed": ("str", "text", "SN-Mu\u0308ller", "SN-M\u00fcller"),
    "serial in Greek and CJK": ("str", "text", "\u03a3\u039d-\u4e03", "\u03a3\u039d-\u4e03"),
    "serial with quotes, ; and %": ("str", "text", "SN'7\";%_", "SN'7\";%_"),
    "store closed and opened again": ("reopen", "text", "SN0042", "SN0042"),
    "read through history()[-1]": ("history", "text", "SN0042", "SN0042"),
    "read through latest_records()": ("latest_records", "text", "SN0042", "SN0042"),
}


def store_form_case(name):
    where, form, written, read = STORE_FORMS[name]

    def run(folder):
        m = model("auto")
        path = _fresh(folder, "forms")
        if form == "file text":
            saved = Path(folder) / "stored_model.json"
            m.save(saved)
            given = saved.read_text(encoding="utf-8")
        else:
            given = m if form == "object" else model_text(m)
        with _store().open_store(path if where == "Path" else str(path)) as store:
            store.add(written, given, calibration_csv=CALIBRATION_CSV, source_name="cal.csv")
            if where == "reopen":
                store.close()
                store = _store().open_store(str(path))
            if where == "history":
                record = store.history(read)[-1]
            elif where == "latest_records":
                record = store.latest_records()[0]
            else:
                record = store.latest(read)
            serials, count = store.serials(), store.count()
        if record is None or serials != [read] or count != 1 or record.serial != read or record.epoch != 1:
            return math.inf, 0.0, f"serials {serials}, {count} records; read {read!r}: {record and record.serial!r}"
        if record.calibration_csv != CALIBRATION_CSV:
            return math.inf, 0.0, "the calibration's text was not stored as given"
        corrected = record.model().correct(TEST_ENCODER)
        rms, peak = truth_of(corrected)
        return arcmin_apart(corrected, m.correct(TEST_ENCODER)), 0.0, (
            f"stored model to the one in memory; truth RMS {rms:.3g}, max {peak:.3g} arcmin")
    return Case("store: write and read back", name, run)


def store_epoch_cases():
    def twice(folder):
        first, second = model("auto"), model("fourier")
        with _store().open_store(_fresh(folder, "epochs")) as store:
            a = store.add("SN1", model_text(first), calibration_csv=CALIBRATION_CSV)
            b = store.add("SN1", model_text(second), calibration_csv=CALIBRATION_CSV + "# again\n")
            history, latest = store.history("SN1"), store.latest("SN1")
            ok = ((a.epoch, b.epoch) == (1, 2) and [r.epoch for r in history] == [1, 2] and latest.epoch == 2
                  and store.count() == 2 and store.serials() == ["SN1"])
            apart = max(arcmin_apart(latest.model().correct(TEST_ENCODER), second.correct(TEST_ENCODER)),
                        arcmin_apart(history[0].model().correct(TEST_ENCODER), first.correct(TEST_ENCODER)))
        return (apart if ok else math.inf), 0.0, "epochs 1, 2; latest the second; each epoch's model as written"

    def same_bytes(folder):
        text = model_text(model("auto"))
        with _store().open_store(_fresh(folder, "same")) as store:
            store.add("SN1", text, calibration_csv=CALIBRATION_CSV)
            again = store.add("SN1", text, calibration_csv=CALIBRATION_CSV)
            skipped = store.add_many([{"serial": "SN1", "model_json": text, "calibration_csv": CALIBRATION_CSV}],
                                     skip_stored=True)
            ok = again.epoch == 2 and skipped == [None] and store.count() == 2
        return (0.0 if ok else math.inf), 0.0, ("the same calibration again: add() a new epoch (2), "
                                                "add_many(skip_stored=True) skips it")

    def three_units(folder):
        text = model_text(model("auto"))
        with _store().open_store(_fresh(folder, "three")) as store:
            for serial in ("sn1", "SN1", "SN001"):
                store.add(serial, text)
            ok = store.serials() == ["SN001", "SN1", "sn1"] and all(len(store.history(s)) == 1
                                                                   for s in ("sn1", "SN1", "SN001"))
            ok = ok and store.latest("Sn1") is None and store.history("SN2") == []
        return (0.0 if ok else math.inf), 0.0, "case and leading zeros count; an unknown serial: None and []"

    return [Case("store: epochs", "the same unit written twice: epochs 1 and 2", twice),
            Case("store: epochs", "the same calibration twice under one serial", same_bytes),
            Case("store: epochs", "sn1, SN1, SN001: three units", three_units)]


#: the drift case's second calibrations: name -> (the change to the encoder's error, arcmin, as a function of the
#: reference angle; the RMS of that change over the turn, arcmin)
DRIFTS = {
    "recalibrated unchanged": (lambda r: 0.0 * r, 0.0),
    "first order grown by 1 arcmin": (lambda r: 1.0 * np.sin(np.radians(r) + 0.5), 1.0 / math.sqrt(2.0)),
}


def drift_case(name):
    change, expected = DRIFTS[name]

    def run(folder):
        from encal.fleet.statistics import DRIFT_MOVED, drift_table

        again = REFERENCE + (truth_error(REFERENCE) + change(REFERENCE)
                             + np.random.default_rng(7).normal(0.0, NOISE_ARCMIN, REFERENCE.size)) / 60.0
        with _store().open_store(_fresh(folder, "drift")) as store:
            store.add("SN1", model_text(model("spectral")))
            store.add("SN1", model_text(_fit(encal.Calibration(REFERENCE, again), "spectral")))
            row, = drift_table(store.records())
        drift, u = row["drift_arcmin"][-1], row["uncertainty_arcmin"]
        verdict = "moved" if expected > 0 else "within"
        ok = row["verdict"] == verdict and row["epochs"] == [1, 2] and (expected == 0 or row["largest_order"] == 1)
        # the measured change is the true one within the noise the verdict weighs it by (3 u)
        return (abs(drift - expected) if ok else math.inf), DRIFT_MOVED * u, (
            f"drift {drift:.3g} arcmin (truth {expected:.3g}), u {u:.3g}; verdict {row['verdict']!r}, "
            f"order {row['largest_order']}")
    return Case("store: drift", name, run)


def grade_cases():
    def limits(_):
        store = _store()
        forms = ["A=0.02,B=0.05", "A=1.2arcmin,B=3arcmin", "A=72arcsec,B=180arcsec", "B=0.05, A=0.02"]
        parsed = [store.parse_grades(text) for text in forms]
        names_ok = all([name for name, _ in p] == ["A", "B"] for p in parsed)
        apart = max(largest([limit for _, limit in p], [1.2, 3.0]) for p in parsed)
        return (apart if names_ok else math.inf), 1e-12, "the thresholds in arcmin, in 4 spellings"

    def graded(_):
        store = _store()
        grades = store.parse_grades("A=0.02,B=0.05")
        got = [store.grade_of(value, grades) for value in (0.5, 1.2, 2.0, 3.0, 3.5)]
        return (0.0 if got == ["A", "A", "B", "B", store.GRADE_NONE] else math.inf), 0.0, f"grades {got}"

    def batch(folder):
        from encal.fleet.batch import fit_batch

        lot = Path(folder) / "lot"
        lot.mkdir(exist_ok=True)
        paths = []
        for serial, seed in (("SN1", 1), ("SN2", 7)):
            reference, encoder = grid_calibration(seed)
            paths.append(lot / f"{serial}.csv")
            encal.write_calibration(paths[-1], encal.Calibration(reference, encoder))
        grades = _store().parse_grades("A=0.02,B=0.05")
        worst, notes = 0.0, []
        with _store().open_store(_fresh(folder, "batch")) as store:
            fit_batch(paths, store, grades=grades, jobs=0)
            fit_batch(paths, store, grades=grades, jobs=0)  # run again: every file stored already, skipped
            if store.count() != 2:
                return math.inf, 0.0, f"{store.count()} records after two runs of one lot of 2"
            for path in paths:
                record = store.latest(path.stem)
                alone = encal.fit(encal.read_calibration(path), "spectral")
                corrected = record.model().correct(TEST_ENCODER)
                worst = max(worst, arcmin_apart(corrected, alone.correct(TEST_ENCODER)))
                rms, peak = truth_of(corrected)
                if (record.grade != _store().grade_of(record.held_out_arcmin, grades) or record.grade != "A"
                        or record.grade_limits() != grades or peak > TRUTH["spectral"][1]):
                    return math.inf, 0.0, f"{path.stem}: grade {record.grade}, truth max {peak:.3g} arcmin"
                notes.append(f"{path.stem} held-out {record.held_out_arcmin:.3g}, truth RMS {rms:.3g}")
        return worst, SAME_ARCMIN, "fit_batch's stored model to encal.fit of the file; " + "; ".join(notes)

    return [Case("store: grades", "parse_grades: degrees, arcmin, arcsec, any order", limits),
            Case("store: grades", "grade_of at and about the limits", graded),
            Case("store: grades", "fit_batch of 2 files (jobs=0, run twice): models, grades, limits", batch)]


def store_cases():
    return ([store_form_case(name) for name in STORE_FORMS] + store_epoch_cases()
            + [drift_case(name) for name in DRIFTS] + grade_cases())


def _store_with_sn1():
    path = scratch() / "refusals.sqlite"
    store = _store().open_store(path)
    if not store.serials():
        store.add("SN1", model_text(model("fourier")), calibration_csv=CALIBRATION_CSV)
    return store


def _other_tables():
    import sqlite3

    path = scratch() / "parts.sqlite"
    with sqlite3.connect(path) as connection:
        connection.execute("CREATE TABLE IF NOT EXISTS parts (id INTEGER)")
    connection.close()
    return path


def _text_file(name, text):
    path = scratch() / name
    path.write_text(text, encoding="utf-8")
    return path


def _tampered_model_text():
    import json

    document = json.loads(model_text(model("fourier")))
    document["parameters"]["cos"][1] += 1.0  # the checksum no longer matches
    return json.dumps(document)


STORE_HARMFUL = {
    "open_store: a folder that does not exist": lambda: _store().open_store("/nonexistent/lot7/encal-store.sqlite"),
    "open_store: a folder": lambda: _store().open_store(scratch()),
    "open_store: a text file": lambda: _store().open_store(_text_file("notes.txt", "not a database\n")),
    "open_store: an SQLite database of other tables": lambda: _store().open_store(_other_tables()),
    "open_store: None": lambda: _store().open_store(None),
    "open_store: a number": lambda: _store().open_store(7),
    "Store.latest_model: a serial not there": lambda: _store_with_sn1().latest_model("SN2"),
    "Store.history: None for a serial": lambda: _store_with_sn1().history(None),
    "Store.add: an empty serial": lambda: _store_with_sn1().add("  ", model_text(model("fourier"))),
    "Store.add: a serial with a line end": lambda: _store_with_sn1().add("SN\n2", model_text(model("fourier"))),
    "Store.add: a serial of 201 characters": lambda: _store_with_sn1().add("S" * 201, model_text(model("fourier"))),
    "Store.add: a number for a serial": lambda: _store_with_sn1().add(42, model_text(model("fourier"))),
    "Store.add: text that is not JSON for a model": lambda: _store_with_sn1().add("SN2", "not a model"),
    "Store.add: JSON that is no model file": lambda: _store_with_sn1().add("SN2", '{"kind": "fourier"}'),
    "Store.add: a model file's path for its text": lambda: _store_with_sn1().add(
        "SN2", str(_text_file("m.json", model_text(model("fourier"))))),
    "Store.add: a model file whose checksum fails": lambda: _store_with_sn1().add("SN2", _tampered_model_text()),
    "Store.add: a calibration CSV for a model": lambda: _store_with_sn1().add("SN2", CALIBRATION_CSV),
    "Store.add: None for a model": lambda: _store_with_sn1().add("SN2", None),
    "Store.add: the same calibration under a second serial": lambda: _store_with_sn1().add(
        "SN2", model_text(model("fourier")), calibration_csv=CALIBRATION_CSV),
    "Store.add: held-out estimate 'x'": lambda: _store_with_sn1().add("SN2", model_text(model("fourier")),
                                                                      held_out_arcmin="x"),
    "Store.add: held-out estimate NaN": lambda: _store_with_sn1().add("SN2", model_text(model("fourier")),
                                                                      held_out_arcmin=np.nan),
    "Store.add: n_points 'many'": lambda: _store_with_sn1().add("SN2", model_text(model("fourier")),
                                                                n_points="many"),
    "Store.add: the calibration as bytes": lambda: _store_with_sn1().add("SN2", model_text(model("fourier")),
                                                                         calibration_csv=b"reference_deg\n"),
    "Store.add_many: a number for a record": lambda: _store_with_sn1().add_many([7]),
    "parse_grades: 'A=fast'": lambda: _store().parse_grades("A=fast"),
    "parse_grades: a limit of -1 degree": lambda: _store().parse_grades("A=-1"),
}


# ------------------------------------------------------------------------------------------------- firmware (storeapi)
# Each firmware exporter of ``encal.deploy.firmware`` and the C export from Python, on the known-truth model fitted to
# 14-bit codes (so the file records its resolution), on the same encoder counting against the reference, and on a
# bidirectional model (tabulated as the mean of its directions, docs/deployment.md). The table is applied by the
# project's own reader of the format (``read_moteus_conf`` etc.: the firmware's rule on its stored values) and must
# give ``Model.correct`` within the round trip the export reports; the same model given as an object, a Compensator,
# a path (str or Path) or with ``bits=14`` given must write the same text.

_FW_MODELS = {}
LSB16_DEG = 360.0 / 2**16


def fw_model(name):
    if name not in _FW_MODELS:
        if name == "14-bit codes":
            made = encal.fit(encal.Calibration(REFERENCE, CODES_ENCODER), "auto")
        elif name == "reversed reading":  # the encoder counts against the reference: its readings are -CODES_ENCODER
            made = encal.fit(encal.Calibration(REFERENCE, CODES_ENCODER, reading_sign=-1, resolution_bits=14), "auto")
        else:
            made = encal.fit(BIDIRECTIONAL_FORMS["arrays"](), "fourier", n_orders=8)
        _FW_MODELS[name] = made
    return _FW_MODELS[name]


def fw_readings(name):
    """(raw readings the firmware sees, degrees, on codes; their reference angles in the reading's sense)."""
    if name == "14-bit codes":
        return CODES_TEST % 360.0, TEST_REFERENCE
    if name == "reversed reading":
        return (-CODES_TEST) % 360.0, -TEST_REFERENCE
    return np.round(TEST_ENCODER / LSB16_DEG) * LSB16_DEG % 360.0, TEST_REFERENCE


def _firmware():
    import encal.deploy.firmware as module

    return module


def fw_export(fmt, source, **options):
    """The text a format writes for ``source`` (the C export's two files joined) and its FirmwareExport or None."""
    fw = _firmware()
    calls = {"moteus": fw.export_moteus, "simplefoc": fw.export_simplefoc, "tinymovr": fw.export_tinymovr,
             "mechaduino": lambda s, **o: fw.export_mechaduino(s, step_zero_deg=0.5, **o),
             "klipper": lambda s, **o: fw.export_klipper(s, step_zero_deg=0.5, step_direction=1, **o)}
    if fmt == "C":
        from encal.deploy import export_c

        files = export_c(source, **options)
        # the header names the model file's checksum, which a model in memory has not
        return "".join(line for name in sorted(files) for line in files[name].splitlines(True)
                       if "sha256" not in line), None
    out = calls[fmt](source, **options)
    return out.text, out


FORMATS = ("moteus", "simplefoc", "tinymovr", "mechaduino", "klipper")


def table_case(fmt, name):
    def run(_):
        fw, m = _firmware(), fw_model(name)
        options = {"bits": 16} if fmt == "tinymovr" and name.startswith("bidirectional") else {}
        text, out = fw_export(fmt, m, **options)
        raw, truth = fw_readings(name)
        sign = m.reading_sign
        wanted = sign * np.asarray(m.correct(raw), dtype=float)  # the corrected angle in the reading's sense
        if fmt in ("moteus", "simplefoc", "tinymovr"):
            reread = {"moteus": fw.read_moteus_conf, "simplefoc": fw.read_simplefoc,
                      "tinymovr": lambda t: fw.read_tinymovr(t, bits=options.get("bits", 14))}[fmt](text)
            applied = raw - (np.asarray(reread.predict(raw)) - out.offset_arcmin) / 60.0
            # the reader interpolates in float64, moteus and SimpleFOC in float32 (1e-5 arcmin of it)
            limit, what = out.max_error_arcmin + 1e-5, "its reported round trip"
        elif fmt == "mechaduino":  # y = lookup[count]: the angle from step 0 in the reading's sense
            lookup = fw.read_c_array(text, "lookup").astype(np.float32).astype(float)
            count = np.rint(raw / (360.0 / 2**14)).astype(np.int64) % 2**14  # the AS5047D's 14-bit counts
            raw = count * (360.0 / 2**14)
            wanted = sign * np.asarray(m.correct(raw), dtype=float)
            applied = lookup[count] + sign * 0.5
            limit, what = out.quantisation_arcmin, "its stated rounding"
        else:  # klipper: the sensor's reading at each full step; the model corrects it to the step's angle
            cal = fw.read_klipper(text)
            readings = cal.reading_sign * np.asarray(cal.encoder_deg)
            raw = readings % 360.0
            wanted = np.asarray(m.correct(raw), dtype=float)
            shift = (wanted - 0.5 - np.asarray(cal.reference_deg) + 180.0) % 360.0 - 180.0
            applied = wanted - (shift - np.round(np.median(shift) / 7.2) * 7.2)  # modulo the driver's 4-step cycle
            truth = None
            # "%.1f" of 16-bit units, times the correction's slope (within 1 %)
            limit, what = 1.01 * 0.05 * 21600.0 / 65536.0, "the list's %.1f rounding"
        apart = arcmin_apart(applied, wanted)
        note = f"{fmt}'s table through encal's reader to Model.correct, within {what}"
        if truth is not None:
            rms = float(np.sqrt(np.mean((((applied - truth + 180.0) % 360.0 - 180.0) * 60.0) ** 2)))
            note += f"; truth RMS {rms:.3g} arcmin"
        if out is not None and out.offset_arcmin and fmt != "simplefoc":
            note += f"; constant left out {out.offset_arcmin:.4g} arcmin (the truth's {-sign * OFFSET_ARCMIN:g})"
        return apart, limit, note
    return Case(f"firmware: {fmt}", f"{name}: the table applied, to Model.correct", run)


#: harmless forms of the model given to an exporter: name -> a function of (model, its saved path)
FW_SOURCES = {
    "Compensator(model)": lambda m, path: encal.Compensator(m),
    "model file path as str": lambda m, path: str(path),
    "model file path as Path": lambda m, path: path,
    "Compensator(path)": lambda m, path: encal.Compensator(path),
    "load_model(path)": lambda m, path: encal.load_model(path),
}


def source_case(fmt, form):
    def run(folder):
        m = fw_model("14-bit codes")
        path = Path(folder) / "codes_model.json"
        if not path.exists():
            m.save(path)
        plain, _ = fw_export(fmt, m, **({"bits": 14} if fmt == "C" else {}))
        if form == "bits=14 given":
            other, _ = fw_export(fmt, m, bits=14)
        else:
            other, _ = fw_export(fmt, FW_SOURCES[form](m, path), **({"bits": 14} if fmt == "C" else {}))
        return (0.0 if other == plain else math.inf), 0.0, "the text written for the model object"
    return Case(f"firmware: {fmt}", f"14-bit codes: {form}", run)


def firmware_cases():
    found = []
    for fmt in FORMATS:
        found += [table_case(fmt, name) for name in ("14-bit codes", "reversed reading",
                                                      "bidirectional (the mean of its directions)")]
    for fmt in FORMATS + ("C",):
        found += [source_case(fmt, form) for form in FW_SOURCES]
        if fmt != "C":
            found.append(source_case(fmt, "bits=14 given"))
    return found


def _arc_model():
    return encal.fit(encal.Calibration(REFERENCE[:90], ENCODER[:90]), "auto")


FIRMWARE_HARMFUL = {
    "export_tinymovr: no bits, none in the model file": lambda: _firmware().export_tinymovr(model("auto")),
    "export_tinymovr: bits=5": lambda: _firmware().export_tinymovr(fw_model("14-bit codes"), bits=5),
    "export_tinymovr: bits=14.5": lambda: _firmware().export_tinymovr(fw_model("14-bit codes"), bits=14.5),
    "export_moteus: bits=7": lambda: _firmware().export_moteus(fw_model("14-bit codes"), bits=7),
    "export_moteus: bits='14'": lambda: _firmware().export_moteus(fw_model("14-bit codes"), bits="14"),
    "export_moteus: sign=0": lambda: _firmware().export_moteus(fw_model("14-bit codes"), sign=0),
    "export_moteus: style='json'": lambda: _firmware().export_moteus(fw_model("14-bit codes"), style="json"),
    "export_simplefoc: bits=True": lambda: _firmware().export_simplefoc(fw_model("14-bit codes"), bits=True),
    "export_simplefoc: firmware_version '2.0'": lambda: _firmware().export_simplefoc(fw_model("14-bit codes"),
                                                                                    firmware_version="2.0"),
    "export_simplefoc: nodes=1": lambda: _firmware().export_simplefoc(fw_model("14-bit codes"), nodes=1),
    "export_mechaduino: bits=12": lambda: _firmware().export_mechaduino(fw_model("14-bit codes"), bits=12,
                                                                        step_zero_deg=0.0),
    "export_mechaduino: no step zero": lambda: _firmware().export_mechaduino(fw_model("14-bit codes")),
    "export_mechaduino: step zero NaN": lambda: _firmware().export_mechaduino(fw_model("14-bit codes"),
                                                                              step_zero_deg=np.nan),
    "export_mechaduino: a 16-bit model without bits=14": lambda: _firmware().export_mechaduino(
        encal.fit(encal.Calibration(REFERENCE, ENCODER, resolution_bits=16), "fourier", n_orders=8),
        step_zero_deg=0.0),
    "export_klipper: no step zero": lambda: _firmware().export_klipper(fw_model("14-bit codes"), step_direction=1),
    "export_klipper: no step direction": lambda: _firmware().export_klipper(fw_model("14-bit codes"),
                                                                            step_zero_deg=0.0),
    "export_klipper: 202 full steps": lambda: _firmware().export_klipper(fw_model("14-bit codes"), full_steps=202,
                                                                         step_zero_deg=0.0, step_direction=1),
    "export_klipper: step direction 0": lambda: _firmware().export_klipper(fw_model("14-bit codes"),
                                                                           step_zero_deg=0.0, step_direction=0),
    "export_moteus: a model of an arc": lambda: _firmware().export_moteus(_arc_model()),
    "export_tinymovr: a model of an arc": lambda: _firmware().export_tinymovr(_arc_model(), bits=14),
    "export_moteus: None for a model": lambda: _firmware().export_moteus(None),
    "export_simplefoc: a model file that does not exist": lambda: _firmware().export_simplefoc("/nonexistent/m.json"),
    "export_tinymovr: a calibration CSV for a model file": lambda: _firmware().export_tinymovr(
        _text_file("cal.csv", CALIBRATION_CSV), bits=14),
    "export_klipper: a calibration for a model": lambda: _firmware().export_klipper(
        encal.Calibration(REFERENCE, ENCODER), step_zero_deg=0.0, step_direction=1),
    "export_c: bits=0": lambda: _deploy().export_c(fw_model("14-bit codes"), bits=0),
    "export_c: prefix '1st'": lambda: _deploy().export_c(fw_model("14-bit codes"), prefix="1st"),
    "export_c: table='int8'": lambda: _deploy().export_c(fw_model("14-bit codes"), table="int8"),
    "read_tinymovr: no bits": lambda: _firmware().read_tinymovr(
        _firmware().export_tinymovr(fw_model("14-bit codes")).text, bits=None),
    "read_moteus_conf: a Klipper list": lambda: _firmware().read_moteus_conf(
        _firmware().export_klipper(fw_model("14-bit codes"), step_zero_deg=0.0, step_direction=1).text),
}


def _deploy():
    import encal.deploy as module

    return module


# ------------------------------------------------------------------------------------------------- refused

def _cal():
    return encal.Calibration(REFERENCE, ENCODER)


#: harmful inputs: name -> a call that must raise an encal error in one sentence
HARMFUL = {
    "Calibration: NaN reference": lambda: encal.Calibration(REFERENCE * np.nan, ENCODER),
    "Calibration: infinite reading": lambda: encal.Calibration(REFERENCE, ENCODER + np.inf),
    "Calibration: lengths differ": lambda: encal.Calibration(REFERENCE, ENCODER[:-1]),
    "Calibration: strings": lambda: encal.Calibration(["0", "1"], ["a", "b"]),
    "Calibration: None": lambda: encal.Calibration(None, None),
    "Calibration: complex angles": lambda: encal.Calibration(REFERENCE + 1j, ENCODER),
    "Calibration: (2, n) against (n, 2)": lambda: encal.Calibration(REFERENCE.reshape(2, -1),
                                                                    ENCODER.reshape(-1, 2)),
    "Calibration: direction 1.7": lambda: encal.Calibration(REFERENCE, ENCODER, direction=np.full(360, 1.7)),
    "Calibration: direction 'cw'": lambda: encal.Calibration(REFERENCE, ENCODER, direction=["cw"] * 360),
    "Calibration: direction True/False": lambda: encal.Calibration(REFERENCE, ENCODER,
                                                                  direction=np.arange(360) % 2 == 0),
    "correct: direction 'cw'": lambda: model().correct([1.0, 2.0], direction="cw"),
    "Calibration.subset: index past the end": lambda: _cal().subset([1000]),
    "Calibration.subset: a mask of another length": lambda: _cal().subset(np.ones(3, bool)),
    "Calibration.subset: a string": lambda: _cal().subset("all"),
    "fit: empty calibration": lambda: encal.fit(encal.Calibration([], [])),
    "fit: radians where degrees are expected": lambda: encal.fit(
        encal.Calibration(np.radians(REFERENCE), np.radians(ENCODER))),
    "fit: unknown method": lambda: encal.fit(_cal(), "fft"),
    "fit: option of another method": lambda: encal.fit(_cal(), "fourier", hidden=8),
    "predict: NaN": lambda: model().predict([1.0, np.nan]),
    "predict: infinity": lambda: model().predict(np.inf),
    "predict: a word": lambda: model().predict("north"),
    "predict: None": lambda: model().predict(None),
    "predict: complex": lambda: model().predict(1 + 2j),
    "predict: ragged list": lambda: model().predict([[1.0, 2.0], [3.0]]),
    "predict: return_std without an uncertainty": lambda: model("fourier").predict(1.0, return_std=True),
    "predict: return_std='no'": lambda: model().predict(1.0, return_std="no"),
    "predict: direction 0": lambda: model().predict(1.0, direction=0),
    "predict: directions of another length": lambda: model().predict([1.0, 2.0, 3.0], direction=[1, -1]),
    "correct: NaN": lambda: model().correct(np.array([np.nan])),
    "correct: table='yes'": lambda: model().correct([1.0], table="yes"),
    "Compensator: NaN": lambda: encal.Compensator(model()).correct(np.nan),
    "Compensator: None": lambda: encal.Compensator(None),
    "load_model: no such file": lambda: encal.load_model("/nonexistent/model.json"),
    "evaluate: arrays for a calibration": lambda: encal.evaluate(model(), (REFERENCE, ENCODER)),
    "evaluate: radians where degrees are expected": lambda: encal.evaluate(
        model(), encal.Calibration(np.radians(REFERENCE), np.radians(ENCODER))),
    "evaluate: empty calibration": lambda: encal.evaluate(model(), encal.Calibration([], [])),
    "error_stats: empty": lambda: encal.error_stats([]),
    "error_stats: NaN": lambda: encal.error_stats([1.0, np.nan]),
    "error_stats: strings": lambda: encal.error_stats(["a", "b"]),
    "error_stats: complex": lambda: encal.error_stats([1 + 1j]),
    "error_stats: ragged": lambda: encal.error_stats([[1.0, 2.0], [3.0]]),
    "harmonics: lengths differ": lambda: encal.harmonics(REFERENCE, ENCODER[:-1]),
    "harmonics: empty": lambda: encal.harmonics([], []),
    "harmonics: NaN": lambda: encal.harmonics(REFERENCE, ENCODER * np.nan),
    "harmonics: strings": lambda: encal.harmonics(["a"], ["b"]),
    "Harmonics(theta): NaN": lambda: encal.harmonics(REFERENCE, ENCODER - REFERENCE)(np.nan),
    "Harmonics(theta): a string": lambda: encal.harmonics(REFERENCE, ENCODER - REFERENCE)("a"),
    "wrap360: a string": lambda: encal.wrap360("a"),
    "wrap180: a string": lambda: encal.wrap180("a"),
    "angle_difference: lengths differ": lambda: encal.angle_difference([1.0, 2.0, 3.0], [1.0, 2.0]),
    "lsb_arcmin: 14.5": lambda: encal.lsb_arcmin(14.5),
    "coverage: empty calibration": lambda: _uncertainty().coverage(model("spectral"), encal.Calibration([], [])),
    "fit_with_prior: words": lambda: _prior().fit_with_prior(["a", "b"], [1.0, 2.0], the_prior()),
    "fit_with_prior: noise -1 arcmin": lambda: _prior().fit_with_prior(REFERENCE, ENCODER - REFERENCE, the_prior(),
                                                                        noise_arcmin=-1.0),
    "fit_with_prior: no prior": lambda: _prior().fit_with_prior(REFERENCE, ENCODER - REFERENCE, None),
    "fleet_prior: numbers for models": lambda: _prior().fleet_prior([1, 2, 3, 4, 5]),
    "selfcal.steps: arrays for a calibration": lambda: _selfcal().steps((REFERENCE, ENCODER)),
    "selfcal.sweep: a NaN phase": lambda: _selfcal().sweep(*_sweep_with_nan(), 7),
    "selfcal.sweep: words": lambda: _selfcal().sweep(["a"], ["b"], [1], 7),
    "plot_profile: lengths differ": lambda: encal.plot_profile(REFERENCE, ENCODER[:-1]),
    "plot_before_after: words": lambda: encal.plot_before_after(REFERENCE, ENCODER, ["a"] * 360),
    "plot_model: None for a model": lambda: encal.plot_model(None),
    "plot_model: coverage 2": lambda: encal.plot_model(model(), coverage=2.0),
    "demo_fleet: 0 encoders": lambda: encal.demo_fleet(0),
    "simulate_fleet: 1.5 encoders": lambda: encal.simulate_fleet(1.5),
}

HARMFUL.update(STORE_HARMFUL)  # task storeapi
HARMFUL.update(FIRMWARE_HARMFUL)


def _uncertainty():
    import encal.models.uncertainty as module

    return module


def _prior():
    import encal.fleet.prior as module

    return module


def _selfcal():
    import encal.selfcal as module

    return module


def _sweep_with_nan():
    phase = np.r_[np.linspace(0.0, 2520.0, 3000), np.linspace(2520.0, 0.0, 3000)]
    encoder, travel = phase / 7, np.repeat([1.0, -1.0], 3000)
    phase[100] = np.nan
    return phase, encoder, travel


def refused(call):
    """'' when ``call`` raises an encal error (or warns an EncalWarning) in one sentence; else what it did."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a NumPy warning on the way to the refusal is no refusal
            result = call()
    except (EncalError, encal.EncalWarning) as exc:
        text = str(exc)
        if "\n" in text or not text:
            return f"{type(exc).__name__} not in one line: {text!r}"
        return ""
    except Exception as exc:  # noqa: BLE001 - what the audit looks for
        return f"{type(exc).__name__}: {exc}"
    return f"accepted: {str(result)[:60]!r}"


def harmful_case(name):
    def run(_):
        outcome = refused(HARMFUL[name])
        return (0.0 if not outcome else math.inf), 0.0, outcome or "refused in one sentence"
    return Case("refused", name, run)


def cases():
    found = []
    for label in METHODS:
        found.append(truth_case(label, REFERENCE, ENCODER, "a 1-degree grid"))
    for label in ("auto", "fourier", "spectral", "lut"):
        found.append(truth_case(label, RANDOM_REFERENCE, RANDOM_ENCODER, "720 random angles"))
    for label in METHODS:
        found += [form_case(label, form) for form in CALIBRATIONS if form != "arrays (the plain form)"]
    for how in ("predict", "correct", "Compensator.correct", "Compensator.predict"):
        found += [input_case("auto", form, how) for form in INPUTS]
    for label in ("lut", "ann"):
        found += [input_case(label, form, "correct") for form in ("2-D Fortran order", "strided", "5 turns up")]
    for how in ("correct, 10**6 + 1 readings", "predict, 10**6 + 1 readings", "correct table=True"):
        found += [big_case(label, how) for label in ("auto", "lut")]
    for label in ("auto", "lut", "ann", "stack"):
        found += [file_case(label, how) for how in ("load_model", "Compensator(path)", "runtime.load",
                                                    "compile_table 14 bits", "export_c: in memory, loaded, path")]
    found += analysis_cases() + directional_cases() + arc_cases() + codes_cases() + uncertainty_cases()
    found += simulate_cases()
    found += store_cases() + firmware_cases()  # task storeapi
    found.append(threads_case())
    found += [harmful_case(name) for name in HARMFUL]
    return found


def outcome(case, folder):
    """(difference, limit, note) of a case; a case that raises is a failure, its exception the note."""
    try:
        difference, limit, note = case.run(folder)
    except Exception as exc:  # noqa: BLE001 - a harmless form must not raise
        return math.inf, 0.0, f"raised {type(exc).__name__}: {exc}"
    return difference, limit, note


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="comma-separated texts: the cases whose group or name holds one")
    args = parser.parse_args(argv)
    selected = cases()
    if args.only:
        keys = args.only.split(",")
        selected = [c for c in selected if any(k in f"{c.group}: {c.name}" for k in keys)]
    failures = 0
    groups = {}  # group -> [cases, agreeing, largest difference, largest limit]
    print("| group | variant | largest difference | limit | agrees | note |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        for case in selected:
            difference, limit, note = outcome(case, folder)
            ok = difference <= limit
            failures += not ok
            tally = groups.setdefault(case.group, [0, 0, 0.0, 0.0])
            tally[0] += 1
            tally[1] += ok
            tally[2], tally[3] = max(tally[2], difference), max(tally[3], limit)
            shown = "refused" if case.group == "refused" and ok else f"{difference:.3g}"
            note = note.replace("|", "/").replace("\n", " ")[:160]
            print(f"| {case.group} | {case.name} | {shown} | {limit:.3g} | {'yes' if ok else 'NO'} | {note} |",
                  flush=True)
    print("\n| group | cases | agree | largest difference | largest limit |")
    print("|---|---:|---:|---:|---:|")
    for group, (n, agreeing, difference, limit) in groups.items():
        shown = "all refused" if group == "refused" and agreeing == n else f"{difference:.3g}"
        print(f"| {group} | {n} | {agreeing} | {shown} | {limit:.3g} |")
    print(f"\n{len(selected) - failures} of {len(selected)} cases agree")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

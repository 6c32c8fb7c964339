"""Mutation fuzzer of session 6's new surfaces (fuzz6): --target-tolerance on bidirectional runs read afresh,
``encal correct --outside`` on arc models, the fleet store.

Seeded and deterministic. Each case runs ``encal.cli.main`` in this process and is flagged for a traceback, an exit
status other than 0/1/2, a refusal message of more than one line, a file left after a refusal, or a wrong number
with exit 0 against a truth built into the input. Usage::

    PYTHONPATH=src OMP_NUM_THREADS=1 python benchmarks/fuzz_session6.py --seed 1 --runs 500 [--surface tol]
"""

import argparse
import contextlib
import io
import json
import math
import sys
import tempfile
import traceback
import warnings
from pathlib import Path

import numpy as np


def run(argv, stdin_text=None):
    """(status, stdout, stderr, traceback or None) of ``encal argv`` in this process."""
    from encal.cli import main

    out, err = io.StringIO(), io.StringIO()
    old_stdin = sys.stdin
    if stdin_text is not None:
        sys.stdin = io.TextIOWrapper(io.BytesIO(stdin_text.encode()), encoding="utf-8")
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                status = main(list(argv))
            except SystemExit as exc:
                status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            except BaseException:  # noqa: BLE001 - a traceback is a finding
                return None, out.getvalue(), err.getvalue(), traceback.format_exc()
    finally:
        sys.stdin = old_stdin
    return status, out.getvalue(), err.getvalue(), None


# ----------------------------------------------------------------------------------------------- target tolerance

TOLERANCE_TEXTS = ["0", "-1", "nan", "inf", "1e-300", "10", "10.0000001", "1_0", "\uff11", "0x1p-3", " 0.01", "0.01 ",
                   "1e-6", "5", "+0.01", "-0", "1e308", "", "0.01,", "1e-3"]


UNIT_SCALES = {"deg": 1.0, "rad": math.pi / 180.0, "rev": 1.0 / 360.0}


def bidirectional_text(rng, spacing, jitter, repeats, reversal_arcmin, start, shuffle, wrap_turns, sep, crlf,
                       unit="deg"):
    """A bidirectional run read afresh, the true reversal ``reversal_arcmin`` at every target (angles in ``unit``)."""
    targets = start + np.arange(0.0, 360.0, spacing)
    rows = []
    for _ in range(repeats):
        for direction in (1, -1):
            for target in (targets if direction == 1 else targets[::-1]):
                reference = target + rng.uniform(-jitter, jitter)
                error = 2.0 * math.sin(math.radians(target)) + direction * reversal_arcmin / 2
                rows.append((reference + 360.0 * wrap_turns, reference + error / 60.0, direction))
    if shuffle:
        rows = [rows[i] for i in rng.permutation(len(rows))]
    end = "\r\n" if crlf else "\n"
    text = sep.join(["reference_deg", "encoder_deg", "direction"]) + end
    scale = UNIT_SCALES[unit]
    text += "".join(sep.join([repr(float(r * scale)), repr(float(e * scale)), str(d)]) + end for r, e, d in rows)
    return text


def tolerance_case(rng, folder):
    spacing = float(rng.choice([1.0, 5.0, 10.0, 12.0, 20.0]))
    jitter = float(rng.choice([0.0, 1e-7, 1e-4, 1e-3, 0.05]))
    repeats = int(rng.choice([1, 2, 3, 5]))
    reversal_arcmin = float(rng.choice([0.0, 0.5, -0.5, 3.0]))
    start = float(rng.choice([0.0, 0.0005, -0.0005, 359.9995 - 360.0, 2.5, spacing / 2]))
    unit = _pick(rng, ["deg", "deg", "rad", "rev"])
    text = bidirectional_text(rng, spacing, jitter, repeats, reversal_arcmin, start, bool(rng.random() < 0.3),
                              int(rng.choice([0, 0, 1, -1])), str(rng.choice([",", ";", "\t"])), rng.random() < 0.2,
                              unit=unit)
    calibration = folder / "bi.csv"
    calibration.write_text(text)
    model = folder / "m.json"
    if model.exists():
        model.unlink()
    if rng.random() < 0.7:
        tol_text = f"{float(rng.choice([1e-6, 1e-4, 2e-3, 0.01, 0.1, 0.4, 0.6, 1.0, 3.0, 6.0, 10.0])):g}"
    else:
        tol_text = str(rng.choice(TOLERANCE_TEXTS))
    argv = ["fit", str(calibration), "-o", str(model), "--method", str(rng.choice(["lut", "spectral", "auto"]))]
    if rng.random() < 0.9:
        argv += [f"--target-tolerance={tol_text}"]
    if unit != "deg":
        argv += ["--unit", unit]
    if rng.random() < 0.1:
        argv += ["--reverse"]
    if rng.random() < 0.1:
        argv += ["--bidirectional", "mean"]
    status, out, err, tb = run(argv)
    findings = []
    try:
        tol = float(tol_text)
    except ValueError:
        tol = None
    if status == 0 and model.exists() and tol is not None and "--target-tolerance" in " ".join(argv):
        data = json.loads(model.read_text())
        figures = _find(data, "reversal_value_arcmin")
        mean_figure = _find(data, "mean_reversal_value_arcmin")
        sign = -1 if "--reverse" in argv else 1
        if figures is not None:
            truth = abs(reversal_arcmin)
            if abs(figures - truth) > 1e-3 or abs(mean_figure - sign * reversal_arcmin) > 1e-3:
                findings.append(f"reversal {figures} / mean {mean_figure}, truth {truth} / {sign * reversal_arcmin}")
        if tol >= spacing - 2 * jitter - 1e-9 and tol < 360:
            findings.append(f"tolerance {tol} >= spacing {spacing} accepted (targets joined)")
        if figures is None:
            findings.append("no reversal figure recorded with --target-tolerance")
    return argv, status, out, err, tb, findings, [model]


def _find(data, key):
    if isinstance(data, dict):
        if key in data:
            return data[key]
        for value in data.values():
            found = _find(value, key)
            if found is not None:
                return found
    return None


def report_case(rng, folder):
    """``encal report --target-tolerance``: the page's reversal value against the truth."""
    spacing = float(rng.choice([5.0, 10.0, 15.0]))
    jitter = float(rng.choice([0.0, 1e-4, 1e-3]))
    reversal_arcmin = float(rng.choice([0.0, 0.5, -2.0]))
    text = bidirectional_text(rng, spacing, jitter, int(rng.choice([1, 2, 3])), reversal_arcmin,
                              float(rng.choice([0.0, -0.0005, 1.0])), bool(rng.random() < 0.3), 0, ",", False)
    calibration = folder / "bi.csv"
    calibration.write_text(text)
    page = folder / "r.html"
    for old in (page, folder / "r_figures"):
        if old.is_dir():
            import shutil
            shutil.rmtree(old)
        elif old.exists():
            old.unlink()
    tol = float(rng.choice([1e-6, 2e-3, 0.01, 1.0, 4.0, 7.5, 10.0]))
    argv = ["report", str(calibration), "-o", str(page), "--no-comparison", "--no-uncertainty", "--method", "lut",
            "--target-tolerance", f"{tol:g}"]
    status, out, err, tb = run(argv)
    findings = []
    if status == 0:
        import re
        body = re.sub(r"<[^>]+>", " ", page.read_text())
        found = re.search(r"reversal value\s+([-0-9.e+]+)\s+mean reversal value\s+([-0-9.e+]+)", body)
        if found is None:
            findings.append("no reversal value on the page")
        else:  # whatever targets matched (by chance under the scatter too), each one's reversal is the truth
            value, mean = float(found.group(1)), float(found.group(2))
            if abs(value - abs(reversal_arcmin)) > 1e-3 or abs(mean - reversal_arcmin) > 1e-3:
                findings.append(f"page: reversal {value} / mean {mean}, truth {abs(reversal_arcmin)} / "
                                f"{reversal_arcmin}"
                                f" (tolerance {tol}, spacing {spacing}, jitter {jitter})")
    return argv, status, out, err, tb, findings, [page]


def iso_case(rng, folder):
    """``reversal`` of a run read afresh (the library, many cases): targets, approaches and B against the truth
    whenever the tolerance lies between the reference's scatter and the targets' spacing."""
    from encal import Calibration
    from encal._core.errors import EncalError
    from encal.data.reversal import reversal

    spacing = float(rng.choice([0.5, 1.0, 5.0, 7.5, 10.0, 15.0]))
    tolerance = float(rng.choice([spacing / 2, spacing / 3, spacing / 10, 1e-3, 0.01, 1e-6]))
    jitter = float(rng.choice([0.0, 1e-7, 1e-4, tolerance / 4]))
    first = float(rng.choice([0.0, -tolerance, 360.0 - tolerance, spacing / 2, -jitter, 1e-9, rng.uniform(0, spacing)]))
    repeats = int(rng.integers(1, 4))
    target = np.tile(first + np.arange(0.0, 360.0 - 1e-9, spacing), 2 * repeats)
    direction = np.tile(np.repeat([1, -1], target.size // (2 * repeats)), repeats)
    reference = target + rng.uniform(-jitter, jitter, target.size) + 360.0 * rng.integers(-1, 2, target.size)
    b = float(rng.choice([0.0, 0.3, -1.0]))
    encoder = reference + (np.sin(np.radians(target)) + direction * b / 2) / 60.0
    argv = [f"reversal spacing={spacing} tolerance={tolerance} jitter={jitter} first={first!r} repeats={repeats}"]
    findings = []
    try:
        analysis = reversal(Calibration(reference, encoder, direction=direction, target_tolerance_deg=tolerance))
        status = 0
    except EncalError as exc:
        status, analysis = 1, None
        err = str(exc)
    else:
        err = ""
    if 2 * jitter < tolerance < spacing - 2 * jitter:
        if analysis is None:
            findings.append(f"refused: {err}")
        else:
            n = round(360.0 / spacing)
            if (analysis.target_deg.size, analysis.min_approaches, analysis.n_unmatched) != (n, repeats, 0):
                findings.append(f"{analysis.target_deg.size} targets of {n}, min approaches {analysis.min_approaches} "
                                f"of {repeats}, {analysis.n_unmatched} unmatched")
            if not np.allclose(analysis.reversal_arcmin, b, atol=1e-6):
                findings.append(f"B_i {analysis.reversal_arcmin.min()}..{analysis.reversal_arcmin.max()}, truth {b}")
    return argv, status, "", err, None, findings, []


_ARC_MODELS = {}


def arc_models(folder):
    """Arc models fitted once: (path, directional) for one direction, both, and a reversed encoder."""
    if not _ARC_MODELS:
        reference = np.arange(20.0, 140.0001, 0.5)
        for name, directions, reverse in (("arc", (1,), False), ("arcbi", (1, -1), False), ("arcrev", (1,), True)):
            lines = ["reference_deg,encoder_deg" + (",direction" if len(directions) == 2 else "")]
            for direction in directions:
                for ref in (reference if direction == 1 else reference[::-1]):
                    error = 1.5 * math.sin(math.radians(3 * ref + 10)) + 0.2 * direction
                    encoder = ref + error / 60.0
                    encoder = -encoder if reverse else encoder
                    lines.append(f"{ref:.9f},{encoder:.9f}" + (f",{direction}" if len(directions) == 2 else ""))
            (folder / f"{name}.csv").write_text("\n".join(lines) + "\n")
            argv = ["fit", str(folder / f"{name}.csv"), "-o", str(folder / f"{name}.json"), "--method", "lut"]
            status, _, err, tb = run(argv + (["--reverse"] if reverse else []))
            assert status == 0 and tb is None, err
            _ARC_MODELS[name] = (folder / f"{name}.json", len(directions) == 2)
    return _ARC_MODELS


ANGLE_FORMS = [lambda t: repr(t), lambda t: f"{t:.12f}", lambda t: f" {t!r} ",
               lambda t: f"+{t!r}" if math.copysign(1.0, t) > 0 else repr(t),
               lambda t: f"{t:e}", lambda t: f"{t!r}\t"]
DIRECTION_FORMS = {1: ["1", "+1", "cw", " 1", "1 "], -1: ["-1", "ccw", " -1"]}


def correct_case(rng, folder):
    """``encal correct --outside`` on arc models, each answer against the standalone runtime's correct_deg."""
    from encal import runtime

    models = arc_models(folder)
    name = str(rng.choice(sorted(models)))
    path, directional = models[name]
    model = runtime.load(str(path))
    start, end = model.range_deg
    readings = []
    for _ in range(int(rng.integers(1, 12))):
        kind = rng.integers(0, 6)
        if kind == 0:
            base = float(rng.choice([start, end]))
            theta = base + float(rng.choice([-1, 1])) * float(rng.choice([0.0, 1e-13, 1e-9, 1e-6, 0.01, 1.0]))
        elif kind == 1:
            theta = float(rng.uniform(start, end))
        elif kind == 2:
            theta = float(rng.uniform(-720, 720))
        elif kind == 3:
            theta = float(rng.choice([start, end])) + 360.0 * float(rng.integers(-3, 4))
        elif kind == 4:
            theta = float(rng.choice([0.0, -0.0, 360.0, 180.0, 1e9, -1e9]))
        else:
            theta = -float(rng.choice([start, end])) if name == "arcrev" else float(rng.uniform(0, 360))
        readings.append(theta)
    outside = rng.choice([None, "error", "clamp", "pass"])
    rows = None
    option_direction = None
    if rng.random() < 0.5:
        rows = [int(rng.choice([1, -1])) for _ in readings]
        texts = [ANGLE_FORMS[rng.integers(0, 3)](t) for t in readings]
        lines = ["encoder_deg,direction"] + [f"{text},{rng.choice(DIRECTION_FORMS[d])}" for text, d in zip(texts, rows)]
    else:
        texts = [ANGLE_FORMS[rng.integers(0, len(ANGLE_FORMS))](t) for t in readings]
        lines = texts
    readings = [float(text) for text in texts]  # the angle the command reads
    if rng.random() < 0.3:
        option_direction = int(rng.choice([1, -1]))
    source = folder / "readings.txt"
    source.write_text(("\r\n" if rng.random() < 0.2 else "\n").join(lines) + "\n")
    argv = ["correct", "--exact", str(path), str(source)]
    if outside is not None:
        argv += ["--outside", str(outside)]
    if option_direction is not None:
        argv += [f"--direction={option_direction:+d}"]
    status, out, err, tb = run(argv)
    findings = []
    answers = out.split()
    rule = "error" if outside is None else str(outside)
    expected = []
    for index, theta in enumerate(readings):
        direction = option_direction if option_direction is not None else (rows[index] if rows else None)
        if not directional:
            direction = None
        try:
            expected.append(model.correct_deg(theta, direction, outside=rule))
        except ValueError:
            expected.append("refused")
            break
    if status == 0:
        if "refused" in expected:
            findings.append(f"exit 0 where the runtime refuses: {readings}")
        elif len(answers) != len(expected):
            findings.append(f"{len(answers)} answers to {len(expected)} readings")
        else:
            for theta, answer, truth in zip(readings, answers, expected):
                value = float(answer)
                if not (math.isnan(value) and math.isnan(truth)) and not abs((value - truth + 180) % 360 - 180) < 2e-13:
                    findings.append(f"reading {theta!r} (rule {rule}): command {answer}, runtime {truth!r}")
    elif status == 1:
        if "refused" not in expected and not (option_direction is not None and rows is not None):
            findings.append(f"refused where the runtime answers every reading: {err.strip()[:200]}")
    return argv, status, out, err, tb, findings, []


SERIAL_NAMES = ["SN1", "SN\u00c51", "SNA\u030a1", "sn1", "SN001", " SN2", "SN2 ", "SN\u00e9 3", "SNe\u03013",
                "x" * 201, "SN\t4", "SN;5", "SN'6", "SN%7", "\u0661\u0662", "SN.8.v2"]


def unit_text(amplitude_arcmin, phase):
    """A full-turn calibration whose error is ``amplitude * sin(theta + phase)`` arc-minutes."""
    reference = np.arange(0.0, 360.0, 2.0)
    error = amplitude_arcmin * np.sin(np.radians(reference) + phase)
    return "reference_deg,encoder_deg\n" + "".join(f"{r:.9f},{r + e / 60:.9f}\n" for r, e in zip(reference, error))


def store_case(rng, folder):
    """``encal fleet fit`` of files with mutated serial names (NFD, spaces, long, copies), then ``encal correct
    --serial`` of each serial against the unit's known error."""
    import shutil
    import unicodedata

    lot = folder / "lot"
    if lot.exists():
        shutil.rmtree(lot)
    lot.mkdir()
    store = folder / "store.sqlite"
    if store.exists() and rng.random() < 0.7:
        store.unlink()
    names = list(rng.choice(SERIAL_NAMES, size=int(rng.integers(1, 5)), replace=False))
    truths = {}
    texts = []
    for name in names:
        amplitude, phase = float(rng.uniform(0.5, 3.0)), float(rng.uniform(0, 6.28))
        text = unit_text(amplitude, phase)
        if texts and rng.random() < 0.2:
            text, (amplitude, phase) = texts[-1]  # a copied file
        texts.append((text, (amplitude, phase)))
        try:
            (lot / f"{name}.csv").write_text(text)
        except OSError:
            continue
        truths[name] = (amplitude, phase, text)
    argv = ["fleet", "fit", str(lot), "--store", str(store), "--jobs", "0", "--method", "spectral"]
    status, out, err, tb = run(argv)
    findings = []
    if tb is not None or status not in (0, 1):
        return argv, status, out, err, tb, findings, []
    refused = err.count("error: refused")
    copies = len({t[2] for t in truths.values()}) < len(truths)
    if status == 0 and copies and not any("already" in line for line in out.splitlines()):
        findings.append("a copied calibration under two serials accepted")
    # each serial fitted now corrects as its unit's known error
    refused_names = [line for line in err.splitlines() if "error: refused" in line]
    fitted = {name: truth for name, truth in truths.items()
              if not any(f"{lot}/{name}.csv:" in line for line in refused_names)}
    stems = {}
    for name in fitted:
        stems.setdefault(unicodedata.normalize("NFC", name).strip(), []).append(name)
    for name, (amplitude, phase, text) in fitted.items():
        if len(stems[unicodedata.normalize("NFC", name).strip()]) > 1:
            continue  # two files of one serial: the later epoch is whichever was stored last
        if store.exists() and status == 0 and "already stored" in out and " 0 already stored" not in out:
            continue
        spelled = unicodedata.normalize(str(rng.choice(["NFC", "NFD"])), name)
        c_status, c_out, c_err, c_tb = run(["correct", "--exact", "--serial", spelled, "--store", str(store)],
                                            stdin_text="90\n")
        if c_tb is not None:
            findings.append(f"correct --serial {spelled!r}: traceback {c_tb.strip().splitlines()[-1]}")
        elif c_status == 0:
            truth = 90.0 - amplitude * math.sin(math.radians(90.0) + phase) / 60.0
            value = float(c_out.split()[0])
            if abs(value - truth) > 0.01 / 60:
                # the same bytes under another serial are that unit's: a copy gives the first's answer, fine
                findings.append(f"correct --serial {spelled!r}: {value!r}, the unit's truth {truth!r}")
        elif c_status not in (1, 2):
            findings.append(f"correct --serial {spelled!r}: status {c_status}")
        elif c_status == 1 and len(c_err.strip().splitlines()) != 1:
            findings.append(f"correct --serial {spelled!r}: message of several lines")
    # a second pass stores nothing new
    before = _count(store)
    status2, out2, err2, tb2 = run(argv)
    if tb2 is not None:
        findings.append("second pass: traceback " + tb2.strip().splitlines()[-1])
    elif _count(store) != before:
        findings.append(f"second pass over the same files stored {_count(store) - before} more records: {out2.strip()}")
    return argv, status, out, err, tb, findings, []


def _count(store):
    import sqlite3

    if not store.exists():
        return 0
    with sqlite3.connect(store) as connection:
        try:
            return connection.execute("SELECT COUNT(*) FROM encal_records").fetchone()[0]
        except sqlite3.OperationalError:
            return 0


def cexport_case(rng, folder):
    """The C export of a random arc model (bits, ends on or between codes, through 0, reading sign), compiled for
    every target under clamp and pass: the range test and the corrected angle at the codes near the ends against
    ``encal correct`` (the harness of tests/models/test_arc.py, on random arcs)."""
    import shutil

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests.models.test_arc import arc_on_codes, codes_near_the_ends, exports_at_codes

    bits = int(rng.choice([8, 10, 12, 14]))
    codes_n = 1 << bits
    first = int(rng.integers(0, codes_n))
    span = int(rng.integers(codes_n // 16, codes_n - 8))
    last = (first + span) % codes_n
    between, reading_sign = bool(rng.random() < 0.5), int(rng.choice([1, -1]))
    argv = [f"cexport bits={bits} first={first} last={last} between={between} reading_sign={reading_sign}"]
    work = folder / "c"
    if work.exists():
        shutil.rmtree(work)
    work.mkdir()
    try:
        model = arc_on_codes(bits, first, last, between, reading_sign=reading_sign)
    except Exception as exc:  # noqa: BLE001
        return argv, 1, "", str(exc), None, [], []
    path = model.save(work / "arc.json")
    codes = codes_near_the_ends(model, bits)

    class Failed(Exception):
        pass

    def command(line):
        status, out, err, tb = run(line)
        if status != 0 or tb is not None:
            raise Failed(status, out, err, tb, f"{' '.join(line[:1] + line[2:8])}: {err.strip()[:300]}")
        return out

    try:
        flags, expected, calls, rows = exports_at_codes(work, path, model, bits, codes, command)
    except Failed as failed:
        status, out, err, tb, finding = failed.args
        return argv, status, out, err, tb, [finding], []
    findings = []
    for k, call in enumerate(calls):
        rule = rows[0, k, 0]
        wrong = np.flatnonzero(rows[:, k, 1].astype(int) != flags)
        if wrong.size:
            findings.append(f"{call[:60]}: in_range wrong at codes {codes[wrong][:5]}")
        gap = np.abs((rows[:, k, 2].astype(float) - expected[rule] + 180.0) % 360.0 - 180.0)
        if gap.max() >= 1e-4:
            findings.append(f"{call[:60]}: {gap.max() * 60:.3g} arcmin off encal correct at code "
                            f"{codes[np.argmax(gap)]}")
    return argv, 0, "", "", None, findings, []


CELL_TOKENS = ["1_0", "\uff11", "\u0661\u0662", "0x1p3", "\u22125", "\u00a01", "1\u00a0", "Infinity", "1e400",
               "-1e400", "nan", "+-1", "1..0", "1e", "\u200b1", "\ufeff1", "1\x00", "\u00bd", "\U0001d7cf", "1,5",
               "1 0", "--1", "1e+0", "1.", ".5", "+1", " 1 ", "-0", "10", "\t1"]
DIRECTION_TOKENS = ["+1", "1.0", "-1.0", "\uff11", "\u22121", "CW", "Ccw", "cw ", "fwd", "0", "2", "1_0", "+ 1",
                    "\u00a01",
                    "-1e0", "1e0", "01", "-01", "--1"]
PLAIN = {"1e+0", "1.", ".5", "+1", " 1 ", "-0", "10", "\t1", "1e400", "-1e400"}


def _pick(rng, items):
    """One of ``items`` as it is (``rng.choice`` makes a NumPy string, which drops a trailing NUL)."""
    return items[int(rng.integers(0, len(items)))]


def cells_case(rng, folder):
    """One cell of a bidirectional calibration, or of ``encal correct``'s input, replaced by an odd token: accepted
    only when it is a plain decimal (or a direction encal names), and then read as Python's float of it."""
    text = bidirectional_text(rng, 10.0, 1e-3, 2, 0.5, 0.0, False, 0, ",", False)
    lines = text.splitlines()
    row = int(rng.integers(1, len(lines)))
    cells = lines[row].split(",")
    column = int(rng.integers(0, 3))
    token = _pick(rng, DIRECTION_TOKENS if column == 2 else CELL_TOKENS)
    cells[column] = token
    lines[row] = ",".join(cells)
    findings = []
    if rng.random() < 0.6:
        calibration = folder / "cells.csv"
        calibration.write_text("\n".join(lines) + "\n")
        model = folder / "cells.json"
        if model.exists():
            model.unlink()
        argv = ["fit", str(calibration), "-o", str(model), "--method", "lut", "--target-tolerance", "0.01"]
        status, out, err, tb = run(argv)
        outputs = [model]
    else:
        model = arc_models(folder)["arcbi"][0]
        readings = folder / "cells.txt"
        body = ["encoder_deg,direction"] + [f"{30 + k},{1 if k % 2 else -1}" for k in range(6)]
        target = int(rng.integers(1, 7))
        parts = body[target].split(",")
        column = int(rng.integers(0, 2)) * 2  # 0 the angle, 2 the direction (as in the calibration's numbering)
        token = _pick(rng, DIRECTION_TOKENS if column == 2 else CELL_TOKENS + ["2", "0", "01"])
        parts[column // 2] = token
        body[target] = ",".join(parts)
        readings.write_text("\n".join(body) + "\n")
        argv = ["correct", "--exact", str(model), str(readings), "--outside", "pass"]
        status, out, err, tb = run(argv)
        outputs = []
    if status == 0:
        plain_direction = token.strip(" \t").lower() in {"+1", "1", "-1", "cw", "ccw", "1.0", "-1.0", "1e0", "-1e0"}
        plain_angle = token in PLAIN or (argv[0] == "correct" and token in {"2", "0", "01", "1"})
        if not ((column != 2 and plain_angle) or (column == 2 and plain_direction)):
            findings.append(f"accepted the cell {token!r} (column {column + 1})")
    if status == 1 and argv[0] == "fit" and token not in PLAIN and not ("line" in err and str(row + 1) in err):
        findings.append(f"a refusal of {token!r} not naming line {row + 1}: {err.strip()[:200]}")
    return argv, status, out, err, tb, findings, outputs


def range_values(rng):
    a = float(rng.uniform(0, 360))
    ulp = math.ulp(360.0)
    choices = [[a, float(rng.uniform(0, 360))], [a, a + 1e-9], [a, a + ulp], [359.9999999, 0.0], [0.0, 359.99999999],
               [a, max(a - 1e-9, 0.0)], [-0.0, 10.0], [10, 200], [1e-320, 5.0], [10.0, 20.0, 30.0], ["10", 20.0],
               [10.0, 360.0], None, [360.0 - ulp, 0.0], [5.0, 5.0], [True, 20.0], [], {"start": 1}, [a, a]]
    return choices[int(rng.integers(0, len(choices)))]


def modelfile_case(rng, folder):
    """An arc model file re-signed with a mutated ``range_deg``: the runtime, the library and ``encal correct``
    agree on whether it loads and on every corrected angle; ``encal export --format c`` refuses in one line or
    writes."""
    from encal import runtime
    from encal._core.errors import EncalError
    from encal.deploy import load_model

    name = _pick(rng, ["arc", "arcbi", "arcrev"])
    document = json.loads(arc_models(folder)[name][0].read_text())
    document["range_deg"] = range_values(rng)
    document["sha256"] = runtime.content_sha256(document)
    path = folder / "mutated.json"
    path.write_text(json.dumps(document))
    argv = [f"modelfile {name} range_deg={document['range_deg']!r}"]
    findings = []
    try:
        model = runtime.load(str(path))
    except ValueError:
        model = None
    try:
        load_model(path)
        library = True
    except EncalError:
        library = False
    if library != (model is not None):
        findings.append(f"the library {'loads' if library else 'refuses'} it, the runtime "
                        f"{'loads' if model is not None else 'refuses'} it")
    readings = [float(rng.uniform(-10, 370)) for _ in range(5)]
    if model is not None and model.range_deg is not None:
        readings += [model.range_deg[0], model.range_deg[1], model.range_deg[0] - 1e-9, model.range_deg[1] + 1e-9]
    source = folder / "readings.txt"
    source.write_text("".join(f"{theta!r}\n" for theta in readings))
    rule = _pick(rng, ["clamp", "pass"])
    status, out, err, tb = run(["correct", "--exact", str(path), str(source), "--outside", rule])
    if tb is not None:
        return argv, status, out, err, tb, findings, []
    if model is None:
        if status != 1 or len(err.strip().splitlines()) != 1:
            findings.append(f"correct of a file the runtime refuses: status {status}, {err.strip()[:200]!r}")
    elif status != 0:
        findings.append(f"correct refuses a file the runtime loads: {err.strip()[:200]}")
    else:
        for theta, answer in zip(readings, out.split()):
            truth = model.correct_deg(theta, None, outside=rule)
            value = float(answer)
            if not (math.isnan(truth) and math.isnan(value)) and not abs((value - truth + 180) % 360 - 180) < 2e-13:
                findings.append(f"reading {theta!r} ({rule}): correct {answer}, runtime {truth!r}")
    out_dir = folder / "cout"
    if out_dir.exists():
        import shutil
        shutil.rmtree(out_dir)
    e_status, e_out, e_err, e_tb = run(["export", str(path), "--format", "c", "--outside", rule, "--bits", "12",
                                        "--table", "-o", str(out_dir)])
    if e_tb is not None:
        findings.append("export: traceback " + e_tb.strip().splitlines()[-1])
    elif e_status not in (0, 1, 2) or (e_status == 1 and len(e_err.strip().splitlines()) != 1):
        findings.append(f"export: status {e_status}, {e_err.strip()[:200]!r}")
    elif e_status != 0 and out_dir.exists() and any(out_dir.iterdir()):
        findings.append("export: files left after a refusal")
    elif e_status == 0 and model is None:
        findings.append("export wrote a file the runtime refuses")
    return argv, status, out, err, tb, findings, []


SURFACES = {"modelfile": modelfile_case, "cells": cells_case, "cexport": cexport_case, "iso": iso_case,
            "tol": tolerance_case, "report": report_case, "correct": correct_case, "store": store_case}


def check(argv, status, out, err, tb, findings, outputs):
    flags = list(findings)
    if tb is not None:
        flags.append("traceback: " + tb.strip().splitlines()[-1])
    elif status not in (0, 1, 2):
        flags.append(f"status {status}")
    if status in (1, 2):
        lines = [line for line in err.strip().splitlines() if "warning:" not in line]
        if argv[0] == "fleet":
            lines = [line for line in lines if not line.startswith("encal fleet: error: refused ")] or [""]
        if status == 1 and len(lines) != 1:
            flags.append(f"message of {len(lines)} lines: {err.strip()[:300]!r}")
        for output in outputs:
            if output.exists():
                flags.append(f"{output} left after a refusal")
    return flags


def main(table=None):
    """The command line of a fuzzer whose cases are ``table`` (surface name -> case function; default this file's):
    ``--seed``, ``--runs``, ``--surface`` (repeatable)."""
    import time

    table = SURFACES if table is None else table
    parser = argparse.ArgumentParser()
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--surface", choices=sorted(table), action="append")
    options = parser.parse_args()
    start = time.process_time()
    total_flags = drive(table, options.surface or sorted(table), options.runs, np.random.default_rng(options.seed))
    print(f"{options.runs} runs, {total_flags} flagged, {time.process_time() - start:.1f} s CPU of this process")


def drive(table, surfaces, runs, rng):
    """Run ``runs`` cases, the surfaces of ``table`` in turn, each checked by :func:`check`; print every flagged
    case and the count of runs by surface and status; return how many were flagged."""
    counts = {}
    total_flags = 0
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        for index in range(runs):
            surface = surfaces[index % len(surfaces)]
            argv, status, out, err, tb, findings, outputs = table[surface](rng, folder)
            counts[(surface, status)] = counts.get((surface, status), 0) + 1
            flags = check(argv, status, out, err, tb, findings, outputs)
            if flags:
                total_flags += 1
                print(f"#{index} {surface} status {status}: {' '.join(argv)}")
                for flag in flags:
                    print("   ", flag)
                if err.strip():
                    print("    stderr:", err.strip().splitlines()[-1][:400])
    print("runs by (surface, status):", dict(sorted(counts.items(), key=str)))
    return total_flags


if __name__ == "__main__":
    main()

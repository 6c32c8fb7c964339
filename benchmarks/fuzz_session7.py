"""Mutation fuzzer of session 7's new surfaces (fuzz7): ``encal correct --enc-unit/--enc-col`` (fast and careful
paths against ``Compensator.correct`` of the readings converted to degrees), the ``sigma_arcmin`` column of a
calibration CSV (read against its truth, and ``encal fit``'s model file against its own ``--json``).

Seeded and deterministic. Each case runs ``encal.cli.main`` in this process and is flagged for a traceback, an exit
status other than 0/1/2, a refusal message of more than one line, or a wrong number with exit 0. Usage::

    PYTHONPATH=src OMP_NUM_THREADS=1 python benchmarks/fuzz_session7.py --seed 1 --runs 3500 [--surface counts]

Surfaces: counts (encal correct --enc-unit/--enc-col, fast and careful paths, stdin, CRLF, BOM, quoted cells,
--skip-bad, a directional model's direction column), sigma (the sigma_arcmin column: signs, blanks, exponents,
decimal commas and the other decimal mark, direction and epoch columns, duplicated stops, --reverse, arcs,
shuffled rows), fit (encal fit --json and its model file), profile (ISO 230-2 of two-direction runs), spectral (the
noise floor on noise-free band-limited profiles). 3,500 runs (700 a surface) take 35 s CPU (37 s wall at load ~1,
2026-11-28); on main at b370b78, 46 flagged (a sigma cell in the other decimal mark read with exit 0) and 206
counts runs ended with status 2 (a "-" after an option), none on branch fuzz7.
"""

import json
import math

import numpy as np

from fuzz_session6 import main as fuzz_main
from fuzz_session6 import run

_MODELS = {}


def models(folder):
    """Model files fitted once: 'plain' (Fourier), 'directional' (per-direction)."""
    if not _MODELS:
        theta = np.arange(0.0, 360.0, 5.0)
        err = 3.0 * np.sin(np.radians(theta)) + 1.0 * np.cos(np.radians(2 * theta))
        lines = ["reference_deg,encoder_deg"] + [f"{float(t)!r},{float(t + e / 60.0)!r}" for t, e in zip(theta, err)]
        (folder / "plain.csv").write_text("\n".join(lines) + "\n")
        status, _, err_text, tb = run(["fit", "--method", "fourier", str(folder / "plain.csv"), "-o",
                                       str(folder / "plain.json")])
        assert status == 0, (err_text, tb)
        lines = ["reference_deg,encoder_deg,direction"]
        for d in (1, -1):
            lines += [f"{float(t)!r},{float(t + (e + d * 0.5) / 60.0)!r},{d}" for t, e in zip(theta, err)]
        (folder / "dir.csv").write_text("\n".join(lines) + "\n")
        status, _, err_text, tb = run(["fit", "--method", "fourier", "--bidirectional", "per-direction",
                                       str(folder / "dir.csv"), "-o", str(folder / "dir.json")])
        assert status == 0, (err_text, tb)
        _MODELS["plain"] = folder / "plain.json"
        _MODELS["directional"] = folder / "dir.json"
    return _MODELS


UNITS = ["deg", "rad", "rev", "counts:8", "counts:12", "counts:14", "counts:16", "counts:1", "counts:24", "counts:32"]


def _reading(rng, unit):
    if unit.startswith("counts:"):
        bits = int(unit.split(":")[1])
        kind = rng.integers(0, 5)
        if kind == 0:
            return str(int(rng.integers(0, 2**bits)))
        if kind == 1:
            return str(int(rng.integers(-2**bits, 3 * 2**bits)))
        if kind == 2:
            return str(int(rng.choice([0, 2**bits - 1, 2**bits, -1, 999999, 1000000, 12345678])))
        if kind == 3:
            return f"{rng.integers(0, 2**bits)}.{rng.integers(0, 100)}"
        return f"{float(rng.integers(0, 2**bits)):e}"
    scale = {"deg": 360.0, "rad": 2 * math.pi, "rev": 1.0}[unit]
    kind = rng.integers(0, 3)
    if kind == 0:
        return repr(float(rng.uniform(-scale, 2 * scale)))
    if kind == 1:
        return f"{rng.uniform(0, scale):.6f}"
    return repr(float(rng.choice([0.0, -0.0, scale, 999999.5, 1e6])))


def counts_case(rng, folder):
    """``encal correct --enc-unit U [--enc-col NAME]``: every answer against Compensator.correct(reading * scale)."""
    from encal._core.angles import angle_unit
    from encal.deploy import Compensator

    paths = models(folder)
    kind = "directional" if rng.random() < 0.25 else "plain"
    compensator = Compensator(str(paths[kind]))
    unit = str(rng.choice(UNITS))
    scale = angle_unit(unit).degrees_per_unit
    n = int(rng.choice([1, 3, 50, 2000]))
    readings = [_reading(rng, unit) for _ in range(n)]
    garbage = rng.random() < 0.3
    if garbage:  # a bad cell somewhere: refused naming its line, or 'nan' with --skip-bad
        readings[int(rng.integers(0, n))] = str(rng.choice(["abc", "1,5", "nan", "inf", "0x10", "1e999", "--1",
                                                            "\u0661", "1 2"]))
    column = str(rng.choice(["encoder_deg", "counts", "Raw", "enc"]))
    layout = rng.integers(0, 4)  # 0: one per line; 1: CSV; 2: CSV with direction; 3: CSV, column quoted
    directions = [int(rng.choice([1, -1])) for _ in readings]
    header_name = column if rng.random() < 0.7 else column.upper()
    if layout == 0:
        column = "encoder_deg" if rng.random() < 0.5 else column
        lines = list(readings)
    elif layout == 1:
        lines = [f"time_s,{header_name},x"] + [f"{i},{r},7" for i, r in enumerate(readings)]
    elif layout == 2:
        lines = [f"{header_name},direction"] + [f"{r},{d}" for r, d in zip(readings, directions)]
    else:
        lines = [f'"{header_name}",x'] + [f'"{r}",1' for r in readings]
    first_row = 0 if layout == 0 else 1
    line_of = [first_row + i + 1 for i in range(n)]  # each reading's line number
    for where, extra in ((2, "# a comment"), (3, "")):
        if rng.random() < 0.2 and len(lines) > where:
            lines.insert(where, extra)
            line_of = [number + (number > where) for number in line_of]
    text = ("\r\n" if rng.random() < 0.2 else "\n").join(lines) + ("\n" if rng.random() < 0.9 else "")
    if rng.random() < 0.1:
        text = "\ufeff" + text
    exact = rng.random() < 0.5
    skip_bad = rng.random() < 0.5
    argv = ["correct", str(paths[kind]), "--enc-unit", unit] + (["--skip-bad"] if skip_bad else [])
    if layout != 0 or column != "encoder_deg":
        argv += ["--enc-col", column]
    if exact:
        argv.append("--exact")
    stdin_text = None
    if rng.random() < 0.3:
        argv.append("-")
        stdin_text = text
    else:
        source = folder / "readings.csv"
        source.write_bytes(text.encode())
        argv.append(str(source))
    status, out, err, tb = run(argv, stdin_text=stdin_text)
    findings = []
    values = np.array([_number(r) for r in readings])
    degrees = values * scale
    bad = ~(np.abs(degrees) <= 1e9)
    if skip_bad:
        degrees = np.where(bad, np.nan, degrees)
        bad = np.zeros(n, dtype=bool)
    use_dir = kind == "directional" and layout == 2
    if status == 0:
        if bad.any():
            findings.append(f"exit 0 with a reading beyond 1e9 degrees: {readings[int(np.argmax(bad))]}")
        answers = out.split()
        if len(answers) != n:
            findings.append(f"{len(answers)} answers to {n} readings")
        else:
            good = np.isfinite(degrees)
            truth = np.full(n, np.nan)
            truth[good] = compensator.correct(degrees[good], np.array(directions)[good] if use_dir else None)
            got = np.array([float(a) for a in answers])
            tol = 0.0 if exact else 6e-13
            diff = np.where(np.isnan(got) & np.isnan(truth), 0.0, np.abs((got - truth + 180) % 360 - 180))
            diff = np.where(np.isnan(diff), np.inf, diff)
            if np.any(diff > tol):
                i = int(np.argmax(diff))
                findings.append(f"reading {readings[i]} ({unit}): command {answers[i]}, library {truth[i]!r}")
    elif status == 1:
        if not bad.any():
            findings.append(f"refused plain readings: {err.strip()[:300]}")
        elif f"line {line_of[int(np.argmax(bad))]} " not in err:
            findings.append(f"refusal does not name line {line_of[int(np.argmax(bad))]}: {err.strip()[:300]}")
    return argv, status, out, err, tb, findings, []


def _number(text):
    if not text.isascii():
        return math.nan
    try:
        return float(text)
    except ValueError:
        return math.nan


SIGMA_FORMS = [lambda s: repr(s), lambda s: f"{s:.3e}", lambda s: f"+{s!r}", lambda s: f" {s!r} ", lambda s: f"{s:E}"]
BAD_SIGMAS = ["", "-0.1", "nan", "inf", "-inf", "1_0", "0x1p-3", "abc", "1e400", "\uff11"]


def sigma_case(rng, folder):
    """A calibration with a sigma_arcmin column: the read reference_std_arcmin against the truth, or a refusal."""
    from encal.data.calibration import read_calibration

    spacing = float(rng.choice([1.0, 2.0, 5.0, 10.0]))
    arc = rng.random() < 0.2
    theta = np.arange(0.0, 120.0 if arc else 360.0, spacing)
    n = theta.size
    sigma = rng.uniform(0.0, 2.0, n) * (rng.random() < 0.8)
    err = 2.0 * np.sin(np.radians(theta))
    sep = ";" if rng.random() < 0.3 else ","
    comma = sep == ";" and rng.random() < 0.5
    reverse = rng.random() < 0.2
    with_dir = rng.random() < 0.25
    with_epoch = rng.random() < 0.2
    dup = rng.random() < 0.2
    average = dup and rng.random() < 0.5
    names = ["reference_deg", "encoder_deg", "sigma_arcmin"]
    if rng.random() < 0.2:
        names = ["Reference_Deg", "ENCODER_DEG", "Sigma_Arcmin"]
    if with_dir:
        names.append("direction")
    if with_epoch:
        names.append("epoch")
    order = list(rng.permutation(len(names))) if rng.random() < 0.3 else list(range(len(names)))
    rows = []
    truth = []
    for i, t in enumerate(theta):
        for d in ((1, -1) if with_dir else (1,)):
            encoder = float(t + err[i] / 60.0)
            cells = [repr(float(t)), repr(-encoder if reverse else encoder),
                     SIGMA_FORMS[rng.integers(0, 5)](float(sigma[i]))]
            truth.append(float(cells[2]))
            if with_dir:
                cells.append(str(d))
            if with_epoch:
                cells.append("a")
            rows.append(cells)
            if dup and i % 7 == 3:
                extra = list(cells)
                if average:  # another reading of the stop
                    extra[1] = repr(float(extra[1]) + 1e-4)
                extra[2] = repr(float(truth[-1] * 2 + 0.01))
                truth.append(float(extra[2]))
                rows.append(extra)
    if rng.random() < 0.3:  # rows in any order (truth follows its row)
        shuffled = rng.permutation(len(rows))
        rows, truth = [rows[i] for i in shuffled], [truth[i] for i in shuffled]
    bad_cell = None
    if rng.random() < 0.25:
        where = int(rng.integers(0, len(rows)))
        bad_cell = str(rng.choice(BAD_SIGMAS))
        rows[where][2] = bad_cell
    mixed = sep == ";" and rng.random() < 0.3  # the sigma cells in the other decimal mark: refused
    sigma_comma = comma != mixed
    if comma or sigma_comma:
        rows = [[c.replace(".", ",") if (sigma_comma if k == 2 else comma) else c for k, c in enumerate(r)]
                for r in rows]
    if mixed and not (any("." in r[k] or "," in r[k] for r in rows for k in (0, 1))
                      and any("." in r[2] or "," in r[2] for r in rows)):
        mixed = False  # (no cell with a mark on one side)
    if mixed and bad_cell is None:
        bad_cell = "mixed"
    text = sep.join(names[j] for j in order) + "\n"
    text += "".join(sep.join(r[j] for j in order) + "\n" for r in rows)
    if rng.random() < 0.1:
        text = text.replace("\n", "\r\n")
    path = folder / "sigma.csv"
    path.write_text(text)
    argv = ["read", str(path)] + (["--reverse"] if reverse else []) + (["--average-duplicates"] if average else [])
    findings = []
    tb = None
    status, out, err_text = 0, "", ""
    try:
        cal = read_calibration(path, reverse=reverse, duplicates="average" if average else "refuse")
    except Exception as exc:  # noqa: BLE001
        from encal import CalibrationError, InputError

        if isinstance(exc, (InputError, CalibrationError)):
            status, err_text = 1, str(exc)
            if bad_cell is None:
                findings.append(f"refused: {exc}")
            elif "line" not in str(exc) or ("sigma_arcmin" not in str(exc) and "decimal" not in str(exc)):
                findings.append(f"message without line/column: {exc}")
        else:
            import traceback

            tb = traceback.format_exc()
            status = None
    else:
        if bad_cell is not None and bad_cell not in ("1e400",):
            findings.append(f"read a bad sigma cell {bad_cell!r}")
        elif cal.reference_std_arcmin is None:
            findings.append("no reference_std_arcmin")
        else:
            # the sigmas read at each reference angle and direction against the file's (a stop's averaged
            # readings keep the largest of its sigmas)
            table, read = {}, {}
            for cells, s in zip(rows, truth):
                key = (round(float(cells[0].replace(",", ".")) % 360, 6), int(cells[3]) if with_dir else 1)
                table.setdefault(key, []).append(s)
            if average:
                table = {key: [max(values)] for key, values in table.items()}
            directions = cal.direction if cal.direction is not None else np.ones(len(cal), dtype=int)
            for ref, d, s in zip(cal.reference_deg, directions, cal.reference_std_arcmin):
                read.setdefault((round(float(ref) % 360, 6), int(d)), []).append(float(s))
            for key in sorted(set(table) | set(read)):
                want, got = sorted(table.get(key, [])), sorted(read.get(key, []))
                if len(want) != len(got) or not np.allclose(want, got, rtol=1e-12, atol=0):
                    findings.append(f"sigmas at {key}: read {got!r}, file {want!r}")
                    break
    return argv, status, out, err_text, tb, findings, []


def fit_case(rng, folder):
    """``encal fit --json`` of a calibration with a sigma_arcmin column (uniform, or a step, or an arc): the model
    file's predicted std at the calibrated angles is at least the reference's sigma there, and the library's fit of
    the same calibration with ``uncertainty=True`` predicts the same std."""
    from encal import read_calibration
    from encal.deploy import Compensator
    from encal.models.fitting import fit

    spacing = float(rng.choice([2.0, 5.0, 10.0]))
    arc = rng.random() < 0.2
    theta = np.arange(0.0, 150.0 if arc else 360.0, spacing) + float(rng.choice([0.0, 200.0]))
    level = float(rng.choice([0.0, 0.1, 1.0, 5.0]))
    sigma = np.where(theta % 360 < 180, level, float(rng.choice([level, 0.2, 3.0])))
    err = 2.0 * np.sin(np.radians(theta)) + rng.normal(0, 0.05, theta.size)
    with_dir = rng.random() < 0.3
    reverse = rng.random() < 0.2
    lines = ["reference_deg,encoder_deg,sigma_arcmin" + (",direction" if with_dir else "")]
    for t, e, sd in zip(theta, err, sigma):
        for d in ((1, -1) if with_dir else (None,)):
            encoder = float(t + (e + (0.3 * d if d else 0)) / 60.0)
            cell = f"{float(t)!r},{-encoder if reverse else encoder!r},{float(sd)!r}"
            lines.append(cell + (f",{d}" if d else ""))
    path = folder / "fit.csv"
    path.write_text("\n".join(lines) + "\n")
    out_path = folder / "fit.json"
    if out_path.exists():
        out_path.unlink()
    method = "auto" if arc else str(rng.choice(["spectral", "spectral", "fourier", "auto"]))
    argv = ["fit", "--json", "--method", method, str(path), "-o", str(out_path)]
    bidirectional = str(rng.choice(["mean", "per-direction"])) if with_dir else None
    if bidirectional:
        argv += ["--bidirectional", bidirectional]
    if reverse:
        argv.append("--reverse")
    status, out, err_text, tb = run(argv)
    findings = []
    if status == 0:
        comp = Compensator(str(out_path))
        parts = [comp.model.forward, comp.model.reverse] if comp.model.kind == "directional" else [comp.model]
        if any(part.uncertainty is None for part in parts):
            return argv, status, out, err_text, tb, findings, []
        readings = -theta if reverse else theta  # (the reversal is a few arcmin: at the calibrated angles)
        where = ~np.isnan(comp.predict(readings))
        try:
            _, std = comp.predict(readings, return_std=True)
        except Exception as exc:  # noqa: BLE001
            findings.append(f"predict(return_std=True) of the model file: {type(exc).__name__}: {exc}")
            return argv, status, out, err_text, tb, findings, []
        # (at a step of sigma, the nearer neighbour's: sigma is interpolated between the points)
        floor = np.minimum(sigma, np.minimum(np.roll(sigma, 1), np.roll(sigma, -1)))
        if np.any(std[where] < floor[where] * (1 - 1e-9)):
            i = int(np.argmax(floor[where] - std[where]))
            findings.append(f"model std {float(std[where][i])!r} below the reference sigma {float(floor[where][i])!r} "
                            f"at {float(theta[where][i])!r}")
        held = json.loads(out).get("held_out") or {}
        if held.get("rms_arcmin") is not None and held.get("reference_std_rms_arcmin") is None:
            findings.append("held_out without reference_std_rms_arcmin")
        expected = getattr(comp.model, "expected_rms_between_points", lambda: None)()
        if held.get("estimator") == "posterior" and expected is not None and not math.isclose(
                expected, held["rms_arcmin"], rel_tol=1e-12):
            findings.append(f"--json held_out {held['rms_arcmin']!r}, the model file's posterior {expected!r}")
        if method in ("spectral", "fourier"):
            cal = read_calibration(path, reverse=reverse)
            library = fit(cal, method, uncertainty=True, bidirectional=bidirectional)
            _, again = Compensator(library).predict(readings, return_std=True)
            if not np.allclose(again[where], std[where], rtol=1e-9, atol=1e-12):
                findings.append(f"library std {again[where][:3]} != model file's {std[where][:3]}")
    elif status is not None:
        findings.append(f"refused: {err_text.strip()[:300]}")
    return argv, status, out, err_text, tb, findings, []


def profile_case(rng, folder):
    """``encal profile --json`` of a two-direction run with a known reversal B (some targets unmatched, one or more
    approaches, an offset, --zero arbitrary, --reverse, a sigma column): iso230_2's B against the truth, and the
    repeatability/accuracy given only with two approaches each way at every target."""
    spacing = float(rng.choice([5.0, 10.0, 15.0]))
    repeats = int(rng.choice([1, 2, 3]))
    b = float(rng.choice([0.0, 0.5, -2.0, 3.0]))
    offset = float(rng.choice([0.0, 30.0]))
    reverse = rng.random() < 0.2
    unmatched = rng.random() < 0.3
    with_sigma = rng.random() < 0.3
    targets = np.arange(0.0, 360.0, spacing)
    rows = []
    for r in range(repeats):
        for d in (1, -1):
            for i, t in enumerate(targets if d == 1 else targets[::-1]):
                ref = float(t) + (spacing / 3 if unmatched and d == -1 and i % 4 == 1 else 0.0)
                error = 2.0 * math.sin(math.radians(ref)) + d * b / 2 + offset
                encoder = ref + error / 60.0
                rows.append((ref, -encoder if reverse else encoder, d))
    head = "reference_deg,encoder_deg,direction" + (",sigma_arcmin" if with_sigma else "")
    text = head + "\n" + "".join(f"{r!r},{e!r},{d}" + (",0.5" if with_sigma else "") + "\n" for r, e, d in rows)
    path = folder / "profile.csv"
    path.write_text(text)
    argv = ["profile", "--json", str(path)]
    if reverse:
        argv.append("--reverse")
    if rng.random() < 0.3:
        argv += ["--zero", "arbitrary"]
    status, out, err, tb = run(argv)
    findings = []
    if status == 0:
        data = json.loads(out)
        iso = data.get("iso230_2")
        if iso is None:
            findings.append("no iso230_2")
        else:
            mean_b = iso.get("mean_reversal_value_arcmin")
            if mean_b is None or abs(mean_b - b) > 1e-6 or abs(iso.get("reversal_value_arcmin") - abs(b)) > 1e-6:
                findings.append(f"B {iso.get('reversal_value_arcmin')} / mean {mean_b}, truth {abs(b)} / {b}")
            if (repeats < 2) != (iso.get("repeatability_arcmin") is None):
                findings.append(f"repeatability {iso.get('repeatability_arcmin')} with {repeats} approaches")
    else:
        findings.append(f"refused: {err.strip()[:300]}")
    return argv, status, out, err, tb, findings, []


def spectral_case(rng, folder):
    """The spectral model of a noise-free (or nearly) band-limited profile at N points, scaled from 1e-6 to 1e3
    arcmin, quantised or not: its prediction between the points against the truth (the noise floor at exp(-20) of
    the mean square), and the posterior finite."""
    import time

    from encal import Calibration, CalibrationError
    from encal.models.fitting import fit

    n = int(rng.choice([24, 36, 90, 180, 360]))
    orders = sorted(set(int(k) for k in rng.integers(1, n // 4, size=int(rng.integers(1, 5)))))
    scale = float(10.0 ** rng.uniform(-6, 1.5))  # (beyond, the profile folds over: refused)
    amplitudes = rng.normal(0, 1, (len(orders), 2)) * scale
    noise = float(rng.choice([0.0, 0.0, 1e-9, 1e-6])) * scale
    offset = float(rng.choice([0.0, 0.37]))
    theta = offset + np.arange(n) * (360.0 / n)

    def truth(angle):
        radians = np.radians(angle)
        return sum(a * np.cos(k * radians) + b * np.sin(k * radians) for k, (a, b) in zip(orders, amplitudes))

    error = truth(theta) + rng.normal(0, 1, n) * noise
    cal = Calibration(theta - error / 60.0, theta)
    argv = [f"spectral n={n} orders={orders} scale={scale:.3g} noise={noise:.3g} offset={offset}"]
    findings = []
    start = time.process_time()
    try:
        model = fit(cal, "spectral")
    except CalibrationError as exc:  # a profile of tens of arcmin at a high order folds over: refused
        return argv, 1, "", str(exc), None, findings, []
    except Exception as exc:  # noqa: BLE001
        import traceback

        return argv, None, "", str(exc), traceback.format_exc(), findings, []
    seconds = time.process_time() - start
    between = offset + (np.arange(n) + 0.5) * (360.0 / n)
    miss = np.max(np.abs(model.predict(between) - truth(between)))
    size = float(np.sqrt(np.mean(truth(theta) ** 2)))
    if not miss <= 1e-3 * size + 10 * noise:
        findings.append(f"between the points off by {miss:.3g} arcmin of a profile RMS {size:.3g}")
    _, std = model.predict(between, return_std=True)
    if not np.all(np.isfinite(std)):
        findings.append("a non-finite posterior std")
    if seconds > 5.0:
        findings.append(f"{seconds:.1f} s CPU")
    return argv, 0, "", "", None, findings, []


SURFACES = {"counts": counts_case, "sigma": sigma_case, "fit": fit_case, "profile": profile_case,
            "spectral": spectral_case}


def main():
    fuzz_main(SURFACES)


if __name__ == "__main__":
    main()

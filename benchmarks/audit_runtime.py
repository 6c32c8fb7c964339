"""Audit: the standalone runtime (src/encal/runtime.py) against encal's Model.predict / Model.correct.

For every kind and variant encal writes (fitted here on simulated data with ``encal.fit`` and saved), and every
frozen model file in tests/data, evaluates both at ~2*10^4 angles (random ones over several turns, edges, the
table's nodes and the midpoints between them, an arc's ends and just outside) and prints the largest difference
of ``predict`` (arc-minutes) and of ``correct`` (degrees, round the circle) per model, and where NaN differs.

    PYTHONPATH=src OMP_NUM_THREADS=1 /work/main/.venv/bin/python benchmarks/audit_runtime.py
"""

import math
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

import encal
from encal import runtime
from encal._core.number_cells import MAX_ABS_DEG
from encal.deploy import Compensator, load_model, save_model

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
N_RANDOM = 20000


def profile(theta_deg, offset_arcmin=0.0):
    r = np.radians(theta_deg)
    return offset_arcmin + 4.0 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r) - 0.6 * np.sin(4 * r) + 0.2 * np.cos(17 * r)


def calibration(*, step=2.0, arc=None, reverse=False, offset_arcmin=0.0, bits=None, both_ways=False, seed=0):
    rng = np.random.default_rng(seed)
    reference = np.arange(0.0, 360.0, step) if arc is None else np.arange(arc[0], arc[1] + 1e-9, step)
    direction = None
    error = profile(reference, offset_arcmin) + 0.02 * rng.standard_normal(reference.size)
    if both_ways:
        reference = np.concatenate([reference, reference[::-1]])
        direction = np.repeat([1, -1], reference.size // 2)
        error = np.concatenate([error, error[::-1]]) + 0.3 * direction
    encoder = reference + error / 60.0  # the model input's angle
    if bits is not None:
        lsb = 360.0 / 2**bits
        encoder = np.round(encoder / lsb) * lsb
    if reverse:  # an encoder counting against the reference: its readings are -encoder, negated back on reading
        return encal.Calibration(reference, encoder, direction=direction, name="rev", reading_sign=-1,
                                 resolution_bits=bits)
    return encal.Calibration(reference, encoder, direction=direction, name="enc", resolution_bits=bits)


def variants():
    """(label, model) of every kind and variant encal writes."""
    full = calibration()
    yield "fourier", encal.fit(full, method="fourier")
    yield "spectral", encal.fit(full, method="spectral")
    yield "lut cubic", encal.fit(full, method="lut", interpolation="cubic")
    yield "lut linear", encal.fit(full, method="lut", interpolation="linear")
    yield "ann periodic", encal.fit(full, method="ann", rng=1, hidden=12, epochs=30)
    yield "ann raw", encal.fit(full, method="ann", rng=2, hidden=20, encoding="raw", epochs=30)
    yield "ann logsig", encal.fit(full, method="ann", rng=3, hidden=10, activation="logsig", epochs=30)
    yield "hybrid", encal.fit(full, method="hybrid", rng=4, epochs=30)
    yield "stack", encal.fit(full, method="stack", rng=5,
                             members=[{"family": "fourier"}, {"family": "lut", "options": {"interpolation": "cubic"}},
                                      {"family": "ann", "options": {"hidden": 6, "epochs": 20}}],
                             weights=[0.5, 0.3, 0.2])
    both = calibration(both_ways=True)
    yield "directional fourier", encal.fit(both, method="fourier")
    yield "directional lut", encal.fit(both, method="lut", interpolation="cubic")
    yield "arc", encal.fit(calibration(step=1.0, arc=(20.0, 140.0)))
    yield "arc through 0", encal.fit(calibration(step=1.0, arc=(300.0, 420.0)))
    yield "lut on an arc", encal.fit(calibration(step=1.0, arc=(20.0, 140.0)), method="lut")
    yield "arc directional", encal.fit(calibration(step=1.0, arc=(20.0, 140.0), both_ways=True))
    yield "arc reversed", encal.fit(calibration(step=1.0, arc=(20.0, 140.0), reverse=True))
    yield "fourier reversed", encal.fit(calibration(reverse=True), method="fourier")
    yield "lut reversed", encal.fit(calibration(reverse=True), method="lut", interpolation="cubic")
    yield "directional reversed", encal.fit(calibration(reverse=True, both_ways=True), method="fourier")
    yield "fourier offset 37 deg", encal.fit(calibration(offset_arcmin=37 * 60.0), method="fourier")
    yield "lut offset 179.9 deg", encal.fit(calibration(offset_arcmin=179.9 * 60.0), method="lut")
    yield "fourier offset -0.5 deg", encal.fit(calibration(offset_arcmin=-30.0), method="fourier")
    yield "fourier 12 bits", encal.fit(calibration(bits=12), method="fourier")
    yield "lut 10 bits", encal.fit(calibration(bits=10, step=0.5), method="lut", interpolation="cubic")
    yield "arc directional reversed", encal.fit(calibration(step=1.0, arc=(200.0, 330.0), both_ways=True,
                                                            reverse=True))
    yield "hybrid reversed", encal.fit(calibration(reverse=True), method="hybrid", rng=6, epochs=20)
    yield "stack of spectral and ann", encal.fit(full, method="stack", rng=7, weights=[0.7, 0.3],
                                                 members=[{"family": "spectral"},
                                                          {"family": "ann", "options": {"hidden": 4, "epochs": 10}}])
    rng = np.random.default_rng(11)
    reference = np.sort(rng.uniform(0.0, 360.0, 12000))
    dense = encal.Calibration(reference, reference + profile(reference) / 60.0, name="dense")
    yield "lut dense (binned)", encal.fit(dense, method="lut", interpolation="cubic")
    yield "spectral dense", encal.fit(dense, method="spectral")


def angles_for(model):
    """Angles (degrees, encoder readings) at which to compare."""
    rng = np.random.default_rng(42)
    ulp = math.ulp(360.0)
    edges = [0.0, -0.0, 360.0 - ulp, 360.0, -360.0, 720.0, 1e-300, -1e-300, -1e-17, 1e-17, 180.0, 90.0, 1.0, -1.0,
             359.0, 361.0, 1e15, -1e15, 1e10 + 0.25, -1e10 - 0.25, 2.0**40, 2.0**40 + 0.5, 123.456, -123.456]
    theta = [rng.uniform(-1080.0, 1080.0, N_RANDOM), edges]
    parts = [model.forward, model.reverse] if model.kind == "directional" else [model]
    for part in parts:
        breaks = getattr(part, "breaks_deg", None)
        if breaks is not None:
            nodes = np.asarray(breaks)
            between = 0.5 * (nodes[:-1] + nodes[1:])
            for values in (nodes, between, np.nextafter(nodes, -np.inf), np.nextafter(nodes, np.inf)):
                theta += [values, values - 360.0, values + 360.0]
                if model.reading_sign == -1:
                    theta += [-values]
    if model.range_deg is not None:
        for end in model.range_deg:
            for delta in (0.0, 1e-12, -1e-12, 5e-10, -5e-10, 1e-9, -1e-9, 1.5e-9, -1.5e-9, 2e-9, -2e-9, 1e-6, -1e-6,
                          1e-3, -1e-3):
                value = end + delta
                theta += [[value, value + 360.0, value - 360.0, -value]]
    return np.concatenate([np.asarray(t, dtype=float).reshape(-1) for t in theta])


def directions_of(model):
    return (None, 1, -1) if model.kind == "directional" else (None,)


def compare(label, path):
    """The largest differences of runtime against encal for the model file at ``path``."""
    model = load_model(path)
    stored = runtime.load(path)
    compensator = Compensator(path)
    theta = angles_for(model)
    worst = {"predict": 0.0, "correct": 0.0, "compensator": 0.0, "scalar": 0.0, "nan": 0}
    for direction in directions_of(model):
        ours_p = np.array([stored.predict_arcmin(t, direction) for t in theta])
        ours_c = np.array([stored.correct_deg(t, direction) for t in theta])
        theirs_p = model.predict(theta, direction=direction)
        theirs_c = model.correct(theta, direction)
        via_comp = compensator.correct(theta, direction)
        nan_ours, nan_theirs = np.isnan(ours_p), np.isnan(theirs_p)
        worst["nan"] += int(np.sum(nan_ours != nan_theirs)) + int(np.sum(np.isnan(ours_c) != np.isnan(theirs_c)))
        worst["nan"] += int(np.sum(np.isnan(ours_c) != np.isnan(via_comp)))
        both = ~nan_ours & ~nan_theirs
        worst["predict"] = max(worst["predict"], float(np.max(np.abs(ours_p[both] - theirs_p[both]), initial=0.0)))
        for name, other in (("correct", theirs_c), ("compensator", via_comp)):
            ok = ~np.isnan(ours_c) & ~np.isnan(other)
            gap = np.abs((ours_c[ok] - other[ok] + 180.0) % 360.0 - 180.0)
            worst[name] = max(worst[name], float(np.max(gap, initial=0.0)))
            if np.any((other[ok] < 0) | (other[ok] >= 360.0)) or np.any((ours_c[ok] < 0) | (ours_c[ok] >= 360.0)):
                worst["nan"] += 1000000  # out of [0, 360)
        # scalars one at a time (encal's small-array path)
        pick = np.linspace(0, theta.size - 1, 400).astype(int)
        for t in theta[pick]:
            a = float(model.predict(float(t), direction=direction))
            b = stored.predict_arcmin(float(t), direction)
            if math.isnan(a) != math.isnan(b):
                worst["nan"] += 1
            elif not math.isnan(a):
                worst["scalar"] = max(worst["scalar"], abs(a - b))
    return worst


def frozen():
    for path in sorted(DATA.glob("model_v*.json")):
        yield path.name, path




def cli_compare(path, *, stdin=False, direction_column=False, direction=None, outside=None, inside_only=False,
                readings=None):
    """Largest difference (degrees) of ``encal correct --exact`` against the runtime, NaN mismatches, readings."""
    import subprocess

    model = load_model(path)
    stored = runtime.load(path)
    theta = angles_for(model) if readings is None else np.asarray(readings, dtype=float)
    if inside_only and model.range_deg is not None:
        theta = theta[~np.isnan(model.predict(theta))]
    theta = theta[np.abs(theta) <= MAX_ABS_DEG]  # the command reads angles within +-1e9 degrees (a calibration's bound)
    rng = np.random.default_rng(7)
    directions = rng.choice([1, -1], theta.size) if direction_column else None
    texts = [repr(float(t)) for t in theta]
    theta = np.array([float(t) for t in texts])
    if direction_column:
        directions = directions[:theta.size]
        body = "encoder_deg,direction\n" + "".join(f"{t},{d:+d}\n" for t, d in zip(texts, directions))
    else:
        body = "".join(t + "\n" for t in texts)
    command = [sys.executable, "-m", "encal", "correct", "--exact", str(path)]
    if direction is not None:
        command += ["--direction", str(direction)]
    if outside is not None:
        command += ["--outside", outside]
    if stdin:
        result = subprocess.run(command, input=body, capture_output=True, text=True)
    else:
        with tempfile.NamedTemporaryFile("w", suffix=".csv" if direction_column else ".txt", delete=False) as f:
            f.write(body)
        result = subprocess.run(command + [f.name], capture_output=True, text=True)
    if result.returncode != 0:
        return f"exit {result.returncode}: {result.stderr.strip()[:200]}"
    answers = np.array([float(line) for line in result.stdout.split()])
    chosen = direction if direction is not None else None
    rule = {} if outside is None else {"outside": outside}
    ours = np.array([stored.correct_deg(t, int(d) if direction_column and direction is None else chosen, **rule)
                     for t, d in zip(theta, directions if direction_column else [None] * theta.size)])
    nan = int(np.sum(np.isnan(ours) != np.isnan(answers)))
    ok = ~np.isnan(ours) & ~np.isnan(answers)
    gap = np.abs((ours[ok] - answers[ok] + 180.0) % 360.0 - 180.0)
    return float(np.max(gap, initial=0.0)), nan, theta.size


def outside_compare(path, rule):
    """Largest difference (degrees) of ``encal correct --outside rule`` against the runtime's rule, per direction,
    at readings all round the turn; None when this runtime has no rules (before task runtime6)."""
    import inspect

    stored = runtime.load(path)
    if "outside" not in inspect.signature(stored.correct_deg).parameters:
        return None
    model = load_model(path)
    theta = np.linspace(-360.0, 720.0, 1081)
    worst = 0.0
    for direction in directions_of(model):
        gap = cli_compare(path, direction=direction, outside=rule, readings=theta)
        worst = max(worst, gap[0] + 1e6 * gap[1]) if not isinstance(gap, str) else float("inf")
    return worst


def main():
    """Print the table of the largest differences, one row per model."""
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        labelled = list(frozen())
        for label, model in variants():
            path = Path(folder) / (label.replace(" ", "_") + ".json")
            save_model(model, path)
            labelled.append((label, path))
        print("| model | predict (arcmin) | correct (arcmin) | Compensator (arcmin) | encal correct (arcmin) "
              "| NaN mismatches | --outside clamp, pass vs runtime (arcmin) |")
        print("|---|---|---|---|---|---|---|")
        for label, path in labelled:
            try:
                worst = compare(label, path)
            except Exception as exc:  # noqa: BLE001 - an audit reports everything
                print(f"| {label} | refused by encal: {type(exc).__name__}: {str(exc)[-90:]} |||||")
                continue
            model = load_model(path)
            command = [cli_compare(path, inside_only=True)]
            if model.kind == "directional":
                command += [cli_compare(path, inside_only=True, direction=d) for d in (1, -1)]
                command.append(cli_compare(path, inside_only=True, direction_column=True, stdin=True))
            refused = [c for c in command if isinstance(c, str)]
            cli = "refused: " + refused[0][:100] if refused else f"{max(c[0] for c in command) * 60:.3g}"
            nan = worst["nan"] + sum(c[1] for c in command if not isinstance(c, str))
            rules = "-"
            if model.range_deg is not None:
                found = [outside_compare(path, rule) for rule in ("clamp", "pass")]
                rules = "no rules" if found[0] is None else ", ".join(f"{v * 60:.3g}" for v in found)
            print(f"| {label} | {worst['predict']:.3g} | {worst['correct'] * 60:.3g} | {worst['compensator'] * 60:.3g} "
                  f"| {cli} | {nan} | {rules} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

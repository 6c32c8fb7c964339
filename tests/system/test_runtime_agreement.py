"""Task runtime6: the standalone runtime, the Python API (Model, Compensator) and `encal correct` give the same
corrected angles for every model file encal writes, at edge angles, by direction, and outside an arc.

The full audit (every kind and variant, 2*10^4 angles each, the largest differences) is
``benchmarks/audit_runtime.py``; these tests keep its cases that once disagreed, and a quick sweep of all kinds.
"""

import math

import numpy as np
import pytest

import encal
from encal import runtime
from encal.cli import main
from encal.deploy import Compensator, load_model, save_model
from encal.models.directional import DirectionalModel
from encal.models.fourier import FourierModel
from encal._core.number_cells import MAX_ABS_DEG
from tests._paths import DATA

#: Largest difference of a corrected angle, degrees: a few units in the last place of 360 (5.7e-14 each).
ROUNDING_DEG = 2e-13
#: Largest difference of a predicted error, arc-minutes: rounding (a float-summation order), not a formula.
ROUNDING_ARCMIN = 1e-11


def corrected_by_the_command(capsys, folder, path, readings, *options, directions=None):
    """`encal correct --exact` of readings written one per line in ``folder`` (or in a CSV with a direction
    column)."""
    source = folder / "readings.csv"
    if directions is None:
        source.write_text("".join(f"{theta!r}\n" for theta in readings))
    else:
        source.write_text("encoder_deg,direction\n" + "".join(f"{t!r},{d:+d}\n" for t, d in zip(readings, directions)))
    status = main(["correct", "--exact", *options, str(path), str(source)])
    out, err = capsys.readouterr()
    assert status == 0, err
    return np.array([float(line) for line in out.split()])


def readable_by_the_command(readings, *values):
    """The readings ``encal correct`` reads (within +-MAX_ABS_DEG; the library and the runtime take any finite
    angle, the command refuses beyond it), with the matching items of each of ``values``."""
    keep = [abs(theta) <= MAX_ABS_DEG for theta in readings]
    return [[item for item, kept in zip(sequence, keep) if kept] for sequence in (readings, *values)]


def circular_gap(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert np.array_equal(np.isnan(a), np.isnan(b))
    keep = ~np.isnan(a)
    return float(np.max(np.abs((a[keep] - b[keep] + 180.0) % 360.0 - 180.0), initial=0.0))


def edge_readings(model):
    ulp = math.ulp(360.0)
    readings = [0.0, -0.0, 360.0 - ulp, 360.0, -360.0, 1e-300, -1e-17, 1.0, -1.0, 180.0, 359.5, 720.25, -1e10 - 0.5,
                1e15, 123.456, -123.456]
    readings += list(np.random.default_rng(3).uniform(-1080.0, 1080.0, 200))
    parts = [model.forward, model.reverse] if model.kind == "directional" else [model]
    for part in parts:
        if hasattr(part, "breaks_deg"):  # a table's nodes, just beside them and the middles between them
            nodes = part.breaks_deg[::max(1, part.breaks_deg.size // 40)]
            readings += [*nodes, *np.nextafter(nodes, -np.inf), *(0.5 * (nodes[:-1] + nodes[1:]))]
    if model.range_deg is not None:
        for end in model.range_deg:
            readings += [end + delta for delta in (0.0, 1e-12, -1e-12, 1e-9, -1e-9, 2e-9, -2e-9, 1e-3, -1e-3)]
    return [model.reading_sign * float(theta) for theta in readings]


def fitted_models(tmp_path):
    reference = np.arange(0.0, 360.0, 3.0)
    error = 2.0 * np.sin(np.radians(reference) + 0.4) + 0.7 * np.cos(np.radians(3 * reference))
    full = encal.Calibration(reference, reference + error / 60.0, name="full")
    reversed_ = encal.Calibration(reference, reference + error / 60.0, name="rev", reading_sign=-1)
    arc = np.arange(30.0, 150.0, 1.0)
    arc_cal = encal.Calibration(arc, arc + 2.0 * np.sin(np.radians(arc)) / 60.0, name="arc", reading_sign=-1)
    travel = np.repeat([1, -1], reference.size)
    both = np.concatenate([reference, reference[::-1]])
    both_error = np.concatenate([error, error[::-1]]) + 0.3 * travel
    models = {
        "lut cubic, reversed": encal.fit(reversed_, method="lut", interpolation="cubic"),
        "fourier, zero offset 37 deg": encal.fit(encal.Calibration(reference, reference + 37.0 + error / 60.0),
                                                 method="fourier", orders=[0, 1, 3]),
        "ann periodic": encal.fit(full, method="ann", hidden=5, epochs=10, rng=0),
        "ann raw": encal.fit(full, method="ann", hidden=5, epochs=10, rng=0, encoding="raw"),
        "directional, reversed": encal.fit(encal.Calibration(both, both + both_error / 60.0, direction=travel,
                                                             reading_sign=-1), method="fourier", orders=[0, 1, 3]),
        "arc, reversed": encal.fit(arc_cal),
    }
    return {label: save_model(model, tmp_path / f"{label.split(',')[0].replace(' ', '-')}-{i}.json")
            for i, (label, model) in enumerate(models.items())}


def test_every_kind_agrees_with_the_runtime_and_the_command(tmp_path, capsys):
    """Known truth is the runtime's formula (docs/model-file.md, in pure Python): encal's Model, its Compensator and
    `encal correct` agree with it to rounding, NaN for NaN, for every frozen model file and fitted variants."""
    paths = {p.name: p for p in sorted(DATA.glob("model_v*.json")) if "v3" not in p.name}  # encal has no 'sine'
    paths.update(fitted_models(tmp_path))
    for label, path in paths.items():
        model, stored, compensator = load_model(path), runtime.load(path), Compensator(path)
        readings = edge_readings(model)
        for direction in ((None, 1, -1) if model.kind == "directional" else (None,)):
            ours = np.array([stored.predict_arcmin(theta, direction) for theta in readings])
            theirs = model.predict(readings, direction=direction)
            assert np.array_equal(np.isnan(ours), np.isnan(theirs)), label
            assert np.nanmax(np.abs(ours - theirs)) <= ROUNDING_ARCMIN, label
            ours = [stored.correct_deg(theta, direction) for theta in readings]
            assert circular_gap(ours, model.correct(readings, direction)) <= ROUNDING_DEG, label
            assert circular_gap(ours, compensator.correct(readings, direction)) <= ROUNDING_DEG, label
            readable, values = readable_by_the_command(readings, ours)
            inside = [theta for theta, value in zip(readable, values) if not math.isnan(value)]
            options = () if direction is None else ("--direction", str(direction))
            command = corrected_by_the_command(capsys, tmp_path, path, inside, *options)
            assert circular_gap([value for value in values if not math.isnan(value)], command) <= ROUNDING_DEG, label
        if model.kind == "directional":
            directions = np.random.default_rng(0).choice([1, -1], len(readings)).tolist()
            readable, directions = readable_by_the_command(readings, directions)
            command = corrected_by_the_command(capsys, tmp_path, path, readable, directions=directions)
            ours = [stored.correct_deg(theta, d) for theta, d in zip(readable, directions)]
            assert circular_gap(ours, command) <= ROUNDING_DEG, label


def reversed_arc(tmp_path, start):
    model = FourierModel([0, 1], [0.5, 2.0], [0.0, 3.0])
    model.range_deg, model.reading_sign = [start, 140.0], -1
    return save_model(model, tmp_path / "reversed-arc.json")


def test_a_reversed_reading_at_an_arcs_end_is_inside_or_outside_for_all_alike(tmp_path, capsys):
    """Compensator (and so `encal correct`) wrapped a reversed encoder's reading before negating it: two roundings,
    an ulp from the format's (reading_sign * reading) mod 360, and at the tolerance of an arc's end the reading
    -20.052773416719354 was outside (refused, exit 1) for the command and inside for the model and the runtime."""
    start = 20.052773417719354
    path = reversed_arc(tmp_path, start)
    model, stored, compensator = load_model(path), runtime.load(path), Compensator(path)
    readings = [-(start - 1e-9) + k * math.ulp(start) for k in range(-40, 41)]
    readings += [theta + 360.0 for theta in readings] + [theta - 720.0 for theta in readings]
    ours = [stored.correct_deg(theta) for theta in readings]
    assert any(math.isnan(value) for value in ours) and not all(math.isnan(value) for value in ours)
    assert circular_gap(ours, model.correct(readings)) == 0.0
    assert circular_gap(ours, compensator.correct(readings)) == 0.0
    passed = corrected_by_the_command(capsys, tmp_path, path, readings, "--outside", "pass")
    expected = [stored.correct_deg(theta, outside="pass") for theta in readings]
    assert circular_gap(expected, passed) == 0.0
    inside = [theta for theta, value in zip(readings, ours) if not math.isnan(value)]
    assert circular_gap([stored.correct_deg(theta) for theta in inside],
                        corrected_by_the_command(capsys, tmp_path, path, inside)) == 0.0  # none refused


@pytest.mark.parametrize("rule", ["clamp", "pass"])
def test_the_command_outside_a_directional_arc_uses_the_readings_direction(tmp_path, capsys, rule):
    """`encal correct --outside clamp` corrected a reading outside a directional arc model with the mean of its two
    parts whatever its direction (0.3 arcmin off here, half the reversal); known truth: the part of its direction at
    the nearer end, the runtime's correct_deg(theta, direction, outside='clamp')."""
    forward, reverse = FourierModel([0, 1], [0.3, 2.0], [0.0, 3.0]), FourierModel([0, 1], [-0.3, 2.0], [0.0, 3.0])
    model = DirectionalModel(forward, reverse)
    model.range_deg = [300.0, 60.0]
    path = save_model(model, tmp_path / "directional-arc.json")
    stored = runtime.load(path)
    readings = [0.0, 59.0, 61.0, 100.0, 179.0, 181.0, 250.0, 299.0, 301.0]
    for direction in (1, -1):
        options = ("--outside", rule, "--direction", str(direction))
        command = corrected_by_the_command(capsys, tmp_path, path, readings, *options)
        known = [stored.correct_deg(theta, direction, outside=rule) for theta in readings]
        assert circular_gap(known, command) <= ROUNDING_DEG
    if rule == "clamp":  # at 100 degrees, past the end 60: the forward part there, 0.3 + 2 cos 60 + 3 sin 60
        assert known[3] == pytest.approx(100.0 - (-0.3 + 1.0 + 3.0 * math.sin(math.radians(60.0))) / 60.0, abs=1e-12)
    directions = [1, -1, 1, -1, 1, -1, 1, -1, 1]
    command = corrected_by_the_command(capsys, tmp_path, path, readings, "--outside", rule, directions=directions)
    known = [stored.correct_deg(theta, d, outside=rule) for theta, d in zip(readings, directions)]
    assert circular_gap(known, command) <= ROUNDING_DEG

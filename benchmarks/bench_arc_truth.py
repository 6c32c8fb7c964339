"""Arcs and two-encoder joints against known truth: every path that meets an angle outside a calibrated arc.

Task arc8. Two tables:

1. Arcs (a sum of harmonics plus 0.05 arcmin of noise, readings every 0.25 deg over arcs of 120 deg, one
   straddling 0, one of 30 deg, one of 350 deg (one gap of 10 deg: a full-turn model, no range), one written in
   (-180, 180]): the correction inside against the truth, the 2-sigma band's coverage inside and the model's
   uncertainty at the ends over the middle, then, for test readings 10 deg past each end, what each path does
   there: ``Model.predict`` (NaN?), ``encal.runtime`` (NaN?), ``encal correct`` by default (exit 1?), with
   ``--outside clamp`` and ``pass`` (the documented rule, to 1e-9 deg?), ``encal evaluate`` (exit 0, readings
   outside counted out?), and the host C of ``encal export --format c --outside clamp|pass`` compiled with gcc
   and run at angles inside, at the ends and outside (its in_range flag and correction against Python's rule;
   for cortex-m4f, at 16 bits, away from the ends by more than a code, where docs/in-place.md states its limits).
2. ``encal selfcal dual`` on simulated joints (``encal.selfcal.dual.simulate_dual``): the profiles against
   the truth on the orders the command says it separates, and what each wrong input does.

Run: ``PYTHONPATH=src python benchmarks/bench_arc_truth.py`` (about a minute; gcc for the C columns).
"""

import os
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

import encal
from encal import runtime
from encal._core.arcs import apply_outside_rule, inside
from encal._core.errors import InputError
from encal.selfcal.dual import dual, simulate_dual

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the known-truth helper of the dual tests
from tests.selfcal.test_dual import separable_rms  # noqa: E402

NOISE_ARCMIN = 0.05
CASES = (("120 deg", 30.0, 120.0, False), ("120 deg through 0", 300.0, 120.0, False), ("30 deg", 100.0, 30.0, False),
         ("350 deg", 5.0, 350.0, False), ("120 deg in (-180,180]", -150.0, 120.0, True))


def truth_arcmin(theta_deg):
    """The true error (arcmin) at the reference angle (degrees)."""
    t = np.deg2rad(theta_deg)
    return 3.0 * np.sin(t + 0.3) + 1.5 * np.cos(2 * t - 0.2) + 0.8 * np.sin(5 * t + 1.0) + 0.3 * np.cos(11 * t)


def truth_at_reading(reading_deg):
    """The true error as a function of the encoder reading (fixed point of reading = angle + error / 60)."""
    angle = np.asarray(reading_deg, dtype=float)
    for _ in range(8):
        angle = reading_deg - truth_arcmin(angle) / 60.0
    return truth_arcmin(angle)


def write_log(path, start, span, step, seed, negative, extra=0.0):
    rng = np.random.default_rng(seed)
    reference = start - extra + np.arange(0.0, span + 2 * extra + 1e-9, step)
    encoder = reference + (truth_arcmin(reference) + rng.normal(0.0, NOISE_ARCMIN, reference.size)) / 60.0
    wrap = (lambda a: (a + 180.0) % 360.0 - 180.0) if negative else (lambda a: a % 360.0)
    np.savetxt(path, np.column_stack([wrap(reference), wrap(encoder)]), delimiter=",",
               header="reference_deg,encoder_deg", comments="", fmt="%.9f")
    return wrap(encoder)


def cli(*argv):
    env = dict(os.environ, PYTHONPATH=str(Path(encal.__file__).resolve().parents[1]))
    done = subprocess.run([sys.executable, "-m", "encal", *map(str, argv)], env=env, capture_output=True, text=True)
    return done.returncode, done.stdout


def c_gap_deg(folder, model, angles, rule, *, near_end_deg=0.0):
    """Largest gap (deg) between the compiled C and Python's rule, and whether in_range agrees everywhere, at the
    angles farther than ``near_end_deg`` from an end (a compact table blends the two codes about a step: within a
    code of an end it may be up to the step off, and float's range test takes 2^-14 deg past an end as inside,
    as docs/in-place.md says)."""
    code = rc_main = None
    (folder / "main.c").write_text(
        '#include <stdio.h>\n#include <stdlib.h>\n#include "encal.h"\nint main(int argc, char **argv) { int i;\n'
        'for (i = 1; i < argc; ++i) { double a = atof(argv[i]); printf("%d %.12f\\n", encal_in_range(a), '
        '(double)encal_correct_deg((float)a)); } return 0; }\n')
    subprocess.run(["gcc", "-std=c99", "-O1", "-I", str(folder), str(folder / "main.c"), str(folder / "encal.c"),
                    "-lm", "-o", str(folder / "main")], check=True)
    # float in: the angles are compared as the C sees them (float32)
    angles32 = np.asarray(angles, dtype=np.float32).astype(float)
    far = np.min(np.abs((angles32[:, None] - np.asarray(model.range_deg)[None, :] + 180.0) % 360.0 - 180.0), axis=1)
    angles32 = angles32[far > near_end_deg]
    rc_main = subprocess.run([str(folder / "main"), *[repr(float(a)) for a in angles32]], capture_output=True,
                             text=True, check=True)
    rows = np.array([line.split() for line in rc_main.stdout.splitlines()], dtype=float)
    expected = apply_outside_rule(model, angles32, rule)
    code = np.abs((rows[:, 1] - expected + 180.0) % 360.0 - 180.0)
    return float(code.max()), bool(np.array_equal(rows[:, 0].astype(bool), inside(angles32, model.range_deg)))


def arc_table(folder):
    rows = []
    for label, start, span, negative in CASES:
        train, test = folder / "train.csv", folder / "test.csv"
        write_log(train, start, span, 0.25, 1, negative)
        test_readings = write_log(test, start, span, 0.37, 2, negative, extra=10.0)
        rc, _ = cli("fit", train, "-o", folder / "m.json")
        model = encal.load_model(folder / "m.json")
        row = {"case": label, "kind": model.kind, "fit": rc}
        rng_deg = model.range_deg
        if rng_deg is None:
            grid = np.arange(0.0, 360.0, 0.05)
            gap = ~inside(grid, (start % 360.0, (start + span) % 360.0))
            error = model.predict(grid) - truth_at_reading(grid)
            row.update(inside_rms=np.sqrt(np.mean(error[~gap] ** 2)), gap_max=np.abs(error[gap]).max())
            rows.append(row)
            continue
        s, e = rng_deg
        length = (e - s) % 360.0
        grid = s + np.linspace(0.0, length, 2001)
        mean, std = model.predict(grid, return_std=True)
        model_std = np.sqrt(np.maximum(std**2 - model.uncertainty["noise_std_arcmin"] ** 2, 0.0))
        error = mean - truth_at_reading(grid)
        outside = (e + np.linspace(0.5, (360.0 - length) - 0.5, 50)) % 360.0
        loaded = runtime.load(folder / "m.json")
        row.update(
            inside_rms=np.sqrt(np.mean(error**2)), coverage=np.mean(np.abs(error) <= 2 * model_std),
            ends_over_middle=min(model_std[0], model_std[-1]) / model_std[1000],
            predict_nan=bool(np.all(np.isnan(model.predict(outside)))),
            runtime_nan=bool(np.all(np.isnan([loaded.predict_arcmin(a) for a in outside]))),
            correct_default=cli("correct", folder / "m.json", test)[0])
        readings = np.loadtxt(test, delimiter=",", skiprows=1)[:, 1]
        for rule in ("clamp", "pass"):
            rc, out = cli("correct", folder / "m.json", test, "--outside", rule)
            got = np.array(out.split(), dtype=float)
            want = apply_outside_rule(model, readings, rule)
            row[f"correct_{rule}"] = f"{rc}, {np.abs((got - want + 180) % 360 - 180).max():.1e}" if rc == 0 else rc
        rc, out = cli("evaluate", folder / "m.json", test)
        row["evaluate"] = rc
        near = np.concatenate([[s, e, s - 1e-3, e + 1e-3, s - 0.01, e + 0.01], grid[::200], outside[::5],
                               test_readings[::40]])
        for target_name in ("host", "cortex-m4f"):
            for rule in ("clamp", "pass"):
                target = folder / f"c_{target_name}_{rule}"
                rc, _ = cli("export", folder / "m.json", "--format", "c", "--target", target_name, "--outside", rule,
                            "--bits", "16", "-o", target)
                code = 360.0 / 2**16 if target_name == "cortex-m4f" else 0.0
                gap = (c_gap_deg(target, model, near, rule, near_end_deg=code) if rc == 0 and shutil.which("gcc")
                       else (rc, None))
                row[f"{target_name}_{rule}"] = f"{gap[0] * 60:.3g}, {'agrees' if gap[1] else 'DIFFERS'}"
        rows.append(row)
    return rows


def dual_table():
    def separable_error(series, truth, side, confounded):
        return "{:.2f} of {:.2f}".format(*separable_rms(series, truth, side, confounded))

    rows = []
    for ratio, turns in ((6.0, 3.0), (7.5, 3.0), (-9.0, 3.0), (3.7, 3.0), (0.5, 3.0), (6.0, 1.3), (6.0, 0.8),
                         (1.0, 3.0)):
        motor, output, truth = simulate_dual(ratio, output_turns=turns, seed=3)
        cases = {"as given": (motor, output, ratio), "sign flipped": (motor, output, -ratio),
                 "columns swapped": (output, motor, ratio), "ratio x2": (motor, output, 2 * ratio),
                 "counts (14 bits)": (np.round(motor * 2**14 / 360) % 2**14, np.round(output * 2**14 / 360) % 2**14,
                                      ratio)}
        for what, (m, o, n) in cases.items():
            try:
                result = dual(m, o, n, pinion_teeth=12)
            except InputError as refused:
                rows.append((ratio, turns, what, "refused", str(refused)[:70]))
                continue
            motor_gap = separable_error(result.motor.series, truth["motor_at_reading"], 0, result.confounded)
            output_gap = separable_error(result.output.series, truth["output_at_reading"], 1, result.confounded)
            rows.append((ratio, turns, what, "exit 0", f"separable orders, arcmin RMS off of true: motor {motor_gap}, "
                         f"output {output_gap}; {len(result.confounded)} pairs named"))
    motor, output, _ = simulate_dual(6.0, seed=3, samples_per_motor_turn=2880, output_turns=1.5)
    try:
        counts = dual(np.round(motor * 2**16 / 360) % 2**16, np.round(output * 2**16 / 360) % 2**16, 6.0)
        rows.append((6.0, 1.5, "counts (16 bits, 2880 a turn)", "exit 0", f"{counts.output_turns:.4g} output turns"))
    except InputError as refused:
        rows.append((6.0, 1.5, "counts (16 bits, 2880 a turn)", "refused", str(refused)[:70]))
    # Whole-number ratio, the fast shaft's error the smaller; the prior of the confounded pairs
    # (motor j / output jN) follows each shaft's evidence scale, so the larger error takes them; the band now covers
    # the pair's whole amplitude (it covered 4 % and 6 % before arc8).
    motor, output, truth = simulate_dual(2.0, seed=3, motor_rms_arcmin=4.0, output_rms_arcmin=12.0)
    result = dual(motor, output, 2.0, pinion_teeth=12)
    grid = np.arange(0.0, 360.0, 2.0)
    for shaft in ("motor", "output"):
        got, want = getattr(result, shaft).error_arcmin(grid), truth[f"{shaft}_at_reading"](grid)
        miss = (got - got.mean()) - (want - want.mean())
        sigma = getattr(result, shaft).sigma_arcmin(grid)
        rows.append((2.0, 3.0, f"motor 4, output 12 arcmin RMS: {shaft}", "exit 0",
                     f"profile {np.sqrt(np.mean(miss**2)):.2f} arcmin RMS off (true {want.std():.2f}); 2-sigma band "
                     f"covers {np.mean(np.abs(miss) <= 2 * sigma):.0%}"))
    return rows


def main():
    warnings.simplefilter("ignore")
    with tempfile.TemporaryDirectory() as tmp:
        rows = arc_table(Path(tmp))
    print("| arc | kind | inside RMS off (arcmin) | 2-sigma coverage | sigma ends/middle | predict NaN | runtime NaN "
          "| correct (exit) | --outside clamp / pass (exit, max deg off) | evaluate (exit) | C host clamp / pass "
          "(max arcmin off the rule, in_range) | C cortex-m4f clamp / pass |")
    print("|---" * 12 + "|")
    for r in rows:
        if "coverage" not in r:
            print(f"| {r['case']} | {r['kind']} | {r['inside_rms']:.4f} (gap: max {r['gap_max']:.3f}) | - | - | - "
                  "| - | - | - | - | - | - |")
            continue
        print(f"| {r['case']} | {r['kind']} | {r['inside_rms']:.4f} | {r['coverage']:.1%} | {r['ends_over_middle']:.2f}"
              f" | {r['predict_nan']} | {r['runtime_nan']} | {r['correct_default']} | {r['correct_clamp']} / "
              f"{r['correct_pass']} | {r['evaluate']} | {r['host_clamp']} / {r['host_pass']} | {r['cortex-m4f_clamp']}"
              f" / {r['cortex-m4f_pass']} |")
    print()
    print("| ratio | output turns | input | result | detail |")
    print("|---|---|---|---|---|")
    for row in dual_table():
        print("| " + " | ".join(str(x) for x in row) + " |")


if __name__ == "__main__":
    main()

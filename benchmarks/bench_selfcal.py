"""Self-calibration without a precision reference: the goals of issue 15, measured on the simulators.

For each method and each simulated encoder (AS5047 class, 14 bit, 2 arcmin reading noise; first-harmonic
error of 0.5, 1 and 2 degrees; 2nd-4th harmonics as in ``draw_magnetic_encoder``) and seed:

- ``true`` : RMS of the true error (vs reading) at the orders the method reports, arcmin;
- ``miss`` : RMS of recovered minus true error over a 0.5-degree grid of readings, arcmin, and ``miss/true``
  (goal: <= 10 %);
- ``floor`` : the noise floor of the log: RMS of what the same method recovers from the same kind of log of
  an error-free encoder (same motor, noise and speeds; other seed), and ``miss/floor`` (goal: <= 2);
- ``σ`` : RMS over the grid of the stated standard uncertainty (one sigma), arcmin;
- ``cover`` : share of the grid where |recovered - true| <= 2 sigma (nominally 95 %).

Spin: 12-slot 14-pole motor (cogging at order 84), an unbalanced load (order-1 torque ripple of 3e-5 N m),
random drive torque of 1e-5 N m RMS; 20 revolutions at 2 and at 4 rev/s sampled at 2 kHz. One speed (4 rev/s)
is scored outside the orders it leaves out (multiples of 7 and 12) twice: all other orders, and all but
order 1, which the unbalanced load confounds.
Law: three speeds (1.5, 3, 6 rev/s) of an inertia-dominated rotor and of a damped one (viscous friction
3e-3 N m s, like the back-EMF damping of a voltage drive, and a larger unbalance): the chi-square of the
1/speed^2 law, and the miss with three speeds and with the first two.
Sweep: a moteus-style capture of 64 samples per electrical period, one revolution up and one down; a
7-pole-pair 12-slot motor and a 21-pole-pair 36-slot motor; scored outside the multiples of the pole pairs.
Steps: a 200-step stepper (4-step pattern of 4 arcmin RMS, tooth errors of 1 arcmin RMS), 10 readings per
step averaged and truncated to whole counts; two calibrations with the magnet turned by 137.5 degrees
(unknown to the method) starting at the same step. The stepper's error is scored per step, free and as
the 4-step-pattern-plus-tooth model; its floor is the miss on the error-free encoder's pair.
Real: the shift method on the Mechaduino repeat pairs of /work/shared/data/real (what it finds).

Run:  .venv/bin/python benchmarks/bench_selfcal.py [--seeds 3]
"""

import os

for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(variable, "1")

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from encal.data.calibration import read_calibration  # noqa: E402
from encal.selfcal import SpinLog, spin, steps, sweep  # noqa: E402
from encal.selfcal.synthetic import (MagneticEncoder, draw_magnetic_encoder, draw_stepper, make_motor,  # noqa: E402
                                    simulate_spin, simulate_steps, simulate_sweep)

GRID = np.arange(720) * 0.5
ECCENTRICITIES = (0.5, 1.0, 2.0)
REAL = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real" / "mechaduino"
REAL_PAIRS = [("kaiwol_2016-10-20_b", "kaiwol_2016-10-21"), ("jcchurch_2017-05-04_a", "jcchurch_2017-05-04_b"),
              ("jcchurch_2016-11-22", "jcchurch_2016-11-23_9"), ("jcchurch_2016-11-25", "jcchurch_2016-11-28"),
              ("jcchurch_2016-12-08", "jcchurch_2016-12-10"), ("jcchurch_2016-11-24", "jcchurch_2017-01-04"),
              ("proto_2016-03-17_a", "proto_2016-03-17_b")]


def rms(values):
    return float(np.sqrt(np.mean(np.square(values))))


def at_orders(values, orders):
    spectrum = np.fft.rfft(values)
    keep = np.zeros(spectrum.size)
    keep[np.asarray(list(orders), dtype=int)] = 1.0
    return np.fft.irfft(spectrum * keep, n=values.size)


def score(series, truth_values, floor_series=None):
    """true, miss, floor, cover of ``series`` against the truth at its orders."""
    truth = at_orders(truth_values, series.orders)
    miss = series.evaluate(GRID) - truth
    floor = rms(floor_series.evaluate(GRID)) if floor_series is not None else float("nan")
    return {"true": rms(truth), "miss": rms(miss), "floor": floor, "sigma": rms(series.sigma(GRID)),
            "cover": float(np.mean(np.abs(miss) <= 2 * series.sigma(GRID)))}


def row(label, s):
    ratio = s["miss"] / s["floor"] if np.isfinite(s["floor"]) else float("nan")
    return (f"| {label} | {s['true']:.2f} | {s['miss']:.3f} | {100 * s['miss'] / s['true']:.1f} % | "
            f"{s['floor']:.3f} | {ratio:.2f} | {s['sigma']:.3f} | {100 * s['cover']:.0f} % |")


def spin_logs(motor, encoder, seed, speeds=(2.0, 4.0)):
    logs = []
    for i, speed in enumerate(speeds):
        run = simulate_spin(motor, encoder, speed, revolutions=20, sample_rate_hz=2000.0, rng=seed * 10 + i,
                            torque_noise_nm=1e-5)
        logs.append(SpinLog(run.time_s, run.encoder_deg, f"{speed}"))
    return logs


def bench_spin(seeds):
    perfect = MagneticEncoder((), noise_arcmin=2.0, bits=14)
    rows = {"two": [], "one": [], "one_but_1": []}
    for seed in range(seeds):
        motor = make_motor(7, 12, 100 + seed, unbalance_nm=3e-5)
        floor_logs = spin_logs(motor, perfect, 1000 + seed)
        floor_two = spin(floor_logs, pole_pairs=7, slots=12).series
        floor_one = spin(floor_logs[1:], pole_pairs=7, slots=12).series
        for ecc in ECCENTRICITIES:
            encoder = draw_magnetic_encoder(seed, eccentricity_deg=ecc)
            truth = encoder.error_at_reading(GRID)
            logs = spin_logs(motor, encoder, seed)
            two = spin(logs, pole_pairs=7, slots=12).series
            one = spin(logs[1:], pole_pairs=7, slots=12).series
            case = f"{ecc:g}°, seed {seed}"
            rows["two"].append((case, score(two, truth, floor_two)))
            rows["one"].append((case, score(one, truth, floor_one)))
            rows["one_but_1"].append((case, score(one.without([1]), truth, floor_one.without([1]))))
    return rows


def bench_law(seeds):
    """Three speeds, inertia-dominated and damped (viscous 3e-3 N m s, as back-EMF damping of a voltage drive)."""
    rows = []
    for seed in range(seeds):
        encoder = draw_magnetic_encoder(seed, eccentricity_deg=1.0)
        truth = encoder.error_at_reading(GRID)
        for label, motor in (("inertia-dominated", make_motor(7, 12, 100 + seed, unbalance_nm=3e-5)),
                             ("damped", make_motor(7, 12, 100 + seed, unbalance_nm=3e-4, viscous_nm_s=3e-3))):
            logs = spin_logs(motor, encoder, 500 + seed, speeds=(1.5, 3.0, 6.0))
            three = spin(logs, pole_pairs=7, slots=12)
            two = spin(logs[:2], pole_pairs=7, slots=12)
            rows.append((f"{label}, seed {seed}", three.details["ripple_law_chi2_per_dof"],
                         score(three.series, truth), score(two.series, truth)))
    return rows


def print_law(rows):
    print("\n### Spin at three speeds: the 1/speed^2 law checked (encoder 1°, arcmin)\n\n"
          "| rotor | chi2/dof | miss/true, 3 speeds | miss/true, 2 speeds (1.5, 3) | cover ±2σ, 3 speeds |\n"
          "|---|---|---|---|---|")
    for label, law, three, two in rows:
        print(f"| {label} | {law:.3g} | {100 * three['miss'] / three['true']:.1f} % | "
              f"{100 * two['miss'] / two['true']:.1f} % | {100 * three['cover']:.0f} % |")


def bench_sweep(seeds):
    perfect = MagneticEncoder((), noise_arcmin=2.0, bits=14)
    rows = {}
    for pole_pairs, slots in ((7, 12), (21, 36)):
        rows[(pole_pairs, slots)] = []
        for seed in range(seeds):
            motor = make_motor(pole_pairs, slots, 200 + seed)

            def run(encoder, rng, **options):
                capture = simulate_sweep(motor, encoder, rng=rng)
                return sweep(capture.phase * 360 / 65536, capture.encoder * 360 / 65536,
                             np.where(np.isin(capture.direction, (1, 3)), 1, -1), pole_pairs, **options)

            variants = [("", {})] + ([(", --slots 12", {"slots": 12})] if slots == 12 else [])
            for suffix, options in variants:
                floor = run(perfect, 2000 + seed, **options).series
                for ecc in ECCENTRICITIES:
                    encoder = draw_magnetic_encoder(seed, eccentricity_deg=ecc)
                    result = run(encoder, seed, **options)
                    rows[(pole_pairs, slots)].append((f"{ecc:g}°, seed {seed}{suffix}",
                                                      score(result.series, encoder.error_at_reading(GRID), floor),
                                                      result.details["lag_arcmin"]))
    return rows


def bench_steps(seeds, turn=137.5):
    perfect = MagneticEncoder((), noise_arcmin=2.0, bits=14)
    rows = []
    for seed in range(seeds):
        stepper = draw_stepper(300 + seed)
        floor_a = simulate_steps(stepper, perfect, rng=3000 + seed)
        floor_b = simulate_steps(stepper, perfect.turned(turn), rng=4000 + seed)
        floor_result = steps(floor_a.calibration, floor_b.calibration)
        floor = floor_result.series
        floor_truth = floor_a.stepper_error_arcmin - floor_a.stepper_error_arcmin.mean()
        stepper_floor = {key: rms(floor_result.details[key] - floor_truth)
                         for key in ("stepper_error_arcmin", "stepper_model_arcmin")}
        for ecc in ECCENTRICITIES:
            encoder = draw_magnetic_encoder(seed, eccentricity_deg=ecc)
            first = simulate_steps(stepper, encoder, rng=seed)
            second = simulate_steps(stepper, encoder.turned(turn), rng=seed + 50)
            result = steps(first.calibration, second.calibration)
            truth = first.stepper_error_arcmin - first.stepper_error_arcmin.mean()
            stepper_scores = {}
            for key, sigma_key in (("stepper_error_arcmin", "stepper_sigma_arcmin"),
                                   ("stepper_model_arcmin", "stepper_model_sigma_arcmin")):
                miss = result.details[key] - truth
                stepper_scores[key] = (rms(truth), rms(miss), stepper_floor[key],
                                       float(np.mean(np.abs(miss) <= 2 * result.details[sigma_key])))
            rows.append((f"{ecc:g}°, seed {seed}", score(result.series, encoder.error_at_reading(GRID), floor),
                         stepper_scores,
                         result.details["turn_deg"]))
    return rows


def bench_real():
    lines = []
    for a, b in REAL_PAIRS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            first = read_calibration(next(REAL.glob(f"mech_{a}*.csv")))
            second = read_calibration(next(REAL.glob(f"mech_{b}*.csv")))
        result = steps(first, second)
        d = result.details
        kind = ("repeat (not turned)" if d["repeat"] else
                f"turned {d['turn_deg']:.1f} deg, shift {d['step_shift']}")
        single = steps(first).details["stepper_pattern_rms_arcmin"]
        offset = np.degrees(np.angle(np.mean(np.exp(1j * np.radians(second.encoder_deg - first.encoder_deg)))))
        lines.append(f"| {a} / {b} | {offset / 1.8:.3f} | {kind} | {d['difference_residual_rms_arcmin']:.2f} | "
                     f"{single:.2f} | {d['stepper_error_rms_arcmin']:.2f} |")
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--parts", nargs="+", choices=("spin", "law", "sweep", "steps", "real"),
                        default=("spin", "law", "sweep", "steps", "real"))
    args = parser.parse_args()
    start = time.process_time()
    header = ("| case | true | miss | miss/true | floor | miss/floor | σ (RMS) | cover ±2σ |\n"
              "|---|---|---|---|---|---|---|---|")
    print(f"load average at start: {open('/proc/loadavg').read().split()[:3]}")
    if "spin" in args.parts:
        print_spin(bench_spin(args.seeds), header)
    if "law" in args.parts:
        print_law(bench_law(args.seeds))
    if "sweep" in args.parts:
        print_sweep(bench_sweep(args.seeds), header)
    if "steps" in args.parts:
        print_steps(bench_steps(args.seeds), header)
    if "real" in args.parts and REAL.is_dir():
        print("\n### Real Mechaduino repeat pairs\n\n| pair | offset (full steps) | found | difference residual RMS | "
              "4-step pattern RMS (one calibration) | stepper error RMS |\n|---|---|---|---|---|---|")
        print("\n".join(bench_real()))
    print(f"\nCPU time {time.process_time() - start:.0f} s; load average at end: "
          f"{open('/proc/loadavg').read().split()[:3]}")


def print_spin(spin_rows, header):
    print("\n### Spin (arcmin)\n\n" + header)
    for key, label in (("two", "two speeds, all orders 1-32"), ("one", "one speed, orders kept"),
                       ("one_but_1", "one speed, orders kept but 1")):
        for ecc, s in spin_rows[key]:
            print(row(f"{label}, {ecc}", s))


def print_sweep(sweep_rows, header):
    print("\n### Sweep (arcmin)\n\n" + header)
    for (p, slots), entries in sweep_rows.items():
        for ecc, s, lag in entries:
            print(row(f"{p} pole pairs, {slots} slots, {ecc} (lag {lag:.2f} arcmin)", s))


def print_steps(step_rows, header):
    print("\n### Steps, two calibrations turned 137.5° (arcmin)\n\n" + header)
    for ecc, s, _, turn in step_rows:
        print(row(f"encoder, {ecc} (turn found {turn:.2f}°)", s))
    print("\n| stepper error | true RMS | miss RMS | miss/true | floor | miss/floor | cover ±2σ |\n"
          "|---|---|---|---|---|---|---|")
    for ecc, _, stepper_scores, _ in step_rows:
        for key, label in (("stepper_error_arcmin", "per step"), ("stepper_model_arcmin", "pattern + tooth")):
            true, miss, floor, cover = stepper_scores[key]
            print(f"| {label}, encoder {ecc} | {true:.2f} | {miss:.3f} | {100 * miss / true:.1f} % | {floor:.3f} | "
                  f"{miss / floor:.2f} | {100 * cover:.0f} % |")


if __name__ == "__main__":
    main()

"""Every model family on the real AS5047D calibrations of shared/data/real/mechaduino.

Usage::

    python benchmarks/bench_real_data.py                 # both protocols, about 50 s (2026-11-28)
    python benchmarks/bench_real_data.py --protocol even-odd
    python benchmarks/bench_real_data.py --data PATH     # another copy of the data folder

Two protocols:

``even-odd``
    Within one calibration: fit on the even rows (full steps 0, 2, 4, ...),
    test on the odd rows. Every file.
``repeat``
    Fit on one calibration, test on the repeat calibrations of the same board:
    the files listed in its ``similar_r>0.9`` column of ``index.csv`` that come
    from the same repository (a high correlation across repositories is a
    similar magnet mount, not the same board). The motor's start position, and
    so the arbitrary zero of ``encoder - reference``, differs between repeats:
    each file's circular-mean offset is removed before fitting and testing, so
    the comparison is of the profiles' shapes. Repeats are pooled into one RMS.

Per file: test RMS (arcmin) of every method, the best single method, auto, and
auto / best. Then a summary per protocol. The repeat protocol reads the encoder
at the calibrated steps, so there auto runs with ``use_grid=True`` (validated at
the steps; docs/model-selection.md); even-odd reads between them (the default). One seed (0) for the randomised
methods; the 60 files average the luck of any one initialisation.

The last column, "step parity", is the amplitude (arcmin) of the pattern that
alternates from one full step to the next, ``|mean((-1)^k e_k)|`` over all the rows
k of the training file: the stepper's alternate full steps land
unevenly, an error of the reference that repeats in every calibration of the
same motor but cannot be predicted between calibration points.
"""

import os

# One BLAS thread: the matrices are small and a threaded BLAS contends on 2 cores.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import csv  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import encal  # noqa: E402
from _methods import METHODS, RANDOMISED  # noqa: E402  (benchmarks/_methods.py)

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "real" / "mechaduino"

SINGLE = [name for name in METHODS if name != "auto"]
#: auto may be this much worse than the best single method (fraction of RMS)
GOAL = 0.02


def without_offset(cal):
    """The calibration with its circular-mean offset ``encoder - reference`` removed."""
    difference = np.radians(cal.encoder_deg - cal.reference_deg)
    offset = np.degrees(np.arctan2(np.sin(difference).mean(), np.cos(difference).mean()))
    return encal.Calibration(cal.reference_deg + offset, cal.encoder_deg, name=cal.name)


def step_parity_arcmin(cal):
    """Amplitude of the error pattern alternating between consecutive rows (full steps), arcmin."""
    error = cal.errors_arcmin
    return float(abs(np.mean(error * (-1.0) ** np.arange(error.size))))


def test_rms(train_cal, test_cals, seed=0, auto_options=None):
    """Pooled test RMS (arcmin) of every method, auto's chosen candidate and CPU seconds, and the residuals."""
    result, chosen, seconds, residual = {}, None, 0.0, {}
    for name, (method, options) in METHODS.items():
        if name == "auto":
            options = {**options, **(auto_options or {})}
        start = time.process_time()
        model = encal.fit(train_cal, method=method, rng=seed if method in RANDOMISED else None, **options)
        if name == "auto":
            chosen = model.training["selection"]["chosen"]
            seconds = time.process_time() - start
        residuals = np.concatenate([encal.evaluate(model, cal).residual_arcmin for cal in test_cals])
        result[name] = float(np.sqrt(np.mean(residuals**2)))
        residual[name] = residuals
    return result, chosen, seconds, residual


def paired_z(residual_a, residual_b):
    """How many standard errors the mean square of ``residual_a`` exceeds that of ``residual_b`` by,
    the two residuals being at the same test points (the paired difference of their squares)."""
    difference = residual_a**2 - residual_b**2
    return float(np.mean(difference) / (np.std(difference, ddof=1) / np.sqrt(difference.size)))


def read_index(folder):
    with open(folder / "index.csv", newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def even_odd_cases(folder, rows):
    for row in rows:
        cal = encal.read_calibration(folder / row["file"], name=row["file"])
        even = np.arange(len(cal)) % 2 == 0
        yield row["file"], cal.subset(even), [cal.subset(~even)], step_parity_arcmin(cal)


def repeat_cases(folder, rows):
    by_stem = {row["file"].removesuffix(".csv"): row for row in rows}
    for row in rows:
        repeats = [by_stem[stem] for stem in row["similar_r>0.9"].split() if stem in by_stem]
        repeats = [other for other in repeats if other["repo"] == row["repo"]]
        if not repeats:
            continue
        train_cal = without_offset(encal.read_calibration(folder / row["file"], name=row["file"]))
        test_cals = [without_offset(encal.read_calibration(folder / other["file"])) for other in repeats]
        yield f"{row['file']} -> {len(repeats)} repeat(s)", train_cal, test_cals, step_parity_arcmin(train_cal)


def short(name):
    return name.removeprefix("mech_").removesuffix(".csv")


def run(protocol, cases, auto_options=None):
    print(f"\n## Protocol: {protocol}\n")
    print("| file | " + " | ".join(METHODS) + " | best single | auto chose | auto / best | step parity |")
    print("|---|" + "---|" * (len(METHODS) + 4))
    ratios, wins, chosen_families, seconds, table = [], Counter(), Counter(), [], {name: [] for name in METHODS}
    for label, train_cal, test_cals, parity in cases:
        rms, chosen, elapsed, residual = test_rms(train_cal, test_cals, auto_options=auto_options)
        best = min(SINGLE, key=rms.get)
        ratio = rms["auto"] / rms[best]
        ratios.append((ratio, label, best, chosen, paired_z(residual["auto"], residual[best])))
        wins[best] += 1
        chosen_families[chosen.split()[0]] += 1
        seconds.append(elapsed)
        for name in METHODS:
            table[name].append(rms[name])
        flag = " **>2%**" if ratio > 1 + GOAL else ""
        print(f"| {short(label)} | " + " | ".join(f"{rms[name]:.3f}" for name in METHODS)
              + f" | {best} | {chosen} | {ratio:.3f}{flag} | {parity:.2f} |")

    values = np.array([r[0] for r in ratios])
    failures = [r for r in ratios if r[0] > 1 + GOAL]
    print(f"\n### Summary ({protocol}, {len(ratios)} files)\n")
    print("| method | median RMS | geometric-mean RMS | files where best |")
    print("|---|---|---|---|")
    for name in METHODS:
        column = np.array(table[name])
        print(f"| {name} | {np.median(column):.3f} | {np.exp(np.mean(np.log(column))):.3f} | "
              f"{wins.get(name, '-') if name != 'auto' else '-'} |")
    print(f"\n- auto / best single: median {np.median(values):.3f}, worst {values.max():.3f}; "
          f"within {GOAL:.0%} on {len(values) - len(failures)} of {len(values)} files")
    print(f"- auto chose: {', '.join(f'{family} {count}' for family, count in chosen_families.most_common())}")
    print(f"- auto fit CPU time: median {np.median(seconds):.2f} s, max {np.max(seconds):.2f} s")
    if failures:
        print(f"- more than {GOAL:.0%} worse than the best single method (z: the difference of the mean "
              "squares in standard errors of its paired difference; below 2, one test run cannot tell it "
              "from a tie):")
        for ratio, label, best, chosen, z in sorted(failures, reverse=True):
            print(f"  - {short(label)}: {ratio:.3f} (best {best}, auto chose {chosen}; z {z:.1f})")
        real = sum(z >= 2.0 for *_, z in failures)
        print(f"- of these, {real} with z >= 2")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--protocol", choices=["even-odd", "repeat", "both"], default="both")
    parser.add_argument("--data", type=Path, default=DATA, help="folder with index.csv and the CSV files")
    args = parser.parse_args()
    rows = read_index(args.data)
    print("# Real AS5047D calibrations (Mechaduino), test RMS in arcmin")
    print(f"python {platform.python_version()}, numpy {np.__version__}, {os.cpu_count()} cores, "
          f"{platform.machine()}; data: {len(rows)} files of {args.data}")
    if args.protocol in ("even-odd", "both"):
        run("even-odd (fit on even rows, test on odd rows)", even_odd_cases(args.data, rows))
    if args.protocol in ("repeat", "both"):
        # The repeats are read at the same full steps: auto validates for readings at the steps.
        run("repeat (fit on one calibration, test on the same board's repeats, offsets removed; "
            "auto with use_grid=True)", repeat_cases(args.data, rows), auto_options={"use_grid": True})


if __name__ == "__main__":
    main()

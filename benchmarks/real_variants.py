"""The spectral model's blind variants on the real AS5047D files (even/odd), against the best single method.

Usage::

    python benchmarks/bench_real_data.py --protocol even-odd > real.md    # once: every method
    python benchmarks/real_variants.py real.md uniform noise half gcv
    python benchmarks/real_variants.py real.md networks   # auto with the networks cross-validated against it
    python benchmarks/real_variants.py real.md cv         # the cross-validated choice (folds=5, seed 0)

The best single method's test RMS per file is read from the output of bench_real_data.py (its
table), so that the networks are not refitted for every variant of the blind split.
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import encal  # noqa: E402
from encal.models import spectral  # noqa: E402

from bench_real_data import DATA, METHODS, SINGLE, even_odd_cases, read_index, short  # noqa: E402


def best_single(table_path):
    """file stem -> the best single method's test RMS (arcmin), from bench_real_data.py's even-odd table."""
    names = list(METHODS)
    best = {}
    for line in open(table_path, encoding="utf-8"):
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if len(cells) == len(names) + 5 and cells[0] not in ("file", "---"):
            try:
                values = dict(zip(names, map(float, cells[1:len(names) + 1])))
            except ValueError:
                continue
            best.setdefault(cells[0], min(values[name] for name in SINGLE))
    return best


def main():
    table, variants = sys.argv[1], sys.argv[2:] or list(spectral.BLIND_SPLITS)
    best = best_single(table)
    rows = read_index(DATA)
    ratios = {variant: [] for variant in variants}
    networks_chosen, cpu = 0, {variant: [] for variant in variants}
    for label, train, tests, _ in even_odd_cases(DATA, rows):
        for variant in variants:
            start = time.process_time()
            if variant == "networks":  # encal fit --networks: the default split, networks cross-validated
                model = encal.fit(train, method="auto", networks=True, rng=0)
                networks_chosen += model.training["selection"]["chosen"] != "spectral"
            elif variant == "cv":  # encal fit --folds 5: the cross-validated choice among the families
                model = encal.fit(train, method="auto", folds=5, rng=0)
            else:
                spectral.BLIND_SPLIT = variant
                model = encal.fit(train, method="auto")
            cpu[variant].append(time.process_time() - start)
            residual = np.concatenate([encal.evaluate(model, cal).residual_arcmin for cal in tests])
            ratios[variant].append(float(np.sqrt(np.mean(residual**2))) / best[short(label)])
    print("| blind split | median auto / best single | worst | files within 2 % | fit CPU, s: all, median, max |")
    print("|---|---|---|---|---|")
    for variant, values in ratios.items():
        values = np.array(values)
        print(f"| {variant} | {np.median(values):.3f} | {values.max():.3f} | {int(np.sum(values <= 1.02))} of "
              f"{values.size} | {sum(cpu[variant]):.1f}, {np.median(cpu[variant]):.2f}, {max(cpu[variant]):.2f} |")
    if "networks" in variants:
        print(f"\nwith --networks a network was chosen on {networks_chosen} of {len(ratios['networks'])} files")


if __name__ == "__main__":
    main()

"""Does the report's comparison agree with `encal fit`'s choice on the real Mechaduino files, or say why not?

    python benchmarks/bench_report_consistency.py [--limit N]

For each of the 60 real AS5047D calibrations (../shared/data/real/mechaduino/, 200 full steps), two reports
(``encoder_report(..., uncertainty=False, rng=0)``, the default model):

- **alone**: the whole file, the comparison by interleaved 5-fold cross-validation;
- **even/odd**: fitted on the even full steps, every candidate scored on the odd ones (a test calibration,
  points none of them saw).

Prints, per file, where encal fit's choice ranks among the 12 candidates and whether the page carries the
sentence that says which figure to trust (``EncoderReport.comparison_note``), then a summary. A choice that
ranks more than 5 % behind the best without that sentence is a contradiction the page leaves unexplained:
the script exits 1 if there is one. This is the table of RESULTS.md "The report's one truth".
"""

import argparse
import sys
from pathlib import Path

import numpy as np

import encal
from encal.encoder_report import encoder_report
from encal.models.choice import is_chosen

REAL = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real" / "mechaduino"


def rank(report):
    table = report.comparison
    rows = sorted((r for r in table["table"] if r.get("cv_rms_arcmin") is not None), key=lambda r: r["cv_rms_arcmin"])
    chosen = next(r for r in rows if is_chosen(r, table))
    return rows.index(chosen) + 1, len(rows), chosen["cv_rms_arcmin"] / rows[0]["cv_rms_arcmin"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=int, default=None)
    args = parser.parse_args()
    files = sorted(p for p in REAL.glob("mech_*.csv"))[:args.limit]
    print("| file | alone: rank, ratio to best, sentence | even/odd: rank, ratio to best, sentence |")
    print("|---|---|---|")
    summary = {"alone": [], "even/odd": []}
    for path in files:
        cal = encal.read_calibration(path)
        steps = np.arange(len(cal))
        even, odd = cal.subset(steps % 2 == 0), cal.subset(steps % 2 == 1)
        cells = []
        for scheme, (train, tests) in (("alone", (cal, [])), ("even/odd", (even, [odd]))):
            report = encoder_report(train, tests, uncertainty=False, rng=0, compare=True)
            position, count, ratio = rank(report)
            said = bool(report.comparison_note)
            summary[scheme].append((position, ratio, said))
            cells.append(f"{position} of {count}, {ratio:.2f}, {'yes' if said else 'no'}")
        print(f"| {path.stem} | {cells[0]} | {cells[1]} |", flush=True)
    failures = 0
    for scheme, rows in summary.items():
        first = sum(position == 1 for position, _, _ in rows)
        close = sum(ratio <= 1.05 for _, ratio, _ in rows)
        said = sum(s for _, _, s in rows)
        unexplained = sum(ratio > 1.05 and not s for _, ratio, s in rows)
        failures += unexplained
        print(f"\n{scheme}: {len(rows)} files; encal fit's choice first on {first}, within 5 % of the best on {close}; "
              f"the page says which figure to trust on {said}; unexplained contradictions: {unexplained}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

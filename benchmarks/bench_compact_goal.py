"""Compact tables against the goal on real encoders: deployed error within 1 % of the model's test RMS.

    python benchmarks/bench_compact_goal.py

For pairs of repeat calibrations of one AS5047D board (14-bit; ../shared/data/real/mechaduino,
pairs that index.csv marks as repeats), fits a model to the first (``auto``, seed 0, and a
10-term Fourier series), measures its test RMS on the second (after compensation, the offset of
the arbitrary reference zero removed), and finds, for linear and for cubic B-spline
interpolation, the smallest cortex-m4f compact table whose deployed error (max over all 16,384
codes) is within 1 % of that test RMS, and the one the default tolerance (a tenth of an LSB,
0.132 arcmin) gives. Prints nodes, dtype, bytes and the deployed error; the instructions per
reading of a table do not depend on its size (bench_mcu.py).
"""

import os
from pathlib import Path

import numpy as np

import encal
from encal.deploy import Compensator
from encal.deploy.compact import choose_compact

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real" / "mechaduino"
PAIRS = [("mech_jcchurch_2016-11-22_9d73d2c6.csv", "mech_jcchurch_2016-11-23_96c09994.csv"),
         ("mech_jcchurch_2016-11-24_4a2ae585.csv", "mech_jcchurch_2016-11-25_7e521b9f.csv"),
         ("mech_kaiwol_2016-10-20_b_92fa4feb.csv", "mech_kaiwol_2016-10-21_9d58ebc8.csv")]


def test_rms(model, cal):
    residual = cal.errors_arcmin - model.predict(cal.encoder_deg)
    residual -= np.mean(residual)  # the two runs' reference zeros differ
    return float(np.sqrt(np.mean(residual**2)))


def main():
    print(f"# load average {os.getloadavg()[0]:.2f}")
    print("| train / test | model | test RMS, arcmin | tolerance | interpolation | table | bytes | "
          "deployed max / RMS, arcmin | met |")
    print("|---|---|---|---|---|---|---|---|---|")
    for train_name, test_name in PAIRS:
        train = encal.read_calibration(REAL / train_name)
        test = encal.read_calibration(REAL / test_name)
        for label, method, options in (("auto", "auto", {"rng": 0}), ("fourier, 10 terms", "fourier",
                                                                      {"n_orders": 10})):
            model = encal.fit(train, method=method, **options)
            comp = Compensator(model)
            rms = test_rms(model, test)
            for name, tolerance in (("1 % of test RMS", 0.01 * rms), ("0.1 LSB", None)):
                for interpolation in ("linear", "cubic"):
                    table, met = choose_compact(comp, tolerance_arcmin=tolerance, interpolations=(interpolation,))
                    print(f"| {train_name[5:-13]} / {test_name[5:-13]} | {label}: {model.kind} | {rms:.3g} | "
                          f"{name} | {interpolation} | {table.nodes}-node {table.dtype} | {table.table_bytes} | "
                          f"{table.max_error_arcmin:.3g} / {table.rms_error_arcmin:.3g} | {'yes' if met else 'NO'} |",
                          flush=True)


if __name__ == "__main__":
    main()

"""Write a dense calibration CSV: a continuous sweep over several revolutions (motion control).

Usage::

    python benchmarks/dense_sweep.py ROWS OUT.csv [--revolutions R] [--noise-only] [--seed S]

Each revolution visits the same ROWS / R reference angles, equally spaced, so every angle is read R
times. The error is orders 1, 2, 16, 32 and 48 (3, 1.5, 0.6, 0.3 and 0.2 arcmin) plus Gaussian noise of
0.1 arcmin (only the noise with ``--noise-only``); angles are written with 10 decimals. Used for the
"reading a calibration" and "dense calibrations" figures of BENCHMARKS.md.
"""

import argparse

import numpy as np

HARMONICS = ((1, 3.0, 0.3), (2, 1.5, 1.1), (16, 0.6, 2.0), (32, 0.3, 0.5), (48, 0.2, 2.5))  # order, arcmin, rad


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rows", type=int)
    parser.add_argument("out")
    parser.add_argument("--revolutions", type=int, default=5)
    parser.add_argument("--noise-only", action="store_true")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    stops = args.rows // args.revolutions
    reference = np.tile(np.arange(stops) * 360.0 / stops, args.revolutions)
    error = rng.normal(0.0, 0.1, reference.size)
    if not args.noise_only:
        for order, amplitude, phase in HARMONICS:
            error += amplitude * np.cos(order * np.radians(reference) + phase)
    encoder = np.mod(reference + error / 60.0, 360.0)
    with open(args.out, "w", encoding="ascii") as handle:
        handle.write("reference_deg,encoder_deg\n")
        np.savetxt(handle, np.column_stack([reference, encoder]), fmt="%.10f", delimiter=",")


if __name__ == "__main__":
    main()

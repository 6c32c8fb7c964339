"""How far above the spectral model's noise floor the noise of real and simulated calibrations lies.

Usage::

    PYTHONPATH=src python benchmarks/bench_noise_floor.py [--data PATH]

The spectral model estimates the noise variance no lower than ``exp(-NOISE_FLOOR_NATS)`` of the data's mean
square (``encal.models._evidence``). For every blind search of a spectral fit of the 60 real AS5047D calibrations
(``shared/data/real/mechaduino``, skipped when absent) and of the encoders ``encal simulate`` writes (the README's,
train, test, epoch and decoder files of 4 encoders), this prints the smallest and the median ratio of the noise
variance found to the floor: a ratio near 1 would mean the floor decides a real fit's noise.
"""

import argparse
import math
import tempfile
import warnings
from pathlib import Path

import numpy as np

import encal
from encal.models import _evidence

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "real" / "mechaduino"


def ratios_of(paths):
    ratios = []
    original = _evidence.fit_hyperparameters

    def recording(design, **options):
        hyper, post = original(design, **options)
        if not hyper.noise_fixed:
            ratios.append(hyper.noise_var / (math.exp(-_evidence.NOISE_FLOOR_NATS) * design.scale))
        return hyper, post

    _evidence.fit_hyperparameters = recording
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for path in paths:
                encal.fit(encal.read_calibration(path, allow_gaps=True), "spectral")
    finally:
        _evidence.fit_hyperparameters = original
    return np.array(ratios)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA)
    args = parser.parse_args()
    print("| calibrations | files | blind searches | smallest noise variance / floor | median |\n|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        import contextlib
        import io

        from encal.cli import main as cli

        with contextlib.redirect_stdout(io.StringIO()):
            cli(["simulate", "--encoders", "4", "--out", folder])
        suites = {"simulated (encal simulate, 4 encoders)": sorted(Path(folder).glob("*.csv"))}
        if args.data.is_dir():
            suites["real AS5047D (Mechaduino)"] = sorted(args.data.glob("mech_*.csv"))
        for label, paths in suites.items():
            ratios = ratios_of(paths)
            print(f"| {label} | {len(paths)} | {ratios.size} | {ratios.min():.3g} | {np.median(ratios):.3g} |")


if __name__ == "__main__":
    main()

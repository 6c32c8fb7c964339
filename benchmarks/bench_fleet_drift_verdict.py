"""The fleet report's drift verdict on unchanged units: the RMS change of a unit's profile between two calibrations
against the two models' uncertainties combined (fleet8; docs/production.md, "The fleet report").

Usage::

    python benchmarks/bench_fleet_drift_verdict.py [--units 20]

Each unit of ``encal.simulate.simulate_fleet(units, seed=11)`` is fitted by the spectral model on its training run
and on a second run over the same grid at the same epoch with fresh noise (``calibration_run(..., rng=99)``): an
unchanged unit calibrated twice. Printed per unit: the ratio ``d / sqrt(u1² + u2²)``, ``d`` the RMS difference of
the two profiles (zero offsets removed, 360 angles), ``u`` each posterior's ``σ_model`` RMS over the turn, as
:func:`encal.fleet.statistics.drift_table` computes them; and the same ratio for the simulator's own second epoch
(``epoch2``: a drifted mount and resolver). The verdict calls a unit *moved* above
:data:`encal.fleet.statistics.DRIFT_MOVED`.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from encal.fleet.statistics import DRIFT_MOVED  # noqa: E402
from encal.models.fitting import fit  # noqa: E402
from encal.simulate import simulate_fleet  # noqa: E402
from encal.simulate._run import TRAINING_GRID_DEG, calibration_run  # noqa: E402


def _profile(model):
    predicted = np.asarray(model.predict(np.arange(360.0)), dtype=float)
    return predicted - predicted.mean()


def _uncertainty(model):
    return float(np.sqrt(np.mean(np.square(model.uncertainty["model_std_arcmin"]))))


def _ratio(first, later):
    change = np.sqrt(np.mean((_profile(later) - _profile(first)) ** 2))
    return change / np.hypot(_uncertainty(first), _uncertainty(later))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--units", type=int, default=20)
    args = parser.parse_args()
    repeats, epochs = [], []
    for member in simulate_fleet(args.units, seed=11):
        first = fit(member.train.calibration, method="spectral")
        again = calibration_run(member.encoder, TRAINING_GRID_DEG, rng=np.random.default_rng(99))
        repeats.append(_ratio(first, fit(again.calibration, method="spectral")))
        epochs.append(_ratio(first, fit(member.epoch2.calibration, method="spectral")))
        print(f"{member.name}: unchanged repeat {repeats[-1]:.2f}, epoch2 {epochs[-1]:.2f}")
    print(f"unchanged repeats: {min(repeats):.2f} to {max(repeats):.2f} (median {np.median(repeats):.2f}); epoch2: "
          f"{min(epochs):.2f} to {max(epochs):.2f}; 'moved' above {DRIFT_MOVED:g}")


if __name__ == "__main__":
    main()

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

Then the production lot of ``benchmarks/_fleet_lots.py`` (units 0-19 of seed 3202): each unit calibrated twice over
the training grid with fresh noise, the odd units remounted between the two (a new eccentricity, N_c(0, 0.5'),
drawn from seed ``[9, i]``): the ratio of each, and the change of its first order's amplitude.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

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


def _production(units=20):
    import _fleet_lots as lots
    import _physics_world as world

    from encal.data.calibration import Calibration

    design = lots._design()

    def calibrated(parameters, seed):
        case = world._case(lambda t, q=parameters: lots._unit_angle(q, t), lots.TRAIN_GRID_DEG, lots.TEST_GRID_DEG,
                           world._RESOLVER_BITS, parameters["noise_lsb"], np.random.default_rng(seed))
        return fit(Calibration(lots.TRAIN_GRID_DEG, np.asarray(case["theta"], dtype=float)), method="spectral")

    for remounted in (False, True):
        ratios = []
        for i in range(remounted, units, 2):
            parameters = lots._unit_parameters(design, np.random.default_rng([3202, i]))
            first = calibrated(parameters, [3202, i, 1])
            if remounted:
                parameters = {**parameters, "eccentricity": world._complex_normal(np.random.default_rng([9, i]),
                                                                                  0.5 / lots.ARCMIN_PER_RAD)}
            later = calibrated(parameters, [3202, i, 2])
            order_1 = abs(np.fft.rfft(_profile(later) - _profile(first))[1]) * 2 / 360
            ratios.append(_ratio(first, later))
            print(f"production unit {i}{' remounted' if remounted else ''}: {ratios[-1]:.2f} (first order changed "
                  f"by {order_1:.3f} arcmin)")
        print(f"production lot, {'remounted' if remounted else 'unchanged'}: {min(ratios):.2f} to {max(ratios):.2f}, "
              f"{sum(r > DRIFT_MOVED for r in ratios)} of {len(ratios)} moved")


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
    _production()


if __name__ == "__main__":
    main()

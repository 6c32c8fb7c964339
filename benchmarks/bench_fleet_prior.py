"""The fleet prior (issue 32), leave-one-out: a unit from a quarter of its points or a quarter turn.

Usage::

    python benchmarks/bench_fleet_prior.py                       # 60 real boards and a simulated lot of 60
    python benchmarks/bench_fleet_prior.py --simulated 30 --real 0

For each unit, the prior is learned (encal.fleet.prior.fleet_prior) from the full-calibration spectral
fits of every *other* unit; then the unit is fitted from part of its calibration, alone
(``fit_spectral``) and under the fleet prior (``fit_with_prior``):

- ``quarter of the points``: every 4th reference stop (45 of 180 simulated, 50 of 200 real);
- ``quarter turn``: the stops in [0, 90) degrees only.

Simulated lot (encal.simulate, seed 32; training run 0:2:358 degrees): the error is the RMS of the
model minus the unit's noise-free error at the test run's angles (1:2:359 degrees), against the same for
the spectral fit of the full training run (the full calibration); the goal of the issue is a quarter
within 1.1x the full calibration's error.

Real Mechaduino boards (/work/shared/data/real/mechaduino or ../shared/data/real/mechaduino; 60 AS5047D
boards, 200 full steps each): no truth, so the error is the RMS of the model's residual at the stops the
part left out (readings, noise included), against the full fit's residual at the same stops (which the
full fit saw: a lower bound of its error there). Zero offsets are removed from every RMS (a motor's
zero is arbitrary).
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from encal.data.calibration import read_calibration  # noqa: E402
from encal.fleet.prior import fit_with_prior, fleet_prior  # noqa: E402
from encal.models.spectral import fit_spectral  # noqa: E402

PARTS = {
    "quarter of the points": lambda reference: np.isin(np.arange(reference.size), np.arange(0, reference.size, 4)),
    "quarter turn": lambda reference: (reference % 360.0) < 90.0,
}


def _rms_about_mean(values):
    values = np.asarray(values, dtype=float)
    return float(np.sqrt(np.mean((values - values.mean()) ** 2)))


def _real_units():
    here = Path(__file__).resolve().parents[1]
    for folder in (here.parent / "shared" / "data" / "real" / "mechaduino", Path("/work/shared/data/real/mechaduino")):
        if folder.is_dir():
            return [read_calibration(p) for p in sorted(folder.glob("mech_*.csv"))]
    return []


def _simulated_units(count):
    from encal.simulate import simulate_fleet

    return simulate_fleet(count, seed=32)


def _leave_one_out(units, full_models, evaluate):
    rows = {name: {"alone": [], "prior": [], "full": []} for name in PARTS}
    for index, (cal, full) in enumerate(zip(units, full_models)):
        prior = fleet_prior([m for j, m in enumerate(full_models) if j != index])
        for name, choose in PARTS.items():
            kept = choose(cal.reference_deg)
            theta, error = cal.encoder_deg[kept], cal.errors_arcmin[kept]
            alone = fit_spectral(theta, error)
            with_prior = fit_with_prior(theta, error, prior)
            for label, model in (("alone", alone), ("prior", with_prior), ("full", full)):
                rows[name][label].append(evaluate(index, model, ~kept))
    return rows


def _print(title, rows, full_label):
    print(f"\n{title}")
    print(f"  {'part':<22} {'alone (arcmin)':>15} {'fleet prior':>12} {full_label:>16} {'prior/full':>11} "
          f"{'alone/full':>11}  (medians over units; prior/full: median of the per-unit ratios, 90th pct)")
    for name, columns in rows.items():
        alone, prior, full = (np.array(columns[k]) for k in ("alone", "prior", "full"))
        ratio = prior / full
        print(f"  {name:<22} {np.median(alone):>15.3f} {np.median(prior):>12.3f} {np.median(full):>16.3f} "
              f"{np.median(ratio):>6.2f} ({np.percentile(ratio, 90):.2f}) {np.median(alone / full):>8.2f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--simulated", type=int, default=60, help="units in the simulated lot (0: none)")
    parser.add_argument("--real", type=int, default=60, help="real boards used, at most 60 (0: none)")
    args = parser.parse_args()
    start = time.perf_counter()
    if args.simulated:
        members = _simulated_units(args.simulated)
        units = [m.train.calibration for m in members]
        full = [fit_spectral(c.encoder_deg, c.errors_arcmin) for c in units]

        def against_truth(index, model, _left_out):
            test = members[index].test
            truth = test.noise_free_error_arcmin
            return _rms_about_mean(model.predict(test.calibration.encoder_deg) - truth)

        _print(f"Simulated lot ({len(units)} units): RMS of model - noise-free error at the test angles",
               _leave_one_out(units, full, against_truth), "full calibration")
    if args.real:
        units = _real_units()[:args.real]
        if not units:
            print("\n(real boards: the Mechaduino data set is not here; left out)")
        else:
            full = [fit_spectral(c.encoder_deg, c.errors_arcmin) for c in units]

            def against_readings(index, model, left_out):
                cal = units[index]
                return _rms_about_mean(model.predict(cal.encoder_deg[left_out]) - cal.errors_arcmin[left_out])

            _print(f"Real Mechaduino boards ({len(units)}): RMS residual at the stops left out",
                   _leave_one_out(units, full, against_readings), "full fit (seen)")
    print(f"\n{time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()

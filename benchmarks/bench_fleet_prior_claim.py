"""What a unit fitted under the fleet prior claims against what it is: the held-out estimate and the ±2σ band.

Usage::

    python benchmarks/bench_fleet_prior_claim.py                    # both simulated lots of 60 and the 60 real boards
    python benchmarks/bench_fleet_prior_claim.py --lots production --real 0 --units 30

A production line grades each unit by its held-out estimate (``expected_rms_between_points``: the posterior's RMS
error of a correction at angles not calibrated, a new reading's noise included). Leave-one-out as
bench_fleet_prior.py (each unit's prior learned from the full calibrations of every other unit), each unit fitted
under it from a quarter of its points (every 4th stop) and from a quarter turn (0-90 degrees), then:

- ``truth/claim``: the unit's true error after correction, ``sqrt(RMS(model - noise-free error)² + σ²)`` at the
  test run's angles (none of them calibrated; σ the unit's true noise), the difference about its mean (the shape:
  a motor's zero is arbitrary, and since claim9 the claim and the band are of the shape; ``SHAPE = False`` for
  prior8's truth with the offset), over its claim: median, 90th percentile, the share of units over 2x, and
  ``sqrt(mean truth² / mean claim²)`` over units (1 when the claim is right in mean square, what a Gaussian
  posterior promises);
- ``±2σ coverage``: the share of the test angles where ``|model - noise-free error|`` (about its mean) is within
  twice the model's posterior standard deviation (``include_noise=False``): its mean over units (95 % promised)
  and the 10th percentile unit;
- the units over 1.5x: the scale of the fleet's spread their fit chose (``spread_scale``), their noise estimate over
  the truth, and how far their own full calibration is from the others' prior (``unit scale``: the mean over
  orders of its squared Mahalanobis distance per part, 1 for a unit like the fleet).

Real Mechaduino boards have no truth: the claim is compared with the RMS residual at the stops left out (readings,
noise included, as the claim), the band with the noise included.
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import _fleet_lots  # noqa: E402
from bench_fleet_prior import PARTS, real_boards  # noqa: E402
from encal.fleet.prior import _unit_harmonics, _unit_scales, fit_with_prior, fleet_prior  # noqa: E402
from encal.models.spectral import fit_spectral  # noqa: E402


#: Whether the truth is of the shape about the offset (the model's band and claim are, since claim9).
SHAPE = True


def _rows(units, full, truth_of):
    """Per part, per unit: (truth, claim, coverage, spread scale, noise estimate, unit scale)."""
    coefficients, _ = _unit_harmonics(full, 60, 360)
    rows = {name: [] for name in PARTS}
    for index, unit in enumerate(units):
        prior = fleet_prior([m for j, m in enumerate(full) if j != index])
        unit_scale = float(_unit_scales(coefficients[index:index + 1], prior.mean_cos + 1j * prior.mean_sin,
                                        *prior.blocks())[0])
        for name, choose in PARTS.items():
            kept = choose(unit["reference"])
            model = fit_with_prior(unit["theta"][kept], unit["y"][kept], prior)
            true, covered = truth_of(unit, model, ~kept)
            rows[name].append((true, model.expected_rms_between_points(), covered,
                               model.training["fleet_prior"]["spread_scale"], model.uncertainty["noise_std_arcmin"],
                               unit_scale))
    return rows


def _against_truth(unit, model, _left_out):
    predicted, std = model.predict(unit["theta_test"], return_std=True, include_noise=False)
    difference = predicted - unit["truth_test"]
    if SHAPE:
        difference = difference - difference.mean()  # a motor's zero is arbitrary: the grade is of the shape
    return (float(np.sqrt(np.mean(difference**2) + unit["sigma"] ** 2)),
            float(np.mean(np.abs(difference) <= 2.0 * std)))


def _against_readings(unit, model, left_out):
    predicted, std = model.predict(unit["theta"][left_out], return_std=True)
    residual = predicted - unit["y"][left_out]
    residual = residual - residual.mean()  # a motor's zero is arbitrary; the offset is the readings', not the model's
    return float(np.sqrt(np.mean(residual**2))), float(np.mean(np.abs(residual) <= 2.0 * std))


def _print(title, rows, units, true_noise=True):
    print(f"\n{title}")
    print(f"  {'part':<22} {'truth/claim: median':>20} {'90th pct':>9} {'over 2x':>8} {'RMS ratio':>10} "
          f"{'±2σ coverage: mean':>19} {'10th pct unit':>14}")
    for name, values in rows.items():
        true, claim, covered = (np.array([v[k] for v in values]) for k in range(3))
        ratio = true / claim
        print(f"  {name:<22} {np.median(ratio):>20.2f} {np.percentile(ratio, 90):>9.2f} "
              f"{100 * np.mean(ratio > 2):>7.1f}% {np.sqrt(np.mean(true**2) / np.mean(claim**2)):>10.2f} "
              f"{100 * np.mean(covered):>18.1f}% {100 * np.percentile(covered, 10):>13.1f}%")
        for index in np.flatnonzero(ratio > 1.5):
            _, _, covered_unit, scale, noise, unit_scale = values[index]
            noise_text = f"noise {noise / units[index]['sigma']:.2f}x the truth" if true_noise else f"noise {noise:.3f}"
            print(f"  {'':<22}   unit {index:>2}: {ratio[index]:.2f}x, coverage {100 * covered_unit:.0f}%, "
                  f"spread scale {scale:.2f}, unit scale {unit_scale:.2f}, {noise_text}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--units", type=int, default=60, help="units in each simulated lot (0: none)")
    parser.add_argument("--lots", default="simulated,production", help="simulated lots, comma-separated")
    parser.add_argument("--real", type=int, default=60, help="real boards used, at most 60 (0: none)")
    args = parser.parse_args()
    start = time.process_time()
    for lot in (name for name in args.lots.split(",") if args.units):
        units = _fleet_lots.LOTS[lot][0](args.units)
        full = [fit_spectral(u["theta"], u["y"]) for u in units]
        _print(f"Lot '{lot}' ({len(units)} units): truth at the test angles", _rows(units, full, _against_truth), units)
    if args.real:
        boards = real_boards(args.real)
        if boards is not None:
            units, full = boards
            _print(f"Real Mechaduino boards ({len(units)}): the readings at the stops left out (noise included)",
                   _rows(units, full, _against_readings), units, true_noise=False)
    print(f"\n{time.process_time() - start:.0f} s of CPU")


if __name__ == "__main__":
    main()

"""What a fleet prior learned from units fitted under a fleet prior does to the next units' held-out estimates
(fleet8; docs/production.md, "A fleet prior").

Usage::

    python benchmarks/bench_fleet_prior_feedback.py

A lot of 80 units with known truth: each unit's error is a Fourier series of orders 1-5 whose coefficients are drawn
N(0, 1 arcmin) (seed 2), read with noise 0.02 arcmin. Units 0-19 are calibrated over the whole turn (180 stops) and
fitted alone (``fit(..., method="spectral")``); units 20-59 over a quarter turn (45 stops, 0-88 deg) under the prior
of the first 20, as ``encal fleet fit --prior-from STORE --store STORE`` stores them. Units 60-79, each over a quarter
turn, are then fitted under the prior learned from (a) the 20 units fitted alone and (b) all 60, as the prior was
learned before fleet8 (every latest record of the store). Printed: the prior's variance at orders 1-5, and the
median over units 60-79 of the true RMS error of the model (zero offsets removed) and of the held-out estimate the
model claims (``expected_rms_between_points``, what a unit is graded by).

Then what leaving one unit out of a large store's prior changes, and costs (``LEAVE_ONE_OUT_UNITS``): fleets of 1001 and
10,001 units of Gaussian harmonics (60 orders, seed 0), the prior of all against the prior without one unit (20 units
each): the largest change of an order's mean (in its spread) and of its variance; and the CPU time of one such prior.
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from encal.data.calibration import Calibration  # noqa: E402
from encal.fleet.prior import _prior_of, _unit_harmonics, fit_with_prior, fleet_prior  # noqa: E402
from encal.models.fitting import fit  # noqa: E402

ORDERS = 5
FULL = np.arange(0.0, 360.0, 2.0)
QUARTER = np.arange(0.0, 90.0, 2.0)
GRID = np.arange(360.0)


def _truth(coefficients, angle_deg):
    theta = np.radians(angle_deg)
    return sum(coefficients[k, 0] * np.cos(k * theta) + coefficients[k, 1] * np.sin(k * theta)
               for k in range(1, ORDERS + 1))


def _calibration(coefficients, reference_deg, seed):
    error = _truth(coefficients, reference_deg) + np.random.default_rng(seed).normal(0.0, 0.02, reference_deg.size)
    return Calibration(reference_deg, reference_deg + error / 60.0)


def _under(prior, coefficients, seed):
    cal = _calibration(coefficients, QUARTER, seed)
    return fit_with_prior(cal.encoder_deg, cal.errors_arcmin, prior)


def _true_error(model, coefficients):
    predicted, truth = model.predict(GRID), _truth(coefficients, GRID)
    return float(np.sqrt(np.mean(((predicted - predicted.mean()) - (truth - truth.mean())) ** 2)))


def main():
    coefficients = np.random.default_rng(2).normal(0.0, 1.0, (80, ORDERS + 1, 2))
    alone = [fit(_calibration(coefficients[i], FULL, i), method="spectral") for i in range(20)]
    first = fleet_prior(alone)
    under = [_under(first, coefficients[i], i) for i in range(20, 60)]
    # (b) as the prior was learned before fleet8: from every model, those fitted under a prior included
    mixed = _prior_of(*_unit_harmonics(alone + under, 60, 360))
    assert fleet_prior(alone + under).units == 20  # today's fleet_prior leaves the 40 out
    for label, prior in (("(a) the 20 fitted alone", first), ("(b) all 60, 40 under a prior", mixed)):
        models = [(_under(prior, coefficients[i], i), i) for i in range(60, 80)]
        true = np.median([_true_error(model, coefficients[i]) for model, i in models])
        claimed = np.median([model.expected_rms_between_points() for model, _ in models])
        print(f"{label}: variance of orders 1-5 {np.round(prior.variance[:ORDERS], 3).tolist()} arcmin^2; units "
              f"60-79 median true error {true:.3f} arcmin, median held-out estimate claimed {claimed:.3f} arcmin")


def leave_one_out():
    import time

    rng = np.random.default_rng(0)
    for units in (1001, 10001):
        coefficients = rng.normal(size=(units, 60)) + 1j * rng.normal(size=(units, 60))
        noises = np.full(units, 0.1)
        whole = _prior_of(coefficients, noises)
        moved_mean = moved_variance = 0.0
        start = time.process_time()
        for left_out in rng.choice(units, 20, replace=False):
            keep = np.arange(units) != left_out
            other = _prior_of(coefficients[keep], noises[keep])
            moved_mean = max(moved_mean, np.max(np.abs(other.mean_cos - whole.mean_cos) / np.sqrt(whole.variance)))
            moved_variance = max(moved_variance, np.max(np.abs(other.variance / whole.variance - 1.0)))
        cost = (time.process_time() - start) / 20
        print(f"{units} units: one left out moved an order's mean by at most {100 * moved_mean:.3f} % of its spread, "
              f"its variance by {100 * moved_variance:.2f} %; {1000 * cost:.0f} ms of CPU a prior")


if __name__ == "__main__":
    main()
    leave_one_out()

"""Is a repeat pass's noise worth using below the quantisation's LSB/sqrt(12)? (issue 25)

Usage::

    python benchmarks/bench_repeat_floor.py            # a few minutes (120 fits)

Two passes of a 14-bit encoder (LSB/sqrt(12) = 0.38 arcmin) over the grid 0:2:358 deg, with reading noise of
0.02 to 0.3 arcmin and a profile of 1.5 arcmin RMS with fine structure (order 40). A quantised encoder repeats
its codes: the scatter of the two readings at one stop misses the rounding to whole codes, which is the same at
both readings of a stop and differs from stop to stop. For 10 seeds each the script prints the RMS error, at the
midpoints 1:2:359 deg, of the spectral model with

- ``floored``: the noise from the repeats, raised to LSB/sqrt(12) (what encal does),
- ``as is``: the scatter of the repeats given as the noise,
- ``one pass``: the first pass alone, blind,

and the mean scatter of the repeats (arcmin).
"""

import warnings

import numpy as np

from encal.models.spectral import fit_spectral, repeat_noise

LSB = 360.0 / 2**14
GRID = np.arange(0.0, 360.0, 2.0)
MIDPOINTS = np.arange(1.0, 360.0, 2.0)


def profile_arcmin(theta_deg):
    theta = np.radians(theta_deg)
    return (2.0 * np.sin(theta + 0.3) + 0.6 * np.cos(2 * theta) + 0.2 * np.sin(16 * theta)
            + 0.05 * np.sin(40 * theta))


def midpoint_rms(model):
    truth = profile_arcmin(MIDPOINTS)
    return float(np.sqrt(np.mean((model.predict(MIDPOINTS + truth / 60.0) - truth) ** 2)))


def main():
    warnings.simplefilter("ignore")
    print(f"{'noise':>6} {'floored':>8} {'as is':>8} {'one pass':>9} {'scatter':>8}  (arcmin, mean of 10 seeds)")
    for noise in (0.02, 0.05, 0.1, 0.3):
        rows = []
        for seed in range(10):
            rng = np.random.default_rng(seed)
            passes = [np.round((GRID + (profile_arcmin(GRID) + rng.normal(0.0, noise, GRID.size)) / 60.0) / LSB)
                      * LSB for _ in range(2)]
            theta = np.concatenate(passes)
            error = (theta - np.tile(GRID, 2)) * 60.0
            scatter = repeat_noise(np.tile(GRID, 2), error)[0]
            rows.append([midpoint_rms(fit_spectral(theta, error)),
                         midpoint_rms(fit_spectral(theta, error, noise_arcmin=max(scatter, 1e-6))),
                         midpoint_rms(fit_spectral(passes[0], (passes[0] - GRID) * 60.0)), scatter])
        mean = np.mean(rows, axis=0)
        print(f"{noise:>6.2f} {mean[0]:>8.4f} {mean[1]:>8.4f} {mean[2]:>9.4f} {mean[3]:>8.4f}")


if __name__ == "__main__":
    main()

"""Does the predictive uncertainty cover the residuals it claims to? Measured on the demo fleet.

For every demo encoder and method: fit on the training run (0:2:358), estimate the uncertainty with
:func:`encal.models.uncertainty.add_uncertainty`, and count the share of residuals inside ±2σ on

- the test run (1:2:359, same epoch and decoder): what the uncertainty is made for, nominally 95 %;
- the second epoch (0:2:358 again, after the mount and resolver drifted): outside what it is made for, shown
  to say how far a drift takes the residuals beyond the claim.

Then, for bidirectional runs of the same encoders (forward over the grid, one degree past its end, and back):
the ISO 230-2 reversal values, and the residual RMS and ±2σ share on a bidirectional test run of a
per-direction model used with and without the direction, and of a model of the mean.

The simulator knows the noise-free error, so the first table also gives the truth the estimate aims at:
``true noise`` is the RMS of measured minus noise-free error on the training run (the measurement floor) and
``model err`` the RMS of the model's prediction minus the noise-free error on the test run.

``auto`` is the spectral model, whose uncertainty is its posterior (no bootstrap; ``estim`` = ``post``,
``ν`` not applicable), as ``encal.fit(..., uncertainty=True)`` keeps it; ``spectral`` the same family asked
for by name.

``--real``: the same ±2σ check of auto's posterior on the real AS5047D files
(``../shared/data/real/``), under the two protocols of ``bench_real_data.py``: fitted on the even rows and
tested on the odd rows, and fitted on one calibration and tested on the same board's repeats (zero offsets
removed). What separates the test residual from the claim is split into the part the calibration cannot
tell: the odd rows' mean offset from the even rows (a stepper's alternate full steps differ) and, for the
repeats, the change of the profile between runs.

``ann-matlab`` is ``ann`` trained by MATLAB's rule (1000 epochs, ``plateau_patience=None``) rather than the
default stop, to show that the uncertainty holds under either.

``--known-noise``: the noise estimate and the ±2σ coverage on a known truth, the construction of
tests/models/test_uncertainty.py (orders 1, 2, 4 and 15, Gaussian noise of 0.2 arcmin; ``fourier`` with those
orders, ``lut`` linear): σ_noise over the truth on 120 calibrations of 360 points (seeds 0-119), and the share of
fresh residuals at 1:2:359 inside ±2σ of a fit on 0:2:358 over 200 seeds, with the means of 40 blocks of 5; then
a 1:8:1 network on orders 1, 2 and 4 under the paper's and MATLAB's stopping rules over seeds 0-39.

Run:  .venv/bin/python benchmarks/bench_uncertainty.py [--methods fourier lut ann ann-matlab hybrid auto]
      [--n-boot 30] [--encoders 4] [--no-bidirectional]
      .venv/bin/python benchmarks/bench_uncertainty.py --real
      .venv/bin/python benchmarks/bench_uncertainty.py --known-noise
"""

import os

# One BLAS thread: the refits are many small least-squares problems, which threads only slow down
# when the machine is shared.
for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(variable, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import encal  # noqa: E402
from encal.data.reversal import reversal  # noqa: E402
from encal.models.fitting import fit_bidirectional  # noqa: E402
from encal.models.fitting import refit_spec  # noqa: E402
from encal.simulate import TEST_GRID_DEG, TRAINING_GRID_DEG, calibration_run, measurement_floor  # noqa: E402
from encal.simulate import demo_fleet  # noqa: E402
from encal.models.uncertainty import add_uncertainty, coverage, has_posterior  # noqa: E402


#: Benchmark labels that fit a method with options of their own: label -> (method, options).
VARIANTS = {"ann-matlab": ("ann", {"plateau_patience": None})}


def method_and_options(label):
    return VARIANTS.get(label, (label, {}))


def residual_rms(model, cal):
    return float(encal.evaluate(model, cal).after.rms)


def bidirectional_run(encoder, grid_deg, seed):
    """Forward over ``grid_deg``, one degree past its end, then back; the turning point is dropped."""
    visits = np.concatenate([grid_deg, [grid_deg[-1] + 1.0], grid_deg[::-1]])
    cal = calibration_run(encoder, visits, rng=seed).calibration
    keep = np.arange(visits.size) != grid_deg.size
    direction = np.concatenate([np.ones(grid_deg.size + 1), -np.ones(grid_deg.size)])[keep]
    return encal.Calibration(cal.reference_deg[keep], cal.encoder_deg[keep], direction=direction,
                             name=cal.name, resolution_bits=cal.resolution_bits)


def bidirectional_table(fleet, methods, n_boot):
    print(f"{'encoder':8s} {'B̄ LSB':>7s} {'B LSB':>6s} {'method':10s} {'RMS dir':>8s} {'RMS no dir':>10s} "
          f"{'RMS mean':>9s} {'±2σ dir':>8s} {'±2σ no dir':>10s} {'±2σ mean':>9s}")
    for index, member in enumerate(fleet):
        train = bidirectional_run(member.encoder, TRAINING_GRID_DEG, 10 + index)
        test = bidirectional_run(member.encoder, TEST_GRID_DEG, 20 + index)
        iso = reversal(train).as_dict()
        for label in methods:
            method, options = method_and_options(label)
            seed = {"rng": 0} if method in ("ann", "hybrid", "auto") else {}
            split = add_uncertainty(fit_bidirectional(train, "per-direction", method, **seed, **options), train,
                                    options=options, n_boot=n_boot, rng=1)
            mean = add_uncertainty(fit_bidirectional(train, "mean", method, **seed, **options), train,
                                   options=options, n_boot=n_boot, rng=1)
            observed = test.errors_arcmin
            with_direction, without = split.predict(test.encoder_deg, return_std=True, direction=test.direction), \
                split.predict(test.encoder_deg, return_std=True)
            of_mean = mean.predict(test.encoder_deg, return_std=True)
            rms = [np.sqrt(np.mean((observed - m) ** 2)) for m, _ in (with_direction, without, of_mean)]
            share = [np.mean(np.abs(observed - m) <= 2 * s) for m, s in (with_direction, without, of_mean)]
            print(f"{member.name:8s} {iso['mean_reversal_value_lsb']:7.2f} {iso['reversal_value_lsb']:6.2f} "
                  f"{label:10s} {rms[0]:8.3f} {rms[1]:10.3f} {rms[2]:9.3f} {100 * share[0]:7.1f}% "
                  f"{100 * share[1]:9.1f}% {100 * share[2]:8.1f}%")


def real_table():
    """±2σ coverage of auto (the spectral model's posterior) on the real files, both protocols."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_real_data import DATA, even_odd_cases, read_index, repeat_cases

    rows = read_index(DATA)
    print("arcmin; pred σ = RMS of the predictive std at the test angles; test RMS = RMS test residual; "
          "offset = mean test residual; ±2σ less offset = coverage of the residuals less that mean")
    for protocol, cases in (("even-odd", even_odd_cases(DATA, rows)), ("repeat", repeat_cases(DATA, rows))):
        print(f"\n{protocol}")
        print(f"{'file':46s} {'σ noise':>8s} {'pred σ':>7s} {'test RMS':>9s} {'offset':>7s} {'±2σ':>6s} "
              f"{'±2σ less offset':>16s}")
        shares, less, ratio = [], [], []
        for name, train, tests, _ in cases:
            model = encal.fit(train)
            theta = np.concatenate([t.encoder_deg for t in tests])
            observed = np.concatenate([t.errors_arcmin for t in tests])
            mean, std = model.predict(theta, return_std=True)
            residual = observed - mean
            offset = float(np.mean(residual))
            shares.append(np.mean(np.abs(residual) <= 2 * std))
            less.append(np.mean(np.abs(residual - offset) <= 2 * std))
            ratio.append(np.sqrt(np.mean(residual**2)) / np.sqrt(np.mean(std**2)))
            print(f"{name.removeprefix('mech_')[:46]:46s} {model.uncertainty['noise_std_arcmin']:8.3f} "
                  f"{np.sqrt(np.mean(std**2)):7.3f} {np.sqrt(np.mean(residual**2)):9.3f} {offset:7.2f} "
                  f"{100 * shares[-1]:5.1f}% {100 * less[-1]:15.1f}%", flush=True)
        print(f"{protocol}: {len(shares)} files; ±2σ covers median {100 * np.median(shares):.1f}% "
              f"(mean {100 * np.mean(shares):.1f}%, {np.sum(np.array(shares) >= 0.9)} files at 90 % or more); "
              f"less the mean offset median {100 * np.median(less):.1f}%; test RMS / pred σ median "
              f"{np.median(ratio):.2f} ({np.min(ratio):.2f}..{np.max(ratio):.2f})")


def known_reversal(seeds=120):
    """docs/bidirectional.md: tests/models/test_directional.py's coverage test over ``seeds`` seeds (a reversal of
    0.4 arcmin, noise 0.15 arcmin, orders 0-3): the mean reversal value and the ±2σ share of fresh residuals of a
    per-direction model used with the direction and of a model of the mean, with the means of blocks of 6."""
    from tests.models.test_directional import REVERSAL, coverage_of_fresh_bidirectional_readings

    shares, reversal = {"per-direction": [], "mean": []}, []
    for seed in range(seeds):
        seed_shares, seed_reversal = coverage_of_fresh_bidirectional_readings(seed)
        for mode, share in seed_shares.items():
            shares[mode].append(share)
        reversal.append(seed_reversal)
    reversal = np.array(reversal)
    print(f"bidirectional ({seeds} seeds, reversal {REVERSAL} arcmin): mean reversal value {reversal.mean():.4f} "
          f"(standard error {reversal.std(ddof=1) / np.sqrt(seeds):.4f})"
          + "".join(f"; ±2σ {mode} {100 * np.mean(v):.1f} % (blocks of 6: "
                    f"{100 * np.min(np.mean(np.reshape(v, (-1, 6)), axis=1)):.1f}-"
                    f"{100 * np.max(np.mean(np.reshape(v, (-1, 6)), axis=1)):.1f} %)" for mode, v in shares.items()))


def known_noise():
    """docs/uncertainty.md's "Known noise": the tests' construction over many seeds."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests.models.test_uncertainty import NOISE, ORDERS, fitted, network_coverage, noisy_calibration

    for method, options in (("fourier", {"orders": ORDERS}), ("lut", {})):
        ratios = np.array([fitted(noisy_calibration(np.arange(0.0, 360.0, 1.0), np.random.default_rng(seed)),
                                  method, options, seed).uncertainty["noise_std_arcmin"] / NOISE
                           for seed in range(120)])
        shares = []
        for seed in range(200):
            rng = np.random.default_rng(100 + seed)
            model = fitted(noisy_calibration(np.arange(0.0, 360.0, 2.0), rng), method, options, seed)
            shares.append(coverage(model, noisy_calibration(np.arange(1.0, 360.0, 2.0), rng)))
        blocks = np.mean(np.reshape(shares, (40, 5)), axis=1)
        print(f"{method}: σ_noise / truth over 120 calibrations: mean {ratios.mean():.3f}, standard deviation "
              f"{ratios.std(ddof=1):.3f}, range {ratios.min():.2f}-{ratios.max():.2f}; ±2σ over 200 seeds "
              f"{100 * np.mean(shares):.1f} % (40 blocks of 5: {100 * blocks.min():.1f}-{100 * blocks.max():.1f} %)")
    known_reversal()
    for stop in ("plateau", "matlab"):  # a 1:8:1 network on orders 1, 2 and 4, seeds 0-39 (n_boot 20)
        results = [network_coverage(stop, seed) for seed in range(40)]
        noise = np.array([u["noise_std_arcmin"] for u, _ in results])
        dof = [u["residual_dof"] for u, _ in results if u["noise_estimator"] == "residual"]
        shares = np.array([share for _, share in results])
        blocks = np.mean(np.reshape(shares, (5, 8)), axis=1)
        print(f"ann, {stop} rule: residual estimate on {len(dof)} of 40 (ν {min(dof):.0f}-{max(dof):.0f}); σ_noise "
              f"mean {noise.mean():.3f}, standard deviation {noise.std(ddof=1):.3f}, range {noise.min():.3f}-"
              f"{noise.max():.3f}; ±2σ {100 * shares.mean():.1f} % (per seed {100 * shares.std(ddof=1):.1f} %; "
              f"5 blocks of 8: {100 * blocks.min():.1f}-{100 * blocks.max():.1f} %)")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", nargs="+", default=["fourier", "lut", "ann"])
    parser.add_argument("--n-boot", type=int, default=30)
    parser.add_argument("--encoders", type=int, default=4)
    parser.add_argument("--no-bidirectional", action="store_true", help="skip the second table")
    parser.add_argument("--real", action="store_true",
                        help="auto's posterior on the real AS5047D files instead of the demo fleet")
    parser.add_argument("--known-noise", action="store_true",
                        help="only the noise estimate and coverage on the tests' known truth, over many seeds")
    args = parser.parse_args()
    if args.known_noise:
        known_noise()
        return
    if args.real:
        real_table()
        return

    fleet = demo_fleet(args.encoders)
    header = (f"{'encoder':8s} {'method':10s} {'estim':5s} {'ν':>6s} {'σ_noise':>8s} {'true':>6s} {'σ_model':>8s} "
              f"{'model err':>9s} {'pred σ':>7s} {'test RMS':>9s} {'±2σ test':>9s} {'±2σ ep2':>8s} {'seconds':>8s}")
    print(f"n_boot = {args.n_boot}, 10 folds; arcmin; σ_model, model err and pred σ are RMS over the test angles; "
          "estim: res = residual, cv = cross-validated noise; true = measurement floor of the training run")
    print(header)
    shares = {label: [] for label in args.methods}
    for member in fleet:
        train, test, epoch2 = (member.train.calibration, member.test.calibration, member.epoch2.calibration)
        for label in args.methods:
            method, options = method_and_options(label)
            seed = {"rng": 0} if method in ("ann", "hybrid", "auto") else {}
            started = time.perf_counter()
            model = encal.fit(train, method, **seed, **options)
            if not has_posterior(model):
                refit_method, refit_options = refit_spec(model, method, options)
                add_uncertainty(model, train, method=refit_method, options=refit_options, n_boot=args.n_boot, rng=1)
            seconds = time.perf_counter() - started
            mean, std = model.predict(test.encoder_deg, return_std=True)
            u = model.uncertainty
            if has_posterior(model):
                _, model_std = model.predict(test.encoder_deg, return_std=True, include_noise=False)
            else:  # only the spectral model's predict takes include_noise: σ_model from sqrt(std² − σ_noise²)
                model_std = np.sqrt(np.maximum(np.square(std) - u["noise_std_arcmin"] ** 2, 0.0))
            model_error = np.sqrt(np.mean(np.square(mean - member.test.noise_free_error_arcmin)))
            on_test, on_epoch2 = coverage(model, test), coverage(model, epoch2)
            shares[label].append(on_test)
            estimator = {"residual": "res", "cross-validation": "cv"}.get(u.get("noise_estimator"), "post")
            dof = f"{u['residual_dof']:6.1f}" if "residual_dof" in u else f"{'-':>6s}"
            print(f"{member.name:8s} {label:10s} {estimator:5s} {dof} {u['noise_std_arcmin']:8.3f} "
                  f"{measurement_floor(member.train):6.3f} {np.sqrt(np.mean(np.square(model_std))):8.3f} "
                  f"{model_error:9.3f} {np.sqrt(np.mean(std**2)):7.3f} {residual_rms(model, test):9.3f} "
                  f"{100 * on_test:8.1f}% {100 * on_epoch2:7.1f}% {seconds:8.1f}", flush=True)
    print()
    for label, values in shares.items():
        print(f"{label:10s} mean share of test residuals inside ±2σ: {100 * np.mean(values):.1f}% "
              f"(over {len(values)} encoders x 180 points)")
    print()
    if args.no_bidirectional:
        return
    print("bidirectional runs (ISO 230-2 reversal of the training run; arcmin; test run 1:2:359 both ways)")
    bidirectional_table(fleet, args.methods, args.n_boot)


if __name__ == "__main__":
    main()

"""The spectral model and the evidence-based auto against the plain baselines and the informed bound.

Usage::

    python benchmarks/bench_spectral.py                    # fleet and fleet+, a few minutes
    python benchmarks/bench_spectral.py --cases fleet      # one case
    python benchmarks/bench_spectral.py --cv-auto          # also the cross-validated auto (slow)
    python benchmarks/bench_spectral.py --scaling          # fit time and memory against n
    python benchmarks/bench_spectral.py --background-bound --cases fleet fleet+ rough
                                    # what a better smooth background could gain (expected errors)
    python benchmarks/bench_spectral.py --collapse         # safeguard 1's repeated search on 30 draws (seconds)

Cases (each encoder fitted on its training run, 0:2:358 degrees, and tested on its test run,
1:2:359 degrees, fresh noise):

- ``fleet``: ``encal.simulate.demo_fleet()`` (4 encoders);
- ``fleet+``: ``encal.simulate.simulate_fleet(8, 7)`` (8 encoders);
- ``rough``: the fleet+ encoders with an added flat "roughness" spectrum up to order 90 of
  1.5 times the noise power per order (independent per encoder);
- ``12bit``: the fleet+ encoders read by a 12-bit encoder (readings rounded to 360/4096 degrees);
- ``jitter``: a jittered 5-degree grid (72 stops, each moved by up to ±1 degree) tested at 360
  random angles, on the fleet+ encoders' noise-free profiles plus the training run's noise level;
- ``epoch``: the fleet+ encoders tested on their later epoch (``member.epoch2``) instead;
- ``jitter+``: 32 more jittered cases, ``simulate_fleet(8, 7)`` and ``simulate_fleet(8, 11)`` with two
  draws of the jitter each (the encoder's name, a letter for the member, the draw).

Per encoder, test RMS divided by the test run's measurement floor for: ``np.interp`` of the
training points (periodic), the CV-chosen Fourier series, the paper's top-10 series, the cubic
lookup table, the spectral model blind and with the noise supplied (the training run's actual
noise standard deviation), the evidence-based auto (blind), optionally the cross-validated auto,
and the informed estimator applied to the same run (``informed_estimate`` of
benchmarks/bench_floor_bound.py: told the true profile's power per order and the noise). Then per
case: ±2σ coverage of the spectral model's predictive intervals at the test points, beside the
coverage of a model that knew the profile, and the ratios of auto to the best plain baseline and
to the informed estimator.
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from encal.models import select  # noqa: E402
from encal.models.auto import fit_auto  # noqa: E402
from encal.models.fourier import fit_fourier  # noqa: E402
from encal.models.lut import fit_lut  # noqa: E402
from encal.models.spectral import fit_spectral  # noqa: E402
from encal.simulate import demo_fleet, measurement_floor, simulate_fleet  # noqa: E402

from bench_floor_bound import harmonic_coefficients, informed_estimate, order_power, synthesise  # noqa: E402

PLAIN = ("interp", "fourier cv", "fourier top10")


def rms(values):
    return float(np.sqrt(np.mean(np.square(values))))


def interp_model(theta, error):
    order = np.argsort(theta)
    return lambda t: np.interp(np.mod(t, 360.0), theta[order], error[order], period=360.0)


def cases(names):
    fleet_plus = list(simulate_fleet(8, 7))
    for name in names:
        if name == "fleet":
            for member in demo_fleet():
                yield name, member.name, _uniform_case(member, member.test)
        elif name == "fleet+":
            for member in fleet_plus:
                yield name, member.name, _uniform_case(member, member.test)
        elif name == "epoch":
            for member in fleet_plus:
                yield name, member.name, _uniform_case(member, member.epoch2)
        elif name == "rough":
            for i, member in enumerate(fleet_plus):
                yield name, member.name, _rough_case(member, i)
        elif name == "12bit":
            for member in fleet_plus:
                yield name, member.name, _quantised_case(member, 12)
        elif name == "jitter":
            for i, member in enumerate(fleet_plus):
                yield name, member.name, _jitter_case(member, i)
        elif name == "jitter+":
            more = fleet_plus + list(simulate_fleet(8, 11))
            for draw in (0, 1):
                for i, member in enumerate(more):
                    label = f"{member.name}{'abcdefghijklmnop'[i]}{draw}"
                    yield name, label, _jitter_case(member, 5000 + 100 * draw + i)


def _truth_function(member):
    """The noise-free profile at any angle: interpolated from the training and test runs' truth (1 degree)."""
    theta = np.r_[member.train.calibration.encoder_deg, member.test.calibration.encoder_deg]
    truth = np.r_[member.train.noise_free_error_arcmin, member.test.noise_free_error_arcmin]
    coefficients = harmonic_coefficients(truth[np.argsort(np.round(np.r_[member.train.calibration.reference_deg,
                                                                         member.test.calibration.reference_deg]))])
    return lambda t: synthesise(coefficients, np.asarray(t, dtype=float)), theta


def _uniform_case(member, test):
    train = member.train
    noise = train.errors_arcmin - train.noise_free_error_arcmin
    truth_fn, _ = _truth_function(member)
    return {"theta": train.calibration.encoder_deg, "y": train.errors_arcmin,
            "theta_test": test.calibration.encoder_deg, "y_test": test.errors_arcmin,
            "floor": measurement_floor(test), "sigma": float(np.std(noise)), "truth": truth_fn}


def _rough_case(member, seed):
    case = _uniform_case(member, member.test)
    rng = np.random.default_rng(1000 + seed)
    orders = np.arange(1, 91)
    std = np.sqrt(1.5 * 2.0 * case["sigma"] ** 2 / 180)
    a, b = rng.normal(0.0, std, (2, orders.size))

    def rough(t):
        r = np.radians(np.asarray(t, dtype=float))[:, None]
        return np.cos(orders * r) @ a + np.sin(orders * r) @ b

    truth = case["truth"]
    case.update(y=case["y"] + rough(case["theta"]), y_test=case["y_test"] + rough(case["theta_test"]),
                truth=lambda t: truth(t) + rough(t))
    return case


def _quantised_case(member, bits):
    case = _uniform_case(member, member.test)
    quantum = 360.0 / 2**bits
    for angles, errors in (("theta", "y"), ("theta_test", "y_test")):
        reference = case[angles] - case[errors] / 60.0
        reading = np.round(case[angles] / quantum) * quantum
        case[angles], case[errors] = reading, (reading - reference) * 60.0
    case["sigma"] = float(np.sqrt(case["sigma"] ** 2 + (quantum * 60.0) ** 2 / 12.0))
    case["floor"] = rms(case["y_test"] - case["truth"](case["theta_test"]))
    return case


def _jitter_case(member, seed):
    rng = np.random.default_rng(2000 + seed)
    base = _uniform_case(member, member.test)
    truth, sigma = base["truth"], base["sigma"]
    reference = np.arange(0.0, 360.0, 5.0) + rng.uniform(-1.0, 1.0, 72)
    y = truth(reference) + rng.normal(0.0, sigma, reference.size)
    reference_test = rng.uniform(0.0, 360.0, 360)
    noise_test = rng.normal(0.0, sigma, reference_test.size)
    y_test = truth(reference_test) + noise_test
    return {"theta": np.mod(reference + y / 60.0, 360.0), "y": y,
            "theta_test": np.mod(reference_test + y_test / 60.0, 360.0), "y_test": y_test,
            "floor": rms(noise_test), "sigma": sigma, "truth": truth}


def evaluate_case(case, cv_auto, seed=0):
    theta, y, theta_test, y_test = case["theta"], case["y"], case["theta_test"], case["y_test"]
    result, timing = {}, {}

    def run(name, fit):
        start = time.process_time()
        model = fit()
        timing[name] = time.process_time() - start
        predict = model if callable(model) and not hasattr(model, "predict") else model.predict
        result[name] = rms(y_test - predict(theta_test))
        return model

    run("interp", lambda: interp_model(theta, y))
    run("fourier cv", lambda: fit_fourier(theta, y, select="cv"))
    run("fourier top10", lambda: fit_fourier(theta, y, select="top", n_orders=10))
    run("lut cubic", lambda: fit_lut(theta, y, interpolation="cubic"))
    blind = run("spectral blind", lambda: fit_spectral(theta, y))
    run("spectral noise", lambda: fit_spectral(theta, y, noise_arcmin=case["sigma"]))
    run("auto", lambda: fit_auto(theta, y, rng=seed))
    run("auto noise", lambda: fit_auto(theta, y, rng=seed, noise_arcmin=case["sigma"]))
    if cv_auto:
        run("cv auto", lambda: select.fit_auto(theta, y, rng=seed))
    result["informed"] = rms(y_test - informed_estimate(theta, y, theta_test, case["truth"], case["sigma"]))
    mean, std = blind.predict(theta_test, return_std=True)
    coverage = float(np.mean(np.abs(y_test - mean) <= 2.0 * std))
    # What ±2σ covers for a model that knew the profile: 0.95 for Gaussian noise, 1.00 for rounding to
    # codes (uniform, with 2σ beyond its half-width).
    ideal = float(np.mean(np.abs(y_test - case["truth"](theta_test)) <= 2.0 * case["sigma"]))
    return result, timing, (coverage, ideal)


def scaling():
    """CPU time and peak traced memory of auto (and the spectral model) against n, uniform and off-grid."""
    import tracemalloc

    _warm_up()
    print("## fit time against n (orders 1, 2, 16 of 3, 0.9, 0.3 arcmin; noise 0.1 arcmin)\n")
    print("| n | angles | path | spectral CPU (s) | auto CPU (s) | auto peak memory (MB) | noise found |")
    print("|---|---|---|---|---|---|---|")
    for n in (180, 1000, 10_000, 100_000, 1_000_000):
        rng = np.random.default_rng(0)
        reference = np.arange(n) * (360.0 / n)
        r = np.radians(reference)
        error = 3 * np.sin(r) + 0.9 * np.cos(2 * r) + 0.3 * np.sin(16 * r) + rng.normal(0.0, 0.1, n)
        for label, theta in (("uniform", reference), ("off-grid", np.mod(reference + error / 60.0, 360.0))):
            start = time.process_time()
            model = fit_spectral(theta, error)
            spectral_s = time.process_time() - start
            tracemalloc.start()
            start = time.process_time()
            fit_auto(theta, error, rng=0)
            auto_s = time.process_time() - start
            peak = tracemalloc.get_traced_memory()[1] / 1e6
            tracemalloc.stop()
            print(f"| {n} | {label} | {model.training['path']} | {spectral_s:.2f} | {auto_s:.2f} | {peak:.0f} "
                  f"| {model.training['noise']['std_arcmin']:.4f} |")
    jittered_cost()


def _warm_up():
    """One fit on each path, so that the imports (SciPy's) and first calls are outside the timings."""
    theta = np.arange(0.0, 360.0, 5.0)
    error = np.sin(np.radians(theta)) + np.random.default_rng(0).normal(0.0, 0.1, theta.size)
    fit_spectral(theta, error)
    fit_spectral(theta + error / 60.0, error)


def jittered_cost(repeats=3):
    """CPU time of the spectral model on stops off a regular grid, blind and with the noise known."""
    print("\n## stops off a regular grid: CPU seconds per fit (best of 3; orders 1, 2, 16, 40 of 3, 0.9, 0.3, "
          "0.05 arcmin; noise 0.1 arcmin; each stop moved by up to ±0.2 spacings)\n")
    print("| stops | blind | noise known (to twice Nyquist) | noise known, max_order = Nyquist | highest order |")
    print("|---|---|---|---|---|")
    _warm_up()
    for m in (72, 180, 360):
        rng = np.random.default_rng(m)
        reference = (np.arange(m) + rng.uniform(-0.2, 0.2, m)) * 360.0 / m
        r = np.radians(reference)
        error = (3 * np.sin(r) + 0.9 * np.cos(2 * r) + 0.3 * np.sin(16 * r) + 0.05 * np.cos(40 * r)
                 + rng.normal(0.0, 0.1, m))
        theta = reference + error / 60.0
        cells, highest = [], None
        for options in ({}, {"noise_arcmin": 0.1}, {"noise_arcmin": 0.1, "max_order": m // 2}):
            times = []
            for _ in range(repeats):
                start = time.process_time()
                model = fit_spectral(theta, error, **options)
                times.append(time.process_time() - start)
            cells.append(f"{min(times):.2f}")
            if options == {"noise_arcmin": 0.1}:
                highest = model.training["max_order"]
        print(f"| {m} | {' | '.join(cells)} | {highest} |")


def background_bound(names, highest=90):
    """What the best smooth background could gain over the fitted one, in expected profile error.

    For each encoder on a uniform grid, with the true power ``P_ν`` of every order (from the noise-free
    profile) and the noise variance per coefficient ``V = 2σ²/n``: the expected squared error of the
    posterior mean under prior variances ``s_ν`` is ``Σ (1 - λ)² P + λ² V``, ``λ = s / (s + V)``. The
    orders where the fit (noise supplied) admitted lines keep ``s = P``; elsewhere ``s`` is the fitted
    power law, the best power law ``A ν^-β`` and the best log-quadratic background (slope ``-β₀`` at
    ν = 1 and ``-β_K`` at ν = 90, both in [1, 8]) chosen with the truth known, or ``P`` itself (the
    informed estimator). Printed as the implied test-RMS ratio to the informed estimator,
    ``sqrt((floor² + E) / (floor² + E_informed))``.
    """
    import scipy.optimize

    print("## the background: expected test RMS / the informed estimator's (noise supplied)\n")
    print("| case | encoder | fitted power law | best power law | best log-quadratic |")
    print("|---|---|---|---|---|")
    nu = np.arange(1, highest + 1, dtype=float)
    log_nu, log_top = np.log(nu), math.log(highest)
    for case_name, encoder, case in cases(names):
        theta, error, sigma = case["theta"], case["y"], case["sigma"]
        variance = 2.0 * sigma**2 / error.size
        power = order_power(harmonic_coefficients(case["truth"](np.arange(720) * 0.5)))[1:highest + 1]
        model = fit_spectral(theta, error, noise_arcmin=sigma)
        is_line = np.isin(nu, model.training["lines"])

        def expected(s):
            s = np.where(is_line, power, s)
            shrink = s / (s + variance)
            return float(np.sum((1.0 - shrink) ** 2 * power + shrink**2 * variance))

        def power_law(x):
            return expected(np.exp(x[0] - x[1] * log_nu))

        def log_quadratic(x):
            return expected(np.exp(x[0] - x[1] * log_nu - (x[2] - x[1]) * log_nu**2 / (2.0 * log_top)))

        starts = [(a, b) for a in (-5.0, -2.0, 0.0) for b in (1.0, 2.0, 4.0)]
        best_law = min(scipy.optimize.minimize(power_law, x0, bounds=[(-30, 5), (1, 8)]).fun for x0 in starts)
        best_quadratic = min(scipy.optimize.minimize(log_quadratic, (a, b, c), bounds=[(-30, 5), (1, 8), (1, 8)]).fun
                             for a, b in starts for c in (1.0, 2.0, 4.0))
        background = model.training["background"]
        fitted = expected(background["amplitude_arcmin2"] * nu ** -background["exponent"])
        floor2, informed = case["floor"] ** 2, expected(power)
        ratios = [math.sqrt((floor2 + e) / (floor2 + informed)) for e in (fitted, best_law, best_quadratic)]
        print(f"| {case_name} | {encoder} | " + " | ".join(f"{r:.3f}" for r in ratios) + " |")


def collapse(draws=30):
    """Safeguard 1's repeated search (docs/model-selection.md): ``draws`` jittered 72-stop grids of a ν^-2
    profile, the noise known (``jittered_power_law`` of tests/models/test_spectral.py), fitted with the search
    as it is and with the repeat switched off (``COLLAPSE_LINE_FRACTION = 1``): the draws whose search ends with
    lines on more than a third of the orders, and their profile error against the repeated search's."""
    import sys
    from pathlib import Path

    from encal.models import _evidence

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests.models.test_spectral import jittered_power_law

    test = np.arange(0.0, 360.0, 0.5)
    kept = _evidence.COLLAPSE_LINE_FRACTION
    print("| draw | lines, highest order (no repeat) | profile RMS no repeat / as is | lines as is |")
    print("|---|---|---|---|")
    collapsed = []
    for seed in range(draws):
        theta, error, truth = jittered_power_law(seed)
        model = fit_spectral(theta, error, noise_arcmin=0.05)
        _evidence.COLLAPSE_LINE_FRACTION = 1.0
        try:
            plain = fit_spectral(theta, error, noise_arcmin=0.05)
        finally:
            _evidence.COLLAPSE_LINE_FRACTION = kept
        lines, orders = len(plain.training["lines"]), int(plain.training["max_order"])
        ratio = (np.sqrt(np.mean((plain.predict(test) - truth(test)) ** 2))
                 / np.sqrt(np.mean((model.predict(test) - truth(test)) ** 2)))
        if lines > kept * orders:
            collapsed.append((seed, lines, ratio))
        print(f"| {seed} | {lines}, {orders} | {ratio:.2f} | {len(model.training['lines'])} |")
    print(f"\nwithout the repeat, lines on more than a third of the orders in {len(collapsed)} of {draws} draws"
          + (f" (seeds {', '.join(str(c[0]) for c in collapsed)}: {min(c[1] for c in collapsed)}-"
             f"{max(c[1] for c in collapsed)} lines, profile error {min(c[2] for c in collapsed):.2f}-"
             f"{max(c[2] for c in collapsed):.2f} times the repeated search's)" if collapsed else ""))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=["fleet", "fleet+"],
                        choices=["fleet", "fleet+", "rough", "12bit", "jitter", "jitter+", "epoch"])
    parser.add_argument("--cv-auto", action="store_true", help="also the cross-validated auto (slow)")
    parser.add_argument("--scaling", action="store_true", help="only the fit time against n (and off a regular grid)")
    parser.add_argument("--background-bound", action="store_true",
                        help="only what the best smooth background could gain (uniform-grid cases)")
    parser.add_argument("--collapse", action="store_true",
                        help="only safeguard 1's repeated search: 30 jittered draws with and without it")
    args = parser.parse_args()
    if args.collapse:
        collapse()
        return
    if args.background_bound:
        background_bound(args.cases)
        return
    if args.scaling:
        print(f"# spectral model, time against n; load {open('/proc/loadavg').read().split()[0]}\n")
        scaling()
        return
    print(f"# spectral model benchmark; python {platform.python_version()}, numpy {np.__version__}, "
          f"load {open('/proc/loadavg').read().split()[0]}\n")
    rows, summary = {}, {}
    for case_name, encoder, case in cases(args.cases):
        result, timing, coverage = evaluate_case(case, args.cv_auto)
        rows.setdefault(case_name, []).append((encoder, case["floor"], result, timing, coverage))
    for case_name, entries in rows.items():
        names = list(entries[0][2])
        print(f"## {case_name}: test RMS / floor\n")
        print("| encoder | floor (arcmin) | " + " | ".join(names) + " | best plain | auto / best plain "
              "| auto noise / best plain | informed / best plain | auto noise / informed | ±2σ coverage "
              "| ideal coverage |")
        print("|---|---|" + "---|" * len(names) + "---|---|---|---|---|---|---|")
        ratios, ratios_noise, coverages, ideals, reachable, to_informed = [], [], [], [], [], []
        for encoder, floor, result, timing, coverage in entries:
            best_plain = min(result[name] for name in PLAIN)
            ratios.append(result["auto"] / best_plain)
            ratios_noise.append(result["auto noise"] / best_plain)
            reachable.append(result["informed"] / best_plain)
            to_informed.append(result["auto noise"] / result["informed"])
            coverage, ideal = coverage
            coverages.append(coverage)
            ideals.append(ideal)
            cells = " | ".join(f"{result[name] / floor:.3f}" for name in names)
            print(f"| {encoder} | {floor:.4f} | {cells} | {best_plain / floor:.3f} | {ratios[-1]:.3f} "
                  f"| {ratios_noise[-1]:.3f} | {reachable[-1]:.3f} | {to_informed[-1]:.3f} | {coverage:.3f} "
                  f"| {ideal:.3f} |")
        times = {name: np.mean([entry[3][name] for entry in entries]) for name in entries[0][3]}
        print(f"\nauto / best plain: median {np.median(ratios):.3f}, worst {max(ratios):.3f}; with the noise "
              f"supplied: median {np.median(ratios_noise):.3f}, worst {max(ratios_noise):.3f}; "
              f"informed / best plain: worst {max(reachable):.3f}; auto noise / informed: median "
              f"{np.median(to_informed):.3f}, worst {max(to_informed):.3f}; "
              f"±2σ coverage (spectral, blind) {min(coverages):.3f}..{max(coverages):.3f}, "
              f"mean {np.mean(coverages):.3f} (a model that knew the profile: mean {np.mean(ideals):.3f})")
        print("mean CPU time per fit (s): " + ", ".join(f"{name} {value:.3f}" for name, value in times.items()))
        print()


if __name__ == "__main__":
    main()

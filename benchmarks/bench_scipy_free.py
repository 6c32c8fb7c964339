"""What a SciPy-free spectral fit would gain and cost: ``encal fit`` with NumPy-only stand-ins, measured (issue 30).

Usage::

    PYTHONPATH=src python benchmarks/bench_scipy_free.py [--rows 1000000] [--repeats 5] [--files sweep,random]
                                                         [--real 60] [--simulated 6] [--data PATH]

(``PYTHONPATH`` names the encal measured, in this process and in the ``encal fit`` processes.)

The spectral fit needs SciPy for L-BFGS-B (``scipy.optimize.minimize`` in ``encal.models._evidence._optimise``)
and LAPACK/BLAS (``_evidence._lapack``: ``dpotrf``, ``dpotrs``, ``dlauum``; ``encal.numerics.triangular``:
``dtrmm``, ``dtrtri``; ``encal._core.threads._blas`` imports ``scipy.linalg`` for threadpoolctl). This script
defines NumPy-only stand-ins for them (section "stand-ins" below), patches them into encal's modules
(:class:`scipy_free`) and measures, without changing encal:

* the Cholesky factor by ``np.linalg.cholesky``, with the jitter rule of ``_evidence._cholesky``;
* the triangular inverse by halves with ``@`` (leaves of at most 64 rows by ``np.linalg.inv``); the solve of
  ``dpotrs`` as two products with that inverse, kept for ``_evidence._evidence``'s call of the inverse that
  follows; ``dlauum`` as ``np.dot(Xᵀ, X)``;
* a projected L-BFGS (two-loop recursion over the variables not held at a bound, a line search on the path
  projected onto the box with sufficient decrease and curvature, growing the step by the secant of the slope and
  shrinking it by quadratic interpolation) with L-BFGS-B's ``ftol``/``gtol`` tests, first step (minus the
  gradient) and memory, in ``_optimise``'s bounds, start and two passes (per reading, then in nats when the first
  stops at its first iteration). It is not L-BFGS-B: no generalised Cauchy point, no subspace minimisation, a
  simpler line search than More and Thuente's; its searches end elsewhere on the evidence's flat ridges;
* ``threads._blas`` without ``import scipy.linalg`` (threadpoolctl sees NumPy's OpenBLAS only).

1. Whole processes, paired and interleaved as ``benchmarks/bench_dense_read.py`` (CPU user + system from GNU
   ``/usr/bin/time``, one BLAS thread, bytecode kept in the temporary folder from the warm-up run on). First
   processes that only import NumPy, then also ``scipy.linalg``, then also ``scipy.optimize``. Then, on
   bench_dense_read's two ``--rows``-row files (a 5-revolution sweep and uniformly random angles; ``--files`` picks
   them): ``encal fit`` as it is (``python -m encal fit FILE -o MODEL``); ``encal fit`` SciPy-free (the same command
   line from a child that patches every stand-in in before anything imports SciPy, and fails, naming the importer,
   if SciPy is in ``sys.modules`` at its end); ``encal fit`` with the hand-written optimiser alone, SciPy's LAPACK
   kept (the child fails if ``scipy.optimize`` was imported); and bench_dense_read's NumPy script. ``--repeats``
   rounds after one warm-up each; medians and the median (min-max) of the pair ratios. For each ``encal fit``, in
   one untimed run, the evaluations of the evidence (computations, not the results kept for a repeated point, and
   the CPU seconds in them) and of the optimiser's objective, and how its model file differs from the one of ``encal
   fit`` as it is (max |difference| of the profiles at 3,600 angles in arcmin and in units of the posterior standard
   deviation of the profile, log evidence, the lines chosen).
2. How the fits differ, in this process: the first ``--real`` real AS5047D calibrations of
   shared/data/real/mechaduino (``--data``; read as ``benchmarks/bench_real_data.py`` does), each fitted with SciPy
   and SciPy-free (``encal.fit(..., method='auto')`` as ``encal fit`` does) on all its rows (profile, evidence,
   lines) and on its even rows (held-out RMS on its odd rows); and ``--simulated`` resolvers of ``encal.simulate``
   (seeds 0, 1, ..., 180 stops on the 2-degree grid each moved by up to ±0.3 of a step, fixed seeds), the same, with
   the RMS off a second run's readings and off the noise-free error at the test grid's angles.

Options: ``--rows`` rows of each dense file; ``--repeats`` timed pairs; ``--files`` which dense files (``sweep``,
``random``, both comma-separated, or ``none``); ``--real`` how many real files (0: none; none either without the
data folder); ``--simulated`` how many simulated encoders (0: none); ``--data`` the folder of the real files
(index.csv and the CSV files). With the defaults the run takes about 1.5 minutes of wall time on the shared 2-core
machine (85 s at load average 1.5).
"""

import math
import os
import sys

import numpy as np

# -- stand-ins: NumPy only --------------------------------------------------------------------------------------

#: Blocks of at most this many rows are inverted by ``np.linalg.inv`` (as encal's ``_LEAF`` by ``dtrtri``).
LEAF = 64


def triangular_inverse(lower):
    """``L⁻¹`` of a lower-triangular ``L`` (its upper triangle not read), by halves:
    ``[[A, 0], [C, D]]⁻¹ = [[A⁻¹, 0], [-D⁻¹ C A⁻¹, D⁻¹]]``."""
    n = lower.shape[0]
    if n <= LEAF:
        return np.tril(np.linalg.inv(np.tril(lower)))
    half = n // 2
    inverse = np.zeros((n, n))
    inverse[:half, :half] = first = triangular_inverse(lower[:half, :half])
    inverse[half:, half:] = second = triangular_inverse(lower[half:, half:])
    inverse[half:, :half] = -second @ (lower[half:, :half] @ first)
    return inverse


def inverse_of(factor):
    """:func:`triangular_inverse` of ``factor``, kept for the next call with the same array: ``_evidence._evidence``
    solves with the factor (``dpotrs``) and then inverts it; by NumPy the solve is two products with the inverse
    (blocked triangular solves by ``np.linalg.solve`` took 0.43 ms at P = 401, LAPACK's dpotrs 0.07 ms)."""
    if _kept[0] is not factor:
        _kept[:] = [factor, triangular_inverse(factor)]
    return _kept[1]


_kept = [None, None]


def cholesky(fill, buffer):
    """``_evidence._cholesky`` by ``np.linalg.cholesky``: the same jitter, from 1e-14 to 1e-8 of the largest
    diagonal entry in steps of 100, where rounding makes the matrix indefinite."""
    matrix = fill(buffer)
    top = float(matrix.diagonal().max())
    jitter = 1e-14 * top
    try:
        return np.linalg.cholesky(matrix)
    except np.linalg.LinAlgError:
        pass
    while jitter <= 1e-8 * top:
        matrix = fill(buffer)
        matrix[np.diag_indices_from(matrix)] += jitter
        try:
            return np.linalg.cholesky(matrix)
        except np.linalg.LinAlgError:
            jitter *= 100.0
    raise np.linalg.LinAlgError("the posterior precision is not positive definite")


class NumpyLapack:
    """The two LAPACK calls ``_evidence._evidence`` makes on the factor, with SciPy's signatures."""

    @staticmethod
    def dpotrs(factor, b, lower=1):
        inverse = inverse_of(factor)
        return inverse.T @ (inverse @ b), 0

    @staticmethod
    def dlauum(inverse_factor, lower=1, overwrite_c=0):
        return np.dot(inverse_factor.T, inverse_factor), 0  # Lᵀ L whole (symmetric: BLAS's syrk)


def projected_lbfgs(fun, x0, lower, upper, memory=10, ftol=1e-13, gtol=1e-8, maxiter=500):
    """Minimise ``fun`` (returning the value and gradient) within the box ``[lower, upper]``.

    The stopping tests are L-BFGS-B's: the projected gradient's largest component at most ``gtol``, or a relative
    reduction ``(f_k - f_k+1) / max(|f_k|, |f_k+1|, 1)`` at most ``ftol``, or ``maxiter`` iterations, or a line
    search that finds no decrease. The direction is the two-loop L-BFGS product over the free variables (those
    not held at a bound by the gradient), minus the gradient where that is no descent; the first is minus the
    gradient. Returns ``(x, f, iterations)``.
    """
    x = np.clip(np.asarray(x0, dtype=float), lower, upper)
    f, g = fun(x)
    pairs, iteration = [], 0
    while iteration < maxiter and np.max(np.abs(np.clip(x - g, lower, upper) - x), initial=0.0) > gtol:
        free = ~(((x <= lower) & (g > 0)) | ((x >= upper) & (g < 0)))
        q = np.where(free, g, 0.0)
        alphas = []
        for s, y, rho in reversed(pairs):
            alphas.append(rho * (s[free] @ q[free]))
            q[free] -= alphas[-1] * y[free]
        if pairs:
            s, y, _ = pairs[-1]
            q[free] *= (s @ y) / (y @ y)
        for (s, y, rho), alpha in zip(pairs, reversed(alphas)):
            q[free] += (alpha - rho * (y[free] @ q[free])) * s[free]
        direction = -q
        if not g @ direction < 0.0:  # no descent: steepest descent, the memory cleared
            direction, pairs = np.where(free, -g, 0.0), []
        found = line_search(fun, x, f, g, direction, lower, upper, first=iteration == 0)
        if found is None:
            break
        trial, f_trial, g_trial = found
        s, y = trial - x, g_trial - g
        if s @ y > np.finfo(float).eps * (y @ y):  # L-BFGS-B skips a pair of too little curvature too
            pairs = (pairs + [(s, y, 1.0 / (s @ y))])[-memory:]
        reduction, x, f, g = f - f_trial, trial, f_trial, g_trial
        iteration += 1
        if reduction <= ftol * max(abs(f), abs(f + reduction), 1.0):
            break
    return x, f, iteration


def line_search(fun, x, f, g, direction, lower, upper, first, tries=20):
    """A step along ``direction``, projected onto the box, with sufficient decrease (1e-3) and curvature (0.9):
    ``(x, f, g)`` there, or None.

    The step starts at 1. While the slope stays steep it grows to where the secant of the slope vanishes (4 to 100
    times the step), up to the first bound (not at all on the ``first`` iteration: L-BFGS-B's first step is at most
    1); past a step with too little decrease it shrinks to the minimum of the quadratic through the last steep
    point's value and slope and that step's value (within 0.1 to 0.5 of the interval).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        to_bound = np.where(direction > 0, (upper - x) / direction,
                            np.where(direction < 0, (lower - x) / direction, np.inf))
    largest = 1.0 if first else max(float(np.min(to_bound, initial=np.inf)), 1.0)
    base = (0.0, f, float(g @ direction))  # the last step with enough decrease: its step, value and slope
    step, long, short = 1.0, None, None
    for _ in range(tries):
        trial = np.clip(x + step * direction, lower, upper)  # clipped only at the step ``largest``
        f_trial, g_trial = fun(trial)
        if not (np.isfinite(f_trial) and f_trial <= f + 1e-3 * (g @ (trial - x))):
            long = (step, f_trial)
        elif step >= largest or g_trial @ direction >= 0.9 * (g @ direction):
            return trial, f_trial, g_trial
        else:
            previous, base, short = base, (step, f_trial, float(g_trial @ direction)), (trial, f_trial, g_trial)
        if long is None:
            (s0, _, d0), d1 = previous, base[2]
            guess = step + (step - s0) * d1 / (d0 - d1) if d1 > d0 else np.inf
            step = min(max(guess, 4.0 * step), 100.0 * step, largest)
        else:
            (s0, f0, d0), width = base, long[0] - base[0]
            curvature = 2.0 * (long[1] - f0 - d0 * width)
            guess = s0 - d0 * width**2 / curvature if np.isfinite(curvature) and curvature > 0 else s0 + 0.5 * width
            step = min(max(guess, s0 + 0.1 * width), s0 + 0.5 * width)
    return short


def optimise(design, hyper):
    """``_evidence._optimise`` with :func:`projected_lbfgs` for L-BFGS-B: the same bounds, start, tolerances,
    memory and two passes (per reading, then in nats when the first stops at its first iteration)."""
    from encal.models import _evidence as ev

    line_orders = sorted(hyper.lines)
    log_scale = math.log(design.scale)
    bounds = [(log_scale - 40.0, log_scale + 14.0), ev.EXPONENT_BOUNDS]
    if not hyper.noise_fixed:
        bounds.append((log_scale - ev.NOISE_FLOOR_NATS, log_scale + 3.0))
    bounds.extend([(log_scale - 30.0, log_scale + 14.0)] * len(line_orders))
    lower, upper = np.array(bounds, dtype=float).T
    log_orders = np.log(np.maximum(design.orders, 1).astype(float))
    x = np.clip(ev._pack(hyper, line_orders), lower, upper)
    for per_reading, gtol in ((True, 1e-8), (False, 1e-8 * max(design.n, 1))):
        x, _, iterations = projected_lbfgs(
            lambda x: ev._objective(x, design, hyper, line_orders, log_orders, per_reading), x, lower, upper,
            memory=ev._memory(x.size), ftol=1e-13, gtol=gtol, maxiter=500)
        if iterations > 1:
            break
    return ev._unpack(x, hyper, line_orders)


def blas_controller():
    """``threads._blas`` without ``import scipy.linalg``: threadpoolctl sees NumPy's OpenBLAS alone."""
    from encal._core import threads

    if threads._controller is None:
        from threadpoolctl import ThreadpoolController

        threads._controller = ThreadpoolController()
    return threads._controller


class scipy_free:
    """Context manager (and, entered for good, the child's set-up): the stand-ins patched into encal's modules;
    with ``optimiser_only``, :func:`optimise` alone (SciPy's LAPACK kept)."""

    def __init__(self, optimiser_only=False):
        self.optimiser_only = optimiser_only

    def __enter__(self):
        from encal._core import threads
        from encal.models import _evidence
        from encal.numerics import triangular

        self.saved = [(module, name, getattr(module, name)) for module, name in (
            (_evidence, "_lapack"), (_evidence, "_cholesky"), (_evidence, "_optimise"),
            (_evidence, "lower_triangular_inverse"), (triangular, "lower_triangular_inverse"), (threads, "_blas"))]
        _evidence._optimise = optimise
        if not self.optimiser_only:
            _evidence._lapack = NumpyLapack
            _evidence._cholesky = cholesky
            _evidence.lower_triangular_inverse = triangular.lower_triangular_inverse = inverse_of
            threads._blas = blas_controller
        return self

    def __exit__(self, *exc):
        _kept[:] = [None, None]
        for module, name, value in self.saved:
            setattr(module, name, value)


class Counts:
    """Computations of the evidence (``_evidence._evidence``), the CPU seconds in them, and evaluations of the
    optimiser's objective."""

    def __init__(self):
        import time

        from encal.models import _evidence

        self.evidence = self.objective = 0
        self.seconds = 0.0
        self.module, self.originals = _evidence, (_evidence._evidence, _evidence._objective)

        def evidence(*args, **kwargs):
            self.evidence += 1
            start = time.process_time()
            try:
                return self.originals[0](*args, **kwargs)
            finally:
                self.seconds += time.process_time() - start

        def objective(*args, **kwargs):
            self.objective += 1
            return self.originals[1](*args, **kwargs)

        _evidence._evidence, _evidence._objective = evidence, objective

    def close(self):
        self.module._evidence, self.module._objective = self.originals


class _ScipyWatch:
    """A finder that records the stack of the first import of SciPy (it imports nothing itself)."""

    stack = None

    def __init__(self, watched="scipy"):
        self.watched = watched

    def find_spec(self, name, path=None, target=None):
        if self.stack is None and name.startswith(self.watched):
            import traceback

            self.stack = "".join(traceback.format_stack(limit=14)[:-1])
        return None


def child(mode, argv, count=False):
    """``encal fit`` as the command line runs it (``argv`` its arguments); ``mode`` 'scipy' (as it is),
    'scipy-free' or 'no-optimize' (the hand-written optimiser, SciPy's LAPACK kept).

    The stand-ins are patched in before anything imports SciPy, and the process fails naming the importer if
    SciPy (SciPy's optimiser for 'no-optimize') is in ``sys.modules`` at its end. With ``count``, the evaluation
    counts go to stderr.
    """
    forbidden = {"scipy-free": "scipy", "no-optimize": "scipy.optimize"}.get(mode)
    if forbidden:
        watch = _ScipyWatch(forbidden)
        sys.meta_path.insert(0, watch)
    from encal.cli import main

    if forbidden:
        scipy_free(optimiser_only=mode == "no-optimize").__enter__()
    counts = Counts() if count else None
    status = main(argv)
    if counts is not None:
        print(f"counts evidence {counts.evidence} objective {counts.objective} seconds {counts.seconds:.3f}",
              file=sys.stderr)
    if forbidden and forbidden in sys.modules:
        print(f"{forbidden} was imported:\n{watch.stack}", file=sys.stderr)
        raise SystemExit(3)
    raise SystemExit(status)


# -- measurement (the parent) -----------------------------------------------------------------------------------

HERE = os.path.dirname(os.path.abspath(__file__))
CHILD = "import sys; sys.path.insert(0, {here!r}); import bench_scipy_free as b; b.child({mode!r}, sys.argv[1:]{count})"


def child_command(mode, arguments, count=False):
    """A ``python -c`` command line: the stand-ins come from this module's cached bytecode, not a recompiled
    script."""
    code = CHILD.format(here=HERE, mode=mode, count=", count=True" if count else "")
    return [sys.executable, "-c", code, *map(str, arguments)]


def profile_difference(first, second, angles=np.arange(3600) * 0.1):
    """Largest |difference| of two models' profiles at ``angles`` (3,600 over the circle), arcmin, and the largest in
    units of the first's posterior standard deviation of the profile there (NaN without one)."""
    from encal import EncalError

    difference = np.abs(first.predict(angles) - second.predict(angles))
    try:
        std = first.predict(angles, return_std=True, include_noise=False)[1]
    except (TypeError, EncalError):
        std = np.full(angles.shape, np.nan)
    return float(np.max(difference)), float(np.max(difference / std))


def model_summary(model):
    training = model.training or {}
    return training.get("log_evidence_nats"), tuple(training.get("lines") or ()), model.kind


def compare_fits(cal, rng_seed=0, test=None, truth=None):
    """Fit ``cal`` as ``encal fit`` does (method auto), with SciPy and SciPy-free; their differences."""
    import encal

    counts = Counts()
    with_scipy = encal.fit(cal, rng=rng_seed)
    counts.close()
    with scipy_free():
        counts_free = Counts()
        without = encal.fit(cal, rng=rng_seed)
        counts_free.close()
    (evidence_a, lines_a, kind_a), (evidence_b, lines_b, kind_b) = model_summary(with_scipy), model_summary(without)
    profile, in_std = profile_difference(with_scipy, without)
    result = {"profile": profile, "in_std": in_std, "same_kind": kind_a == kind_b,
              "evidence": (evidence_b - evidence_a) if evidence_a is not None and evidence_b is not None else None,
              "same_lines": lines_a == lines_b, "lines": (lines_a, lines_b),
              "counts": (counts.evidence, counts.objective, counts_free.evidence, counts_free.objective)}
    if test is not None:
        reference, error = test
        result["held_out"] = tuple(float(np.sqrt(np.mean((m.predict(reference) - error) ** 2)))
                                   for m in (with_scipy, without))
    if truth is not None:
        angles, true_error = truth
        result["truth"] = tuple(float(np.sqrt(np.mean((m.predict(angles) - true_error) ** 2)))
                                for m in (with_scipy, without))
    return result


def real_cases(folder, count):
    """``(name, calibration)`` of the first ``count`` files of ``folder``'s index.csv (as bench_real_data)."""
    import csv

    import encal

    with open(os.path.join(folder, "index.csv"), newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))[:count]
    for row in rows:
        yield row["file"], encal.read_calibration(os.path.join(folder, row["file"]), name=row["file"])


def simulated_cases(count):
    """``(name, calibration, test, truth)`` of ``count`` simulated resolvers on jittered stops (seeds 0, 1, ...)."""
    from encal.simulate import TEST_GRID_DEG, TRAINING_GRID_DEG, calibration_run, draw_encoder

    for seed in range(count):
        rng = np.random.default_rng(1000 + seed)
        stops = TRAINING_GRID_DEG + rng.uniform(-0.3, 0.3, TRAINING_GRID_DEG.size) * 2.0
        encoder = draw_encoder(seed, name=f"sim{seed}")
        run = calibration_run(encoder, stops, rng=seed)
        test = calibration_run(encoder, TEST_GRID_DEG, rng=10_000 + seed)
        yield (f"sim{seed}", run.calibration, (test.calibration.encoder_deg, test.calibration.errors_arcmin),
               (test.calibration.encoder_deg, test.noise_free_error_arcmin))


def spread(values, names=None):
    """``worst`` (largest in magnitude, with its sign and, given ``names``, its case) and the median magnitude."""
    values = np.asarray(values, dtype=float)
    names = list(names) if names is not None else [None] * values.size
    known = np.flatnonzero(np.isfinite(values))
    if not known.size:
        return "none"
    worst = known[np.argmax(np.abs(values[known]))]
    where = f" ({names[worst]})" if names[worst] else ""
    return f"worst {values[worst]:+.2g}{where}, median |.| {np.median(np.abs(values[known])):.2g}"


def print_differences(label, results, held_out="held-out RMS"):
    """One line per group: profiles, evidence, lines, evaluations, held-out RMS and RMS off the truth."""
    print(f"\n{label}: {len(results)} fits")
    names = [r["name"] for r in results]
    print(f"- profile, max |difference| at 3,600 angles (arcmin): {spread([r['profile'] for r in results], names)}")
    worst = max(results, key=lambda r: r["profile"])
    print(f"- the same in units of the posterior std of the profile (SciPy's fit): "
          f"{spread([r['in_std'] for r in results], names)}; at the largest difference ({worst['name']}) the log "
          f"evidence differs by {worst['evidence']:+.3g} nats")
    evidence = [np.nan if r["evidence"] is None else r["evidence"] for r in results]
    print(f"- log evidence, SciPy-free minus SciPy (nats): {spread(evidence, names)}"
          f"; SciPy-free higher in {sum(1 for r in results if (r['evidence'] or 0) > 0)}")
    different = [r for r in results if not r["same_lines"]]
    print(f"- the same lines in {len(results) - len(different)} of {len(results)}"
          + "".join(f"; {r['name']}: {r['lines'][0]} / {r['lines'][1]}" for r in different[:4])
          + f"; the same model kind in {sum(r['same_kind'] for r in results)}")
    counts = np.array([r["counts"] for r in results]).sum(axis=0)
    print(f"- evidence computations (objective evaluations), all fits: SciPy {counts[0]} ({counts[1]}), "
          f"SciPy-free {counts[2]} ({counts[3]})")
    for key, what in (("held_out", held_out),
                      ("truth", "RMS off the noise-free error at the test angles")):
        pairs = np.array([r[key] for r in results if key in r])
        if pairs.size:
            relative = pairs[:, 1] / pairs[:, 0] - 1.0
            cases = [r["name"] for r in results if key in r]
            print(f"- {what} (arcmin): SciPy median {np.median(pairs[:, 0]):.4g}, SciPy-free "
                  f"{np.median(pairs[:, 1]):.4g}; relative difference {spread(relative, cases)} "
                  f"(SciPy-free lower in {int(np.sum(relative < 0))}, higher in {int(np.sum(relative > 0))})")


#: The ``encal fit`` processes measured: child mode -> label.
VARIANTS = {"scipy": "encal fit as it is", "scipy-free": "encal fit SciPy-free",
            "no-optimize": "encal fit, the hand-written optimiser, SciPy's LAPACK"}
#: The imports measured alone (``python -c``).
IMPORTS = {"NumPy": "import numpy", "NumPy, scipy.linalg": "import numpy, scipy.linalg",
           "NumPy, scipy.linalg, scipy.optimize": "import numpy, scipy.linalg, scipy.optimize"}


def ratio(a, b):
    """The median (min-max) of the pair ratios ``a / b``."""
    r = a / b
    return f"**{np.median(r):.2f}x** ({np.min(r):.2f}-{np.max(r):.2f})"


def print_imports(env, repeats, run_process):
    """CPU seconds of processes that only import (:data:`IMPORTS`), paired and interleaved after a warm-up."""
    commands = {label: [sys.executable, "-c", code] for label, code in IMPORTS.items()}
    for command in commands.values():
        run_process(command, env)
    cpu = {label: [] for label in commands}
    for _ in range(max(repeats, 5)):
        for label, command in commands.items():
            cpu[label].append(run_process(command, env)[0])
    cpu = {label: np.array(value) for label, value in cpu.items()}
    print("\n| a process that imports | CPU, median | minus NumPy's alone |\n|---|---|---|")
    for label, times in cpu.items():
        print(f"| {label} | {np.median(times):.3f} s | {np.median(times - cpu['NumPy']):+.3f} s |")


STAND_INS = ("triangular_inverse", "inverse_of", "cholesky", "NumpyLapack", "projected_lbfgs", "line_search",
             "optimise",
             "blas_controller")


def numerics_lines():
    """Lines of code of each stand-in (:data:`STAND_INS`): neither docstrings nor comments nor blank lines."""
    import ast

    with open(__file__, encoding="utf-8") as handle:
        source = handle.read()
    lines = source.splitlines()
    counts = {}
    for node in ast.parse(source).body:
        if getattr(node, "name", None) not in STAND_INS:
            continue
        skip = set()
        for inner in ast.walk(node):
            body = getattr(inner, "body", None)
            if isinstance(body, list) and body and isinstance(body[0], ast.Expr) \
                    and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
                skip.update(range(body[0].lineno, body[0].end_lineno + 1))
        code = [lines[number - 1].strip() for number in range(node.lineno, node.end_lineno + 1) if number not in skip]
        counts[node.name] = sum(1 for line in code if line and not line.startswith("#"))
    return counts


def main():
    import argparse
    import subprocess
    import tempfile
    import time
    import warnings

    sys.path.insert(0, HERE)
    from bench_dense_read import NUMPY_FIT, _process_env, run_process, write_files

    import encal

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--files", default="sweep,random", help="which dense files: sweep, random or both")
    parser.add_argument("--real", type=int, default=60, help="how many real files (0: none)")
    parser.add_argument("--simulated", type=int, default=6, help="how many simulated encoders (0: none)")
    parser.add_argument("--data", default=os.path.join(HERE, "..", "..", "shared", "data", "real", "mechaduino"),
                        help="folder with index.csv and the real CSV files")
    args = parser.parse_args()
    print(f"rows {args.rows}, {args.repeats} pairs each, load average {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores")
    started = time.process_time()
    with tempfile.TemporaryDirectory() as folder:
        files = {name: path for name, path in write_files(folder, args.rows).items()
                 if name in args.files.split(",")}
        script = os.path.join(folder, "numpy_fit.py")
        with open(script, "w") as handle:
            handle.write(NUMPY_FIT)
        env = _process_env(folder)
        print_imports(env, args.repeats, run_process)
        print("\n| file | whole process | CPU, median | / the NumPy script | / encal fit as it is | evidence "
              "computations (objective evaluations; CPU in the computations) | profile max abs diff. from as it is, "
              "arcmin (in posterior stds) | log evidence minus as it is's, nats | the same lines |\n"
              "|---|---|---|---|---|---|---|---|---|")
        for name, path in files.items():
            models = {key: os.path.join(folder, f"{name}-{key}.json") for key in VARIANTS}
            commands = {"scipy": [sys.executable, "-m", "encal", "fit", path, "-o", models["scipy"]],
                        **{key: child_command(key, ["fit", path, "-o", models[key]]) for key in VARIANTS if
                           key != "scipy"},
                        "plain": [sys.executable, script, path, os.path.join(folder, "coefficients.npy")]}
            for command in commands.values():  # warm-up: bytecode
                run_process(command, env)
            cpu = {key: [] for key in commands}
            for _ in range(args.repeats):
                for key, command in commands.items():
                    cpu[key].append(run_process(command, env)[0])
            cpu = {key: np.array(value) for key, value in cpu.items()}
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fitted = {key: encal.load_model(models[key]) for key in VARIANTS}
            for key, label in (*VARIANTS.items(), ("plain", "the NumPy script")):
                cells = [f"{np.median(cpu[key]):.3f} s", ratio(cpu[key], cpu["plain"]), ratio(cpu[key], cpu["scipy"])]
                if key in VARIANTS:
                    process = subprocess.run(child_command(key, ["fit", path, "-o", os.path.join(folder, "c.json")],
                                                           count=True), env=env, capture_output=True, text=True)
                    if process.returncode != 0:
                        raise SystemExit(f"the {key} child failed: {process.stderr.strip()[-2000:]}")
                    words = next(x for x in process.stderr.splitlines() if x.startswith("counts ")).split()
                    cells.append(f"{words[2]} ({words[4]}; {float(words[6]):.2f} s)")
                if key in VARIANTS and key != "scipy":
                    (evidence_a, lines_a, _), (evidence_b, lines_b, _) = (model_summary(fitted["scipy"]),
                                                                          model_summary(fitted[key]))
                    profile, in_std = profile_difference(fitted["scipy"], fitted[key])
                    cells += [f"{profile:.2g} ({in_std:.2g})", f"{evidence_b - evidence_a:+.3g}",
                              "yes" if lines_a == lines_b else f"no: {lines_a} / {lines_b}"]
                else:
                    cells += [""] * (4 if key == "plain" else 3)
                print(f"| {name} | {label} | " + " | ".join(cells) + " |")
    if args.real and not os.path.exists(os.path.join(args.data, "index.csv")):
        print(f"\nno real files: {args.data} has no index.csv (pass --data)")
    elif args.real:
        full, held_out = [], []
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for name, cal in real_cases(args.data, args.real):
                full.append({"name": name, **compare_fits(cal)})
                even = np.arange(len(cal)) % 2 == 0
                odd = cal.subset(~even)
                held_out.append({"name": name, **compare_fits(cal.subset(even),
                                                              test=(odd.encoder_deg, odd.errors_arcmin))})
        print_differences("real AS5047D files, all rows", full)
        print_differences("real AS5047D files, even rows", held_out,
                          "held-out RMS on the odd rows, fitted on the even rows")
    if args.simulated:
        simulated = []
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for name, cal, test, truth in simulated_cases(args.simulated):
                simulated.append({"name": name, **compare_fits(cal, test=test, truth=truth)})
        print_differences("simulated resolvers, 180 jittered stops", simulated,
                          "RMS off a second run's readings at the test grid's angles")
    counts = numerics_lines()
    print(f"\nthe stand-ins: {sum(counts.values())} lines of code, docstrings, comments and blank lines aside ("
          + ", ".join(f"{name} {count}" for name, count in counts.items()) + ")")
    print(f"\nthis process's CPU {time.process_time() - started:.0f} s; load average at the end "
          f"{os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()

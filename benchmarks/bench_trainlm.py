"""trainlm speed on the paper's 1:80:1 network, and the hidden-size sweep behind the periodic default.

Usage::

    python benchmarks/bench_trainlm.py            # speed tables (about a minute)
    python benchmarks/bench_trainlm.py --sweep    # + test RMS against N (a few minutes)

Table 1: trainlm with MATLAB's defaults on the first demo-fleet encoder's
training run (180 points, 0:2:358°): milliseconds per epoch, epochs, tries
per epoch (μ retries included), seconds to the stop, training and test RMS
(interleaved 1:2:359° run), for 'raw' (241 weights) and 'periodic' (321
weights) input, three initialisation seeds. "ms/epoch" is wall-clock time,
"CPU ms/ep" the process's CPU time (all threads), the fairer figure on a
machine that other work shares.

Table 2: the same training with the linear algebra done two ways: one
Cholesky factorisation of JJᵀ + μI per μ try (what trainlm does), or one
eigendecomposition of JJᵀ per epoch, after which every μ try is two
matrix-vector products.

Table 3 (``--sweep``): test RMS on the interleaved 1:2:359° grid against the
number of hidden neurons, four simulated encoders (``simulate_fleet(4, 7)``)
times three initialisation seeds.
"""

import argparse
import os
import platform
import time

import numpy as np

import encal.training.trainlm as trainlm_module
from encal.models.ann import fit_ann
from encal.training import train
from encal.training.network import NetworkProblem


def demo_run():
    """Training and test calibrations of the first demo-fleet encoder (or a synthetic stand-in)."""
    try:
        from encal.simulate._fleet import demo_fleet
    except ImportError:
        theta = np.arange(0.0, 360.0, 2.0)
        rng = np.random.default_rng(0)

        def profile(t):
            t = np.radians(t)
            return 3 * np.sin(t + 0.3) + 1.5 * np.cos(2 * t) + 0.5 * np.sin(4 * t + 1) + 0.3 * np.cos(7 * t)

        return ("synthetic", theta, profile(theta) + 0.1 * rng.standard_normal(180), theta + 1,
                profile(theta + 1))
    member = demo_fleet()[0]
    train_cal, test_cal = member.train.calibration, member.test.calibration
    return (f"demo_fleet()[0] ({member.name})", train_cal.encoder_deg, train_cal.errors_arcmin,
            test_cal.encoder_deg, test_cal.errors_arcmin)


class EigenSystem:
    """trainlm's damped step from one eigendecomposition of the Gram matrix per epoch."""

    def __init__(self, J, e, gram=None):
        self.J, self.dual = J, J.shape[0] < J.shape[1]
        if gram is None:
            gram = J @ J.T if self.dual else J.T @ J
        self.eigenvalues, self.vectors = np.linalg.eigh(gram, UPLO="L")
        self.projected = self.vectors.T @ (e if self.dual else J.T @ e)

    def step(self, mu):
        dx = self.vectors @ (self.projected / (self.eigenvalues + mu))
        return -(self.J.T @ dx) if self.dual else -dx


def speed_table(theta, error, theta_test, error_test, strategy="cholesky", seeds=(0, 1, 2)):
    """One row per input encoding and seed: the run's speed, stop and accuracy."""
    rows = []
    for encoding in ("raw", "periodic"):
        problem = NetworkProblem.from_angles(theta, error, 80, encoding=encoding)
        test = NetworkProblem.from_angles(theta_test, error_test, 80, encoding=encoding,
                                          input_scaling=problem.input_scaling,
                                          target_scaling=problem.target_scaling)
        gain = float(problem.target_scaling.gain)
        for seed in seeds:
            original = trainlm_module.DampedGaussNewton
            if strategy == "eigh":
                trainlm_module.DampedGaussNewton = EigenSystem
            try:
                cpu_start = time.process_time()
                result = train(problem, "trainlm", x0=problem.initial_weights(seed))
                cpu_seconds = time.process_time() - cpu_start
            finally:
                trainlm_module.DampedGaussNewton = original
            epochs = max(result.epochs, 1)
            # nfev: one Jacobian per epoch (and at the start) plus one evaluation per μ try
            tries = (result.nfev - 1) / epochs - 1
            rows.append((encoding, seed, problem.n_params, 1e3 * result.time_s / epochs,
                         1e3 * cpu_seconds / epochs, result.epochs, tries, result.time_s, result.reason,
                         np.sqrt(result.mse) / gain, np.sqrt(test.mse(result.x)) / gain))
    return rows


def print_speed(rows):
    print(f"{'input':<9} {'seed':>4} {'weights':>7} {'ms/epoch':>9} {'CPU ms/ep':>9} {'epochs':>6} "
          f"{'tries/ep':>8} {'seconds':>8} {'stop':<9} {'train RMS':>9} {'test RMS':>9}")
    for enc, seed, n, ms, cpu_ms, epochs, tries, seconds, reason, train_rms, test_rms in rows:
        print(f"{enc:<9} {seed:>4d} {n:>7d} {ms:>9.3f} {cpu_ms:>9.3f} {epochs:>6d} {tries:>8.2f} "
              f"{seconds:>8.3f} {reason:<9} {train_rms:>8.4f}' {test_rms:>8.4f}'")


def sweep(hidden=(8, 12, 16, 20, 30, 40, 80), seeds=(0, 1, 2)):
    from encal.simulate._fleet import simulate_fleet

    fleet = simulate_fleet(4, 7)
    print(f"{'input':<9} {'N':>3} " + " ".join(f"{m.name:>7}" for m in fleet) + f" {'mean':>7} {'s/fit':>6}")
    for encoding, sizes in (("periodic", hidden), ("raw", (80,))):
        for n in sizes:
            per_encoder, seconds = [], []
            for member in fleet:
                train_cal, test_cal = member.train.calibration, member.test.calibration
                rms = []
                for seed in seeds:
                    start = time.perf_counter()
                    model = fit_ann(train_cal.encoder_deg, train_cal.errors_arcmin, hidden=n,
                                    encoding=encoding, rng=seed)
                    seconds.append(time.perf_counter() - start)
                    residual = test_cal.errors_arcmin - model.predict(test_cal.encoder_deg)
                    rms.append(np.sqrt(np.mean(residual**2)))
                per_encoder.append(np.mean(rms))
            print(f"{encoding:<9} {n:>3d} " + " ".join(f"{v:>6.3f}'" for v in per_encoder)
                  + f" {np.mean(per_encoder):>6.3f}' {np.mean(seconds):>6.2f}")


def machine():
    threads = os.environ.get("OPENBLAS_NUM_THREADS", "default")
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    return (f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
            f"NumPy {np.__version__}, OPENBLAS_NUM_THREADS={threads}, load average {load}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sweep", action="store_true", help="also run the hidden-size sweep")
    args = parser.parse_args()
    name, theta, error, theta_test, error_test = demo_run()
    print(f"trainlm 1:80:1, MATLAB defaults, on {name}: {theta.size} training points")
    print(f"machine: {machine()}\n")
    print("Table 1: speed and convergence, seeds 0-2")
    print_speed(speed_table(theta, error, theta_test, error_test))
    print("\nTable 2: linear algebra per epoch, mean of seeds 0-2")
    print(f"{'strategy':<30} {'input':<9} {'ms/epoch':>9} {'CPU ms/ep':>9}")
    for strategy, label in (("cholesky", "Cholesky per μ try (trainlm)"),
                            ("eigh", "eigendecomposition per epoch")):
        rows = speed_table(theta, error, theta_test, error_test, strategy)
        for encoding in ("raw", "periodic"):
            ms = np.mean([row[3] for row in rows if row[0] == encoding])
            cpu_ms = np.mean([row[4] for row in rows if row[0] == encoding])
            print(f"{label:<30} {encoding:<9} {ms:>9.3f} {cpu_ms:>9.3f}")
    if args.sweep:
        print("\nTable 3: test RMS (arcmin) against hidden neurons N, trainlm, mean of 3 seeds")
        sweep()


if __name__ == "__main__":
    main()

"""How close to the measurement floor can the network alone come, alone and averaged?

Usage::

    python benchmarks/bench_networks.py              # 3 seeds, about 5 minutes on 2 cores
    python benchmarks/bench_networks.py --seeds 1    # quicker

The demo fleet's goal for "the network alone" is stated against the measurement
floor (``encal.simulate.measurement_floor``). This script measures the network
configurations a user would try, on every demo encoder: fitted to the training
run (0:2:358 degrees), tested on the test run (1:2:359 degrees, fresh noise).

An *ensemble* of k networks is their mean, each trained from its own initial
weights: ``encal.fit(cal, method="stack", members=[{"family": "ann", "options":
options}] * k, weights=[1 / k] * k, rng=seed)``. It is a model file of kind
``stack`` like any other, so it deploys unchanged (runtime, C, tables). Member
``i`` draws from the ``i``-th stream of the seed, so the first 3 members of the
ensemble of 10 are the ensemble of 3: the script fits 10 once per encoder and
seed and scores the means of its first 1, 3, 5 and 10 members (trainbr: 1 and 3).

Printed: test RMS / floor per encoder (mean over the seeds), the worst encoder,
and the CPU seconds of one network's fit (mean).
"""

import os

# One BLAS thread: the matrices are small and a threaded BLAS contends on 2 cores.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import encal  # noqa: E402
from encal.simulate import demo_fleet, measurement_floor  # noqa: E402

#: name -> (options of the ``ann`` method, ensemble sizes). trainbr lands near the same weights from
#: every start (its ensembles of 3 gain under 1 %) and takes 20 times as long, so it stops at 3.
CONFIGURATIONS = {
    "periodic 1:30:1 trainlm (default)": ({}, (1, 3, 5, 10)),
    "periodic 1:40:1 trainlm": ({"hidden": 40}, (1, 3, 5, 10)),
    "periodic 1:60:1 trainlm": ({"hidden": 60}, (1, 3, 5, 10)),
    "raw 1:80:1 trainlm (the paper's)": ({"encoding": "raw", "hidden": 80}, (1, 3, 5, 10)),
    "raw 1:80:1 trainbr": ({"encoding": "raw", "hidden": 80, "algorithm": "trainbr"}, (1, 3)),
}


def ensemble_ratios(member, options, sizes, seed):
    """Test RMS / floor of the means of the first k networks, for each k in sizes; and CPU seconds per network."""
    largest = max(sizes)
    start = time.process_time()
    model = encal.fit(member.train.calibration, method="stack", rng=seed,
                      members=[{"family": "ann", "options": options}] * largest, weights=[1.0 / largest] * largest)
    seconds = (time.process_time() - start) / largest
    test = member.test.calibration
    predictions = np.array([network.predict(test.encoder_deg) for network in model.members])
    floor = measurement_floor(member.test)
    ratios = {}
    for k in sizes:
        residual = test.errors_arcmin - predictions[:k].mean(axis=0)
        ratios[k] = float(np.sqrt(np.mean(residual ** 2))) / floor
    assert abs(ratios[largest] - encal.evaluate(model, test).after.rms / floor) < 1e-9  # the deployable model
    return ratios, seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=3, help="number of seeds 0..N-1 (default 3)")
    args = parser.parse_args()

    fleet = demo_fleet()
    names = [member.name for member in fleet]
    print(f"# The network alone on the demo fleet (test runs), seeds 0..{args.seeds - 1}")
    print(f"python {platform.python_version()}, numpy {np.__version__}, {os.cpu_count()} cores, "
          f"{platform.machine()}\n")
    print("Test RMS / measurement floor, mean over the seeds; an ensemble of k is the mean of k networks.\n")
    print("| network | k | " + " | ".join(names) + " | worst | CPU s per network |")
    print("|---|---|" + "---|" * len(names) + "---|---|")
    for label, (options, sizes) in CONFIGURATIONS.items():
        ratios = {k: {name: [] for name in names} for k in sizes}
        seconds = []
        for member in fleet:
            for seed in range(args.seeds):
                by_size, elapsed = ensemble_ratios(member, options, sizes, seed)
                seconds.append(elapsed)
                for k, ratio in by_size.items():
                    ratios[k][member.name].append(ratio)
        for k in sizes:
            means = [float(np.mean(ratios[k][name])) for name in names]
            cells = " | ".join(f"{mean:.2f}" for mean in means)
            cost = f"{np.mean(seconds):.3f}" if k == sizes[0] else ""
            print(f"| {label} | {k} | {cells} | {max(means):.2f} | {cost} |", flush=True)


if __name__ == "__main__":
    main()

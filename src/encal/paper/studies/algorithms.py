"""Training-algorithm comparison (the paper's Table 2) at a fixed network size.

The paper trains the 1:80:1 network with seven MATLAB algorithms and reports
one final MSE each (Levenberg-Marquardt lowest, 0.0083 arcmin^2). One run per
algorithm is an anecdote: the final MSE of a network depends on its initial
weights. Here every algorithm trains the network from the same ``seeds``
initial weights with the same epoch budget, and the table gives the mean,
spread and range over seeds, plus each network's RMS on the test grid.
"""

from collections import Counter
from dataclasses import dataclass

import numpy as np

from ..._core.limits import check_size
from ..._core.parameters import check_bool, invalid
from ._checks import check_algorithms, check_calibration, check_encoding, check_epochs, check_seed
from ._fits import task_seed, train_once
from ..._core.pool import run_tasks
from ..._core.threads import single_blas_thread

__all__ = ["PAPER_ALGORITHMS", "EXTRA_ALGORITHMS", "AlgorithmRow", "AlgorithmStudy", "compare_algorithms"]

#: The paper's seven algorithms in its Table 2 order, with the names it prints.
PAPER_ALGORITHMS = {
    "trainrp": "Res-Backpropagation",
    "traincgp": "Conj-Gradient",
    "traincgf": "Fletcher-Reeves",
    "trainoss": "One Step-Secant",
    "trainlm": "Levenberg-Marquardt",
    "trainscg": "Scaled-Conjugate",
    "trainbfg": "Quasi-Newton",
}

#: Algorithms encal adds: Bayesian regularisation and the two plain backpropagation variants.
EXTRA_ALGORITHMS = ("trainbr", "traingd", "traingdx")


@dataclass(frozen=True, eq=False)
class AlgorithmRow:
    """One algorithm's fits, one per seed.

    Attributes
    ----------
    algorithm : str
        MATLAB name.
    paper_name : str or None
        The name the paper's Table 2 prints, if it is one of the paper's.
    mse_arcmin2 : ndarray of shape (n_seeds,)
        Final training MSE of each fit, arcmin^2.
    epochs : ndarray of int of shape (n_seeds,)
        Epochs each fit ran.
    reasons : tuple of str
        What stopped each fit (keys of ``encal.training.STOP_REASONS``).
    time_s : ndarray of shape (n_seeds,)
        Training time of each fit, seconds.
    test_rms_arcmin : ndarray of shape (n_seeds,) or None
        RMS of each network's residual on the test points, arcmin.
    curve_arcmin2 : ndarray
        Training MSE after every epoch of the first seed's fit, arcmin^2.
    test_curve_arcmin2 : ndarray or None
        Test MSE after every epoch of the same fit, arcmin^2.
    cpu_s : ndarray of shape (n_seeds,)
        CPU time of each fit, seconds.
    """

    algorithm: str
    paper_name: str | None
    mse_arcmin2: np.ndarray
    epochs: np.ndarray
    reasons: tuple
    time_s: np.ndarray
    test_rms_arcmin: np.ndarray | None
    curve_arcmin2: np.ndarray
    test_curve_arcmin2: np.ndarray | None = None
    cpu_s: np.ndarray | None = None

    @property
    def mse_mean(self):
        """Mean final MSE over seeds, arcmin^2."""
        return float(self.mse_arcmin2.mean())

    @property
    def mse_std(self):
        """Population standard deviation of the final MSE over seeds, arcmin^2."""
        return float(self.mse_arcmin2.std())

    @property
    def mse_min(self):
        """Lowest final MSE, arcmin^2."""
        return float(self.mse_arcmin2.min())

    @property
    def mse_max(self):
        """Highest final MSE, arcmin^2."""
        return float(self.mse_arcmin2.max())

    @property
    def epochs_median(self):
        """Median number of epochs run."""
        return float(np.median(self.epochs))

    @property
    def time_mean_s(self):
        """Mean training time, seconds."""
        return float(self.time_s.mean())

    @property
    def cpu_mean_s(self):
        """Mean CPU time of one fit, seconds (None if not measured)."""
        return None if self.cpu_s is None else float(self.cpu_s.mean())

    @property
    def test_rms_median(self):
        """Median test RMS over seeds, arcmin (None without test points)."""
        return None if self.test_rms_arcmin is None else float(np.median(self.test_rms_arcmin))

    @property
    def test_rms_worst(self):
        """Largest test RMS over seeds, arcmin (None without test points)."""
        return None if self.test_rms_arcmin is None else float(self.test_rms_arcmin.max())

    @property
    def stop_reasons(self):
        """The stop reasons with their counts, most common first (``'epochs x4, min_grad x1'``)."""
        return ", ".join(f"{reason} x{count}" for reason, count in Counter(self.reasons).most_common())


@dataclass(frozen=True, eq=False)
class AlgorithmStudy:
    """Final training MSE of one network size per training algorithm, over seeds.

    Attributes
    ----------
    encoder : str
    hidden : int
    encoding : str
    epochs : int
        The epoch budget every algorithm had.
    seeds : ndarray of int
        Seeds of the initial weights (the same for every algorithm).
    rows : tuple of AlgorithmRow
        In the order the algorithms were given.
    """

    encoder: str
    hidden: int
    encoding: str
    epochs: int
    seeds: np.ndarray
    rows: tuple

    @property
    def n_seeds(self):
        return int(self.seeds.size)

    def row(self, algorithm):
        """The row of one algorithm."""
        for row in self.rows:
            if row.algorithm == algorithm:
                return row
        raise KeyError(algorithm)

    def ranking(self):
        """Algorithms from lowest to highest mean MSE."""
        return [row.algorithm for row in sorted(self.rows, key=lambda r: r.mse_mean)]

    def table(self):
        """Table 2 as a :class:`~encal.paper.studies.tables.Table`."""
        from .tables import algorithm_table

        return algorithm_table(self)

    def plot(self, ax=None):
        """Final MSE per algorithm with its spread (see :func:`encal.figures.plot_algorithms`)."""
        from ...figures import plot_algorithms
        from .tables import PAPER_TABLE2

        return plot_algorithms(self, ax=ax, paper_mse=PAPER_TABLE2)

    def plot_curves(self, ax=None):
        """MSE against epoch of every algorithm (first seed)."""
        from ...figures import plot_training_curves

        return plot_training_curves({r.algorithm: [r.curve_arcmin2] for r in self.rows}, hidden=self.hidden,
                                    ax=ax)


@single_blas_thread
def compare_algorithms(cal, test=None, *, algorithms=(*PAPER_ALGORITHMS, *EXTRA_ALGORITHMS), hidden=80,
                       encoding="raw", epochs=1000, seeds=5, rng=0, workers=None, progress=False):
    """Train the 1:N:1 network with every algorithm from the same initial weights (Table 2).

    Parameters
    ----------
    cal : Calibration
        Training calibration.
    test : Calibration, optional
        Test calibration; each network's residual RMS on it is recorded.
    algorithms : sequence of str
        MATLAB names; default the paper's seven, then trainbr, traingd and traingdx.
    hidden : int, default=80
        Hidden nodes N (the paper's 80).
    encoding : {'raw', 'periodic'}, default='raw'
        Network input encoding (the paper's raw angle by default).
    epochs : int, default=1000
        The same epoch budget for every algorithm (MATLAB's default); an algorithm stops earlier only by
        its own MATLAB criteria (``min_grad``, ``mu_max``, ...).
    seeds : int, default=5
        Fits per algorithm; fit k of every algorithm starts from the same weights, seeded by ``(rng, N, k)``.
    rng : int, default=0
        Study seed.
    workers : int, Workers or None, default=None
        Worker processes: None for the CPU count (at most 2), 0 to fit in this process.
    progress : bool, default=False
        Progress bar on stderr.

    Returns
    -------
    AlgorithmStudy
    """
    where = "compare_algorithms"
    cal = check_calibration(cal, "cal", where)
    if test is not None:
        test = check_calibration(test, "test", where)
    algorithms = check_algorithms(algorithms, where)
    if isinstance(epochs, dict):
        raise invalid("epochs", where, "one int >= 1, the same budget for every algorithm", epochs,
                      shown="a dict")
    budget = check_epochs(epochs, algorithms, where)
    hidden = check_size("hidden", hidden, where)
    encoding = check_encoding(encoding, where)
    n_seeds = check_size("seeds", seeds, where)
    seed = check_seed(rng, where)
    progress = check_bool(progress, "progress", where)
    seeds_used = np.array([task_seed(seed, hidden, k) for k in range(n_seeds)])
    test_points = None if test is None else (test.encoder_deg, test.errors_arcmin)
    tasks = [{"theta_deg": cal.encoder_deg, "error_arcmin": cal.errors_arcmin, "hidden": hidden,
              "algorithm": algorithm, "encoding": encoding, "seed": int(s), "epochs": budget[algorithm],
              "keep_curve": k == 0, "test": test_points}
             for algorithm in algorithms for k, s in enumerate(seeds_used)]
    results = run_tasks(train_once, tasks, workers=workers, label="algorithm table", progress=progress)
    rows = []
    for i, algorithm in enumerate(algorithms):
        mine = results[i * n_seeds:(i + 1) * n_seeds]
        rows.append(AlgorithmRow(
            algorithm=algorithm,
            paper_name=PAPER_ALGORITHMS.get(algorithm),
            mse_arcmin2=np.array([r["mse_arcmin2"] for r in mine]),
            epochs=np.array([r["epochs"] for r in mine]),
            reasons=tuple(r["reason"] for r in mine),
            time_s=np.array([r["time_s"] for r in mine]),
            test_rms_arcmin=None if test is None else np.array([r["test_rms_arcmin"] for r in mine]),
            curve_arcmin2=mine[0]["curve"],
            test_curve_arcmin2=None if test is None else mine[0]["test_curve"],
            cpu_s=np.array([r["cpu_s"] for r in mine]),
        ))
    return AlgorithmStudy(encoder=cal.name, hidden=hidden, encoding=encoding, epochs=int(epochs),
                          seeds=seeds_used, rows=tuple(rows))

"""Hidden-node sweep (the paper's Fig. 2): training MSE against the number of hidden nodes.

The paper trains the 1:N:1 network on one encoder's training grid for
N = 10, 20, ..., 110 with backpropagation (``traingd``) and Levenberg-Marquardt
(``trainlm``), records the final MSE (Fig. 2a) and the MSE against the
iteration for N = 80 (Fig. 2b), and picks N = 80 as the knee. Here every point
is a fit from a seeded Nguyen-Widrow start; with several seeds the spread shows
how much of a difference between two N is the starting point.
"""

from dataclasses import dataclass

import numpy as np

from ..._core.limits import check_size
from ..._core.parameters import check_bool, check_choice
from ._checks import check_algorithms, check_calibration, check_counts, check_encoding, check_epochs, check_seed
from ._fits import task_seed, train_once
from ..._core.pool import run_tasks
from ..._core.threads import single_blas_thread

__all__ = ["PAPER_HIDDEN", "SweepResult", "hidden_node_sweep"]

#: The paper's hidden-node counts, 10 to 110 in steps of 10.
PAPER_HIDDEN = tuple(range(10, 111, 10))


@dataclass(frozen=True, eq=False)
class SweepResult:
    """Final training MSE of the 1:N:1 network for several N, algorithms and seeds.

    Attributes
    ----------
    encoder : str
        Name of the calibration the networks were trained on.
    hidden : ndarray of int of shape (n_hidden,)
        Hidden-node counts N.
    algorithms : tuple of str
        Training algorithms (MATLAB names).
    encoding : {'raw', 'periodic'}
        Network input encoding.
    seeds : ndarray of int of shape (n_hidden, n_seeds)
        Seed of the initial weights of every fit (shared by all algorithms).
    epochs : dict of str to int
        Epoch budget of each algorithm.
    mse_arcmin2 : dict of str to ndarray of shape (n_hidden, n_seeds)
        Final training MSE, arcmin^2.
    epochs_run : dict of str to ndarray of shape (n_hidden, n_seeds)
        Epochs each fit ran before it stopped.
    time_s : dict of str to ndarray of shape (n_hidden, n_seeds)
        Wall-clock training time of each fit, seconds.
    cpu_s : dict of str to ndarray of shape (n_hidden, n_seeds)
        CPU time of each fit, seconds.
    curve_hidden : int or None
        N whose training curves are kept (80, the paper's Fig. 2b).
    curves_arcmin2 : dict of str to list of ndarray
        Training MSE after every epoch (arcmin^2) at ``curve_hidden``, one array per seed.
    test_mse_arcmin2 : dict of str to ndarray of shape (n_hidden, n_seeds), or None
        Final MSE on the test points, arcmin^2, when a test calibration was given.
    test_curves_arcmin2 : dict of str to list of ndarray, or None
        Test MSE after every epoch at ``curve_hidden`` (arcmin^2).
    """

    encoder: str
    hidden: np.ndarray
    algorithms: tuple
    encoding: str
    seeds: np.ndarray
    epochs: dict
    mse_arcmin2: dict
    epochs_run: dict
    time_s: dict
    cpu_s: dict
    curve_hidden: int | None
    curves_arcmin2: dict
    test_mse_arcmin2: dict | None = None
    test_curves_arcmin2: dict | None = None

    @property
    def n_seeds(self):
        """Number of seeds per point."""
        return self.seeds.shape[1]

    def mse_mean(self, algorithm):
        """Mean final MSE over seeds for every N, arcmin^2."""
        return self.mse_arcmin2[algorithm].mean(axis=1)

    def mse_std(self, algorithm):
        """Population standard deviation of the final MSE over seeds for every N, arcmin^2 (0 for one seed)."""
        return self.mse_arcmin2[algorithm].std(axis=1)

    def test_mse_median(self, algorithm):
        """Median final test MSE over seeds for every N, arcmin^2 (None without a test calibration).

        The median, because one network of several that oscillates between the training points can raise the
        mean test MSE a hundredfold.
        """
        return None if self.test_mse_arcmin2 is None else np.median(self.test_mse_arcmin2[algorithm], axis=1)

    def table(self):
        """The sweep as a :class:`~encal.paper.studies.tables.Table` (Fig. 2a as numbers)."""
        from .tables import sweep_table

        return sweep_table(self)

    def plot(self, ax=None):
        """Fig. 2a: final MSE against N (see :func:`encal.figures.plot_sweep`)."""
        from ...figures import plot_sweep

        return plot_sweep(self, ax=ax)

    def plot_curves(self, ax=None):
        """Fig. 2b: MSE against epoch at ``curve_hidden`` (see :func:`encal.figures.plot_training_curves`)."""
        from ...figures import plot_training_curves

        return plot_training_curves(self.curves_arcmin2, hidden=self.curve_hidden, test=self.test_curves_arcmin2,
                                    ax=ax)


@single_blas_thread
def hidden_node_sweep(cal, test=None, *, hidden=PAPER_HIDDEN, algorithms=("trainlm", "traingd"), encoding="raw",
                      epochs=1000, seeds=1, curve_hidden=80, rng=0, workers=None, progress=False):
    """Train the 1:N:1 network for every N and algorithm; record the final MSE (Fig. 2a) and curves (Fig. 2b).

    Parameters
    ----------
    cal : Calibration
        Training calibration (the paper uses one encoder's 0:2:358 grid).
    test : Calibration, optional
        Test calibration: every network's MSE on it is recorded after every epoch (it never steers training),
        to show what the training MSE does not: where a larger network stops generalising.
    hidden : sequence of int, default=(10, 20, ..., 110)
        Hidden-node counts N.
    algorithms : sequence of str, default=('trainlm', 'traingd')
        Training algorithms; the paper's Fig. 2 compares Levenberg-Marquardt and backpropagation.
    encoding : {'raw', 'periodic'}, default='raw'
        Network input: the angle itself, as in the paper, or (cos, sin).
    epochs : int or dict of str to int, default=1000
        Epoch budget (MATLAB's default) of each algorithm; a fit can stop earlier by its own criteria.
    seeds : int, default=1
        Fits per point, from different initial weights.
    curve_hidden : int or None, default=80
        N whose MSE-per-epoch curves are kept; must be one of ``hidden``.
    rng : int, default=0
        Study seed; the initial weights of the fit (N, k) come from ``(rng, N, k)`` whatever the algorithm,
        the number of workers or the order fits finish in.
    workers : int, Workers or None, default=None
        Worker processes: None for the CPU count (at most 2), 0 to fit in this process
        (see :mod:`encal._core.pool`).
    progress : bool, default=False
        Progress bar on stderr.

    Returns
    -------
    SweepResult
    """
    where = "hidden_node_sweep"
    cal = check_calibration(cal, "cal", where)
    if test is not None:
        test = check_calibration(test, "test", where)
    test_points = None if test is None else (test.encoder_deg, test.errors_arcmin)
    hidden = check_counts(hidden, "hidden", where)
    n_seeds = check_size("seeds", seeds, where)
    algorithms = check_algorithms(algorithms, where)
    encoding = check_encoding(encoding, where)
    budget = check_epochs(epochs, algorithms, where)
    seed = check_seed(rng, where)
    progress = check_bool(progress, "progress", where)
    if curve_hidden is not None:
        curve_hidden = check_choice(curve_hidden, "curve_hidden", where, [*hidden.tolist(), None])
    seeds_grid = np.array([[task_seed(seed, n, k) for k in range(n_seeds)] for n in hidden])
    theta, error = cal.encoder_deg, cal.errors_arcmin
    keys, tasks = [], []
    for algorithm in algorithms:
        for i, n in enumerate(hidden):
            for k in range(n_seeds):
                keys.append((algorithm, i, k))
                tasks.append({"theta_deg": theta, "error_arcmin": error, "hidden": int(n),
                              "algorithm": algorithm, "encoding": encoding, "seed": int(seeds_grid[i, k]),
                              "epochs": budget[algorithm],
                              "keep_curve": curve_hidden is not None and int(n) == int(curve_hidden),
                              "test": test_points})
    results = run_tasks(train_once, tasks, workers=workers, label="hidden-node sweep", progress=progress)
    shape = (hidden.size, n_seeds)
    mse = {a: np.empty(shape) for a in algorithms}
    epochs_run = {a: np.empty(shape, dtype=int) for a in algorithms}
    time_s = {a: np.empty(shape) for a in algorithms}
    cpu_s = {a: np.empty(shape) for a in algorithms}
    test_mse = None if test is None else {a: np.empty(shape) for a in algorithms}
    curves = {a: [None] * n_seeds for a in algorithms}
    test_curves = None if test is None else {a: [None] * n_seeds for a in algorithms}
    for (algorithm, i, k), result in zip(keys, results):
        mse[algorithm][i, k] = result["mse_arcmin2"]
        epochs_run[algorithm][i, k] = result["epochs"]
        time_s[algorithm][i, k] = result["time_s"]
        cpu_s[algorithm][i, k] = result["cpu_s"]
        if result["curve"] is not None:
            curves[algorithm][k] = result["curve"]
        if test is not None:
            test_mse[algorithm][i, k] = result["test_mse_arcmin2"]
            if result["test_curve"] is not None:
                test_curves[algorithm][k] = result["test_curve"]
    if curve_hidden is None:
        curves, test_curves = {}, None
    return SweepResult(encoder=cal.name, hidden=hidden, algorithms=algorithms, encoding=encoding,
                       seeds=seeds_grid, epochs=budget, mse_arcmin2=mse, epochs_run=epochs_run, time_s=time_s,
                       cpu_s=cpu_s, curve_hidden=None if curve_hidden is None else int(curve_hidden),
                       curves_arcmin2=curves, test_mse_arcmin2=test_mse, test_curves_arcmin2=test_curves)

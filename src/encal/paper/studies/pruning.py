"""SVD pruning of the hidden layer (the paper's Fig. 3), done so that it means something.

The paper forms X, the 180 x 80 matrix of the hidden nodes' outputs "before
the sigmoid", counts its non-zero singular values (54-65 of 80 for its four
encoders) and retrains with that many nodes. For a network with one input,
column j of that X is ``w_j x + b_j``: every column is a combination of the
two vectors ``x`` and ``1``, so X has rank 2 at most, whatever the weights,
and its singular values beyond the second are rounding noise.

What Kanjilal & Banerjee (1993, the paper's reference [33]) decompose is the
matrix of the hidden nodes' outputs *after* the activation, H = f(X): two
nodes are redundant when their outputs are (nearly) proportional over the
training inputs, and then H has a small singular value. The number of
significant singular values of H is the number of hidden nodes the network
can use; :func:`svd_pruning` counts those above ``threshold`` times the
largest, retrains a network of that size, and reports both networks' MSE and
test RMS. The figure shows both spectra.

The threshold, 1e-2 of the largest singular value: the output is
``Σ σ_i (v_iᵀ w2) u_i``, so with output weights no larger along direction i
than along the first, direction i adds a pattern at most ``σ_i / σ_1`` times
the dominant one. For a profile of a few arc-minutes, 1 % is a few hundredths
of an arc-minute, well under one 16-bit LSB (0.33 arcmin); a direction that
matters only through much larger output weights is one that fits noise.
It is also what "non-zero" means on a linear plot of singular values like the
paper's Fig. 3, where anything under about 1 % of the largest lies on the
axis. The counts at 1e-3 and 1e-4 are reported too
(:data:`SENSITIVITY_THRESHOLDS`); ``docs/paper.md`` discusses them.
"""

from dataclasses import dataclass

import numpy as np

from ..._core.limits import check_size
from ...models.ann import ANNModel
from ..._core.parameters import check_number, check_type
from ._checks import check_algorithms, check_calibration, check_encoding, check_seed
from ._fits import fit_network, hidden_layer, task_seed, training_mse_arcmin2
from ..._core.threads import single_blas_thread

__all__ = ["DEFAULT_THRESHOLD", "SENSITIVITY_THRESHOLDS", "PruningResult", "significant_count",
           "svd_pruning"]

#: Relative threshold: singular values of H above 1e-2 times the largest are significant.
DEFAULT_THRESHOLD = 1e-2

#: Thresholds at which the count is also reported, to show how much it depends on the choice.
SENSITIVITY_THRESHOLDS = (1e-2, 1e-3, 1e-4)


def significant_count(singular_values, threshold=DEFAULT_THRESHOLD):
    """Number of singular values above ``threshold`` times the largest.

    Examples
    --------
    >>> significant_count([10.0, 1.0, 0.02, 0.001], threshold=1e-3)
    3
    """
    s = np.asarray(singular_values, dtype=float)
    if s.size == 0 or s[0] <= 0:
        return 0
    return int(np.count_nonzero(s > threshold * s.max()))


@dataclass(frozen=True, eq=False)
class PruningResult:
    """SVD analysis of a trained network's hidden layer and the network retrained at the pruned size.

    Attributes
    ----------
    encoder : str
    hidden : int
        Hidden nodes of the analysed network.
    encoding : str
    threshold : float
        Relative threshold of a significant singular value.
    singular_before : ndarray of shape (hidden,)
        Singular values of X, the hidden nodes' net inputs (the paper's matrix), largest first.
    singular_after : ndarray of shape (hidden,)
        Singular values of H = f(X), the hidden nodes' outputs, largest first.
    rank_before_activation : int
        Numerical rank of X (NumPy's default tolerance); 2 at most for one input.
    significant : int
        Singular values of H above ``threshold`` times the largest: the pruned network's size.
    counts : dict of float to int
        The same count at each of :data:`SENSITIVITY_THRESHOLDS`.
    full_model, pruned_model : ANNModel
    full_mse, pruned_mse : float
        Final training MSE, arcmin^2.
    full_test_rms, pruned_test_rms : float or None
        Residual RMS on the test calibration, arcmin.
    """

    encoder: str
    hidden: int
    encoding: str
    threshold: float
    singular_before: np.ndarray
    singular_after: np.ndarray
    rank_before_activation: int
    significant: int
    counts: dict
    full_model: object
    pruned_model: object
    full_mse: float
    pruned_mse: float
    full_test_rms: float | None
    pruned_test_rms: float | None

    def plot(self, ax=None):
        """Fig. 3: both singular-value spectra (see :func:`encal.figures.plot_singular_values`)."""
        from ...figures import plot_singular_values

        return plot_singular_values(self, ax=ax)


def _test_rms(model, test):
    if test is None:
        return None
    residual = test.errors_arcmin - model.predict(test.encoder_deg)
    return float(np.sqrt(np.mean(residual**2)))


@single_blas_thread
def svd_pruning(cal, test=None, *, hidden=80, encoding="raw", algorithm="trainlm", epochs=1000,
                threshold=DEFAULT_THRESHOLD, rng=0, model=None, **train_options):
    """Count the significant hidden nodes of a trained 1:N:1 network by SVD, and retrain at that size.

    Parameters
    ----------
    cal : Calibration
        Training calibration.
    test : Calibration, optional
        Test calibration for the two networks' residual RMS.
    hidden : int, default=80
        Hidden nodes of the network to analyse (the paper's 80).
    encoding : {'raw', 'periodic'}, default='raw'
    algorithm : str, default='trainlm'
    epochs : int, default=1000
        Epoch budget of both trainings.
    threshold : float, default=1e-2
        A singular value of H is significant above ``threshold`` times the largest.
    rng : int, default=0
        Study seed; the network of N nodes starts from the weights seeded by ``(rng, N, 0)``, the same as
        the first seed of :func:`~encal.paper.studies.sweep.hidden_node_sweep` and
        :func:`~encal.paper.studies.algorithms.compare_algorithms`.
    model : ANNModel, optional
        An already trained network to analyse instead of training one. The pruned network is then trained
        the way it was (its encoding, algorithm and options, recorded in ``model.training``).
    **train_options
        More options of the training (``plateau_patience``, ...), for both networks.

    Returns
    -------
    PruningResult
    """
    where = "svd_pruning"
    cal = check_calibration(cal, "cal", where)
    if test is not None:
        test = check_calibration(test, "test", where)
    threshold = check_number(threshold, "threshold", where, low=0.0, high=1.0, low_open=True, high_open=True)
    seed = check_seed(rng, where)
    epochs = check_size("epochs", epochs, where)
    theta, error = cal.encoder_deg, cal.errors_arcmin
    train_options["epochs"] = epochs
    if model is None:
        hidden = check_size("hidden", hidden, where)
        encoding = check_encoding(encoding, where)
        algorithm = check_algorithms([algorithm], where)[0]
        model = fit_network(theta, error, hidden=hidden, algorithm=algorithm, encoding=encoding,
                            seed=task_seed(seed, hidden, 0), **train_options)
    else:
        check_type(model, ANNModel, "model", where, "an ANNModel (a trained 1:N:1 network) or None")
        algorithm = model.training.get("algorithm", algorithm)
        train_options = {**model.training.get("options", {}), **train_options}
    hidden, encoding = model.hidden, model.encoding
    before, after = hidden_layer(model, theta)
    singular_before = np.linalg.svd(before, compute_uv=False)
    singular_after = np.linalg.svd(after, compute_uv=False)
    significant = max(significant_count(singular_after, threshold), 1)
    pruned = fit_network(theta, error, hidden=significant, algorithm=algorithm, encoding=encoding,
                         seed=task_seed(seed, significant, 0), **train_options)
    return PruningResult(
        encoder=cal.name, hidden=hidden, encoding=encoding, threshold=float(threshold),
        singular_before=singular_before, singular_after=singular_after,
        rank_before_activation=int(np.linalg.matrix_rank(before)),
        significant=significant,
        counts={t: significant_count(singular_after, t) for t in SENSITIVITY_THRESHOLDS},
        full_model=model, pruned_model=pruned,
        full_mse=training_mse_arcmin2(model, theta, error),
        pruned_mse=training_mse_arcmin2(pruned, theta, error),
        full_test_rms=_test_rms(model, test), pruned_test_rms=_test_rms(pruned, test),
    )

"""What a training run returns, and the one table of its stopping reasons."""

from dataclasses import dataclass, field

import numpy as np

__all__ = ["TrainResult", "STOP_REASONS"]

#: reason -> (status, success, message). ``success`` means the run ended by a
#: criterion that says the weights are as good as this run can make them.
STOP_REASONS = {
    "goal": (1, True, "Performance goal met."),
    "min_grad": (2, True, "Gradient norm fell below min_grad."),
    "plateau": (3, True, "Normalised RMS error stopped decreasing (the paper's rule)."),
    "max_fail": (4, True, "Validation error rose max_fail epochs in a row; best validation weights kept."),
    "epochs": (0, False, "Maximum number of epochs reached."),
    "time": (0, False, "Maximum training time reached."),
    "mu_max": (5, True, "mu reached mu_max: no step lowers the error any more."),
    "no_progress": (6, True, "The line search found no step that lowers the error."),
    "non_finite": (-1, False, "The error became NaN or infinite; last finite weights kept."),
}


@dataclass
class TrainResult:
    """Outcome of :func:`encal.training.train`.

    Attributes
    ----------
    x : ndarray of shape (n_params,)
        Final weights (with a validation problem: the weights of the best validation epoch).
    algorithm : str
        MATLAB name of the algorithm (``'trainlm'``, ...).
    reason : str
        Key of :data:`STOP_REASONS` that ended the run.
    success, status, message
        From :data:`STOP_REASONS`.
    epochs : int
        Number of completed epochs (iterations).
    mse : float
        Training performance of ``x`` (mean squared residual, problem units).
    val_mse : float or None
        Validation performance of ``x``, when a validation problem was given.
    history : dict of str to ndarray
        Per epoch, starting with epoch 0 (the initial weights): ``'mse'``,
        ``'grad_norm'``, and ``'val_mse'`` when validating; algorithms may add
        their own (``'mu'`` for trainlm, ``'gamma'`` for trainbr, ...).
    nfev : int
        Number of performance evaluations.
    time_s : float
        Wall-clock training time in seconds.
    """

    x: np.ndarray
    algorithm: str
    reason: str
    epochs: int
    mse: float
    val_mse: float | None = None
    history: dict = field(default_factory=dict)
    nfev: int = 0
    time_s: float = 0.0

    @property
    def status(self):
        return STOP_REASONS[self.reason][0]

    @property
    def success(self):
        return STOP_REASONS[self.reason][1]

    @property
    def message(self):
        return STOP_REASONS[self.reason][2]

    def __repr__(self):
        return (
            f"TrainResult(algorithm={self.algorithm!r}, reason={self.reason!r}, "
            f"epochs={self.epochs}, mse={self.mse:.6g})"
        )

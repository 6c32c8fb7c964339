"""Stopping criteria and per-epoch history, shared by every algorithm.

An algorithm calls :meth:`Monitor.update` once per completed epoch with the
new weights, their training performance and gradient; the monitor records the
history, evaluates the validation problem, and answers whether to stop. An
algorithm that must stop for a reason of its own (``mu_max``, a failed line
search) calls :meth:`Monitor.stop`.

Criteria and defaults follow MATLAB's ``trainParam``: ``epochs``, ``goal``,
``min_grad``, ``max_fail`` (only with a validation problem), ``time``; plus the
paper's rule (``plateau``): stop when the normalised RMS error has not
decreased by a relative ``plateau_tol`` over the last ``plateau_patience``
epochs.
"""

import math
import time as _time

import numpy as np

__all__ = ["Monitor"]


class Monitor:
    """Per-epoch bookkeeping and stopping for one training run.

    Parameters
    ----------
    problem : Objective
        The training problem.
    validation : Objective, optional
        A validation problem on other points; enables ``max_fail``.
    epochs : int
        Maximum number of epochs.
    goal : float
        Stop when the training performance is at or below ``goal``.
    min_grad : float
        Stop when the gradient norm falls below ``min_grad``.
    max_fail : int
        Stop when the validation performance has not improved for this many
        epochs in a row; the best validation weights are returned.
    time : float
        Maximum training time in seconds.
    plateau_patience : int or None
        Enables the paper's rule when set.
    plateau_tol : float
        Relative decrease of the RMS error that counts as still decreasing.
    callback : callable, optional
        Called as ``callback(epoch, w, mse)`` after every epoch.
    """

    def __init__(self, problem, *, validation=None, epochs=1000, goal=0.0, min_grad=1e-7,
                 max_fail=6, time=math.inf, plateau_patience=None, plateau_tol=1e-4,
                 callback=None):
        self.problem = problem
        self.validation = validation
        self.max_epochs = int(epochs)
        self.goal = float(goal)
        self.min_grad = float(min_grad)
        self.max_fail = int(max_fail)
        self.max_time = float(time)
        self.plateau_patience = plateau_patience
        self.plateau_tol = float(plateau_tol)
        self.callback = callback
        self.epoch = 0
        self.reason = None
        self.history = {"mse": [], "grad_norm": []}
        if validation is not None:
            self.history["val_mse"] = []
        self.extra = {}
        self.best_w = None
        self.best_val = math.inf
        self.last_finite_w = None
        self._fails = 0
        self._start = _time.perf_counter()

    @property
    def elapsed(self):
        """Seconds since the monitor was made."""
        return _time.perf_counter() - self._start

    def record(self, name, value):
        """Store an algorithm-specific per-epoch quantity (``'mu'``, ``'gamma'``, ...)."""
        self.extra.setdefault(name, []).append(float(value))

    def start(self, w, mse, grad):
        """Record epoch 0 (the initial weights). Returns True if training should not even start."""
        return self._observe(w, mse, grad, count_epoch=False)

    def update(self, w, mse, grad):
        """Record a completed epoch. Returns True when training must stop (see ``reason``)."""
        return self._observe(w, mse, grad, count_epoch=True)

    def stop(self, reason):
        """Stop for an algorithm's own reason, a key of ``STOP_REASONS``."""
        self.reason = reason
        return True

    def _observe(self, w, mse, grad, count_epoch):
        if count_epoch:
            self.epoch += 1
        mse = float(mse)
        with np.errstate(over="ignore", invalid="ignore"):
            grad_norm = float(np.linalg.norm(grad)) if grad is not None else math.nan
        if not (math.isfinite(mse) and np.all(np.isfinite(w))):
            self.reason = "non_finite"
            return True
        self.last_finite_w = np.array(w, dtype=float, copy=True)
        self.history["mse"].append(mse)
        self.history["grad_norm"].append(grad_norm)
        if self.validation is not None:
            val = self.validation.mse(w)
            self.history["val_mse"].append(val)
            if val < self.best_val:
                self.best_val = val
                self.best_w = self.last_finite_w
                self._fails = 0
            else:
                self._fails += 1
        if self.callback is not None:
            self.callback(self.epoch, w, mse)
        if mse <= self.goal:
            self.reason = "goal"
        elif grad_norm < self.min_grad:
            self.reason = "min_grad"
        elif self.validation is not None and self._fails >= self.max_fail:
            self.reason = "max_fail"
        elif self._plateaued():
            self.reason = "plateau"
        elif self.epoch >= self.max_epochs:
            self.reason = "epochs"
        elif self.elapsed >= self.max_time:
            self.reason = "time"
        return self.reason is not None

    def _plateaued(self):
        k = self.plateau_patience
        mse = self.history["mse"]
        if k is None or len(mse) <= k:
            return False
        old_rms, new_rms = math.sqrt(mse[-1 - k]), math.sqrt(mse[-1])
        return new_rms > old_rms * (1.0 - self.plateau_tol)

    def recent_fall(self, window):
        """``(fall, epochs)``: the relative fall of the RMS error over the last ``window`` epochs (fewer when
        fewer ran; 0.25 is a fall of 25 %, negative a rise), and the number of epochs it spans."""
        mse = self.history["mse"]
        span = min(int(window), len(mse) - 1)
        if span < 1 or mse[-1 - span] <= 0.0:
            return 0.0, max(span, 0)
        return 1.0 - math.sqrt(mse[-1]) / math.sqrt(mse[-1 - span]), span

    def final_weights(self, w):
        """The weights to return: with a validation problem, those of the best validation epoch (as MATLAB
        does); otherwise ``w``, or the last finite weights if ``w`` is not finite."""
        if self.best_w is not None:
            return self.best_w
        if self.reason == "non_finite" or not np.all(np.isfinite(w)):
            return self.last_finite_w
        return np.asarray(w, dtype=float)

    def histories(self):
        """History as arrays, including algorithm-specific entries."""
        out = {k: np.asarray(v, dtype=float) for k, v in self.history.items()}
        out.update({k: np.asarray(v, dtype=float) for k, v in self.extra.items()})
        return out

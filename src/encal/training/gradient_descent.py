"""Gradient-descent backpropagation: MATLAB's ``traingd`` and ``traingdx``.

``traingd`` steps ``x ← x - lr·g`` every epoch with a fixed learning rate. A
learning rate that is too large makes it diverge; the run then stops with
``'non_finite'`` and keeps the last finite weights.

``traingdx`` adds momentum and an adaptive learning rate (MATLAB's
``traingdx.m``; Vogl et al. (1988), "Accelerating the convergence of the
back-propagation method", Biological Cybernetics 59, 257-263). Each epoch
tries ``dx ← mc·dx - (1 - mc)·lr·g``:

* if the error grows by more than the factor ``max_perf_inc`` the step is
  not taken, ``lr`` is multiplied by ``lr_dec`` and the momentum is reset to
  ``dx = -lr·g``; an overflowing trial counts as such a step;
* otherwise the step is taken, and ``lr`` is multiplied by ``lr_inc`` if the
  error fell.

A rejected step still counts as an epoch, as in MATLAB.
"""

import numpy as np

from ._registry import register_algorithm
from ._trial import trial_mse_and_gradient
from .trainlm import check_option

__all__ = ["traingd", "traingdx"]


@register_algorithm("traingd", min_grad=1e-5)
def traingd(problem, x0, monitor, *, lr=0.01):
    """Gradient descent with a fixed learning rate.

    Parameters
    ----------
    lr : float, default=0.01
        Learning rate: each epoch moves the weights by ``-lr`` times the
        gradient of the mean squared error.
    """
    lr = check_option("traingd", "lr", lr, 0.0)
    x = x0
    mse, grad = trial_mse_and_gradient(problem, x)
    if monitor.start(x, mse, grad):
        return x
    while True:
        with np.errstate(over="ignore"):
            x = x - lr * grad
        mse, grad = trial_mse_and_gradient(problem, x)
        if monitor.update(x, mse, grad):  # stops with 'non_finite' if the step overflowed
            return x


@register_algorithm("traingdx", min_grad=1e-5)
def traingdx(problem, x0, monitor, *, lr=0.01, lr_inc=1.05, lr_dec=0.7, max_perf_inc=1.04, mc=0.9):
    """Gradient descent with momentum and an adaptive learning rate.

    Parameters
    ----------
    lr : float, default=0.01
        Initial learning rate.
    lr_inc : float, default=1.05
        Factor (>= 1) applied to ``lr`` after a step that lowers the error.
    lr_dec : float, default=0.7
        Factor in (0, 1) applied to ``lr`` after a rejected step.
    max_perf_inc : float, default=1.04
        Largest accepted ratio of new to old error (>= 1).
    mc : float, default=0.9
        Momentum constant in [0, 1).

    Records ``'lr'``, the learning rate after each epoch.
    """
    lr = check_option("traingdx", "lr", lr, 0.0)
    lr_inc = check_option("traingdx", "lr_inc", lr_inc, 1.0, low_open=False)
    lr_dec = check_option("traingdx", "lr_dec", lr_dec, 0.0, 1.0)
    max_perf_inc = check_option("traingdx", "max_perf_inc", max_perf_inc, 1.0, low_open=False)
    mc = check_option("traingdx", "mc", mc, 0.0, 1.0, low_open=False)
    x = x0
    mse, grad = trial_mse_and_gradient(problem, x)
    monitor.record("lr", lr)
    if monitor.start(x, mse, grad):
        return x
    change = -lr * grad
    while True:
        with np.errstate(over="ignore", invalid="ignore"):
            change = mc * change - (1.0 - mc) * lr * grad
            trial = x + change
        trial_mse, trial_grad = trial_mse_and_gradient(problem, trial)
        if trial_mse > max_perf_inc * mse:  # also true for an overflow (inf)
            lr *= lr_dec
            change = -lr * grad
        else:
            if trial_mse < mse:
                lr *= lr_inc
            x, mse, grad = trial, trial_mse, trial_grad
        monitor.record("lr", lr)
        if monitor.update(x, mse, grad):
            return x

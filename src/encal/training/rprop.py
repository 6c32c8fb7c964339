"""Resilient backpropagation: MATLAB's ``trainrp``.

Riedmiller, M. and Braun, H. (1993), "A direct adaptive method for faster
backpropagation learning: the RPROP algorithm", Proc. IEEE ICNN, 586-591.

Every weight moves by its own step size against the sign of its gradient
component; the magnitude of the gradient is ignored. A step size grows by
``delt_inc`` while its gradient component keeps its sign, shrinks by
``delt_dec`` when the sign flips (the last step jumped over a minimum), and
never exceeds ``deltamax``. As in MATLAB's ``trainrp.m`` the step is taken
even after a sign flip, without Riedmiller & Braun's weight-backtracking
(the variant Igel & Hüsken (2000) call Rprop⁻), and the first epoch already
counts as "same sign".
"""

import math

import numpy as np

from ._registry import register_algorithm
from ._trial import trial_mse_and_gradient
from .trainlm import check_option

__all__ = ["trainrp"]

#: Step sizes are kept above this so that a step size can always grow again.
_SMALLEST_STEP = np.finfo(float).tiny


@register_algorithm("trainrp", min_grad=1e-5)
def trainrp(problem, x0, monitor, *, delt_inc=1.2, delt_dec=0.5, delta0=0.07, deltamax=50.0):
    """Rprop.

    Parameters
    ----------
    delt_inc : float, default=1.2
        Growth factor (>= 1) of a step size whose gradient keeps its sign.
    delt_dec : float, default=0.5
        Shrink factor in (0, 1) of a step size whose gradient changes sign.
    delta0 : float, default=0.07
        Initial step size of every weight.
    deltamax : float, default=50.0
        Largest step size.

    Records ``'step_min'`` and ``'step_max'``, the smallest and largest step
    size of each epoch (``delta0`` at epoch 0).

    Notes
    -----
    A step whose error overflows is not taken: every step size is multiplied
    by ``delt_dec`` and the next epoch tries again from the same weights.
    """
    delt_inc = check_option("trainrp", "delt_inc", delt_inc, 1.0, low_open=False)
    delt_dec = check_option("trainrp", "delt_dec", delt_dec, 0.0, 1.0)
    delta0 = check_option("trainrp", "delta0", delta0, 0.0)
    deltamax = check_option("trainrp", "deltamax", deltamax, 0.0)
    x = x0
    mse, grad = trial_mse_and_gradient(problem, x)
    step_size = np.full(problem.n_params, delta0)
    monitor.record("step_min", delta0)
    monitor.record("step_max", delta0)
    if monitor.start(x, mse, grad):
        return x
    old_grad = grad
    while True:
        agreement = grad * old_grad
        factor = np.where(agreement > 0.0, delt_inc, np.where(agreement < 0.0, delt_dec, 1.0))
        step_size = np.clip(step_size * factor, _SMALLEST_STEP, deltamax)
        trial = x - step_size * np.sign(grad)
        trial_mse, trial_grad = trial_mse_and_gradient(problem, trial)
        if math.isfinite(trial_mse):
            x, mse, old_grad, grad = trial, trial_mse, grad, trial_grad
        else:
            step_size = np.maximum(step_size * delt_dec, _SMALLEST_STEP)
            old_grad = np.zeros_like(grad)  # leaves the shrunken step sizes as they are next epoch
        monitor.record("step_min", step_size.min())
        monitor.record("step_max", step_size.max())
        if monitor.update(x, mse, grad):
            return x

"""The epoch loop of the line-search methods (traincgf, traincgp, trainoss, trainbfg).

Each epoch asks a direction rule for a search direction, checks that it
points downhill (else restarts the rule with steepest descent), and moves to
the point the line search accepts. When the search fails along a rule's
direction, one more search along steepest descent is tried before stopping
with ``'no_progress'``.
"""

from typing import Protocol

import numpy as np

from ._trial import trial_mse_and_gradient

__all__ = ["DirectionRule", "descend"]


class DirectionRule(Protocol):
    """How a method turns gradients and steps into search directions.

    Attributes
    ----------
    min_cosine : float
        Restart with steepest descent when the cosine of the angle between the
        direction and ``-grad`` is not above this.
    """

    min_cosine: float

    def restart(self, grad):
        """Forget the past; return the steepest-descent direction ``-grad``."""

    def next(self, step, grad_change, grad):
        """The direction at ``x_new``, after a step ``x_new - x`` that changed the gradient
        by ``grad_change`` to ``grad``."""


def _downhill(direction, grad, min_cosine):
    lengths = float(np.linalg.norm(grad) * np.linalg.norm(direction))
    if not lengths > 0.0:
        return False
    return bool(-float(grad @ direction) / lengths > min_cosine)  # False for NaN


def descend(problem, x0, monitor, rule, search):
    """Minimise along the directions of ``rule`` with the line search ``search``.

    Records ``'step'``, the length of each epoch's weight change (0 at epoch 0).

    Parameters
    ----------
    problem : Objective
    x0 : ndarray of shape (n,)
    monitor : Monitor
    rule : DirectionRule
    search : LineSearch

    Returns
    -------
    ndarray of shape (n,)
        The last weights.
    """
    x = x0
    mse, grad = trial_mse_and_gradient(problem, x)
    monitor.record("step", 0.0)
    if monitor.start(x, mse, grad):
        return x
    previous_mse = None
    direction = rule.restart(grad)
    while True:
        if not _downhill(direction, grad, rule.min_cosine):
            direction = rule.restart(grad)
        found = search(problem, x, mse, grad, direction, previous_mse)
        if found is None and not np.array_equal(direction, -grad):
            direction = rule.restart(grad)
            found = search(problem, x, mse, grad, direction, previous_mse)
        if found is None:
            monitor.stop("no_progress")
            return x
        step, grad_change = found.x - x, found.grad - grad
        previous_mse = mse
        x, mse, grad = found.x, found.mse, found.grad
        direction = rule.next(step, grad_change, grad)
        monitor.record("step", float(np.linalg.norm(step)))
        if monitor.update(x, mse, grad):
            return x

"""Conjugate-gradient training: MATLAB's ``traincgf``, ``traincgp`` and ``trainscg``.

``traincgf`` and ``traincgp`` search along conjugate directions
``d = -g + β·d_old`` with a line search, restarting with steepest descent
every ``n_params`` epochs and whenever ``d`` is not clearly downhill (the
cosine of its angle with ``-g`` at most 1e-3, MATLAB's test). They differ only
in ``β``:

* Fletcher-Reeves: ``β = gᵀg / g_oldᵀg_old``;
* Polak-Ribière: ``β = (g - g_old)ᵀg / g_oldᵀg_old``.

References: Fletcher & Reeves (1964), Comput. J. 7(2), 149-154; Polak &
Ribière (1969), Rev. Fr. Inform. Rech. Oper. 3(16), 35-43; Scales (1985),
Introduction to Non-Linear Optimization, p. 78 (MATLAB's reference).

``trainscg`` is Møller's scaled conjugate gradient, which needs no line
search: see :func:`trainscg`.
"""

import math

import numpy as np

from ._descent import descend
from ._registry import register_algorithm
from ._trial import trial_mse_and_gradient
from .linesearch import LineSearch
from .trainlm import check_option

__all__ = ["traincgf", "traincgp", "trainscg", "ConjugateDirections"]

#: MATLAB's traincg* restart when the unit direction's slope is above -0.001·‖g‖.
_MIN_COSINE = 1e-3


def _fletcher_reeves(grad, old_grad):
    return (grad @ grad) / (old_grad @ old_grad)


def _polak_ribiere(grad, old_grad):
    return ((grad - old_grad) @ grad) / (old_grad @ old_grad)


class ConjugateDirections:
    """Nonlinear conjugate-gradient directions with periodic restarts (a DirectionRule).

    Parameters
    ----------
    update : {'fletcher-reeves', 'polak-ribiere'}
        The formula for β.
    restart_every : int
        Restart with steepest descent after this many directions.
    """

    min_cosine = _MIN_COSINE
    _UPDATES = {"fletcher-reeves": _fletcher_reeves, "polak-ribiere": _polak_ribiere}

    def __init__(self, update, restart_every):
        self._beta = self._UPDATES[update]
        self.restart_every = int(restart_every)

    def restart(self, grad):
        self._grad, self._direction, self._count = grad, -grad, 1
        return self._direction

    def next(self, step, grad_change, grad):
        if self._count >= self.restart_every or not np.any(self._grad):
            return self.restart(grad)
        self._direction = -grad + self._beta(grad, self._grad) * self._direction
        self._grad = grad
        self._count += 1
        return self._direction


@register_algorithm("traincgf", min_grad=1e-10)
def traincgf(problem, x0, monitor, *, line_search="wolfe", alpha=0.001, beta=0.1, low_lim=0.1,
             up_lim=0.5, minstep=1e-6, maxstep=100.0):
    """Fletcher-Reeves conjugate gradient with restarts and a line search.

    Parameters
    ----------
    line_search : {'wolfe', 'backtracking'}, default='wolfe'
        The strong-Wolfe search stands in for MATLAB's ``srchcha``; see
        :mod:`encal.training.linesearch`.
    alpha, beta, low_lim, up_lim, minstep, maxstep : float
        Line-search parameters with MATLAB's names and defaults (0.001, 0.1,
        0.1, 0.5, 1e-6, 100).

    Records ``'step'``, the length of each epoch's weight change.
    """
    search = LineSearch.from_options("traincgf", line_search, alpha=alpha, beta=beta,
                                     low_lim=low_lim, up_lim=up_lim, minstep=minstep,
                                     maxstep=maxstep)
    rule = ConjugateDirections("fletcher-reeves", restart_every=problem.n_params)
    return descend(problem, x0, monitor, rule, search)


@register_algorithm("traincgp", min_grad=1e-10)
def traincgp(problem, x0, monitor, *, line_search="wolfe", alpha=0.001, beta=0.1, low_lim=0.1,
             up_lim=0.5, minstep=1e-6, maxstep=100.0):
    """Polak-Ribière conjugate gradient with restarts and a line search.

    Parameters are those of :func:`traincgf`. Records ``'step'``.
    """
    search = LineSearch.from_options("traincgp", line_search, alpha=alpha, beta=beta,
                                     low_lim=low_lim, up_lim=up_lim, minstep=minstep,
                                     maxstep=maxstep)
    rule = ConjugateDirections("polak-ribiere", restart_every=problem.n_params)
    return descend(problem, x0, monitor, rule, search)


@register_algorithm("trainscg", min_grad=1e-6)
def trainscg(problem, x0, monitor, *, sigma=5e-5, lambda_=5e-7):
    """Møller's scaled conjugate gradient.

    Møller, M. F. (1993), "A scaled conjugate gradient algorithm for fast
    supervised learning", Neural Networks 6(4), 525-533, algorithm SCG.

    Each epoch estimates the curvature along the direction ``p`` from a
    gradient difference over a step of length ``sigma``, adds ``λ‖p‖²`` (a
    Levenberg-Marquardt-like scale that keeps it positive), and steps to the
    minimum of that quadratic model. The step is kept when the model's
    predicted decrease compares well enough (Møller's ``Δ >= 0``); ``λ`` is
    divided by 4 when ``Δ >= 0.75`` and raised when ``Δ < 0.25``. Directions
    follow Møller's conjugacy update, restarted every ``n_params`` epochs.
    A rejected step still counts as an epoch, as in MATLAB.

    Parameters
    ----------
    sigma : float, default=5e-5
        Step length of the finite-difference curvature estimate.
    lambda_ : float, default=5e-7
        Initial scale λ (MATLAB's ``lambda``; renamed because ``lambda`` is a
        Python keyword).

    Records ``'lambda'``, the scale after each epoch.

    Notes
    -----
    Two guards beyond Møller's paper: a trial point whose error overflows
    counts as a failed step with ``Δ = -1`` (so λ grows and the next step is
    shorter), and a direction that is not downhill is replaced by ``-g``.
    """
    sigma = check_option("trainscg", "sigma", sigma, 0.0)
    scale = check_option("trainscg", "lambda_", lambda_, 0.0)
    x = x0
    mse, grad = trial_mse_and_gradient(problem, x)
    monitor.record("lambda", scale)
    if monitor.start(x, mse, grad):
        return x
    direction = -grad
    raised_scale = 0.0  # Møller's λ̄: the scale already folded into `curvature`
    success = True
    epoch = 0
    while True:
        epoch += 1
        slope = -float(direction @ grad)  # Møller's μ
        if not slope > 0.0:
            direction = -grad
            slope = float(grad @ grad)
            success = True
        length_sq = float(direction @ direction)
        if not length_sq > 0.0:
            monitor.stop("no_progress")
            return x
        if success:
            probe = sigma / math.sqrt(length_sq)
            probe_grad = trial_mse_and_gradient(problem, x + probe * direction)[1]
            if probe_grad is None:  # no curvature information; λ alone scales the step
                curvature = 0.0
            else:
                curvature = float(direction @ (probe_grad - grad)) / probe
        curvature += (scale - raised_scale) * length_sq
        if curvature <= 0.0:  # make the model positive definite
            raised_scale = 2.0 * (scale - curvature / length_sq)
            curvature = -curvature + scale * length_sq
            scale = raised_scale
        step = slope / curvature
        with np.errstate(over="ignore", invalid="ignore"):
            trial = x + step * direction
        trial_mse, trial_grad = trial_mse_and_gradient(problem, trial)
        if math.isfinite(trial_mse):
            comparison = 2.0 * curvature * (mse - trial_mse) / (slope * slope)
        else:
            comparison = -1.0
        if comparison >= 0.0:
            old_grad = grad
            x, mse, grad = trial, trial_mse, trial_grad
            raised_scale = 0.0
            success = True
            if epoch % problem.n_params == 0:
                direction = -grad
            else:
                conjugacy = (float(grad @ grad) - float(grad @ old_grad)) / slope
                direction = -grad + conjugacy * direction
            if comparison >= 0.75:
                scale *= 0.25
        else:
            raised_scale = scale
            success = False
        if comparison < 0.25:
            scale += curvature * (1.0 - comparison) / length_sq  # ‖p‖² of the step just tried
        monitor.record("lambda", scale)
        if monitor.update(x, mse, grad):
            return x

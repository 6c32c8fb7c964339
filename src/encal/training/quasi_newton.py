"""Quasi-Newton training: MATLAB's ``trainbfg`` and ``trainoss``.

Both search along ``d = -H g`` for an approximation ``H`` of the inverse
Hessian built from steps ``s = x_new - x`` and gradient changes
``y = g_new - g``, with MATLAB's default line search, backtracking
(``srchbac``, see :mod:`encal.training.linesearch`). A direction that is not
downhill restarts the method with ``d = -g``, as MATLAB does.

``trainbfg`` keeps the full ``n × n`` BFGS matrix; ``trainoss`` applies one
BFGS update to the identity each epoch (memoryless BFGS), so it stores
nothing but the last step: O(n) work per epoch instead of O(n²).
"""

import numpy as np

from ._descent import descend
from ._registry import register_algorithm
from .linesearch import LineSearch

__all__ = ["trainbfg", "trainoss", "InverseBFGS", "OneStepSecant"]

_EPS = np.finfo(float).eps


def _curvature_ok(step, grad_change):
    """``sᵀy > 0`` by a margin: only then does a BFGS update keep ``H`` positive definite."""
    lengths = float(np.linalg.norm(step) * np.linalg.norm(grad_change))
    return float(step @ grad_change) > _EPS * lengths


class InverseBFGS:
    """BFGS directions from the inverse-Hessian update (a DirectionRule).

    Nocedal & Wright (2006), Numerical Optimization, eq. (6.17); before the
    first update ``H`` is scaled to ``(sᵀy / yᵀy) I`` (their eq. 6.20), so
    the first quasi-Newton step has the right length. An update is skipped
    when ``sᵀy`` is not positive. MATLAB's ``trainbfg`` (after Gill, Murray &
    Wright 1981, p. 119) updates the Hessian itself and solves a linear system
    per epoch; in exact arithmetic the directions are the same.

    Parameters
    ----------
    n_params : int
    """

    min_cosine = 0.0

    def __init__(self, n_params):
        self.n_params = int(n_params)
        self._work = None

    def restart(self, grad):
        self.inverse_hessian = np.eye(self.n_params)
        self._scaled = False
        return -grad

    def next(self, step, grad_change, grad):
        if _curvature_ok(step, grad_change):
            H = self.inverse_hessian
            sy = float(step @ grad_change)
            if not self._scaled:
                H *= sy / float(grad_change @ grad_change)
                self._scaled = True
            Hy = H @ grad_change
            rho = 1.0 / sy
            # H ← (I - ρ s yᵀ) H (I - ρ y sᵀ) + ρ s sᵀ, expanded. Two n × n work arrays for the outer
            # products instead of four new ones per epoch (the same products and sums, bit for bit).
            outer, other = self._work_arrays()
            np.multiply.outer(step, Hy, out=outer)
            np.multiply.outer(Hy, step, out=other)
            outer += other
            outer *= rho
            H -= outer
            np.multiply.outer(step, step, out=outer)
            outer *= rho * rho * float(grad_change @ Hy) + rho
            H += outer
        return -(self.inverse_hessian @ grad)

    def _work_arrays(self):
        if self._work is None:
            self._work = (np.empty((self.n_params, self.n_params)), np.empty((self.n_params, self.n_params)))
        return self._work


class OneStepSecant:
    """Battiti's one-step secant directions (a DirectionRule).

    Battiti, R. (1992), "First- and second-order methods for learning: between
    steepest descent and Newton's method", Neural Computation 4(2), 141-166:
    ``d = -g + A s + B y`` with ``B = sᵀg / sᵀy`` and
    ``A = -(1 + yᵀy / sᵀy) B + yᵀg / sᵀy``, which is ``-H g`` for ``H`` the
    BFGS update of the identity. Falls back to ``-g`` when ``sᵀy <= 0``.
    """

    min_cosine = 0.0

    def restart(self, grad):
        return -grad

    def next(self, step, grad_change, grad):
        if not _curvature_ok(step, grad_change):
            return -grad
        sy = float(step @ grad_change)
        b = float(step @ grad) / sy
        a = -(1.0 + float(grad_change @ grad_change) / sy) * b + float(grad_change @ grad) / sy
        return -grad + a * step + b * grad_change


@register_algorithm("trainbfg", min_grad=1e-6)
def trainbfg(problem, x0, monitor, *, line_search="backtracking", alpha=0.001, beta=0.1,
             low_lim=0.1, up_lim=0.5, minstep=1e-6, maxstep=100.0):
    """BFGS quasi-Newton with a line search.

    Parameters
    ----------
    line_search : {'backtracking', 'wolfe'}, default='backtracking'
        MATLAB's ``srchbac`` or a strong-Wolfe search; see
        :mod:`encal.training.linesearch`.
    alpha, beta, low_lim, up_lim, minstep, maxstep : float
        Line-search parameters with MATLAB's names and defaults (0.001, 0.1,
        0.1, 0.5, 1e-6, 100).

    Records ``'step'``, the length of each epoch's weight change.
    """
    search = LineSearch.from_options("trainbfg", line_search, alpha=alpha, beta=beta,
                                     low_lim=low_lim, up_lim=up_lim, minstep=minstep,
                                     maxstep=maxstep)
    return descend(problem, x0, monitor, InverseBFGS(problem.n_params), search)


@register_algorithm("trainoss", min_grad=1e-10)
def trainoss(problem, x0, monitor, *, line_search="backtracking", alpha=0.001, beta=0.1,
             low_lim=0.1, up_lim=0.5, minstep=1e-6, maxstep=100.0):
    """One-step secant (memoryless BFGS) with a line search.

    Parameters are those of :func:`trainbfg`. Records ``'step'``.
    """
    search = LineSearch.from_options("trainoss", line_search, alpha=alpha, beta=beta,
                                     low_lim=low_lim, up_lim=up_lim, minstep=minstep,
                                     maxstep=maxstep)
    return descend(problem, x0, monitor, OneStepSecant(), search)

"""Levenberg-Marquardt, as MATLAB's ``trainlm`` documents it.

Each epoch forms the Jacobian ``J`` of the residuals ``e`` at the weights
``X`` and tries ``dX = -(JᵀJ + μI)⁻¹ Jᵀe``. A step that lowers the mean
squared error is taken and μ is multiplied by ``mu_dec``; otherwise μ is
multiplied by ``mu_inc`` and the step is tried again, until μ exceeds
``mu_max`` (stop reason ``'mu_max'``).

Defaults are MATLAB's: ``mu=0.001``, ``mu_dec=0.1``, ``mu_inc=10``,
``mu_max=1e10``, ``epochs=1000``, ``goal=0``, ``min_grad=1e-7``. Like
MATLAB's ``trainlm.m``, μ is kept at or above 1e-20. The gradient that
``min_grad`` tests is that of the mean squared error, ``2 Jᵀe / m``.

Speed: the Gram matrix is formed once per epoch and every μ retry costs
one Cholesky factorisation of it. When the network has more weights ``n``
than points ``m`` (1:80:1 on 180 points) the identity
``(JᵀJ + μI)⁻¹ Jᵀ = Jᵀ (JJᵀ + μI)⁻¹`` replaces the n × n system by an
m × m one, and a problem that can form ``JJᵀ`` more cheaply than from J
(the network's ``jacobian_outer``) is asked to. A Cholesky factorisation per
try measured about three times faster than one eigendecomposition per epoch
(``benchmarks/bench_trainlm.py``, Table 2): an epoch takes two tries on average.
A damped matrix that is not numerically positive definite, or a trial step
whose error is not finite, counts as a failed try.
"""

import math

import numpy as np
from scipy.linalg.blas import dsyrk
from scipy.linalg.lapack import dpotrf, dpotrs

from .._core.errors import InputError
from ._registry import register_algorithm

__all__ = ["trainlm", "DampedGaussNewton", "MU_FLOOR"]

#: Smallest μ, as in MATLAB's trainlm.m.
MU_FLOOR = 1e-20


class DampedGaussNewton:
    """Damped Gauss-Newton steps at one point, for any damping, from one Gram matrix.

    Solves ``(β JᵀJ + (α + μ) I) dX = -(β Jᵀe + α X)`` (Levenberg-Marquardt
    when ``β = 1``, ``α = 0``; Bayesian regularisation otherwise) by a
    Cholesky factorisation of the smaller of ``JᵀJ`` and ``JJᵀ``.

    Parameters
    ----------
    J : ndarray of shape (m, n)
        Jacobian of the residuals.
    e : ndarray of shape (m,)
        Residuals.
    gram : ndarray, optional
        The Gram matrix if the caller has it: ``J Jᵀ`` when ``m < n``, else
        ``JᵀJ``; only its lower triangle is read.
    """

    def __init__(self, J, e, gram=None):
        self.J = J
        self.e = e
        m, n = J.shape
        #: True when the m × m matrix JJᵀ is used (more weights than residuals).
        self.dual = m < n
        if gram is not None:
            self.gram = gram
        else:
            # J.T is J's memory in Fortran order, so BLAS reads it without a copy;
            # syrk fills only the lower triangle, all that Cholesky reads.
            self.gram = dsyrk(1.0, J.T, trans=1 if self.dual else 0, lower=1)
        self._Jte = None if self.dual else J.T @ e
        self._work = None

    def factor(self, scale, shift):
        """Lower Cholesky factor of ``scale · G + shift · I`` (G the Gram matrix).

        Only the lower triangle of the result is meaningful; None when the
        matrix is not numerically positive definite.
        """
        # One work array per system (an epoch's μ tries), in the Gram matrix's memory order, so that
        # LAPACK factors it in place without another copy.
        if self._work is None:
            self._work = np.empty_like(self.gram)
            # A view of the work array's diagonal (its memory is contiguous in either order).
            self._diagonal = self._work.ravel(order="K")[::self._work.shape[0] + 1]
        A = self._work
        if scale == 1.0:
            np.copyto(A, self.gram)
        else:
            np.multiply(self.gram, scale, out=A)
        self._diagonal += shift
        lower, info = dpotrf(A, lower=1, clean=0, overwrite_a=1)
        return lower if info == 0 else None

    def _solve(self, lower, rhs):
        return dpotrs(lower, rhs, lower=1)[0]

    def step(self, mu, beta=1.0, alpha=0.0, x=None):
        """The step ``dX``, or None when the damped matrix is numerically singular.

        Parameters
        ----------
        mu : float
            Damping μ > 0.
        beta, alpha : float, default=1.0, 0.0
            Weights of the data and weight terms of ``β·Σe² + α·ΣX²``.
        x : ndarray of shape (n,), optional
            Current weights; needed when ``alpha > 0``.
        """
        damping = alpha + mu
        factor = self.factor(beta, damping)
        if factor is None:
            return None
        if self.dual:
            # Woodbury: (βJᵀJ + cI)⁻¹ = (I - βJᵀ(βJJᵀ + cI)⁻¹J) / c, with Jᵀ pushed through.
            rhs = self.e if beta == 1.0 else beta * self.e
            if alpha:
                rhs = rhs - (alpha * beta / damping) * (self.J @ x)
            dx = -(self.J.T @ self._solve(factor, rhs))
            if alpha:
                dx -= (alpha / damping) * x
            return dx
        rhs = self._Jte if beta == 1.0 else beta * self._Jte
        if alpha:
            rhs = rhs + alpha * x
        return -self._solve(factor, rhs)


def check_option(algorithm, name, value, low, high=math.inf, *, low_open=True, high_open=True):
    """``float(value)``, checked to lie in the given interval; raises InputError in one sentence."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    above = number > low if low_open else number >= low
    below = number < high if high_open else number <= high
    if not (above and below):
        if high == math.inf:
            rule = f"{'>' if low_open else '>='} {low:g}"
        else:
            rule = f"in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
        raise InputError(f"{name} of {algorithm} must be a float {rule}. Got {value!r} instead.")
    return number


def check_mu_options(algorithm, mu, mu_dec, mu_inc, mu_max):
    """Validated ``(mu, mu_dec, mu_inc, mu_max)`` of a Levenberg-Marquardt algorithm."""
    return (
        check_option(algorithm, "mu", mu, 0.0),
        check_option(algorithm, "mu_dec", mu_dec, 0.0, 1.0),
        check_option(algorithm, "mu_inc", mu_inc, 1.0),
        check_option(algorithm, "mu_max", mu_max, 0.0),
    )


def sum_of_squares(problem, x):
    """``Σe²`` at trial weights, where overflow just means a bad step."""
    with np.errstate(over="ignore", invalid="ignore"):
        e = problem.residuals(x)
        return float(e @ e)


def damped_system(problem, x, J, e):
    """:class:`DampedGaussNewton` at ``x``, with the problem's own ``jacobian_outer`` when it has one."""
    outer = getattr(problem, "jacobian_outer", None)
    dual = J.shape[0] < J.shape[1]
    return DampedGaussNewton(J, e, gram=outer(x) if dual and outer is not None else None)


@register_algorithm("trainlm")
def trainlm(problem, x0, monitor, *, mu=0.001, mu_dec=0.1, mu_inc=10.0, mu_max=1e10):
    """Levenberg-Marquardt back end (see the module docstring); records ``'mu'`` each epoch."""
    mu, mu_dec, mu_inc, mu_max = check_mu_options("trainlm", mu, mu_dec, mu_inc, mu_max)
    m = problem.n_samples
    x = x0
    e, J = problem.residuals_and_jacobian(x)
    sse = float(e @ e)
    monitor.record("mu", mu)
    if monitor.start(x, sse / m, (2.0 / m) * (J.T @ e)):
        return x
    while True:
        system = damped_system(problem, x, J, e)
        while True:
            dx = system.step(mu)
            if dx is not None:
                trial = x + dx
                trial_sse = sum_of_squares(problem, trial)
                if trial_sse < sse:
                    break
            mu *= mu_inc
            if mu > mu_max:
                monitor.stop("mu_max")
                return x
        mu = max(mu * mu_dec, MU_FLOOR)
        x = trial
        e, J = problem.residuals_and_jacobian(x)
        sse = float(e @ e)
        monitor.record("mu", mu)
        if monitor.update(x, sse / m, (2.0 / m) * (J.T @ e)):
            return x

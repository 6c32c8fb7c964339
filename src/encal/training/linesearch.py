"""Line searches: how far to step along a descent direction.

Both searches look at ``phi(a) = mse(x + a·d)`` for a direction ``d`` with
``phi'(0) = g·d < 0`` and accept a step multiplier ``a`` that satisfies

* sufficient decrease (Armijo): ``phi(a) <= phi(0) + alpha·a·phi'(0)``, and
* a curvature condition with ``beta``: the slope must have flattened,
  ``phi'(a) >= beta·phi'(0)``.

``alpha`` and ``beta`` carry MATLAB's names and defaults (0.001 and 0.1): they
play the roles of Nocedal & Wright's ``c1`` and ``c2``.

``'backtracking'``
    MATLAB's ``srchbac`` algorithm, the backtracking line search of Dennis &
    Schnabel (1983), Numerical Methods for Unconstrained Optimization and
    Nonlinear Equations, Algorithm A6.3.1mod: try ``a = 1`` (the natural step
    of a quasi-Newton direction); while sufficient decrease fails, shrink
    ``a`` to the minimiser of a quadratic (first time) or cubic interpolant,
    kept within ``[low_lim·a, up_lim·a]``; when the first trial decreases
    the error but the slope is still steep, double ``a`` and then refine
    between the last good and the first bad multiplier until the curvature
    condition holds. MATLAB's default for ``trainbfg`` and ``trainoss``.
``'wolfe'``
    A strong-Wolfe search, :func:`scipy.optimize.line_search` (Nocedal &
    Wright (2006), Numerical Optimization, Algorithms 3.5 and 3.6), with the
    initial step of their eq. (3.60) from the previous decrease of the error.
    When SciPy's search fails (overflowing trial points, rounding near the
    minimum) the backtracking search takes over. It stands in for MATLAB's
    ``srchcha`` (Charalambous 1992) as the search of ``traincgf`` and
    ``traincgp``: conjugate-gradient directions rely on a nearly exact line
    minimum, which the strong Wolfe conditions with ``beta = 0.1`` give; with
    ``beta < 1/2`` every Fletcher-Reeves direction is downhill (Nocedal &
    Wright, Lemma 5.6).

Step lengths ``‖a·d‖`` are at most ``maxstep``. Backtracking gives up, and
the search returns None, when sufficient decrease would need a step shorter
than ``minstep`` (MATLAB's absolute step length, 1e-6 by default: lower it to
resolve weights more finely than that).
"""

import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.optimize import line_search as _scipy_strong_wolfe

from .._core.errors import InputError
from ._trial import trial_mse_and_gradient
from .trainlm import check_option

__all__ = ["LineSearch", "LineStep", "LINE_SEARCHES"]

#: Names accepted by the ``line_search`` option.
LINE_SEARCHES = ("backtracking", "wolfe")

#: Least fraction of the bracket by which each refinement step moves (Dennis & Schnabel).
_MIN_BRACKET_FRACTION = 0.2


@dataclass(frozen=True)
class LineStep:
    """An accepted step: ``x = x_old + step·d`` with its performance and gradient."""

    x: np.ndarray
    mse: float
    grad: np.ndarray
    step: float


@dataclass(frozen=True)
class LineSearch:
    """A line search with its parameters (see the module docstring).

    Parameters
    ----------
    method : {'backtracking', 'wolfe'}
    alpha : float
        Sufficient-decrease factor, in (0, beta).
    beta : float
        Curvature factor, in (alpha, 1).
    low_lim, up_lim : float
        Each backtracking step keeps at least ``low_lim`` and at most
        ``up_lim`` of the previous multiplier; ``0 < low_lim <= up_lim < 1``.
    minstep, maxstep : float
        Shortest and longest step length ``‖a·d‖``.
    """

    method: str = "backtracking"
    alpha: float = 0.001
    beta: float = 0.1
    low_lim: float = 0.1
    up_lim: float = 0.5
    minstep: float = 1e-6
    maxstep: float = 100.0

    @classmethod
    def from_options(cls, algorithm, method, *, alpha, beta, low_lim, up_lim, minstep, maxstep):
        """A validated search from an algorithm's options (errors name ``algorithm``)."""
        if method not in LINE_SEARCHES:
            raise InputError(
                f"line_search of {algorithm} must be one of {', '.join(map(repr, LINE_SEARCHES))}. "
                f"Got {method!r} instead."
            )
        alpha = check_option(algorithm, "alpha", alpha, 0.0, 1.0)
        beta = check_option(algorithm, "beta", beta, alpha, 1.0)
        up_lim = check_option(algorithm, "up_lim", up_lim, 0.0, 1.0)
        low_lim = check_option(algorithm, "low_lim", low_lim, 0.0, up_lim, high_open=False)
        minstep = check_option(algorithm, "minstep", minstep, 0.0)
        maxstep = check_option(algorithm, "maxstep", maxstep, minstep)
        return cls(method, alpha, beta, low_lim, up_lim, minstep, maxstep)

    def __call__(self, problem, x, mse, grad, direction, previous_mse=None):
        """Search along ``direction`` from ``x``.

        Parameters
        ----------
        problem : Objective
        x : ndarray of shape (n,)
            Current weights, with their performance ``mse`` and gradient ``grad``.
        direction : ndarray of shape (n,)
            Search direction; must be downhill (``grad · direction < 0``).
        previous_mse : float, optional
            Performance one epoch earlier; sets the first trial of ``'wolfe'``.

        Returns
        -------
        LineStep or None
            None when no step was found that lowers the error enough.
        """
        line = _Line(problem, x, direction)
        slope = float(grad @ direction)
        if not (line.norm > 0.0 and slope < 0.0):
            return None
        if self.method == "wolfe":
            step = self._wolfe(line, mse, grad, slope, previous_mse)
            if step is not None:
                return step
        return self._backtracking(line, mse, slope)

    def _armijo(self, a, phi, phi0, slope0):
        return phi <= phi0 + self.alpha * a * slope0

    def _backtracking(self, line, phi0, slope0):
        """Dennis & Schnabel's Algorithm A6.3.1mod (MATLAB's srchbac)."""
        min_a, max_a = self.minstep / line.norm, self.maxstep / line.norm
        first_a = a = min(1.0, max_a)
        phi, grad = line.at(a)
        previous = None  # (a, phi) of the last trial that failed sufficient decrease
        while not self._armijo(a, phi, phi0, slope0):
            if a < min_a:
                return None
            shrunk = self._interpolate(a, phi, previous, phi0, slope0)
            previous = (a, phi)
            a = min(max(shrunk, self.low_lim * a), self.up_lim * a)
            phi, grad = line.at(a)
        slope = float(grad @ line.direction)
        if slope >= self.beta * slope0:
            return line.step(a)
        if a == first_a:
            # Still steeply downhill after the first trial: lengthen the step.
            while a < max_a:
                previous = (a, phi, grad, slope)
                a = min(2.0 * a, max_a)
                phi, grad = line.at(a)
                if not self._armijo(a, phi, phi0, slope0):
                    break
                slope = float(grad @ line.direction)
                if slope >= self.beta * slope0:
                    return line.step(a)
            else:
                return line.step(a)
            low, high = previous, (a, phi)
        else:
            low, high = (a, phi, grad, slope), previous
        return line.step(self._refine(line, low, high, phi0, slope0, min_a))

    def _interpolate(self, a, phi, previous, phi0, slope0):
        """Minimiser of the quadratic (no earlier trial) or cubic model of phi on [0, a]."""
        if not math.isfinite(phi):
            return 0.0  # no model through an overflow: shrink as far as low_lim allows
        excess = phi - phi0 - slope0 * a  # > 0 since sufficient decrease failed
        if not excess > 0.0:
            return self.up_lim * a
        if previous is None or not math.isfinite(previous[1]):
            return -slope0 * a * a / (2.0 * excess)
        b, phi_b = previous
        excess_b = phi_b - phi0 - slope0 * b
        cubic = (excess / (a * a) - excess_b / (b * b)) / (a - b)
        square = (-b * excess / (a * a) + a * excess_b / (b * b)) / (a - b)
        if cubic == 0.0:
            return -slope0 / (2.0 * square) if square > 0.0 else self.up_lim * a
        discriminant = square * square - 3.0 * cubic * slope0
        if not discriminant >= 0.0:
            return self.up_lim * a
        shrunk = (-square + math.sqrt(discriminant)) / (3.0 * cubic)
        return shrunk if math.isfinite(shrunk) else self.low_lim * a

    def _refine(self, line, low, high, phi0, slope0, min_a):
        """Shrink [low, high] until the curvature condition holds at ``low``; return its multiplier.

        ``low = (a, phi, grad, slope)`` decreases the error enough but is still
        steep; ``high = (a, phi)`` does not decrease it enough. Each trial is the
        minimiser of the quadratic through phi(low), phi'(low) and phi(high),
        kept at least 20 % of the bracket away from either end.
        """
        a_low, phi_low, _, slope_low = low
        a_high, phi_high = high
        width = a_high - a_low
        while slope_low < self.beta * slope0 and width > min_a:
            curvature = phi_high - phi_low - slope_low * width  # > 0 when beta > alpha
            if curvature > 0.0:
                offset = -slope_low * width * width / (2.0 * curvature)
            else:  # only through rounding
                offset = 0.5 * width
            offset = min(max(offset, _MIN_BRACKET_FRACTION * width),
                         (1.0 - _MIN_BRACKET_FRACTION) * width)
            a = a_low + offset
            phi, grad = line.at(a)
            if self._armijo(a, phi, phi0, slope0):
                a_low, phi_low = a, phi
                slope_low = float(grad @ line.direction)
                width -= offset
            else:
                phi_high = phi
                width = offset
        return a_low

    def _wolfe(self, line, phi0, grad0, slope0, previous_mse):
        """SciPy's strong-Wolfe search; None when it fails."""
        if previous_mse is None or not previous_mse > phi0:
            # SciPy's first-step rule then gives a step of length ~1.
            previous_mse = phi0 + 0.5 * float(np.linalg.norm(grad0))
        with warnings.catch_warnings():
            # SciPy warns (LineSearchWarning, a RuntimeWarning) when it fails; we fall back instead.
            warnings.simplefilter("ignore", RuntimeWarning)
            a = _scipy_strong_wolfe(
                line.mse_at_point, line.grad_at_point, line.origin, line.direction,
                gfk=grad0, old_fval=phi0, old_old_fval=previous_mse,
                c1=self.alpha, c2=self.beta, amax=self.maxstep / line.norm,
            )[0]
        if a is None:
            return None
        step = line.step(float(a))
        return step if self._armijo(step.step, step.mse, phi0, slope0) else None


class _Line:
    """The problem along ``origin + a·direction``; each point is evaluated once."""

    def __init__(self, problem, origin, direction):
        self.problem = problem
        self.origin = origin
        self.direction = direction
        self.norm = float(np.linalg.norm(direction))
        self._cache = {}

    def _evaluate(self, x):
        key = x.tobytes()
        if key not in self._cache:
            self._cache[key] = trial_mse_and_gradient(self.problem, x)
        return self._cache[key]

    def point(self, a):
        return self.origin + a * self.direction

    def at(self, a):
        """``(mse, grad)`` at multiplier ``a``; ``(inf, None)`` where not finite."""
        return self._evaluate(self.point(a))

    def mse_at_point(self, x):
        return self._evaluate(x)[0]

    def grad_at_point(self, x):
        grad = self._evaluate(x)[1]
        return np.full_like(x, np.nan) if grad is None else grad

    def step(self, a):
        x = self.point(a)
        mse, grad = self._evaluate(x)
        return LineStep(x=x, mse=mse, grad=grad, step=a)

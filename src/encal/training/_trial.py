"""Performance and gradient at trial weights, where overflow just means a bad step."""

import math

import numpy as np

__all__ = ["trial_mse_and_gradient"]


def trial_mse_and_gradient(problem, w):
    """``(mse, gradient)`` at trial weights ``w``, or ``(inf, None)`` where they are not finite.

    An over-long step can make the residuals overflow. The algorithms treat
    such a point as infinitely bad and back off, so NumPy's floating-point
    warnings are silenced here and NaN is reported as ``inf`` (NaN would
    compare as neither better nor worse). A gradient whose norm overflows
    counts as not finite too: the monitor could not judge it.
    """
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        mse, grad = problem.mse_and_gradient(w)
        mse = float(mse)
        # A finite gradient whose norm overflows is as unusable as an infinite one.
        if not (math.isfinite(mse) and math.isfinite(np.linalg.norm(grad))):
            return math.inf, None
    return mse, grad

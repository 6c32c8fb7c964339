"""Cross-validation over interleaved circular folds: the one loop that every held-out estimate shares.

The automatic choice of a model family (:func:`encal.models.select.fit_auto`), the number of Fourier
orders of ``fit_fourier(select='cv')`` and the noise of an uncertainty estimate
(:mod:`encal.models.uncertainty`) all ask the same question: how well does a fit predict calibration points it
did not see? They deal the points into the same folds (:func:`interleaved_folds`) and run the same loop
(:func:`held_out_predictions`); only what they fit differs.
"""

import numpy as np

from .._core.angles import wrap360
from ..analysis.profile import distinct_angles

__all__ = ["interleaved_folds", "held_out_predictions"]


def interleaved_folds(theta_deg, folds):
    """Fold index of every point: the ``i``-th distinct angle in increasing order goes to fold ``i mod folds``.

    Every fold is spread evenly round the circle, so a held-out point lies between points the fold's
    fit has seen, as a live reading lies between calibration points. Repeated readings of one angle
    (closer than 1e-9 degrees) share a fold, so a held-out point never has an identical twin among
    the training points.

    Parameters
    ----------
    theta_deg : array-like of shape (n,)
        Encoder angles in degrees, any order.
    folds : int
        Number of folds, at least 2 and at most the number of distinct angles.

    Returns
    -------
    ndarray of int of shape (n,)
        Fold of each point, in the order of ``theta_deg``.

    Examples
    --------
    >>> interleaved_folds([0.0, 90.0, 180.0, 270.0, 45.0], 2).tolist()
    [0, 0, 1, 0, 1]
    """
    distinct, group = distinct_angles(wrap360(np.asarray(theta_deg, dtype=float).reshape(-1)))
    return (np.arange(distinct.size) % folds)[group]


def held_out_predictions(fit_predict, theta_deg, error_arcmin, fold):
    """Every point predicted by a fit to the points of the other folds.

    Parameters
    ----------
    fit_predict : callable
        ``fit_predict(k, train_theta_deg, train_error_arcmin, test_theta_deg) -> predictions`` fits
        the training points of fold ``k`` and predicts the error (arc-minutes) at the held-out
        angles: an array of shape ``(..., n_test)`` (a leading shape for several fits at once, such as
        one row per number of Fourier orders). It is called for ``k = 0, 1, ...`` in turn.
    theta_deg : ndarray of shape (n,)
        Encoder angles, degrees.
    error_arcmin : ndarray of shape (n,)
        Errors, arc-minutes.
    fold : ndarray of int of shape (n,)
        Fold of each point, from :func:`interleaved_folds`.

    Returns
    -------
    ndarray of shape (..., n)
        The held-out prediction of every point, arc-minutes, in the order of the points.
    """
    predictions = None
    for k in range(int(fold.max()) + 1):
        test = fold == k
        train = ~test
        # (np.compress and index arrays: half the time of boolean indexing on 10^6 points in folds of random order)
        held = np.flatnonzero(test)
        predicted = np.asarray(fit_predict(k, np.compress(train, theta_deg), np.compress(train, error_arcmin),
                                           np.take(theta_deg, held)), dtype=float)
        if predictions is None:
            predictions = np.empty(predicted.shape[:-1] + (np.size(theta_deg),))
        predictions[..., held] = predicted
    return predictions

"""The shared cross-validation loop (encal.models.validation)."""

import numpy as np
import pytest

from encal.models.validation import held_out_predictions, interleaved_folds

THETA = np.arange(0.0, 360.0, 10.0)


def test_folds_interleave_round_the_circle_and_keep_repeats_together():
    shuffled = np.r_[THETA[::-1], 20.0 + 1e-12]
    fold = interleaved_folds(shuffled, 4)
    assert fold.tolist()[:-1] == (np.arange(36) % 4)[::-1].tolist()
    assert fold[-1] == fold[shuffled.tolist().index(20.0)]


def test_each_point_is_predicted_by_a_fit_to_the_other_folds_only():
    error = np.sin(np.radians(THETA))
    fold = interleaved_folds(THETA, 3)
    calls = []

    def training_mean(k, train_theta, train_error, test_theta):
        calls.append(k)
        assert not np.isin(test_theta, train_theta).any()
        return np.full(test_theta.size, train_error.mean())

    predicted = held_out_predictions(training_mean, THETA, error, fold)
    assert calls == [0, 1, 2]
    for k in range(3):
        assert predicted[fold == k] == pytest.approx(error[fold != k].mean(), abs=1e-15)


def test_several_fits_at_once_keep_their_leading_shape():
    fold = interleaved_folds(THETA, 2)

    def two_fits(k, train_theta, train_error, test_theta):
        return np.outer([1.0, 2.0], test_theta + k)

    predicted = held_out_predictions(two_fits, THETA, THETA, fold)
    assert predicted.shape == (2, THETA.size)
    assert predicted[1] == pytest.approx(2.0 * (THETA + fold), abs=1e-12)

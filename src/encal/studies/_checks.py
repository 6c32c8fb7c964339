"""Validation of the options every study takes, with one message template."""

import numpy as np

from ..calibration import Calibration
from ..errors import InputError

__all__ = ["check_calibration", "check_counts", "check_epochs", "check_seed"]


def check_seed(seed):
    """The study seed as an int >= 0 (every fit's seed is derived from it)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"rng must be an int >= 0 (the study's seed). Got {seed!r} instead.")
    return int(seed)


def check_epochs(epochs, algorithms):
    """An epoch budget per algorithm from an int (the same for all) or a dict."""
    budget = dict(epochs) if isinstance(epochs, dict) else {a: epochs for a in algorithms}
    for algorithm in algorithms:
        value = budget.get(algorithm)
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise InputError(f"epochs for {algorithm} must be an int >= 1. Got {value!r} instead.")
        budget[algorithm] = int(value)
    return {a: budget[a] for a in algorithms}


def check_calibration(cal, name="cal"):
    """Refuse anything but a Calibration, with one sentence."""
    if not isinstance(cal, Calibration):
        raise InputError(f"{name} must be a Calibration. Got {type(cal).__name__} instead.")
    return cal


def check_counts(values, name):
    """Whole numbers >= 1 (hidden-node counts, seeds) as an int array."""
    try:
        counts = np.asarray([int(v) for v in values])
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a list of whole numbers >= 1. Got {values!r} instead.") from None
    if counts.size == 0 or np.any(counts < 1):
        raise InputError(f"{name} must be a non-empty list of whole numbers >= 1. Got {values!r} instead.")
    return counts

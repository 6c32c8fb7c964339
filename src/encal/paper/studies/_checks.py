"""Checking the options every study takes, with encal's one message template (:mod:`encal._core.parameters`)."""

import numbers

import numpy as np

from ..._core.limits import SIZE_LIMITS, check_size
from ...data.calibration import Calibration
from ...numerics.network import ENCODINGS
from ..._core.parameters import check_choice, check_int, check_type, invalid
from ...training import ALGORITHMS

__all__ = ["check_algorithms", "check_calibration", "check_counts", "check_encoding", "check_epochs",
           "check_seed"]


def check_seed(seed, caller):
    """The study seed as an int >= 0 (every fit's seed is derived from it)."""
    return check_int(seed, "rng", caller, low=0, note="the study's seed")


def check_epochs(epochs, algorithms, caller):
    """An epoch budget per algorithm from an int (the same for all) or a dict of algorithm -> int."""
    if not isinstance(epochs, dict):
        value = check_size("epochs", epochs, caller)
        return {a: value for a in algorithms}
    return {a: check_size(f"epochs[{a}]", epochs.get(a), caller, limit="epochs") for a in algorithms}


def check_calibration(cal, name, caller):
    """Refuse anything but a Calibration, with one sentence."""
    return check_type(cal, Calibration, name, caller, "a Calibration")


def check_counts(values, name, caller):
    """A non-empty sequence of sizes (hidden-node counts), each from 1 to its limit, as an int array."""
    high = SIZE_LIMITS[name][0]
    try:
        counts = [int(v) if isinstance(v, numbers.Integral) and not isinstance(v, bool) else None for v in values]
    except TypeError:  # not a sequence
        counts = [None]
    if not counts or any(c is None or not 1 <= c <= high for c in counts):
        raise invalid(name, caller, f"a non-empty sequence of ints from 1 to {high}", values)
    return np.asarray(counts)


def check_algorithms(algorithms, caller):
    """A non-empty tuple of training algorithms' MATLAB names."""
    known = sorted(ALGORITHMS)
    if isinstance(algorithms, str):
        algorithms = (algorithms,)
    try:
        algorithms = tuple(algorithms)
    except TypeError:
        raise invalid("algorithms", caller, "a non-empty sequence of training algorithms", algorithms) from None
    if not algorithms:
        raise invalid("algorithms", caller, "a non-empty sequence of training algorithms", algorithms)
    return tuple(check_choice(a, "algorithms", caller, known) for a in algorithms)


def check_encoding(encoding, caller):
    """A network input encoding, ``'raw'`` or ``'periodic'``."""
    return check_choice(encoding, "encoding", caller, sorted(ENCODINGS))

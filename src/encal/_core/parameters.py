"""Checking the parameters of encal's public functions: one place, one sentence.

Every public entry point checks its parameters with these functions and refuses a bad one with the
same sentence, naming the parameter, the function, what was expected and what was given::

    The 'hidden' parameter of fit_ann must be an int >= 1. Got 0 instead.

Each check returns the value in the form the caller uses (an ``int``, a ``float``).
"""

import math
import numbers

import numpy as np

from .errors import InputError

__all__ = ["invalid", "check_int", "check_number", "check_choice", "check_bool", "check_seed", "check_type",
           "real_array"]


def invalid(name, caller, expected, value, *, shown=None, error=InputError):
    """The :class:`~encal._core.errors.InputError` for a parameter that is not what it must be.

    ``shown`` replaces ``repr(value)`` in the message (e.g. the type of an object whose repr is long);
    ``error`` is the exception class (another :class:`~encal._core.errors.EncalError` where one fits better:
    a :class:`~encal._core.errors.CalibrationError` for the options of a calibration). The checks below take it too.

    Examples
    --------
    >>> str(invalid("hidden", "fit_ann", "an int >= 1", 0))
    "The 'hidden' parameter of fit_ann must be an int >= 1. Got 0 instead."
    """
    shown = repr(value) if shown is None else shown
    return error(f"The {name!r} parameter of {caller} must be {expected}. Got {shown} instead.")


def _with_note(expected, note):
    return expected if note is None else f"{expected} ({note})"


def check_int(value, name, caller, *, low=None, high=None, note=None, error=InputError):
    """``value`` as an ``int`` in ``[low, high]`` (either bound may be None); a bool is not an int.

    Examples
    --------
    >>> check_int(3, "folds", "fit_auto", low=2, high=9)
    3
    >>> check_int(1, "folds", "fit_auto", low=2, high=9)
    Traceback (most recent call last):
    encal.InputError: The 'folds' parameter of fit_auto must be an int from 2 to 9. Got 1 instead.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) \
            or (low is not None and value < low) or (high is not None and value > high):
        if low is not None and high is not None:
            expected = f"an int from {low} to {high}"
        elif low is not None:
            expected = f"an int >= {low}"
        elif high is not None:
            expected = f"an int <= {high}"
        else:
            expected = "an int"
        raise invalid(name, caller, _with_note(expected, note), value, error=error)
    return int(value)


def check_number(value, name, caller, *, low=None, high=None, low_open=False, high_open=False, note=None,
                 error=InputError):
    """``value`` as a finite ``float`` within the given bounds (open or closed).

    Examples
    --------
    >>> check_number(0.5, "tolerance", "fit_auto", low=0.0, high=1.0, high_open=True)
    0.5
    >>> check_number(float("nan"), "coverage_factor", "coverage", low=0.0, low_open=True)
    Traceback (most recent call last):
    encal.InputError: The 'coverage_factor' parameter of coverage must be a finite number > 0. Got nan instead.
    """
    ok = not isinstance(value, bool) and isinstance(value, (numbers.Real, np.floating)) and math.isfinite(value)
    if ok and low is not None:
        ok = value > low if low_open else value >= low
    if ok and high is not None:
        ok = value < high if high_open else value <= high
    if not ok:
        if low is not None and high is not None:
            expected = f"a finite number in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
        elif low is not None:
            expected = f"a finite number {'>' if low_open else '>='} {low:g}"
        elif high is not None:
            expected = f"a finite number {'<' if high_open else '<='} {high:g}"
        else:
            expected = "a finite number"
        raise invalid(name, caller, _with_note(expected, note), value, error=error)
    return float(value)


def check_choice(value, name, caller, choices, *, error=InputError):
    """``value`` if it is one of ``choices`` (listed in their order in the message).

    Examples
    --------
    >>> check_choice("cubic", "interpolation", "fit_lut", ("linear", "cubic"))
    'cubic'
    """
    try:
        known = value in choices
    except TypeError:  # an unhashable value asked of a dict or set
        known = False
    if not known:
        raise invalid(name, caller, "one of " + ", ".join(repr(choice) for choice in choices), value, error=error)
    return value


def check_bool(value, name, caller, *, error=InputError):
    """``value`` if it is ``True`` or ``False``."""
    if not isinstance(value, (bool, np.bool_)):
        raise invalid(name, caller, "True or False", value, error=error)
    return bool(value)


def check_seed(value, name, caller):
    """``value`` if it is None, an int >= 0 or a :class:`numpy.random.Generator` (a seed of random numbers)."""
    if value is None or isinstance(value, np.random.Generator):
        return value
    if isinstance(value, numbers.Integral) and not isinstance(value, bool) and value >= 0:
        return int(value)
    raise invalid(name, caller, "None, an int >= 0 or a numpy.random.Generator", value)


def check_type(value, types, name, caller, expected, *, error=InputError):
    """``value`` if it is an instance of ``types``; else the message names the type it has.

    Examples
    --------
    >>> check_type([1.0], dict, "encoder", "Model", "a dict")
    Traceback (most recent call last):
    encal.InputError: The 'encoder' parameter of Model must be a dict. Got an object of type list instead.
    """
    if not isinstance(value, types):
        raise invalid(name, caller, expected, value, shown=f"an object of type {type(value).__name__}", error=error)
    return value


def real_array(values, name, caller, expected="real numbers", *, error=InputError):
    """``values`` as a float ndarray (any shape; NaN and infinity kept for the caller to judge), or the sentence
    saying what they are instead: text, None, complex numbers, a ragged list (NumPy's own ValueError,
    TypeError or ComplexWarning, which in a notebook is a traceback far from the call).

    Examples
    --------
    >>> real_array([1, 2.5], "errors", "error_stats").tolist()
    [1.0, 2.5]
    >>> real_array(["a"], "errors", "error_stats")
    Traceback (most recent call last):
    encal.InputError: The 'errors' parameter of error_stats must be real numbers. Got ['a'] instead.
    """
    if values is None:
        raise invalid(name, caller, expected, values, error=error)
    try:
        if getattr(values, "dtype", None) is not None and values.dtype.kind == "c":
            raise TypeError("complex")  # NumPy would drop the imaginary part with a warning (a list is refused)
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError, OverflowError):  # 'abc', a dict, a ragged list, 10**400, 1+2j
        shown = repr(values)
        raise invalid(name, caller, expected, values, shown=shown if len(shown) <= 60 else shown[:56] + " ...",
                      error=error) from None

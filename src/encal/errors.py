"""Exception types raised by encal.

Every error that a user can cause with bad input is an :class:`EncalError`.
Its message is one sentence that says what was expected, what was received
and where (file, line, column). The command line prints that sentence and
exits with status 1, without a traceback.
"""

__all__ = ["EncalError", "CalibrationError", "ModelFileError", "InputError"]


class EncalError(ValueError):
    """Base class of every error caused by the user's data or options."""


class CalibrationError(EncalError):
    """A calibration (CSV file or arrays) cannot be used."""


class ModelFileError(EncalError):
    """A model file cannot be loaded: not JSON, another format, altered, newer."""


class InputError(EncalError):
    """Angles or options given to a command or function are not usable."""

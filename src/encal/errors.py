"""Exception types raised by encal.

Every error that a user can cause with bad input is an :class:`EncalError`.
Its message is one sentence that says what was expected, what was received
and where (file, line, column). The command line prints that sentence and
exits with status 1, without a traceback.

Input that is usable but probably not what the user meant (angles that look
like radians) gets an :class:`EncalWarning` instead; the command line prints
it as one ``warning:`` line on stderr and goes on.
"""

__all__ = ["EncalError", "CalibrationError", "ModelFileError", "InputError", "EncalWarning"]


class EncalError(ValueError):
    """Base class of every error caused by the user's data or options."""


class CalibrationError(EncalError):
    """A calibration (CSV file or arrays) cannot be used."""


class ModelFileError(EncalError):
    """A model file cannot be loaded: not JSON, another format, altered, newer."""


class InputError(EncalError):
    """Angles or options given to a command or function are not usable."""


class EncalWarning(UserWarning):
    """Input that encal accepts but that is probably a mistake (e.g. angles that look like radians)."""

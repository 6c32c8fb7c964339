"""Exception types raised by encal.

Every error that a user can cause with bad input is an :class:`EncalError`.
Its message is one sentence that says what was expected, what was received
and where (file, line, column). The command line prints that sentence and
exits with status 1, without a traceback.

Input that is usable but probably not what the user meant (angles that look
like radians) gets an :class:`EncalWarning` instead; the command line prints
it as one ``warning:`` line on stderr and goes on. A result that is usable but
may not be what the user expects (training cut short by a limit the user did
not set) gets one too: :class:`TrainingLimitWarning`.
"""

__all__ = ["EncalError", "CalibrationError", "ModelFileError", "InputError", "EncalWarning",
           "TrainingLimitWarning"]


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


class TrainingLimitWarning(EncalWarning):
    """Training stopped on a limit while the error was still falling: the default epoch limit, or a time limit.

    Raised by :func:`encal.training.train` (and so by every network fit) when

    - training ran to the default limit of epochs (the caller gave no ``epochs``) while its RMS error was
      still falling: by at least the plateau rule's tolerance over its window when the rule is on, by 1 %
      over the last 20 epochs (the paper's rule) otherwise; or
    - the time limit (``time``, seconds) stopped it, whatever the error did: the result then depends on
      the machine's speed.

    A limit the caller set (``epochs=``, as the paper's studies and auto's candidates do) is a fixed
    budget and is never warned about.
    """


# A traceback names each class as a user imports it (``encal.InputError``), not by this private module's path;
# pickling finds it there too.
for _class in (EncalError, CalibrationError, ModelFileError, InputError, EncalWarning, TrainingLimitWarning):
    _class.__module__ = "encal"
del _class

"""Registry of training algorithms and the one front end that dispatches to them."""

import inspect
import math
import warnings

import numpy as np

from .._core.errors import InputError, TrainingLimitWarning
from .._core.parameters import check_int, check_number
from ._monitor import Monitor
from ._result import TrainResult

__all__ = ["ALGORITHMS", "STOPPING_PARAMETERS", "register_algorithm", "train"]

#: name -> (back end, default stopping parameters)
ALGORITHMS = {}

#: The stopping parameters every algorithm takes (MATLAB's ``trainParam`` names, and the plateau rule).
STOPPING_PARAMETERS = ("epochs", "goal", "min_grad", "max_fail", "time", "plateau_patience", "plateau_tol")

#: "Still improving" when the plateau rule is off: the paper's rule, the RMS error fell by at least 1 % over
#: the last 20 epochs (:class:`~encal._core.errors.TrainingLimitWarning`).
IMPROVING_WINDOW, IMPROVING_FALL = 20, 0.01


def register_algorithm(name, **stopping_defaults):
    """Decorator registering a back end ``fn(problem, x0, monitor, **options) -> x``.

    The back end calls ``monitor.start(x0, mse, grad)`` once, then
    ``monitor.update(x, mse, grad)`` after every epoch, and returns when either
    returns True or when it calls ``monitor.stop(reason)``. ``stopping_defaults``
    are MATLAB's documented ``trainParam`` defaults for that algorithm.
    """

    def decorate(fn):
        ALGORITHMS[name] = (fn, stopping_defaults)
        return fn

    return decorate


class _Counted:
    """Wraps an objective and counts performance evaluations."""

    def __init__(self, problem):
        self._problem = problem
        self.n_params = problem.n_params
        self.n_samples = problem.n_samples
        self.nfev = 0

    def residuals(self, w):
        self.nfev += 1
        return self._problem.residuals(w)

    def residuals_and_jacobian(self, w):
        self.nfev += 1
        return self._problem.residuals_and_jacobian(w)

    def mse(self, w):
        self.nfev += 1
        return self._problem.mse(w)

    def mse_and_gradient(self, w):
        self.nfev += 1
        return self._problem.mse_and_gradient(w)

    def __getattr__(self, name):
        return getattr(self._problem, name)


def train(problem, algorithm="trainlm", *, x0, validation=None, callback=None, **options):
    """Minimise a least-squares problem with one of MATLAB's training algorithms.

    Parameters
    ----------
    problem : Objective
        Training problem (see :class:`encal.training.Objective`).
    algorithm : str, default='trainlm'
        MATLAB name: one of ``sorted(encal.training.ALGORITHMS)``.
    x0 : array-like of shape (n_params,)
        Initial weights.
    validation : Objective, optional
        Validation problem; enables the ``max_fail`` criterion.
    callback : callable, optional
        ``callback(epoch, w, mse)`` after every epoch.
    **options
        Stopping parameters (``epochs``, ``goal``, ``min_grad``, ``max_fail``,
        ``time`` in seconds, ``plateau_patience``, ``plateau_tol``) and the
        algorithm's own parameters (``mu``, ``lr``, ...), with MATLAB's
        defaults for those not given.

    Returns
    -------
    TrainResult

    Warns
    -----
    TrainingLimitWarning
        When training ran to the default limit of epochs (no ``epochs`` given) while its RMS error was still
        falling (by ``plateau_tol`` over ``plateau_patience`` epochs with the plateau rule, by 1 % over the
        last 20 epochs without), or when the ``time`` limit stopped it. An ``epochs`` given is a fixed
        budget: reaching it is not warned about.
    """
    if algorithm not in ALGORITHMS:
        known = ", ".join(sorted(ALGORITHMS))
        raise InputError(f"unknown training algorithm {algorithm!r}; expected one of: {known}")
    backend, defaults = ALGORITHMS[algorithm]
    epochs_given = options.get("epochs") is not None
    stopping = {"epochs": 1000, "goal": 0.0, "min_grad": 1e-7, "max_fail": 6, "time": math.inf}
    stopping.update(defaults)
    for key in STOPPING_PARAMETERS:
        if key in options:
            stopping[key] = options.pop(key)
    accepted = set(inspect.signature(backend).parameters) - {"problem", "x0", "monitor"}
    unknown = set(options) - accepted
    if unknown:
        raise InputError(
            f"{algorithm} does not take the option(s) {', '.join(sorted(unknown))}; "
            f"it takes: {', '.join(sorted(accepted | set(STOPPING_PARAMETERS))) or 'none'}"
        )
    stopping = _checked_stopping(stopping)
    x0 = np.array(x0, dtype=float, copy=True).reshape(-1)
    if x0.size != problem.n_params:
        raise InputError(f"x0 has {x0.size} values; the problem has {problem.n_params} parameters")
    counted = _Counted(problem)
    monitor = Monitor(counted, validation=validation, callback=callback, **stopping)
    x = backend(counted, x0, monitor, **options)
    if monitor.reason is None:  # a back end that ran out of epochs without saying so
        monitor.reason = "epochs"
    _warn_if_cut_short(monitor, algorithm, epochs_given)
    x = monitor.final_weights(x)
    if x is None:
        raise InputError("the initial weights x0 give a NaN or infinite error; expected finite "
                         "performance at x0 (check the data and the initial weights)")
    return TrainResult(
        x=x,
        algorithm=algorithm,
        reason=monitor.reason,
        epochs=monitor.epoch,
        mse=problem.mse(x),
        val_mse=None if validation is None else validation.mse(x),
        history=monitor.histories(),
        nfev=counted.nfev,
        time_s=monitor.elapsed,
    )


def _checked_stopping(stopping):
    """The stopping parameters after checking each (:mod:`encal._core.parameters`'s one template)."""
    checked = dict(stopping)
    checked["epochs"] = check_int(stopping["epochs"], "epochs", "train", low=0)
    checked["goal"] = check_number(stopping["goal"], "goal", "train", low=0.0, note="a mean squared error")
    checked["min_grad"] = check_number(stopping["min_grad"], "min_grad", "train", low=0.0)
    checked["max_fail"] = check_int(stopping["max_fail"], "max_fail", "train", low=1)
    if stopping["time"] != math.inf:
        checked["time"] = check_number(stopping["time"], "time", "train", low=0.0, note="seconds, or math.inf")
    if stopping.get("plateau_patience") is not None:
        checked["plateau_patience"] = check_int(stopping["plateau_patience"], "plateau_patience", "train", low=1,
                                                note="epochs, or None")
    if "plateau_tol" in stopping:
        checked["plateau_tol"] = check_number(stopping["plateau_tol"], "plateau_tol", "train", low=0.0, high=1.0)
    return checked


def _warn_if_cut_short(monitor, algorithm, epochs_given):
    """Warn (:class:`~encal._core.errors.TrainingLimitWarning`) when a limit, not a criterion, ended a run that was
    still improving: the default epoch limit, or the time limit (whatever the error did)."""
    if monitor.reason == "time":
        window = monitor.plateau_patience or IMPROVING_WINDOW
        fall, span = monitor.recent_fall(window)
        warnings.warn(TrainingLimitWarning(
            f"Training with {algorithm} stopped on its time limit of {monitor.max_time:g} s after "
            f"{monitor.epoch} epochs, {_fall_text(fall, span)}, so the result depends on this machine's speed "
            "(give epochs instead of time for a repeatable fit)."), stacklevel=3)
    elif monitor.reason == "epochs" and not epochs_given:
        plateau = monitor.plateau_patience is not None
        window = monitor.plateau_patience if plateau else IMPROVING_WINDOW
        threshold = monitor.plateau_tol if plateau else IMPROVING_FALL
        fall, span = monitor.recent_fall(window)
        if fall >= threshold:
            warnings.warn(TrainingLimitWarning(
                f"Training with {algorithm} stopped at the default limit of {monitor.max_epochs} epochs while "
                f"its error was still falling ({_fall_text(fall, span)}); give epochs (encal fit --epochs) to "
                "train longer or to fix the budget."), stacklevel=3)


def _fall_text(fall, span):
    """The recent change of the RMS error in words: ``'the RMS error fell by 3.1 % over the last 20 epochs'``."""
    if span == 0:
        return "before its error could fall"
    if fall > 0.0:
        return f"the RMS error fell by {100.0 * fall:.2g} % over the last {span} epochs"
    return f"the RMS error did not fall over the last {span} epochs"

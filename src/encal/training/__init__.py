"""Training algorithms for least-squares problems, named and defaulted as MATLAB names them.

One front end, :func:`train`, dispatches on ``algorithm=`` to back ends that
share one signature and one stopping monitor.
"""

from ._objective import LinearLeastSquares, Objective
from ._registry import ALGORITHMS, STOPPING_PARAMETERS, register_algorithm, train
from ._result import STOP_REASONS, TrainResult

# Importing the back ends registers them.
from . import _algorithms  # noqa: E402,F401

__all__ = ["train", "ALGORITHMS", "STOPPING_PARAMETERS", "register_algorithm", "TrainResult", "STOP_REASONS",
           "Objective", "LinearLeastSquares"]

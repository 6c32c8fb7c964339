"""encal: make cheap angle encoders accurate.

Calibrate an encoder against a better reference, model its error profile
``error = encoder - reference`` (arc-minutes, as a function of the encoder
angle in degrees), and subtract the predicted error from every later reading.

Public names are loaded on first use, so ``import encal`` stays fast and
does not import Matplotlib.
"""

import importlib

from ._version import __version__

# public name -> module that defines it
_PUBLIC = {
    "wrap360": "angles", "wrap180": "angles", "angle_difference": "angles", "lsb_arcmin": "angles",
    "Calibration": "calibration", "read_calibration": "calibration",
    "write_calibration": "calibration",
    "ErrorStats": "profile", "error_stats": "profile", "harmonics": "profile",
    "Harmonics": "profile",
    "fit": "fitting", "evaluate": "fitting", "Evaluation": "fitting",
    "Model": "models", "Selection": "models.choice",
    "plot_profile": "plots", "plot_model": "plots", "plot_before_after": "plots",
    "hidden_node_sweep": "studies", "compare_algorithms": "studies", "svd_pruning": "studies",
    "compare_models": "studies", "reproducibility": "studies",
    "demo_fleet": "simulate", "simulate_fleet": "simulate", "measurement_floor": "simulate",
    "save_model": "deploy", "load_model": "deploy", "Compensator": "deploy",
    "SelfCalibration": "selfcal",
    "EncalError": "errors", "CalibrationError": "errors", "ModelFileError": "errors",
    "InputError": "errors", "EncalWarning": "errors", "TrainingLimitWarning": "errors",
}

__all__ = ["__version__", *_PUBLIC]


def __getattr__(name):
    try:
        module = _PUBLIC[name]
    except KeyError:
        raise AttributeError(f"module 'encal' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(__all__)

"""encal: make cheap angle encoders accurate.

Calibrate an encoder against a better reference, model its error profile
``error = encoder - reference`` (arc-minutes, as a function of the encoder
angle in degrees), and subtract the predicted error from every later reading.

Public names are loaded on first use, so ``import encal`` stays fast and
does not import Matplotlib.
"""

import importlib

from ._core.deprecation import install_moved_modules
from ._version import __version__

# public name -> module that defines it
_PUBLIC = {
    "wrap360": "_core.angles", "wrap180": "_core.angles", "angle_difference": "_core.angles",
    "lsb_arcmin": "_core.angles",
    "Calibration": "data.calibration", "read_calibration": "data.calibration",
    "write_calibration": "data.calibration",
    "ErrorStats": "analysis.profile", "error_stats": "analysis.profile", "harmonics": "analysis.profile",
    "Harmonics": "analysis.profile",
    "fit": "models.fitting", "evaluate": "models.fitting", "Evaluation": "models.fitting",
    "Model": "models", "Selection": "models.auto",
    "plot_profile": "figures", "plot_model": "figures", "plot_before_after": "figures",
    "hidden_node_sweep": "paper.studies", "compare_algorithms": "paper.studies", "svd_pruning": "paper.studies",
    "compare_models": "paper.studies", "reproducibility": "paper.studies",
    "demo_fleet": "simulate", "simulate_fleet": "simulate", "measurement_floor": "simulate",
    "save_model": "deploy", "load_model": "deploy", "Compensator": "deploy",
    "SelfCalibration": "selfcal",
    "EncalError": "_core.errors", "CalibrationError": "_core.errors", "ModelFileError": "_core.errors",
    "InputError": "_core.errors", "EncalWarning": "_core.errors", "TrainingLimitWarning": "_core.errors",
}

__all__ = ["__version__", *_PUBLIC]

# The paths of encal 0.1 (old module -> the module that defines its names now): they work until encal 0.3,
# with a DeprecationWarning on first use of a name (encal._core.deprecation).
_MOVED = {
    "angles": "_core.angles", "errors": "_core.errors", "parameters": "_core.parameters",
    "calibration": "data.calibration", "bidirectional": "data.reversal",
    "profile": "analysis.profile", "outliers": "analysis.outliers", "plots": "figures",
    "fitting": "models.fitting", "uncertainty": "models.uncertainty", "models.choice": "models.auto",
    "deploy.choice": "deploy.deployment", "drift": "reports.drift", "encoder_report": "reports.encoder",
    "report": "paper.report", "demo": "paper.demo", "studies": "paper.studies", "arcs": "_core.arcs",
    **{f"studies.{name}": f"paper.studies.{name}"
       for name in ("algorithms", "comparison", "pruning", "reproducibility", "sweep", "tables")},
    "selfcal.simulate": "selfcal.synthetic",  # named apart from the resolver simulator encal.simulate
    **{f"selfcal.simulate.{name}": f"selfcal.synthetic.{name}" for name in ("encoder", "motor", "stepper")},
}
install_moved_modules({f"{__name__}.{old}": f"{__name__}.{new}" for old, new in _MOVED.items()}, _PUBLIC)


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

"""The import paths of encal 0.1 keep working for one release, each with a DeprecationWarning."""

import importlib
import pickle

import pytest

# old module -> (a name it held, the module that defines it now)
MOVED = {
    "encal.angles": ("wrap360", "encal._core.angles"),
    "encal.errors": ("InputError", "encal._core.errors"),
    "encal.parameters": ("check_int", "encal._core.parameters"),
    "encal.calibration": ("read_calibration", "encal.data.calibration"),
    "encal.outliers": ("isolated_points", "encal.analysis.outliers"),
    "encal.profile": ("harmonics", "encal.analysis.profile"),
    "encal.bidirectional": ("reversal", "encal.data.reversal"),
    "encal.fitting": ("fit", "encal.models.fitting"),
    "encal.uncertainty": ("add_uncertainty", "encal.models.uncertainty"),
    "encal.drift": ("compare_calibrations", "encal.reports.drift"),
    "encal.plots": ("plot_profile", "encal.figures"),
    "encal.encoder_report": ("write_encoder_report", "encal.reports.encoder"),
    "encal.report": ("write_report", "encal.paper.report"),
    "encal.demo": ("run_demo", "encal.paper.demo"),
    "encal.models.choice": ("Selection", "encal.models.auto"),
    "encal.deploy.choice": ("choose_deployment", "encal.deploy.deployment"),
    "encal.studies": ("compare_models", "encal.paper.studies"),
    "encal.studies.algorithms": ("compare_algorithms", "encal.paper.studies.algorithms"),
    "encal.studies.comparison": ("compare_models", "encal.paper.studies.comparison"),
    "encal.studies.pruning": ("svd_pruning", "encal.paper.studies.pruning"),
    "encal.studies.reproducibility": ("reproducibility", "encal.paper.studies.reproducibility"),
    "encal.studies.sweep": ("hidden_node_sweep", "encal.paper.studies.sweep"),
    "encal.studies.tables": ("Table", "encal.paper.studies.tables"),
    "encal.arcs": ("arc_of", "encal._core.arcs"),
    "encal.selfcal.simulate": ("make_motor", "encal.selfcal.synthetic"),
    "encal.selfcal.simulate.encoder": ("draw_magnetic_encoder", "encal.selfcal.synthetic.encoder"),
    "encal.selfcal.simulate.motor": ("simulate_spin", "encal.selfcal.synthetic.motor"),
    "encal.selfcal.simulate.stepper": ("simulate_steps", "encal.selfcal.synthetic.stepper"),
}


@pytest.mark.parametrize("old", sorted(MOVED))
def test_an_old_path_warns_and_hands_over_the_same_object(old):
    name, new = MOVED[old]
    module = importlib.import_module(old)
    with pytest.warns(DeprecationWarning,
                      match=rf"{old} is deprecated and will be removed in encal 0.3: import {name} "):
        value = getattr(module, name)
    assert value is getattr(importlib.import_module(new), name)
    assert name in dir(module)


def test_from_import_of_an_old_path_warns_and_names_the_public_place_when_there_is_one():
    with pytest.warns(DeprecationWarning, match="import read_calibration from encal instead"):
        from encal.calibration import read_calibration
    with pytest.warns(DeprecationWarning, match="import check_folds from encal.data.calibration instead"):
        from encal.calibration import check_folds
    assert read_calibration is importlib.import_module("encal").read_calibration
    assert check_folds is importlib.import_module("encal.data.calibration").check_folds


def test_an_old_folder_left_behind_does_not_hide_the_new_place(tmp_path, monkeypatch):
    # After a pull that moved selfcal/simulate, its folder stays with only __pycache__ in an editable checkout.
    import sys

    import encal.selfcal

    (tmp_path / "simulate" / "__pycache__").mkdir(parents=True)
    monkeypatch.setattr(encal.selfcal, "__path__", [*encal.selfcal.__path__, str(tmp_path)])
    monkeypatch.delitem(sys.modules, "encal.selfcal.simulate", raising=False)
    module = importlib.import_module("encal.selfcal.simulate")
    with pytest.warns(DeprecationWarning, match="import make_motor from encal.selfcal.synthetic instead"):
        assert module.make_motor is importlib.import_module("encal.selfcal.synthetic").make_motor


def test_an_old_path_says_which_name_it_lacks():
    module = importlib.import_module("encal.fitting")
    with pytest.raises(AttributeError, match="module 'encal.fitting' has no attribute 'no_such_name'"):
        module.no_such_name


def test_the_errors_are_named_as_a_user_imports_them():
    import encal
    from encal._core.errors import InputError

    assert InputError.__module__ == "encal" and encal.InputError is InputError
    error = pickle.loads(pickle.dumps(InputError("one sentence")))  # as a worker process sends it back
    assert type(error) is InputError and str(error) == "one sentence"

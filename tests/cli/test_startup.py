"""What a command imports at start-up (encal.cli): its own module and the libraries it needs, nothing else."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import encal.cli
from encal.cli import COMMANDS, build_parser
from encal.deploy import Compensator
from encal.models import kind_names
from tests._paths import DATA


#: Runs main() on the arguments after the first and writes the names of the modules it imported
#: (of SciPy, Matplotlib and encal) to the file named by the first.
PROBE = """\
import json, sys
from encal.cli import main
try:
    status = main(sys.argv[2:])
except SystemExit as exc:  # argparse's --help
    status = exc.code
names = sorted(name for name in sys.modules if name.startswith(("scipy", "matplotlib", "numpy", "encal")))
with open(sys.argv[1], "w") as handle:
    json.dump({"status": status, "modules": names}, handle)
"""


def imported_by(tmp_path, *argv, stdin="", env=None):
    """The exit status, the output and the imported modules of ``encal ARGV`` in a fresh process."""
    listing = tmp_path / "modules.json"
    process = subprocess.run([sys.executable, "-c", PROBE, str(listing), *argv], input=stdin,
                             capture_output=True, text=True, timeout=120, env=env)
    assert process.stderr == ""
    result = json.loads(listing.read_text())
    return result["status"], process.stdout, result["modules"]


@pytest.mark.parametrize("model_name, kinds", [("lut", ["lut"]), ("lut_linear", ["lut"]), ("fourier", ["fourier"]),
                                               ("spectral", ["fourier", "spectral"])])  # a spectral model is a series
def test_correct_imports_its_own_command_and_model_kind_and_no_scipy(tmp_path, model_name, kinds):
    model = DATA / f"model_v1_{model_name}.json"
    angles = [0.0, 12.5, 359.75]
    status, out, modules = imported_by(tmp_path, "correct", str(model), stdin="".join(f"{a}\n" for a in angles))
    assert status == 0
    np.testing.assert_allclose([float(line) for line in out.splitlines()], Compensator(model).correct(angles),
                               rtol=0, atol=1e-12)
    assert [name for name in modules if name.startswith(("scipy", "matplotlib"))] == []
    assert "numpy.ma" not in modules  # imported by np.unique's first call: 8 ms
    assert [name for name in modules if name.startswith("encal.cli.cmd_")] == ["encal.cli.cmd_correct"]
    every_kind = {f"encal.models.{name}" for name in kind_names()}
    assert [name for name in modules if name in every_kind] == [f"encal.models.{kind}" for kind in kinds]
    heavy = ("encal.paper.studies", "encal.training", "encal.deploy.cexport", "encal.deploy.targets", "encal.figures")
    assert not [name for name in modules if name.startswith(heavy)]


def test_the_command_list_imports_no_command_and_not_numpy(tmp_path):
    status, out, modules = imported_by(tmp_path, "--help")
    assert status == 0
    assert all(f"    {name}" in out for name in COMMANDS)
    assert [name for name in modules if name.startswith(("numpy", "scipy", "encal.cli.cmd_"))] == []


def test_every_command_file_has_its_line_in_the_command_list():
    files = sorted(path.stem[4:] for path in Path(encal.cli.__file__).parent.glob("cmd_*.py"))
    assert sorted(COMMANDS) == files


def _help_of(parser, argv, capsys):
    with pytest.raises(SystemExit) as info:
        parser.parse_args(argv)
    assert info.value.code == 0
    return capsys.readouterr().out


@pytest.mark.parametrize("name", list(COMMANDS))
def test_a_commands_help_is_the_same_when_its_options_are_added_on_demand(name, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "100")
    everything = build_parser(every_command=True)
    expected = everything._subparsers._group_actions[0].choices[name].format_help()
    shown = _help_of(build_parser(), [name, "--help"], capsys)
    assert shown == expected
    assert shown.startswith(f"usage: encal {name} ")
    option_strings = [option for action in everything._subparsers._group_actions[0].choices[name]._actions
                      for option in action.option_strings]
    assert all(option in shown for option in option_strings)


def test_the_command_list_is_the_same_when_no_command_is_loaded(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "100")
    shown = _help_of(build_parser(), ["--help"], capsys)
    assert shown == build_parser(every_command=True).format_help()
    for name, line in COMMANDS.items():
        assert f"    {name}" in shown and line.split()[0] in shown


def test_ctrl_c_while_the_command_is_imported_stops_it_cleanly(monkeypatch, capsys):
    def interrupted(command, name):
        raise KeyboardInterrupt

    monkeypatch.setattr(encal.cli, "_add_options", interrupted)
    assert encal.cli.main(["correct", "model.json"]) == 130
    assert capsys.readouterr().err == "encal correct: interrupted\n"


@pytest.mark.parametrize("threads, scipy_expected", [(None, False), ("2", True)])
def test_a_dense_fourier_fit_loads_scipy_only_to_limit_a_blas_the_user_threaded(tmp_path, threads, scipy_expected):
    # The command line pins one BLAS thread before NumPy loads; its fits then need no threadpool controller, whose
    # set-up imports scipy.linalg (0.15-0.3 s), and a well-conditioned dense Fourier fit needs no SciPy at all.
    # A user's own thread count wins, and the fit limits BLAS around its work as in a program.
    import os

    rng = np.random.default_rng(0)
    reference = rng.uniform(0.0, 360.0, 60_000)
    path = tmp_path / "dense.csv"
    np.savetxt(path, np.c_[reference, reference + np.sin(np.radians(reference)) / 60.0], fmt="%.9f",
               delimiter=",", header="reference_deg,encoder_deg", comments="")
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                                             "MKL_NUM_THREADS")}
    if threads is not None:
        env["OPENBLAS_NUM_THREADS"] = threads
    status, out, modules = imported_by(tmp_path, "fit", str(path), "--method", "fourier", "--orders", "1,2,3",
                                       "-o", str(tmp_path / "model.json"), env=env)
    assert status == 0
    assert any(name.startswith("scipy") for name in modules) == scipy_expected
    parameters = json.loads((tmp_path / "model.json").read_text())["parameters"]
    np.testing.assert_allclose(parameters["sin"], [1.0, 0.0, 0.0], rtol=0, atol=1e-3)  # sin θ / 60 degrees

"""The README's examples run as written, on the files its own command makes."""

import re
import shlex
import shutil
import subprocess
import sys
import warnings

import pytest

from encal.cli import main
from tests._paths import EXAMPLES, README

#: The README's calibration commands that write a report (seconds each: the slow test runs them).
_WRITES_A_REPORT = re.compile(r"^encal report ")


def _readme_shell_commands():
    """Every ``encal ...`` command of the README: its ``sh`` blocks' lines and its table's inline commands."""
    text = README.read_text(encoding="utf-8")
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", text, flags=re.S):
        for line in block.splitlines():
            words = shlex.split(line, comments=True)
            if words[:1] == ["encal"]:
                commands.append(words)
    commands += [shlex.split(command) for command in re.findall(r"^\| [^|]+ \| `(encal [^`]*)` \|$", text, flags=re.M)]
    return commands


@pytest.fixture
def readme_folder(tmp_path, monkeypatch):
    """A folder holding what the README's commands read: ``sim/``, ``examples/``, ``table.csv``, ``readings.txt``."""
    subprocess.run([sys.executable, "-m", "encal", "simulate", "--encoders", "1", "--out", str(tmp_path / "sim")],
                   check=True, capture_output=True)
    shutil.copytree(EXAMPLES, tmp_path / "examples", ignore=shutil.ignore_patterns("*.py"))
    shutil.copy(tmp_path / "sim" / "enc1_train.csv", tmp_path / "table.csv")  # "a rotary table, degrees"
    (tmp_path / "readings.txt").write_text("".join(f"{angle}\n" for angle in range(0, 360, 10)), encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_the_readme_lists_its_commands():
    commands = [" ".join(words[:2]) for words in _readme_shell_commands()]
    for command in ("encal profile", "encal fit", "encal report", "encal export", "encal evaluate", "encal correct",
                    "encal drift"):
        assert command in commands, f"{command} is no longer found in README.md's examples"


def test_the_readme_commands_run_as_written(readme_folder, capsys):
    commands = [words for words in _readme_shell_commands() if not _WRITES_A_REPORT.match(" ".join(words))]
    commands.sort(key=lambda words: words[1] != "fit")  # the model file the others read first
    for words in commands:
        assert main(words[1:]) == 0, f"README.md: `{' '.join(words)}` failed: {capsys.readouterr().err}"
    assert (readme_folder / "fw" / "encal.h").is_file() and (readme_folder / "comp.cfg").is_file()


@pytest.mark.slow
def test_the_readme_reports_run_as_written(readme_folder, capsys):
    commands = [words for words in _readme_shell_commands() if _WRITES_A_REPORT.match(" ".join(words))]
    assert len(commands) >= 4  # the walk-through's and the table's three
    for words in commands:
        assert main(words[1:]) == 0, f"README.md: `{' '.join(words)}` failed: {capsys.readouterr().err}"
        assert (readme_folder / words[words.index("-o") + 1]).stat().st_size > 10_000


def test_the_readme_python_example_runs_as_written(tmp_path, monkeypatch):
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)
    assert blocks, "README.md has no Python example"
    subprocess.run([sys.executable, "-m", "encal", "simulate", "--encoders", "1", "--out", str(tmp_path)],
                   check=True, capture_output=True)
    monkeypatch.chdir(tmp_path)
    import matplotlib.pyplot as plt

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the example must run without a warning, e.g. training cut short
        for block in blocks:
            exec(compile(block, str(README), "exec"), {"__name__": "readme"})
    assert (tmp_path / "enc1.json").is_file()
    figure = tmp_path / "enc1_before_after.png"
    plt.figure().savefig(tmp_path / "blank.png")
    assert figure.stat().st_size > 2 * (tmp_path / "blank.png").stat().st_size  # the plot, not an empty canvas

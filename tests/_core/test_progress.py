"""The progress line of a long command: shown on a terminal after 2 s, one closing line elsewhere when long.

The clock is a fake one and the terminal a stub, so that no test depends on how fast the machine is.
"""

import io
import itertools
import sys
import threading
import warnings

import numpy as np
import pytest

import encal._core.progress as progress_module
from encal._core.progress import LOG_AFTER_S, SHOW_AFTER_S, Activity, clear_line
from encal.cli import main
from encal._core.errors import EncalWarning


class Terminal(io.StringIO):
    """stderr on a terminal."""

    def isatty(self):
        return True


class Clock:
    """Seconds that advance by ``step`` at every reading (thread-safe: the redraw thread reads it too)."""

    def __init__(self, step=0.0, start=0.0):
        self.now, self.step = start, step
        self._lock = threading.Lock()

    def __call__(self):
        with self._lock:
            self.now += self.step
            return self.now


def test_nothing_is_drawn_on_a_terminal_before_two_seconds():
    clock, terminal = Clock(), Terminal()
    with Activity("encal fit", stream=terminal, clock=clock, background=False) as activity:
        activity.stage("reading cal.csv", total=100)
        clock.now = SHOW_AFTER_S - 0.1
        activity.update(40)
        assert not activity.tick()
    assert terminal.getvalue() == ""  # a short run leaves nothing, not even a closing line


def test_after_two_seconds_the_stage_and_its_bar_are_drawn_and_the_run_ends_with_its_stages():
    clock, terminal = Clock(), Terminal()
    with Activity("encal fit", stream=terminal, clock=clock, background=False) as activity:
        activity.stage("reading cal.csv", total=200)
        clock.now = 2.5
        activity.update(50)
        assert activity.tick()
        assert terminal.getvalue() == "\rencal fit: reading cal.csv [#######---------------------]  25%   2.5 s"
        clock.now = 4.0
        activity.stage("fitting (lut)")  # a stage without a total: no bar
        shown = terminal.getvalue()
        assert shown.rstrip(" ").endswith("\rencal fit: fitting (lut) ...   4.0 s")
        assert len(shown.rsplit("\r", 1)[1]) == len(shown.split("\r")[1])  # padded over the longer line
        clock.now = 6.0
    assert terminal.getvalue().endswith("\rencal fit: done in 6.0 s (reading cal.csv 4.0 s, fitting (lut) 2.0 s)\n")


def test_a_failed_run_takes_its_line_off_the_terminal():
    clock, terminal = Clock(), Terminal()
    with pytest.raises(ValueError), Activity("encal fit", stream=terminal, clock=clock, background=False) as activity:
        activity.stage("reading cal.csv")
        clock.now = 3.0
        activity.tick()
        raise ValueError("bad line")
    shown = "\rencal fit: reading cal.csv ...   3.0 s"
    assert terminal.getvalue() == shown + "\r" + " " * (len(shown) - 1) + "\r"


def test_a_warning_takes_the_place_of_the_line():
    clock, terminal = Clock(), Terminal()
    with Activity("encal fit", stream=terminal, clock=clock, background=False) as activity:
        activity.stage("reading cal.csv")
        clock.now = 3.0
        activity.tick()
        clear_line()
        terminal.write("a warning\n")
        clock.now = 3.5
        activity.tick()
    lines = terminal.getvalue().split("\n")
    assert lines[0].endswith("\ra warning")
    assert lines[1].startswith("\rencal fit: reading cal.csv ...   3.5 s")


@pytest.mark.parametrize("seconds, expected", [(LOG_AFTER_S - 0.1, ""),
                                               (LOG_AFTER_S, "encal fit: done in 10.0 s (reading cal.csv 10.0 s)\n")])
def test_off_a_terminal_one_closing_line_and_only_for_a_long_run(seconds, expected):
    clock, log = Clock(), io.StringIO()
    with Activity("encal fit", stream=log, clock=clock) as activity:
        activity.stage("reading cal.csv", total=10)
        clock.now = seconds
        activity.update(10)
        assert not activity.tick()
    assert log.getvalue() == expected


def test_the_background_thread_draws_while_the_work_holds_the_main_thread(monkeypatch):
    monkeypatch.setattr(progress_module, "REDRAW_S", 0.01)
    clock, terminal = Clock(), Terminal()
    with Activity("encal fit", stream=terminal, clock=clock) as activity:
        activity.stage("fitting (spectral)", total=3)
        clock.now = 5.0
        for _ in range(500):  # the work: no call to tick
            if "fitting" in terminal.getvalue():
                break
            threading.Event().wait(0.01)
    assert terminal.getvalue().startswith("\rencal fit: fitting (spectral) [")


# ------------------------------------------------------------------ the commands


def sweep_csv(path, revolutions=5, stops=720):
    """A dense sweep: each stop read once per revolution."""
    rng = np.random.default_rng(0)
    reference = np.tile(np.arange(stops) * 360.0 / stops, revolutions)
    encoder = reference + (2.0 * np.sin(np.radians(reference)) + rng.normal(0.0, 0.1, reference.size)) / 60.0
    path.write_text("reference_deg,encoder_deg\n"
                    + "".join(f"{r!r},{e!r}\n" for r, e in zip(reference.tolist(), encoder.tolist())))
    return path


@pytest.fixture
def files(tmp_path):
    cal = sweep_csv(tmp_path / "sweep.csv")
    model = tmp_path / "sweep.json"
    assert main(["fit", str(cal), "-o", str(model), "--method", "lut"]) == 0
    angles = tmp_path / "angles.txt"
    angles.write_text("".join(f"{a!r}\n" for a in np.linspace(0.0, 359.0, 5000).tolist()))
    return {"cal": cal, "model": model, "angles": angles, "out": tmp_path}


COMMANDS = {
    "profile": (["profile", "{cal}"], "reading {cal}"),
    "fit lut": (["fit", "{cal}", "-o", "{out}/m.json", "--method", "lut"], "reading {cal}"),
    "fit spectral": (["fit", "{cal}", "-o", "{out}/m.json", "--method", "spectral"], "reading {cal}"),
    "evaluate": (["evaluate", "{model}", "{cal}"], "reading {model}"),
    "correct": (["correct", "{model}", "{angles}"], "correcting {angles}"),
    "report": (["report", "{cal}", "-o", "{out}/r.html", "--method", "lut", "--no-uncertainty", "--no-comparison"],
               "reading {cal}"),
}


def _argv(argv, files):
    return [word.format(**files) for word in argv]


@pytest.mark.parametrize("name", list(COMMANDS))
def test_a_long_command_shows_its_stages_on_a_terminal(name, files, monkeypatch, capsys):
    argv, first = COMMANDS[name]
    monkeypatch.setattr(progress_module, "_now", Clock(step=1.0))  # every reading of the clock: a second later
    terminal = Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert main(_argv(argv, files)) == 0
    err = terminal.getvalue()
    command = argv[0]
    assert f"\rencal {command}: {first.format(**files)}" in err
    closing = err.rsplit("\r", 1)[-1]
    assert closing.startswith(f"encal {command}: done in ") and closing.endswith("\n")
    assert closing.rstrip("\n ").endswith(" s)")  # spaces over the rest of a longer line before it
    assert closing.count("\n") == 1 and err.count(" done in ") == 1
    assert f"({first.format(**files)} " in closing  # the stages and their times, the first one first


@pytest.mark.parametrize("name", list(COMMANDS))
def test_off_a_terminal_a_long_command_writes_one_line_and_a_short_one_none(name, files, monkeypatch, capsys):
    argv, first = COMMANDS[name]
    assert main(_argv(argv, files)) == 0
    assert capsys.readouterr().err == ""  # real seconds: well under 10
    monkeypatch.setattr(progress_module, "_now", Clock(step=LOG_AFTER_S))
    assert main(_argv(argv, files)) == 0
    err = capsys.readouterr().err
    assert err.startswith(f"encal {argv[0]}: done in ") and err.count("\n") == 1
    assert f"({first.format(**files)} " in err


def test_correct_shows_nothing_when_its_answers_go_to_the_terminal(files, monkeypatch, capsys):
    monkeypatch.setattr(progress_module, "_now", Clock(step=LOG_AFTER_S))
    monkeypatch.setattr(sys.stdout, "isatty", lambda: True, raising=False)
    assert main(["correct", str(files["model"]), str(files["angles"])]) == 0
    assert capsys.readouterr().err == ""


def test_a_warning_while_reading_is_a_line_of_its_own(files, monkeypatch):
    monkeypatch.setattr(progress_module, "_now", Clock(step=1.0))
    terminal = Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    lines = files["cal"].read_text().splitlines()
    reference, encoder = (float(cell) for cell in lines[1001].split(","))
    lines[1001] = f"{reference!r},{encoder + 0.3!r}"  # 18 arcmin off the other readings of its stop
    files["cal"].write_text("\n".join(lines) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("default", EncalWarning)
        assert main(["profile", str(files["cal"])]) == 0
    warning = next(line for line in terminal.getvalue().split("\n") if "warning:" in line)
    assert warning.split("\r")[-1].startswith("encal profile: warning: ")
    assert not warning.split("\r")[-1].endswith(" s")  # the progress line is not glued to it

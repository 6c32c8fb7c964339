"""Figures the user pages state, recomputed by the commands the pages give beside them.

Each test runs a page's own reproduction (its code block or command) and compares every number of the table or
output the page shows, at the page's rounding, so a change of the simulator, the statistics or a model that moves a
published figure fails here instead of leaving the page wrong.
"""

import re
import subprocess
import sys

import numpy as np
import pytest

from tests._paths import REAL_MECHADUINO, REPO

DOCS = REPO / "docs"


def _python_block_after(page, marker):
    """The first ```python block of ``page`` after the line holding ``marker``."""
    text = (DOCS / page).read_text(encoding="utf-8")
    return re.search(re.escape(marker) + r".*?```python\n(.*?)```", text, flags=re.S).group(1)


def _table_rows(page, header_start):
    """The body rows of the Markdown table whose header begins with ``header_start``, as lists of cells."""
    lines = (DOCS / page).read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header_start))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip("|").split("|")])
    return rows


def _number(cell):
    return float(cell.replace("−", "-"))


def _run_block(block, capsys):
    exec(compile(block, "docs", "exec"), {"__name__": "docs"})
    return capsys.readouterr().out


def test_the_demo_fleet_table_of_the_simulator_page_is_what_its_code_prints(capsys):
    printed = _run_block(_python_block_after("simulator.md", "Reproduce the table:"), capsys)
    computed = {}
    for line in printed.splitlines():
        name, rest = line.split(" ", 1)
        numbers = [float(x) for x in re.findall(r"-?\d+\.?\d*(?:e-?\d+)?", rest.replace("np.int64(", ""))]
        computed[name] = numbers
    rows = _table_rows("simulator.md", "| encoder | seed | MAE |")
    assert [row[0] for row in rows] == sorted(computed)
    for row in rows:
        mae, rms, std, low, high, *rest = computed[row[0]]
        orders, (epoch_rms, decoder2_max, floor) = rest[:10], rest[10:]
        shown = [_number(cell) for cell in row[2:7]]
        assert shown == pytest.approx(np.round([mae, rms, std, low, high], 2), abs=1e-9), row[0]
        assert [int(o) for o in row[7].split(", ")] == [int(o) for o in orders], row[0]
        assert _number(row[8]) == pytest.approx(round(epoch_rms, 3), abs=1e-9), row[0]
        assert _number(row[10]) == pytest.approx(round(decoder2_max, 2), abs=1e-9), row[0]
        assert _number(row[11]) == pytest.approx(round(floor, 3), abs=1e-9), row[0]


def test_the_simulate_example_of_the_simulator_page_is_what_the_command_prints(tmp_path):
    text = (DOCS / "simulator.md").read_text(encoding="utf-8")
    shown = re.findall(r"^(enc\d: train .*) -> sims/", text, flags=re.M)
    assert len(shown) == 4
    result = subprocess.run([sys.executable, "-m", "encal", "simulate", "--out", str(tmp_path / "sims")],
                            check=True, capture_output=True, text=True)
    printed = re.findall(r"^(enc\d: train .*) -> ", result.stdout, flags=re.M)
    assert [line.rstrip() for line in printed] == [line.rstrip() for line in shown]


@pytest.mark.skipif(not REAL_MECHADUINO.is_dir(),
                    reason="the real Mechaduino calibrations are not beside the repository")
def test_the_real_encoder_table_of_the_statistics_page_is_what_its_code_prints(capsys, monkeypatch):
    monkeypatch.chdir(REPO)  # the block globs ../shared/data/real/mechaduino
    printed = _run_block(_python_block_after("statistics.md", "Reproduce:"), capsys)
    computed = {m.group(1): (float(m.group(2)), float(m.group(3)))
                for m in re.finditer(r"^(.+?)\s+median (\S+)\s+mean (\S+) arcmin$", printed, flags=re.M)}
    names = {"fourier top10": "fourier top 10", "fourier cv": "fourier cv (5 folds", "lut linear": "lut linear",
             "lut cubic": "lut cubic"}
    rows = _table_rows("statistics.md", "| method | median | mean | min | max |")
    assert len(computed) == 4
    for name, (median, mean) in computed.items():
        row = next(row for row in rows if row[0].startswith(names[name]))
        assert (_number(row[1]), _number(row[2])) == (median, mean), name


def test_the_known_truth_table_of_the_self_calibration_page_is_what_its_benchmark_prints():
    text = (DOCS / "self-calibration.md").read_text(encoding="utf-8")
    section = text.split("### Against a truth written outside encal", 1)[1]
    shown = [line for line in section.splitlines() if line.startswith("| ")]
    result = subprocess.run([sys.executable, str(REPO / "benchmarks" / "bench_selfcal_truth.py")], check=True,
                            capture_output=True, text=True, cwd=REPO)
    printed = [line for line in result.stdout.splitlines() if line.startswith("| ")]
    assert len(shown) > 10
    assert printed == shown


def test_the_bidirectional_pages_examples_run_and_give_its_measured_reversal(tmp_path, monkeypatch):
    """users7: the page read "enc1_bidirectional.csv", which no command or page made, and used undefined names."""
    text = (DOCS / "bidirectional.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert "write_calibration" in blocks[0] and "read_calibration" in blocks[1]
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "docs"}
    for block in blocks[:2]:
        exec(compile(block, "docs/bidirectional.md", "exec"), namespace)
    iso = namespace["iso"].as_dict()
    mean_low, mean_high, value_low, value_high = (abs(_number(x)) for x in re.search(
        r"`B̄` = (−?[\d.]+) to (−?[\d.]+) LSB.*?`B` = (\d+)–(\d+) LSB", text, flags=re.S).groups())
    assert mean_low <= -iso["mean_reversal_value_lsb"] <= mean_high  # the page's sign: B̄ negative
    assert value_low <= iso["reversal_value_lsb"] <= value_high
    assert namespace["model"].training["bidirectional"] == "mean"


def test_the_self_calibration_pages_commands_run_on_the_files_its_block_writes(tmp_path, monkeypatch, capsys):
    """users7: the page's commands read spin.csv and moteus_raw.txt, which nothing made."""
    import shlex
    import shutil

    from encal.cli import main
    from tests._paths import EXAMPLES

    text = (DOCS / "self-calibration.md").read_text(encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    shutil.copytree(EXAMPLES, tmp_path / "examples", ignore=shutil.ignore_patterns("*.py"))
    _run_block(_python_block_after("self-calibration.md", "To try them without a motor"), capsys)
    commands = [shlex.split(line, comments=True) for line in re.search(r"```sh\n(.*?)```", text, flags=re.S)
                .group(1).splitlines()]
    steps_command = shlex.split(re.search(r"`(encal selfcal steps examples/[^`]*)`", text).group(1))
    commands = [steps_command if words[:3] == ["encal", "selfcal", "steps"] else words for words in commands]
    for words in commands:
        capsys.readouterr()
        assert main(words[1:]) == 0, f"self-calibration.md: `{' '.join(words)}` failed: {capsys.readouterr().err}"
        if words[:3] == ["encal", "selfcal", "steps"]:
            printed = capsys.readouterr().out
    said = re.search(r"orders 1, 2 and 4 at ([\d.]+), ([\d.]+) and ([\d.]+) arcmin.*?`--step-zero ([\d.]+)`", text,
                     flags=re.S).groups()
    found = [re.search(rf"^\s+{order}\s+([\d.]+)", printed, flags=re.M).group(1) for order in (1, 2, 4)]
    assert [float(x) for x in said[:3]] == pytest.approx([round(float(x), 2) for x in found], abs=1e-9)
    assert f"--step-zero {said[3]} " in printed
    assert (tmp_path / "moteus.cfg").is_file()


def test_the_in_place_pages_commands_run_on_the_files_its_blocks_write(tmp_path, monkeypatch, capsys):
    """users7: the page's commands read arm.csv, arm_test.csv and joint.csv, which nothing made."""
    import shlex

    from encal.cli import main

    text = (DOCS / "in-place.md").read_text(encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "--encoders", "1", "--out", "sim"]) == 0
    for marker in ("To try it without a joint, cut", "To try it without a joint, the simulator"):
        _run_block(_python_block_after("in-place.md", marker), capsys)
        commands = re.search(re.escape(marker) + r".*?```python\n.*?```.*?```\n(.*?)```", text, flags=re.S).group(1)
        for line in commands.splitlines():
            words = shlex.split(line.replace("[", "").replace("]", ""), comments=True)
            capsys.readouterr()
            assert main(words[1:]) == 0, f"in-place.md: `{line}` failed: {capsys.readouterr().err}"
    from encal import load_model

    assert load_model(tmp_path / "arm.json").kind == "arc" and (tmp_path / "arm.html").is_file()
    assert (tmp_path / "output.json").is_file()

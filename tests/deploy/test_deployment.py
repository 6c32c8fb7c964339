"""Cost-aware choice: the cheapest deployment within a tolerance, the most accurate within a budget."""

import json

import numpy as np
import pytest

from encal.cli import main
from encal.deploy.deployment import candidates, choose_deployment, parse_budget
from encal.deploy.targets import export_target
from encal._core.errors import InputError
from tests._paths import DATA

FOURIER = DATA / "model_v1_fourier.json"


@pytest.mark.parametrize("text, expected", [("1024B", ("bytes", 1024)), ("4KiB", ("bytes", 4096)),
                                            ("256entries", ("entries", 256)), ("200ops", ("operations", 200)),
                                            ("64 nodes", ("entries", 64))])
def test_parse_budget(text, expected):
    assert parse_budget(text) == expected


@pytest.mark.parametrize("text", ["", "12", "-5B", "3 parsecs", "B"])
def test_bad_budgets(text):
    with pytest.raises(InputError, match="expected a budget"):
        parse_budget(text)


@pytest.mark.parametrize(("call", "message"), [
    (lambda: choose_deployment(FOURIER, tolerance_arcmin=0.01, cost="flash"),
     "The 'cost' parameter of choose_deployment must be one of 'bytes', 'entries', 'operations'. "
     "Got 'flash' instead."),
    (lambda: choose_deployment(FOURIER, tolerance_arcmin=float("nan")),
     "The 'tolerance_arcmin' parameter of choose_deployment must be a finite number > 0 (arc-minutes, or None). "
     "Got nan instead."),
    (lambda: choose_deployment(FOURIER, tolerance_arcmin=0.01, target="host"),
     "The 'target' parameter of choose_deployment must be one of 'cortex-m4f', 'fixed'. Got 'host' instead."),
    (lambda: choose_deployment(FOURIER, budget=("flash", 64)),
     "The 'budget' parameter of choose_deployment must be a text such as '1KiB' or a pair (cost, value > 0) with "
     "a cost among bytes, entries, operations. Got ('flash', 64) instead."),
    (lambda: choose_deployment(FOURIER, budget=("bytes", -64)),
     "The 'budget' parameter of choose_deployment must be a finite number > 0 (bytes). Got -64 instead."),
    (lambda: choose_deployment(FOURIER, tolerance_arcmin=0.01, bits=0),
     "The 'bits' parameter of choose_deployment must be an int from 2 to 32 (the encoder resolution: a compact "
     "table has at least 4 nodes and at most one per code; or None for the model file's). Got 0 instead."),
    (lambda: candidates(FOURIER, target="fixed-point"),
     "The 'target' parameter of candidates must be one of 'cortex-m4f', 'fixed'. Got 'fixed-point' instead."),
])
def test_bad_options_use_the_template(call, message):
    with pytest.raises(InputError) as info:
        call()
    assert str(info.value) == message


def test_the_cheapest_within_the_tolerance_is_chosen_for_each_cost():
    every = candidates(FOURIER)
    for cost in ("bytes", "entries", "operations"):
        chosen, report = choose_deployment(FOURIER, tolerance_arcmin=0.01, cost=cost)
        assert report["met"] and chosen.max_error_arcmin <= 0.01
        within = [d for d in every if d.max_error_arcmin <= 0.01]
        assert chosen.cost(cost) == min(d.cost(cost) for d in within)
    # in bytes, the 9-term series (108 bytes) beats every table within 0.01 arcmin
    assert choose_deployment(FOURIER, tolerance_arcmin=0.01, cost="bytes")[0].form == "formula"
    # in operations, a table (15) beats the series
    assert choose_deployment(FOURIER, tolerance_arcmin=0.01, cost="operations")[0].form == "table"


def test_the_most_accurate_within_a_budget_and_what_it_gave_up():
    chosen, report = choose_deployment(FOURIER, budget="256B", tolerance_arcmin=1e-9)
    affordable = [d for d in candidates(FOURIER) if d.bytes <= 256]
    assert chosen.max_error_arcmin == min(d.max_error_arcmin for d in affordable)
    assert report["met"] is False and "gave up" in report["gave_up"] and "next more accurate" in report["gave_up"]


def test_a_budget_below_every_deployment_is_refused():
    with pytest.raises(InputError, match="budget of at least 15 operations"):
        choose_deployment(FOURIER, budget=("operations", 3))


def test_export_with_a_cost(tmp_path):
    _, summary = export_target(FOURIER, "cortex-m4f", cost="bytes", tolerance_arcmin=0.01)
    assert summary["form"] == "formula" and "gave up" in summary["gave_up"]


def test_fit_budget_records_the_deployment_and_export_uses_it(tmp_path, capsys):
    ref = np.arange(0.0, 360.0, 1.8)
    codes = np.round((ref + 0.2 * np.sin(np.radians(ref)) + 0.05 * np.cos(np.radians(3 * ref))) * 2**14 / 360)
    cal = tmp_path / "c.csv"
    cal.write_text("reference_deg,encoder_deg\n" + "".join(
        f"{r:.1f},{c % 2**14 * 360 / 2**14:.10f}\n" for r, c in zip(ref, codes)))
    model = tmp_path / "m.json"
    assert main(["fit", str(cal), "-o", str(model), "--method", "fourier", "--budget", "64B"]) == 0
    out = capsys.readouterr().out
    assert "deployment within 64B" in out and "gave up" in out
    recorded = json.loads(model.read_text())["training"]["deployment"]
    assert recorded["bytes"] <= 64 and recorded["budget"] == "64B"
    assert main(["export", str(model), "--format", "c", "--target", "cortex-m4f", "-o", str(tmp_path / "c")]) == 0
    out = capsys.readouterr().out
    assert "chosen by encal fit --budget 64B" in out
    if recorded["form"] == "table":
        cubic = " cubic B-spline" if recorded["interpolation"] == "cubic" else ""
        assert f"{recorded['nodes']}-node {recorded['dtype']}{cubic} table" in out


def test_fit_target_without_budget_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as info:  # a usage error
        main(["fit", str(DATA / "model_v1_fourier.json"), "-o", str(tmp_path / "m.json"), "--target", "fixed"])
    assert info.value.code == 2 and "--target names the processor of --budget" in capsys.readouterr().err

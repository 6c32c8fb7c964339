"""The demo orchestration (encal.paper.demo): tables, files, model files checked against the report."""

import csv
import io
from dataclasses import replace

import numpy as np
import pytest

from encal import evaluate, load_model
from encal.paper.demo import run_demo
from encal._core.errors import EncalError, InputError


def _run(out, settings):
    stdout = io.StringIO()
    result = run_demo(out, settings=settings, workers=0, progress=False, stdout=stdout, report=False)
    return result, stdout.getvalue()


@pytest.fixture(scope="module")
def demo(tiny_demo):
    """The smallest demo (conftest's ``tiny_demo``): two encoders, two sweep points, a few epochs."""
    return tiny_demo


def _without_model_selection(result):
    """The demo's settings with one encoder whose model file is Table 3's Fourier series, not encal fit's choice.

    For the tests of what the demo does with its files, which do not depend on the model: the choice
    cross-validates every candidate family, most of a small demo's time.
    """
    return replace(result.settings, n_encoders=1, saved_model="fourier")


def test_demo_prints_every_table(demo):
    _, result, text = demo
    for title in ("Table 1.", "Fig. 2a", "Table 2.", "Fig. 3", "Table 3.", "Reproducibility"):
        assert title in text
    assert list(result.tables) == ["table1_profiles", "fig2a_sweep", "table2_algorithms", "fig3_pruning",
                                   "table3_comparison", "reproducibility"]
    assert "loaded back corrects the test run" in text


def test_demo_writes_each_table_as_csv(demo):
    out, result, _ = demo
    for name, table in result.tables.items():
        rows = list(csv.reader((out / "tables" / f"{name}.csv").read_text().splitlines()))
        assert rows[0] == [column.key for column in table.columns]
        assert len(rows) == len(table.rows) + 1


def test_table3_has_every_model_for_every_encoder(demo):
    _, result, _ = demo
    records = result.tables["table3_comparison"].records()
    assert len(records) == 2 * 6
    assert {r["model"] for r in records} >= {"before compensation", "Fourier top-10 (paper)", "LUT linear",
                                              "LUT cubic", "ANN 1:80:1 raw (paper)", "ANN periodic (encal)"}
    assert all(r["rms_over_floor"] > 0.5 for r in records)


def test_each_model_file_reproduces_the_reported_accuracy(demo):
    out, result, _ = demo
    for name, encoder in result.encoders.items():
        model = load_model(out / f"{name}.json")
        after = evaluate(model, encoder.test).after
        reported = encoder.saved.stats
        assert after.rms == pytest.approx(reported.rms, rel=1e-12)
        assert after.max_abs == pytest.approx(reported.max_abs, rel=1e-12)
        assert result.checks[name]["rms_arcmin"] == pytest.approx(reported.rms, rel=1e-12)


def test_each_model_file_is_the_one_encal_fit_chooses(demo):
    from encal import fit

    out, result, _ = demo
    assert result.settings.saved_model == "auto"
    name, encoder = next(iter(result.encoders.items()))
    chosen = fit(encoder.train, method="auto", rng=0)
    saved = load_model(out / f"{name}.json")
    assert saved.kind == chosen.kind
    assert saved.parameters() == chosen.parameters()
    assert saved.training["selection"]["chosen"] == chosen.training["selection"]["chosen"]
    assert encoder.saved.label == f"chosen by encal fit: {chosen.training['selection']['chosen']}"


def test_demo_is_reproducible_to_the_byte(demo, tmp_path):
    out, first, _ = demo
    second, _ = _run(tmp_path, first.settings)
    for name in ("enc1.json", "enc2.json", "tables/table1_profiles.csv", "tables/fig2a_sweep.csv",
                 "tables/fig3_pruning.csv", "tables/table3_comparison.csv", "tables/reproducibility.csv"):
        assert (tmp_path / name).read_bytes() == (out / name).read_bytes(), name
    untimed = lambda result: [{k: v for k, v in r.items() if k != "cpu_s"}  # noqa: E731
                              for r in result.tables["table2_algorithms"].records()]
    assert untimed(second) == untimed(first)


def test_demo_records_stage_times(demo):
    _, result, _ = demo
    assert {"simulate", "encoders", "sweep", "algorithms", "files", "total"} <= set(result.timings)
    assert result.workers == 0


def test_demo_refuses_a_file_as_its_folder(demo, tmp_path):
    path = tmp_path / "file"
    path.write_text("x")
    with pytest.raises(InputError, match="is a file; expected a folder"):
        run_demo(path, settings=demo[1].settings, workers=0, progress=False, stdout=io.StringIO())


def test_demo_stops_when_a_model_file_does_not_reproduce_the_report(demo, tmp_path, monkeypatch):
    import encal.deploy
    from encal.models.fourier import FourierModel

    monkeypatch.setattr(encal.deploy, "load_model", lambda path: FourierModel([0], [0.0], [0.0]))
    with pytest.raises(EncalError, match="expected the saved model to reproduce the reported accuracy"):
        run_demo(tmp_path, settings=_without_model_selection(demo[1]), workers=0, progress=False,
                 stdout=io.StringIO(), report=False)


def test_demo_without_a_folder_writes_nothing(demo, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result, text = _run(None, _without_model_selection(demo[1]))
    assert result.files == {} and list(tmp_path.iterdir()) == []
    assert "no files written" in text
    assert np.isfinite(result.encoders["enc1"].floor_arcmin)

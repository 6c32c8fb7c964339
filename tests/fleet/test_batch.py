"""encal fleet fit against known truth: every unit's calibration has a first harmonic of its own amplitude, so that a
record holding another unit's model, an older one, or none is seen (fleet5's audit of the production line)."""

import unicodedata

import numpy as np
import pytest

from encal.cli import main
from encal.fleet import batch
from encal.fleet.batch import serial_of
from encal.store import open_store

POINTS = 180


def _write_unit(path, amplitude_arcmin, seed=0):
    """A calibration whose error is ``amplitude_arcmin * cos(theta)`` plus a fixed third order and a little noise."""
    reference = np.arange(POINTS) * (360.0 / POINTS)
    error = amplitude_arcmin * np.cos(np.radians(reference)) + 0.3 * np.sin(np.radians(3 * reference))
    error = error + np.random.default_rng(seed).normal(0.0, 0.01, POINTS)
    encoder = (reference + error / 60.0) % 360.0
    path.write_text("reference_deg,encoder_deg\n" + "".join(f"{r:.6f},{e:.6f}\n" for r, e in zip(reference, encoder)),
                    encoding="utf-8")


def _first_order_arcmin(record):
    """The amplitude of the first harmonic of a record's model (arc-minutes)."""
    profile = np.asarray(record.model().predict(np.arange(360.0)), dtype=float)
    return abs(np.fft.rfft(profile)[1]) * 2.0 / 360.0


def _fit(*argv):
    return main(["fleet", "fit", *map(str, argv), "--jobs", "0"])


def test_each_serial_gets_its_own_model_and_its_figures(tmp_path, capsys):
    for k in (1, 2, 3):
        _write_unit(tmp_path / f"SN{k:03d}.csv", k, seed=k)
    store = tmp_path / "s.sqlite"
    assert _fit(tmp_path, "--store", store) == 0
    with open_store(store) as opened:
        records = opened.latest_records()
    assert [r.serial for r in records] == ["SN001", "SN002", "SN003"]
    for k, record in zip((1, 2, 3), records):
        assert _first_order_arcmin(record) == pytest.approx(k, abs=0.01)
        # RMS of k cos + 0.3 sin 3 (and the noise's 0.01) about its mean
        assert record.rms_before_arcmin == pytest.approx(np.sqrt(k**2 / 2 + 0.3**2 / 2 + 0.01**2), abs=2e-3)
        assert record.rms_after_arcmin < 0.02


def test_a_file_whose_name_is_no_serial_number_is_refused_alone(tmp_path, capsys):
    """One file named with a tab used to abort the batch at its write: no unit of its group was stored."""
    for k in (1, 2, 3):
        _write_unit(tmp_path / f"SN{k}.csv", k, seed=k)
    _write_unit(tmp_path / "SN\t9.csv", 9, seed=9)
    store = tmp_path / "s.sqlite"
    assert _fit(tmp_path, "--store", store) == 1
    out, err = capsys.readouterr()
    assert "3 of 4 files fitted" in out and "1 refused" in out
    assert err.count("\n") == 1 and "SN\t9.csv: its serial number 'SN\\t9' is not" in err
    with open_store(store) as opened:
        assert opened.serials() == ["SN1", "SN2", "SN3"]


def test_serial_numbers_are_stripped_and_composed_but_case_and_zeros_kept(tmp_path):
    assert serial_of(tmp_path / " SN1 .csv") == "SN1"
    assert serial_of(tmp_path / (unicodedata.normalize("NFD", "SNÅ1") + ".csv")) == unicodedata.normalize("NFC",
                                                                                                          "SNÅ1")
    assert [serial_of(tmp_path / f"{name}.csv") for name in ("sn1", "SN01", "SN1")] == ["sn1", "SN01", "SN1"]


def test_a_unit_recalibrated_from_a_mac_is_one_unit_its_newest_model_found(tmp_path, capsys):
    """A file name in Unicode's decomposed form (as macOS writes it) used to be another serial number: the lookup
    typed in the composed form then found the older calibration, with exit 0."""
    first, second = tmp_path / "a", tmp_path / "b"
    first.mkdir()
    second.mkdir()
    _write_unit(first / (unicodedata.normalize("NFC", "SNÅ1") + ".csv"), 1, seed=1)
    _write_unit(second / (unicodedata.normalize("NFD", "SNÅ1") + ".csv"), 4, seed=4)
    store = tmp_path / "s.sqlite"
    assert _fit(first, "--store", store) == 0
    assert _fit(second, "--store", store) == 0
    with open_store(store) as opened:
        assert len(opened.serials()) == 1
        latest = opened.latest(unicodedata.normalize("NFD", "SNÅ1"))
    assert latest.epoch == 2 and _first_order_arcmin(latest) == pytest.approx(4, abs=0.01)


def test_a_units_files_are_its_epochs_in_natural_order(tmp_path):
    """run9 before run10: in plain string order run10 came first and the older run9 was the latest epoch."""
    _write_unit(tmp_path / "SN7_run9.csv", 1, seed=1)
    _write_unit(tmp_path / "SN7_run10.csv", 10, seed=10)
    store = tmp_path / "s.sqlite"
    assert _fit(tmp_path, "--store", store, "--serial-pattern", r"(SN\d+)_") == 0
    with open_store(store) as opened:
        history = opened.history("SN7")
    assert [(r.epoch, r.source_name) for r in history] == [(1, "SN7_run9.csv"), (2, "SN7_run10.csv")]
    assert _first_order_arcmin(history[-1]) == pytest.approx(10, abs=0.01)


def test_a_copied_calibration_is_refused_not_stored_under_another_serial(tmp_path, capsys):
    """The same bytes under two serial numbers (a file copied or misnamed) used to give both units one model."""
    lot = tmp_path / "lot"
    lot.mkdir()
    for k in (1, 2, 3):
        _write_unit(lot / f"SN{k}.csv", k, seed=k)
    (lot / "SN4.csv").write_bytes((lot / "SN2.csv").read_bytes())
    store = tmp_path / "s.sqlite"
    assert _fit(lot, "--store", store) == 1
    out, err = capsys.readouterr()
    assert "2 of 4 files fitted" in out and "2 refused" in out
    assert "SN4.csv: its bytes are the calibration of SN2 as well (in this batch)" in err
    later = tmp_path / "later"
    later.mkdir()
    (later / "SN5.csv").write_bytes((lot / "SN1.csv").read_bytes())
    assert _fit(later, "--store", store) == 1
    assert "SN5.csv: its bytes are the calibration of SN1 as well (in the store)" in capsys.readouterr().err
    with open_store(store) as opened:
        assert opened.serials() == ["SN1", "SN3"] and opened.count() == 2
    # the same file of the same unit is still a resumed batch's skip, not a refusal
    assert _fit(lot / "SN1.csv", "--store", store) == 0


def test_a_record_the_store_refuses_leaves_the_others_of_its_group_stored(tmp_path, monkeypatch, capsys):
    """One record refused at the write (here a held-out figure that is not a number) used to abort the whole
    group's transaction and the batch."""
    for k in (1, 2, 3):
        _write_unit(tmp_path / f"SN{k}.csv", k, seed=k)
    fit_unit = batch.fit_unit

    def with_a_bad_figure(task):
        outcome = fit_unit(task)
        if task[0] == "SN2":
            outcome = [(path, status, {**fields, "held_out_arcmin": float("nan")}) for path, status, fields in outcome]
        return outcome

    monkeypatch.setattr(batch, "fit_unit", with_a_bad_figure)
    store = tmp_path / "s.sqlite"
    assert _fit(tmp_path, "--store", store) == 1
    out, err = capsys.readouterr()
    assert "2 of 3 files fitted" in out and "SN2.csv: its record was refused by the store" in err
    with open_store(store) as opened:
        assert opened.serials() == ["SN1", "SN3"]


def test_export_of_a_stored_unit_equals_export_of_its_model_file(tmp_path, capsys):
    for k in (1, 2):
        _write_unit(tmp_path / f"SN{k}.csv", k, seed=k)
    store = tmp_path / "s.sqlite"
    assert _fit(tmp_path, "--store", store, "--enc-unit", "deg") == 0
    with open_store(store) as opened:
        (tmp_path / "SN2.json").write_text(opened.latest("SN2").model_json, encoding="utf-8")
    for fmt, extra in (("table", ["--bits", "12"]), ("tinymovr", ["--bits", "14"]),
                       ("mechaduino", ["--bits", "14", "--step-zero", "0"])):
        by_serial, by_file = tmp_path / f"serial.{fmt}", tmp_path / f"file.{fmt}"
        assert main(["export", "--serial", "SN2", "--store", str(store), "--format", fmt, *extra,
                     "-o", str(by_serial)]) == 0
        assert main(["export", str(tmp_path / "SN2.json"), "--format", fmt, *extra, "-o", str(by_file)]) == 0
        assert by_serial.read_bytes() == by_file.read_bytes()

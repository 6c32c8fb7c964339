"""encal.cli._serial: ``--serial S --store DB`` of ``encal correct`` and ``encal export``, and the stores read."""

import pytest

from encal.cli import main


@pytest.mark.parametrize("argv", [
    ("correct", "--serial", "SN1", "--store", "{store}", "-"),
    ("export", "--serial", "SN1", "--store", "{store}", "--format", "table", "--bits", "12", "-o", "{folder}/t.bin"),
    ("fleet", "report", "--store", "{store}", "-o", "{folder}/fleet.html"),
])
def test_an_empty_file_as_the_store_to_read_is_refused_and_left_empty(tmp_path, capsys, argv, monkeypatch):
    # fuzz6: an empty file is an empty SQLite database; opening it wrote a store's tables into the input (28 kB)
    # and then said the serial number had no record
    import io

    store = tmp_path / "touched.sqlite"
    store.write_bytes(b"")
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(b"10\n")))
    assert main([part.format(store=store, folder=tmp_path) for part in argv]) == 1
    err = capsys.readouterr().err
    assert f"--store {store}: an empty file; expected a store written by 'encal fleet fit'" in err
    assert store.stat().st_size == 0
    assert not (tmp_path / "t.bin").exists() and not (tmp_path / "fleet.html").exists()


def test_a_folder_as_the_store_to_read_is_named_a_folder(tmp_path, capsys):
    assert main(["export", "--serial", "SN1", "--store", str(tmp_path), "--format", "table", "--bits", "12", "-o",
                 str(tmp_path / "t.bin")]) == 1
    assert f"--store {tmp_path}: a folder; expected a store written by 'encal fleet fit'" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [
    ["fleet", "report", "--store", "{store}", "-o", "{output}"],
    ["export", "--serial", "SN1", "--store", "{store}", "--format", "table", "--bits", "12", "-o", "{output}"],
    ["export", "--serial", "SN1", "--store", "{store}", "--format", "c", "--name", "s", "-o", "{folder}"],
])
@pytest.mark.parametrize("output", ["s.sqlite", "./s.sqlite", "link.html"])
def test_an_output_is_never_written_over_the_store(tmp_path, capsys, monkeypatch, argv, output):
    """fleet8: 'encal fleet report --store s.sqlite -o s.sqlite' replaced every record of the store with the page
    (exit 0), and 'export --serial' with its table; by another path or through a link as well."""
    from encal.models.fourier import FourierModel
    from encal.models.modelfile import dumps, model_to_dict
    from encal.store import open_store

    monkeypatch.chdir(tmp_path)
    store = tmp_path / ("s.h" if "c" in argv else "s.sqlite")
    with open_store(store) as opened:
        for serial in ("SN1", "SN2", "SN3"):
            opened.add(serial, dumps(model_to_dict(FourierModel([0, 1], [0.0, 1.0], [0.0, 0.5]))))
    (tmp_path / "link.html").symlink_to(store)
    before = store.read_bytes()
    names = {"store": store.name, "output": store.name if output == "s.sqlite" else output, "folder": "."}
    if output == "./s.sqlite":
        names["output"] = f"./{store.name}"
    assert main([part.format(**names) for part in argv]) == 1
    assert "is the same file as the calibration store" in capsys.readouterr().err
    assert store.read_bytes() == before

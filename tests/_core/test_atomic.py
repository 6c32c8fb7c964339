"""Whole-or-nothing writes: single files and sets of files (encal._core.atomic)."""

import os
import signal
import stat

import pytest

import encal._core.atomic as atomic
from encal._core.atomic import atomic_file_set, atomic_write, staged_path
from encal.cli import main
from encal._core.errors import InputError


class _Boom(Exception):
    pass


def _leftovers(folder):
    return sorted(p.name for p in folder.rglob("*.tmp"))


def test_a_set_renames_every_file_at_its_end(tmp_path):
    first, second = tmp_path / "a.txt", tmp_path / "b.txt"
    with atomic_file_set():
        atomic_write(first, "one")
        assert not first.exists()
        assert staged_path(first).read_text() == "one"
        atomic_write(second, "two")
    assert first.read_text() == "one" and second.read_text() == "two"
    assert staged_path(first) == first
    assert _leftovers(tmp_path) == []


def test_a_failed_set_writes_nothing_and_keeps_the_old_files(tmp_path):
    first, second = tmp_path / "a.txt", tmp_path / "b.txt"
    first.write_text("old a")
    with pytest.raises(_Boom):
        with atomic_file_set():
            atomic_write(first, "new a")
            atomic_write(second, "new b")
            raise _Boom
    assert first.read_text() == "old a" and not second.exists()
    assert _leftovers(tmp_path) == []


def test_an_inner_set_joins_the_outer_one(tmp_path):
    path = tmp_path / "a.txt"
    with pytest.raises(_Boom):
        with atomic_file_set():
            with atomic_file_set():
                atomic_write(path, "inner")
            assert not path.exists()
            raise _Boom
    assert not path.exists() and _leftovers(tmp_path) == []


def test_writing_one_path_twice_keeps_the_last(tmp_path):
    path = tmp_path / "a.txt"
    with atomic_file_set():
        atomic_write(path, "first")
        atomic_write(path, "second")
        assert staged_path(path).read_text() == "second"
    assert path.read_text() == "second" and _leftovers(tmp_path) == []


def _fail_on_nth_rename(monkeypatch, n):
    """Make the n-th (1-based) os.replace of encal._core.atomic raise OSError."""
    real = os.replace
    count = iter(range(1, 10**6))

    def failing(source, destination):
        if next(count) == n:
            raise PermissionError(13, "Permission denied")
        return real(source, destination)

    monkeypatch.setattr(atomic.os, "replace", failing)


@pytest.mark.parametrize("failing", [1, 2, 3, 4])
def test_a_rename_failing_part_way_through_a_set_puts_every_old_file_back(tmp_path, monkeypatch, failing):
    files = {name: tmp_path / name for name in ("a.txt", "b.txt", "c.txt", "d.txt")}
    files["a.txt"].write_text("old a")
    files["c.txt"].write_text("old c")
    os.symlink(files["c.txt"], tmp_path / "link-to-c")
    _fail_on_nth_rename(monkeypatch, failing)
    with pytest.raises(PermissionError):
        with atomic_file_set():
            for name in ("a.txt", "b.txt"):
                atomic_write(files[name], f"new {name[0]}")
            atomic_write(tmp_path / "link-to-c", "new c")
            atomic_write(files["d.txt"], "new d")
            atomic_write(files["a.txt"], "newer a")
    assert files["a.txt"].read_text() == "old a" and files["c.txt"].read_text() == "old c"
    assert not files["b.txt"].exists() and not files["d.txt"].exists()
    assert os.readlink(tmp_path / "link-to-c") == str(files["c.txt"])
    assert _leftovers(tmp_path) == []


def test_a_set_over_old_files_leaves_no_second_name(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("old")
    with atomic_file_set():
        atomic_write(path, "new")
    assert path.read_text() == "new" and sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_a_set_keeps_old_files_by_copy_where_hard_links_are_refused(tmp_path, monkeypatch):
    def no_links(source, destination):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(atomic.os, "link", no_links)
    (tmp_path / "a.txt").write_text("old a")
    _fail_on_nth_rename(monkeypatch, 2)
    with pytest.raises(PermissionError):
        with atomic_file_set():
            atomic_write(tmp_path / "a.txt", "new a")
            atomic_write(tmp_path / "b.txt", "new b")
    assert (tmp_path / "a.txt").read_text() == "old a" and not (tmp_path / "b.txt").exists()
    assert _leftovers(tmp_path) == []


def _fail_on_nth_write(monkeypatch, n):
    """Make the n-th (1-based) atomic_write of the process raise OSError."""
    real = atomic.atomic_open
    count = iter(range(1, 10**6))

    def failing(path, *args, **kwargs):
        if next(count) == n:
            raise OSError(28, "No space left on device")
        return real(path, *args, **kwargs)

    monkeypatch.setattr(atomic, "atomic_open", failing)


def test_simulate_failing_part_way_leaves_the_old_fleet(tmp_path, monkeypatch, capsys):
    out = tmp_path / "fleet"
    assert main(["simulate", "--encoders", "1", "--out", str(out)]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert len(before) == 4
    _fail_on_nth_write(monkeypatch, 3)
    assert main(["simulate", "--encoders", "2", "--seed", "7", "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "No space left" in err[0]
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert _leftovers(tmp_path) == []


def test_c_export_failing_on_the_source_leaves_no_header(tmp_path, monkeypatch, capsys):
    model = tmp_path / "m.json"
    cal = tmp_path / "cal.csv"
    cal.write_text("reference_deg,encoder_deg\n" + "".join(f"{k * 10.0},{k * 10.0 + 0.01 * (k % 3)}\n"
                                                           for k in range(36)))
    assert main(["fit", str(cal), "--method", "fourier", "-o", str(model)]) == 0
    _fail_on_nth_write(monkeypatch, 2)
    target = tmp_path / "c"
    assert main(["export", str(model), "--format", "c", "--bits", "16", "-o", str(target)]) == 1
    assert "No space left" in capsys.readouterr().err
    assert list(target.iterdir()) == [] and _leftovers(tmp_path) == []


def test_a_symbolic_link_is_written_through(tmp_path):
    target = tmp_path / "target.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    atomic_write(link, "new")
    assert link.is_symlink() and target.read_text() == "new"
    with atomic_file_set():
        atomic_write(link, "newer")
        assert staged_path(link).read_text() == "newer"
    assert link.is_symlink() and target.read_text() == "newer"


def test_a_pipe_or_device_is_not_replaced(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match=r"cannot write .*fifo: it is not a regular file \(a device, pipe or "
                                         r"socket\); expected the path of a file"):
        atomic_write(fifo, "data")
    assert stat.S_ISFIFO(fifo.lstat().st_mode)
    assert [p.name for p in tmp_path.iterdir()] == ["fifo"]
    with pytest.raises(InputError, match="not a regular file"):
        atomic_write("/dev/null", "data")
    assert stat.S_ISCHR(os.lstat("/dev/null").st_mode)


def test_a_folder_that_cannot_be_written_is_named_not_the_temporary_file(tmp_path):
    with pytest.raises(InputError) as info:
        atomic_write("/proc/encal-model.json", "data")
    message = str(info.value)
    assert message.startswith("cannot write /proc/encal-model.json: ") and ".tmp" not in message


def test_sigterm_part_way_cleans_up_like_ctrl_c(tmp_path, monkeypatch, capsys):
    # SIGTERM (kill, timeout, a CI runner) arriving during the third file of a set: exit 143, no new file,
    # no temporary file, the old files intact.
    out = tmp_path / "fleet"
    assert main(["simulate", "--encoders", "1", "--out", str(out)]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    real = atomic.atomic_open
    count = iter(range(1, 10**6))

    def terminated(path, *args, **kwargs):
        if next(count) == 3:
            os.kill(os.getpid(), signal.SIGTERM)
        return real(path, *args, **kwargs)

    monkeypatch.setattr(atomic, "atomic_open", terminated)
    assert main(["simulate", "--encoders", "2", "--seed", "7", "--out", str(out)]) == 143
    assert capsys.readouterr().err.strip().splitlines()[-1] == "encal simulate: terminated"
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert _leftovers(tmp_path) == []
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


@pytest.mark.parametrize("length", [240, 250, 255])
def test_a_legal_long_name_is_written(tmp_path, length):
    """The temporary file's name adds 13 characters: a 250-character name was refused as if the folder
    could not be written (issue 17, item 15)."""
    path = tmp_path / ("m" * (length - 5) + ".json")
    atomic_write(path, "{}\n")
    assert path.read_text() == "{}\n" and sorted(p.name for p in tmp_path.iterdir()) == [path.name]


def test_a_long_name_of_multibyte_characters_is_written(tmp_path):
    path = tmp_path / ("é" * 125 + ".csv")  # 254 bytes
    atomic_write(path, "x\n")
    assert path.read_text() == "x\n"


def test_a_name_too_long_is_refused_with_the_right_reason(tmp_path):
    path = tmp_path / ("m" * 256)
    with pytest.raises(InputError, match="its name is 256 bytes long; expected at most 255"):
        atomic_write(path, "x")
    assert list(tmp_path.iterdir()) == []


def test_write_file_set_writes_every_file_or_none(tmp_path):
    folder = tmp_path / "new" / "folder"
    paths = atomic.write_file_set(folder, {"a.h": "header\n", "a.c": b"source\n"})
    assert paths == [folder / "a.h", folder / "a.c"]
    assert (folder / "a.h").read_text() == "header\n" and (folder / "a.c").read_bytes() == b"source\n"

    with pytest.raises(TypeError):  # the second file fails while it is written, before any rename
        atomic.write_file_set(tmp_path / "other", {"b.h": "1\n", "b.c": 3})
    assert sorted(p.name for p in (tmp_path / "other").iterdir()) == []

"""Write files whole or not at all.

A file is written to a temporary file in the destination folder and then
renamed over the destination, so a reader never sees half a file and a
failure never leaves one behind.

A command that writes several files (``encal simulate``, ``encal demo``,
``encal export c``) wraps its writes in :func:`atomic_file_set`: every file is
written to its temporary file first and the renames happen together at the
end, so a failure part-way leaves none of the new files and every old one.
"""

import contextlib
import contextvars
import os
import secrets
import shutil
import tempfile
from pathlib import Path

from .signals import held
from .errors import InputError

__all__ = ["atomic_write", "atomic_open", "atomic_file_set", "write_file_set", "staged_path", "check_name_length"]

#: (temporary path, destination) pairs of the innermost open file set, or None.
_PENDING = contextvars.ContextVar("encal_pending_renames", default=None)


@contextlib.contextmanager
def atomic_file_set():
    """Defer the renames of every :func:`atomic_open` in the block to its successful end.

    On success the temporary files replace their destinations in the order
    they were written; on any exception they are deleted and no destination
    is touched. Sets nest: an inner set joins the outer one.
    """
    if _PENDING.get() is not None:
        yield
        return
    pending = []
    token = _PENDING.set(pending)
    try:
        yield
    except BaseException:
        with held():
            for tmp, _ in pending:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(tmp)
        raise
    else:
        # A stop signal during the renames is held until they are all done: all new files or, above, none.
        with held():
            _replace_all(pending)
    finally:
        _PENDING.reset(token)


def _replace_all(pending):
    """Rename every temporary file over its destination; if one rename fails, undo the others.

    Each destination that exists is kept under a second name (a hard link, or a copy where the file
    system has none) until every rename has succeeded, so a failure part-way (a permission
    changed, a file system gone, a destination made a folder meanwhile) puts every old file back,
    removes every new one and leaves no temporary file.
    """
    kept = {}  # destination -> its old content's second name, or None when it did not exist
    done = 0
    try:
        for tmp, path in pending:
            if path not in kept:
                kept[path] = _keep(path)
            os.replace(tmp, path)
            done += 1
    except BaseException:
        for tmp, _ in pending[done:]:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
        for path, old in kept.items():
            if old is not None:
                os.replace(old, path)
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(old)  # still there when ``path`` was never replaced: rename between two links is a no-op
            else:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(path)
        raise
    for old in kept.values():
        if old is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(old)


def _keep(path):
    """A second name for the file at ``path`` in its folder, or None when there is no file there."""
    if not os.path.lexists(path):
        return None
    folder = path.parent if str(path.parent) else Path(".")
    prefix = f".{_shortened(path.name, _longest_name(folder) - 22)}."
    while True:
        old = folder / f"{prefix}{secrets.token_hex(4)}.old.tmp"
        try:
            os.link(path, old)
        except FileExistsError:
            continue
        except OSError:  # a file system without hard links
            shutil.copy2(path, old)
        return old


def _destination(path):
    """The file a write to ``path`` replaces: the target of a symbolic link, else ``path`` itself."""
    path = Path(path)
    return Path(os.path.realpath(path)) if path.is_symlink() else path


def staged_path(path):
    """Where the content written for ``path`` is now: its temporary file while a set defers its rename.

    Lets a command read back a file it wrote inside :func:`atomic_file_set`
    (``encal demo`` reloads each saved model to check it).
    """
    path = _destination(path)
    for tmp, destination in reversed(_PENDING.get() or ()):
        if destination == path:
            return Path(tmp)
    return path


@contextlib.contextmanager
def atomic_open(path, mode="w", encoding="utf-8", newline=None):
    """Open a temporary file that replaces ``path`` when the block succeeds.

    Parameters
    ----------
    path : str or os.PathLike
        Destination. Its folder must exist.
    mode : {'w', 'wb'}, default='w'
        Text or binary.

    Raises
    ------
    InputError
        If the destination folder does not exist or cannot be written, the destination is a folder
        or not a regular file (a device, pipe or socket), or writing fails (the disk is full).

    Notes
    -----
    A symbolic link is followed: the file it points to is replaced, and the link stays.
    """
    if isinstance(path, bool) or not (isinstance(path, (str, bytes)) or hasattr(type(path), "__fspath__")):
        shown = repr(path) if len(repr(path)) <= 60 else repr(path)[:57] + "..."
        raise InputError(f"cannot write to {shown}: expected the path of a file (a str or os.PathLike)")
    given = Path(os.fsdecode(path))
    check_name_length(given)
    path = _destination(given)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(
            f"cannot write {given}: the folder {folder} does not exist"
        )
    if path.is_dir():
        raise InputError(f"cannot write {given}: it is a folder; expected the path of a file")
    if path.exists() and not path.is_file():
        # Renaming over /dev/null or a pipe would replace it with a regular file.
        raise InputError(f"cannot write {given}: it is not a regular file (a device, pipe or socket); "
                         "expected the path of a file")
    longest = _longest_name(folder)
    tmp = None
    try:
        # Held: a stop signal right after the file is created must find its name known, to remove it.
        with held():
            fd, tmp = tempfile.mkstemp(prefix=f".{_shortened(path.name, longest - 16)}.", suffix=".tmp",
                                       dir=folder)
        kwargs = {} if "b" in mode else {"encoding": encoding, "newline": newline}
        with os.fdopen(fd, mode, **kwargs) as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp, 0o644)
        pending = _PENDING.get()
        if pending is None:
            os.replace(tmp, path)
        else:
            pending.append((tmp, path))
    except OSError as exc:
        if tmp is None:
            raise InputError(f"cannot write {given}: {exc.strerror or exc}; expected a folder where files "
                             "can be written") from None
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise InputError(f"cannot write {given}: {exc.strerror or exc}") from None
    except BaseException:
        if tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
        raise


def check_name_length(path):
    """Refuse, with :class:`InputError`, a file name longer than its file system holds."""
    folder = path.parent if str(path.parent) else Path(".")
    longest = _longest_name(folder if folder.is_dir() else Path("."))
    size = len(os.fsencode(path.name))
    if size > longest:
        raise InputError(f"cannot write {path}: its name is {size} bytes long; expected at most {longest}, the "
                         "longest file name the file system holds")


def _longest_name(folder):
    """The longest file name, in bytes, that ``folder``'s file system holds (255 when it does not say)."""
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        return 255


def _shortened(name, limit):
    """``name`` cut to at most ``limit`` bytes (whole characters), for the temporary file's name.

    The temporary name adds a dot, eight random characters and ``.tmp`` to it: a legal name of 250
    bytes would otherwise make an illegal temporary name, refused with the wrong reason.
    """
    encoded = os.fsencode(name)
    if len(encoded) <= limit:
        return name
    return encoded[:max(limit, 1)].decode("utf-8", "ignore") or "encal"  # a cut character is dropped


def atomic_write(path, data):
    """Write ``data`` (str or bytes) to ``path`` atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Destination. Its folder must exist.
    data : str or bytes
        Content; text is written as UTF-8 with ``\\n`` line ends.
    """
    mode = "wb" if isinstance(data, (bytes, bytearray)) else "w"
    with atomic_open(path, mode, newline="\n" if mode == "w" else None) as handle:
        handle.write(data)


def write_file_set(directory, files):
    """Write several files into ``directory`` as one set: all of them, or none.

    Parameters
    ----------
    directory : str or os.PathLike
        Destination folder; created when missing.
    files : dict of str to (str or bytes)
        File name -> content, as :func:`atomic_write` takes it.

    Returns
    -------
    list of pathlib.Path
        The paths written, in the order of ``files``.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = [directory / name for name in files]
    with atomic_file_set():
        for path, data in zip(paths, files.values()):
            atomic_write(path, data)
    return paths

"""Write files whole or not at all.

A file is written to a temporary file in the destination folder and then
renamed over the destination, so a reader never sees half a file and a
failure never leaves one behind.
"""

import contextlib
import os
import tempfile
from pathlib import Path

from .errors import InputError

__all__ = ["atomic_write", "atomic_open"]


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
        If the destination folder does not exist, or the destination is a folder.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(
            f"cannot write {path}: the folder {folder} does not exist"
        )
    if path.is_dir():
        raise InputError(f"cannot write {path}: it is a folder; expected the path of a file")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    try:
        kwargs = {} if "b" in mode else {"encoding": encoding, "newline": newline}
        with os.fdopen(fd, mode, **kwargs) as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


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

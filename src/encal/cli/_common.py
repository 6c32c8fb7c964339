"""Helpers shared by the command modules."""

import contextlib
import json
import os
import sys
import warnings

from .._core.errors import EncalWarning
from .._core.number_cells import not_plain_note, read_whole

__all__ = ["add_calibration_options", "add_target_tolerance_option", "add_zero_options", "read_calibration_from_args",
           "positive_int", "print_json", "warnings_as_lines", "check_environment", "output_that_may_close", "activity",
           "check_paths"]


def add_calibration_options(parser):
    """The options every command that reads a calibration CSV accepts."""
    parser.add_argument("--allow-gaps", action="store_true",
                        help="accept a calibration with a coverage gap over 30 degrees")
    parser.add_argument("--reverse", action="store_true",
                        help="the encoder counts against the reference: negate its angles")
    duplicates = parser.add_mutually_exclusive_group()
    duplicates.add_argument("--average-duplicates", dest="duplicates", action="store_const", const="average",
                            default="refuse", help="average repeated reference angles instead of refusing them")
    duplicates.add_argument("--keep-duplicates", dest="duplicates", action="store_const", const="keep",
                            help="keep repeated reference angles as repeated readings of one stop (their scatter "
                                 "is the noise of one reading); a file with the same number of readings at every "
                                 "angle, or a log of several turns, is read so without it")
    parser.add_argument("--ref-col", metavar="NAME", default="reference_deg",
                        help="the reference column: its header name or number from 1 (default reference_deg)")
    parser.add_argument("--enc-col", metavar="NAME", default="encoder_deg",
                        help="the encoder column: its header name or number from 1 (default encoder_deg)")
    parser.add_argument("--ref-unit", metavar="UNIT", type=angle_unit_argument, default=None,
                        help="unit of the reference column: deg (default), rad, rev or counts:B")
    parser.add_argument("--enc-unit", metavar="UNIT", type=angle_unit_argument, default=None,
                        help="unit of the encoder column: deg (default), rad, rev or counts:B (B bits)")
    parser.add_argument("--unit", metavar="UNIT", type=angle_unit_argument, default=None,
                        help="unit of both columns, unless --ref-unit or --enc-unit says otherwise")


def add_target_tolerance_option(parser):
    """``--target-tolerance DEG``: reference angles this close to a neighbour are one ISO 230-2 target."""
    from ..data.calibration import MAX_TARGET_TOLERANCE_DEG

    def parse(text):
        import argparse

        from .._core.number_cells import read_number

        try:
            value = read_number(text)
        except ValueError:
            value = float("nan")
        if not 0.0 < value <= MAX_TARGET_TOLERANCE_DEG:
            raise argparse.ArgumentTypeError(f"expected degrees greater than 0 and at most "
                                             f"{MAX_TARGET_TOLERANCE_DEG:g}, got {text!r}")
        return value

    parse.__name__ = "float"  # argparse names the type in its messages
    parser.add_argument("--target-tolerance", type=parse, metavar="DEG", dest="target_tolerance",
                        help="a bidirectional run whose reference is read afresh at every approach: reference "
                             "angles within DEG of a neighbour are one target position (ISO 230-2; default: the "
                             "same angle written twice, 1e-6 degree)")


def angle_unit_argument(text):
    """argparse type: a unit of angle readings (deg, rad, rev or counts:B)."""
    import argparse

    from .._core.angles import angle_unit

    try:
        return angle_unit(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_zero_options(parser):
    """``--zero auto|arbitrary|fixed`` (and ``--arbitrary-zero``): how the reference's zero is treated."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--zero", choices=("auto", "arbitrary", "fixed"), default="auto",
                       help="the reference's zero: 'arbitrary' (a motor, a stepper) states the zero offset "
                            "apart and gives the statistics of the shape about it; 'fixed' (a rotary table) "
                            "counts it as error; 'auto' (default) takes it as arbitrary when the offset "
                            "exceeds 1 degree, and says what it did")
    group.add_argument("--arbitrary-zero", dest="zero", action="store_const", const="arbitrary",
                       help="same as --zero arbitrary")


def activity(command, enabled=True):
    """The progress line of a command that may run long on a dense calibration (:class:`encal._core.progress.Activity`):
    on a terminal from 2 seconds on, elsewhere one closing line for runs of 10 seconds or more."""
    from .._core.progress import Activity

    return Activity(f"encal {command}", enabled=enabled)


def read_calibration_from_args(path, args, progress=None, *, targets=False):
    """Read ``path`` with the options of :func:`add_calibration_options`; ``progress`` (an
    :func:`activity`) shows the reading as a stage of its own; with ``targets``, the option of
    :func:`add_target_tolerance_option` too (the calibration a model is fitted on, not a test file)."""
    from ..data.calibration import read_calibration

    reference = getattr(args, "ref_col", "reference_deg")
    encoder = getattr(args, "enc_col", "encoder_deg")
    if str(reference).strip().lower() == str(encoder).strip().lower() and getattr(args, "_parser", None):
        args._parser.error(f"--ref-col {reference} and --enc-col {encoder} name the same column; expected "
                           "the reference and the encoder in two different columns")
    if progress is not None:
        progress.stage(f"reading {path}")
    cal = read_calibration(
        path,
        progress=None if progress is None else progress.update,
        allow_gaps=getattr(args, "allow_gaps", False),
        reverse=getattr(args, "reverse", False),
        duplicates=getattr(args, "duplicates", "refuse"),
        resolution_bits=getattr(args, "bits", None),
        reference_column=getattr(args, "ref_col", "reference_deg"),
        encoder_column=getattr(args, "enc_col", "encoder_deg"),
        reference_unit=getattr(args, "ref_unit", None) or getattr(args, "unit", None) or "deg",
        encoder_unit=getattr(args, "enc_unit", None) or getattr(args, "unit", None) or "deg",
        target_tolerance_deg=getattr(args, "target_tolerance", None) if targets else None,
    )
    if cal.target_tolerance_deg is not None:
        _check_both_directions(cal, path)
    return cal


def _check_both_directions(cal, path):
    """Refuse ``--target-tolerance`` for a calibration of one direction of travel (it matches nothing there)."""
    from .._core.errors import InputError
    from ..data.reversal import has_both_directions

    if not has_both_directions(cal):
        raise InputError(f"{path}: --target-tolerance matches the targets of a run in both directions of travel, "
                         "but this calibration has readings of one direction only; expected a direction column "
                         "holding +1 and -1 (or leave out --target-tolerance)")


def int_in_range(low, high=None):
    """argparse type: a whole number in [low, high] (no upper bound when ``high`` is None)."""
    import argparse

    expected = f"a whole number >= {low}" if high is None else f"a whole number from {low} to {high}"

    def parse(text):
        try:
            value = read_whole(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}{not_plain_note(text)}") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"expected {expected}, got {value}")
        return value

    parse.__name__ = "int"  # argparse names the type in its messages
    return parse


def size_option(name, low=1):
    """argparse type of a size option: a whole number from ``low`` to its bound in
    :data:`encal._core.limits.SIZE_LIMITS`."""
    import argparse

    from .._core.limits import size_message

    def parse(text):
        try:
            value = read_whole(text)
        except ValueError:
            raise argparse.ArgumentTypeError(size_message(name, low, repr(text)) + not_plain_note(text)) from None
        try:
            from .._core.limits import check_size

            return check_size(name, value, "encal", low)
        except ValueError:
            raise argparse.ArgumentTypeError(size_message(name, low, value)) from None

    parse.__name__ = "int"
    return parse


#: argparse types: an int >= 1, an int >= 0
positive_int = int_in_range(1)
nonnegative_int = int_in_range(0)


def print_json(data, stream=None):
    """Print one JSON object on one line."""
    stream = stream or sys.stdout
    stream.write(json.dumps(data, allow_nan=False) + "\n")


@contextlib.contextmanager
def warnings_as_lines(command, stream=None):
    """Print every :class:`~encal._core.errors.EncalWarning` raised in the block as one line on stderr.

    The line reads ``encal COMMAND: warning: <message>``; other warnings are shown as Python shows them.
    """
    stream = stream or sys.stderr
    with warnings.catch_warnings():
        warnings.simplefilter("always", EncalWarning)
        shown = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if stream is None:  # stderr closed: print(file=None) would write into the data on stdout
                return
            if issubclass(category, EncalWarning):
                from .._core.progress import clear_line

                clear_line()  # a progress line on the terminal: the warning takes its place, the line comes back
                print(f"encal {command}: warning: {message}", file=stream)
            else:
                shown(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield


def check_environment():
    """Refuse, in one sentence, environment variables that would make a command fail or write wrong data.

    ``SOURCE_DATE_EPOCH`` is checked before anything reads it (SciPy's import reads it, and a malformed
    value stopped every command with a traceback).
    """
    from .._core.environment import source_date_epoch

    source_date_epoch()


class _ForgivingStdout:
    """Standard output that stops writing, without failing, once its reader has gone away.

    Used for commands whose product is files (``demo``, ``study --out``, ``fit``): a reader that
    stops early (``encal demo | head``) must not stop the work half-way. ``encal correct``, whose
    product is stdout, writes to ``sys.stdout.buffer`` and stops at a broken pipe itself.
    """

    def __init__(self, stream):
        self._stream = stream
        self.broken = False

    def write(self, text):
        if not self.broken:
            try:
                return self._stream.write(text)
            except BrokenPipeError:
                self._discard()
        return len(text)

    def flush(self):
        if not self.broken:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._discard()

    def _discard(self):
        self.broken = True
        # What is still buffered would fail again when Python flushes stdout at exit.
        with contextlib.suppress(OSError, ValueError, AttributeError):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
            os.close(devnull)

    def __getattr__(self, name):
        return getattr(self._stream, name)


@contextlib.contextmanager
def output_that_may_close(command):
    """Run a command with a standard output whose early closing does not stop it (except ``correct``)."""
    if command == "correct" or sys.stdout is None:
        yield
        return
    original = sys.stdout
    sys.stdout = _ForgivingStdout(original)
    try:
        yield
        sys.stdout.flush()
    finally:
        sys.stdout = original


#: What ``check_paths`` says an input of each kind is: (what is expected, what writing over it would destroy).
INPUT_KINDS = {
    "calibration": ("a calibration CSV", "input calibration"),
    "model": ("a model file", "model file"),
    "firmware": ("the firmware's file", "firmware's file"),
    "capture": ("a capture or log", "input capture"),
    "angles": ("a file of encoder angles", "input"),
    "store": ("a calibration store written by 'encal fleet fit'", "calibration store"),
}


def _identity(path):
    """What identifies the file a write to ``path`` would replace: (device, inode) when it exists (links
    followed, as :func:`encal._core.atomic.atomic_open` follows them), else its absolute path with links resolved."""
    try:
        status = os.stat(path)
    except (OSError, ValueError):
        return ("path", os.path.realpath(path))
    return ("file", status.st_dev, status.st_ino)


def _check_input(path, kind):
    """Refuse an input that is missing, a folder or unreadable, in one sentence (before any work)."""
    import stat

    from .._core.errors import InputError

    expected = INPUT_KINDS[kind][0]
    try:
        status = os.stat(path)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file; expected {expected}") from None
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: cannot be read ({getattr(exc, 'strerror', None) or exc}); expected "
                         f"{expected}") from None
    if stat.S_ISDIR(status.st_mode):
        raise InputError(f"{path}: is a folder; expected {expected}")
    if stat.S_ISREG(status.st_mode):  # a pipe or a device is not opened here: opening may block or act
        try:
            with open(path, "rb"):
                pass
        except OSError as exc:
            raise InputError(f"{path}: cannot be read ({exc.strerror or exc}); expected {expected}") from None


def check_paths(inputs=(), outputs=(), folders=()):
    """Refuse, before any work, paths that cannot be read or written, and any output that is an input.

    Every command that reads or writes files calls this first, so that a refusal costs nothing and
    destroys nothing: writing over an input (``encal fit A.csv --repeat R.csv -o R.csv``) would
    replace it, and with exit status 0. Files are compared, not names: a symbolic or hard link to an
    input, or the same file by another path, is the input.

    Parameters
    ----------
    inputs : iterable of (str, str)
        ``(path, kind)`` of every file read, ``kind`` a key of :data:`INPUT_KINDS`; ``'-'`` (standard
        input) and None are skipped. Each must exist, be no folder, and (a regular file) open for reading;
        no file may be given twice.
    outputs : iterable of (str, str)
        ``(option, path)`` of every file written, ``option`` as the user gave it (``'-o'``). Its folder
        must exist; it must not be a folder, nor the same file as an input or another output.
    folders : iterable of (str, str, iterable of str)
        ``(option, folder, names)`` of a folder written into (created when missing): it must not be a
        file, and none of ``folder/name`` the same file as an input or an output.

    Raises
    ------
    InputError
        The first problem found, in one sentence (exit status 1).
    """
    from pathlib import Path

    from .._core.atomic import check_name_length
    from .._core.errors import InputError

    inputs = [(str(path), kind) for path, kind in inputs if path is not None and str(path) != "-"]
    for path, kind in inputs:
        _check_input(path, kind)
    written = []  # (what the user named, path)
    for option, path in outputs:
        if path is None:
            continue
        path = Path(path)
        check_name_length(path)
        folder = path.parent if str(path.parent) else Path(".")
        if not folder.is_dir():
            raise InputError(f"cannot write {option} {path}: the folder {folder} does not exist; expected the "
                             "path of a file in an existing folder")
        if path.is_dir():
            raise InputError(f"cannot write {option} {path}: it is a folder; expected the path of a file")
        if path.exists() and not path.is_file():  # as encal._core.atomic refuses it, but before the work
            raise InputError(f"cannot write {option} {path}: it is not a regular file (a device, pipe or socket); "
                             "expected the path of a file")
        written.append((f"{option} {path}", path))
    for option, folder, names in folders:
        if folder is None:
            continue
        folder = Path(folder)
        if folder.exists() and not folder.is_dir():
            raise InputError(f"cannot write into {option} {folder}: it is a file; expected a folder")
        written += [(f"{option} {folder} (its {name})", folder / name) for name in names]
    identities = {}  # identity -> how a message names that file
    for path, kind in inputs:
        identity = _identity(path)
        if identity in identities:
            # fit --repeat A.csv on A.csv took the noise from readings that were not repeats: 1.5e-7 arcmin
            raise InputError(f"{path} is the same file as {identities[identity]}: the same input given twice; "
                             "expected different files (a second pass, a held-out or a later calibration is "
                             "another measurement)")
        identities[identity] = f"the {INPUT_KINDS[kind][1]} {path}"
    for what, path in written:
        identity = _identity(path)
        if identity in identities:
            raise InputError(f"{what} is the same file as {identities[identity]}; expected another path for "
                             "the output, since writing it would replace that file")
        identities[identity] = f"the output {what}"

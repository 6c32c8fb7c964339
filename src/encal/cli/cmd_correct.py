"""Correct encoder angles with a model file, streaming.

Reads encoder angles in degrees, one per line, or a CSV file whose header names
an encoder_deg column (--enc-col names another; --enc-unit reads radians, turns or
an encoder's counts, counts:B); blank lines and ``#`` comments are skipped. Writes one
corrected angle per line, in degrees in [0, 360), with 12 decimals (printf's
``%.12f`` of the library's value: within 5e-13 degrees of it); with --exact,
Python's shortest round-tripping repr (parse it as a double and you get the
library's value exactly), about half as fast.

Memory stays constant however long the input. Each block of input is answered
as soon as it is read, and a pipe that delivers one line gives one answer at
once, so encal correct can sit in a live acquisition chain:

    acquire | encal correct enc1.json | log

A malformed line stops the command with status 1 and a message naming the
line (the answers to the lines before it are already written); with
--skip-bad it gets ``nan`` and the stream goes on.
"""

import contextlib
import os
import re
import sys

from .._core import signals as _signals
from ..deploy import Compensator
from ..deploy.stream import correct_stream
from .._core.errors import InputError
from ._common import angle_unit_argument
from ._serial import add_serial_options, model_input, model_or_serial


def add_arguments(parser):
    parser.add_argument("model", metavar="MODEL.json", nargs="?",
                        help="model file written by 'encal fit' (or --serial)")
    parser.add_argument("input", metavar="FILE", nargs="?", default="-",
                        help="encoder angles in degrees, one per line, or a CSV with an "
                             "encoder_deg column; '-' (default) reads standard input")
    parser.add_argument("--enc-col", metavar="NAME", default="encoder_deg", type=_column_name,
                        help="the CSV column of the readings (default encoder_deg; any letter case)")
    parser.add_argument("--enc-unit", metavar="UNIT", type=angle_unit_argument, default="deg",
                        help="unit of the readings: deg (default), rad, rev or counts:B (codes of a B-bit encoder); "
                             "the corrected angles are written in degrees")
    parser.add_argument("--skip-bad", action="store_true",
                        help="write 'nan' for a malformed line and go on instead of stopping")
    parser.add_argument("--exact", action="store_true",
                        help="write each corrected angle as the shortest text that reads back to the same double "
                             "(default: 12 decimals, within 5e-13 degrees, faster)")
    parser.add_argument("--direction", type=int, choices=[1, -1], metavar="{+1,-1}",
                        help="direction of travel of the readings, for a bidirectional model fitted per "
                             "direction (default: each row's own direction when the CSV has a direction column, "
                             "else the mean of both directions; other models ignore it)")
    add_serial_options(parser)  # issue 32: the unit's latest model in the calibration store (FILE the one argument)
    parser.add_argument("--outside", choices=("error", "clamp", "pass"), default="error",
                        help="a reading outside the range of a model calibrated over an arc: refuse it (default), "
                             "use the correction of the nearer end of the arc (clamp), or leave it uncorrected "
                             "(pass); a full-turn model has no outside")


def _column_name(text):
    """argparse type of --enc-col: a CSV column's name (not blank)."""
    import argparse

    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected the name of a CSV column, got {text!r}")
    if text.strip().lower() == "direction":  # read as readings, +1 and -1 were corrected as 1 and -1 degrees
        raise argparse.ArgumentTypeError("expected the column of the readings; 'direction' is the direction of "
                                         "travel of each reading, which a directional model reads by itself")
    return text


def claim_extras(args, extras):
    """Take a FILE given after an option (``encal correct M.json --skip-bad FILE``, or ``-`` for standard input)."""
    if args.input == "-" and len(extras) == 1 and (extras[0] == "-" or not extras[0].startswith("-")):
        args.input = extras[0]
        return True
    return False


def run(args):
    from ._common import check_paths

    if args.serial is not None and args.model is not None and args.input == "-":
        args.model, args.input = None, args.model  # with --serial, the one argument is FILE
    check_paths(inputs=[model_input(args), (args.input, "angles")])
    compensator = Compensator(model_or_serial(args, args._parser))
    if compensator.model.range_deg is not None:  # an arc: a reading outside it follows the stated rule
        from .._core.arcs import OutsideRule

        compensator = OutsideRule(compensator, args.outside,
                                  where="reading" if args.input == "-" else f"reading of {args.input}")
    if sys.stdout is None:  # started with standard output closed (`>&-`)
        raise InputError("standard output is closed; expected somewhere to write the corrected angles")
    if args.input == "-" and sys.stdin is None:
        raise InputError("standard input is closed; expected encoder angles on it, or give a FILE")
    _check_output_is_not_an_input(args.input, args.model)
    sink = _sink(sys.stdout)
    try:
        if args.input == "-":
            correct_stream(compensator, _CheckedLines(sys.stdin.buffer, "stdin"), sink, skip_bad=args.skip_bad,
                           direction=args.direction, exact=args.exact, column=args.enc_col, unit=args.enc_unit)
        else:
            with open(args.input, "rb") as source, _file_activity(source, args.input) as counted:
                correct_stream(compensator, _CheckedLines(counted, args.input), sink, skip_bad=args.skip_bad,
                               name=args.input, direction=args.direction, exact=args.exact, column=args.enc_col,
                               unit=args.enc_unit)
    except BrokenPipeError:
        # The reader went away (`encal correct ... | head`): stop quietly, and keep
        # Python from failing again when it flushes stdout at exit.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except OSError as exc:
        if not isinstance(sink, _WholeLines) or sink.failure is not exc:  # not a failed write of the answers
            raise
        # A full disk (ENOSPC), a quota, an I/O error: _WholeLines has cut the output back to whole lines.
        done = (f"the answers to the first {sink.lines_written} angles are written whole, and nothing after them"
                if sink.lines_written else "no answer is written")
        raise InputError(f"cannot write the corrected angles to standard output ({exc.strerror or exc}); expected "
                         f"room for them: {done}") from None
    return 0


def _check_output_is_not_an_input(input_path, model_path):
    """Refuse standard output redirected into an input: the angles (``encal correct M a.txt >> a.txt``),
    whose answers would be read back as angles without end until the disk is full, or the model file."""
    import stat

    try:
        written = os.fstat(sys.stdout.fileno())
    except (AttributeError, OSError, ValueError):  # a replaced stream (a test's capture), no descriptor
        return
    if not stat.S_ISREG(written.st_mode):
        return
    inputs = {"the model file " + str(model_path): model_path,
              ("standard input" if input_path == "-" else str(input_path)): input_path}
    for name, path in inputs.items():
        try:
            read = os.fstat(sys.stdin.fileno()) if path == "-" else os.stat(path)
        except (AttributeError, OSError, ValueError):
            continue
        if (written.st_dev, written.st_ino) == (read.st_dev, read.st_ino):
            raise InputError(f"standard output is the same file as {name}; expected the corrected angles to go "
                             "to another file (writing them there would change the input as it is read)")


#: Longest input line, in bytes without its line end: bounds the memory when no line end comes.
MAX_LINE_BYTES = 1 << 16
_LONE_CR = re.compile(rb"\r(?!\n)")


class _CheckedLines:
    """The input as :func:`~encal.deploy.stream.correct_stream` reads it, checked on the way.

    - A line longer than :data:`MAX_LINE_BYTES` stops the command, once the answers to the lines before
      it are written (the stream's own check let lines of up to twice that through).
    - A CR alone ends a line (encal's CSV dialect): it is passed on as an LF, so a file with CR line
      ends is read in whole lines too (the stream saw it as one line and refused it past 64 KiB).
    - A CSV header that names a column twice (``encoder_deg,encoder_deg``) stops the command
      before any answer: the stream would read the first one, silently.
    """

    def __init__(self, source, name):
        self._read = getattr(source, "read1", source.read)
        self._name = name
        self._held = b""  # a CR that ended the last read: a line end, or the start of a CRLF
        self._line_bytes = 0  # bytes of the line being read, so far
        self._lines = 0  # line ends passed on
        self._error = None  # raised at the next read: the answers to the lines before it come first
        self._head = b""  # the unfinished line, until the first line that is not blank or a comment
        self._looking = True  # for that first line (a header, perhaps)

    def read1(self, size=-1):
        if self._error is not None:
            raise self._error
        while True:
            block = self._read(size)
            data, self._held = self._held + block, b""
            if block and data.endswith(b"\r"):
                data, self._held = data[:-1], b"\r"
            if data or not block:
                break
        if b"\r" in data:
            data = _LONE_CR.sub(b"\n", data)
        if self._looking:
            self._check_header(data, end=not block)
        return self._check_lengths(data)

    read = read1

    def _too_long(self, number):
        return InputError(f"line {number} of {self._name} is longer than {MAX_LINE_BYTES} bytes (64 KiB); expected "
                          "one encoder angle, or one CSV row, per line (is this a binary file?)")

    def _check_lengths(self, data):
        first = data.find(b"\n")
        if first < 0:
            self._line_bytes += len(data)
            if self._line_bytes > MAX_LINE_BYTES:
                raise self._too_long(self._lines + 1)
            return data
        ends_cr = first > 0 and data[first - 1] == 0x0D
        if self._line_bytes + first - ends_cr > MAX_LINE_BYTES:
            raise self._too_long(self._lines + 1)
        last = data.rfind(b"\n")
        if last - first > MAX_LINE_BYTES:  # a read longer than a line: look at every line (never with the stream's)
            for offset, line in enumerate(data[first + 1:last].split(b"\n"), start=2):
                if len(line.removesuffix(b"\r")) > MAX_LINE_BYTES:
                    raise self._too_long(self._lines + offset)
        self._lines += data.count(b"\n")
        self._line_bytes = len(data) - last - 1
        if self._line_bytes > MAX_LINE_BYTES:
            self._error = self._too_long(self._lines + 1)
            self._line_bytes = 0
            return data[:last + 1]  # the lines before the long one are answered first
        return data

    def _check_header(self, data, end):
        """Refuse a first line that is a CSV header naming a column twice (counting lines as the stream does)."""
        from .._core import csv_dialect as _csv

        text = self._head + data
        lines = text.split(b"\n")
        self._head = b"" if end else lines.pop()
        for number, line in enumerate(lines, start=self._lines + 1):
            line = line.decode("utf-8", "replace")
            if number == 1:
                line = line.removeprefix("\ufeff")
            if _csv.is_skipped(line):
                continue
            self._looking, self._head = False, b""
            try:
                names = _csv.column_names(line)
            except _csv.QuotingError:
                return  # the stream names the problem
            repeated = _csv.repeated_names(names) if "encoder_deg" in names else None
            if repeated is not None:
                raise InputError(f"line {number} of {self._name}: {repeated}")
            return


@contextlib.contextmanager
def _file_activity(source, name):
    """``source`` counted into the progress line of a long correction of a FILE (:func:`._common.activity`).

    Only when the answers go to a file or a pipe: on a terminal they are the progress, and a line drawn
    among them would garble them. Standard input is a live stream with no end to show.
    """
    from ._common import activity

    try:
        answers_on_terminal = sys.stdout.isatty()
    except (AttributeError, OSError, ValueError):
        answers_on_terminal = False
    with activity("correct", enabled=not answers_on_terminal) as progress:
        try:
            size = os.fstat(source.fileno()).st_size or None
        except (AttributeError, OSError, ValueError):
            size = None
        progress.stage(f"correcting {name}", total=size)
        yield _Counted(source, progress)


class _Counted:
    """A binary file whose reads are counted into a progress line (bytes read so far)."""

    def __init__(self, source, progress):
        self._source, self._progress, self._done = source, progress, 0

    def _count(self, data):
        self._done += len(data)
        self._progress.update(self._done)
        return data

    def read(self, *size):
        return self._count(self._source.read(*size))

    def read1(self, *size):
        return self._count(self._source.read1(*size))

    def readinto(self, buffer):
        n = self._source.readinto(buffer)
        if n:
            self._done += n
            self._progress.update(self._done)
        return n

    def __getattr__(self, name):
        return getattr(self._source, name)


def _sink(stdout):
    """Where the answers go: whole lines straight to the file descriptor when there is one."""
    try:
        descriptor = stdout.fileno()
    except (AttributeError, OSError, ValueError):  # a replaced stdout (io.StringIO, a test's capture)
        return getattr(stdout, "buffer", None) or _TextSink(stdout)
    stdout.flush()
    return _WholeLines(descriptor)


class _WholeLines:
    """Writes blocks of whole lines to a file descriptor; a stop signal never cuts a line in two.

    Ctrl-C, SIGTERM or SIGHUP during a write are held (:func:`encal._core.signals.held`): the line being
    written is finished, the rest of the block is dropped, and then the signal stops the command, so
    the output ends with a whole line (a pipe reader never sees ``0.856519`` for ``0.8565199569925398``).
    A second signal stops at once.
    """

    def __init__(self, descriptor):
        self.descriptor = descriptor
        self.lines_written = 0
        self.failure = None  # the OSError that stopped a write

    def write(self, data):
        view = memoryview(data)
        done = 0
        with _signals.held():
            start = self._offset()
            try:
                while done < len(view):
                    if _signals.pending():
                        if done == 0 or data[done - 1] == 0x0A:  # at the start of a line: stop here
                            break
                        view = view[:data.index(b"\n", done) + 1]  # finish this line only
                    done += os.write(self.descriptor, view[done:])
            except BrokenPipeError:
                raise
            except OSError as exc:
                self.failure = exc
                # A full disk took part of a line (a write may be short before it fails): cut a file back to
                # the end of the last whole line, so that no part of a number is read as an angle.
                whole = data.rfind(b"\n", 0, done) + 1
                self.lines_written += data.count(b"\n", 0, whole)
                if start is not None and whole < done:
                    with contextlib.suppress(OSError):
                        os.ftruncate(self.descriptor, start + whole)
                        os.lseek(self.descriptor, start + whole, os.SEEK_SET)
                raise
            self.lines_written += data.count(b"\n", 0, done)

    def _offset(self):
        """Where the next write lands in a regular file, or None (a pipe, a terminal, a device)."""
        import stat

        try:
            if not stat.S_ISREG(os.fstat(self.descriptor).st_mode):
                return None
            return os.lseek(self.descriptor, 0, os.SEEK_CUR)
        except OSError:
            return None

    def flush(self):
        pass


class _TextSink:
    """Bytes to a text stream (for a replaced ``sys.stdout`` without a buffer)."""

    def __init__(self, stream):
        self.stream = stream

    def write(self, data):
        self.stream.write(data.decode("ascii"))

    def flush(self):
        self.stream.flush()

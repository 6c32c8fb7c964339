"""Correct encoder angles with a model file, streaming.

Reads encoder angles in degrees, one per line, or a CSV file whose header names
an encoder_deg column; blank lines and ``#`` comments are skipped. Writes one
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
import sys

from .._core import signals as _signals
from ..deploy import Compensator
from ..deploy.stream import correct_stream
from .._core.errors import InputError


def add_arguments(parser):
    parser.add_argument("model", metavar="MODEL.json", help="model file written by 'encal fit'")
    parser.add_argument("input", metavar="FILE", nargs="?", default="-",
                        help="encoder angles in degrees, one per line, or a CSV with an "
                             "encoder_deg column; '-' (default) reads standard input")
    parser.add_argument("--skip-bad", action="store_true",
                        help="write 'nan' for a malformed line and go on instead of stopping")
    parser.add_argument("--exact", action="store_true",
                        help="write each corrected angle as the shortest text that reads back to the same double "
                             "(default: 12 decimals, within 5e-13 degrees, faster)")
    parser.add_argument("--direction", type=int, choices=[1, -1], metavar="{+1,-1}",
                        help="direction of travel of the readings, for a bidirectional model fitted per "
                             "direction (default: the mean of both directions; other models ignore it)")


def claim_extras(args, extras):
    """Take a FILE given after an option (``encal correct M.json --skip-bad FILE``)."""
    if args.input == "-" and len(extras) == 1 and not extras[0].startswith("-"):
        args.input = extras[0]
        return True
    return False


def run(args):
    compensator = Compensator(args.model)
    if sys.stdout is None:  # started with standard output closed (`>&-`)
        raise InputError("standard output is closed; expected somewhere to write the corrected angles")
    if args.input == "-" and sys.stdin is None:
        raise InputError("standard input is closed; expected encoder angles on it, or give a FILE")
    sink = _sink(sys.stdout)
    try:
        if args.input == "-":
            correct_stream(compensator, sys.stdin.buffer, sink, skip_bad=args.skip_bad,
                           direction=args.direction, exact=args.exact)
        else:
            with open(args.input, "rb") as source, _file_activity(source, args.input) as counted:
                correct_stream(compensator, counted, sink, skip_bad=args.skip_bad,
                               name=args.input, direction=args.direction, exact=args.exact)
    except BrokenPipeError:
        # The reader went away (`encal correct ... | head`): stop quietly, and keep
        # Python from failing again when it flushes stdout at exit.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 0


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

    def write(self, data):
        view = memoryview(data)
        done = 0
        with _signals.held():
            while done < len(view):
                if _signals.pending():
                    if done == 0 or data[done - 1] == 0x0A:  # at the start of a line: stop here
                        break
                    view = view[:data.index(b"\n", done) + 1]  # finish this line only
                done += os.write(self.descriptor, view[done:])

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

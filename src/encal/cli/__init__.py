"""The ``encal`` command line: a thin layer over the public API.

Each command lives in a module ``cmd_<name>.py`` of this package with
``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``; the
modules are found at start-up, so adding a command means adding a file.

Exit status: 0 on success, 1 on bad data or a failed operation (one line on
stderr, no traceback), 2 on wrong usage (argparse), 130 on Ctrl-C, 143 on
SIGTERM and 129 on SIGHUP (all clean up as a failure does; see :mod:`encal._signals`).
"""

import os

# encal's matrices are small (at most a few hundred rows): one BLAS thread per process is fastest, and a
# threaded BLAS on a busy 2-core machine was measured 100x slower (a 0.4 s fit took 98 s). This must run
# before NumPy is first imported; a user's own setting wins.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import importlib  # noqa: E402
import pkgutil  # noqa: E402
import re  # noqa: E402
import signal  # noqa: E402
import sys  # noqa: E402

from .. import _signals
from .._version import __version__
from ..errors import EncalError

__all__ = ["main"]

#: Order in ``encal --help``; commands not listed follow alphabetically.
_ORDER = ["demo", "simulate", "profile", "fit", "report", "evaluate", "correct", "export",
          "compare", "study", "drift"]


def _command_modules():
    names = [m.name[4:] for m in pkgutil.iter_modules(__path__) if m.name.startswith("cmd_")]
    names.sort(key=lambda n: (_ORDER.index(n) if n in _ORDER else len(_ORDER), n))
    return {name: importlib.import_module(f"{__name__}.cmd_{name}") for name in names}


def build_parser():
    """The argument parser with every command."""
    parser = argparse.ArgumentParser(
        prog="encal",
        description="Calibrate low-cost angle encoders and compensate their systematic error.",
    )
    parser.add_argument("--version", action="version", version=f"encal {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module in _command_modules().items():
        cmd = sub.add_parser(name, help=module.HELP, description=module.__doc__ or module.HELP,
                             formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(cmd)
        cmd.set_defaults(_run=module.run, _claim_extras=getattr(module, "claim_extras", None), _parser=cmd)
    return parser


#: A library message about a parameter: "The 'tolerance_arcmin' parameter of export_target must ...".
_PARAMETER_MESSAGE = re.compile(r"The '(\w+)' parameter of [\w.]+ (must .*)", re.DOTALL)


def _in_flag_terms(text, args):
    """A library's message about a parameter, worded with the flag the user gave for it.

    "The 'tolerance_arcmin' parameter of export_target must ..." becomes "--tolerance must ..."
    when the command has that option (its name, or the name without a unit suffix) and the user
    set it; otherwise (a value read from a file, an option left at its default) the text is kept.
    """
    match = _PARAMETER_MESSAGE.fullmatch(text)
    parser = getattr(args, "_parser", None)
    if match is None or parser is None:
        return text
    name = match.group(1)
    names = {name, name.removesuffix("_arcmin"), name.removesuffix("_deg")}
    for action in parser._actions:
        if action.option_strings and action.dest in names:
            value = getattr(args, action.dest, None)
            if value is not None and value != action.default:
                return f"{action.option_strings[-1]} {match.group(2)}"
    return text


def main(argv=None):
    """Run the command line; returns the exit status.

    Parameters
    ----------
    argv : list of str, optional
        The arguments; None reads ``sys.argv`` as the ``encal`` program does, and then a command
        stopped by Ctrl-C ends the process itself with status 130 (see the comment below).
    """
    status = _main(argv)
    if status > 128 and argv is None:
        # A signal stopped the command, which has cleaned up. End the process here rather than through
        # the interpreter's teardown, which a signal can no longer be trusted to survive:
        # - Ctrl-C caught while a library ran Python code through PyRun_String (NumPy's import does) leaves
        #   CPython's "unhandled KeyboardInterrupt" flag set, and the interpreter kills itself with SIGINT
        #   at exit instead of returning 130;
        # - a signal that cut a C extension's initialisation short can leave it half set up, and its
        #   teardown then aborts the process ("Fatal Python error: PyThreadState_Get", status -6).
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        os._exit(status)
    return status


def _main(argv):
    command = args = None
    restore = _signals.install()
    stderr = sys.stderr
    if stderr is None:
        # Started with stderr closed (`2>&-`): argparse and print(file=None) would write messages to stdout,
        # into the data. They go nowhere instead.
        sys.stderr = open(os.devnull, "w", encoding="utf-8")  # noqa: SIM115 (closed below)
    try:
        _prepare_process()
        from ._common import check_environment, output_that_may_close, warnings_as_lines

        command = _named_command(sys.argv[1:] if argv is None else argv)
        check_environment()
        parser = build_parser()
        args, extras = parser.parse_known_args(argv)
        if extras:
            # argparse binds an optional positional (`encal correct MODEL [FILE]`) before it sees later options,
            # so `encal correct M.json --skip-bad FILE` leaves FILE over; a command may claim such leftovers.
            claim = getattr(args, "_claim_extras", None)
            if claim is None or not claim(args, extras):
                parser.error(f"unrecognized arguments: {' '.join(extras)}")
        if args.command is None:
            parser.print_help(sys.stderr)
            return 2
        command = args.command
        with warnings_as_lines(command), output_that_may_close(command):
            return int(args._run(args) or 0)
    except EncalError as exc:
        _say(f"{_prefix(command)}: error: {_in_flag_terms(str(exc), args)}")
        return 1
    except BrokenPipeError:
        return 0
    except OSError as exc:
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        _say(f"{_prefix(command)}: error: {where}{exc.strerror or exc}")
        return 1
    except KeyboardInterrupt as exc:
        return _stopped(command, exc)
    except ImportError as exc:
        # A signal that lands while a C extension initialises (SciPy's, during the imports of the first
        # seconds) surfaces as "ImportError: initialization failed" caused by the signal's exception.
        interrupt = _signals.cause_of(exc)
        if interrupt is None:
            raise
        return _stopped(command, interrupt)
    finally:
        restore()
        if stderr is None:
            sys.stderr.close()
            sys.stderr = None


def _stopped(command, exc):
    """Say that a signal stopped the command; the exit status for it (128 + the signal's number)."""
    what = "interrupted" if not isinstance(exc, _signals.Terminated) else (
        "hung up" if exc.signum == getattr(signal, "SIGHUP", None) else "terminated")
    _say(f"{_prefix(command)}: {what}")
    return _signals.exit_status(exc)


def _named_command(argv):
    """The command ``argv`` names (its first word that is a command's name), or None; for messages
    given before the commands are imported."""
    names = {m.name[4:] for m in pkgutil.iter_modules(__path__) if m.name.startswith("cmd_")}
    return next((word for word in argv if isinstance(word, str) and word in names), None)


def _prefix(command):
    return "encal" if command is None else f"encal {command}"


def _say(line):
    """Print one line on stderr (never on stdout: see main)."""
    with contextlib.suppress(OSError, ValueError):
        print(line, file=sys.stderr)


def _prepare_process():
    """Make standard streams and the environment safe for any command (run before the commands are imported).

    - A standard stream the process was started without (``2>&-``) gets /dev/null, so that no file
      encal opens, nor a worker process, takes its number and receives what was meant for it.
    - Text that the streams' encoding cannot hold (``PYTHONIOENCODING=ascii``) is escaped, not fatal.
    - encal draws its figures on Matplotlib canvases for files and never opens a window, so
      ``MPLBACKEND`` cannot change its output, but an invalid one stops Matplotlib's import: it is
      replaced with ``agg`` for encal and its worker processes.
    """
    for number, mode in ((0, os.O_RDONLY), (1, os.O_WRONLY), (2, os.O_WRONLY)):
        try:
            os.fstat(number)
        except OSError:
            descriptor = os.open(os.devnull, mode)
            if descriptor != number:
                os.dup2(descriptor, number)
                os.close(descriptor)
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, ValueError, OSError):
            stream.reconfigure(errors="backslashreplace")
    if "MPLBACKEND" in os.environ:
        os.environ["MPLBACKEND"] = "agg"


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

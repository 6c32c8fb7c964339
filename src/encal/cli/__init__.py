"""The ``encal`` command line: a thin layer over the public API.

Each command lives in a module ``cmd_<name>.py`` of this package with
``add_arguments(parser)`` and ``run(args) -> int`` (its docstring is the
command's ``--help`` text), and has one line in :data:`COMMANDS`. A command's
module is imported only when that command runs (or shows its ``--help``), so
that each command starts with only the libraries it needs: adding a command
means adding its file and its line.

Exit status: 0 on success, 1 on bad data or a failed operation (one line on
stderr, no traceback), 2 on wrong usage (argparse), 130 on Ctrl-C, 143 on
SIGTERM and 129 on SIGHUP (all clean up as a failure does; see :mod:`encal._core.signals`).
"""

import os

# encal's matrices are small (at most a few hundred rows): one BLAS thread per process is fastest, and a
# threaded BLAS on a busy 2-core machine was measured 100x slower (a 0.4 s fit took 98 s). This must run
# before NumPy is first imported; a user's own setting wins.
_BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
for _variable in _BLAS_THREAD_VARIABLES:
    os.environ.setdefault(_variable, "1")
_PINNED_BEFORE_NUMPY = "numpy" not in __import__("sys").modules and all(
    os.environ[_variable] == "1" for _variable in _BLAS_THREAD_VARIABLES)

import argparse  # noqa: E402
import contextlib  # noqa: E402
import importlib  # noqa: E402
import re  # noqa: E402
import signal  # noqa: E402
import sys  # noqa: E402

from .._core import signals as _signals
from .._core import threads as _threads
from .._version import __version__
from .._core.errors import EncalError
from .._core.number_cells import plain_option

__all__ = ["main"]

if _PINNED_BEFORE_NUMPY:  # the public functions need not limit BLAS again (nor load SciPy's to do so)
    _threads.note_pinned_by_environment()

#: Every command, in the order of ``encal --help``: name -> the line ``encal --help`` shows for it.
COMMANDS = {
    "demo": "the paper's whole procedure on the built-in demo fleet (tables, figures, report, model files)",
    "simulate": 'write simulated calibration CSVs (train, test, epoch2, decoder2) of resolver encoders',
    "profile": 'error statistics and harmonic analysis of one calibration',
    "fit": 'fit an error model to a calibration and save it',
    "report": 'HTML report (and PNG figures) for your own encoder',
    "evaluate": 'residual statistics of a model on a calibration',
    "correct": 'correct encoder angles (one per line, degrees) with a model file',
    "export": 'export a model as a dense correction table or as C source for firmware',
    "compare": 'compare Fourier, lookup-table and network models on a test calibration (Table 3)',
    "study": 'hidden-node sweep, training-algorithm table or SVD pruning of the network on a calibration',
    "drift": "drift of repeated calibrations and whether the first one's model still holds",
    "import": "read a firmware's calibration output or correction table (moteus, Klipper, Mechaduino, ...)",
    "selfcal": 'calibrate without a precision reference: from a spin, an electrical-angle sweep or full steps',
    "fleet": "a production line: fit every unit's calibration into a store by serial number, report on the fleet",
}


class _Parser(argparse.ArgumentParser):
    """An argument parser whose ``type=float`` and ``type=int`` options read a number as every file encal reads
    does (:mod:`encal._core.number_cells`): ``--noise 1_0`` or a full-width digit is a usage error (status 2),
    not 10. Its sub-parsers (commands, and their own sub-commands) are of this class too."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.register("type", float, plain_option(float))
        self.register("type", int, plain_option(int))


class _CommandsAction(argparse._SubParsersAction):
    """The commands' sub-parsers: a command's options are added when argparse selects the command.

    Until then a sub-parser holds only the command's name and help line, which is all ``encal --help``
    shows; a command's module (and what it imports) is imported only for the command that runs.
    """

    def __call__(self, parser, namespace, values, option_string=None):
        command = self._name_parser_map.get(values[0])
        if command is not None:
            _add_options(command, values[0])
        super().__call__(parser, namespace, values, option_string)


def _add_options(command, name):
    """Give the sub-parser ``command`` the options, description and run function of the command ``name``."""
    if command.get_default("_run") is not None:
        return
    module = importlib.import_module(f"{__name__}.cmd_{name}")
    command.description = module.__doc__ or COMMANDS[name]
    module.add_arguments(command)
    command.set_defaults(_run=module.run, _claim_extras=getattr(module, "claim_extras", None), _parser=command)


def build_parser(*, every_command=False):
    """The argument parser with every command.

    Parameters
    ----------
    every_command : bool, default=False
        Add every command's options now, importing every command's module (for a program that inspects
        the parser); by default a command's options are added when parsing selects the command, which
        parses and helps exactly alike.
    """
    parser = _Parser(
        prog="encal",
        description="Calibrate low-cost angle encoders and compensate their systematic error.",
    )
    parser.add_argument("--version", action="version", version=f"encal {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", action=_CommandsAction)
    for name, line in COMMANDS.items():
        command = sub.add_parser(name, help=line, description=line,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
        if every_command:
            _add_options(command, name)
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
    given before the command is imported."""
    return next((word for word in argv if isinstance(word, str) and word in COMMANDS), None)


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

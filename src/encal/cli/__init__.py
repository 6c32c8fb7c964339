"""The ``encal`` command line: a thin layer over the public API.

Each command lives in a module ``cmd_<name>.py`` of this package with
``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``; the
modules are found at start-up, so adding a command means adding a file.

Exit status: 0 on success, 1 on bad data or a failed operation (one line on
stderr, no traceback), 2 on wrong usage (argparse), 130 on Ctrl-C and 143 on
SIGTERM (both clean up as a failure does).
"""

import os

# encal's matrices are small (at most a few hundred rows): one BLAS thread per process is fastest, and a
# threaded BLAS on a busy 2-core machine was measured 100x slower (a 0.4 s fit took 98 s). This must run
# before NumPy is first imported; a user's own setting wins.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import importlib  # noqa: E402
import pkgutil  # noqa: E402
import signal  # noqa: E402
import sys  # noqa: E402
import threading  # noqa: E402

from .._version import __version__
from ..errors import EncalError

__all__ = ["main"]

#: Order in ``encal --help``; commands not listed follow alphabetically.
_ORDER = ["demo", "simulate", "profile", "fit", "evaluate", "correct", "export",
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
        cmd.set_defaults(_run=module.run, _claim_extras=getattr(module, "claim_extras", None))
    return parser


def main(argv=None):
    """Run the command line; returns the exit status."""
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
    from ._common import warnings_as_lines

    previous = _terminate_like_interrupt()
    try:
        with warnings_as_lines(args.command):
            return int(args._run(args) or 0)
    except EncalError as exc:
        print(f"encal {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except BrokenPipeError:
        return 0
    except OSError as exc:
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        print(f"encal {args.command}: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:
        print(f"encal {args.command}: {'terminated' if isinstance(exc, _Terminated) else 'interrupted'}",
              file=sys.stderr)
        return 143 if isinstance(exc, _Terminated) else 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


class _Terminated(KeyboardInterrupt):
    """SIGTERM (``kill``, ``timeout``, a CI runner), handled as Ctrl-C: temporary files removed, workers stopped."""


def _raise_terminated(signum, frame):
    raise _Terminated()


def _terminate_like_interrupt():
    """Make SIGTERM raise :class:`_Terminated` while a command runs; return the handler to restore, or None."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _raise_terminated)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""How a signal stops encal: at once, but never in the middle of a step that must be whole.

Ctrl-C (SIGINT), ``kill`` (SIGTERM) and a closed terminal (SIGHUP) end a command as a failure
does: the exception unwinds, temporary files are removed, worker processes are stopped. A few
steps must not be cut in two: renaming a set of finished files over their destinations, creating a
temporary file and registering it for removal, writing a block of whole output lines. They run
inside :func:`held`, which holds the signal until the step is done and then acts on it; a second
signal acts at once (the user insists).
"""

import contextlib
import os
import signal
import threading

__all__ = ["STOP_SIGNALS", "Terminated", "install", "held", "pending", "exit_status", "cause_of"]

#: The signals that stop a command (SIGHUP does not exist on Windows).
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised as Ctrl-C's KeyboardInterrupt is, so that the same clean-up runs.

    Attributes
    ----------
    signum : int
        The signal's number.
    """

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


def exit_status(exc):
    """The shell's exit status for a command stopped by ``exc``: 128 + the signal's number (130 for Ctrl-C)."""
    return 128 + (exc.signum if isinstance(exc, Terminated) else signal.SIGINT)


def cause_of(exc):
    """The KeyboardInterrupt (Ctrl-C or :class:`Terminated`) that caused ``exc``, or None.

    A signal raised while a C extension module initialises reaches Python as the ImportError the
    failed initialisation raises, with the signal's exception as its cause or context.
    """
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def _raise(signum, frame):
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise Terminated(signum)


def _in_main_thread():
    return threading.current_thread() is threading.main_thread()


def install():
    """Make SIGINT, SIGTERM and SIGHUP raise (KeyboardInterrupt or :class:`Terminated`).

    Returns
    -------
    callable
        Restores the previous handlers. Outside the main thread nothing is changed.
    """
    if not _in_main_thread():
        return lambda: None
    previous = {}
    for signum in STOP_SIGNALS:
        if signal.getsignal(signum) == signal.SIG_IGN:
            continue  # started with the signal ignored (nohup): keep it ignored
        previous[signum] = signal.signal(signum, _raise)

    def restore():
        for number, handler in previous.items():
            signal.signal(number, handler)

    return restore


_held = None  # the first signal received inside held(), or None
_handlers = None  # the handlers held() replaced, while it runs


def pending():
    """True when a stop signal arrived inside the running :func:`held` block."""
    return _held is not None


def _hold(signum, frame):
    global _held
    if _held is not None:  # a second signal: act at once
        _deliver(signum, _handlers.get(signum))
    _held = signum


def _deliver(signum, handler):
    if callable(handler):
        handler(signum, None)
    elif handler == signal.SIG_DFL:
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)


@contextlib.contextmanager
def held():
    """Hold SIGINT, SIGTERM and SIGHUP until the block ends, then act on the first that came.

    Blocks nest (an inner one holds nothing more). Outside the main thread, where Python runs no
    signal handler, the block runs as it is.
    """
    global _held, _handlers
    if _handlers is not None or not _in_main_thread():
        yield
        return
    handlers = {}
    try:
        for signum in STOP_SIGNALS:
            handlers[signum] = signal.signal(signum, _hold)
        _handlers = handlers
        yield
    finally:
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
        _handlers = None
        signum, _held = _held, None
        if signum is not None:
            _deliver(signum, handlers.get(signum))

"""One BLAS thread around encal's own work.

encal's matrices are small (hundreds of rows): a threaded BLAS spends more time waking and synchronising
its threads than computing, and on a busy machine its spinning threads compete with the work itself
(BENCHMARKS.md, "BLAS threads"). The command line pins one thread through the environment before NumPy
loads; a program that imports encal has usually set nothing, so the public entry points limit BLAS to one
thread around their own work with threadpoolctl and restore the caller's setting on return.
"""

import contextvars
import functools

__all__ = ["single_blas_thread", "note_pinned_by_environment"]

_controller = None
_pinned_by_environment = False
_inside = contextvars.ContextVar("encal_single_blas_thread", default=False)


def _blas():
    """The threadpool controller of the BLAS libraries NumPy and SciPy load (each wheel brings its own)."""
    global _controller
    if _controller is None:
        import numpy  # noqa: F401
        import scipy.linalg  # noqa: F401  (SciPy's own OpenBLAS loads with scipy.linalg)
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
    return _controller


def note_pinned_by_environment():
    """Record that every BLAS this process loads runs one thread already: the variables said 1 before NumPy loaded.

    The command line sets them so; the decorated functions then need no threadpool controller, whose set-up imports
    ``scipy.linalg`` (0.15-0.3 s of CPU) for commands that need no SciPy.
    """
    global _pinned_by_environment
    _pinned_by_environment = True


def single_blas_thread(function):
    """Decorate a public function so that BLAS runs on one thread while it works (nested calls limit once)."""

    @functools.wraps(function)
    def limited(*args, **kwargs):
        if _pinned_by_environment or _inside.get():
            return function(*args, **kwargs)
        token = _inside.set(True)
        try:
            with _blas().limit(limits=1, user_api="blas"):
                return function(*args, **kwargs)
        finally:
            _inside.reset(token)

    return limited

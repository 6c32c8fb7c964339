"""Memory that NumPy has freed given back to the operating system between the stages of a command.

glibc's allocator serves a large block from a mapping of its own and, when such a block is freed, raises the size
from which it maps blocks to that block's (up to 32 MiB): after a file of tens of MiB was read at once, the arrays of
10^6 numbers that follow come from the heap, and once freed they stay resident (up to twice that size at the heap's
top, and the pages of the holes left below it). ``encal fit`` of a 10^6-row file kept 60-110 MiB so after its
reading, and its peak depended on where the fit's arrays then landed (BENCHMARKS.md, issue 30).
"""

import sys

__all__ = ["release_freed_memory"]

_trim = None


def release_freed_memory():
    """Give the allocator's free memory back to the operating system (glibc's ``malloc_trim``); elsewhere nothing.

    Returns
    -------
    bool
        Whether any memory was released.
    """
    global _trim
    if _trim is None:
        _trim = False
        if sys.platform.startswith("linux"):
            try:
                import ctypes

                function = ctypes.CDLL(None).malloc_trim  # glibc (musl has none)
                function.argtypes, function.restype = [ctypes.c_size_t], ctypes.c_int
                _trim = function
            except (OSError, AttributeError):
                pass
    return bool(_trim(0)) if _trim else False

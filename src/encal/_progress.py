"""Progress bars on stderr for the long parts of a study or the demo.

On a terminal the bar is redrawn in place; elsewhere (a log file, a pipe, a
test capturing stderr) only one line is printed when the work ends, so logs
stay readable.
"""

import sys
import time

__all__ = ["Progress"]

_BAR_WIDTH = 28


class Progress:
    """A counter of finished tasks, shown as a bar on a stream.

    Parameters
    ----------
    total : int
        Number of tasks.
    label : str
        What is being done, e.g. ``'hidden-node sweep'``.
    stream : file-like, optional
        Where to draw; ``sys.stderr`` by default.
    enabled : bool, default=True
        ``False`` draws nothing (the library default when no progress is asked for).

    Examples
    --------
    >>> import io
    >>> out = io.StringIO()
    >>> with Progress(3, "fits", stream=out) as bar:
    ...     for _ in range(3):
    ...         bar.advance()
    >>> out.getvalue().startswith("fits: 3/3 done in ")
    True
    """

    def __init__(self, total, label, *, stream=None, enabled=True):
        self.total = max(int(total), 0)
        self.label = str(label)
        self.stream = sys.stderr if stream is None else stream
        self.enabled = bool(enabled)
        self.done = 0
        self._start = time.perf_counter()
        isatty = getattr(self.stream, "isatty", None)
        self._live = self.enabled and callable(isatty) and isatty()

    @property
    def elapsed(self):
        """Seconds since the bar was made."""
        return time.perf_counter() - self._start

    def advance(self, n=1):
        """Count ``n`` more finished tasks and redraw."""
        self.done = min(self.done + int(n), self.total)
        if self._live:
            self._draw(end="")

    def close(self):
        """Print the final line (once)."""
        if self.enabled:
            self._draw(end="\n")
            self.enabled = self._live = False

    def _draw(self, end):
        seconds = self.elapsed
        if self._live:
            filled = _BAR_WIDTH * self.done // self.total if self.total else _BAR_WIDTH
            bar = "#" * filled + "-" * (_BAR_WIDTH - filled)
            text = f"\r{self.label}: [{bar}] {self.done}/{self.total} {seconds:5.1f} s"
        else:
            text = f"{self.label}: {self.done}/{self.total} done in {seconds:.1f} s"
        self.stream.write(text + end)
        self.stream.flush()

    def __enter__(self):
        if self._live:
            self._draw(end="")
        return self

    def __exit__(self, *exc):
        self.close()
        return False


"""Progress on stderr: bars for the parts of a study or the demo, and the line of a long command.

:class:`Progress` counts finished tasks: on a terminal the bar is redrawn in place; elsewhere (a log
file, a pipe, a test capturing stderr) only one line is printed when the work ends, so logs stay
readable. :class:`Activity` is the line of a command that may run long on a dense calibration
(``profile``, ``fit``, ``evaluate``, ``correct FILE``, ``report``): nothing for the first 2 seconds,
then the stage and its progress, redrawn in place; off a terminal one closing line for runs of 10
seconds or more, nothing otherwise.
"""

import sys
import threading
import time

__all__ = ["Progress", "Activity", "clear_line", "SHOW_AFTER_S", "LOG_AFTER_S"]

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



#: Seconds a command runs before its progress line appears on a terminal: nothing for short runs.
SHOW_AFTER_S = 2.0
#: Seconds a command runs before it writes its one closing line when stderr is not a terminal (a log file,
#: a pipe): a record of where a long run spent its time, and nothing in the logs of ordinary runs.
LOG_AFTER_S = 10.0
#: Seconds between two redraws of the line on a terminal.
REDRAW_S = 0.2

_active = []  # the activity drawing on the terminal now, for clear_line()
_now = time.monotonic  # the clock of an Activity unless given (a test replaces it)


class Activity:
    """What a long command is doing, shown on stderr once it has run :data:`SHOW_AFTER_S` seconds.

    A command names its stages (``stage('reading cal.csv', total=bytes)``) and reports progress within
    one (``update(done)``). On a terminal nothing is shown for the first 2 seconds; from then on a
    background thread redraws one line in place every 0.2 s (the stage, a bar when its total is known,
    the seconds so far), also while a single long NumPy call holds the work, and :meth:`close` ends it
    with the stages' times. Elsewhere (a log, a pipe, a test capturing stderr) only that closing line is
    written, and only when the run took :data:`LOG_AFTER_S` seconds or more.

    Parameters
    ----------
    command : str
        Named at the start of the line, e.g. ``'encal fit'``.
    stream : file-like, optional
        ``sys.stderr`` by default.
    clock : callable, optional
        Seconds (``time.monotonic`` by default); a test passes a fake clock.
    background : bool, default=True
        Redraw from a background thread on a terminal; False leaves the redraws to :meth:`tick` (each
        :meth:`stage` calls it too).
    enabled : bool, default=True
        False shows nothing at all (``encal correct`` writing its answers to the terminal).

    Examples
    --------
    >>> import io
    >>> seconds = iter([0.0, 0.5, 12.0])
    >>> log = io.StringIO()
    >>> with Activity("encal fit", stream=log, clock=lambda: next(seconds)) as activity:
    ...     activity.stage("reading cal.csv")
    >>> log.getvalue()
    'encal fit: done in 12.0 s (reading cal.csv 11.5 s)\\n'
    """

    def __init__(self, command, *, stream=None, clock=None, background=True, enabled=True):
        self.command = str(command)
        self.stream = sys.stderr if stream is None else stream
        self.clock = _now if clock is None else clock
        self.enabled = bool(enabled) and self.stream is not None
        self._start = self.clock()
        self._stages = []  # [label, start seconds]
        self.done, self.total = 0, None
        isatty = getattr(self.stream, "isatty", None)
        self._live = self.enabled and callable(isatty) and bool(isatty())
        self._shown = 0  # characters of the line on the terminal (0: nothing shown)
        self._closed = False
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = None
        if self._live and background:
            self._thread = threading.Thread(target=self._redraw, name="encal-progress", daemon=True)

    def stage(self, label, total=None):
        """Start the stage ``label`` (e.g. ``'reading cal.csv'``), of ``total`` units of work if known."""
        with self._lock:
            self._stages.append([str(label), self.clock()])
            self.done, self.total = 0, total
        self.tick()

    def update(self, done, total=None):
        """Units of the current stage done so far (and its total, if it was not known)."""
        with self._lock:
            self.done = done
            if total is not None:
                self.total = total

    def advance(self, n=1):
        """Count ``n`` more units of the current stage done (a callback with no argument, e.g. a fit's rounds)."""
        with self._lock:
            self.done += n

    def tick(self):
        """Redraw the line if it is due (a terminal, 2 s after the start); True if drawn."""
        if not self._live:
            return False
        with self._lock:
            now = self.clock()
            if self._closed or now - self._start < SHOW_AFTER_S:
                return False
            self._write(self._line(now), end="")
            return True

    def clear(self):
        """Take the line off the terminal, so that another line can be written (the next tick redraws it)."""
        with self._lock:
            if self._shown:
                self._write("", end="")
                self.stream.write("\r")
                self._shown = 0

    def close(self, failed=False):
        """Stop; end the line with the stages' times (on a terminal: if it was shown; elsewhere: if long)."""
        self._stop.set()
        if self._thread is not None and self._thread.is_alive():
            self._thread.join()
        with self._lock:
            if self._closed:
                return
            self._closed = True
            now = self.clock()
            if self._live and self._shown:
                if failed:  # the error message follows on a clean line
                    self._write("", end="")
                    self.stream.write("\r")
                else:
                    self._write(self._summary(now), end="\n")
            elif self.enabled and not self._live and not failed and now - self._start >= LOG_AFTER_S:
                self.stream.write(self._summary(now) + "\n")
            if self.enabled:
                self.stream.flush()

    def _line(self, now):
        label = self._stages[-1][0] if self._stages else "working"
        if self.total:
            fraction = min(max(self.done / self.total, 0.0), 1.0)
            filled = int(_BAR_WIDTH * fraction)
            progress = f" [{'#' * filled}{'-' * (_BAR_WIDTH - filled)}] {100 * fraction:3.0f}%"
        else:
            progress = " ..."
        return f"{self.command}: {label}{progress} {now - self._start:5.1f} s"

    def _summary(self, now):
        ends = [start for _, start in self._stages[1:]] + [now]
        parts = ", ".join(f"{label} {end - start:.1f} s" for (label, start), end in zip(self._stages, ends))
        return f"{self.command}: done in {now - self._start:.1f} s" + (f" ({parts})" if parts else "")

    def _write(self, text, end):
        """Draw ``text`` over the line on the terminal (padded over a longer previous one)."""
        if self._live:
            self.stream.write("\r" + text.ljust(self._shown) + end)
            self._shown = 0 if end else len(text)
        else:
            self.stream.write(text + end)
        self.stream.flush()

    def _redraw(self):
        while not self._stop.wait(REDRAW_S):
            try:
                self.tick()
            except (OSError, ValueError):  # the terminal went away
                return

    def __enter__(self):
        _active.append(self)
        if self._thread is not None:
            self._thread.start()
        return self

    def __exit__(self, kind, value, traceback):
        try:
            self.close(failed=kind is not None)
        finally:
            _active.remove(self)
        return False


def clear_line():
    """Take the progress line off the terminal before another message is written to it."""
    for activity in _active:
        activity.clear()

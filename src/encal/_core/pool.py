"""Run independent fits on up to two processes, with results in a fixed order.

A study is a list of independent fits (one per hidden-node count, algorithm
and seed). Each task carries its own seed, and every worker process computes
the same way, so the results do not depend on how many processes run them or
in which order they finish.

Worker processes are *spawned* (a fresh interpreter, not a fork) with one
BLAS thread each, for two reasons:

- speed: every fit multiplies matrices of a few hundred rows; BLAS threads
  add contention, not speed (measured on a busy two-core machine: a sweep of
  twelve 100-epoch fits took 61 s in-process with the default BLAS threads and
  5.5 s on two single-threaded workers);
- reproducibility: a different number of BLAS threads sums in a different
  order, and a few hundred Levenberg-Marquardt epochs amplify that last-bit
  difference into a visibly different network.

``workers=0`` runs the tasks in the calling process instead (no process is
started; the BLAS threads are whatever the process has). A script that
starts workers must guard its top-level code with
``if __name__ == "__main__":``, as :mod:`multiprocessing` requires.
"""

import concurrent.futures
import multiprocessing
import os
import threading
import time

from .progress import Progress
from .limits import check_size

__all__ = ["MAX_WORKERS", "default_workers", "Workers", "run_tasks"]

#: The demo's target machine has two cores; more processes buy nothing for a few dozen small fits.
MAX_WORKERS = 2

_BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def default_workers():
    """``os.cpu_count()`` capped at :data:`MAX_WORKERS` (at least 1)."""
    return max(1, min(os.cpu_count() or 1, MAX_WORKERS))


class Workers:
    """A pool of worker processes that several studies share (started on first use).

    Parameters
    ----------
    count : int, optional
        Number of processes; default :func:`default_workers`. With 0 every task
        runs in the calling process and no process is started.

    Examples
    --------
    >>> with Workers(0) as workers:
    ...     run_tasks(abs, [-1, -2], workers=workers)
    [1, 2]
    """

    def __init__(self, count=None):
        if count is None:
            count = default_workers()
        self.count = check_size("workers", count, "Workers", low=0)
        self._executor = None

    def executor(self):
        """The process pool, started now if needed (None when ``count`` is 0)."""
        if self.count == 0:
            return None
        if self._executor is None:
            saved = {name: os.environ.get(name) for name in _BLAS_THREAD_VARIABLES}
            os.environ.update({name: "1" for name in _BLAS_THREAD_VARIABLES})
            try:
                self._executor = concurrent.futures.ProcessPoolExecutor(
                    max_workers=self.count, mp_context=multiprocessing.get_context("spawn"),
                    initializer=_die_with_parent, initargs=(os.getpid(),))
                # Start every process now, while the environment says one BLAS thread.
                list(self._executor.map(int, range(self.count)))
            finally:
                for name, value in saved.items():
                    if value is None:
                        os.environ.pop(name, None)
                    else:
                        os.environ[name] = value
        return self._executor

    def close(self):
        """Stop the processes (waiting for running tasks, cancelling queued ones)."""
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._executor = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


#: How often a worker checks that the process that started it is still there, in seconds.
PARENT_CHECK_S = 0.5


def _die_with_parent(parent_pid):
    """Worker initializer: exit when the parent is gone.

    A parent killed with SIGKILL (or crashing) cannot stop its workers, and they would wait for work
    for ever. When the parent dies the worker is handed to another process, so its parent id changes.
    """
    def watch():
        while os.getppid() == parent_pid:
            time.sleep(PARENT_CHECK_S)
        os._exit(1)

    threading.Thread(target=watch, name="encal-parent-watch", daemon=True).start()


def run_tasks(function, tasks, *, workers=None, label="fits", progress=False):
    """Call ``function(task)`` for every task and return the results in task order.

    Parameters
    ----------
    function : callable
        A module-level function (it is sent to worker processes by name).
    tasks : sequence
        Picklable arguments, one per call.
    workers : int, Workers or None, default=None
        Number of processes (None: :func:`default_workers`; 0: this process), or a shared :class:`Workers`.
    label : str, default='fits'
        Name shown on the progress bar.
    progress : bool, default=False
        Draw a progress bar on stderr.

    Returns
    -------
    list
        ``[function(task) for task in tasks]``, whatever the number of workers.
    """
    tasks = list(tasks)
    if isinstance(workers, Workers):
        return _run(function, tasks, workers, label, progress)
    if workers is None:
        workers = default_workers()
    if isinstance(workers, int) and not isinstance(workers, bool) and workers > 0:
        workers = min(workers, max(len(tasks), 1))
    with Workers(workers) as pool:
        return _run(function, tasks, pool, label, progress)


def _run(function, tasks, workers, label, progress):
    with Progress(len(tasks), label, enabled=progress) as bar:
        executor = workers.executor() if tasks else None
        if executor is None:
            results = []
            for task in tasks:
                results.append(function(task))
                bar.advance()
            return results
        futures = {executor.submit(function, task): index for index, task in enumerate(tasks)}
        results = [None] * len(tasks)
        try:
            for future in concurrent.futures.as_completed(futures):
                results[futures[future]] = future.result()
                bar.advance()
        except BaseException:
            for future in futures:
                future.cancel()
            raise
        return results

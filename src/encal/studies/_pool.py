"""Run independent fits on up to two processes, with results in a fixed order.

A study is a list of independent fits (one per hidden-node count, algorithm
and seed). Each task carries its own seed, so the results do not depend on
how many processes run them or in which order they finish.
"""

import concurrent.futures
import multiprocessing
import os

from .._progress import Progress
from ..errors import InputError

__all__ = ["MAX_WORKERS", "default_workers", "run_tasks"]

#: The demo's target machine has two cores; more processes than that buy nothing for a few dozen fits.
MAX_WORKERS = 2


def default_workers():
    """``os.cpu_count()`` capped at :data:`MAX_WORKERS` (at least 1)."""
    return max(1, min(os.cpu_count() or 1, MAX_WORKERS))


def _check_workers(workers):
    if workers is None:
        return default_workers()
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"workers must be an int >= 1 or None. Got {workers!r} instead.")
    return workers


def run_tasks(function, tasks, *, workers=None, label="fits", progress=False):
    """Call ``function(task)`` for every task and return the results in task order.

    Parameters
    ----------
    function : callable
        A module-level function (it is sent to worker processes by name).
    tasks : sequence
        Picklable arguments, one per call.
    workers : int, optional
        Number of processes; default :func:`default_workers`. With 1 the tasks
        run in this process.
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
    workers = min(_check_workers(workers), max(len(tasks), 1))
    with Progress(len(tasks), label, enabled=progress) as bar:
        if workers == 1:
            results = []
            for task in tasks:
                results.append(function(task))
                bar.advance()
            return results
        context = multiprocessing.get_context("spawn")
        with _single_threaded_blas(), concurrent.futures.ProcessPoolExecutor(
                max_workers=workers, mp_context=context) as pool:
            futures = {pool.submit(function, task): index for index, task in enumerate(tasks)}
            results = [None] * len(tasks)
            try:
                for future in concurrent.futures.as_completed(futures):
                    results[futures[future]] = future.result()
                    bar.advance()
            except BaseException:
                pool.shutdown(wait=True, cancel_futures=True)
                raise
        return results


class _single_threaded_blas:
    """Spawned workers inherit the environment: one BLAS thread each, so two workers use two cores.

    Each fit multiplies matrices of a few hundred rows; letting every worker's BLAS start its own
    threads on a two-core machine only adds contention.
    """

    _VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")

    def __enter__(self):
        self._saved = {name: os.environ.get(name) for name in self._VARIABLES}
        for name in self._VARIABLES:
            os.environ[name] = "1"
        return self

    def __exit__(self, *exc):
        for name, value in self._saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
        return False

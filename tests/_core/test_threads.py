"""encal limits BLAS to one thread around its own work, whatever the calling program set."""

import numpy as np
import scipy.linalg  # noqa: F401  (SciPy's own BLAS loaded, as in a program that uses encal)
from threadpoolctl import threadpool_info, threadpool_limits

import encal
from encal._core.threads import single_blas_thread


def blas_threads():
    return sorted({pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"})


def test_a_decorated_function_runs_on_one_blas_thread_and_restores_the_callers_setting():
    seen = []

    @single_blas_thread
    def work():
        seen.append(blas_threads())
        inner()

    @single_blas_thread
    def inner():
        seen.append(blas_threads())

    with threadpool_limits(limits=2, user_api="blas"):
        assert blas_threads() == [2]
        work()
        assert blas_threads() == [2]  # the caller's setting back
    assert seen == [[1], [1]]


def test_fit_runs_on_one_blas_thread(monkeypatch):
    from encal.models import fitting

    seen = []
    original = fitting.fitter

    def spying(method):
        seen.append(blas_threads())
        return original(method)

    monkeypatch.setattr(fitting, "fitter", spying)
    reference = np.arange(0.0, 360.0, 2.0)
    cal = encal.Calibration(reference, reference + np.sin(np.radians(reference)) / 60.0)
    with threadpool_limits(limits=2, user_api="blas"):
        encal.fit(cal, method="fourier")
        assert blas_threads() == [2]
    assert seen and all(threads == [1] for threads in seen)


def test_public_entry_points_that_fit_limit_blas_themselves():
    # a program that imports encal sets no thread variables: each entry point that solves small linear
    # systems limits BLAS itself (the fleet prior's fit took 20 s of CPU instead of 0.15 s without it)
    from encal.fleet.prior import fit_with_prior, fleet_prior

    for function in (encal.fit, encal.evaluate, fit_with_prior, fleet_prior):
        assert getattr(function, "__wrapped__", None) is not None, function.__qualname__


def test_a_process_that_pinned_blas_before_numpy_loaded_sets_up_no_controller(monkeypatch):
    # The command line sets the thread variables to 1 before NumPy loads and says so: a decorated function then
    # runs as it is, without threadpoolctl's controller, whose set-up imports scipy.linalg.
    from encal._core import threads

    def no_controller():
        raise AssertionError("a threadpool controller was set up")

    monkeypatch.setattr(threads, "_blas", no_controller)
    monkeypatch.setattr(threads, "_pinned_by_environment", True)
    assert single_blas_thread(lambda x: 2 * x)(21) == 42

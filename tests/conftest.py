"""Shared fixtures."""

import os

# One BLAS thread: encal's matrices are small, and with several processes on 2 cores a threaded BLAS
# spends more time contending than computing (measured: fit_fourier 0.009 s -> 0.78 s under load).
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np
import pytest
from hypothesis import settings

from tests._paths import REAL_MECHADUINO as REAL_DATA

# Locally Hypothesis explores new examples on every run; in CI (CI=true) it replays a fixed sequence so
# that a run's verdict does not depend on which examples happened to be drawn.
settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")


@pytest.fixture(autouse=True)
def _close_pyplot_figures():
    """Plots drawn with ax=None go to pyplot's current figure (Matplotlib's convention): close them after
    each test, so that no test draws on another's axes."""
    yield
    import sys

    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")


@pytest.fixture
def real_data_dir():
    """The folder of real AS5047D calibrations (shared/ beside the repository); skips when absent."""
    if not REAL_DATA.is_dir():
        pytest.skip("shared/data/real/mechaduino is not beside this checkout")
    return REAL_DATA


@pytest.fixture
def write_csv(tmp_path):
    """Write text to a CSV file in tmp_path and return its path."""

    def write(text, name="cal.csv", mode="w"):
        path = tmp_path / name
        if isinstance(text, bytes):
            path.write_bytes(text)
        else:
            path.write_text(text, encoding="utf-8", newline="")
        return path

    return write


def grid_csv(step=2.0, offset=0.0, error=lambda ref: 0.01 * np.sin(np.radians(ref))):
    """CSV text of a calibration on a regular grid with a given error function (degrees)."""
    ref = np.arange(0.0, 360.0, step) + offset
    lines = ["reference_deg,encoder_deg"] + [f"{float(r)!r},{float(r + error(r))!r}" for r in ref]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="session")
def tiny_demo(tmp_path_factory):
    """``(out, result, printed text)`` of the smallest demo: two encoders, two sweep points, a few epochs.

    One run serves test_demo.py and test_report.py (its files written to ``out``, no report or figures).
    """
    import io

    from encal.paper.demo import DemoSettings, run_demo

    settings = DemoSettings(n_encoders=2, hidden=(8, 80), sweep_seeds=1, sweep_epochs=3, algorithm_seeds=2,
                            algorithm_epochs=3, network_epochs=3)
    out = tmp_path_factory.mktemp("demo")
    stdout = io.StringIO()
    result = run_demo(out, settings=settings, workers=0, progress=False, stdout=stdout, report=False)
    return out, result, stdout.getvalue()

"""The deployment promise, end to end: a model fitted from the command line corrects a test run identically
through the API, the standalone runtime, `encal correct`, the dense table (within its stated bound) and the
compiled C export."""

import importlib.util
import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

import encal
import encal.runtime
from encal.cli import main
from encal.deploy import load_table

FLOAT32_TOLERANCE_DEG = 2e-5  # a float32 angle near 360 deg is exact to 360 * 2**-24 = 2.1e-5 deg


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """enc1 of the simulated demo fleet, fitted with `encal fit` (fourier and network)."""
    folder = tmp_path_factory.mktemp("e2e")
    assert main(["simulate", "--encoders", "1", "--out", str(folder)]) == 0
    models = {}
    for method, extra in (("fourier", []), ("ann", ["--hidden", "12", "--seed", "0", "--epochs", "200"])):
        path = folder / f"{method}.json"
        assert main(["fit", str(folder / "enc1_train.csv"), "-o", str(path), "--method", method, *extra]) == 0
        models[method] = path
    return folder, models


def _angular_gap_deg(a, b):
    return np.abs(encal.angle_difference(np.asarray(a, dtype=float), np.asarray(b, dtype=float)))


@pytest.mark.parametrize("method", ["fourier", "ann"])
def test_every_deployed_form_corrects_the_test_run_alike(fitted, method, tmp_path, capfd):
    folder, models = fitted
    model_path = models[method]
    test = encal.read_calibration(folder / "enc1_test.csv")
    theta = test.encoder_deg
    api = encal.load_model(model_path).correct(theta)

    # The corrected test run is as accurate as `encal evaluate` says.
    capfd.readouterr()
    assert main(["evaluate", str(model_path), str(folder / "enc1_test.csv"), "--json"]) == 0
    stated = json.loads(capfd.readouterr().out)
    residual = encal.angle_difference(api, test.reference_deg) * 60.0
    assert np.sqrt(np.mean(residual**2)) == pytest.approx(stated["rms_arcmin"], rel=1e-12)
    assert stated["rms_arcmin"] < 0.5 * stated["before"]["rms_arcmin"]

    # The standalone runtime (standard library only), loaded from its file as a user would copy it.
    spec = importlib.util.spec_from_file_location("copied_runtime", encal.runtime.__file__)
    runtime = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(runtime)
    stored = runtime.load(str(model_path))
    assert np.max(_angular_gap_deg([stored.correct_deg(t) for t in theta], api)) < 1e-9 / 60

    # `encal correct` in a separate process.
    angles = tmp_path / "angles.txt"
    angles.write_text("".join(f"{t!r}\n" for t in theta.tolist()), encoding="utf-8")
    done = subprocess.run([sys.executable, "-m", "encal", "correct", str(model_path), str(angles)],
                          capture_output=True, text=True, check=True)
    assert np.max(_angular_gap_deg(np.array(done.stdout.split(), dtype=float), api)) < 1e-12

    # The dense 16-bit table: the simulated encoder's readings are whole codes, so the stated
    # quantisation bound is the worst case.
    table_path = tmp_path / "enc1.tab"
    assert main(["export", str(model_path), "--format", "table", "--bits", "16", "-o", str(table_path)]) == 0
    table = load_table(table_path)
    codes = np.rint(theta * 65536 / 360.0).astype(np.int64) % 65536
    assert np.allclose(codes * 360.0 / 65536, theta, atol=1e-9)
    deviation_arcmin = _angular_gap_deg(table.correct_counts(codes), api) * 60.0
    assert np.max(deviation_arcmin) <= table.quantisation_arcmin * (1 + 1e-9) + 1e-12

    # The C export, compiled with strict warnings.
    compiler = shutil.which("gcc") or shutil.which("cc")
    if compiler is None:
        pytest.skip("no C compiler on this machine")
    assert main(["export", str(model_path), "--format", "c", "--bits", "16", "-o", str(tmp_path / "c"),
                 "--name", "enc1"]) == 0
    driver = tmp_path / "c" / "driver.c"
    driver.write_text(
        '#include <stdio.h>\n#include "enc1.h"\n'
        "int main(void) { double t; while (scanf(\"%lf\", &t) == 1) "
        "printf(\"%.9g\\n\", (double)enc1_correct_deg((float)t)); return 0; }\n", encoding="utf-8")
    program = tmp_path / "c" / "driver"
    subprocess.run([compiler, "-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", "-o", str(program),
                    str(driver), str(tmp_path / "c" / "enc1.c"), "-lm"], check=True)
    with angles.open() as source:
        done = subprocess.run([str(program)], stdin=source, capture_output=True, text=True, check=True)
    c_corrected = np.array(done.stdout.split(), dtype=float)
    # float32 input and output: the reading itself is rounded to float32 before correction.
    assert np.max(_angular_gap_deg(c_corrected, api)) < FLOAT32_TOLERANCE_DEG * 2

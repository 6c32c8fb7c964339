"""Write the model files of each format version kept in tests/data, and their expected values.

Run once per format version (``python tests/data/make_model_files.py [VERSION]``, 1 by
default; 3 for the files that name a form) and commit the output; never regenerate the
files of an older version: the tests check that
today's encal still reads them and predicts what they predicted when written. A kind
added to a version later (``stack``) is drawn last, so the earlier files come out
byte-identical; commit only its file and its entry of ``expected_v1.json``, keeping the
entries written before (a rerun may differ from them in the last bit).

The models are hand-made (realistic sizes and magnitudes, no calibration data
behind them). The expected values are computed by the standalone runtime, in
pure Python, independently of the NumPy model classes.
"""

import hashlib
import json
import math
import os
import sys
from pathlib import Path

import numpy as np

from encal._core.atomic import atomic_write
from encal import runtime
from encal.models.modelfile import dumps, model_to_dict
from encal.models.base import Model

HERE = Path(__file__).resolve().parent
ANGLES = [0.0, 1e-12, 0.5, 1.0, 2.0, 45.0, 89.99, 123.456, 180.0, 270.0, 358.0, 359.0,
          359.999999, 360.0, -0.25, -1.0, -359.5, 721.25, 1e6 + 0.125, -1e9]


class StoredModel(Model):
    """A model given by its kind and parameters (evaluated by the runtime); ``form`` for a kind the format
    does not name."""

    def __init__(self, kind, parameters, *, uncertainty=None, form=None, reading_sign=1, **metadata):
        super().__init__(**metadata)
        self.kind = kind
        self.form = form
        self.reading_sign = reading_sign
        self._parameters = parameters
        self.uncertainty = uncertainty

    def _predict(self, theta_deg):
        raise NotImplementedError

    def parameters(self):
        return self._parameters

    def free_parameters(self):
        raise NotImplementedError

    @classmethod
    def from_parameters(cls, parameters, *, encoder=None, training=None):
        raise NotImplementedError


def fourier_parameters(rng, orders):
    amplitude = [6.0 / (1 + k) if k else 1.5 for k in orders]
    return {"orders": orders,
            "cos": [float(a * rng.uniform(-1, 1)) for a in amplitude],
            "sin": [0.0 if k == 0 else float(a * rng.uniform(-1, 1))
                    for k, a in zip(orders, amplitude)]}


def profile(theta_deg):
    r = np.radians(theta_deg)
    return (4.0 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r) - 0.6 * np.sin(4 * r)
            + 0.3 * np.exp(-0.5 * ((theta_deg - 200.0) / 6.0) ** 2))


def lut_parameters(interpolation, breaks):
    from encal.models.lut import fit_lut

    model = fit_lut(breaks, profile(breaks), interpolation=interpolation)
    return model.parameters()


def ann_parameters(rng, hidden, encoding, activation):
    n_inputs = 1 if encoding == "raw" else 2
    low, high = ([0.0], [358.0]) if encoding == "raw" else ([-1.0, -1.0], [1.0, 1.0])
    return {"encoding": encoding, "activation": activation,
            "input_offset": low, "input_gain": [2.0 / (h - lo) for lo, h in zip(low, high)],
            "target_offset": -5.75, "target_gain": 2.0 / 11.5,
            "W1": rng.normal(0.0, 2.0, (hidden, n_inputs)).tolist(),
            "b1": rng.normal(0.0, 1.5, hidden).tolist(),
            "W2": rng.normal(0.0, 0.6, hidden).tolist(),
            "b2": float(rng.normal(0.0, 0.2))}


def uncertainty(step, level):
    n = round(360 / step)
    return {"method": "parametric-bootstrap", "grid_step_deg": step,
            "model_std_arcmin": [level * (1.2 + math.sin(2 * math.pi * i / n)) for i in range(n)],
            "noise_std_arcmin": 0.14, "n_boot": 30, "n_folds": 10}


def training(method, algorithm=None, epochs=None, seed=None, **options):
    return {"method": method, "algorithm": algorithm, "epochs": epochs, "seed": seed,
            "data_sha256": hashlib.sha256(method.encode()).hexdigest(), "n_points": 180,
            "options": options}


def models():
    rng = np.random.default_rng(20261122)
    grid = np.arange(0.0, 360.0, 2.0)
    uneven = np.sort(rng.uniform(1.0, 361.0, 37))
    uneven = np.r_[1.0, uneven[(uneven > 1.5) & (uneven < 360.5)]]
    fourier = fourier_parameters(rng, [0, 1, 2, 3, 4, 8, 16, 50, 97])
    ann = ann_parameters(rng, 8, "periodic", "tansig")
    yield "fourier", "fourier", fourier, training("fourier", select="top", n_orders=9), None
    yield "lut", "lut", lut_parameters("cubic", grid), training("lut", interpolation="cubic"), None
    yield ("lut_linear", "lut", lut_parameters("linear", uneven),
           training("lut", interpolation="linear"), None)
    yield ("ann", "ann", ann, training("ann", "trainlm", 120, 0, hidden=8, encoding="periodic"),
           uncertainty(1.0, 0.05))
    yield ("ann_raw", "ann", ann_parameters(rng, 6, "raw", "logsig"),
           training("ann", "trainscg", 400, 1, hidden=6, encoding="raw"), None)
    yield ("hybrid", "hybrid",
           {"fourier": fourier_parameters(rng, [1, 2, 4]),
            "ann": ann_parameters(rng, 5, "periodic", "logsig")},
           training("hybrid", "trainbr", 80, 2, n_orders=3, hidden=5), None)
    yield ("directional", "directional",
           {"forward": {"kind": "fourier", "parameters": fourier_parameters(rng, [0, 1, 2]),
                        "uncertainty": uncertainty(10.0, 0.1)},
            "reverse": {"kind": "lut", "parameters": lut_parameters("linear", grid)}},
           training("directional", treatment="per-direction"), uncertainty(5.0, 0.08))
    # Added with the stack kind (still format version 1); drawn last so the files above do not change.
    yield ("stack", "stack",
           {"members": [{"kind": "fourier", "parameters": fourier_parameters(rng, [0, 1, 2, 16])},
                        {"kind": "lut", "parameters": lut_parameters("cubic", grid)},
                        {"kind": "ann", "parameters": ann_parameters(rng, 4, "periodic", "tansig")}],
            "weights": [0.45, 0.4, 0.15]},
           training("stack", "trainlm", 100, 3, members=[{"family": "fourier", "options": {"orders": [0, 1, 2, 16]}},
                                                         {"family": "lut", "options": {"interpolation": "cubic"}},
                                                         {"family": "ann", "options": {"hidden": 4}}],
                    weights=[0.45, 0.4, 0.15]), uncertainty(2.0, 0.06))
    # Added with the spectral kind (still format version 1): a posterior-mean series and its posterior std.
    posterior = uncertainty(1.0, 0.03)
    posterior["method"] = "posterior"
    del posterior["n_boot"], posterior["n_folds"]
    yield ("spectral", "spectral", fourier_parameters(rng, list(range(91))),
           training("spectral", noise_arcmin=0.1), posterior)


def models_v3():
    """Format version 3: a kind the format does not name ('sine', a made-up kind), stored as a Fourier series,
    alone (its encoder counting against the reference) and as a stack's member."""
    rng = np.random.default_rng(20261124)
    sine = {"kind": "sine", "form": "fourier", "parameters": fourier_parameters(rng, [1, 3])}
    yield "sine", "sine", sine["parameters"], training("sine"), None, {"form": "fourier", "reading_sign": -1}
    yield ("stack", "stack",
           {"members": [sine, {"kind": "lut", "parameters": lut_parameters("linear", np.arange(0.0, 360.0, 10.0))}],
            "weights": [0.7, 0.3]},
           training("stack", members=[{"family": "sine"}, {"family": "lut"}], weights=[0.7, 0.3]), None, {})


def main(version=1):
    os.environ.setdefault("SOURCE_DATE_EPOCH", "1795337100")  # 2026-11-22T10:05:00Z
    expected = {}
    drawn = {1: models, 3: models_v3}[version]()
    for name, kind, parameters, record, spread, *more in drawn:
        model = StoredModel(kind, parameters, uncertainty=spread, training=record,
                            encoder={"name": f"v{version}-{name}", "resolution_bits": 16}, **(more or [{}])[0])
        path = HERE / f"model_v{version}_{name}.json"
        atomic_write(path, dumps(model_to_dict(model)))
        stored = runtime.load(path)
        expected[path.name] = {
            "theta_deg": ANGLES,
            "predict_arcmin": [stored.predict_arcmin(t) for t in ANGLES],
            "correct_deg": [stored.correct_deg(t) for t in ANGLES],
        }
        print(f"wrote {path.name}", file=sys.stderr)
    atomic_write(HERE / f"expected_v{version}.json", json.dumps(expected, indent=1) + "\n")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1)

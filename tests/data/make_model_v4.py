"""Write tests/data/model_v4_arc.json (format version 4: an arc model with its range_deg) and expected_v4.json.

Run once (``python tests/data/make_model_v4.py``) and commit the output; never regenerate: the tests check that
today's encal still reads the file and predicts what it predicted when written (null: outside the arc, NaN).
The expected values are computed by the standalone runtime, in pure Python.
"""

import json
import math
from pathlib import Path

import numpy as np

from encal import runtime
from encal._atomic import atomic_write
from encal.models.arc import fit_arc
from encal.models.modelfile import dumps, model_to_dict

HERE = Path(__file__).resolve().parent
ANGLES = [0.0, 20.0, 20.5, 45.0, 89.99, 123.456, 139.5, 140.0, 180.0, 270.0, 359.0, 380.25, -250.0]


def main():
    theta = np.linspace(20.0, 140.0, 241)
    error = 2.0 * np.sin(np.radians(theta)) + 0.5 * np.cos(np.radians(7.0 * theta)) + 0.05 * np.sin(37.0 * theta)
    model = fit_arc(theta, error)
    model.encoder = {"name": "arc-v4", "resolution_bits": 14}
    model.training = {**model.training, "n_points": int(theta.size)}
    document = model_to_dict(model, reproducible=True)
    atomic_write(HERE / "model_v4_arc.json", dumps(document))
    loaded = runtime.load(HERE / "model_v4_arc.json")
    values = [loaded.predict_arcmin(a) for a in ANGLES]
    expected = {"model_v4_arc.json": {"theta_deg": ANGLES,
                                      "predict_arcmin": [None if math.isnan(v) else v for v in values]}}
    atomic_write(HERE / "expected_v4.json", json.dumps(expected, indent=1) + "\n")


if __name__ == "__main__":
    main()

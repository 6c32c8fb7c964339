"""The methods the accuracy benchmarks compare, shared by bench_accuracy.py and bench_real_data.py."""

from encal.models import kind_names
from encal.paper.studies.comparison import PAPER_NETWORK  # 1:80:1 raw, trainlm, the paper's stopping rule

#: benchmark name -> (method of encal.fit, options)
METHODS = {
    "fourier top10": ("fourier", {"select": "top", "n_orders": 10}),
    "fourier cv": ("fourier", {"select": "cv"}),
    "lut linear": ("lut", {"interpolation": "linear"}),
    "lut cubic": ("lut", {"interpolation": "cubic"}),
    "ann periodic": ("ann", {}),
    "ann raw 1:80:1 lm": (PAPER_NETWORK.method, PAPER_NETWORK.options),
    "hybrid": ("hybrid", {}),
    "auto": ("auto", {}),
}

#: methods whose fit draws random numbers (they take a seed)
RANDOMISED = set(kind_names(randomised=True))

"""Every model on the test grid (the paper's Table 3 and Fig. 4).

Each model is fitted to the training calibration (0, 2, ..., 358 deg) and
judged on the test calibration (1, 3, ..., 359 deg), points it never saw, by
the residual ``observed error - predicted error``. The paper compares the
raw error, its Fourier-series method (the ten harmonics of largest amplitude)
and its 1:80:1 network; encal adds the lookup tables of the authors' earlier
work (linear and cubic) and its own default network (periodic input, which
is continuous at 0/360 deg). When the noise-free truth is known (the simulated
fleet), each RMS is also divided by the measurement floor, the RMS no model
can beat on that run.
"""

import time
from dataclasses import dataclass, field

import numpy as np

from ...models.fitting import evaluate, fit
from ...models.ann import DEFAULT_STOPPING
from ...analysis.profile import error_stats
from ..._core.limits import check_size
from ..._core.parameters import check_number, invalid
from ._checks import check_calibration, check_seed
from ._fits import task_seed
from ..._core.threads import single_blas_thread

__all__ = ["ModelSpec", "PAPER_STOPPING", "PAPER_NETWORK", "DEFAULT_MODELS", "ComparisonEntry", "Comparison",
           "compare_models"]


@dataclass(frozen=True)
class ModelSpec:
    """One model of the comparison: how :func:`encal.fit` makes it.

    Parameters
    ----------
    key : str
        Short name (``'fourier'``, ``'ann-paper'``); also the row key in tables and JSON.
    label : str
        Name printed in tables and figures.
    method : str
        ``method`` of :func:`encal.fit`.
    options : dict
        Options of the method.
    """

    key: str
    label: str
    method: str
    options: dict = field(default_factory=dict)

    @property
    def trained(self):
        """Whether the model is a network trained from random initial weights."""
        return self.method in ("ann", "hybrid", "auto")


#: The paper's rule for ending training, "stopped when the normalised rms error stops decreasing any
#: further", made concrete: stop when the RMS error has not fallen by 1 % over the last 20 epochs.
PAPER_STOPPING = {"plateau_patience": 20, "plateau_tol": 0.01}

#: The paper's network: 1:80:1, raw angle input, tansig, Levenberg-Marquardt, the paper's stopping rule.
PAPER_NETWORK = ModelSpec("ann-paper", "ANN 1:80:1 raw (paper)", "ann",
                          {"hidden": 80, "encoding": "raw", "algorithm": "trainlm", **PAPER_STOPPING})

#: The models of Table 3, in its column order.
DEFAULT_MODELS = (
    ModelSpec("fourier", "Fourier top-10 (paper)", "fourier", {"select": "top", "n_orders": 10}),
    ModelSpec("lut-linear", "LUT linear", "lut", {"interpolation": "linear"}),
    ModelSpec("lut-cubic", "LUT cubic", "lut", {"interpolation": "cubic"}),
    PAPER_NETWORK,
    # What encal.fit(method='ann') gives: its stop is spelled out because compare_models sets the epoch budget.
    ModelSpec("ann-periodic", "ANN periodic (encal)", "ann",
              {"encoding": "periodic", "algorithm": "trainlm", **DEFAULT_STOPPING["trainlm"]}),
)


@dataclass(frozen=True, eq=False)
class ComparisonEntry:
    """One row of Table 3: a model's residual on the test points.

    Attributes
    ----------
    key, label : str
        From the :class:`ModelSpec` (``'before'`` for the raw error).
    model : Model or None
        The fitted model (None for ``'before'``).
    stats : ErrorStats
        Statistics of the residual, arcmin.
    residual_arcmin : ndarray of shape (n,)
        Residual at every test point, arcmin.
    floor_arcmin : float or None
        Measurement floor of the test run, arcmin, when known.
    fit_time_s : float
        Time to fit the model, seconds.
    """

    key: str
    label: str
    model: object
    stats: object
    residual_arcmin: np.ndarray
    floor_arcmin: float | None
    fit_time_s: float = 0.0

    @property
    def rms_over_floor(self):
        """Residual RMS divided by the measurement floor (None when the floor is unknown)."""
        return None if self.floor_arcmin is None else self.stats.rms / self.floor_arcmin

    def as_dict(self):
        """JSON-ready: key, label, the residual statistics (``*_arcmin``) and ``rms_over_floor``."""
        data = {"model": self.key, "label": self.label, **self.stats.as_dict()}
        if self.floor_arcmin is not None:
            data["rms_over_floor"] = self.rms_over_floor
        return data


@dataclass(frozen=True, eq=False)
class Comparison:
    """Table 3 for one encoder: every model's residual on the test calibration.

    Attributes
    ----------
    encoder : str
    encoder_deg : ndarray of shape (n,)
        Encoder angles of the test points, degrees.
    entries : tuple of ComparisonEntry
        ``'before'`` first, then the models in the order given.
    floor_arcmin : float or None
        Measurement floor of the test run, arcmin.
    """

    encoder: str
    encoder_deg: np.ndarray
    entries: tuple
    floor_arcmin: float | None

    def entry(self, key):
        """The entry with this key."""
        for entry in self.entries:
            if entry.key == key:
                return entry
        raise KeyError(key)

    def as_dict(self):
        """JSON-ready: encoder, floor and one object per model."""
        return {"encoder": self.encoder, "n": int(self.encoder_deg.size), "floor_arcmin": self.floor_arcmin,
                "models": [entry.as_dict() for entry in self.entries]}

    def table(self):
        """Table 3 for this encoder."""
        from .tables import comparison_table

        return comparison_table({self.encoder: self})

    def plot(self, key="ann-paper", ax=None):
        """Fig. 4: one model's residual against the encoder angle (see :func:`encal.figures.plot_residuals`)."""
        from ...figures import plot_residuals

        return plot_residuals(self, key=key, ax=ax)


@single_blas_thread
def compare_models(train, test, *, models=DEFAULT_MODELS, floor_arcmin=None, epochs=1000, rng=0):
    """Fit every model to ``train`` and measure its residual on ``test`` (Table 3 for one encoder).

    Parameters
    ----------
    train, test : Calibration
        Training and test calibrations of one encoder.
    models : sequence of ModelSpec, default=DEFAULT_MODELS
        Models to compare: Fourier top-10, linear and cubic lookup tables, the paper's 1:80:1 raw network and
        encal's periodic network.
    floor_arcmin : float, optional
        Measurement floor of the test run (arcmin), when the truth is known.
    epochs : int, default=1000
        Epoch budget of the networks (the paper's network may stop earlier by :data:`PAPER_STOPPING`).
    rng : int, default=0
        Study seed; a network of N hidden nodes starts from the weights seeded by ``(rng, N, 0)``.

    Returns
    -------
    Comparison
    """
    where = "compare_models"
    train = check_calibration(train, "train", where)
    test = check_calibration(test, "test", where)
    seed = check_seed(rng, where)
    epochs = check_size("epochs", epochs, where)
    if floor_arcmin is not None:
        floor_arcmin = check_number(floor_arcmin, "floor_arcmin", where, low=0.0, low_open=True,
                                    note="arc-minutes, or None")
    keys = [spec.key for spec in models]
    if len(set(keys)) != len(keys) or "before" in keys:
        raise invalid("models", where, "a sequence of ModelSpec whose keys are distinct and not 'before'", models,
                      shown=f"the keys {keys}")
    floor = None if floor_arcmin is None else float(floor_arcmin)
    raw = test.errors_arcmin
    entries = [ComparisonEntry("before", "before compensation", None, error_stats(raw), raw.copy(), floor)]
    for spec in models:
        options = dict(spec.options)
        start = time.perf_counter()
        if spec.trained:
            hidden = options.get("hidden", _default_hidden(options))
            options.setdefault("epochs", epochs)
            model = fit(train, spec.method, rng=task_seed(seed, hidden, 0), **options)
        else:
            model = fit(train, spec.method, **options)
        fit_time = time.perf_counter() - start
        evaluation = evaluate(model, test)
        entries.append(ComparisonEntry(spec.key, spec.label, model, evaluation.after,
                                       evaluation.residual_arcmin, floor, fit_time))
    return Comparison(train.name or test.name, test.encoder_deg.copy(), tuple(entries), floor)


def _default_hidden(options):
    from ...models.ann import DEFAULT_HIDDEN

    return DEFAULT_HIDDEN[options.get("encoding", "periodic")]

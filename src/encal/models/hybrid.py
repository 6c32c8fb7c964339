"""Hybrid error model: a Fourier series of the dominant orders plus a small network on the rest.

A resolver's or magnetic encoder's error is mostly a handful of harmonics, some
of high order (a resolver's 16th, 32nd, ...), which a Fourier series fits
exactly and cheaply but a small network cannot; a local defect (a scratch on a
code disc, a dent in a magnet) is the opposite, and a series long enough to
follow it also follows the noise everywhere else. The hybrid fits the
``n_orders`` largest harmonics by least squares (the paper's Fourier model),
then a small periodic 1:N:1 network to what they leave.

The two parts are fitted one after the other, not jointly: a joint fit
(variable projection, the Fourier coefficients solved inside every training
step) was tried and was no more accurate on simulated resolvers and local
defects, so the simpler sequential fit is kept.
"""

import numbers

import numpy as np

from ..errors import ModelFileError
from ..parameters import check_int, invalid
from ..profile import profile_arrays
from .ann import ANNModel, fit_ann
from .base import Model
from .fourier import FourierModel, fit_fourier

__all__ = ["HybridModel", "fit_hybrid"]


class HybridModel(Model):
    """The sum of a Fourier-series model and a network model.

    Parameters
    ----------
    fourier : FourierModel
        The dominant harmonics, arc-minutes.
    ann : ANNModel
        The network fitted to the residual of ``fourier``, arc-minutes.
    encoder, training : dict, optional
        See :class:`~encal.models.base.Model`.
    """

    kind = "hybrid"

    def __init__(self, fourier, ann, *, encoder=None, training=None):
        super().__init__(encoder=encoder, training=training)
        self.fourier = fourier
        self.ann = ann

    def _predict(self, theta_deg):
        return self.fourier._predict(theta_deg) + self.ann._predict(theta_deg)

    @property
    def evaluation_width(self):
        return max(self.fourier.evaluation_width, self.ann.evaluation_width)

    def _table_bound(self):
        parts = [self.fourier._table_bound(), self.ann._table_bound()]
        return None if None in parts else tuple(map(sum, zip(*parts)))

    def free_parameters(self):
        return self.fourier.free_parameters() + self.ann.free_parameters()

    def parameters(self):
        return {"fourier": self.fourier.parameters(), "ann": self.ann.parameters()}

    @classmethod
    def from_parameters(cls, parameters, *, encoder=None, training=None):
        if not (isinstance(parameters, dict) and isinstance(parameters.get("fourier"), dict)
                and isinstance(parameters.get("ann"), dict)):
            shown = sorted(parameters) if isinstance(parameters, dict) else type(parameters).__name__
            raise ModelFileError("hybrid model parameters must be an object with the objects 'fourier' and "
                                 f"'ann' (docs/model-file.md). Got {shown} instead.")
        return cls(FourierModel.from_parameters(parameters["fourier"]),
                   ANNModel.from_parameters(parameters["ann"]), encoder=encoder, training=training)

    def __repr__(self):
        name = self.encoder.get("name") or "unnamed encoder"
        return (f"<HybridModel orders={self.fourier.orders.tolist()} + "
                f"1:{self.ann.hidden}:1 network for {name}>")


def fit_hybrid(theta_enc_deg, error_arcmin, *, n_orders=10, hidden=8, algorithm="trainlm", epochs=300,
               restarts=3, rng=None, **train_options):
    """Fit the ``n_orders`` largest harmonics, then a periodic network to their residual.

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees.
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.
    n_orders : int, default=10
        Number of harmonics of largest amplitude in the Fourier part (see
        :func:`~encal.models.fourier.fit_fourier` with ``select='top'``).
    hidden : int, default=8
        Hidden nodes of the network part (a 2-input ``periodic`` 1:N:1 network).
    algorithm : str, default='trainlm'
        Training algorithm of the network part, MATLAB's name.
    epochs : int, default=300
        Maximum training epochs of the network part. The residual is small and
        mostly local, so a short run suffices; it also bounds the time of an auto fit.
    restarts : int, default=3
        Train the network from this many random starts and keep the one that fits the residual
        best. A small network on a local feature often stops in a poor local minimum
        (docs/model-selection.md), and three starts cost little.
    rng : None, int >= 0 or numpy.random.Generator
        Seed of the network's initial weights; the same seed gives the same model. ``None``
        draws a seed and records it.
    **train_options
        Passed to :func:`~encal.models.ann.fit_ann` (``goal``, ``activation``, ``mu``, ...).

    Returns
    -------
    HybridModel
        ``training`` holds the options and the ``fourier`` and ``ann`` parts' own training records.

    Examples
    --------
    >>> theta = np.arange(0.0, 360.0, 2.0)
    >>> bump = 2.0 * np.exp(-0.5 * ((theta - 100.0) / 4.0) ** 2)
    >>> model = fit_hybrid(theta, 5.0 * np.sin(np.radians(theta)) + bump, rng=0)
    >>> float(np.sqrt(np.mean((model.predict(theta) - 5.0 * np.sin(np.radians(theta)) - bump) ** 2))) < 0.1
    True
    """
    theta, error = profile_arrays(theta_enc_deg, error_arcmin, "fit_hybrid")
    restarts = check_int(restarts, "restarts", "fit_hybrid", low=1)
    fourier = fit_fourier(theta, error, n_orders=n_orders, select="top")
    residual = error - fourier.predict(theta)
    generators, seed = _start_generators(rng, restarts)
    fits = [fit_ann(theta, residual, hidden=hidden, algorithm=algorithm, encoding="periodic", epochs=epochs,
                    rng=generator, **train_options) for generator in generators]
    ann = min(fits, key=lambda network: np.mean((residual - network.predict(theta)) ** 2))
    training = {
        "algorithm": algorithm,
        "epochs": ann.training.get("epochs"),
        "seed": seed,
        "options": {"n_orders": n_orders, "hidden": hidden, "algorithm": algorithm, "epochs": epochs,
                    "restarts": restarts, **ann.training.get("options", {})},
        "fourier": fourier.training,
        "ann": ann.training,
    }
    fourier.training, ann.training = {}, {}
    return HybridModel(fourier, ann, training=training)


def _start_generators(rng, count):
    """``(generators, seed)``: one generator per network start, and the int seed to record (or None).

    An int seed (or, for None, a freshly drawn one) is split into independent streams, so the
    starts of seeds 0 and 1 share nothing; a Generator is used for all starts in turn.
    """
    if rng is None:
        rng = int(np.random.SeedSequence().generate_state(1)[0])
    if isinstance(rng, numbers.Integral) and not isinstance(rng, bool) and rng >= 0:
        return [np.random.default_rng(s) for s in np.random.SeedSequence(int(rng)).spawn(count)], int(rng)
    if isinstance(rng, np.random.Generator):
        return [rng] * count, None
    raise invalid("rng", "fit_hybrid", "None, an int >= 0 or a numpy.random.Generator", rng)

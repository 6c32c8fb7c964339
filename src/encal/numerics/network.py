"""The paper's 1:N:1 network: its inputs, scaling, weights and forward pass.

One hidden layer of ``N`` neurons with a sigmoid activation (``tansig`` or
``logsig``) and a linear output neuron, as MATLAB's ``feedforwardnet`` builds
it, including MATLAB's ``mapminmax`` scaling of inputs and target to [-1, 1]
and its Nguyen-Widrow initialisation (``initnw``).

Input encodings of the encoder angle θ (degrees):

``'raw'``
    One input, θ itself (the paper's network). The fitted function of θ on
    [0, 360) is not periodic: its values at 0° and just below 360° are unrelated,
    so the model jumps where the encoder angle wraps.
``'periodic'``
    Two inputs, ``cos θ`` and ``sin θ``. The network is then a continuous,
    periodic function of θ by construction.

Flat weight vector
------------------
Training algorithms see the weights as one vector ``w`` of
``n_params = N * (n_inputs + 2) + 1`` values (1:80:1: 241 for ``'raw'``,
321 for ``'periodic'``), laid out as::

    w = [W1.T.ravel(),  # N × n_inputs, column by column: W1[j, k] is w[k * N + j]
         b1,            # N hidden biases
         W2,            # N output weights
         b2]            # 1 output bias

(``W1`` column by column, as MATLAB's ``IW{1,1}(:)``, keeps each input's
block of the Jacobian contiguous.)

The network's output is ``y_n = W2 · f(W1 x_n + b1) + b2`` for a normalised
input vector ``x_n``; ``docs/model-file.md`` stores the same arrays.

This module evaluates a network; :mod:`encal.training.network` trains one (initial
weights, the least-squares problem and its Jacobian). Predicting with a network
model needs this module alone, not the optimisers.
"""

from dataclasses import dataclass

import numpy as np

from .._core.errors import InputError

__all__ = [
    "ENCODINGS",
    "ACTIVATIONS",
    "ACTIVE_HALF_WIDTH",
    "MapMinMax",
    "encode_angles",
    "n_weights",
    "pack_weights",
    "unpack_weights",
    "forward",
]

#: encoding name -> number of network inputs
ENCODINGS = {"raw": 1, "periodic": 2}


def _tansig_slope(h):
    return 1.0 - h * h


def _logsig(z, out=None):
    """The logistic function 1 / (1 + e^-z), SciPy's ``expit`` (imported on first use: a model file's reader
    needs no SciPy)."""
    from scipy.special import expit

    return expit(z, out=out)


def _logsig_slope(h):
    return h * (1.0 - h)


#: name -> (activation f(z), its derivative written in terms of h = f(z))
ACTIVATIONS = {
    "tansig": (np.tanh, _tansig_slope),
    "logsig": (_logsig, _logsig_slope),
}

#: Half-width of each activation's active input region, MATLAB's
#: ``tansig('active')`` = [-2, 2] and ``logsig('active')`` = [-4, 4].
ACTIVE_HALF_WIDTH = {"tansig": 2.0, "logsig": 4.0}


@dataclass(frozen=True)
class MapMinMax:
    """MATLAB's ``mapminmax`` to [-1, 1]: ``x_n = gain · (x − offset) − 1``.

    Attributes
    ----------
    offset : float or ndarray of shape (k,)
        Minimum of each column of the data the settings were fitted to.
    gain : float or ndarray of shape (k,)
        ``2 / (max − min)`` of each column; 1 where ``max == min``.
    """

    offset: np.ndarray
    gain: np.ndarray

    @classmethod
    def fit(cls, values):
        """Settings that map the range of ``values`` (shape (m,) or (m, k)) onto [-1, 1]."""
        values = np.asarray(values, dtype=float)
        low, high = values.min(axis=0), values.max(axis=0)
        span = np.asarray(high - low, dtype=float)
        with np.errstate(over="ignore"):
            gain = 2.0 / np.where(span > 0, span, 2.0)  # gain 1 where max == min
        gain = np.where(np.isfinite(gain), gain, 1.0)
        return cls(offset=np.asarray(low, dtype=float)[()], gain=gain[()])

    def apply(self, values):
        """Scale raw values to normalised ones."""
        return self.gain * (np.asarray(values, dtype=float) - self.offset) - 1.0

    def reverse(self, normalised):
        """Map normalised values back to raw units."""
        return (np.asarray(normalised, dtype=float) + 1.0) / self.gain + self.offset


def encode_angles(theta_deg, encoding):
    """Network inputs for encoder angles.

    Parameters
    ----------
    theta_deg : array-like of shape (m,)
        Encoder angles in degrees.
    encoding : {'raw', 'periodic'}
        ``'raw'``: the angle in degrees; ``'periodic'``: ``cos θ`` and ``sin θ``.

    Returns
    -------
    ndarray of shape (m, n_inputs)
        Un-normalised inputs (``n_inputs`` is 1 or 2).
    """
    theta = np.asarray(theta_deg, dtype=float).reshape(-1)
    if encoding == "raw":
        return theta[:, None]
    if encoding == "periodic":
        radians = np.deg2rad(theta)
        return np.column_stack((np.cos(radians), np.sin(radians)))
    raise InputError(f"encoding must be one of {sorted(ENCODINGS)}. Got {encoding!r} instead.")


def n_weights(n_inputs, hidden):
    """Length of the flat weight vector of a ``n_inputs``:``hidden``:1 network."""
    return hidden * (n_inputs + 2) + 1


def unpack_weights(w, n_inputs, hidden):
    """Views ``(W1, b1, W2, b2)`` into the flat weight vector ``w`` (see the module docstring)."""
    w = np.asarray(w, dtype=float)
    k = hidden * n_inputs
    W1 = w[:k].reshape(n_inputs, hidden).T
    b1 = w[k:k + hidden]
    W2 = w[k + hidden:k + 2 * hidden]
    return W1, b1, W2, w[-1]


def pack_weights(W1, b1, W2, b2):
    """The flat weight vector of the arrays ``W1`` (N × n_inputs), ``b1`` (N), ``W2`` (N), ``b2``."""
    parts = (np.transpose(W1), b1, W2, b2)
    return np.concatenate([np.ravel(np.asarray(part, dtype=float)) for part in parts])


def forward(inputs, W1, b1, W2, b2, activation="tansig"):
    """Network output for normalised inputs.

    Parameters
    ----------
    inputs : ndarray of shape (m, n_inputs)
        mapminmax'ed inputs.
    W1, b1, W2, b2 : ndarray
        Weights, shapes (N, n_inputs), (N,), (N,), ().
    activation : {'tansig', 'logsig'}

    Returns
    -------
    ndarray of shape (m,)
        Normalised output ``y_n``.
    """
    f = ACTIVATIONS[activation][0]
    return f(inputs @ W1.T + b1) @ W2 + b2

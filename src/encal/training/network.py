"""The paper's 1:N:1 network as a least-squares training problem.

The network itself (input encodings, ``mapminmax`` scaling, the flat weight
vector, the forward pass) is defined in :mod:`encal.numerics.network`, which a
model needs to predict; this module adds what training needs: MATLAB's
Nguyen-Widrow initial weights (``initnw``) and the training problem with its
analytic Jacobian. Its names of :mod:`encal.numerics.network` are that module's.
"""

import numpy as np
from scipy.linalg.blas import dsyrk

from .._core.errors import InputError
from ..numerics.network import (
    ACTIVATIONS,
    ACTIVE_HALF_WIDTH,
    ENCODINGS,
    MapMinMax,
    encode_angles,
    forward,
    n_weights,
    pack_weights,
    unpack_weights,
)

__all__ = [
    "ENCODINGS",
    "ACTIVATIONS",
    "MapMinMax",
    "encode_angles",
    "n_weights",
    "pack_weights",
    "unpack_weights",
    "nguyen_widrow",
    "forward",
    "NetworkProblem",
]


def nguyen_widrow(n_inputs, hidden, activation="tansig", rng=None):
    """Initial weights by the Nguyen-Widrow rule, as MATLAB's ``initnw`` computes them.

    Nguyen, D. and Widrow, B. (1990), "Improving the learning speed of 2-layer
    neural networks by choosing initial values of the adaptive weights",
    Proc. IJCNN, vol. 3, pp. 21-26; MATLAB Deep Learning Toolbox ``initnw``.

    Hidden neurons get weight vectors of length ``0.7 · N^(1/n_inputs)`` in
    random directions and biases spread evenly over the same magnitude, then
    both are scaled to the activation's active region ([-2, 2] for tansig,
    [-4, 4] for logsig); the inputs are assumed mapminmax'ed to [-1, 1]. The
    linear output neuron's weights and bias are uniform on [-1, 1] (MATLAB's
    ``rands``, which ``initnw`` uses for a layer without a finite active region).

    Parameters
    ----------
    n_inputs, hidden : int
        Network size ``n_inputs``:``hidden``:1.
    activation : {'tansig', 'logsig'}, default='tansig'
    rng : None, int or numpy.random.Generator
        The same seed gives bit-identical weights.

    Returns
    -------
    ndarray of shape (n_weights(n_inputs, hidden),)
    """
    rng = np.random.default_rng(rng)
    magnitude = 0.7 * hidden ** (1.0 / n_inputs)
    directions = rng.standard_normal((hidden, n_inputs))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    W1 = magnitude * directions
    if hidden == 1:
        b1 = np.zeros(1)
    else:
        b1 = magnitude * np.linspace(-1.0, 1.0, hidden) * np.sign(W1[:, 0])
    half_width = ACTIVE_HALF_WIDTH[activation]
    W2 = rng.uniform(-1.0, 1.0, hidden)
    b2 = rng.uniform(-1.0, 1.0)
    return pack_weights(half_width * W1, half_width * b1, W2, b2)


class NetworkProblem:
    """Training problem of a 1:N:1 network: an :class:`encal.training.Objective`.

    Residuals are ``y_n − t_n`` in normalised target units (the target
    mapminmax'ed to [-1, 1]); the Jacobian is analytic. Work is vectorised over
    samples.

    Parameters
    ----------
    inputs : array-like of shape (m, n_inputs)
        Normalised network inputs.
    targets : array-like of shape (m,)
        Normalised targets.
    hidden : int
        Number of hidden neurons N.
    activation : {'tansig', 'logsig'}, default='tansig'

    Attributes
    ----------
    n_params, n_samples : int
    encoding : str or None
        Set by :meth:`from_angles`, with ``input_scaling`` and ``target_scaling``
        (:class:`MapMinMax`).
    """

    def __init__(self, inputs, targets, hidden, activation="tansig"):
        self.inputs = np.ascontiguousarray(inputs, dtype=float)
        self.targets = np.ascontiguousarray(targets, dtype=float).reshape(-1)
        if self.inputs.ndim != 2 or self.inputs.shape[0] != self.targets.size:
            raise InputError(
                f"inputs must have shape (m, n_inputs) with m = {self.targets.size} targets. "
                f"Got shape {self.inputs.shape} instead."
            )
        self.hidden = int(hidden)
        self.activation = activation
        self._f, self._slope = ACTIVATIONS[activation]
        self.n_samples, self.n_inputs = self.inputs.shape
        self.n_params = n_weights(self.n_inputs, self.hidden)
        self.encoding = None
        self.input_scaling = None
        self.target_scaling = None
        self._last = (None, None, None)
        self._slopes = None  # back-propagated slopes at the weights of self._last
        self._input_outer = None
        self._jacobian = None

    @classmethod
    def from_angles(cls, theta_deg, error_arcmin, hidden, *, encoding="periodic",
                    activation="tansig", input_scaling=None, target_scaling=None):
        """The problem of fitting errors (arcmin) as a function of encoder angles (degrees).

        ``input_scaling`` and ``target_scaling`` default to mapminmax settings
        fitted to these data; pass a training problem's settings to build its
        validation problem.
        """
        inputs = encode_angles(theta_deg, encoding)
        targets = np.asarray(error_arcmin, dtype=float).reshape(-1)
        if input_scaling is None:
            input_scaling = MapMinMax.fit(inputs)
        if target_scaling is None:
            target_scaling = MapMinMax.fit(targets)
        problem = cls(input_scaling.apply(inputs), target_scaling.apply(targets), hidden,
                      activation)
        problem.encoding = encoding
        problem.input_scaling = input_scaling
        problem.target_scaling = target_scaling
        return problem

    def unpack(self, w):
        """``(W1, b1, W2, b2)`` views of the flat weight vector."""
        return unpack_weights(w, self.n_inputs, self.hidden)

    def initial_weights(self, rng=None):
        """Nguyen-Widrow initial weights (see :func:`nguyen_widrow`)."""
        return nguyen_widrow(self.n_inputs, self.hidden, self.activation, rng)

    def _forward(self, w):
        # The accepted trial point of a Levenberg-Marquardt epoch is evaluated
        # again for its Jacobian: reuse the last forward pass.
        cached_w, h, y = self._last
        # The weights' bytes identify the pass: a cheaper test than np.array_equal, and as safe (equal
        # bytes give equal outputs).
        key = np.asarray(w, dtype=float).tobytes()
        if cached_w != key:
            W1, b1, W2, b2 = self.unpack(w)
            # One input: its outer product with the weights, exactly the matrix product's values
            # (each a single rounded product) without the matrix product's overhead on an inner size of 1.
            z = self.inputs * W1[:, 0] if self.n_inputs == 1 else self.inputs @ W1.T
            z += b1
            h = self._f(z, out=z)
            y = h @ W2 + b2
            self._last = (key, h, y)
            self._slopes = None
        return h, y

    def outputs(self, w):
        """Normalised network outputs at the training inputs, shape (m,)."""
        return self._forward(w)[1].copy()

    def residuals(self, w):
        return self._forward(w)[1] - self.targets

    def residuals_and_jacobian(self, w):
        h, y = self._forward(w)
        W2 = self.unpack(w)[2]
        N = self.hidden
        # d y / d b1_j = W2_j f'(z_j); d y / d W1_jk = that times input k.
        d_hidden = self._hidden_slopes(h, W2)
        # One Jacobian array per problem, refilled by every call (a training algorithm is done with
        # a Jacobian when it asks for the next one): no m x n allocation per epoch.
        if self._jacobian is None:
            self._jacobian = np.empty((self.n_samples, self.n_params))
        J = self._jacobian
        for k in range(self.n_inputs):  # one or two inputs
            np.multiply(d_hidden, self.inputs[:, k:k + 1], out=J[:, k * N:(k + 1) * N])
        n_w1 = N * self.n_inputs
        J[:, n_w1:n_w1 + N] = d_hidden
        J[:, n_w1 + N:n_w1 + 2 * N] = h
        J[:, -1] = 1.0
        return y - self.targets, J

    def _hidden_slopes(self, h, W2):
        """``f'(z) * W2`` (m × N) at the last forward pass, computed once for the Jacobian and ``J Jᵀ``."""
        if self._slopes is None:
            self._slopes = self._slope(h)
            self._slopes *= W2
        return self._slopes

    def jacobian_outer(self, w):
        """``J Jᵀ`` (m × m, lower triangle only), without forming J.

        Row i of the first-layer blocks of J is ``d_i ⊗ [x_i, 1]`` (``d_i`` the
        back-propagated slopes), so ``J Jᵀ = (D Dᵀ) ∘ (X Xᵀ + 1) + H Hᵀ + 1``:
        two rank-N products instead of one of rank ``n_params`` (about half the work).
        Levenberg-Marquardt uses it when the network has more weights than points.
        """
        h, _ = self._forward(w)
        d_hidden = self._hidden_slopes(h, self.unpack(w)[2])
        if self._input_outer is None:
            # Fortran-ordered as syrk's result, so that the element-wise product runs over contiguous
            # memory (the same values: a matrix's memory order does not change its entries).
            self._input_outer = np.asfortranarray(self.inputs @ self.inputs.T + 1.0)
        # C-ordered (m, N) arrays transposed are Fortran-ordered: BLAS reads them in place.
        outer = dsyrk(1.0, d_hidden.T, trans=1, lower=1)
        outer *= self._input_outer
        outer = dsyrk(1.0, h.T, trans=1, lower=1, beta=1.0, c=outer, overwrite_c=1)
        outer += 1.0
        return outer

    def mse(self, w):
        r = self.residuals(w)
        return float(r @ r) / self.n_samples

    def mse_and_gradient(self, w):
        h, y = self._forward(w)
        r = y - self.targets
        m = self.n_samples
        back = (self._slope(h) * self.unpack(w)[2]) * r[:, None]
        grad = np.concatenate([(self.inputs.T @ back).ravel(), back.sum(axis=0), r @ h, [r.sum()]])
        return float(r @ r) / m, (2.0 / m) * grad

"""Type-II maximum likelihood for a Fourier series with a spectral prior (the spectral model's numerics).

The model (docs/model-selection.md): ``y = Φ c + e``, one column of ``Φ`` per cosine or sine
term up to a highest order, independent priors ``c_j ~ N(0, s_j)`` with

    s_j = A ν_j^(-β) + line(ν_j)   (ν_j ≥ 1, β ≥ 1),   s_0 vague,

and white noise ``e ~ N(0, σ² I)``. The data enter only through the Gram matrix ``G = ΦᵀΦ``,
the projections ``b = Φᵀy``, ``yᵀy`` and ``n``: on a uniform complete grid ``G`` is
diagonal (the FFT path, everything O(P)); otherwise it is a dense ``P × P`` matrix built
from trigonometric moments (the Fourier-feature path, O(P³) per evaluation).

This module knows nothing of angles in degrees or of model files: it maximises the log
marginal likelihood (the evidence) over ``A, β, σ²`` and the line variances, admitting a
line where it raises the evidence by more than ``threshold`` nats, and returns the
posterior of the coefficients.
"""

import math
from dataclasses import dataclass, field

import numpy as np

from ..numerics.triangular import lower_triangular_inverse

__all__ = ["Design", "Hyper", "Posterior", "evidence", "fit_hyperparameters", "LINE_THRESHOLD_NATS"]

#: A line is admitted when it raises the log marginal likelihood by more than this.
LINE_THRESHOLD_NATS = 3.0
#: Blind, the noise is raised along the evidence's ridge while the evidence stays within this (nats).
NOISE_SLACK_NATS = 1.0
#: ... when the maximum's noise variance is below this fraction of the periodogram's flat level (a collapse).
COLLAPSE_FRACTION = 0.25
#: The noise variance estimated is at least ``exp(-NOISE_FLOOR_NATS)`` (2e-9) of the data's mean square: its standard
#: deviation 4.5e-5 of the data's RMS, far below any encoder's noise (benchmarks/bench_noise_floor.py: the real
#: files' noise variances are 4e5 times it or more). Below it the evidence of a noise-free series cannot be
#: computed in double precision: at the former floor (exp(-32)) the posterior precision's condition reached 1e20,
#: its Cholesky factor needed the jitter, and a series of 16 orders known at 288 of 360 degrees (a cross-validation
#: fold of a self-calibration's output) was predicted 1e5 to 5e7 arcmin off between its points after 2,000
#: evaluations; at this floor, within 1e-7 arcmin after 6 (tests/models/test_spectral.py).
NOISE_FLOOR_NATS = 20.0
#: Bounds of the background exponent β (the background must decay: safeguard 2).
EXPONENT_BOUNDS = (1.0, 8.0)
#: Prior variance of order 0, in units of the data's mean square: vague.
_VAGUE = 100.0
_MAX_ROUNDS = 40
#: Minus the log evidence per reading where the posterior cannot be computed (n times it in nats).
_FAILED_OBJECTIVE = 1e10
_LINES_PER_ROUND = 8
#: A search that ends with lines on more than this fraction of the orders has collapsed (the background
#: shrank under them); it is repeated from a power law through the periodogram (safeguard 1).
COLLAPSE_LINE_FRACTION = 1.0 / 3.0


@dataclass
class Design:
    """Sufficient statistics of a Fourier-feature regression.

    Attributes
    ----------
    orders : ndarray of int of shape (P,)
        Order of each column.
    shifts : ndarray of shape (P,)
        Column ``j`` is ``cos(ν_j θ - ψ_j)``: 0 for a cosine, π/2 for a sine, ``ν φ`` for the
        single Nyquist column of a regular grid of phase ``φ``.
    gram : ndarray of shape (P,) or (P, P)
        ``ΦᵀΦ`` (its diagonal when the columns are orthogonal).
    projection : ndarray of shape (P,)
        ``Φᵀy``.
    yy : float
        ``yᵀy``.
    n : int
        Number of readings.
    lineable : ndarray of bool of shape (P,)
        Columns whose order may carry a line (every order but 0).
    nyquist : int, optional
        When the series runs past the Nyquist order of the stops: that order. A line above it needs
        ``beyond_nyquist_nats`` more evidence and is not started from the periodogram.
    beyond_nyquist_nats : float
    rounding : ndarray of shape (P,), optional
        Variance per column that a quantised encoder's rounding puts there beyond its white share (on a
        uniform grid): part of every column's prior variance, so that the evidence explains it, but not of
        the profile (:func:`signal_part` takes it out of the posterior).
    picked : ndarray of int, optional
        Orders carried because a scan of the residual showed a line there (above a cap on the orders), not
        as part of a contiguous band: lines there are expected and the collapse safeguard does not count them.
    """

    orders: np.ndarray
    shifts: np.ndarray
    gram: np.ndarray
    projection: np.ndarray
    yy: float
    n: int
    lineable: np.ndarray
    nyquist: int = None
    beyond_nyquist_nats: float = 0.0
    rounding: np.ndarray = None
    picked: np.ndarray = None

    def extra_nats(self, orders):
        """Nats a line at each of ``orders`` needs beyond the threshold: ``beyond_nyquist_nats`` above
        :attr:`nyquist` (an order that is only partly aliased to one below it), else 0."""
        orders = np.asarray(orders)
        if self.nyquist is None:
            return np.zeros(orders.shape)
        return np.where(orders > self.nyquist, self.beyond_nyquist_nats, 0.0)

    @property
    def diagonal(self):
        return self.gram.ndim == 1

    @property
    def scale(self):
        """Mean square of the data (a variance scale for bounds and the vague prior)."""
        return max(self.yy / max(self.n, 1), 1e-300)


@dataclass
class Hyper:
    """Hyperparameters: background ``A ν^-β``, noise variance, lines (order -> variance), flat part.

    ``flat`` is a prior variance added to every order above 0: a flat (white) part of the profile.
    The evidence cannot tell it from the noise on a uniform grid; it is set by
    :func:`split_average`, never optimised.
    """

    amplitude: float
    exponent: float
    noise_var: float
    lines: dict = field(default_factory=dict)
    noise_fixed: bool = False
    flat: float = 0.0

    def variances(self, design):
        """Prior variance of every column."""
        return self._variances(design, _work(design))[0]

    def _variances(self, design, work):
        """The prior variances and the background's part of them (one array each)."""
        s = np.empty(design.orders.size)
        background = self.amplitude * work.positive_orders ** (-self.exponent)
        s[work.positive] = background
        s[work.not_positive] = _VAGUE * design.scale
        if self.flat:
            s[work.positive] += self.flat
        if self.lines:
            columns, _, counts = work.line_columns(tuple(self.lines))
            s[columns] += np.repeat(list(self.lines.values()), counts)  # one addition per column
        if design.rounding is not None:
            s = s + design.rounding
        return s, background


@dataclass
class Posterior:
    """Evidence and posterior at fixed hyperparameters.

    Attributes
    ----------
    log_evidence : float
        ``log p(y | hyperparameters)`` in nats.
    mean : ndarray of shape (P,)
        Posterior mean of the coefficients.
    covariance : ndarray of shape (P,) or (P, P)
        Posterior covariance (its diagonal on the FFT path).
    grad_log_variance : ndarray of shape (P,)
        ``∂ log p / ∂ log s_j``.
    grad_log_noise : float
        ``∂ log p / ∂ log σ²``.
    spread : ndarray of shape (S, P), optional
        For a mixture of posteriors (:func:`split_average`): the deviation of each component's mean
        from the mixture's, times the square root of its weight; the mixture's covariance is
        ``covariance + spreadᵀ spread``.
    """

    log_evidence: float
    mean: np.ndarray
    covariance: np.ndarray
    grad_log_variance: np.ndarray
    grad_log_noise: float
    spread: np.ndarray = None


def evidence(design, variances, noise_var, covariance=True):
    """The log marginal likelihood, its gradient and the posterior (see the module docstring).

    With ``d = √s`` and ``B = I + d G d / σ²`` (symmetric, eigenvalues >= 1):
    ``log p = -½ [n log 2πσ² + log|B| + yᵀy/σ² - uᵀB⁻¹u]``, ``u = d b / σ²``;
    posterior mean ``d B⁻¹ u``, covariance ``d B⁻¹ d``. With ``covariance=False`` the general
    path computes only the diagonal of ``B⁻¹`` (all the gradient needs) and returns no covariance.
    On the general path the last few results are kept: the optimiser asks for the same point again (about 1
    evaluation in 20). A result is shared by those callers, which only read it.
    """
    if design.diagonal:
        return _evidence(design, variances, noise_var, covariance)
    work = _work(design)
    key = (np.asarray(variances, dtype=float).tobytes(), float(noise_var), bool(covariance),
           design.projection.tobytes(), design.yy, design.n)
    for known, post in work.recent:
        if known == key:
            return post
    post = _evidence(design, variances, noise_var, covariance)
    work.recent = [(key, post)] + work.recent[: _RECENT - 1]
    return post


#: Results of the general path kept per design (see :func:`evidence`).
_RECENT = 3


def _evidence(design, variances, noise_var, covariance):
    s, sigma2 = variances, noise_var
    d = np.sqrt(s)
    u = d * design.projection / sigma2
    n, yy = design.n, design.yy
    if design.diagonal:
        g = design.gram
        big_b = 1.0 + s * g / sigma2
        z = u / big_b
        inverse_diagonal = 1.0 / big_b
        logdet = float(np.sum(np.log(big_b)))
        mean = d * z
        covariance = s * inverse_diagonal
        residual2 = yy - 2.0 * design.projection @ mean + np.sum(g * mean**2)
    else:
        lapack = _lapack()
        g = design.gram
        work = _work(design)
        factor = _cholesky(lambda out: _precision(work.fortran_gram, d, sigma2, out), work.buffer)
        z = lapack.dpotrs(factor, u, lower=1)[0]
        logdet = 2.0 * float(np.log(factor.diagonal()).sum())
        # B⁻¹ = L⁻ᵀ L⁻¹ (L⁻¹ by blocks: LAPACK's dtrtri, as dpotri calls it, took 60 % of an evaluation)
        inverse_factor = lower_triangular_inverse(factor)
        if covariance:
            lower, info = lapack.dlauum(inverse_factor, lower=1, overwrite_c=1)  # B⁻¹'s lower triangle
            inverse = lower.T.copy()  # C order; its upper triangle (and diagonal) from B⁻¹'s lower triangle
            np.copyto(inverse, lower, where=work.strictly_lower)
            inverse_diagonal = inverse.diagonal().copy()
        else:
            # the diagonal of B⁻¹ is the column sums of squares of L⁻¹ (upper triangle zero)
            inverse_diagonal = np.einsum("ij,ij->j", inverse_factor, inverse_factor)
        mean = d * z
        covariance = d[:, None] * inverse * d[None, :] if covariance else None
        residual2 = yy - 2.0 * design.projection @ mean + mean @ g @ mean
    log_p = -0.5 * (n * math.log(2.0 * math.pi * sigma2) + logdet + yy / sigma2 - u @ z)
    grad_s = 0.5 * (z**2 + inverse_diagonal - 1.0)
    grad_noise = 0.5 * (max(residual2, 0.0) / sigma2 + s.size - float(inverse_diagonal.sum()) - n)
    return Posterior(float(log_p), mean, covariance, grad_s, float(grad_noise))


def _lapack():
    """SciPy's LAPACK wrappers, imported by a fit (not by a spectral model file's reader)."""
    global _lapack_module
    if _lapack_module is None:
        from scipy.linalg import lapack

        _lapack_module = lapack
    return _lapack_module


_lapack_module = None


def signal_part(design, variances, noise_var, post):
    """The posterior of the profile alone when the prior variances include the rounding's (``design.rounding``).

    With prior variances ``S = S_p + R`` (profile, rounding; diagonal) the profile's posterior mean is
    ``S_p S⁻¹`` times the whole's, and its covariance ``S_p - D (S - Σ) D`` with ``D = S_p S⁻¹`` and ``Σ``
    the whole's posterior covariance. Without rounding the posterior is returned as it is.
    """
    if design.rounding is None or post.covariance is None:
        return post
    profile = np.maximum(variances - design.rounding, 0.0)
    share = np.where(variances > 0, profile / np.maximum(variances, 1e-300), 0.0)
    if design.diagonal:
        covariance = np.maximum(profile - share**2 * (variances - post.covariance), 0.0)
    else:  # Σ_p - D (S - Σ) D with D = S_p S⁻¹, exact for any design
        covariance = -share[:, None] * (np.diag(variances) - post.covariance) * share[None, :]
        covariance[np.diag_indices_from(covariance)] += profile
    return Posterior(post.log_evidence, share * post.mean, covariance, post.grad_log_variance, post.grad_log_noise)


def _precision(gram, d, sigma2, out):
    """``B = I + d G d / σ²`` written into ``out`` (Fortran order, for LAPACK without a copy)."""
    np.multiply(d[:, None], gram, out=out)
    np.multiply(out, d[None, :] / sigma2, out=out)
    out.ravel(order="F")[:: out.shape[0] + 1] += 1.0  # the diagonal, through a view of the buffer
    return out


class _Work:
    """What every evaluation of one design reuses: a ``P × P`` buffer, the columns of each order, recent results.

    Made again when the design's Gram matrix, orders or lineable columns are other arrays; a design's arrays
    are never written in place (the kept results and the Fortran-ordered copy of the Gram matrix assume it).
    """

    def __init__(self, design):
        self.gram, self.orders, self.lineable = design.gram, design.orders, design.lineable
        # the same layout as the buffer: the products run over contiguous memory
        self.fortran_gram = None if design.diagonal else np.asfortranarray(design.gram)
        self.buffer = None if design.diagonal else np.empty(design.gram.shape, order="F")
        self.strictly_lower = None if design.diagonal else np.tri(design.orders.size, k=-1, dtype=bool)
        self.positive = np.flatnonzero(design.orders > 0)
        self.not_positive = np.flatnonzero(design.orders <= 0)
        self.positive_orders = design.orders[self.positive].astype(float)
        self._columns, self._line_columns = {}, {}
        self.recent = []  # (key, Posterior) of the last evaluations, the newest first

    def line_columns(self, line_orders):
        """``(columns, starts, counts)`` of the lines at ``line_orders``, their columns one after the other
        (``starts`` None when a line has no column)."""
        key = tuple(line_orders)
        found = self._line_columns.get(key)
        if found is None:
            parts = [self.columns(k) for k in key]
            counts = np.array([part.size for part in parts])
            starts = np.r_[0, np.cumsum(counts)[:-1]] if np.all(counts > 0) else None
            found = self._line_columns[key] = (np.concatenate(parts), starts, counts)
        return found

    def columns(self, order):
        """Indices of the lineable columns of ``order``."""
        found = self._columns.get(order)
        if found is None:
            found = self._columns[order] = np.flatnonzero((self.orders == order) & self.lineable)
        return found


def _work(design):
    work = design.__dict__.get("_work")
    if work is None or work.gram is not design.gram or work.orders is not design.orders \
            or work.lineable is not design.lineable:
        work = design.__dict__["_work"] = _Work(design)
    return work


def _cholesky(fill, buffer):
    """Lower Cholesky factor of ``I + d G d / σ²`` (``fill(buffer)`` writes it; factorised in place); where
    rounding makes it indefinite (noise-free data, σ² at its bound), a jitter of up to 1e-8 of its largest
    diagonal entry is added."""
    lapack = _lapack()
    top = float(fill(buffer).diagonal().max())
    factor, info = lapack.dpotrf(buffer, lower=1, overwrite_a=1)
    jitter = 1e-14 * top
    while info != 0 and jitter <= 1e-8 * top:
        matrix = fill(buffer)
        matrix.ravel(order="F")[:: matrix.shape[0] + 1] += jitter
        factor, info = lapack.dpotrf(matrix, lower=1, overwrite_a=1)
        jitter *= 100.0
    if info != 0:
        raise np.linalg.LinAlgError("the posterior precision is not positive definite")
    return factor


# -- hyperparameter search -----------------------------------------------------------------

def _pack(hyper, line_orders):
    x = [math.log(hyper.amplitude), hyper.exponent]
    if not hyper.noise_fixed:
        x.append(math.log(hyper.noise_var))
    x.extend(math.log(hyper.lines[k]) for k in line_orders)
    return np.array(x)


def _unpack(x, hyper, line_orders):
    i = 2
    noise = hyper.noise_var
    if not hyper.noise_fixed:
        noise = math.exp(x[2])
        i = 3
    lines = {k: math.exp(v) for k, v in zip(line_orders, x[i:])}
    return Hyper(math.exp(x[0]), float(x[1]), noise, lines, hyper.noise_fixed)


def _objective(x, design, hyper, line_orders, background_parts, per_reading=True):
    trial = _unpack(x, hyper, line_orders)
    work = _work(design)
    s, positive_background = trial._variances(design, work)
    try:
        post = evidence(design, s, trial.noise_var, covariance=False)
    except np.linalg.LinAlgError:  # rounding at an extreme trial point: steer the line search back
        return _FAILED_OBJECTIVE * (1 if per_reading else max(design.n, 1)), np.zeros(x.size)
    background = np.zeros(s.size)
    background[work.positive] = positive_background
    weight = post.grad_log_variance * background / s  # ∂ log p / ∂ log A, per column
    grad = [float(np.sum(weight)), float(-np.sum(weight * background_parts))]
    if not hyper.noise_fixed:
        grad.append(post.grad_log_noise)
    grad = np.array(grad)
    if line_orders:
        columns, starts, counts = work.line_columns(line_orders)
        per_column = np.repeat([trial.lines[k] for k in line_orders], counts)
        if starts is None:  # a line on an order without a column: its gradient is 0
            line_grads = [np.sum(part) for part in np.split(post.grad_log_variance[columns] * per_column
                                                            / s[columns], np.cumsum(counts)[:-1])]
        else:  # each line's columns summed in order, as np.sum does
            line_grads = np.add.reduceat(post.grad_log_variance[columns] * per_column / s[columns], starts)
        grad = np.concatenate([grad, line_grads])
    scale = 1.0 / max(design.n, 1) if per_reading else 1.0
    return -post.log_evidence * scale, -grad * scale


def _optimise(design, hyper):
    """Maximise the evidence over every free hyperparameter from ``hyper`` (L-BFGS-B, analytic gradient).

    The objective is minus the log evidence per reading. Every variable being bounded, L-BFGS-B's first step
    is minus that gradient, ``n`` times shorter than the gradient in nats: on 10^6 readings it could gain less
    than ``ftol`` and the search stopped at its first iteration, up to 1.6 nats below the maximum
    (benchmarks/bench_optimiser_gap.py). A search that stops there goes on with the objective in nats (the same
    gradient tolerance, ``1e-8 n`` nats), whose first step is the gradient's own length; no other search changes.
    """
    import scipy.optimize

    line_orders = sorted(hyper.lines)
    scale = design.scale
    log_scale = math.log(scale)
    bounds = [(log_scale - 40.0, log_scale + 14.0), EXPONENT_BOUNDS]
    if not hyper.noise_fixed:
        bounds.append((log_scale - NOISE_FLOOR_NATS, log_scale + 3.0))
    bounds.extend([(log_scale - 30.0, log_scale + 14.0)] * len(line_orders))
    log_orders = np.log(np.maximum(design.orders, 1).astype(float))
    x0 = np.clip(_pack(hyper, line_orders), [b[0] for b in bounds], [b[1] for b in bounds])
    for per_reading, gtol in ((True, 1e-8), (False, 1e-8 * max(design.n, 1))):
        result = scipy.optimize.minimize(_objective, x0, args=(design, hyper, line_orders, log_orders, per_reading),
                                         jac=True, method="L-BFGS-B", bounds=bounds,
                                         options={"maxiter": 500, "ftol": 1e-13, "gtol": gtol,
                                                  "maxcor": _memory(x0.size)})
        if result.nit > 1:
            break
        x0 = result.x
    return _unpack(result.x, hyper, line_orders)


#: L-BFGS-B's memory, in correction pairs: SciPy's default, and more for a search over more than
#: :data:`_WIDE_SEARCH` hyperparameters (a dense sweep's lines above the cap: with 10 pairs the refit of a 10^5-reading
#: stepper sweep over 98 of them took 396 evaluations of the evidence).
_MEMORY, _MEMORY_WIDE, _WIDE_SEARCH = 10, 30, 30


def _memory(parameters):
    return _MEMORY_WIDE if parameters > _WIDE_SEARCH else _MEMORY


def _line_gain(s_block, q, variance):
    """Evidence gain (nats) of adding ``variance`` to a cos/sin pair.

    ``S = ΦᵀC⁻¹Φ`` and ``q = ΦᵀC⁻¹y`` of the pair's columns under the current model.

    Arrays of 2 × 2 blocks ``(m, 2, 2)``, vectors ``(m, 2)`` and variances ``(m, v)``.
    """
    eigenvalues, vectors = np.linalg.eigh(s_block)
    projected = np.einsum("mij,mi->mj", vectors, q) ** 2
    lam = np.maximum(eigenvalues, 0.0)[:, None, :]
    v = variance[:, :, None]
    return 0.5 * np.sum(v * projected[:, None, :] / (1.0 + v * lam) - np.log1p(v * lam), axis=2)


def _pairs(design):
    """Orders that may carry a line and the column index of their cosine and sine."""
    lineable = np.flatnonzero(design.lineable)
    orders = design.orders[lineable]
    order = np.argsort(orders, kind="stable")
    unique, first, counts = np.unique(orders[order], return_index=True, return_counts=True)
    cos_index = lineable[order[first]]
    sin_index = lineable[order[first + counts - 1]]
    return unique, cos_index, sin_index


def _blocks(design, post, noise_var, cos_index, sin_index):
    """``S = ΦᵀC⁻¹Φ`` (2 × 2 blocks) and ``q = ΦᵀC⁻¹y`` of the given column pairs."""
    sigma2 = noise_var
    q_all = (design.projection - (design.gram * post.mean if design.diagonal else design.gram @ post.mean)) / sigma2
    m = cos_index.size
    blocks = np.zeros((m, 2, 2))
    if design.diagonal:
        g = design.gram
        s_all = g / sigma2 - g**2 * post.covariance / sigma2**2
        blocks[:, 0, 0] = s_all[cos_index]
        blocks[:, 1, 1] = s_all[sin_index]
    else:
        h = design.gram / sigma2
        w = post.covariance @ h  # Σ H
        for a, ia in enumerate((cos_index, sin_index)):
            for b, ib in enumerate((cos_index, sin_index)):
                blocks[:, a, b] = h[ia, ib] - np.einsum("mj,jm->m", h[ia, :], w[:, ib])
    q = np.stack([q_all[cos_index], q_all[sin_index]], axis=1)
    same = cos_index == sin_index
    if np.any(same):  # a single column: its second row is a copy; keep one
        blocks[same, 1, :] = 0.0
        blocks[same, :, 1] = 0.0
        q[same, 1] = 0.0
    return blocks, q


def _best_gains(blocks, q, scale, chunk=4096):
    """Largest gain over a grid of line variances, and its variance, for every pair (in chunks: memory O(chunk))."""
    grid = scale * np.logspace(-12, 6, 73)
    gains, variances = np.empty(blocks.shape[0]), np.empty(blocks.shape[0])
    for start in range(0, blocks.shape[0], chunk):
        part = slice(start, start + chunk)
        values = _line_gain(blocks[part], q[part], np.broadcast_to(grid, (blocks[part].shape[0], grid.size)))
        best = np.argmax(values, axis=1)
        gains[part], variances[part] = values[np.arange(best.size), best], grid[best]
    return gains, variances


def _candidate_gains(design, post, noise_var, orders, cos_index, sin_index, chosen):
    """Each chosen order's best evidence gain as a new line, less the extra nats its order needs, and that line's
    variance (the orders and column pairs of :func:`_pairs`, ``chosen`` a mask over them)."""
    blocks, q = _blocks(design, post, noise_var, cos_index[chosen], sin_index[chosen])
    gains, variances = _best_gains(blocks, q, design.scale)
    return gains - design.extra_nats(orders[chosen]), variances


def _removal_gains(design, hyper, post, orders, cos_index, sin_index):
    """Evidence each present line adds over the model without it (nats)."""
    present = [i for i, k in enumerate(orders) if k in hyper.lines]
    if not present:
        return {}
    present = np.array(present)
    blocks, q = _blocks(design, post, hyper.noise_var, cos_index[present], sin_index[present])
    gains = {}
    for j, i in enumerate(present):
        v = hyper.lines[int(orders[i])]
        m = np.eye(2) - v * blocks[j]
        try:
            without = np.linalg.solve(m, blocks[j])
            q_without = np.linalg.solve(m, q[j])
        except np.linalg.LinAlgError:
            gains[int(orders[i])] = np.inf
            continue
        without = 0.5 * (without + without.T)
        gains[int(orders[i])] = float(_line_gain(without[None], q_without[None], np.array([[v]]))[0, 0])
    return gains


def _initial(design, noise_var, threshold, from_trend=False):
    """Safeguard 1: start from the periodogram (robust flat level, strong orders as lines).

    A line starts where an order's power exceeds the noise level (with ``from_trend``, the noise level
    plus a power law through the periodogram, :func:`_trend`) by the factor ``ln P + threshold``.
    """
    orders, cos_index, sin_index = _pairs(design)
    g = design.gram if design.diagonal else np.diag(design.gram)
    # a column that vanishes at every stop (sin 90θ on a 2° grid) has no coefficient to speak of
    coefficient = np.where(g > 1e-12 * float(np.max(g)), design.projection / np.maximum(g, 1e-300), 0.0)
    power = 0.5 * (coefficient[cos_index] ** 2 + coefficient[sin_index] ** 2)
    power[cos_index == sin_index] *= 2.0
    # The upper half of the orders is where white noise dominates a decaying profile.
    upper = power[orders > np.median(orders)] if power.size > 1 else power
    flat = float(np.median(upper)) / math.log(2.0) if upper.size else design.scale
    flat = max(flat, 1e-30 * design.scale)
    typical_gram = float(np.median(g[cos_index])) if power.size else max(design.n, 1)
    if noise_var is None:
        sigma2 = max(flat * typical_gram, 1e-20 * design.scale)
        fixed = False
    else:
        sigma2, fixed = noise_var, True
    noise_level = sigma2 / typical_gram
    trend = _trend(orders, power, noise_level, threshold) if from_trend else None
    background = 0.0 if trend is None else trend[0] * np.maximum(orders, 1).astype(float) ** -trend[1]
    cut = (noise_level + background) * (math.log(max(power.size, 2)) + threshold)
    strong = (power > cut) & (design.extra_nats(orders) == 0)  # leakage from below would start lines above Nyquist
    if design.diagonal:
        lines = {int(k): float(p - noise_level) for k, p, st in zip(orders, power, strong) if st}
    else:
        lines = _pursuit(design, orders, cos_index, sin_index, g, strong, np.broadcast_to(cut, power.shape),
                         noise_level)
    if trend is not None:
        return Hyper(trend[0], float(np.clip(trend[1], *EXPONENT_BOUNDS)), sigma2, lines, fixed)
    low = power[(~strong) & (orders <= 10)]
    amplitude = max(float(np.median(low)) if low.size else noise_level, noise_level)
    return Hyper(amplitude, 2.0, sigma2, lines, fixed)


def _pursuit(design, orders, cos_index, sin_index, g, candidates, cut, noise_level):
    """The strong orders one at a time, each fitted and taken out of the projections before the next.

    Off a uniform grid the columns are correlated: a strong order leaks into every other order's
    periodogram (3 arcmin at order 1 on 180 stops moved by ±0.2 spacings started 46 lines, and the
    first optimisation over them took 0.9 of the fit's time). Taken out in turn, the strongest
    first, only the orders still above ``cut`` once the stronger ones are fitted start as lines.
    """
    residual = design.projection.astype(float).copy()
    usable = g > 1e-12 * float(np.max(g))
    lines, left = {}, candidates.copy()
    while np.any(left):
        coefficient = np.where(usable, residual / np.maximum(g, 1e-300), 0.0)
        power = 0.5 * (coefficient[cos_index] ** 2 + coefficient[sin_index] ** 2)
        power[cos_index == sin_index] *= 2.0
        ratio = np.where(left, power / cut, 0.0)
        best = int(np.argmax(ratio))
        if ratio[best] <= 1.0:
            break
        lines[int(orders[best])] = float(power[best] - noise_level)
        left[best] = False
        columns = np.unique([cos_index[best], sin_index[best]])
        columns = columns[usable[columns]]
        if columns.size:
            block = design.gram[np.ix_(columns, columns)]
            residual -= design.gram[:, columns] @ np.linalg.lstsq(block, residual[columns], rcond=None)[0]
    return lines


def _trend(orders, power, noise_level, threshold, rounds=4):
    """A power law ``A ν^-β`` (``β >= 1``) through the periodogram's excess over the noise: ``(A, β)`` or None.

    Least squares on ``log`` power against ``log ν``, refitted ``rounds`` times without the orders more
    than ``threshold`` above the line (lines); the log of an exponential variable averages minus Euler's
    constant, which ``A`` adds back. Orders at or below the noise are left out.
    """
    excess = power - noise_level
    keep = (orders > 0) & (excess > 0)
    if keep.sum() < 4:
        return None
    x, y = np.log(orders[keep].astype(float)), np.log(excess[keep])
    use = np.ones(x.size, dtype=bool)
    for _ in range(rounds):
        slope, intercept = np.polyfit(x[use], y[use], 1)
        if slope > -EXPONENT_BOUNDS[0]:
            slope = -EXPONENT_BOUNDS[0]
            intercept = float(np.mean(y[use] - slope * x[use]))
        within = y - (intercept + slope * x) < threshold
        if within.sum() < 4:
            break
        use = within
    return math.exp(intercept + np.euler_gamma), -slope


def fit_hyperparameters(design, *, noise_var=None, threshold=LINE_THRESHOLD_NATS, progress=None, start=None):
    """Type-II maximum likelihood: background, noise (unless given) and lines admitted by evidence.

    Parameters
    ----------
    design : Design
    noise_var : float, optional
        Known noise variance; default: estimated by maximum likelihood.
    threshold : float, default=LINE_THRESHOLD_NATS
        Nats a line must add to the log evidence to be kept.
    progress : callable, optional
        Called with no argument after each round (for a progress bar).
    start : Hyper, optional
        Background, lines and noise to start from (those of a fit of fewer orders to the same data),
        instead of the periodogram; a ``noise_var`` given is kept fixed all the same.

    Returns
    -------
    (Hyper, Posterior)
    """
    if design.yy <= 0.0 or not np.any(design.projection):
        hyper = Hyper(1e-30 * design.scale, 2.0, noise_var or 1e-30, {}, noise_var is not None)
        return hyper, evidence(design, hyper.variances(design), hyper.noise_var)
    if start is not None:
        # blind, the search starts at the start's noise too (a fit of fewer orders to the same data)
        initial = Hyper(start.amplitude, start.exponent, start.noise_var if noise_var is None else noise_var,
                        dict(start.lines), noise_var is not None)
        hyper = _search(design, noise_var, threshold, progress, from_trend=False, initial=initial)
    else:
        hyper = _search(design, noise_var, threshold, progress, from_trend=False)
    if _collapsed(design, hyper):
        # Started with every order above the noise as a line (a small known noise, a smooth profile), the
        # background can shrink under them until no line can leave. Start again from a power law through the
        # periodogram and keep the better of the two, each line costing the threshold it had to pass.
        again = _search(design, noise_var, threshold, progress, from_trend=True)
        if _penalised_evidence(design, again, threshold) > _penalised_evidence(design, hyper, threshold):
            hyper = again
    return hyper, evidence(design, hyper.variances(design), hyper.noise_var)


def _collapsed(design, hyper):
    """Whether lines sit on more than :data:`COLLAPSE_LINE_FRACTION` of the orders (those of ``design.picked`` and
    their lines aside: a scan chose them for their lines)."""
    orders = np.unique(design.orders[design.lineable])
    lines = np.array(sorted(hyper.lines), dtype=int)
    if design.picked is not None:
        orders = orders[~np.isin(orders, design.picked)]
        lines = lines[~np.isin(lines, design.picked)]
    return lines.size > COLLAPSE_LINE_FRACTION * orders.size


def seed_lines(design, hyper, orders, threshold=LINE_THRESHOLD_NATS):
    """``hyper`` with a line at each of ``orders`` that would raise its evidence by more than ``threshold``.

    Each order's gain and best variance are those of :func:`_admit`, computed at ``hyper``'s posterior for
    every order at once (not one after another): a start for :func:`fit_hyperparameters` when columns are
    added to a design whose search ended at ``hyper`` and the new orders show power. The search that follows
    drops any line the others make weak.

    Parameters
    ----------
    design : Design
    hyper : Hyper
        Hyperparameters of a search on this design's other columns.
    orders : sequence of int
        Orders that may start with a line (those with a line in ``hyper`` are kept as they are).
    threshold : float, default=LINE_THRESHOLD_NATS
        Nats a line must add to the log evidence.

    Returns
    -------
    Hyper
        A new one; ``hyper`` is not changed.
    """
    seeded = Hyper(hyper.amplitude, hyper.exponent, hyper.noise_var, dict(hyper.lines), hyper.noise_fixed, hyper.flat)
    all_orders, cos_index, sin_index = _pairs(design)
    pick = np.isin(all_orders, np.asarray(orders, dtype=int)) & ~np.isin(all_orders, list(hyper.lines))
    if not np.any(pick):
        return seeded
    try:
        post = evidence(design, hyper.variances(design), hyper.noise_var)
    except np.linalg.LinAlgError:
        return seeded
    gains, variances = _candidate_gains(design, post, hyper.noise_var, all_orders, cos_index, sin_index, pick)
    for k, gain, v in zip(all_orders[pick], gains, variances):
        if gain > threshold:
            seeded.lines[int(k)] = float(v)
    return seeded


def _penalised_evidence(design, hyper, threshold):
    return evidence(design, hyper.variances(design), hyper.noise_var, covariance=False).log_evidence \
        - threshold * len(hyper.lines)


def _search(design, noise_var, threshold, progress, from_trend, initial=None):
    """Safeguard 1, the search from the periodogram (or ``initial``): background and noise, then lines in rounds."""
    if initial is None:
        initial = _initial(design, noise_var, threshold, from_trend)
    hyper = _prefer_noise(design, _optimise(design, initial), initial.noise_var)
    blind = not hyper.noise_fixed
    hyper.noise_fixed = True  # the lines are chosen at this noise
    hyper = _rounds(design, hyper, threshold, progress)
    hyper.noise_fixed = not blind
    return hyper


def _rounds(design, hyper, threshold, progress):
    """Drop every line that adds less than ``threshold``; else admit lines; re-optimise; until neither changes.

    The lines are dropped together, not the weakest alone: off a uniform grid the periodogram's
    leakage from a strong order can start dozens of lines, more than the rounds could drop one by one.
    """
    orders, cos_index, sin_index = _pairs(design)
    seen = set()
    best_value, best, stalled = -math.inf, None, 0
    for _ in range(_MAX_ROUNDS):
        if progress is not None:
            progress()
        post = evidence(design, hyper.variances(design), hyper.noise_var)
        removal = _removal_gains(design, hyper, post, orders, cos_index, sin_index)
        weak = [k for k, gain in removal.items() if gain < threshold + float(design.extra_nats(k))]
        if weak:
            for k in weak:
                del hyper.lines[k]
                seen.add(k)
        elif not _admit(design, hyper, post, orders, cos_index, sin_index, threshold, seen):
            break
        hyper = _optimise(design, hyper)
        try:
            value = _penalised_evidence(design, hyper, threshold)
        except np.linalg.LinAlgError:
            value = -math.inf
        if value > best_value:
            best_value, best, stalled = value, _copied(hyper), 0
        else:
            stalled += 1
            if stalled >= _STALLED_ROUNDS:
                return best
    return hyper


#: The rounds stop when this many in a row have not raised the evidence less the lines' thresholds, and the best
#: state stands. A fit converges in at most 6 rounds, each better than the last (the 60 real files and the README's
#: simulated encoders); on a noise-free series (a self-calibration's output, its noise at the bound) lines were
#: admitted and dropped in turn until the 40th round, 2,400 evaluations of the evidence in one fit.
_STALLED_ROUNDS = 3


def _copied(hyper):
    return Hyper(hyper.amplitude, hyper.exponent, hyper.noise_var, dict(hyper.lines), hyper.noise_fixed, hyper.flat)


def _profile(design, hyper, noise_var):
    """The hyperparameters that maximise the evidence at a fixed noise variance, and that evidence."""
    fixed = _optimise(design, Hyper(hyper.amplitude, hyper.exponent, noise_var, dict(hyper.lines), True))
    try:
        value = evidence(design, fixed.variances(design), noise_var).log_evidence
    except np.linalg.LinAlgError:
        value = -np.inf
    return Hyper(fixed.amplitude, fixed.exponent, noise_var, fixed.lines, False), value


def _prefer_noise(design, hyper, flat_noise_var, slack=NOISE_SLACK_NATS, steps=4):
    """The blind prior "all noise": after a collapse of σ, the largest σ whose evidence is within ``slack``.

    Along the ridge where a flat part of the spectrum is either signal or noise the evidence is
    nearly constant (docs/model-selection.md); the maximum may then sit at σ → 0, where the model
    interpolates the noise. When the maximum's σ² is below :data:`COLLAPSE_FRACTION` of the
    periodogram's flat level, the noise is raised towards that level as far as the evidence allows
    (bisection on log σ²); otherwise the maximum stands. The bisection's smallest step is tried first: when
    even it costs more than ``slack`` the maximum stands at once.
    """
    if hyper.noise_fixed or hyper.noise_var >= COLLAPSE_FRACTION * flat_noise_var:
        return hyper
    best = evidence(design, hyper.variances(design), hyper.noise_var).log_evidence
    low, high = math.log(hyper.noise_var), math.log(flat_noise_var)
    # The smallest raise the bisection can make first: where even it costs more than the slack, so does every larger
    # one (the evidence falls away from its maximum) and the maximum stands. Off a grid a strong order's leakage
    # lifts the periodogram's flat level far above the noise (660 times on 10^6 random readings); the search then
    # took its maximum for a collapse and ran five optimisations to come back to it.
    if _profile(design, hyper, math.exp(low + (high - low) / 2**steps))[1] < best - slack:
        return hyper
    top, value = _profile(design, hyper, flat_noise_var)
    if value >= best - slack:
        return top
    chosen = hyper
    for _ in range(steps):
        middle = 0.5 * (low + high)
        trial, value = _profile(design, chosen, math.exp(middle))
        if value >= best - slack:
            low, chosen = middle, trial
        else:
            high = middle
    return chosen


def _admit(design, hyper, post, orders, cos_index, sin_index, threshold, seen):
    """Add lines greedily (each raising the evidence by more than ``threshold``); return how many.

    On the FFT path the orders are independent at fixed background and noise, so every order
    that passes is added at once; otherwise one at a time, the posterior updated in between.
    """
    added = 0
    for _ in range(orders.size if design.diagonal else _LINES_PER_ROUND):
        free = np.array([int(k) not in hyper.lines and int(k) not in seen for k in orders])
        if not np.any(free):
            break
        gains, variances = _candidate_gains(design, post, hyper.noise_var, orders, cos_index, sin_index, free)
        if design.diagonal:
            passing = gains > threshold
            for k, v in zip(orders[free][passing], variances[passing]):
                hyper.lines[int(k)] = float(v)
            return int(passing.sum())
        best = int(np.argmax(gains))
        if gains[best] <= threshold:
            break
        hyper.lines[int(orders[free][best])] = float(variances[best])
        added += 1
        post = evidence(design, hyper.variances(design), hyper.noise_var)
    return added


#: Splits of the flat level between signal and noise averaged by :func:`split_average`.
SPLIT_POINTS = 9


def split_fractions(rule, points=SPLIT_POINTS):
    """The fractions of the flat level called profile that the blind split ``rule`` mixes.

    Parameters
    ----------
    rule : str
        A rule of :func:`split_average`.
    points : int, default=SPLIT_POINTS
        Midpoints of a uniform prior's interval.

    Returns
    -------
    ndarray
        Fractions in [0, 1] (dimensionless); ``'gcv'`` chooses one of them.
    """
    if rule == "uniform":
        return (np.arange(points) + 0.5) / points
    if rule == "half":
        return 0.5 * (np.arange(points) + 0.5) / points
    if rule.startswith("u"):  # 'u70': uniform on [0, 0.70]
        return float(rule[1:]) / 100.0 * (np.arange(points) + 0.5) / points
    if rule == "noise":
        return np.zeros(1)
    if rule.startswith("f"):  # 'f30': the one fixed fraction 0.30 (benchmarks/bench_split.py)
        return np.array([float(rule[1:]) / 100.0])
    if rule.startswith("b"):  # 'b10-80': the two fractions 0.10 and 0.80, weighted by their evidence
        return np.array([float(part) / 100.0 for part in rule[1:].split("-")])
    return np.arange(points) / points


def split_average(design, hyper, floor_var=0.0, points=SPLIT_POINTS, rule="uniform"):
    """The posterior averaged over how the flat level divides between signal and noise.

    On a uniform grid a flat part of the profile and white noise add the same level to every
    order: the evidence is flat along ``flat + σ²/g = L`` (``g`` the Gram diagonal of an order's
    column) and one run cannot tell the split. Blind, the fraction ``f = flat / L`` gets a prior
    chosen by the benchmark (``rule``; the default of the spectral model is
    ``spectral.BLIND_SPLIT``): the posterior is the mixture of the posteriors at the prior's
    fractions, weighted by their evidence (nearly equal on the ridge), with the noise variance
    never below ``floor_var`` (the quantisation's, when known).

    Parameters
    ----------
    design : Design
    hyper : Hyper
        The maximum-likelihood hyperparameters with ``flat = 0``: ``σ²/g`` is the flat level ``L``.
    floor_var : float, default=0.0
        Smallest noise variance.
    points : int, default=SPLIT_POINTS
    rule : {'uniform', 'noise', 'half', 'gcv', 'uNN', 'fNN', 'bNN-MM'}, default='uniform'
        ``'uniform'``: the evidence-weighted mixture over fractions uniform on [0, 1]; ``'half'``: on
        [0, 1/2]; ``'uNN'``: on [0, NN/100]; ``'fNN'``: the one fixed fraction NN/100; ``'bNN-MM'``: the
        two fractions NN/100 and MM/100 (evidence-weighted); ``'noise'``: the
        fraction 0 alone (all of the flat level noise); ``'gcv'``: the one
        fraction of the grid [0, 1) (0 included) whose posterior mean, a linear smoother of the data,
        has the lowest generalised cross-validation score ``n RSS / (n - tr H)²`` (Wahba 1985).

    Returns
    -------
    (Posterior, float)
        The mixture (evidence-weighted mean and covariance, and the spread of the components'
        means) and its mean noise variance.
    """
    g_all = design.gram if design.diagonal else np.diag(design.gram)
    positive = design.orders > 0
    g = float(np.median(g_all[positive])) if np.any(positive) else float(max(design.n, 1))
    level = hyper.flat + hyper.noise_var / g
    fractions = split_fractions(rule, points)
    posteriors, noises = [], []
    for fraction in fractions:
        noise = max((1.0 - fraction) * level * g, floor_var, 1e-300)
        trial = Hyper(hyper.amplitude, hyper.exponent, noise, dict(hyper.lines), True, max(level - noise / g, 0.0))
        try:
            variances = trial.variances(design)
            posteriors.append(signal_part(design, variances, noise, evidence(design, variances, noise)))
        except np.linalg.LinAlgError:  # σ² at the floor of noise-free data: that split is left out
            continue
        noises.append(noise)
    if not posteriors:
        variances = hyper.variances(design)
        return signal_part(design, variances, hyper.noise_var,
                           evidence(design, variances, hyper.noise_var)), hyper.noise_var
    log_evidence = np.array([p.log_evidence for p in posteriors])
    if rule == "gcv":
        scores = [_gcv(design, p, noise) for p, noise in zip(posteriors, noises)]
        chosen = int(np.argmin(scores))
        posteriors, noises, log_evidence = [posteriors[chosen]], [noises[chosen]], log_evidence[chosen:chosen + 1]
    weights = np.exp(log_evidence - log_evidence.max())
    weights /= weights.sum()
    means = np.array([p.mean for p in posteriors])
    mean = weights @ means
    covariance = sum(w * p.covariance for w, p in zip(weights, posteriors))
    spread = np.sqrt(weights)[:, None] * (means - mean)
    total = float(log_evidence.max() + math.log(np.mean(np.exp(log_evidence - log_evidence.max()))))
    best = posteriors[int(np.argmax(log_evidence))]
    mixture = Posterior(total, mean, covariance, best.grad_log_variance, best.grad_log_noise, spread)
    return mixture, float(weights @ np.array(noises))


def _gcv(design, post, noise_var):
    """Generalised cross-validation score ``n RSS / (n - tr H)²`` of the posterior mean as a linear smoother.

    ``H = Φ Σ Φᵀ / σ²`` (``Σ`` the posterior covariance): ``tr H = tr(G Σ) / σ²``; the residual sum of
    squares ``yᵀy - 2 bᵀμ + μᵀ G μ``.
    """
    mean, g = post.mean, design.gram
    if design.diagonal:
        trace = float(np.sum(g * post.covariance)) / noise_var
        rss = design.yy - 2.0 * design.projection @ mean + float(np.sum(g * mean**2))
    else:
        trace = float(np.sum(g * post.covariance)) / noise_var
        rss = design.yy - 2.0 * design.projection @ mean + mean @ g @ mean
    left = max(design.n - trace, 1e-12 * design.n)
    return design.n * max(rss, 0.0) / left**2

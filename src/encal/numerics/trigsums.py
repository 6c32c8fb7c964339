"""Trigonometric sums at arbitrary angles in O(n) per term: a Taylor-expanded non-uniform FFT.

Two sums carry every Fourier-feature computation of the spectral model:

- *moments* ``S_m = Σ_i w_i exp(i m θ_i)`` for ``m = 0 .. M`` (the Gram matrix and the
  projections of a Fourier-feature regression are built from them), and
- *series* ``f(θ_i) = Re Σ_m c_m exp(i m θ_i)`` at many angles (a prediction).

Direct evaluation costs O(n M). Here every angle is split into its node on a fine
uniform grid of ``L ≥ 2π M`` points and a small offset ``δ`` (``|M δ| ≤ 1/2``), and
``exp(i m δ)`` is expanded in its Taylor series, which converges to double precision
in at most 16 terms; each term is one FFT of size ``L``. The cost is O(16 n + 16 L log L).
"""

import math

import numpy as np

__all__ = ["trig_moments", "trig_moments_real", "trig_series", "SeriesEvaluator"]

#: Sums smaller than this (n times orders) are evaluated directly.
_DIRECT_LIMIT = 200_000
#: Relative size of the first Taylor term left out.
_TAYLOR_TOLERANCE = 1e-17
#: Angles per block of :func:`trig_moments` (a block's arrays, 8 bytes an angle each, fit in a core's cache).
_BLOCK_ANGLES = 1 << 15
#: Fewest nodes of the fine grid of :func:`trig_moments`' binning. A finer grid needs fewer Taylor terms, each a
#: pass of ``np.bincount`` over the angles, and spreads a sweep's consecutive angles over more nodes (an addition to
#: the bin the last one filled waits for it): 10^6 angles' moments to order 32 on 4096 nodes take 9 terms, 13-22 ms
#: (sweep or random), against 16 terms on 256 nodes, 19-41 ms.
_MOMENTS_NODES = 4096
#: Largest binning (fine-grid nodes times Taylor terms, 8 bytes each) kept for every term at once: the orders of a
#: fit's Gram matrix, not the scan above its cap (a fine grid of 2^15 nodes would hold 4 MB).
_BINNED_LIMIT = 1 << 16


def _fine_grid(highest_order, smallest=16):
    """Size ``L`` of the fine grid (a power of 2, at least ``smallest``, with ``π M / L <= 1/2``) and the Taylor
    terms needed."""
    size = smallest
    while size < 2.0 * math.pi * max(highest_order, 1):
        size *= 2
    x = math.pi * highest_order / size  # the largest |m δ|
    terms, term = 1, 1.0
    while term > _TAYLOR_TOLERANCE and terms < 40:
        term *= x / terms
        terms += 1
    return size, terms


#: Positions (in grid spacings) whose nearest node is exact as an int64 (and as a double).
_EXACT_POSITION = 2.0**52


def _nodes(theta_rad, size):
    """Node index on the fine grid and offset in grid spacings (in [-1/2, 1/2]) of every angle.

    ``size`` is a power of 2, so the node modulo ``size`` is the integer node's low bits: the same indices as
    ``np.mod`` of the rounded position, in a fifth of its time.
    """
    position = np.asarray(theta_rad, dtype=float) * (size / (2.0 * math.pi))
    node = np.rint(position)  # np.round's value
    if position.size and -_EXACT_POSITION < position.min() and position.max() < _EXACT_POSITION:
        index = node.astype(np.int64)
        index &= size - 1
    else:  # a huge angle, or NaN
        index = np.mod(node, size).astype(np.int64)
    position -= node  # (in place: 8 bytes an angle less at the peak)
    return index, position


#: The direct path's matrices ``exp(i m θ_i)`` of the last few sets of angles, ``(bytes of θ, matrix)`` the newest
#: first: a spectral fit takes moments of one set of angles with several weights (its Gram matrix, projections,
#: the rounding's carriers), and the complex exponentials were most of each sum's time.
_recent_exponentials = []
_RECENT_LIMIT = 2


def _exponentials(theta, count):
    """``exp(i m θ_i)`` for ``m < count``, shape ``(count, n)`` (rows of a kept matrix when it has enough)."""
    global _recent_exponentials
    key = theta.tobytes()
    for known, matrix in _recent_exponentials:
        if known == key and matrix.shape[0] >= count:
            return matrix[:count]
    matrix = np.exp(1j * np.multiply.outer(np.arange(count), theta))
    _recent_exponentials = [(key, matrix)] + [entry for entry in _recent_exponentials
                                              if entry[0] != key][: _RECENT_LIMIT - 1]
    return matrix


def trig_moments(theta_rad, weights, highest_order):
    """``S_m = Σ_i w_i exp(i m θ_i)`` for ``m = 0 .. highest_order``.

    Parameters
    ----------
    theta_rad : ndarray of shape (n,)
        Angles in radians.
    weights : ndarray of shape (n,)
        Real weights.
    highest_order : int
        Largest ``m``.

    Returns
    -------
    ndarray of complex of shape (highest_order + 1,)

    Examples
    --------
    >>> theta = np.array([0.1, 1.0, 2.5])
    >>> exact = np.exp(1j * np.outer(np.arange(4), theta)).sum(axis=1)
    >>> bool(np.allclose(trig_moments(theta, np.ones(3), 3), exact, rtol=0, atol=1e-13))
    True
    """
    theta = np.asarray(theta_rad, dtype=float).reshape(-1)
    weights = np.asarray(weights, dtype=float).reshape(-1)
    if theta.size * (highest_order + 1) <= _DIRECT_LIMIT:
        return _exponentials(theta, highest_order + 1) @ weights
    size, terms = _fine_grid(highest_order, _MOMENTS_NODES)
    if terms * size > _BINNED_LIMIT:
        size, terms = _fine_grid(highest_order)
        return _moments_by_term(theta, weights, highest_order, size, terms)
    # Block by block, every Taylor term's binning: a block's nodes, offsets and powers stay in the cache (term by
    # term, each term read and wrote them from memory: on 10^6 angles, half as long again).
    binned = np.zeros((terms, size))
    for start in range(0, theta.size, _BLOCK_ANGLES):
        node, offset = _nodes(theta[start:start + _BLOCK_ANGLES], size)
        power = weights[start:start + _BLOCK_ANGLES].copy()  # w δ^p (δ in spacings)
        runs = _runs(node)
        for p in range(terms):
            binned[p] += _binned(node, power, size, runs)
            power *= offset
    # Σ_j x_j exp(+2πi jm/L) of a real x is the conjugate of its real FFT
    return _taylor_sum((np.conj(np.fft.rfft(row)[: highest_order + 1]) for row in binned), highest_order, size)


#: A block of angles is binned run by run when its nodes change at fewer than this share of them (a sweep's
#: consecutive angles share a node): an addition to the bin the last one filled waits for it, and ``np.bincount`` of
#: a sweep's angles took twice as long as of random ones (10^6 angles' moments to order 400: 43 ms, 25 ms by runs;
#: random angles 23 ms either way). Not in :func:`_moments_by_term`, where it was slower.
_RUN_SHARE = 0.25


def _runs(node):
    """``(starts, nodes)`` of the runs of equal consecutive nodes, or None when there are too many to help."""
    changes = node[1:] != node[:-1]
    if np.count_nonzero(changes) + 1 > _RUN_SHARE * node.size:
        return None
    starts = np.flatnonzero(changes)
    starts += 1
    starts = np.r_[0, starts]
    return starts, node[starts]


def _binned(node, weights, size, runs):
    """``np.bincount(node, weights, minlength=size)``, summed run by run first when given ``runs`` (:func:`_runs`)."""
    if runs is None:
        return np.bincount(node, weights=weights, minlength=size)
    starts, run_node = runs
    return np.bincount(run_node, weights=np.add.reduceat(weights, starts), minlength=size)


def _taylor_sum(spectra, highest_order, size):
    """``Σ_p (i m h)^p / p! · spectra[p, m]``: the Taylor terms' spectra summed into the moments."""
    orders = np.arange(highest_order + 1)
    step = 2.0 * math.pi / size
    total = np.zeros(highest_order + 1, dtype=complex)
    factor = np.ones(highest_order + 1, dtype=complex)  # (i m h)^p / p!
    for p, spectrum in enumerate(spectra):
        total += factor * spectrum
        factor = factor * (1j * orders * step) / (p + 1)
    return total


def _moments_by_term(theta, weights, highest_order, size, terms):
    """:func:`trig_moments` one Taylor term at a time over all the angles (a fine grid too large to keep every
    term's binning)."""
    node, offset = _nodes(theta, size)
    power = weights.copy()
    spectra = []
    for _ in range(terms):
        binned = np.bincount(node, weights=power, minlength=size)
        spectra.append(np.fft.ifft(binned)[: highest_order + 1] * size)
        power *= offset  # (in place, as every product below: no fresh pages for each term of 10^6 angles)
    return _taylor_sum(spectra, highest_order, size)


def trig_moments_real(theta_rad, weights, highest_order):
    """``S_m = Σ_i w_i e^{imθ_i}``, ``m = 0 .. highest_order``, by the Taylor-expanded non-uniform FFT of
    :func:`trig_moments`, one term at a time, each a real FFT of a grid of ``L >= 2 highest_order`` nodes.

    With ``θ_i = (j_i + δ_i) h``, ``h = 2π / L``, ``|δ_i| <= 1/2``:
    ``S_m = Σ_p (imh)^p / p! Σ_j x_{p,j} e^{2πijm/L}`` with ``x_{p,j} = Σ_{j_i = j} w_i δ_i^p`` real, whose sum
    over ``j`` is ``conj(rfft(x_p))[m]``; the terms stop when ``(πM/L)^p / p!`` is below 1e-17
    (``|mhδ| <= πM/L <= π/2``), at most 24. (``trig_moments`` takes a complex FFT of each term on a grid of
    ``L >= 2πM``: at order 73,642 on 10^6 random angles, 16 terms of 2^19 nodes, 0.34 s; here 20 terms of 2^18
    nodes, 0.12 s, the same sums to 1.1e-16 of ``Σ|w_i|``.) Faster than :func:`trig_moments` for orders in the
    thousands; below, :func:`trig_moments` bins every term in one pass.

    Parameters
    ----------
    theta_rad : ndarray of shape (n,)
        Angles in radians.
    weights : ndarray of shape (n,)
        Real weights.
    highest_order : int
        Largest ``m``.

    Returns
    -------
    ndarray of complex of shape (highest_order + 1,)
    """
    size = 16
    while size < 2 * highest_order:
        size *= 2
    largest = math.pi * highest_order / size  # the largest |mhδ|
    terms, term = 1, 1.0
    while term > 1e-17:
        term *= largest / terms
        terms += 1
    node, offset = _nodes(theta_rad, size)
    power = np.array(weights, dtype=float)  # w δ^p (δ in grid spacings)
    factor = np.ones(highest_order + 1, dtype=complex)  # (imh)^p / p!
    turn = 1j * np.arange(highest_order + 1) * (2.0 * math.pi / size)
    moments = np.zeros(highest_order + 1, dtype=complex)
    for p in range(terms):
        spectrum = np.fft.rfft(np.bincount(node, weights=power, minlength=size))[: highest_order + 1]
        moments += factor * np.conj(spectrum)
        factor *= turn / (p + 1)
        power *= offset
    return moments


def trig_series(coefficients, theta_rad):
    """``f(θ) = Re Σ_m c_m exp(i m θ)`` at every angle, ``m = 0 .. len(coefficients) - 1``.

    Parameters
    ----------
    coefficients : ndarray of complex of shape (M + 1,)
    theta_rad : ndarray of shape (n,)
        Angles in radians.

    Returns
    -------
    ndarray of shape (n,)

    Examples
    --------
    >>> c = np.array([1.0, 0.5 - 0.25j])
    >>> bool(np.allclose(trig_series(c, np.array([0.0, np.pi / 2])), [1.5, 1.25]))
    True
    """
    theta = np.asarray(theta_rad, dtype=float).reshape(-1)
    coefficients = np.asarray(coefficients, dtype=complex).reshape(-1)
    highest = coefficients.size - 1
    if theta.size * coefficients.size <= _DIRECT_LIMIT:
        return np.real(np.exp(1j * np.multiply.outer(theta, np.arange(coefficients.size))) @ coefficients)
    size, terms = _fine_grid(highest)
    node, offset = _nodes(theta, size)
    step = 2.0 * math.pi / size
    orders = np.arange(coefficients.size)
    padded = np.zeros(size, dtype=complex)
    result = np.zeros(theta.size)
    power = np.ones(theta.size)  # δ^p / p!
    term = coefficients.copy()  # c_m (i m h)^p
    for p in range(terms):
        padded[: coefficients.size] = term
        values = np.fft.ifft(padded) * size
        result += np.real(values[node]) * power
        power = power * offset / (p + 1)
        term = term * (1j * orders * step)
    return result


class SeriesEvaluator:
    """``f(θ) = Re Σ_m c_m exp(i m θ)`` for fixed coefficients, one angle at a time or many.

    The Taylor terms of :func:`trig_series` do not depend on the angles: they are computed once, and
    each angle then costs a few lookups and multiplications of its own. So the value at an angle is
    the same whatever other angles are evaluated with it (a stream's answers must not depend on its
    buffering; :func:`trig_series` switches method with the number of angles).

    Parameters
    ----------
    coefficients : ndarray of complex of shape (M + 1,)

    Examples
    --------
    >>> f = SeriesEvaluator(np.array([1.0, 0.5 - 0.25j]))
    >>> bool(np.allclose(f(np.array([0.0, np.pi / 2])), [1.5, 1.25], rtol=0, atol=1e-14))
    True
    """

    @staticmethod
    def table_numbers(highest_order):
        """Numbers in the tables of an evaluator of ``highest_order`` (the fine grid's size times the terms)."""
        size, terms = _fine_grid(highest_order)
        return size * terms

    def __init__(self, coefficients):
        coefficients = np.asarray(coefficients, dtype=complex).reshape(-1)
        self.size, terms = _fine_grid(coefficients.size - 1)
        orders = np.arange(coefficients.size)
        step = 2.0 * math.pi / self.size
        padded = np.zeros(self.size, dtype=complex)
        term = coefficients.copy()
        tables = []
        for p in range(terms):
            padded[: coefficients.size] = term
            tables.append(np.real(np.fft.ifft(padded) * self.size) / math.factorial(p))
            term = term * (1j * orders * step)
        self._tables = tables[::-1]  # f^(p)(node) h^p / p!, the highest p first: Horner's rule in the offset

    def __call__(self, theta_rad):
        theta = np.asarray(theta_rad, dtype=float).reshape(-1)
        node, offset = _nodes(theta, self.size)
        result = self._tables[0][node]
        term = np.empty_like(result)
        for table in self._tables[1:]:
            result *= offset
            np.take(table, node, out=term)
            result += term
        return result

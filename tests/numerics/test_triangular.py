"""The inverse of a lower-triangular matrix by blocks (encal.numerics.triangular).

Known truth: ``L⁻¹ L = I``. The factors are those the spectral model's evidence inverts, Cholesky factors of
``B = I + M`` with ``M`` positive semi-definite (eigenvalues of ``B`` from 1 to 1e8 here), at sizes on both sides
of the blocks' leaf size and of a split.
"""

import numpy as np
import pytest
from scipy.linalg import lapack

from encal.numerics.triangular import _LEAF, lower_triangular_inverse

U = 2.0**-53


def _factor(n, seed, largest=1e8):
    """The lower Cholesky factor of ``I + Q diag(λ) Qᵀ`` (λ log-spaced up to ``largest``), its upper triangle
    left as LAPACK leaves it (the matrix's own entries)."""
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    b = np.asfortranarray(np.eye(n) + (q * np.logspace(0, np.log10(largest), n)) @ q.T)
    factor, info = lapack.dpotrf(b, lower=1)
    assert info == 0
    return factor


@pytest.mark.parametrize("n", [1, 2, 3, _LEAF - 1, _LEAF, _LEAF + 1, 2 * _LEAF + 1, 401, 803])
def test_the_inverse_times_the_factor_is_the_identity(n):
    factor = _factor(n, seed=n)
    lower = np.tril(factor)
    inverse = lower_triangular_inverse(factor)
    condition = np.linalg.cond(lower)
    # a triangular inverse's residual is within a small multiple of n u κ(L) (Higham, ch. 14)
    assert np.max(np.abs(inverse @ lower - np.eye(n))) <= 4.0 * n * U * condition
    assert np.all(np.triu(inverse, 1) == 0.0)
    assert inverse.flags.f_contiguous


def test_the_strictly_upper_triangle_is_not_read():
    factor = _factor(300, seed=1)
    garbage = factor.copy(order="F")
    garbage[np.triu_indices(300, 1)] = np.random.default_rng(2).normal(size=300 * 299 // 2) * 1e6
    np.testing.assert_array_equal(lower_triangular_inverse(garbage), lower_triangular_inverse(np.tril(factor)))


def test_agrees_with_lapack_dtrtri():
    factor = _factor(401, seed=3)
    expected = np.tril(lapack.dtrtri(np.tril(factor), lower=1)[0])
    np.testing.assert_allclose(lower_triangular_inverse(factor), expected, rtol=0,
                               atol=1e-12 * np.max(np.abs(expected)))


@pytest.mark.parametrize("zero_at", [0, _LEAF + 5, 299])
def test_a_zero_on_the_diagonal_is_refused(zero_at):
    factor = np.tril(_factor(300, seed=4))
    factor[zero_at, zero_at] = 0.0
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        lower_triangular_inverse(factor)


def test_a_matrix_that_is_not_square_is_refused():
    with pytest.raises(ValueError, match=r"square matrix; got shape \(3, 4\)"):
        lower_triangular_inverse(np.ones((3, 4)))

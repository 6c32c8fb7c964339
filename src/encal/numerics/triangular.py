"""The inverse of a lower-triangular matrix (a Cholesky factor), by blocks.

The spectral model's evidence needs the diagonal of ``B⁻¹ = L⁻ᵀ L⁻¹`` at every step of its optimiser. LAPACK's
``dtrtri`` in the OpenBLAS that NumPy and SciPy wheels bring runs at a third of the speed of the same library's
``dtrmm`` (BENCHMARKS.md, "Triangular inverse"); split in two halves,

    [[A, 0], [C, D]]⁻¹ = [[A⁻¹, 0], [-D⁻¹ C A⁻¹, D⁻¹]],

the work is two triangular products (``dtrmm``), recursively, down to blocks small enough for ``dtrtri``.
"""

import functools

import numpy as np

__all__ = ["lower_triangular_inverse"]

#: Blocks of at most this many rows are inverted by LAPACK's ``dtrtri`` itself.
_LEAF = 64


def lower_triangular_inverse(factor):
    """``L⁻¹`` of a lower-triangular ``L`` (its strictly upper triangle is not read).

    Parameters
    ----------
    factor : ndarray of float of shape (n, n)
        ``L``, non-singular; Fortran order avoids copies.

    Returns
    -------
    ndarray of float of shape (n, n)
        ``L⁻¹`` in Fortran order, zero above the diagonal.

    Raises
    ------
    numpy.linalg.LinAlgError
        If a diagonal entry of ``L`` is zero.

    Examples
    --------
    >>> lower = np.array([[2.0, 0.0], [1.0, 4.0]])
    >>> lower_triangular_inverse(lower) @ lower
    array([[1., 0.],
           [0., 1.]])
    """
    from scipy.linalg import blas, lapack

    factor = np.asarray(factor, dtype=float)
    if factor.ndim != 2 or factor.shape[0] != factor.shape[1]:
        raise ValueError(f"lower_triangular_inverse expects a square matrix; got shape {factor.shape}")
    return _inverse(factor, blas, lapack)


def _inverse(factor, blas, lapack):
    n = factor.shape[0]
    if n <= _LEAF:
        inverse, info = lapack.dtrtri(factor, lower=1)
        if info != 0:
            raise np.linalg.LinAlgError("the triangular matrix is singular")
        np.copyto(inverse, 0.0, where=_strictly_upper(n))  # dtrtri keeps the strictly upper triangle it was given
        return inverse
    half = n // 2
    inverse = np.empty((n, n), order="F")
    inverse[:half, half:] = 0.0
    inverse[:half, :half] = _inverse(factor[:half, :half], blas, lapack)
    inverse[half:, half:] = _inverse(factor[half:, half:], blas, lapack)
    below = blas.dtrmm(1.0, inverse[:half, :half], factor[half:, :half], side=1, lower=1)  # C A⁻¹
    inverse[half:, :half] = blas.dtrmm(-1.0, inverse[half:, half:], below, side=0, lower=1, overwrite_b=1)
    return inverse


@functools.lru_cache(maxsize=8)
def _strictly_upper(n):
    return ~np.tri(n, dtype=bool)

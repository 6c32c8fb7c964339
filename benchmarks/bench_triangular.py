"""The spectral model's evidence: the triangular inverse by blocks against LAPACK's own routines.

Usage::

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=src python benchmarks/bench_triangular.py [--repeats 9]

For Cholesky factors of ``B = I + M`` (``M`` positive semi-definite, the evidence's matrices) of P rows, in one
process, interleaved (A B A B ...), median milliseconds and the median of the pair ratios:

* ``L⁻¹`` by :func:`encal.numerics.triangular.lower_triangular_inverse` against LAPACK ``dtrtri``, the diagonal of
  ``B⁻¹`` that each step of the optimiser needs;
* ``B⁻¹`` as that inverse and ``dlauum`` against LAPACK ``dpotri`` (``dtrtri`` and ``dlauum``), the posterior
  covariance;
* one evaluation of the evidence and its gradient (``encal.models._evidence.evidence``, Cholesky factor included)
  at P = 401 (orders up to 200, the cap off a uniform grid), the figure that counts.

SciPy's LAPACK is the OpenBLAS its wheel brings (``threadpoolctl`` names it in the header).
"""

import argparse
import time

import numpy as np
from scipy.linalg import lapack

from encal.numerics.triangular import lower_triangular_inverse


def factor(n, seed=0):
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    b = np.asfortranarray(np.eye(n) + (q * np.logspace(0, 6, n)) @ q.T)
    return lapack.dpotrf(b, lower=1)[0]


def paired(first, second, repeats, inner):
    first(), second()
    a, b = [], []
    for _ in range(repeats):
        for call, times in ((first, a), (second, b)):
            start = time.perf_counter()
            for _ in range(inner):
                call()
            times.append((time.perf_counter() - start) / inner * 1e3)
    return np.array(a), np.array(b)


def row(label, a, b):
    return (f"| {label} | {np.median(a):.3f} | {np.median(b):.3f} | **{np.median(a / b):.2f}x** "
            f"({np.min(a / b):.2f}-{np.max(a / b):.2f}) |")


def evidence_row(repeats):
    """One evaluation of the evidence and its gradient at P = 401, the new inverse against ``dtrtri``."""
    from encal.models import _evidence

    rng = np.random.default_rng(1)
    theta = rng.uniform(0, 2 * np.pi, 20_000)
    orders = np.repeat(np.arange(201), 2)[1:]
    shifts = np.where(np.arange(orders.size) % 2 == 1, 0.0, np.pi / 2)
    shifts[0] = 0.0
    features = np.cos(orders[None, :] * theta[:, None] - shifts[None, :])
    y = features[:, 1] * 3 + rng.normal(0, 0.1, theta.size)
    design = _evidence.Design(orders, shifts, features.T @ features, features.T @ y, float(y @ y), theta.size,
                              orders > 0)
    variances = 1.0 / np.maximum(orders, 1.0) ** 2
    original = _evidence.lower_triangular_inverse

    def with_dtrtri(matrix):
        return lapack.dtrtri(matrix, lower=1)[0] * np.tri(matrix.shape[0])

    def evaluate(inverse):
        _evidence.lower_triangular_inverse = inverse
        try:
            _evidence._evidence(design, variances, 0.01, False)
        finally:
            _evidence.lower_triangular_inverse = original

    a, b = paired(lambda: evaluate(original), lambda: evaluate(with_dtrtri), repeats, 20)
    return row("evidence and gradient, P = 401", a, b)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=9)
    args = parser.parse_args()
    from threadpoolctl import threadpool_info

    libraries = ", ".join(f"{i['prefix']} {i['version']} ({i['num_threads']} thread{'s' * (i['num_threads'] > 1)})"
                          for i in threadpool_info() if i["user_api"] == "blas")
    print(f"BLAS: {libraries}\n")
    print("| P | by blocks, ms | LAPACK, ms | ratio (min-max) |\n|---|---|---|---|")
    for n in (101, 201, 401, 801):
        lower = factor(n)
        inner = max(1, 400_000_000 // n**3)
        a, b = paired(lambda: lower_triangular_inverse(lower), lambda: lapack.dtrtri(lower, lower=1), args.repeats,
                      inner)
        print(row(f"{n}: L⁻¹ / dtrtri", a, b))
        a, b = paired(lambda: lapack.dlauum(lower_triangular_inverse(lower), lower=1, overwrite_c=1),
                      lambda: lapack.dpotri(lower, lower=1), args.repeats, inner)
        print(row(f"{n}: B⁻¹ (L⁻¹, dlauum) / dpotri", a, b))
    print(evidence_row(args.repeats))


if __name__ == "__main__":
    main()

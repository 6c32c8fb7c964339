"""Bayesian regularisation, as MATLAB's ``trainbr`` implements it.

Levenberg-Marquardt on ``F = β·E_D + α·E_W``, with ``E_D = Σe²`` the sum of
squared (normalised) residuals and ``E_W = ΣX²`` the sum of squared weights.
After every accepted step the hyper-parameters are re-estimated by MacKay's
evidence rules, with the Gauss-Newton Hessian ``H = 2βJᵀJ + 2αI``:

- effective number of parameters ``γ = N_w − 2α·tr(H⁻¹)``,
- ``α = γ / (2 E_W)``, ``β = (N − γ) / (2 E_D)`` (N residuals, N_w weights).

MacKay, D. J. C. (1992), "Bayesian interpolation", Neural Computation 4(3),
415-447; Foresee, F. D. and Hagan, M. T. (1997), "Gauss-Newton approximation
to Bayesian learning", Proc. ICNN, vol. 3, pp. 1930-1935.

Defaults are MATLAB's: ``mu=0.005``, ``mu_dec=0.1``, ``mu_inc=10``,
``mu_max=1e10``, ``epochs=1000``, ``min_grad=1e-7``. As in ``trainbr.m``, the
start is ``γ = N_w``, ``α = γ / (2 E_W)``, ``β = (N − γ) / (2 E_D)`` or 1 when
that is not positive, and γ is computed from the Jacobian at the start of the
epoch. Recorded per epoch: ``'mu'``, ``'gamma'``, ``'alpha'``, ``'beta'``.

Reported to the monitor: the data mean squared error ``E_D / N`` (what
``goal`` tests) and the gradient of ``F / (β N)``, ``2 (Jᵀe + (α/β) X) / N``
(what ``min_grad`` tests; it vanishes at the regularised minimum).
Unlike MATLAB (whose ``trainbr`` sets ``max_fail = 0``), a validation problem,
when given, stops training after ``max_fail`` failures as for any algorithm.

Caution, measured: the first re-estimates, made far from any minimum, can
lock a network into a few effective parameters. On simulated resolver
profiles (``simulate_fleet(4, 7)``) a ``periodic`` 1:12:1 network from
Nguyen-Widrow weights ended at γ ≈ 6 and 0.66' test RMS where trainlm
reaches 0.39'; started from 200 trainlm epochs, trainbr kept γ ≈ 40 and
0.43', and a 1:30:1 network 0.195' (trainlm: 0.21'). The paper's ``raw``
1:80:1 network is not affected (0.18' test RMS with trainbr).
"""

import numpy as np
from scipy.linalg import solve_triangular

from ._registry import register_algorithm
from .trainlm import MU_FLOOR, check_mu_options, damped_system, sum_of_squares

__all__ = ["trainbr", "effective_parameters"]


def effective_parameters(system, beta, alpha):
    """MacKay's γ = N_w − α·tr((βJᵀJ + αI)⁻¹) for the Jacobian of ``system``.

    ``JᵀJ`` and ``JJᵀ`` share their non-zero eigenvalues λ, so with the
    k × k Gram matrix G of :class:`DampedGaussNewton` (k = min(m, n)),
    ``γ = k − α·tr((βG + αI)⁻¹) = Σ βλ / (βλ + α)``.
    """
    k = system.gram.shape[0]
    factor = system.factor(beta, alpha)
    if factor is None:
        scaled = beta * np.clip(np.linalg.eigvalsh(system.gram), 0.0, None)
        ratio = np.divide(scaled, scaled + alpha, out=np.zeros_like(scaled), where=scaled + alpha > 0)
        return float(np.sum(ratio))
    lower = np.tril(factor)
    inverse = solve_triangular(lower, np.eye(k), lower=True, check_finite=False)
    # tr(A⁻¹) = ||L⁻¹||_F² for A = L Lᵀ
    return float(k - alpha * np.sum(inverse * inverse))


@register_algorithm("trainbr")
def trainbr(problem, x0, monitor, *, mu=0.005, mu_dec=0.1, mu_inc=10.0, mu_max=1e10):
    """Bayesian-regularisation back end (see the module docstring)."""
    mu, mu_dec, mu_inc, mu_max = check_mu_options("trainbr", mu, mu_dec, mu_inc, mu_max)
    m, n = problem.n_samples, problem.n_params
    x = x0
    e, J = problem.residuals_and_jacobian(x)
    sse, ssw = float(e @ e), float(x @ x)
    gamma = float(n)
    alpha = gamma / (2.0 * ssw) if ssw > 0 else 1.0
    beta = (m - gamma) / (2.0 * sse) if sse > 0 else 1.0
    if beta <= 0:
        beta = 1.0

    def report(x, e, J):
        for name, value in (("mu", mu), ("gamma", gamma), ("alpha", alpha), ("beta", beta)):
            monitor.record(name, value)
        return (2.0 / m) * (J.T @ e + (alpha / beta) * x)

    if monitor.start(x, sse / m, report(x, e, J)):
        return x
    while True:
        performance = beta * sse + alpha * ssw
        system = damped_system(problem, x, J, e)
        while True:
            dx = system.step(mu, beta, alpha, x)
            if dx is not None:
                trial = x + dx
                trial_sse = sum_of_squares(problem, trial)
                trial_ssw = float(trial @ trial)
                if beta * trial_sse + alpha * trial_ssw < performance:
                    break
            mu *= mu_inc
            if mu > mu_max:
                monitor.stop("mu_max")
                return x
        mu = max(mu * mu_dec, MU_FLOOR)
        gamma = effective_parameters(system, beta, alpha)
        x, sse, ssw = trial, trial_sse, trial_ssw
        alpha = gamma / (2.0 * ssw) if ssw > 0 else 1.0
        if sse > 0 and gamma < m:
            beta = (m - gamma) / (2.0 * sse)
        e, J = problem.residuals_and_jacobian(x)
        if monitor.update(x, sse / m, report(x, e, J)):
            return x

"""Bayesian regularisation: Levenberg-Marquardt with MacKay's evidence rules, after MATLAB's ``trainbr``.

Levenberg-Marquardt on ``F = β·E_D + α·E_W``, with ``E_D = Σe²`` the sum of
squared (normalised) residuals and ``E_W = ΣX²`` the sum of squared weights.
After every accepted step the hyper-parameters are re-estimated at the
accepted weights by MacKay's evidence rules, with the Gauss-Newton Hessian
``H = 2βJᵀJ + 2αI`` of the Jacobian there and the α, β that took the step:

- effective number of parameters ``γ = N_w − 2α·tr(H⁻¹)``,
- ``α = γ / (2 E_W)``, ``β = (N − γ) / (2 E_D)`` (N residuals, N_w weights;
  β is kept while ``γ >= N``).

MacKay, D. J. C. (1992), "Bayesian interpolation", Neural Computation 4(3),
415-447; Foresee, F. D. and Hagan, M. T. (1997), "Gauss-Newton approximation
to Bayesian learning", Proc. ICNN, vol. 3, pp. 1930-1935.

Defaults are MATLAB's: ``mu=0.005``, ``mu_dec=0.1``, ``mu_inc=10``,
``mu_max=1e10``, ``epochs=1000``, ``min_grad=1e-7``. The start is Foresee and
Hagan's: ``α = 0``, ``β = 1``, so the first step is plain Levenberg-Marquardt,
and the first re-estimate (α = 0) has ``γ = rank J`` (N_w when N > N_w).
Recorded per epoch: ``'mu'``, ``'gamma'``, ``'alpha'``, ``'beta'``.

Against MATLAB's ``trainbr.m``, measured:

- ``trainbr.m`` starts from ``γ = N_w``, ``α = γ / (2 E_W)``,
  ``β = (N − γ) / (2 E_D)`` at the initial weights. There E_D is the misfit of
  an untrained network, not noise (demo encoder 1, periodic 1:12:1: 467, against
  2.5-7 at the end), so α/β = 0.44 and the first step shrinks E_W from 397 to 6.
- Older ``trainbr.m`` releases, and earlier versions of this module, took γ
  from the Jacobian at the start of the epoch but E_W and E_D from the
  accepted weights. After a step that shrinks the weights, that γ is too
  large for the new E_W, so α is too large and the next step shrinks them
  further: a loop that can end at a constant output (γ ≈ 1, α → ∞). The
  current ``trainbr.m`` takes the Jacobian at the accepted weights, as here.

Both together, on ``17 sin 4θ + 11.5 sin 2θ + 1.8 sin θ`` arcmin with 2' noise
at 200 points (periodic 1:12:1, ``tests/training/test_trainbr.py``), the old start and
order ended at a constant for 14 seeds of 200, these for none; on a real
AS5047D calibration (``mech_jcchurch_2016-11-23_0p9deg``, trained on the even
rows, 1:12:1) for 5 seeds of 30 (test RMS 14.75' instead of 2.19'), these
for none.

Reported to the monitor: the data mean squared error ``E_D / N`` (what
``goal`` tests) and the gradient of ``F / (β N)``, ``2 (Jᵀe + (α/β) X) / N``
(what ``min_grad`` tests; it vanishes at the regularised minimum; MATLAB tests
the data gradient ``2 ||Jᵀe|| / N``, which does not, so its trainbr stops at
``epochs`` or ``mu_max``). Unlike MATLAB (whose ``trainbr`` sets
``max_fail = 0``), a validation problem, when given, stops training after
``max_fail`` failures as for any algorithm.

Limitations, measured
---------------------
A collapse the evidence prefers. On the demo encoders (``demo_fleet()``) a
``periodic`` network from Nguyen-Widrow weights still ends, at 38 of 40 runs
(1:12:1 and 1:30:1, seeds 0-4), with two active hidden units (γ = 6-10) that
follow harmonics 0-4 and miss the slot harmonics 14, 16, 32 and 48: test RMS
0.41-0.93' where trainlm reaches 0.30-0.50' (1:12:1) and 0.18-0.24' (1:30:1).
This is not a trap of the iteration: the log evidence (Gauss-Newton Laplace
approximation) of that network is 60-290 nats higher than that of the
networks trainbr keeps when started from 200 trainlm epochs (γ = 35-100, test
RMS 0.19-0.40'); with one α per weight group (input weights, hidden biases,
output layer) instead of one α, still 45-85 nats higher (1:12:1). A tanh unit
of (cos θ, sin θ) carries harmonic k only when its input weights are about k
or more; under a Gaussian prior each of the 35-100 well-determined parameters
of such sharp units costs 4-5 nats of Occam factor, more than the likelihood
gains from the smaller residual, which the evidence takes for white noise
(here it is the unmodelled slot harmonics). When the evidence and the test error disagree,
the prior does not suit the data (MacKay 1992): for such profiles fit the slot
orders with a Fourier part (``fit_hybrid``) or use trainlm with a validation
set. The paper's ``raw`` 1:80:1 network is not affected only because its
Nguyen-Widrow input weights are about 112: E_W starts at 1.3e6, α near 1e-4,
and in 1000 epochs E_W falls only to 1e5, so the network stays near the data
fit (test RMS 0.18-0.20', γ = 113-136), far from the evidence's fixed point.

A trap that remains. On the hybrid's residual of a 4° bump
(``docs/model-selection.md``) a 1:8:1 or 1:12:1 network still ends at a
constant from 32 of 40 starts (before: 40), although a fitted network has the
higher evidence (91 against 10 nats at 1:8:1, one start). Holding α = 0 until a
plain step lowers F by less than 1 %, so that α, β are first estimated near a
minimum (where MacKay's rules hold), measured 8 of 40, and gave the fitted
network in 7 of 12 demo runs (1:12:1, seeds 0-2); it is not done here because
it departs further from ``trainbr.m`` and adds a tuning constant.
"""

import functools

import numpy as np
from scipy.linalg.lapack import dtrtrs

from ._registry import register_algorithm
from .trainlm import MU_FLOOR, check_mu_options, damped_system, sum_of_squares

__all__ = ["trainbr", "effective_parameters"]


def effective_parameters(system, beta, alpha):
    """MacKay's γ = N_w − α·tr((βJᵀJ + αI)⁻¹) for the Jacobian of ``system``.

    ``JᵀJ`` and ``JJᵀ`` share their non-zero eigenvalues λ, so with the
    k × k Gram matrix G of :class:`DampedGaussNewton` (k = min(m, n)),
    ``γ = k − α·tr((βG + αI)⁻¹) = Σ βλ / (βλ + α)``; for ``α = 0``, the
    number of non-zero λ (the rank of J).
    """
    k = system.gram.shape[0]
    factor = system.factor(beta, alpha)
    if factor is None:
        scaled = beta * np.clip(np.linalg.eigvalsh(system.gram), 0.0, None)
        ratio = np.divide(scaled, scaled + alpha, out=np.zeros_like(scaled), where=scaled + alpha > 0)
        return float(np.sum(ratio))
    # tr(A⁻¹) = ||L⁻¹||_F² for A = L Lᵀ. L⁻¹ = (Lᵀ)⁻ᵀ from LAPACK's triangular solve with Lᵀ (upper,
    # transposed), which reads only the triangle that holds L: the C-ordered copy of the factor is
    # Lᵀ in Fortran order, and no zeroing of the other triangle is needed.
    upper = np.ascontiguousarray(factor).T
    inverse, info = dtrtrs(upper, _identity(k), lower=0, trans=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"singular Cholesky factor: zero at diagonal {info - 1}")
    return float(k - alpha * np.sum(inverse * inverse))


@functools.lru_cache(maxsize=4)
def _identity(k):
    """The k × k identity, made once per size (read only: trtrs copies its right-hand side)."""
    identity = np.eye(k)
    identity.flags.writeable = False
    return identity


@register_algorithm("trainbr")
def trainbr(problem, x0, monitor, *, mu=0.005, mu_dec=0.1, mu_inc=10.0, mu_max=1e10):
    """Bayesian-regularisation back end (see the module docstring)."""
    mu, mu_dec, mu_inc, mu_max = check_mu_options("trainbr", mu, mu_dec, mu_inc, mu_max)
    m, n = problem.n_samples, problem.n_params
    x = x0
    e, J = problem.residuals_and_jacobian(x)
    sse, ssw = float(e @ e), float(x @ x)
    # Foresee & Hagan's start: the first step is plain Levenberg-Marquardt.
    gamma, alpha, beta = float(n), 0.0, 1.0

    def report(x, e, J):
        for name, value in (("mu", mu), ("gamma", gamma), ("alpha", alpha), ("beta", beta)):
            monitor.record(name, value)
        return (2.0 / m) * (J.T @ e + (alpha / beta) * x)

    if monitor.start(x, sse / m, report(x, e, J)):
        return x
    system = damped_system(problem, x, J, e)
    while True:
        performance = beta * sse + alpha * ssw
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
        x, sse, ssw = trial, trial_sse, trial_ssw
        e, J = problem.residuals_and_jacobian(x)
        system = damped_system(problem, x, J, e)
        # γ, E_W and E_D all at the accepted weights (γ with the α, β of the step).
        gamma = effective_parameters(system, beta, alpha)
        alpha = gamma / (2.0 * ssw) if ssw > 0 else 1.0
        if sse > 0 and gamma < m:
            beta = (m - gamma) / (2.0 * sse)
        if monitor.update(x, sse / m, report(x, e, J)):
            return x

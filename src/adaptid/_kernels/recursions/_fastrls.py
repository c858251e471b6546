r"""Fast RLS on a tapped delay line: the stabilised fast transversal filter (FTF).

Not an entry of the common signature (the regressor is not a row of Φ but the
last n samples of one input u), so :class:`adaptid.FastRLS` calls these kernels
directly. One compiled call runs a whole record.

State of one stream, ``S`` of length ``5n + 3``::

    S = [ theta (n) | w_f (n) | w_b (n) | kt (n) | x (n) | alpha | beta | gamma ]

``theta`` the transversal filter, ``w_f`` / ``w_b`` the forward / backward
predictors of order n, ``kt`` the a-priori gain :math:`\tilde k_k =
\lambda^{-1}P_{k-1}\varphi_k`, ``x`` the delay line
:math:`\varphi_k = [u_k, u_{k-1}, \dots, u_{k-n+1}]` (prewindowed: zeros
before the first sample), ``alpha`` / ``beta`` the forward / backward
prediction-error energies and ``gamma`` the conversion factor
:math:`\gamma_k = 1/(1 + \varphi_k^T\tilde k_k)`.

``opt = [lambda, delta, K1, K2, K3, direct_gamma, gamma_tol]``: the forgetting
factor, the soft-start constant (used by a rescue), the error-feedback gains
of Slock & Kailath (1991) and whether γ is recomputed from the gain
(``1.0``, the stabilised filter) or carried by its order recursion
(``0.0``; with K1 = K2 = K3 = 0 that is the unstabilised 7N FTF of Cioffi &
Kailath, 1984, kept for the stability benchmark only). A rescue happens when
γ leaves (0, 1 + gamma_tol], an energy is not positive or a value not finite.

Per sample, with the extended gain of order n + 1 (Slock & Kailath 1991,
Table I; Diniz, *Adaptive Filtering*, Algorithm 8.2):

.. math::

    e^f &= u_k - w_f^T\varphi_{k-1},\quad
    \tilde k^{(n+1)} = \begin{bmatrix}0\\ \tilde k_{k-1}\end{bmatrix}
      + \frac{e^f}{\lambda\alpha}\begin{bmatrix}1\\ -w_f\end{bmatrix},\quad
    \alpha \leftarrow \lambda\alpha + \gamma_{k-1}(e^f)^2,\quad
    w_f \leftarrow w_f + \gamma_{k-1}e^f\,\tilde k_{k-1},\\
    e^b_s &= u_{k-n} - w_b^T\varphi_k,\quad e^b_f = \lambda\beta\,m,\quad
    e^b_{(j)} = K_j e^b_s + (1 - K_j)e^b_f,\quad
    m = \tilde k^{(n+1)}_{n},\\
    \tilde k_k &= \tilde k^{(n+1)}_{0:n} + m\,w_b,\quad
    \gamma' = \big(\gamma^{-1}_{n+1} - m e^b_{(3)}\big)^{-1},\quad
    \beta \leftarrow \lambda\beta + \gamma'(e^b_{(2)})^2,\quad
    w_b \leftarrow w_b + \gamma' e^b_{(1)}\tilde k_k,\\
    \gamma_k &= 1/(1 + \varphi_k^T\tilde k_k),\quad
    \varepsilon_k = y_k - \theta^T\varphi_k,\quad
    \theta \leftarrow \theta + \gamma_k\varepsilon_k\tilde k_k .
"""

import numpy as np
from numba import prange

from ..._config import NJIT, NJIT_INLINE, NJIT_PARALLEL, njit


@njit(**NJIT_INLINE)
def _dot(S, a, b, n):
    """Σᵢ S[a + i] S[b + i]; for n ≥ 8 in four interleaved partial sums.

    The dot products are the latency-bound chains of the FTF (one FMA after
    the other); four chains let them overlap (``benchmarks/bench_fastrls.py``).
    The sum differs from the sequential one by rounding only.
    """
    if n < 8:
        s = 0.0
        for i in range(n):
            s += S[a + i] * S[b + i]
        return s
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    s3 = 0.0
    m = n - n % 4
    for i in range(0, m, 4):
        s0 += S[a + i] * S[b + i]
        s1 += S[a + i + 1] * S[b + i + 1]
        s2 += S[a + i + 2] * S[b + i + 2]
        s3 += S[a + i + 3] * S[b + i + 3]
    for i in range(m, n):
        s0 += S[a + i] * S[b + i]
    return (s0 + s1) + (s2 + s3)


@njit(**NJIT_INLINE)
def _predictors(S, n, uk, q, opt):
    """Order-n forward/backward update with u_k; shifts u_k into the line.

    Leaves the new gain in S's kt, returns False when the rescue test fails.
    """
    lam = opt[0]
    wf, wb, kt, x = n, 2 * n, 3 * n, 4 * n
    alpha, beta, gamma = S[5 * n], S[5 * n + 1], S[5 * n + 2]
    ef = uk - _dot(S, wf, x, n)
    epsf = gamma * ef
    g0 = ef / (lam * alpha)
    q[0] = g0
    for i in range(n):
        q[i + 1] = S[kt + i] - g0 * S[wf + i]
        S[wf + i] += S[kt + i] * epsf
    alpha = lam * alpha + ef * epsf
    ginv1 = 1.0 / gamma + g0 * ef
    m = q[n]
    ub = S[x + n - 1]
    for i in range(n - 1, 0, -1):  # the line becomes φ_k
        S[x + i] = S[x + i - 1]
    S[x] = uk
    ebs = ub - _dot(S, wb, x, n)
    ebf = lam * beta * m
    eb1 = opt[2] * ebs + (1.0 - opt[2]) * ebf
    eb2 = opt[3] * ebs + (1.0 - opt[3]) * ebf
    eb3 = opt[4] * ebs + (1.0 - opt[4]) * ebf
    gam2 = 1.0 / (ginv1 - m * eb3)
    beta = lam * beta + gam2 * eb2 * eb2
    c = gam2 * eb1
    for i in range(n):
        k = q[i] + m * S[wb + i]
        S[kt + i] = k
        S[wb + i] += k * c
    s = _dot(S, kt, x, n)
    gamma = 1.0 / (1.0 + s) if opt[5] != 0.0 else gam2
    S[5 * n], S[5 * n + 1], S[5 * n + 2] = alpha, beta, gamma
    return (alpha > 0.0 and beta > 0.0 and gamma > 0.0 and gamma <= 1.0 + opt[6]
            and gam2 > 0.0 and np.isfinite(alpha + beta + gamma + s))


@njit(**NJIT)
def _rescue(S, n, opt, q, keep):
    """Restart the predictors at the soft start n samples ago; θ stays.

    The delay line φ_k is kept aside, the predictors set to the soft start of
    a zero line (w_f = w_b = 0, kt = 0, γ = 1, α = max(δ, mean square of φ_k),
    β = αλ⁻ⁿ) and the n inputs of φ_k fed again, oldest first: the predictors,
    the gain and γ are then those of exact least squares on these n inputs
    (prewindowed before them), consistent with the line, in O(n²) once
    (Cioffi & Kailath 1984, sect. V, restart with the stored data).
    """
    p = 0.0
    for i in range(n):
        keep[i] = S[4 * n + i]
        p += keep[i] * keep[i]
        S[n + i] = 0.0
        S[2 * n + i] = 0.0
        S[3 * n + i] = 0.0
        S[4 * n + i] = 0.0
    a = max(opt[1], p / n)
    S[5 * n] = a
    S[5 * n + 1] = a * opt[0] ** (-n)
    S[5 * n + 2] = 1.0
    for i in range(n - 1, -1, -1):
        _predictors(S, n, keep[i], q, opt)


@njit(**NJIT)
def ftf_run(S, u, y, opt, Th, E, skipped):
    """Run the stabilised FTF over u, y (length N) from state S (updated in place).

    ``Th`` (N, n) receives θ after every sample (or has 0 rows: not stored),
    ``E`` the a-priori errors (NaN where skipped), ``skipped`` the samples
    with a non-finite u or y (state untouched). Returns the number of rescues.
    """
    n = (S.shape[0] - 3) // 5
    q = np.empty(n + 1)
    keep = np.empty(n)
    rescues = 0
    store = Th.shape[0] > 0
    x = 4 * n
    for k in range(u.shape[0]):
        uk, yk = u[k], y[k]
        if not (np.isfinite(uk) and np.isfinite(yk)):
            skipped[k] = True
            E[k] = np.nan
        else:
            skipped[k] = False
            if not _predictors(S, n, uk, q, opt):
                _rescue(S, n, opt, q, keep)
                rescues += 1
            e = yk - _dot(S, 0, x, n)
            E[k] = e
            c = S[5 * n + 2] * e
            for i in range(n):
                S[i] += S[3 * n + i] * c
        if store:
            for i in range(n):
                Th[k, i] = S[i]
    return rescues


@njit(**NJIT_PARALLEL)
def ftf_run_batched(S, U, Y, opt, Th, E, skipped, rescues):
    """B independent streams of :func:`ftf_run` in parallel (leading axis B)."""
    for b in prange(U.shape[0]):
        rescues[b] = ftf_run(S[b], U[b], Y[b], opt, Th[b], E[b], skipped[b])


# The QR lattice lives in ._fastlattice (the 400-line rule of the kernels);
# adaptid.FastRLS reaches both methods through this module.
from ._fastlattice import lattice_run, lattice_run_batched  # noqa: E402,F401

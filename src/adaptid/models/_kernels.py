r"""Compiled recursive pseudo-linear regression (RELS for ARMAX, PLR for OE).

The regressor of sample k holds fixed columns (lagged measured signals,
precomputed) followed by ``nd`` lags of a signal v that the recursion itself
produces from the estimates (ARMAX: the a-posteriori residuals; OE: the
a-posteriori simulated output), so the loop cannot be split into "build Φ"
then "run an estimator": it is one compiled pass. No validation here.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["pseudolinear_run"]


@njit(cache=True, nogil=True)
def pseudolinear_run(Phi_fix, Y, nd, alpha, beta, sgn, theta, P, lam, Q, r2, M,
                     Th, E, V):
    r"""Recursive pseudo-linear regression in covariance form.

    Per sample k (``phi`` = fixed columns, then ``sgn * v[k-1..k-nd]``):

    .. math::

        \varepsilon_k = y_k - \varphi_k^T\theta,\quad
        K = \frac{P\varphi_k}{\lambda r_2 + \varphi_k^T P\varphi_k},\quad
        \theta \leftarrow \theta + K\varepsilon_k,\quad
        P \leftarrow (P - K\varphi_k^T P)/\lambda + Q,

    then, with a window M > 0, the sample k - M is removed with weight
    :math:`\lambda^M` (a rank-one downdate), and finally
    :math:`v_k = \alpha y_k + \beta\varphi_k^T\theta`. P is symmetrised
    after every step. ``theta`` and ``P`` are updated in place; ``Th[k]``,
    ``E[k]``, ``V[k]`` receive θ after sample k, ε_k and v_k.

    Returns the number of window removals refused because they would have
    made P indefinite.
    """
    N, nfix = Phi_fix.shape
    n = nfix + nd
    phi = np.empty(n)
    Pphi = np.empty(n)
    K = np.empty(n)
    vh = np.zeros(max(nd, 1))
    Mb = max(M, 1)
    Bphi = np.zeros((Mb, n))
    By = np.zeros(Mb)
    cM = lam ** M
    refused = 0
    for k in range(N):
        for j in range(nfix):
            phi[j] = Phi_fix[k, j]
        for j in range(nd):
            phi[nfix + j] = sgn * vh[j]
        e = Y[k]
        for j in range(n):
            e -= phi[j] * theta[j]
        E[k] = e
        # measurement update (with forgetting) and time update
        s = lam * r2
        for i in range(n):
            acc = 0.0
            for j in range(n):
                acc += P[i, j] * phi[j]
            Pphi[i] = acc
            s += phi[i] * acc
        for i in range(n):
            K[i] = Pphi[i] / s
            theta[i] += K[i] * e
        for i in range(n):
            for j in range(i, n):
                pij = (P[i, j] - K[i] * Pphi[j]) / lam + Q[i, j]
                pji = (P[j, i] - K[j] * Pphi[i]) / lam + Q[j, i]
                P[i, j] = 0.5 * (pij + pji)
                P[j, i] = P[i, j]
        # sliding window: remove the sample that leaves it
        if M > 0:
            slot = k % M
            if k >= M:
                eo = By[slot]
                so = -1.0 / cM
                for i in range(n):
                    acc = 0.0
                    for j in range(n):
                        acc += P[i, j] * Bphi[slot, j]
                    Pphi[i] = acc
                    so += Bphi[slot, i] * acc
                    eo -= Bphi[slot, i] * theta[i]
                if so < 0.0:
                    for i in range(n):
                        K[i] = Pphi[i] / so
                        theta[i] += K[i] * eo
                    for i in range(n):
                        for j in range(i, n):
                            pij = P[i, j] - K[i] * Pphi[j]
                            pji = P[j, i] - K[j] * Pphi[i]
                            P[i, j] = 0.5 * (pij + pji)
                            P[j, i] = P[i, j]
                else:
                    refused += 1
            for j in range(n):
                Bphi[slot, j] = phi[j]
            By[slot] = Y[k]
        # the signal the next regressors need
        yhat = 0.0
        for j in range(n):
            yhat += phi[j] * theta[j]
            Th[k, j] = theta[j]
        v = alpha * Y[k] + beta * yhat
        V[k] = v
        for j in range(nd - 1, 0, -1):
            vh[j] = vh[j - 1]
        if nd > 0:
            vh[0] = v
    return refused

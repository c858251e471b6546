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

from .._config import NJIT
from .._kernels._ud import _bierman_apply, _bierman_prep, _strategy_step, _time_update

__all__ = ["pseudolinear_run"]


@njit(**NJIT)
def pseudolinear_run(Phi_fix, Y, col_group, dyn_group, dyn_lag, alpha, beta, sgn, theta,
                     U, D, lam, Q, kalman, r2, M, rtol, mode, fp, pmax, Th, E, V, Lk):
    r"""Recursive pseudo-linear regression on the U-D factors of P.

    The regressor of sample k is the fixed columns ``Phi_fix[k]`` followed
    by ``nd`` dynamic ones: column j is ``sgn * v_g[k - l]`` with
    ``g = dyn_group[j]``, ``l = dyn_lag[j]``, where the G signals
    :math:`v_{g,k} = \alpha y_k + \beta\sum_{i:\,\text{col\_group}[i]=g}
    \varphi_{k,i}\theta_i` are formed after the update of sample k (ARMAX:
    one group of all columns, the a-posteriori residual; OE: one group per
    input, that input's simulated output). Per sample:

    .. math::

        \varepsilon_k = y_k - \varphi_k^T\theta,\quad
        K = \frac{P\varphi_k}{\lambda r_2 + \varphi_k^T P\varphi_k},\quad
        \theta \leftarrow \theta + K\varepsilon_k,\quad
        P \leftarrow (P - K\varphi_k^T P)/\lambda + Q,

    done as the core estimators do it (:mod:`adaptid._kernels._ud`):
    ``D ← D/λ``, a Bierman update with weight r₂, and for the Kalman
    recursion (``kalman``) the time update ``P + Q`` re-factorised. With a
    window M > 0 the sample k − M is then removed with weight
    :math:`c = \lambda^M` (Bierman with weight −1/c), unless
    :math:`1 - c\,\varphi^T P\varphi <` ``rtol`` (the removal would make P
    indefinite or nearly so): then it is refused and counted. With
    ``mode >= 0`` the measurement update is instead the step of an
    :mod:`adaptid.forgetting` strategy (or of ``P_max``), exactly as in
    :class:`adaptid.RLS` (``_strategy_step``), and ``Lk[k]`` receives the λₖ
    it applied. Finally
    the signals :math:`v_{g,k}` are formed. ``theta``, ``U`` (unit upper
    triangular) and ``D`` are updated in place; ``Th[k]``, ``E[k]``,
    ``V[k, g]`` receive θ after sample k, ε_k and :math:`v_{g,k}`.

    Returns the number of window removals refused, or −1 if the time update
    lost positive definiteness.
    """
    N, nfix = Phi_fix.shape
    nd = dyn_group.shape[0]
    n = nfix + nd
    G = V.shape[1]
    L = 1
    for j in range(nd):
        L = max(L, dyn_lag[j])
    phi = np.empty(n)
    f = np.empty(n)
    v = np.empty(n)
    b = np.empty(n)
    W = np.empty((n, n))
    Pm = np.empty((n, n))
    theta2 = theta.reshape((n, 1))
    ek = np.empty(1)
    yk = np.empty(1)
    vh = np.zeros((G, L))  # vh[g, l - 1] = v_g[k - l]
    vg = np.empty(G)
    Mb = max(M, 1)
    Bphi = np.zeros((Mb, n))
    By = np.zeros(Mb)
    cM = lam ** M
    il = 1.0 / lam
    refused = 0
    for k in range(N):
        for j in range(nfix):
            phi[j] = Phi_fix[k, j]
        for j in range(nd):
            phi[nfix + j] = sgn * vh[dyn_group[j], dyn_lag[j] - 1]
        e = Y[k]
        for j in range(n):
            e -= phi[j] * theta[j]
        E[k] = e
        if mode >= 0:
            ek[0] = e
            yk[0] = Y[k]
            Lk[k] = _strategy_step(theta2, U, D, phi, yk, ek, 1.0, lam, mode, fp, pmax,
                                   f, v, b, Pm, W, n, 1)
        else:
            if lam != 1.0:
                for i in range(n):
                    D[i] *= il
            _bierman_prep(U, D, phi, f, v, n)
            a = _bierman_apply(U, D, r2, f, v, b, n)
            g = e / a
            for i in range(n):
                theta[i] += b[i] * g
            Lk[k] = lam
        if kalman and not _time_update(U, D, Q, W, n):
            return -1
        if M > 0:
            slot = k % M
            if k >= M:
                q = _bierman_prep(U, D, Bphi[slot], f, v, n)
                if 1.0 - cM * q < rtol:
                    refused += 1
                else:
                    eo = By[slot]
                    for i in range(n):
                        eo -= Bphi[slot, i] * theta[i]
                    a = _bierman_apply(U, D, -1.0 / cM, f, v, b, n)
                    g = eo / a
                    for i in range(n):
                        theta[i] += b[i] * g
            for j in range(n):
                Bphi[slot, j] = phi[j]
            By[slot] = Y[k]
        for g in range(G):
            vg[g] = 0.0
        for j in range(n):
            vg[col_group[j]] += phi[j] * theta[j]
            Th[k, j] = theta[j]
        for g in range(G):
            vk = alpha * Y[k] + beta * vg[g]
            V[k, g] = vk
            for lag in range(L - 1, 0, -1):
                vh[g, lag] = vh[g, lag - 1]
            vh[g, 0] = vk
    return refused

r"""Compiled pseudo-linear regression that resumes: the streaming ARMAX / OE / BJ.

The loop of :func:`._pseudolinear.pseudolinear_run` (RELS for ARMAX and
ARMA, PLR for OE and BJ), with every piece of its state passed in and
updated in place, so that a record processed in pieces (one sample per
call, or any split) gives the same numbers bit for bit as one call over the
whole record: θ and the U-D factors of P, the lag history ``vh`` of the
signals the recursion forms, the window's buffer of the regressors used and
the diffuse state, and the number ``k0`` of recursion steps made before.
The arithmetic of a sample is that of ``pseudolinear_run`` (the same inline
helpers, in the same order), so over the rows of a batch model's
regression the estimates equal its ``fit_recursive`` bit for bit.

Two more algorithms that ``pseudolinear_run`` does not have (no P): the
gradient (``grad = 1``) and normalised gradient (``grad = 2``) updates
:math:`\theta \mathrel{+}= \mu\varphi_k\varepsilon_k` and
:math:`\theta \mathrel{+}= \mu\varphi_k\varepsilon_k/(\beta + \varphi_k^T\varphi_k)`,
in the order of operations of the core LMS / NLMS kernels
(:mod:`adaptid._kernels.recursions._lms`). No validation here.
"""

from __future__ import annotations

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit
from ..recursions._bierman import _time_update
from ._pseudolinear import _diffuse_step, _measure, _signals_step, _window_step

__all__ = ["plr_stream"]


@njit(**NJIT_INLINE)
def _gradient(theta, phi, e, grad, mu, beta, n):
    """One (normalised) gradient step."""
    g = mu
    if grad == 2:
        q = beta
        for j in range(n):
            q += phi[j] * phi[j]
        g = g / q if q > 0.0 else 0.0
    for i in range(n):
        gi = g * phi[i]
        theta[i] += gi * e


@njit(**NJIT)
def plr_stream(Phi_fix, Y, alpha, mix, dyn_group, dyn_lag, dyn_sgn, theta, U, D, vh,
               Bphi, By, theta_s, U_s, D_s, dif, k0, lam, Q, kalman, r2, M, rtol, mode, fp,
               pmax, dtol, grad, mu, beta, Th, E, Yh, V, Lk, Ik):
    r"""Samples k0 … k0 + N − 1 of the recursion of ``pseudolinear_run``, resumable.

    Per sample (``Phi_fix[i]`` the fixed columns, the dynamic ones
    ``dyn_sgn[j] * vh[dyn_group[j], dyn_lag[j] - 1]``):

    .. math::

        \hat y_k = \varphi_k^T\theta,\quad
        \varepsilon_k = y_k - \varphi_k^T\theta,\quad
        \theta \leftarrow \theta + K\varepsilon_k\ \text{(or a gradient step)},\quad
        v_{g,k} = \alpha_g y_k + \textstyle\sum_i \text{mix}_{g,i}\varphi_{k,i}\theta_i .

    In/out: θ (n), U (n, n), D (n), ``vh`` (G, L) the signals' lags
    (``vh[g, l - 1]`` = v_g[k − l]), ``Bphi`` (max(M, 1), n), ``By``
    (max(M, 1)) the window buffer (slot k mod M), ``dif`` the diffuse state
    (empty: none). ``theta_s``, ``U_s``, ``D_s``: the prior a window
    re-solve starts from. Out: ``Th`` (N, n), ``E``, ``Yh`` (N), ``V``
    (N, G), ``Lk`` (N) the λₖ applied, ``Ik`` (N) the identified flag.
    Options as ``pseudolinear_run``; ``grad`` 0 (P-based), 1 (gradient),
    2 (normalised gradient) with gain ``mu`` and bias ``beta``.

    Returns the number of window re-solves, or −1 if the Kalman time update
    lost positive definiteness (the state then holds the sample that failed).
    """
    N, nfix = Phi_fix.shape
    nd = dyn_group.shape[0]
    n = nfix + nd
    L = vh.shape[1]
    phi = np.empty(n)
    f = np.empty(n)
    v = np.empty(n)
    b = np.empty(n)
    W = np.empty((n, n))
    Pm = np.empty((n, n))
    theta2 = theta.reshape((n, 1))
    ek = np.empty(1)
    yk = np.empty(1)
    cM = lam ** M
    il = 1.0 / lam
    logl = np.log(lam)
    rebuilds = 0
    diffuse = dif.shape[0] > 0
    for i in range(N):
        k = k0 + i
        for j in range(nfix):
            phi[j] = Phi_fix[i, j]
        for j in range(nd):
            phi[nfix + j] = dyn_sgn[j] * vh[dyn_group[j], dyn_lag[j] - 1]
        e = Y[i]
        for j in range(n):
            e -= phi[j] * theta[j]
        yh = 0.0
        for j in range(n):
            yh += phi[j] * theta[j]
        Yh[i] = yh
        E[i] = e
        ek[0] = e
        yk[0] = Y[i]
        if grad > 0:
            _gradient(theta, phi, e, grad, mu, beta, n)
            Lk[i] = 1.0
        elif diffuse and dif[0] == 0.0:
            if not _diffuse_step(dif, theta2, U, D, phi, yk, ek, k, lam, r2, Q, kalman, M,
                                 Bphi, By, dtol, W, n):
                return -1
            Lk[i] = lam
        else:
            Lk[i] = _measure(theta, theta2, U, D, phi, yk, ek, e, lam, il, r2, mode, fp, pmax,
                             f, v, b, Pm, W, n)
            if kalman and not _time_update(U, D, Q, W, n):
                return -1
            if M > 0 and _window_step(theta, U, D, theta_s, U_s, D_s, phi, Y[i], Bphi, By, k,
                                      M, lam, cM, logl, rtol, f, v, b, n, dif, dtol):
                rebuilds += 1
        Ik[i] = dif[0] if diffuse else 1.0
        for j in range(n):
            Th[i, j] = theta[j]
        _signals_step(alpha, mix, phi, theta, Y[i], V[i], vh, n, L)
    return rebuilds
